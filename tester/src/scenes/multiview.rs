//! The multiview scenes (`VK_KHR_multiview`, core in Vulkan 1.1): one draw renders every view
//! of a pass's view mask, each into its own array layer, as VR applications (OpenXR on
//! Vulkan) draw both eyes and engines draw a cube shadow map's faces in one pass.

use super::*;

/// The view mask of the multiview scenes' main pass: views 0 and 1, into layers 0 and 1.
pub const MULTIVIEW_MASK: u32 = 0b11;

/// `multiview`: the overlap scene drawn once per object in one render pass made with
/// `VkRenderPassMultiviewCreateInfo` (view mask and correlation mask 0b11) into a 2-layer
/// color image and a 2-layer depth image (cleared to 1.0, LESS), attached through 2D-array
/// views of both layers: view 0 is the overlap camera, view 1 a second eye
/// [`crate::scene::MULTIVIEW_EYE_SEPARATION`] to its right, looking the same way with the same
/// projection ([`crate::scene::Scene::view_cameras`]); the tester reads back both layers, each
/// with the ground truth of its own view's camera ([`crate::scene::Scene::seen_from`]; view
/// 1's files in `view1/`). The vertex shader ([`Program::Multiview`]) takes
/// `view_projection[gl_ViewIndex] * model * position`: both views' P * V in a uniform buffer
/// (the matrices a stereo renderer keeps per eye, which push constants could not hold per
/// view), the object's model matrix and color pushed, as `model-view-projection-pair` pushes
/// its model. Then a barrier of both layers into `SHADER_READ_ONLY_OPTIMAL` and the post pass
/// of `depth-layers` ([`Program::DepthLayersPost`]): the bottom quarter of layer 0's color is
/// shaded by layer 0's view distance, the quarter above it by layer 1's, so the second eye's
/// depth shows in the colors read back (the near cube shifted left against the first band);
/// a barrier of both layers puts the image back into its attachment layout for the read-back.
///
/// Layer item: a reversed depth attachment of several views. One draw writes both layers, so
/// whatever revz does to a draw (the reversed clear, compare op and viewport; the precise
/// path's carrier or its fit of the view-projection the shader loads, here an element of a
/// uniform array indexed by `gl_ViewIndex`) must hold for every view; the render pass's own
/// copies (a reversed variant, a promoted one) must keep its multiview structure, and the
/// read twin's refresh must convert both layers the pass wrote. A view left standard, or
/// reversed with the other view's range, shades the second band wrong; a pass that lost its
/// view mask draws layer 0 alone and leaves the second band the clear depth.
pub fn multiview() -> Scene {
    multiview_built("multiview", PassKind::RenderPass)
}

/// `multiview-dynamic`: [`multiview`] with dynamic rendering: `VkRenderingInfo::viewMask`
/// 0b11 over the 2D-array views, the pipeline made with `VkPipelineRenderingCreateInfo::
/// viewMask` 0b11 (the post pass is the same render pass).
///
/// Layer item: the view mask of dynamic rendering and of the pipelines made for it, which a
/// layer must carry into every rendering and pipeline variant it makes (a pipeline whose view
/// mask differs from the rendering's is invalid).
pub fn multiview_dynamic() -> Scene {
    multiview_built("multiview-dynamic", PassKind::DynamicRendering)
}

fn multiview_built(name: &'static str, kind: PassKind) -> Scene {
    let camera = overlap_camera();
    let mut b = Builder::default();
    let objects = b.nearest_first(&camera, overlap_objects());
    let band = b.object(Object::full_screen("multiview layers band", [1.0; 4]));
    let main = b.pass(PassSpec {
        kind,
        view_mask: MULTIVIEW_MASK,
        ..PassSpec::clear(1.0)
    });
    let post = b.pass(PassSpec {
        target: Target::Post,
        depth: DepthLoad::Load,
        load_color: true,
        ..PassSpec::clear(1.0)
    });
    let views = b.pipeline(PipelineSpec {
        program: Program::Multiview,
        ..PipelineSpec::standard("both views", main)
    });
    let shade = b.pipeline(PipelineSpec {
        program: Program::DepthLayersPost,
        depth_test: DepthTest::Off,
        depth_write: false,
        ..PipelineSpec::standard("multiview layers bands", post)
    });
    b.step(Step::BeginPass(main));
    b.step(Step::Bind(views));
    b.draw(&objects);
    b.step(Step::EndPass);
    b.step(Step::MainDepthLayout {
        from: DepthLayout::Attachment,
        to: DepthLayout::Sampled,
    });
    b.step(Step::BeginPass(post));
    b.step(Step::Bind(shade));
    b.step(Step::Draw(band));
    b.step(Step::EndPass);
    b.step(Step::MainDepthLayout {
        from: DepthLayout::Sampled,
        to: DepthLayout::Attachment,
    });
    b.finish(name, camera, None)
}
