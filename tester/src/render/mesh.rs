//! What [`Program::Mesh`] binds and pushes: the scene's positions and indices again, in two
//! storage buffers of one descriptor set (`mesh.mesh` fetches each triangle's corners from
//! them), its layout (the set, and one push-constant range for the mesh and fragment stages:
//! the flat program's 80 bytes and the draw's index range), and the draw's workgroup count.

use anyhow::{Context, Result};
use ash::vk;

use crate::gpu::{Gpu, HostBuffer};
use crate::scene::{DrawRange, Scene};

/// The stages of the mesh layout's push-constant range.
pub(super) const MESH_PUSH_STAGES: vk::ShaderStageFlags = vk::ShaderStageFlags::from_raw(
    vk::ShaderStageFlags::MESH_EXT.as_raw() | vk::ShaderStageFlags::FRAGMENT.as_raw(),
);
/// Where the draw's range goes in the push constants: after the MVP and the color.
pub(super) const DRAW_RANGE_OFFSET: u32 = 80;
/// The triangles one workgroup of `mesh.mesh` emits (its `local_size_x`).
const WORKGROUP_TRIANGLES: u32 = 32;

/// The push-constant range of the mesh layout: `{ mat4 mvp; vec4 color; uint first_index;
/// uint triangle_count; int vertex_offset; }`.
pub(super) const MESH_PUSH_CONSTANT_RANGES: [vk::PushConstantRange; 1] = [vk::PushConstantRange {
    stage_flags: MESH_PUSH_STAGES,
    offset: 0,
    size: DRAW_RANGE_OFFSET + 12,
}];

/// The mesh program's buffers, set and layout; destroyed with the renderer
/// ([`MeshBindings::destroy`]).
pub(super) struct MeshBindings<'a> {
    pub layout: vk::PipelineLayout,
    pub set: vk::DescriptorSet,
    /// The set's layout (the mesh shader objects are created with it).
    pub set_layout: vk::DescriptorSetLayout,
    pool: vk::DescriptorPool,
    _positions: HostBuffer<'a>,
    _indices: HostBuffer<'a>,
}

impl<'a> MeshBindings<'a> {
    pub(super) fn new(gpu: &'a Gpu, scene: &Scene) -> Result<MeshBindings<'a>> {
        let device = &gpu.device;
        let geometry = scene.geometry();
        let upload = |bytes: &[u8], what: &str| -> Result<HostBuffer<'a>> {
            let mut buffer =
                HostBuffer::new(gpu, bytes.len(), vk::BufferUsageFlags::STORAGE_BUFFER)
                    .with_context(|| format!("mesh {what} buffer"))?;
            buffer.write(bytes);
            Ok(buffer)
        };
        let positions = upload(&geometry.position_bytes(), "position")?;
        let indices = upload(&geometry.index_bytes(), "index")?;
        let bindings = [0, 1].map(|binding| {
            vk::DescriptorSetLayoutBinding::default()
                .binding(binding)
                .descriptor_type(vk::DescriptorType::STORAGE_BUFFER)
                .descriptor_count(1)
                .stage_flags(vk::ShaderStageFlags::MESH_EXT)
        });
        let set_info = vk::DescriptorSetLayoutCreateInfo::default().bindings(&bindings);
        // SAFETY: a live device; the create infos refer to locals.
        let set_layout = unsafe { device.create_descriptor_set_layout(&set_info, None) }
            .context("vkCreateDescriptorSetLayout (mesh) failed")?;
        let mut this = MeshBindings {
            layout: vk::PipelineLayout::null(),
            set: vk::DescriptorSet::null(),
            set_layout,
            pool: vk::DescriptorPool::null(),
            _positions: positions,
            _indices: indices,
        };
        // From here on a failure destroys what was made (`destroy` skips null handles).
        let made = (|| -> Result<()> {
            let set_layouts = [this.set_layout];
            let layout_info = vk::PipelineLayoutCreateInfo::default()
                .set_layouts(&set_layouts)
                .push_constant_ranges(&MESH_PUSH_CONSTANT_RANGES);
            // SAFETY: as above.
            this.layout = unsafe { device.create_pipeline_layout(&layout_info, None) }
                .context("vkCreatePipelineLayout (mesh) failed")?;
            let sizes = [vk::DescriptorPoolSize {
                ty: vk::DescriptorType::STORAGE_BUFFER,
                descriptor_count: 2,
            }];
            let pool_info = vk::DescriptorPoolCreateInfo::default()
                .max_sets(1)
                .pool_sizes(&sizes);
            // SAFETY: as above.
            this.pool = unsafe { device.create_descriptor_pool(&pool_info, None) }
                .context("vkCreateDescriptorPool (mesh) failed")?;
            let allocate = vk::DescriptorSetAllocateInfo::default()
                .descriptor_pool(this.pool)
                .set_layouts(&set_layouts);
            // SAFETY: one set of a layout the pool has room for.
            this.set = unsafe { device.allocate_descriptor_sets(&allocate) }
                .context("vkAllocateDescriptorSets (mesh) failed")?[0];
            let infos = [&this._positions, &this._indices].map(|buffer| {
                [vk::DescriptorBufferInfo {
                    buffer: buffer.buffer,
                    offset: 0,
                    range: vk::WHOLE_SIZE,
                }]
            });
            let writes = [0, 1].map(|binding| {
                vk::WriteDescriptorSet::default()
                    .dst_set(this.set)
                    .dst_binding(binding)
                    .descriptor_type(vk::DescriptorType::STORAGE_BUFFER)
                    .buffer_info(&infos[binding as usize])
            });
            // SAFETY: the set and the buffers are live; nothing uses the set yet.
            unsafe { device.update_descriptor_sets(&writes, &[]) };
            Ok(())
        })();
        if let Err(e) = made {
            this.destroy(device);
            return Err(e);
        }
        Ok(this)
    }

    /// Destroys the layout, the pool (and its set) and the set layout (the device is idle).
    pub(super) fn destroy(&self, device: &ash::Device) {
        // SAFETY: created from `device`, no longer in use; null handles are ignored.
        unsafe {
            device.destroy_pipeline_layout(self.layout, None);
            device.destroy_descriptor_pool(self.pool, None);
            device.destroy_descriptor_set_layout(self.set_layout, None);
        }
    }
}

/// The bytes pushed at [`DRAW_RANGE_OFFSET`] for `range`: its first index, its triangle count
/// and its vertex offset.
pub(super) fn draw_range_bytes(range: DrawRange) -> [u8; 12] {
    let mut bytes = [0u8; 12];
    bytes[0..4].copy_from_slice(&range.first_index.to_le_bytes());
    bytes[4..8].copy_from_slice(&(range.index_count / 3).to_le_bytes());
    bytes[8..12].copy_from_slice(&range.vertex_offset.to_le_bytes());
    bytes
}

/// The workgroups that draw `range`: one per [`WORKGROUP_TRIANGLES`] triangles.
pub(super) fn workgroups(range: DrawRange) -> u32 {
    (range.index_count / 3).div_ceil(WORKGROUP_TRIANGLES)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_draw_range_is_pushed_as_the_shaders_block_reads_it_and_covered_by_workgroups() {
        let range = DrawRange {
            first_index: 6,
            index_count: 99,
            vertex_offset: -4,
        };
        let bytes = draw_range_bytes(range);
        assert_eq!(u32::from_le_bytes(bytes[0..4].try_into().unwrap()), 6);
        assert_eq!(u32::from_le_bytes(bytes[4..8].try_into().unwrap()), 33);
        assert_eq!(i32::from_le_bytes(bytes[8..12].try_into().unwrap()), -4);
        // 33 triangles: two workgroups, the second emitting one.
        assert_eq!(workgroups(range), 2);
        assert_eq!(
            workgroups(DrawRange {
                index_count: 96,
                ..range
            }),
            1
        );
    }
}
