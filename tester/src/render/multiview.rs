//! What [`Program::Multiview`] binds: the views' uniform buffer (each view's P * V,
//! [`Scene::views_block`]) in one descriptor set of the vertex stage, and the pipeline layout
//! of that set with the 80 bytes of push constants of the plain layout (the model matrix and
//! the color).

use anyhow::{Context, Result};
use ash::vk;

use super::{bindings::single_descriptor_set, PUSH_CONSTANT_RANGES};
use crate::gpu::{Gpu, HostBuffer};
use crate::scene::Scene;

/// The views' buffer, its set, and the layout of the multiview pipelines. The host writes the
/// buffer once, before recording.
pub(super) struct MultiviewBindings<'a> {
    set_layout: vk::DescriptorSetLayout,
    pool: vk::DescriptorPool,
    /// Binding 0: the views' uniform buffer.
    pub(super) set: vk::DescriptorSet,
    /// The set and the plain layout's push-constant range.
    pub(super) layout: vk::PipelineLayout,
    views: HostBuffer<'a>,
}

impl<'a> MultiviewBindings<'a> {
    /// Creates the views' buffer of `scene` rendered at `aspect`, its set and the layout.
    pub(super) fn new(gpu: &'a Gpu, scene: &Scene, aspect: f64) -> Result<Self> {
        let device = &gpu.device;
        let bytes = scene.views_block(aspect);
        let mut views = HostBuffer::new(gpu, bytes.len(), vk::BufferUsageFlags::UNIFORM_BUFFER)
            .context("the views' uniform buffer")?;
        views.write(&bytes);
        let mut this = MultiviewBindings {
            set_layout: vk::DescriptorSetLayout::null(),
            pool: vk::DescriptorPool::null(),
            set: vk::DescriptorSet::null(),
            layout: vk::PipelineLayout::null(),
            views,
        };
        let bindings = [vk::DescriptorSetLayoutBinding::default()
            .binding(0)
            .descriptor_type(vk::DescriptorType::UNIFORM_BUFFER)
            .descriptor_count(1)
            .stage_flags(vk::ShaderStageFlags::VERTEX)];
        let made = single_descriptor_set(
            device,
            &bindings,
            "views",
            &mut this.set_layout,
            &mut this.pool,
        );
        // Whatever was made is destroyed with `this` on an error.
        this.set = match made {
            Ok(set) => set,
            Err(e) => {
                this.destroy(device);
                return Err(e);
            }
        };
        let buffer_info = [vk::DescriptorBufferInfo {
            buffer: this.views.buffer,
            offset: 0,
            range: vk::WHOLE_SIZE,
        }];
        let writes = [vk::WriteDescriptorSet::default()
            .dst_set(this.set)
            .dst_binding(0)
            .descriptor_type(vk::DescriptorType::UNIFORM_BUFFER)
            .buffer_info(&buffer_info)];
        // SAFETY: valid set and buffer; the info matches the binding type.
        unsafe { device.update_descriptor_sets(&writes, &[]) };
        let set_layouts = [this.set_layout];
        let layout_info = vk::PipelineLayoutCreateInfo::default()
            .set_layouts(&set_layouts)
            .push_constant_ranges(&PUSH_CONSTANT_RANGES);
        // SAFETY: valid device and create info.
        match unsafe { device.create_pipeline_layout(&layout_info, None) } {
            Ok(layout) => this.layout = layout,
            Err(e) => {
                this.destroy(device);
                return Err(e).context("vkCreatePipelineLayout (multiview) failed");
            }
        }
        Ok(this)
    }

    /// Destroys the layout, the pool (its set with it) and the set layout (the buffer goes
    /// with `self`).
    pub(super) fn destroy(&self, device: &ash::Device) {
        // SAFETY: handles of `device`, null or unused by pending work; null is a no-op.
        unsafe {
            device.destroy_pipeline_layout(self.layout, None);
            device.destroy_descriptor_pool(self.pool, None);
            device.destroy_descriptor_set_layout(self.set_layout, None);
        }
    }
}
