//! What a scene records, as data (no Vulkan): the passes it renders (render passes with one or
//! two subpasses, dynamic rendering, a shadow-map pass), the pipelines it creates (their depth,
//! stencil, bias, bounds and viewport state, static or dynamic) and the ordered list of steps
//! the renderer turns into commands (`render/` interprets them one by one).
//!
//! Design: a scene is data plus this small command language, so that adding a scene never
//! touches the renderer unless it needs a new kind of command. [`Plan::check`] states every
//! rule the renderer relies on (indices in range, passes balanced, pipelines used only in the
//! pass and subpass they were made for, dynamic state set before the draws that need it), so a
//! malformed plan is an error before any Vulkan call, and every scene is checked in the unit
//! tests. What a plan needs from the device ([`Needs`]) is derived from it, never declared
//! separately. A main pass may be multisampled ([`Multisample`]): it then renders into
//! transient multisampled attachments resolved into the main color and depth images at its
//! end, with the depth resolve mode the plan names (`--depth-resolve` sets it).
//!
//! Files: this one holds the vocabulary and what is derived from a plan (one concern, kept
//! whole at about 800 lines: each type is read beside the steps that use it); `check.rs` holds
//! [`Plan::check`], the rules.

use std::fmt;

/// A depth or stencil comparison, as `VkCompareOp` (ours, so that scene data stays free of
/// Vulkan and tests can evaluate it).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Compare {
    /// Never passes.
    Never,
    /// reference < stored.
    Less,
    /// reference == stored.
    Equal,
    /// reference <= stored.
    LessOrEqual,
    /// reference > stored.
    Greater,
    /// reference != stored.
    NotEqual,
    /// reference >= stored (no scene draws with it; kept for the complete `VkCompareOp` set).
    #[allow(dead_code)]
    GreaterOrEqual,
    /// Always passes.
    Always,
}

impl Compare {
    /// Whether a fragment (or stencil reference) `reference` passes against `stored`.
    #[cfg(test)]
    pub fn passes<T: PartialOrd>(self, reference: T, stored: T) -> bool {
        match self {
            Compare::Never => false,
            Compare::Less => reference < stored,
            Compare::Equal => reference == stored,
            Compare::LessOrEqual => reference <= stored,
            Compare::Greater => reference > stored,
            Compare::NotEqual => reference != stored,
            Compare::GreaterOrEqual => reference >= stored,
            Compare::Always => true,
        }
    }
}

/// Rasterization depth bias, as `vkCmdSetDepthBias` takes it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DepthBias {
    /// `depthBiasConstantFactor`, in units of the format's minimum resolvable difference.
    pub constant: f32,
    /// `depthBiasSlopeFactor`, times the primitive's maximum depth slope.
    pub slope: f32,
    /// `depthBiasClamp` (0 = no clamp). Used only when the device's `depthBiasClamp` feature
    /// is enabled; 0 otherwise (as Vulkan requires).
    pub clamp: f32,
}

/// The depth test of a pipeline.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DepthTest {
    /// `depthTestEnable = FALSE`.
    Off,
    /// Enabled with a compare op baked into the pipeline.
    Static(Compare),
    /// Enabled; the compare op is `VK_DYNAMIC_STATE_DEPTH_COMPARE_OP` (Vulkan 1.3), set with
    /// [`Step::SetDepthCompareOp`].
    Dynamic,
}

/// The depth bias of a pipeline.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Bias {
    /// `depthBiasEnable = FALSE`.
    Off,
    /// Enabled with static factors.
    Static(DepthBias),
    /// Enabled; `VK_DYNAMIC_STATE_DEPTH_BIAS`, set with [`Step::SetDepthBias`].
    Dynamic,
}

/// The depth bounds test of a pipeline (needs the `depthBounds` feature unless `Off`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Bounds {
    /// `depthBoundsTestEnable = FALSE`.
    Off,
    /// Enabled with static bounds: fragments whose *stored* depth lies outside [min, max] are
    /// discarded.
    Static {
        /// `minDepthBounds`.
        min: f32,
        /// `maxDepthBounds`.
        max: f32,
    },
    /// Enabled; `VK_DYNAMIC_STATE_DEPTH_BOUNDS`, set with [`Step::SetDepthBounds`].
    Dynamic,
}

/// The viewport of a pipeline: always the whole target; only the depth range varies.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Viewport {
    /// Static viewport with depth range [min_depth, max_depth].
    Static {
        /// `minDepth`.
        min_depth: f32,
        /// `maxDepth`.
        max_depth: f32,
    },
    /// `VK_DYNAMIC_STATE_VIEWPORT`, set with [`Step::SetViewport`].
    Dynamic,
}

impl Viewport {
    /// The standard static [0, 1] viewport.
    pub const FULL: Viewport = Viewport::Static {
        min_depth: 0.0,
        max_depth: 1.0,
    };
}

/// What a passing fragment does to the stencil value.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StencilWrite {
    /// `passOp = KEEP`.
    Keep,
    /// `passOp = REPLACE` with the reference.
    Replace,
}

/// A stencil test (the same for front and back faces; fail and depth-fail keep the value).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StencilTest {
    /// Compare op: `reference <op> stored`.
    pub compare: Compare,
    /// The reference value (compare and write masks are 0xff).
    pub reference: u32,
    /// What passing fragments write.
    pub on_pass: StencilWrite,
}

/// The shaders of a pipeline.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Program {
    /// `scene.vert` + `scene.frag`: push-constant MVP, flat push-constant color.
    Flat,
    /// `scene.vert` only (no fragment shader): depth-only passes and subpasses.
    DepthOnly,
    /// `scene.vert` + `frag_depth.frag`: the push constants and flat color of
    /// [`Program::Flat`], and a fragment shader that writes its own depth computed from the
    /// rasterized one, `gl_FragDepth = 0.5 + 0.5 * gl_FragCoord.z` (`Program::frag_depth` in
    /// the unit tests).
    FragDepth,
    /// `shadow_receiver.vert|frag`: the flat color darkened where the shadow map says the
    /// surface is shadowed (needs a [`Target::Shadow`] pass before it).
    ShadowReceiver,
    /// `shadow_receiver.vert` + `shadow_receiver_raw.frag`: the same, from the shadow map's raw
    /// depth values (a texel fetch and a gather through a plain sampler, compared in the
    /// shader) instead of a comparison sampler.
    ShadowReceiverRaw,
    /// `row_major.vert` + `scene.frag`: the MVP in a `RowMajor` push-constant member (its rows
    /// in memory, as HLSL compilers lay it out), flat push-constant color.
    RowMajor,
    /// `row_vector.vert` + `scene.frag`: `position * M` (HLSL's `mul(v, M)`); the same bytes as
    /// [`Program::RowMajor`].
    RowVector,
    /// `mvp_pair.vert|frag`: push constants `{ mat4 model; mat4 view_proj }` (128 bytes, the
    /// guaranteed maximum), `view_proj * (model * position)`; the flat color comes from a
    /// uniform buffer indexed by the object.
    MvpPair,
    /// `lit_mvp.vert|frag`: the push constants of [`Program::Flat`] (`{ mat4 mvp; vec4 color }`,
    /// 80 bytes), and the clip position `pos = mvp * position` used for lighting too: the view
    /// vector `-pos.xyz`, the face normal from its screen-space derivatives, a fixed light,
    /// diffuse and specular on top of the color. A change of the pushed matrix's depth row
    /// changes the shading.
    LitMvp,
    /// `ubo.vert` + `flat_color.frag` (the `ubo` [`Delivery`]): no push constants; a dynamic
    /// uniform buffer of per-object blocks `{ mat4 projection; mat4 view; mat4 model; vec4
    /// color }` at an aligned stride, bound with the object's dynamic offset at each draw;
    /// `projection * view * model * position`.
    Ubo,
    /// `ubo_dynamic.vert` + `flat_color.frag` (the `ubo-dynamic` [`Delivery`]): no push
    /// constants; binding 0 a uniform buffer `{ mat4 view_proj }`, binding 1 a dynamic uniform
    /// buffer of per-object `{ mat4 model; vec4 color }`; `view_proj * model * position`.
    UboDynamic,
    /// `ssbo.vert` + `flat_color.frag` (the `ssbo` [`Delivery`]): no push constants; a
    /// read-only storage buffer of per-object `{ mat4 mvp; vec4 color }` indexed by
    /// `gl_InstanceIndex` (each object drawn as one instance, firstInstance = its index).
    Ssbo,
    /// `split_mvp.vert` + `split_color.frag` (the `push-split` [`Delivery`]): the push
    /// constants of [`Program::Flat`] in two ranges, the matrix at 0..64 for the vertex stage,
    /// the color at 64..80 for the fragment stage (each push split along them).
    SplitPush,
    /// The shaders and push constants of [`Program::SplitPush`] with the fragment stage's range
    /// from 64 to the device's last byte (the `push-full` [`Delivery`]): the layout's ranges
    /// fill the device's push constants (128 bytes on lavapipe 22.3, 256 on 25.0), leaving no
    /// room for revz's carrier.
    FullPush,
    /// The shaders and push constants of [`Program::Flat`] as unlinked vertex and fragment
    /// shader objects (`VK_EXT_shader_object`, the `shader-objects` [`Delivery`]): a bind of
    /// such a pipeline binds the two shaders (null for the other stages) and sets every state
    /// of its [`PipelineSpec`] with the dynamic state commands, as engines built on shader
    /// objects do. Needs the `shaderObject` feature (lavapipe from Mesa 23.1 on).
    ShaderObjects,
    /// `mesh.mesh` (glslang) + `scene.frag` (the `mesh` [`Delivery`]): the push constants and
    /// product of [`Program::Flat`] in a mesh shader (`VK_EXT_mesh_shader`, no task shader),
    /// which fetches each draw's triangles from the scene's index and position arrays in
    /// storage buffers; the draw's index range follows the color in the push constants
    /// (bytes 80..92). Needs the `meshShader` feature (lavapipe from Mesa 23.3 on).
    Mesh,
    /// The shaders and push constants of [`Program::Mesh`] as unlinked mesh and fragment
    /// shader objects (the `mesh-shader-objects` [`Delivery`]), bound as
    /// [`Program::ShaderObjects`] binds its own (the vertex stage null). Needs `shaderObject`
    /// and `meshShader`.
    MeshShaderObjects,
    /// The shaders of [`Program::ShaderObjects`] created linked, in one `vkCreateShadersEXT`
    /// call with `VK_SHADER_CREATE_LINK_STAGE_BIT_EXT` (the `linked-shader-objects`
    /// [`Delivery`]), and bound as that program binds them.
    LinkedShaderObjects,
    /// `ubo_position.vert` + `push.geom` + `scene.frag` (the `push-geometry` [`Delivery`]): the
    /// push constants of [`Program::Flat`], the matrix applied in a geometry shader; one range
    /// for the vertex, geometry and fragment stages.
    PushGeometry,
    /// `ssbo_rows.vert` + `flat_color.frag` (the `ssbo-rows` [`Delivery`]): the buffer of
    /// [`Program::Ssbo`] with each matrix stored as its rows, applied as four dot products.
    SsboRows,
    /// `ssbo_registers.vert` + `flat_color.frag` (the `ssbo-registers` [`Delivery`]): the
    /// buffer of [`Program::SsboRows`], applied as D3D bytecode translators write it (a
    /// private output register written one component at a time, copied into `gl_Position` by
    /// the entry point after it calls the shader's function).
    SsboRegisters,
    /// `ssbo_columns.vert` + `flat_color.frag` (the `ssbo-columns` [`Delivery`]): the buffer of
    /// [`Program::Ssbo`] applied as fxc's `mul(v, M)` and DXVK write it (a register reassigned
    /// by a multiply and three multiply-adds of the columns by splats).
    SsboColumns,
    /// `shaders/spvasm/ssbo_vkd3d.vert` + `flat_color.frag` (the `ssbo-vkd3d` [`Delivery`]):
    /// the buffer of [`Program::Ssbo`] applied in the shape Wine's vkd3d-shader writes a D3D
    /// vertex shader (registers written a component at a time then whole, multiply-adds of
    /// the columns by splats of two registers, the output register `OpCopyMemory`'d into
    /// `Position`), with D3D's rasterizer state: the depth clamp on and depth clipping kept on
    /// (`VK_EXT_depth_clip_enable`).
    SsboVkd3d,
    /// `ubo_position.vert` + `ubo.geom` + `flat_color.frag` (the `ubo-geometry` [`Delivery`]):
    /// the buffers of [`Program::Ubo`], the product applied in a geometry shader to the
    /// vertex stage's `gl_Position`.
    UboGeometry,
    /// `ubo.vert` + `passthrough.geom` + `flat_color.frag` (the `ubo-passthrough-geometry`
    /// [`Delivery`]): [`Program::Ubo`], its projected positions passed through a geometry
    /// shader as they are.
    UboPassthroughGeometry,
    /// `ubo_later.vert` + `passthrough.tesc` + `ubo.tese` + `flat_color.frag` (the
    /// `ubo-tessellation` [`Delivery`]): the buffers of [`Program::Ubo`], the product applied
    /// in a tessellation evaluation shader (patches of three points, every level 1).
    UboTessellation,
    /// `ubo.vert` + `position_passthrough.tesc` + `interpolating.tese` + `flat_color.frag` (the
    /// `ubo-interpolating-tessellation` [`Delivery`]): [`Program::Ubo`], its projected positions
    /// copied by the control stage and interpolated at the patch point by the evaluation stage
    /// (patches of three points, every level 1), as pipelines that tessellate only to
    /// subdivide do.
    UboInterpolatingTessellation,
    /// `ubo_position.vert` + `corner_positions.tesc` + `projecting.tese` + `flat_color.frag`
    /// (the `ubo-projecting-tessellation` [`Delivery`]): the blocks of [`Program::Ubo`],
    /// applied in the tessellation evaluation stage to the patch's object-space positions
    /// (`gl_in[i].gl_Position`, w = 1), which it interpolates and displaces along y (by 0 at
    /// the corners) first, as terrain tessellation does (patches of three points, every
    /// level 1).
    UboProjectingTessellation,
    /// `ubo_position.vert` + `corner_positions.tesc` + `corner_interpolating.tese` +
    /// `ubo.geom` + `flat_color.frag` (the `ubo-tessellated-geometry` [`Delivery`]): the
    /// patch's object-space positions (w = 1) copied and interpolated by the tessellation
    /// stages, then projected by the geometry stage with the blocks of [`Program::Ubo`]
    /// (patches of three points, every level 1).
    UboTessellatedGeometry,
    /// [`Program::UboTessellation`]'s four shaders as shader objects created linked in one
    /// call (the `linked-tessellation-shader-objects` [`Delivery`]; needs
    /// `VK_EXT_shader_object` and `tessellationShader`), every state set at the bind.
    LinkedTessellationShaderObjects,
    /// [`Program::UboPassthroughGeometry`]'s three shaders as unlinked shader objects (the
    /// `passthrough-geometry-shader-objects` [`Delivery`]; needs `VK_EXT_shader_object` and
    /// `geometryShader`), every state set at the bind.
    PassthroughGeometryShaderObjects,
    /// [`Program::UboGeometry`]'s three shaders as unlinked shader objects: the geometry
    /// shader projects the vertex shader's `vec4(p, 1.0)` (the
    /// `projecting-geometry-shader-objects` [`Delivery`]; needs `VK_EXT_shader_object` and
    /// `geometryShader`), every state set at the bind.
    ProjectingGeometryShaderObjects,
    /// `soft_particle.vert|frag`: the push constants of [`Program::Flat`], the flat color faded
    /// where the scene's depth, read from the main depth image with a texel fetch, lies close
    /// behind the fragment (needs a [`Target::SoftParticles`] pass: the depth attached
    /// read-only while it is sampled).
    SoftParticle,
    /// `scene.vert` + `depth_post.frag` (glslang): the bottom quarter of the image shaded by
    /// the main depth's view distance, read with a texel fetch, a bilinear sample and a gather
    /// (drawn over a full-screen quad in a [`Target::Post`] pass).
    DepthPost,
    /// `scene.vert` + `depth_tiles_post.frag`: the top quarter of the image shaded from the
    /// depth pyramid level a [`Step::BuildDepthTiles`] built (each 4 x 4 tile's nearest and
    /// farthest depth), in a [`Target::Post`] pass.
    DepthTiles,
    /// `scene.vert` + `stencil_post.frag`: a band across the middle of the image shaded by the main
    /// depth-stencil image's stencil value and depth (texel fetches of each aspect), in a
    /// [`Target::Post`] pass (needs a depth format with stencil).
    StencilPost,
    /// `scene.vert` + `depth_input.frag` (glslang): the fragments drawn shaded by the main
    /// depth's view distance, read as an input attachment (`subpassLoad`, its variable
    /// decorated `InputAttachmentIndex` 0) in subpass 1 of a [`PassKind::DepthInputSubpasses`]
    /// pass, where subpass 0 wrote it, or after the by-region barrier of a
    /// [`PassKind::DynamicRenderingLocalRead`] rendering that maps the depth to index 0.
    DepthInput,
    /// `scene.vert` + `depth_input_undecorated.frag` (SPIR-V assembly: `depth_input.frag` less
    /// its `InputAttachmentIndex` decoration, which GLSL cannot leave out): the shading of
    /// [`Program::DepthInput`], the depth reaching the undecorated input attachment through
    /// dynamic rendering local read's default mapping, after the by-region barrier of a
    /// [`PassKind::DynamicRenderingLocalRead`] rendering that sets no mapping.
    DepthInputUndecorated,
    /// `scene.vert` + `depth_mips_post.frag` (glslang): the bottom quarter of the image shaded
    /// by the view distance of mip level 1 of the main depth, the top quarter by that of level
    /// 2 (texel fetches through a view of the whole mip chain, which [`Step::BlitDepthLevel`]s
    /// filled), in a [`Target::Post`] pass.
    DepthMipsPost,
    /// `scene.vert` + `depth_layers_post.frag` (glslang): the bottom quarter of the image
    /// shaded by the view distance of array layer 0 of the main depth, the quarter above it by
    /// that of layer 1 (texel fetches through a 2D-array view of both layers), in a
    /// [`Target::Post`] pass.
    DepthLayersPost,
    /// `scene.vert` + `depth_post_ms.frag` (glslang): the bottom 45% of the image shaded
    /// by the view distances of the nearest and the farthest of each pixel's samples of the
    /// multisampled depth a [`Multisample::sampled_depth`] pass kept (texel fetches of each
    /// sample through a `texture2DMS`), in a [`Target::Post`] pass.
    DepthPostMs,
    /// `multiview.vert` (glslang) + `scene.frag`: one draw renders every view of a
    /// [`PassSpec::view_mask`] pass (`VK_KHR_multiview`), each into its own array layer of the
    /// color and depth images. The views' view-projections ([`crate::scene::Scene::view_cameras`],
    /// P * V in f64 rounded once to f32) are in a uniform buffer the shader indexes with
    /// `gl_ViewIndex`; the object's model matrix and color are pushed (80 bytes, the layout of
    /// [`Program::Flat`]'s push constants: `scene.frag` reads the color at 64):
    /// `view_projection[gl_ViewIndex] * model * position`.
    Multiview,
}

/// How a scene hands its matrices to the vertex shader (`--delivery`): push constants, as
/// every scene does by default, or one of three buffer layouts applications use. The buffer
/// deliveries replace [`Program::Flat`] by their program ([`Delivery::program`]) and render
/// the same image.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, PartialOrd, Ord, clap::ValueEnum)]
pub enum Delivery {
    /// Push constants `{ mat4 mvp; vec4 color }`: the scene's own programs.
    #[default]
    Push,
    /// Separate P, V and M in one block per object of a dynamic uniform buffer
    /// ([`Program::Ubo`]).
    Ubo,
    /// Precomposed P * V in a uniform buffer, the per-object model matrix in a dynamic one
    /// ([`Program::UboDynamic`]).
    UboDynamic,
    /// Per-object P * V * M in a storage buffer, indexed by the instance index
    /// ([`Program::Ssbo`]).
    Ssbo,
    /// The storage buffer of [`Delivery::Ssbo`], each matrix stored as its rows and applied as
    /// four dot products ([`Program::SsboRows`]).
    SsboRows,
    /// The buffer of [`Delivery::SsboRows`], applied as DXVK writes a D3D vertex shader: each
    /// dot product stored into one component of a private register ([`Program::SsboRegisters`]).
    SsboRegisters,
    /// The buffer of [`Delivery::Ssbo`], applied as fxc's `mul(v, M)` and DXVK write it
    /// ([`Program::SsboColumns`]).
    SsboColumns,
    /// The buffer of [`Delivery::Ssbo`], applied as Wine's vkd3d-shader writes a D3D vertex
    /// shader, with D3D's depth clamp and clip state ([`Program::SsboVkd3d`]; needs
    /// `depthClamp` and `VK_EXT_depth_clip_enable`).
    SsboVkd3d,
    /// The push constants of [`Delivery::Push`] in a range per stage ([`Program::SplitPush`]).
    PushSplit,
    /// The push constants of [`Delivery::PushSplit`] in ranges that fill 128 bytes
    /// ([`Program::FullPush`]).
    PushFull,
    /// The push constants of [`Delivery::Push`], applied in a geometry shader
    /// ([`Program::PushGeometry`]).
    PushGeometry,
    /// The blocks of [`Delivery::Ubo`], applied in a geometry shader
    /// ([`Program::UboGeometry`]).
    UboGeometry,
    /// [`Delivery::Ubo`]'s projected positions passed through a geometry shader as they are
    /// ([`Program::UboPassthroughGeometry`]).
    UboPassthroughGeometry,
    /// The blocks of [`Delivery::Ubo`], applied in a tessellation evaluation shader
    /// ([`Program::UboTessellation`]).
    UboTessellation,
    /// [`Delivery::Ubo`]'s projected positions interpolated by tessellation stages
    /// ([`Program::UboInterpolatingTessellation`]).
    UboInterpolatingTessellation,
    /// The blocks of [`Delivery::Ubo`], applied in a tessellation evaluation shader to the
    /// patch's interpolated positions ([`Program::UboProjectingTessellation`]).
    UboProjectingTessellation,
    /// The blocks of [`Delivery::Ubo`], applied in a geometry shader to the positions a
    /// tessellation evaluation shader interpolated ([`Program::UboTessellatedGeometry`]).
    UboTessellatedGeometry,
    /// The push constants of [`Delivery::Push`], the flat program bound as shader objects
    /// ([`Program::ShaderObjects`]; needs `VK_EXT_shader_object`).
    ShaderObjects,
    /// The push constants of [`Delivery::Push`], applied in a mesh shader
    /// ([`Program::Mesh`]; needs `VK_EXT_mesh_shader`).
    Mesh,
    /// [`Delivery::Mesh`]'s mesh shader as a shader object ([`Program::MeshShaderObjects`];
    /// needs both extensions).
    MeshShaderObjects,
    /// [`Delivery::ShaderObjects`]' shaders created as one linked set
    /// ([`Program::LinkedShaderObjects`]; needs `VK_EXT_shader_object`).
    LinkedShaderObjects,
    /// [`Delivery::UboTessellation`]'s shaders created as one linked set of shader objects
    /// ([`Program::LinkedTessellationShaderObjects`]; needs `VK_EXT_shader_object`).
    LinkedTessellationShaderObjects,
    /// [`Delivery::UboPassthroughGeometry`]'s shaders as unlinked shader objects
    /// ([`Program::PassthroughGeometryShaderObjects`]; needs `VK_EXT_shader_object`).
    PassthroughGeometryShaderObjects,
    /// [`Delivery::UboGeometry`]'s shaders as unlinked shader objects
    /// ([`Program::ProjectingGeometryShaderObjects`]; needs `VK_EXT_shader_object`).
    ProjectingGeometryShaderObjects,
}

impl Delivery {
    /// Every delivery, push first, and the ones that need an extension lavapipe 22.3 lacks
    /// ([`Delivery::ShaderObjects`], [`Delivery::Mesh`]) last.
    pub const ALL: [Delivery; 24] = [
        Delivery::Push,
        Delivery::PushSplit,
        Delivery::PushFull,
        Delivery::PushGeometry,
        Delivery::Ubo,
        Delivery::UboDynamic,
        Delivery::Ssbo,
        Delivery::SsboRows,
        Delivery::SsboRegisters,
        Delivery::SsboColumns,
        Delivery::SsboVkd3d,
        Delivery::UboGeometry,
        Delivery::UboPassthroughGeometry,
        Delivery::UboTessellation,
        Delivery::UboInterpolatingTessellation,
        Delivery::UboProjectingTessellation,
        Delivery::UboTessellatedGeometry,
        Delivery::ShaderObjects,
        Delivery::Mesh,
        Delivery::MeshShaderObjects,
        Delivery::LinkedShaderObjects,
        Delivery::LinkedTessellationShaderObjects,
        Delivery::PassthroughGeometryShaderObjects,
        Delivery::ProjectingGeometryShaderObjects,
    ];

    /// The deliveries a Vulkan 1.0 device with the core features renders (`ssbo-vkd3d` also
    /// needs `VK_EXT_depth_clip_enable`, which lavapipe has from Mesa 22.3 on): all but the
    /// last six of [`Delivery::ALL`].
    pub const PORTABLE: &'static [Delivery] = match Delivery::ALL.split_last_chunk::<7>() {
        Some((portable, _)) => portable,
        None => &[],
    };

    /// The CLI and report name (`push`, `ubo`, `ubo-dynamic`, `ssbo`).
    pub fn name(self) -> &'static str {
        match self {
            Delivery::Push => "push",
            Delivery::Ubo => "ubo",
            Delivery::UboDynamic => "ubo-dynamic",
            Delivery::Ssbo => "ssbo",
            Delivery::SsboRows => "ssbo-rows",
            Delivery::SsboRegisters => "ssbo-registers",
            Delivery::SsboColumns => "ssbo-columns",
            Delivery::SsboVkd3d => "ssbo-vkd3d",
            Delivery::PushSplit => "push-split",
            Delivery::PushFull => "push-full",
            Delivery::PushGeometry => "push-geometry",
            Delivery::UboGeometry => "ubo-geometry",
            Delivery::UboPassthroughGeometry => "ubo-passthrough-geometry",
            Delivery::UboTessellation => "ubo-tessellation",
            Delivery::UboInterpolatingTessellation => "ubo-interpolating-tessellation",
            Delivery::UboProjectingTessellation => "ubo-projecting-tessellation",
            Delivery::UboTessellatedGeometry => "ubo-tessellated-geometry",
            Delivery::ShaderObjects => "shader-objects",
            Delivery::Mesh => "mesh",
            Delivery::MeshShaderObjects => "mesh-shader-objects",
            Delivery::LinkedShaderObjects => "linked-shader-objects",
            Delivery::LinkedTessellationShaderObjects => "linked-tessellation-shader-objects",
            Delivery::PassthroughGeometryShaderObjects => "passthrough-geometry-shader-objects",
            Delivery::ProjectingGeometryShaderObjects => "projecting-geometry-shader-objects",
        }
    }

    /// The program that replaces [`Program::Flat`]; `None` for push constants (nothing is
    /// replaced).
    pub fn program(self) -> Option<Program> {
        match self {
            Delivery::Push => None,
            Delivery::Ubo => Some(Program::Ubo),
            Delivery::UboDynamic => Some(Program::UboDynamic),
            Delivery::Ssbo => Some(Program::Ssbo),
            Delivery::SsboRows => Some(Program::SsboRows),
            Delivery::SsboRegisters => Some(Program::SsboRegisters),
            Delivery::SsboColumns => Some(Program::SsboColumns),
            Delivery::SsboVkd3d => Some(Program::SsboVkd3d),
            Delivery::PushSplit => Some(Program::SplitPush),
            Delivery::PushFull => Some(Program::FullPush),
            Delivery::PushGeometry => Some(Program::PushGeometry),
            Delivery::UboGeometry => Some(Program::UboGeometry),
            Delivery::UboPassthroughGeometry => Some(Program::UboPassthroughGeometry),
            Delivery::UboTessellation => Some(Program::UboTessellation),
            Delivery::UboInterpolatingTessellation => Some(Program::UboInterpolatingTessellation),
            Delivery::UboProjectingTessellation => Some(Program::UboProjectingTessellation),
            Delivery::UboTessellatedGeometry => Some(Program::UboTessellatedGeometry),
            Delivery::ShaderObjects => Some(Program::ShaderObjects),
            Delivery::Mesh => Some(Program::Mesh),
            Delivery::MeshShaderObjects => Some(Program::MeshShaderObjects),
            Delivery::LinkedShaderObjects => Some(Program::LinkedShaderObjects),
            Delivery::LinkedTessellationShaderObjects => {
                Some(Program::LinkedTessellationShaderObjects)
            }
            Delivery::PassthroughGeometryShaderObjects => {
                Some(Program::PassthroughGeometryShaderObjects)
            }
            Delivery::ProjectingGeometryShaderObjects => {
                Some(Program::ProjectingGeometryShaderObjects)
            }
        }
    }
}

impl Program {
    /// Whether the program's shaders are bound as shader objects (`VK_EXT_shader_object`)
    /// in place of its pipelines.
    pub fn binds_shader_objects(self) -> bool {
        matches!(
            self,
            Program::ShaderObjects
                | Program::LinkedShaderObjects
                | Program::MeshShaderObjects
                | Program::LinkedTessellationShaderObjects
                | Program::PassthroughGeometryShaderObjects
                | Program::ProjectingGeometryShaderObjects
        )
    }

    /// Whether the program's pipelines have D3D's rasterizer state, which translators give
    /// every pipeline: the depth clamp on with depth clipping kept on (`VK_EXT_depth_clip_enable`).
    pub fn clamps_with_clip(self) -> bool {
        self == Program::SsboVkd3d
    }

    /// Whether the program reads its matrices and color from buffers (no push constants).
    pub fn is_buffer_delivery(self) -> bool {
        self.buffers().is_some()
    }

    /// The buffer delivery whose buffers (blocks, descriptor set and layout) the program
    /// reads: itself for [`Program::Ubo`], [`Program::UboDynamic`] and [`Program::Ssbo`],
    /// [`Program::Ubo`] for the programs that apply its product in a later stage; `None` for
    /// the push-constant programs.
    pub fn buffers(self) -> Option<Program> {
        match self {
            Program::Ubo
            | Program::UboGeometry
            | Program::UboPassthroughGeometry
            | Program::UboTessellation
            | Program::UboInterpolatingTessellation
            | Program::UboProjectingTessellation
            | Program::UboTessellatedGeometry
            | Program::LinkedTessellationShaderObjects
            | Program::PassthroughGeometryShaderObjects
            | Program::ProjectingGeometryShaderObjects => Some(Program::Ubo),
            Program::UboDynamic | Program::Ssbo => Some(self),
            Program::SsboRows
            | Program::SsboRegisters
            | Program::SsboColumns
            | Program::SsboVkd3d => Some(Program::Ssbo),
            _ => None,
        }
    }

    /// The stage that applies the program's matrices (where its buffers are bound).
    pub fn projecting_stage(self) -> ash::vk::ShaderStageFlags {
        match self {
            Program::UboGeometry
            | Program::PushGeometry
            | Program::UboTessellatedGeometry
            | Program::ProjectingGeometryShaderObjects => ash::vk::ShaderStageFlags::GEOMETRY,
            Program::UboTessellation
            | Program::UboProjectingTessellation
            | Program::LinkedTessellationShaderObjects => {
                ash::vk::ShaderStageFlags::TESSELLATION_EVALUATION
            }
            _ => ash::vk::ShaderStageFlags::VERTEX,
        }
    }

    /// Whether the program's pipelines tessellate (patches of three control points; needs
    /// `tessellationShader`).
    pub fn tessellates(self) -> bool {
        matches!(
            self,
            Program::UboTessellation
                | Program::UboInterpolatingTessellation
                | Program::UboProjectingTessellation
                | Program::UboTessellatedGeometry
                | Program::LinkedTessellationShaderObjects
        )
    }

    /// Whether the program reads the main depth as an input attachment (the input-attachment
    /// bindings: [`Program::DepthInput`], [`Program::DepthInputUndecorated`]).
    pub fn reads_depth_input(self) -> bool {
        matches!(self, Program::DepthInput | Program::DepthInputUndecorated)
    }

    /// Whether the program samples the shadow map (needs a [`Target::Shadow`] pass before it,
    /// and the shadow bindings).
    pub fn receives_shadow(self) -> bool {
        matches!(self, Program::ShadowReceiver | Program::ShadowReceiverRaw)
    }

    /// Bytes of push constants the program's shaders declare, all of which a
    /// [`Step::Draw`] pushes: 80 (`mat4` + `vec4 color`), 128 (two `mat4`s), or 0 for the
    /// buffer deliveries. Pipelines of programs with the same size share push-constant state
    /// (their layouts have the same push-constant range).
    pub fn push_constant_size(self) -> u32 {
        match self {
            Program::Ubo
            | Program::UboDynamic
            | Program::Ssbo
            | Program::SsboRows
            | Program::SsboRegisters
            | Program::SsboColumns
            | Program::SsboVkd3d
            | Program::UboGeometry
            | Program::UboPassthroughGeometry
            | Program::UboTessellation
            | Program::UboInterpolatingTessellation
            | Program::UboProjectingTessellation
            | Program::UboTessellatedGeometry
            | Program::LinkedTessellationShaderObjects
            | Program::PassthroughGeometryShaderObjects
            | Program::ProjectingGeometryShaderObjects => 0,
            Program::MvpPair => 128,
            Program::Flat
            | Program::DepthOnly
            | Program::FragDepth
            | Program::ShadowReceiver
            | Program::ShadowReceiverRaw
            | Program::RowMajor
            | Program::RowVector
            | Program::LitMvp
            | Program::SplitPush
            | Program::FullPush
            | Program::ShaderObjects
            | Program::LinkedShaderObjects
            | Program::Mesh
            | Program::MeshShaderObjects
            | Program::PushGeometry
            | Program::SoftParticle
            | Program::DepthPost
            | Program::DepthTiles
            | Program::StencilPost
            | Program::DepthInput
            | Program::DepthInputUndecorated
            | Program::DepthMipsPost
            | Program::DepthLayersPost
            | Program::DepthPostMs
            | Program::Multiview => 80,
        }
    }

    /// The depth a fragment of the program stores (and is tested with), given the depth
    /// rasterized for it (`gl_FragCoord.z`, standard depth with the tester's own [0, 1]
    /// viewports): `0.5 + 0.5 * z` for [`Program::FragDepth`] (`frag_depth.frag`), `z`
    /// itself for every other program (they leave depth to the rasterizer).
    #[cfg(test)]
    pub fn frag_depth(self, z: f64) -> f64 {
        match self {
            Program::FragDepth => 0.5 + 0.5 * z,
            _ => z,
        }
    }
}

/// One graphics pipeline.
#[derive(Clone, Debug, PartialEq)]
pub struct PipelineSpec {
    /// A short name for messages.
    pub name: &'static str,
    /// The pass it is made for (a render pass compatible with that pass's, or its
    /// dynamic-rendering formats); usable in every pass of the same target and kind.
    pub pass: usize,
    /// The subpass it is made for.
    pub subpass: u32,
    /// Its shaders.
    pub program: Program,
    /// Depth test.
    pub depth_test: DepthTest,
    /// `depthWriteEnable`.
    pub depth_write: bool,
    /// Color write mask RGBA (true) or none (false).
    pub color_write: bool,
    /// Depth bias.
    pub bias: Bias,
    /// Depth bounds test.
    pub bounds: Bounds,
    /// Stencil test (None: disabled).
    pub stencil: Option<StencilTest>,
    /// Viewport depth range.
    pub viewport: Viewport,
    /// `VkPipelineViewportDepthClipControlCreateInfoEXT::negativeOneToOne`: clip-space depth
    /// in [-w, w] (OpenGL's convention) instead of [0, w] (needs `VK_EXT_depth_clip_control`).
    pub negative_one_to_one: bool,
    /// Built with `VK_EXT_graphics_pipeline_library` (needs it and its `graphicsPipelineLibrary`
    /// feature; render passes only): four libraries (vertex input interface, pre-rasterization
    /// shaders, fragment shader, fragment output interface), each holding its part of this
    /// same state, linked into the pipeline that is bound. `false`: one ordinary
    /// `vkCreateGraphicsPipelines` call. Both give the same pipeline.
    pub libraries: bool,
    /// `cullMode = BACK` (front faces counter-clockwise in framebuffer coordinates: the
    /// outside of the meshes, which wind counter-clockwise seen from outside in the y-up world
    /// and are mirrored by the y-down projection), as lit applications draw closed meshes; the
    /// ground truth culls the same triangles. `false`: no culling.
    pub cull_back_faces: bool,
    /// `depthClampEnable` (needs `depthClamp`): no clipping at the near and far planes,
    /// fragment depth clamped to the viewport's depth range.
    pub depth_clamp: bool,
}

impl PipelineSpec {
    /// The standard pipeline of `pass` subpass 0: flat color, depth test LESS with writes,
    /// full [0, 1] viewport, nothing else (what the `overlap` scene uses).
    pub fn standard(name: &'static str, pass: usize) -> PipelineSpec {
        PipelineSpec {
            name,
            pass,
            subpass: 0,
            program: Program::Flat,
            depth_test: DepthTest::Static(Compare::Less),
            depth_write: true,
            color_write: true,
            bias: Bias::Off,
            bounds: Bounds::Off,
            stencil: None,
            viewport: Viewport::FULL,
            negative_one_to_one: false,
            libraries: false,
            cull_back_faces: false,
            depth_clamp: false,
        }
    }
}

/// Which image a pass renders into.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Target {
    /// The color attachment and the depth attachment of the chosen format (read back).
    Main,
    /// A D32_SFLOAT shadow map with SAMPLED usage, no color (sampled by
    /// [`Program::ShadowReceiver`]); drawn with the scene's light.
    Shadow,
    /// The color attachment (loaded) and the main depth image attached read-only (loaded;
    /// entered from `DEPTH_STENCIL_ATTACHMENT_OPTIMAL` into `DEPTH_STENCIL_READ_ONLY_OPTIMAL`
    /// by the render pass itself, and left there), which its pipelines test against and
    /// sample at once ([`Program::SoftParticle`]). The main depth image gets SAMPLED usage.
    SoftParticles,
    /// The color attachment (loaded) alone, while the main depth image is sampled in
    /// `SHADER_READ_ONLY_OPTIMAL` ([`Program::DepthPost`]): a [`Step::MainDepthLayout`] puts it
    /// there before and back after. The main depth image gets SAMPLED usage.
    Post,
    /// One mip level and array layer of the main depth image alone, as the depth attachment
    /// of a pass without color ([`Program::DepthOnly`] pipelines; through a view of that
    /// subresource, at that level's size): how engines render the cascades or views of a
    /// layered depth image. Cleared or loaded, left in its attachment layout. The main depth
    /// image gets as many mip levels and array layers as the plan's slices name
    /// ([`Needs::depth_subresources`]); level 0 layer 0 is the one [`Target::Main`] renders
    /// into and the read-back reads.
    DepthSlice {
        /// The mip level.
        level: u32,
        /// The array layer.
        layer: u32,
    },
}

/// How a pass is begun.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PassKind {
    /// `vkCmdBeginRenderPass`, one subpass: a render pass made with `vkCreateRenderPass`, or
    /// with `vkCreateRenderPass2` when the pass is multisampled (its depth resolve needs
    /// `VkSubpassDescriptionDepthStencilResolve`).
    RenderPass,
    /// `vkCmdBeginRenderPass`, two subpasses sharing the depth attachment: subpass 0 has no
    /// color attachment (depth pre-pass), subpass 1 has both; a subpass dependency orders
    /// subpass 0's depth writes before subpass 1's depth tests.
    DepthPrepassSubpasses,
    /// `vkCmdBeginRenderPass` (main target), two subpasses, as deferred renderers read depth:
    /// subpass 0 draws into the color and the depth attachment; subpass 1 draws into the same
    /// color attachment and reads the depth as an input attachment
    /// (`DEPTH_STENCIL_READ_ONLY_OPTIMAL`, its depth aspect: [`Program::DepthInput`]), with
    /// the depth also attached read-only (tested, never written) where `depth_attached`, and
    /// no depth attachment otherwise. A subpass dependency orders subpass 0's depth and color
    /// writes before subpass 1's reads, tests and color writes. The main depth image gets
    /// INPUT_ATTACHMENT usage.
    DepthInputSubpasses {
        /// Subpass 1 keeps the depth as its (read-only) depth-stencil attachment too.
        depth_attached: bool,
    },
    /// `vkCmdBeginRendering` (Vulkan 1.3 `dynamicRendering`).
    DynamicRendering,
    /// `vkCmdBeginRendering` recorded as two render pass instances of one rendering, as
    /// engines that split a rendering across recording jobs do: begun with
    /// `VK_RENDERING_SUSPENDING_BIT`, its [`Step::NextSubpass`] ends that instance and begins
    /// the same rendering info again with `VK_RENDERING_RESUMING_BIT` (nothing recorded in
    /// between; the resumed instance loads and clears nothing), and its pipelines of "subpass
    /// 1" draw in the resumed instance. Its images are those of one rendering of the same
    /// draws.
    DynamicRenderingSuspended {
        /// The resumed instance is recorded in a second primary command buffer, submitted
        /// right after the first in the same batch (the first ends with the suspended
        /// instance; the rest of the frame, read-back included, goes into the second).
        across_command_buffers: bool,
    },
    /// `vkCmdBeginRendering` (main target) that reads the depth it writes as an input
    /// attachment within the same rendering, as deferred renderers on dynamic rendering do
    /// (`VK_KHR_dynamic_rendering_local_read`, core in Vulkan 1.4): the twin of
    /// [`PassKind::DepthInputSubpasses`], whose two subpasses it keeps as two phases of the
    /// one rendering. "Subpass 0" draws into the color and the depth attachment;
    /// [`Step::NextSubpass`] records, inside the rendering, the by-region barrier local reads
    /// need (`vkCmdPipelineBarrier` with `VK_DEPENDENCY_BY_REGION_BIT`, a memory barrier from
    /// the depth and color attachment writes to input attachment reads, depth tests and color
    /// writes); "subpass 1" draws with pipelines that read the depth as an input attachment
    /// ([`PassKind::depth_input_program`]). The depth stays attached throughout (a
    /// rendering's attachments do not change: subpass 1's pipelines test it or not, never
    /// write it), and the main depth image is in `RENDERING_LOCAL_READ_KHR` for the whole
    /// rendering: the barrier before `vkCmdBeginRendering` puts it there, one after
    /// `vkCmdEndRendering` puts it back into its attachment layout. The main depth image gets
    /// INPUT_ATTACHMENT usage.
    DynamicRenderingLocalRead {
        /// The depth is mapped to input attachment index 0 explicitly: every pipeline made for
        /// the pass chains `VkRenderingInputAttachmentIndexInfoKHR` (`pDepthInputAttachmentIndex`
        /// pointing to 0, the color attachment `VK_ATTACHMENT_UNUSED`), and the command buffer
        /// sets the same mapping with `vkCmdSetRenderingInputAttachmentIndicesKHR` right after
        /// `vkCmdBeginRendering` (the two must match at each draw). `false`: neither, the
        /// default mapping, in which the depth attachment maps to the input attachment
        /// variable without an `InputAttachmentIndex` decoration.
        indexed: bool,
    },
}

impl PassKind {
    /// Number of subpasses.
    pub fn subpass_count(self) -> u32 {
        match self {
            PassKind::DepthPrepassSubpasses
            | PassKind::DepthInputSubpasses { .. }
            | PassKind::DynamicRenderingLocalRead { .. }
            | PassKind::DynamicRenderingSuspended { .. } => 2,
            PassKind::RenderPass | PassKind::DynamicRendering => 1,
        }
    }

    /// Whether the pass reads the main depth as an input attachment in its subpass 1.
    pub fn reads_depth_input(self) -> bool {
        self.depth_input_program().is_some()
    }

    /// The program that reads the depth as an input attachment in subpass 1 of the pass: the
    /// one whose input attachment variable the depth is mapped to (decorated with index 0 in
    /// a render pass and where a local-read rendering maps the depth to 0, undecorated where
    /// it keeps the default mapping); `None` where the pass reads no input attachment.
    pub fn depth_input_program(self) -> Option<Program> {
        match self {
            PassKind::DepthInputSubpasses { .. }
            | PassKind::DynamicRenderingLocalRead { indexed: true } => Some(Program::DepthInput),
            PassKind::DynamicRenderingLocalRead { indexed: false } => {
                Some(Program::DepthInputUndecorated)
            }
            PassKind::RenderPass
            | PassKind::DepthPrepassSubpasses
            | PassKind::DynamicRendering
            | PassKind::DynamicRenderingSuspended { .. } => None,
        }
    }

    /// Whether the pass is begun with `vkCmdBeginRendering` (no render pass object).
    pub fn is_dynamic_rendering(self) -> bool {
        matches!(
            self,
            PassKind::DynamicRendering
                | PassKind::DynamicRenderingLocalRead { .. }
                | PassKind::DynamicRenderingSuspended { .. }
        )
    }

    /// Whether the pass reads the depth it writes in the same dynamic rendering
    /// (`VK_KHR_dynamic_rendering_local_read`).
    pub fn reads_locally(self) -> bool {
        matches!(self, PassKind::DynamicRenderingLocalRead { .. })
    }
}

/// What a pass does with an attachment's previous contents.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum DepthLoad {
    /// LOAD_OP_CLEAR to this depth (and the stencil, where there is one, to 0).
    Clear(f32),
    /// LOAD_OP_LOAD (depth and stencil).
    Load,
}

/// How a multisampled depth attachment is resolved into a single-sample one, as
/// `VkResolveModeFlagBits` (`--depth-resolve`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, clap::ValueEnum)]
pub enum ResolveMode {
    /// `VK_RESOLVE_MODE_SAMPLE_ZERO_BIT`: sample 0 (every device supports it).
    SampleZero,
    /// `VK_RESOLVE_MODE_AVERAGE_BIT`: the mean of the samples.
    Average,
    /// `VK_RESOLVE_MODE_MIN_BIT`: the smallest sample (the nearest, with standard depth).
    Min,
    /// `VK_RESOLVE_MODE_MAX_BIT`: the largest sample.
    Max,
}

impl ResolveMode {
    /// The Vulkan name without `VK_RESOLVE_MODE_` and `_BIT` (`SAMPLE_ZERO`).
    pub fn vk_name(self) -> &'static str {
        match self {
            ResolveMode::SampleZero => "SAMPLE_ZERO",
            ResolveMode::Average => "AVERAGE",
            ResolveMode::Min => "MIN",
            ResolveMode::Max => "MAX",
        }
    }
}

/// The multisampling of a main pass: it renders into transient color and depth attachments
/// of `samples` samples per pixel (its pipelines rasterize with as many), which are resolved
/// at the end of the pass into the main color image (averaged) and the main depth image
/// (with `depth_resolve`); only the resolved images are read back.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Multisample {
    /// Samples per pixel: a power of two from 2 to 64 (`VkSampleCountFlagBits`).
    pub samples: u32,
    /// How the depth attachment is resolved (unless `sampled_depth`).
    pub depth_resolve: ResolveMode,
    /// The depth attachment is not resolved but kept (stored, with SAMPLED usage instead of
    /// TRANSIENT_ATTACHMENT), for shaders to read each of its samples after the pass
    /// ([`Program::DepthPostMs`], after a [`Step::MultisampledDepthLayout`]); the color is
    /// resolved all the same. Render passes of the main target only.
    pub sampled_depth: bool,
}

/// One pass over a target.
#[derive(Clone, Debug, PartialEq)]
pub struct PassSpec {
    /// The image it renders into.
    pub target: Target,
    /// How it is begun.
    pub kind: PassKind,
    /// Depth (and stencil) load op.
    pub depth: DepthLoad,
    /// Color load op (Main only): `true` loads, `false` clears to the clear color.
    pub load_color: bool,
    /// Multisampled with a resolve at the end (main target, one-subpass kinds, both
    /// attachments cleared), or single-sample (None).
    pub multisample: Option<Multisample>,
    /// The views of a multiview pass (`VK_KHR_multiview`, Vulkan 1.1; main target,
    /// single-sample, one subpass): bit `i` renders view `i` into array layer `i` of the color
    /// and depth images, attached through 2D-array views of their layers
    /// (`VkRenderPassMultiviewCreateInfo`'s view mask and correlation mask, or
    /// `VkRenderingInfo::viewMask`; its pipelines are made with the same mask). 0: no
    /// multiview (one layer, the usual views).
    pub view_mask: u32,
}

impl PassSpec {
    /// A one-subpass render pass over the main target clearing color and depth to `depth`.
    pub fn clear(depth: f32) -> PassSpec {
        PassSpec {
            target: Target::Main,
            kind: PassKind::RenderPass,
            depth: DepthLoad::Clear(depth),
            load_color: false,
            multisample: None,
            view_mask: 0,
        }
    }

    /// Whether `subpass` of this pass has a color attachment.
    pub fn has_color(&self, subpass: u32) -> bool {
        let depth_only_target = matches!(self.target, Target::Shadow | Target::DepthSlice { .. });
        let depth_prepass = self.kind == PassKind::DepthPrepassSubpasses && subpass == 0;
        !(depth_only_target || depth_prepass)
    }

    /// Whether `subpass` of this pass has a depth(-stencil) attachment (written or read-only).
    pub fn has_depth(&self, subpass: u32) -> bool {
        self.target != Target::Post
            && !(self.kind
                == PassKind::DepthInputSubpasses {
                    depth_attached: false,
                }
                && subpass == 1)
    }

    /// Whether `subpass` of this pass reads the main depth as an input attachment.
    pub fn reads_depth_input(&self, subpass: u32) -> bool {
        self.kind.reads_depth_input() && subpass == 1
    }

    /// Whether a pipeline made for `other` can be used in this pass (same attachments, sample
    /// counts, resolves and subpass structure; load ops do not matter).
    pub fn compatible(&self, other: &PassSpec) -> bool {
        self.target == other.target
            && self.kind == other.kind
            && self.multisample == other.multisample
            && self.view_mask == other.view_mask
    }

    /// Samples per pixel of the pass's attachments (and its pipelines' rasterization).
    pub fn samples(&self) -> u32 {
        self.multisample.map_or(1, |m| m.samples)
    }
}

/// One recorded command (or group of commands).
#[derive(Clone, Debug, PartialEq)]
pub enum Step {
    /// `vkCmdClearDepthStencilImage` of the main depth image (outside any pass) to `depth`
    /// (stencil 0 where there is one), with the layout transitions around it. The depth image
    /// gets TRANSFER_DST usage.
    ClearDepthImage {
        /// The depth clear value.
        depth: f32,
    },
    /// Begins pass `n`.
    BeginPass(usize),
    /// `vkCmdNextSubpass`; in a [`PassKind::DynamicRenderingLocalRead`] rendering, which has
    /// no subpasses, the by-region barrier that makes what was drawn before it readable as an
    /// input attachment after it (its "subpass 1").
    NextSubpass,
    /// Ends the current pass.
    EndPass,
    /// Binds pipeline `n`.
    Bind(usize),
    /// Pushes object `n`'s constants (all of them, in the bound program's layout: its MVP
    /// for the current pass's view, its color) and draws it.
    Draw(usize),
    /// Pushes only bytes `offset..offset + size` of object `n`'s constants (in the bound
    /// program's layout), as an application updating part of its push constants does.
    Push {
        /// The object whose constants are pushed.
        object: usize,
        /// First byte (a multiple of 4).
        offset: u32,
        /// Number of bytes (a multiple of 4, > 0).
        size: u32,
    },
    /// Draws object `n` with the push constants as they are (no push): whatever earlier
    /// [`Step::Draw`]s and [`Step::Push`]es left there. Every byte the program declares must
    /// have been pushed since the command buffer began (or since a pipeline with another
    /// push-constant size was bound).
    DrawPushed(usize),
    /// `vkCmdSetDepthCompareOp`.
    SetDepthCompareOp(Compare),
    /// `vkCmdSetDepthBias`.
    SetDepthBias(DepthBias),
    /// `vkCmdSetDepthBounds`.
    SetDepthBounds {
        /// Minimum.
        min: f32,
        /// Maximum.
        max: f32,
    },
    /// `vkCmdSetViewport`: the whole target with this depth range.
    SetViewport {
        /// `minDepth`.
        min_depth: f32,
        /// `maxDepth`.
        max_depth: f32,
    },
    /// `vkCmdClearAttachments` of the depth aspect (only) inside the current pass, over the
    /// rectangle `[x0, y0, x1, y1]` given as fractions of the target size.
    ClearDepthRect {
        /// `[x0, y0, x1, y1]`, each in [0, 1], x0 < x1, y0 < y1.
        rect: [f32; 4],
        /// The depth clear value.
        depth: f32,
    },
    /// An image barrier of the main depth image (outside any pass; every mip level and array
    /// layer) from one layout to another, ordering the accesses of the first before those of
    /// the second.
    MainDepthLayout {
        /// Its layout before.
        from: DepthLayout,
        /// Its layout after.
        to: DepthLayout,
    },
    /// An image barrier of one mip level of the main depth image (all its layers; outside any
    /// pass) from one layout to another, as [`Step::MainDepthLayout`] does for the whole
    /// image: what an application records between the levels of a depth pyramid. Only this
    /// step may start from [`DepthLayout::Undefined`] (the level's contents discarded).
    DepthLevelLayout {
        /// The mip level.
        level: u32,
        /// Its layout before.
        from: DepthLayout,
        /// Its layout after.
        to: DepthLayout,
    },
    /// An image barrier of the multisampled depth image a [`Multisample::sampled_depth`] pass
    /// keeps (outside any pass) from one layout to another, as [`Step::MainDepthLayout`] does
    /// for the main depth image.
    MultisampledDepthLayout {
        /// Its layout before.
        from: DepthLayout,
        /// Its layout after.
        to: DepthLayout,
    },
    /// `vkCmdBlitImage` of mip level `level - 1` of the main depth image (in
    /// `TRANSFER_SRC_OPTIMAL`) into level `level` (in `TRANSFER_DST_OPTIMAL`), the whole of
    /// each, NEAREST (depth blits must be), the depth aspect alone, every layer: how engines
    /// fill the lower levels of a depth chain without a shader.
    BlitDepthLevel {
        /// The level written (at least 1).
        level: u32,
    },
    /// A compute dispatch (outside any pass, the main depth image sampled) that builds a depth
    /// pyramid level from the main depth (`depth_tiles.comp`: each 4 x 4 tile's nearest and
    /// farthest depth, into a storage buffer), then a barrier making it visible to fragment
    /// shaders ([`Program::DepthTiles`]).
    BuildDepthTiles,
    /// Binds the depth pyramid's compute pipeline and descriptors (outside any pass), as a
    /// frame whose culling pass binds its compute state first: each later
    /// [`Step::BuildDepthTiles`] of the recording dispatches without binding again, so revz's
    /// conversions in between (read twin refreshes) must bind that state again after their
    /// own dispatch (`--bind-tiles-first`).
    BindDepthTiles(TileDescriptors),
    /// Records each list into its own secondary command buffer (RENDER_PASS_CONTINUE,
    /// inheriting the current render pass, subpass and framebuffer) and executes them all with
    /// one `vkCmdExecuteCommands`. It must be the only kind of step in its subpass.
    ExecuteSecondaries(Vec<Vec<Step>>, Recording),
}

/// A layout of the main depth image between passes, with the accesses made in it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DepthLayout {
    /// `DEPTH_STENCIL_ATTACHMENT_OPTIMAL`: depth tests and writes.
    Attachment,
    /// `DEPTH_STENCIL_READ_ONLY_OPTIMAL`: tested and sampled (where a
    /// [`Target::SoftParticles`] pass leaves it).
    ReadOnly,
    /// `SHADER_READ_ONLY_OPTIMAL`: sampled by fragment shaders.
    Sampled,
    /// `TRANSFER_SRC_OPTIMAL`: blitted from ([`Step::BlitDepthLevel`]).
    TransferSrc,
    /// `TRANSFER_DST_OPTIMAL`: blitted into ([`Step::BlitDepthLevel`]).
    TransferDst,
    /// `UNDEFINED`, as the layout a [`Step::DepthLevelLayout`] leaves: the level's contents
    /// are discarded (a barrier from any layout).
    Undefined,
}

/// How the secondaries of a [`Step::ExecuteSecondaries`] are recorded.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Recording {
    /// One after the other on the main thread, from the main command pool.
    MainThread,
    /// All at once, each on its own thread (`std::thread::scope`) with its own command pool
    /// created on that thread: multi-threaded recording as engines do it.
    ThreadPerSecondary,
    /// As [`Recording::ThreadPerSecondary`], but the odd-numbered lists inherit the render
    /// pass and subpass without the framebuffer (which the inheritance info may leave null):
    /// a layer then only knows the depth format the secondary draws into.
    ThreadPerSecondaryOddWithoutFramebuffer,
}

/// The passes, pipelines and steps of a scene.
#[derive(Clone, Debug, PartialEq)]
pub struct Plan {
    /// The passes, begun by [`Step::BeginPass`].
    pub passes: Vec<PassSpec>,
    /// The pipelines, bound by [`Step::Bind`].
    pub pipelines: Vec<PipelineSpec>,
    /// What is recorded, in order.
    pub steps: Vec<Step>,
}

/// How [`Step::BindDepthTiles`] binds the depth pyramid's compute descriptors.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum TileDescriptors {
    /// A descriptor set (`vkCmdBindDescriptorSets`).
    Sets,
    /// A descriptor buffer (`VK_EXT_descriptor_buffer`: `vkGetDescriptorEXT` at creation,
    /// `vkCmdBindDescriptorBuffersEXT` and `vkCmdSetDescriptorBufferOffsetsEXT`), as
    /// vkd3d-proton, and Zink on a driver with the extension, bind every descriptor.
    Buffer,
    /// Push descriptors (`vkCmdPushDescriptorSetKHR` of the compute bind point).
    Push,
    /// Push descriptors through an update template (`vkCmdPushDescriptorSetWithTemplateKHR`).
    PushTemplate,
    /// A descriptor set, the compute program a shader object (`VK_EXT_shader_object`,
    /// `vkCmdBindShadersEXT`) instead of a pipeline.
    ShaderObject,
    /// A descriptor set bound with `vkCmdBindDescriptorSets2KHR` (`VK_KHR_maintenance6`).
    Sets2,
    /// A descriptor buffer whose offsets are set with `vkCmdSetDescriptorBufferOffsets2EXT`
    /// (`VK_KHR_maintenance6` with `VK_EXT_descriptor_buffer`).
    Buffer2,
}

/// What a plan needs from the device and the targets, derived from the plan itself.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Needs {
    /// A depth format with a stencil aspect.
    pub stencil: bool,
    /// The `depthBounds` feature.
    pub depth_bounds: bool,
    /// The `dynamicRendering` feature (Vulkan 1.3), or `VK_ATTACHMENT_STORE_OP_NONE`, which
    /// comes with it (a [`Target::SoftParticles`] pass).
    pub dynamic_rendering: bool,
    /// `vkCmdSetDepthCompareOp` (Vulkan 1.3, or `VK_EXT_extended_dynamic_state`).
    pub dynamic_compare_op: bool,
    /// The `depthBiasClamp` feature would be used (optional: clamp 0 without it).
    pub depth_bias_clamp: bool,
    /// TRANSFER_DST usage on the depth image.
    pub clear_depth_image: bool,
    /// The shadow-map target.
    pub shadow_map: bool,
    /// The main depth image is sampled ([`Target::SoftParticles`], [`Target::Post`]).
    pub sampled_depth: bool,
    /// The main depth image is read as an input attachment
    /// ([`PassKind::DepthInputSubpasses`], [`PassKind::DynamicRenderingLocalRead`]):
    /// INPUT_ATTACHMENT usage and a depth-aspect view.
    pub input_depth: bool,
    /// A compute pass builds depth tiles ([`Step::BuildDepthTiles`]).
    pub depth_tiles: bool,
    /// `VK_EXT_descriptor_buffer` (the depth pyramid's descriptors in a descriptor buffer:
    /// [`TileDescriptors::Buffer`]).
    pub descriptor_buffer: bool,
    /// `VK_KHR_maintenance6` (the depth pyramid's descriptors bound with a `2` command:
    /// [`TileDescriptors::Sets2`], [`TileDescriptors::Buffer2`]).
    pub maintenance6: bool,
    /// `VK_KHR_dynamic_rendering_local_read`'s `dynamicRenderingLocalRead` (a
    /// [`PassKind::DynamicRenderingLocalRead`] pass: input attachments, a barrier and the
    /// `RENDERING_LOCAL_READ_KHR` layout inside `vkCmdBeginRendering`).
    pub dynamic_rendering_local_read: bool,
    /// How [`Step::BindDepthTiles`] binds the depth pyramid's compute descriptors (`None`:
    /// no such step; its dispatches bind a descriptor set).
    pub tile_descriptors: Option<TileDescriptors>,
    /// Number of secondary command buffers recorded on the main thread (from the main pool;
    /// threaded ones come from their threads' own pools).
    pub secondaries: usize,
    /// `VK_EXT_depth_clip_control` with `depthClipControl` (a pipeline clips depth to
    /// [-w, w]).
    pub depth_clip_control: bool,
    /// `VK_EXT_graphics_pipeline_library` (and `VK_KHR_pipeline_library`) with
    /// `graphicsPipelineLibrary` (a pipeline is built from libraries).
    pub graphics_pipeline_library: bool,
    /// `VK_EXT_depth_range_unrestricted`: a viewport depth range or a depth clear value
    /// outside [0, 1].
    pub depth_range_unrestricted: bool,
    /// The `depthClamp` feature (a pipeline clamps depth).
    pub depth_clamp: bool,
    /// `VK_EXT_depth_clip_enable`'s `depthClipEnable`: a pipeline clamps depth and keeps
    /// clipping it ([`Program::SsboVkd3d`], D3D's rasterizer state).
    pub depth_clip_enable: bool,
    /// The `geometryShader` feature (a pipeline projects in a geometry shader).
    pub geometry_shader: bool,
    /// The `tessellationShader` feature (a pipeline projects in a tessellation evaluation
    /// shader).
    pub tessellation_shader: bool,
    /// `VK_EXT_shader_object`'s `shaderObject` (a pipeline is bound as shader objects).
    pub shader_object: bool,
    /// `VK_EXT_mesh_shader`'s `meshShader` (a pipeline projects in a mesh shader).
    pub mesh_shader: bool,
    /// Multisampled attachments of this sample count, resolved with this depth resolve mode
    /// (the device must support both for the formats, and the mode in
    /// `VkPhysicalDeviceDepthStencilResolveProperties`); every multisampled pass of a plan
    /// shares them.
    pub multisample: Option<Multisample>,
    /// The mip levels and array layers of the main depth image: one each, or as many as its
    /// [`Target::DepthSlice`] passes, [`Step::DepthLevelLayout`] barriers and
    /// [`Step::BlitDepthLevel`]s name.
    pub depth_subresources: DepthSubresources,
    /// The main depth image is blitted from level to level ([`Step::BlitDepthLevel`]):
    /// TRANSFER_SRC and TRANSFER_DST usage, BLIT_SRC and BLIT_DST features.
    pub depth_blits: bool,
    /// The views of the plan's multiview passes (their [`PassSpec::view_mask`]s' highest bit
    /// plus one; 0 without one): they need the `multiview` feature, and the main color and
    /// depth images get one array layer per view (the depth's in `depth_subresources`).
    pub views: u32,
}

/// The mip levels and array layers of the main depth image.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DepthSubresources {
    /// `mipLevels` (at least 1).
    pub levels: u32,
    /// `arrayLayers` (at least 1).
    pub layers: u32,
}

impl Default for DepthSubresources {
    fn default() -> Self {
        DepthSubresources {
            levels: 1,
            layers: 1,
        }
    }
}

impl DepthSubresources {
    /// Whether the image has more than one subresource per aspect.
    pub fn is_single(self) -> bool {
        self.levels == 1 && self.layers == 1
    }
}

/// Why a plan is malformed.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct PlanError(pub String);

impl fmt::Display for PlanError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for PlanError {}

macro_rules! ensure {
    ($cond:expr, $($arg:tt)+) => {
        if !$cond {
            return Err(PlanError(format!($($arg)+)));
        }
    };
}

mod check;

impl Plan {
    /// One render pass clearing depth to 1.0, the standard pipeline, every object drawn in
    /// order: the plan of the `overlap` scene.
    pub fn single_pass(objects: usize) -> Plan {
        let mut steps = vec![Step::BeginPass(0), Step::Bind(0)];
        steps.extend((0..objects).map(Step::Draw));
        steps.push(Step::EndPass);
        Plan {
            passes: vec![PassSpec::clear(1.0)],
            pipelines: vec![PipelineSpec::standard("standard", 0)],
            steps,
        }
    }

    /// The plan with its matrices handed over by `delivery`: every [`Program::Flat`] pipeline
    /// gets the delivery's buffer program, the rest unchanged ([`Delivery::Push`] changes
    /// nothing). The error says why the plan cannot take it: a pipeline with another program
    /// (its shaders declare their own push constants or bindings), a shadow pass (its draws
    /// use the light's matrices), or push-constant updates between draws
    /// ([`Step::Push`], [`Step::DrawPushed`]).
    pub fn with_delivery(&self, delivery: Delivery) -> Result<Plan, PlanError> {
        let Some(program) = delivery.program() else {
            return Ok(self.clone());
        };
        let name = delivery.name();
        let mut plan = self.clone();
        for pipeline in &mut plan.pipelines {
            ensure!(
                pipeline.program == Program::Flat || pipeline.program == program,
                "pipeline {} uses the {:?} program, which has no {name} variant (only the flat \
                 push-constant program has one)",
                pipeline.name,
                pipeline.program
            );
            ensure!(
                !pipeline.libraries
                    || program.projecting_stage() == ash::vk::ShaderStageFlags::VERTEX,
                "pipeline {} is built from libraries, whose pre-rasterization library the tester \
                 builds with a vertex stage alone; the {name} delivery projects in a later stage",
                pipeline.name
            );
            ensure!(
                !matches!(program, Program::Mesh | Program::MeshShaderObjects)
                    || !pipeline.libraries,
                "pipeline {} is built from libraries, whose pre-rasterization library the tester \
                 builds with a vertex stage",
                pipeline.name
            );
            ensure!(
                !matches!(
                    program,
                    Program::ShaderObjects
                        | Program::LinkedShaderObjects
                        | Program::MeshShaderObjects
                        | Program::LinkedTessellationShaderObjects
                        | Program::PassthroughGeometryShaderObjects
                        | Program::ProjectingGeometryShaderObjects
                ) || (pipeline.viewport != Viewport::Dynamic && !pipeline.libraries),
                "pipeline {} has a dynamic viewport or is built from libraries; the {name} \
                 delivery sets every state at its bind",
                pipeline.name
            );
            pipeline.program = program;
        }
        if let Some(n) = plan.passes.iter().position(|p| p.target != Target::Main) {
            return Err(PlanError(format!(
                "pass {n} renders a shadow map with the light's matrices; the {name} delivery \
                 holds the camera's only"
            )));
        }
        // The split push constants take partial pushes too (each split along the ranges).
        if let Some(step) = plan
            .all_steps()
            .into_iter()
            .filter(|_| program.is_buffer_delivery())
            .find(|s| matches!(s, Step::Push { .. } | Step::DrawPushed(_)))
        {
            return Err(PlanError(format!(
                "{step:?} updates push constants between draws; the {name} delivery has none"
            )));
        }
        Ok(plan)
    }

    /// The plan with the depth pyramid's compute state bound by its first step
    /// ([`Step::BindDepthTiles`] with `descriptors`): its dispatches then bind nothing. Only
    /// plans that build depth tiles take it.
    pub fn with_tiles_bound_first(&self, descriptors: TileDescriptors) -> Result<Plan, PlanError> {
        ensure!(
            self.steps.contains(&Step::BuildDepthTiles),
            "the plan builds no depth tiles (only depth-reads does)"
        );
        let mut plan = self.clone();
        plan.steps.insert(0, Step::BindDepthTiles(descriptors));
        Ok(plan)
    }

    /// The buffer delivery program of the plan's pipelines, if one uses one.
    pub fn buffer_program(&self) -> Option<Program> {
        self.pipelines
            .iter()
            .map(|p| p.program)
            .find(|p| p.is_buffer_delivery())
    }

    /// Sets the depth resolve mode of every multisampled pass (`--depth-resolve`); returns
    /// whether the plan has one.
    pub fn set_depth_resolve(&mut self, mode: ResolveMode) -> bool {
        let mut any = false;
        for multisample in self
            .passes
            .iter_mut()
            .filter_map(|p| p.multisample.as_mut())
            .filter(|m| !m.sampled_depth)
        {
            multisample.depth_resolve = mode;
            any = true;
        }
        any
    }

    /// Whether the plan's [`Target::Post`] passes sample the main depth image: unless every
    /// pipeline made for one reads the multisampled depth instead ([`Program::DepthPostMs`]).
    pub fn post_samples_main_depth(&self) -> bool {
        let mut post = self
            .pipelines
            .iter()
            .filter(|p| {
                self.passes
                    .get(p.pass)
                    .is_some_and(|q| q.target == Target::Post)
            })
            .peekable();
        post.peek().is_none() || post.any(|p| p.program != Program::DepthPostMs)
    }

    /// Every step, with the steps inside secondaries, in recording order.
    pub fn all_steps(&self) -> Vec<&Step> {
        fn walk<'a>(steps: &'a [Step], out: &mut Vec<&'a Step>) {
            for step in steps {
                out.push(step);
                if let Step::ExecuteSecondaries(lists, _) = step {
                    for list in lists {
                        walk(list, out);
                    }
                }
            }
        }
        let mut out = Vec::new();
        walk(&self.steps, &mut out);
        out
    }

    /// The objects drawn with a depth-clamping pipeline (in the order of their draws): they
    /// may lie beyond the near or far plane, as clamping draws them.
    #[cfg(test)]
    pub fn clamped_objects(&self) -> Vec<usize> {
        let mut bound: Option<&PipelineSpec> = None;
        let mut clamped = Vec::new();
        for step in self.all_steps() {
            match step {
                Step::Bind(n) => bound = self.pipelines.get(*n),
                Step::Draw(object) | Step::DrawPushed(object)
                    if bound.is_some_and(|p| p.depth_clamp) =>
                {
                    clamped.push(*object);
                }
                _ => {}
            }
        }
        clamped
    }

    /// What the plan needs from the device and the targets.
    pub fn needs(&self) -> Needs {
        let mut needs = Needs::default();
        for pass in &self.passes {
            needs.shadow_map |= pass.target == Target::Shadow;
            needs.sampled_depth |= pass.target == Target::SoftParticles
                || (pass.target == Target::Post && self.post_samples_main_depth());
            // The read-only depth attachment is stored with VK_ATTACHMENT_STORE_OP_NONE (a
            // STORE would write it while it is sampled), which comes with dynamic rendering
            // (Vulkan 1.3, or VK_KHR_dynamic_rendering below it).
            needs.dynamic_rendering |= pass.target == Target::SoftParticles;
            needs.multisample = needs.multisample.or(pass.multisample);
            needs.input_depth |= pass.kind.reads_depth_input();
            if let Target::DepthSlice { level, layer } = pass.target {
                let slices = &mut needs.depth_subresources;
                slices.levels = slices.levels.max(level + 1);
                slices.layers = slices.layers.max(layer + 1);
            }
            if pass.kind.is_dynamic_rendering() {
                needs.dynamic_rendering = true;
            }
            needs.dynamic_rendering_local_read |= pass.kind.reads_locally();
            if pass.view_mask != 0 {
                let views = 32 - pass.view_mask.leading_zeros();
                needs.views = needs.views.max(views);
                let slices = &mut needs.depth_subresources;
                slices.layers = slices.layers.max(views);
            }
            if let DepthLoad::Clear(depth) = pass.depth {
                needs.depth_range_unrestricted |= !(0.0..=1.0).contains(&depth);
            }
        }
        for pipeline in &self.pipelines {
            needs.stencil |= pipeline.stencil.is_some() || pipeline.program == Program::StencilPost;
            needs.depth_bounds |= pipeline.bounds != Bounds::Off;
            needs.dynamic_compare_op |= pipeline.depth_test == DepthTest::Dynamic;
            needs.depth_clip_control |= pipeline.negative_one_to_one;
            needs.graphics_pipeline_library |= pipeline.libraries;
            needs.depth_clamp |= pipeline.depth_clamp || pipeline.program.clamps_with_clip();
            needs.depth_clip_enable |= pipeline.program.clamps_with_clip();
            needs.geometry_shader |= matches!(
                pipeline.program,
                Program::UboGeometry
                    | Program::UboPassthroughGeometry
                    | Program::UboTessellatedGeometry
                    | Program::PushGeometry
                    | Program::PassthroughGeometryShaderObjects
                    | Program::ProjectingGeometryShaderObjects
            );
            needs.tessellation_shader |= pipeline.program.tessellates();
            needs.shader_object |= pipeline.program.binds_shader_objects();
            needs.mesh_shader |=
                matches!(pipeline.program, Program::Mesh | Program::MeshShaderObjects);
            if let Viewport::Static {
                min_depth,
                max_depth,
            } = pipeline.viewport
            {
                needs.depth_range_unrestricted |=
                    !(0.0..=1.0).contains(&min_depth) || !(0.0..=1.0).contains(&max_depth);
            }
            if let Bias::Static(bias) = pipeline.bias {
                needs.depth_bias_clamp |= bias.clamp != 0.0;
            }
        }
        for step in self.all_steps() {
            match step {
                Step::ClearDepthImage { depth } => {
                    needs.clear_depth_image = true;
                    needs.depth_range_unrestricted |= !(0.0..=1.0).contains(depth);
                }
                Step::SetViewport {
                    min_depth,
                    max_depth,
                } => {
                    needs.depth_range_unrestricted |=
                        !(0.0..=1.0).contains(min_depth) || !(0.0..=1.0).contains(max_depth);
                }
                Step::SetDepthBias(bias) => needs.depth_bias_clamp |= bias.clamp != 0.0,
                Step::BuildDepthTiles => needs.depth_tiles = true,
                Step::BindDepthTiles(descriptors) => {
                    needs.depth_tiles = true;
                    needs.descriptor_buffer |= matches!(
                        descriptors,
                        TileDescriptors::Buffer | TileDescriptors::Buffer2
                    );
                    needs.maintenance6 |= matches!(
                        descriptors,
                        TileDescriptors::Sets2 | TileDescriptors::Buffer2
                    );
                    needs.shader_object |= *descriptors == TileDescriptors::ShaderObject;
                    needs.tile_descriptors = Some(*descriptors);
                }
                Step::DepthLevelLayout { level, .. } => {
                    let slices = &mut needs.depth_subresources;
                    slices.levels = slices.levels.max(level + 1);
                }
                Step::BlitDepthLevel { level } => {
                    let slices = &mut needs.depth_subresources;
                    slices.levels = slices.levels.max(level + 1);
                    needs.depth_blits = true;
                }
                Step::ExecuteSecondaries(lists, Recording::MainThread) => {
                    needs.secondaries += lists.len();
                }
                _ => {}
            }
        }
        needs
    }

    /// The draw commands one recording of the plan makes, per (pipeline, target drawn into):
    /// `(pipeline index, target, multisampled, draws)`, in the order each pair first draws.
    /// What a depth profile of a layer under the tester must count (`render.json`'s
    /// `recorded`).
    pub fn draw_census(&self) -> Vec<(usize, Target, bool, usize)> {
        fn walk(
            plan: &Plan,
            steps: &[Step],
            pass: &mut Option<(usize, u32)>,
            bound: &mut Option<usize>,
            out: &mut Vec<(usize, Target, bool, usize)>,
        ) {
            for step in steps {
                match step {
                    Step::BeginPass(n) => *pass = Some((*n, 0)),
                    Step::NextSubpass => {
                        if let Some((_, subpass)) = pass {
                            *subpass += 1;
                        }
                    }
                    Step::EndPass => *pass = None,
                    Step::Bind(n) => *bound = Some(*n),
                    Step::Draw(_) | Step::DrawPushed(_) => {
                        let (Some(pipeline), Some((spec, subpass))) = (
                            *bound,
                            pass.and_then(|(n, s)| plan.passes.get(n).map(|p| (p, s))),
                        ) else {
                            continue;
                        };
                        // A post pass, or a subpass without a depth attachment, draws into no
                        // depth image.
                        if !spec.has_depth(subpass) {
                            continue;
                        }
                        let key = (pipeline, spec.target, spec.multisample.is_some());
                        match out.iter_mut().find(|e| (e.0, e.1, e.2) == key) {
                            Some(entry) => entry.3 += 1,
                            None => out.push((key.0, key.1, key.2, 1)),
                        }
                    }
                    // Each secondary begins with nothing bound, in the pass it continues.
                    Step::ExecuteSecondaries(lists, _) => {
                        for list in lists {
                            let mut bound = None;
                            walk(plan, list, pass, &mut bound, out);
                        }
                    }
                    _ => {}
                }
            }
        }
        let mut out = Vec::new();
        walk(self, &self.steps, &mut None, &mut None, &mut out);
        out
    }

    /// The depth the main depth image holds where nothing was drawn: the value of the first
    /// depth clear of the main target (render pass or image clear), 1.0 if there is none.
    pub fn main_clear_depth(&self) -> f32 {
        for step in &self.steps {
            match step {
                Step::ClearDepthImage { depth } => return *depth,
                Step::BeginPass(n) => {
                    if let Some(pass) = self.passes.get(*n) {
                        if pass.target == Target::Main {
                            if let DepthLoad::Clear(depth) = pass.depth {
                                return depth;
                            }
                        }
                    }
                }
                _ => {}
            }
        }
        1.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_census_counts_draws_per_pipeline_and_target_secondaries_included() {
        let mut shadow = PassSpec::clear(1.0);
        shadow.target = Target::Shadow;
        let plan = Plan {
            passes: vec![shadow, PassSpec::clear(1.0)],
            pipelines: vec![
                PipelineSpec::standard("shadow", 0),
                PipelineSpec::standard("main", 1),
            ],
            steps: vec![
                Step::BeginPass(0),
                Step::Bind(0),
                Step::Draw(0),
                Step::Draw(1),
                Step::EndPass,
                Step::BeginPass(1),
                Step::ExecuteSecondaries(
                    vec![
                        vec![Step::Bind(1), Step::Draw(0)],
                        vec![Step::Bind(1), Step::Draw(1), Step::DrawPushed(1)],
                    ],
                    Recording::MainThread,
                ),
                Step::EndPass,
            ],
        };
        assert_eq!(
            plan.draw_census(),
            vec![(0, Target::Shadow, false, 2), (1, Target::Main, false, 3)]
        );
    }

    #[test]
    fn compare_ops_evaluate_like_vulkan() {
        let ops = [
            (Compare::Never, [false, false, false]),
            (Compare::Less, [true, false, false]),
            (Compare::Equal, [false, true, false]),
            (Compare::LessOrEqual, [true, true, false]),
            (Compare::Greater, [false, false, true]),
            (Compare::NotEqual, [true, false, true]),
            (Compare::GreaterOrEqual, [false, true, true]),
            (Compare::Always, [true, true, true]),
        ];
        for (op, expected) in ops {
            // reference below, equal to, above the stored 0.5
            let got = [0.25, 0.5, 0.75].map(|reference| op.passes(reference, 0.5));
            assert_eq!(got, expected, "{op:?}");
        }
    }

    #[test]
    fn the_single_pass_plan_is_valid() {
        let plan = Plan::single_pass(3);
        plan.check(3, false).unwrap();
        assert_eq!(plan.needs(), Needs::default());
        assert_eq!(plan.main_clear_depth(), 1.0);
        assert!(
            plan.check(2, false).is_err(),
            "draws an object that does not exist"
        );
    }

    #[test]
    fn partial_pushes_must_cover_what_a_draw_reads() {
        let base = Plan::single_pass(2);
        let with_steps = |steps: Vec<Step>| Plan {
            steps,
            ..base.clone()
        };
        let push = |object, offset, size| Step::Push {
            object,
            offset,
            size,
        };
        let framed = |middle: Vec<Step>| {
            let mut steps = vec![Step::BeginPass(0), Step::Bind(0)];
            steps.extend(middle);
            steps.push(Step::EndPass);
            with_steps(steps)
        };
        // A draw before anything was pushed.
        assert!(framed(vec![Step::DrawPushed(0)]).check(2, false).is_err());
        // Two partial pushes covering all 80 bytes, or a full draw before.
        framed(vec![push(0, 0, 32), push(0, 32, 48), Step::DrawPushed(0)])
            .check(2, false)
            .unwrap();
        framed(vec![Step::Draw(0), push(1, 64, 16), Step::DrawPushed(1)])
            .check(2, false)
            .unwrap();
        // A gap (48..64 never pushed).
        assert!(
            framed(vec![push(0, 0, 48), push(0, 64, 16), Step::DrawPushed(0)])
                .check(2, false)
                .is_err()
        );
        // Misaligned, empty, or beyond the program's 80 bytes.
        for bad in [push(0, 2, 16), push(0, 0, 0), push(0, 64, 32)] {
            assert!(framed(vec![Step::Draw(0), bad]).check(2, false).is_err());
        }
        // Binding a pipeline with another push-constant size forgets what was pushed.
        let mut plan = framed(vec![
            Step::Draw(0),
            Step::Bind(1),
            Step::Bind(0),
            Step::DrawPushed(0),
        ]);
        plan.pipelines.push(PipelineSpec {
            program: Program::MvpPair,
            ..PipelineSpec::standard("pair", 0)
        });
        assert!(plan.check(2, false).is_err());
        plan.pipelines[1].program = Program::RowMajor;
        plan.check(2, false).unwrap();
    }

    #[test]
    fn a_buffer_delivery_replaces_the_flat_program_and_drops_the_pushes() {
        let plan = Plan::single_pass(2);
        assert_eq!(plan.with_delivery(Delivery::Push).unwrap(), plan);
        for delivery in [Delivery::Ubo, Delivery::UboDynamic, Delivery::Ssbo] {
            let taken = plan.with_delivery(delivery).unwrap();
            let program = delivery.program().unwrap();
            assert_eq!(taken.pipelines[0].program, program);
            assert_eq!(taken.buffer_program(), Some(program));
            assert_eq!(program.push_constant_size(), 0);
            taken.check(2, false).unwrap();
            // A push into a program without push constants is malformed.
            let mut pushing = taken.clone();
            pushing.steps.insert(
                2,
                Step::Push {
                    object: 0,
                    offset: 0,
                    size: 16,
                },
            );
            assert!(pushing.check(2, false).is_err());
            // Two buffer deliveries in one plan share no buffers.
            let mut mixed = taken.clone();
            let other = if program == Program::Ssbo {
                Program::Ubo
            } else {
                Program::Ssbo
            };
            mixed.pipelines.push(PipelineSpec {
                program: other,
                ..PipelineSpec::standard("other", 0)
            });
            mixed.steps.insert(2, Step::Bind(1));
            assert!(mixed.check(2, false).is_err());
        }
        // Other programs, partial pushes and shadow passes refuse.
        let mut pair = plan.clone();
        pair.pipelines[0].program = Program::MvpPair;
        assert!(pair.with_delivery(Delivery::Ubo).is_err());
        let mut partial = plan.clone();
        partial.steps[3] = Step::DrawPushed(1);
        assert!(partial.with_delivery(Delivery::Ssbo).is_err());
        assert!(plan.buffer_program().is_none());
    }

    #[test]
    fn threaded_secondaries_are_not_allocated_from_the_main_pool() {
        let mut plan = Plan::single_pass(2);
        let list = |n| vec![Step::Bind(0), Step::Draw(n)];
        plan.steps = vec![
            Step::BeginPass(0),
            Step::ExecuteSecondaries(vec![list(0), list(1)], Recording::ThreadPerSecondary),
            Step::EndPass,
        ];
        plan.check(2, false).unwrap();
        assert_eq!(plan.needs().secondaries, 0);
        plan.steps[1] = Step::ExecuteSecondaries(vec![list(0), list(1)], Recording::MainThread);
        assert_eq!(plan.needs().secondaries, 2);
    }

    #[test]
    fn multisampled_passes_are_checked_and_resolve_as_set() {
        let multisample = Multisample {
            samples: 4,
            depth_resolve: ResolveMode::SampleZero,
            sampled_depth: false,
        };
        let mut plan = Plan::single_pass(1);
        assert!(!plan.set_depth_resolve(ResolveMode::Average));
        plan.passes[0].multisample = Some(multisample);
        plan.check(1, false).unwrap();
        assert_eq!(plan.needs().multisample, Some(multisample));
        assert!(plan.set_depth_resolve(ResolveMode::Max));
        assert_eq!(
            plan.needs().multisample.map(|m| m.depth_resolve),
            Some(ResolveMode::Max)
        );

        let broken = |change: &dyn Fn(&mut Plan)| {
            let mut broken = plan.clone();
            change(&mut broken);
            broken.check(1, true).is_err()
        };
        for samples in [0, 1, 3, 128] {
            assert!(
                broken(&|p| p.passes[0].multisample = Some(Multisample {
                    samples,
                    ..multisample
                })),
                "{samples} samples"
            );
        }
        assert!(broken(&|p| p.passes[0].depth = DepthLoad::Load));
        assert!(broken(&|p| p.passes[0].load_color = true));
        assert!(broken(
            &|p| p.passes[0].kind = PassKind::DepthPrepassSubpasses
        ));
        assert!(broken(&|p| {
            p.passes[0].target = Target::Shadow;
            p.pipelines[0].program = Program::DepthOnly;
            p.pipelines[0].color_write = false;
        }));
        // A pipeline made for a single-sample pass is not used in a multisampled one.
        assert!(broken(&|p| {
            p.passes.push(PassSpec::clear(1.0));
            p.pipelines[0].pass = 1;
            p.steps.extend([Step::BeginPass(1), Step::EndPass]);
        }));
        // Two multisampled passes share one set of attachments: one sample count and mode.
        let second = |resolve| {
            move |p: &mut Plan| {
                p.passes.push(PassSpec {
                    multisample: Some(Multisample {
                        depth_resolve: resolve,
                        ..multisample
                    }),
                    ..PassSpec::clear(1.0)
                });
                p.steps.extend([
                    Step::BeginPass(1),
                    Step::Bind(0),
                    Step::Draw(0),
                    Step::EndPass,
                ]);
            }
        };
        assert!(!broken(&second(ResolveMode::Max)));
        assert!(broken(&second(ResolveMode::Average)));
    }

    #[test]
    fn library_pipelines_need_the_extension_and_a_render_pass_or_plain_rendering() {
        let mut plan = Plan::single_pass(1);
        plan.pipelines[0].libraries = true;
        plan.check(1, false).unwrap();
        assert_eq!(
            plan.needs(),
            Needs {
                graphics_pipeline_library: true,
                ..Needs::default()
            }
        );
        // A plain dynamic rendering: the libraries chain its rendering info.
        plan.passes[0].kind = PassKind::DynamicRendering;
        plan.check(1, false).unwrap();
        // A local-read one: not built here.
        plan.passes[0].kind = PassKind::DynamicRenderingLocalRead { indexed: false };
        let error = plan.check(1, false).unwrap_err();
        assert!(error.0.contains("library pipelines"), "{error}");
    }

    #[test]
    fn a_local_read_rendering_reads_its_depth_after_its_barrier() {
        // The overlap plan, then a band reading the depth after the by-region barrier.
        let mut plan = Plan::single_pass(2);
        plan.passes[0].kind = PassKind::DynamicRenderingLocalRead { indexed: false };
        plan.pipelines.push(PipelineSpec {
            subpass: 1,
            program: Program::DepthInputUndecorated,
            depth_test: DepthTest::Off,
            depth_write: false,
            ..PipelineSpec::standard("band", 0)
        });
        let end = plan.steps.len() - 1;
        plan.steps
            .splice(end..end, [Step::NextSubpass, Step::Bind(1), Step::Draw(1)]);
        plan.check(2, false).unwrap();
        assert_eq!(
            plan.needs(),
            Needs {
                dynamic_rendering: true,
                dynamic_rendering_local_read: true,
                input_depth: true,
                ..Needs::default()
            }
        );
        // Before the barrier, no input attachment is readable.
        let mut early = plan.clone();
        early.pipelines[1].subpass = 0;
        assert!(early.check(2, false).is_err());
        // Plain dynamic rendering has no barrier step, nor input attachments.
        let mut plain = plan.clone();
        plain.passes[0].kind = PassKind::DynamicRendering;
        assert!(plain.check(2, false).is_err());
        // The explicit mapping reads the decorated variable.
        let mut indexed = plan.clone();
        indexed.passes[0].kind = PassKind::DynamicRenderingLocalRead { indexed: true };
        assert!(indexed.check(2, false).is_err());
        indexed.pipelines[1].program = Program::DepthInput;
        indexed.check(2, false).unwrap();
        // No secondaries inside a local-read rendering (a plain one takes them).
        let mut secondaries = plan.clone();
        secondaries.steps.splice(
            1..4,
            [Step::ExecuteSecondaries(
                vec![vec![Step::Bind(0), Step::Draw(0), Step::Draw(1)]],
                Recording::MainThread,
            )],
        );
        let error = secondaries.check(2, false).unwrap_err();
        assert!(
            error.0.contains("plain single-sample renderings"),
            "{error}"
        );
    }

    #[test]
    fn check_rejects_malformed_plans() {
        let base = Plan::single_pass(1);
        let with_steps = |steps: Vec<Step>| Plan {
            steps,
            ..base.clone()
        };
        // A draw before any bind.
        let plan = with_steps(vec![
            Step::BeginPass(0),
            Step::Draw(0),
            Step::Bind(0),
            Step::EndPass,
        ]);
        assert!(plan.check(1, false).is_err());
        // A pass never ended.
        let plan = with_steps(vec![Step::BeginPass(0), Step::Bind(0), Step::Draw(0)]);
        assert!(plan.check(1, false).is_err());
        // Dynamic state on a static pipeline.
        let plan = with_steps(vec![
            Step::BeginPass(0),
            Step::Bind(0),
            Step::SetDepthCompareOp(Compare::Less),
            Step::Draw(0),
            Step::EndPass,
        ]);
        assert!(plan.check(1, false).is_err());
        // Inline commands and secondaries mixed in one subpass.
        let plan = with_steps(vec![
            Step::BeginPass(0),
            Step::Bind(0),
            Step::ExecuteSecondaries(
                vec![vec![Step::Bind(0), Step::Draw(0)]],
                Recording::MainThread,
            ),
            Step::EndPass,
        ]);
        assert!(plan.check(1, false).is_err());
        // A secondary that draws without binding its own pipeline.
        let plan = with_steps(vec![
            Step::BeginPass(0),
            Step::ExecuteSecondaries(vec![vec![Step::Draw(0)]], Recording::ThreadPerSecondary),
            Step::EndPass,
        ]);
        assert!(plan.check(1, false).is_err());
        // A dynamic compare op never set before the draw.
        let mut plan = base.clone();
        plan.pipelines[0].depth_test = DepthTest::Dynamic;
        assert!(plan.check(1, false).is_err());
        plan.steps.insert(2, Step::SetDepthCompareOp(Compare::Less));
        plan.check(1, false).unwrap();
        assert!(plan.needs().dynamic_compare_op);
    }
}
