//! Scenes as pure data (no Vulkan): a camera (and, for shadow maps, a light), generated
//! meshes, model matrices and colors, the scene's [`Plan`] (passes, pipelines and steps), and
//! what the renderer derives from them (the shared vertex/index arrays, the draw ranges and the
//! per-object push constants).
//!
//! Conventions: right-handed world, y up; Vulkan clip space with depth in [0, 1] (standard,
//! not reversed: near = 0, far = 1, compare LESS) and y pointing down, obtained by flipping
//! the y row of glam's right-handed [0, 1]-depth perspective (the former
//! `DMat4::perspective_rh`, `glam::dcamera::rh::proj::directx::perspective` since glam 0.34);
//! the viewport height stays positive. A camera may instead use OpenGL's [-1, 1] depth or an
//! already reversed projection ([`Projection`]). Every matrix is computed in f64; each
//! object's precomposed MVP = P * V * M is rounded once to f32, which is what most
//! applications push. Objects may also carry their model (or model-view) transform in their
//! vertices ([`Space`]), and programs lay their push constants out differently
//! ([`Scene::push_constants_in`]).
//!
//! Adding a scene: add a variant to [`SceneId`] and a row to [`crate::scenes::CATALOG`] naming
//! a builder function that returns a [`Scene`].

use clap::ValueEnum;
use glam::dcamera::rh::{proj, view};
use glam::{DMat4, DVec3, DVec4};

use crate::plan::{Delivery, Plan, Program};

/// The scenes the tester can render (`--scene`); each variant's documentation is on its
/// builder in [`crate::scenes`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, ValueEnum)]
pub enum SceneId {
    /// Three cubes overlapping on screen at different depths, a tilted slab cutting through
    /// the middle one, and a ground plane.
    Overlap,
    /// Static compare ops: depth pre-pass (LESS), EQUAL color pass, LESS_OR_EQUAL coplanar
    /// overlay, GREATER, ALWAYS and NEVER objects.
    CompareOps,
    /// The same with `vkCmdSetDepthCompareOp` between draws of one pipeline.
    CompareOpsDynamic,
    /// `compare-ops` with its depth pre-pass drawn farthest first.
    CompareOpsUnsorted,
    /// Depth cleared to 0.985 by the render pass.
    ClearRenderPass,
    /// `vkCmdClearAttachments` of a depth rectangle to 0.98 between draws.
    ClearAttachments,
    /// `vkCmdClearDepthStencilImage` to 0.98, then a render pass that loads depth.
    ClearImage,
    /// Coplanar decals pulled forward by a static depth bias (with clamp).
    DepthBias,
    /// The same with `vkCmdSetDepthBias`, a different bias per decal.
    DepthBiasDynamic,
    /// Depth bounds [0, 0.975], static and dynamic (needs the `depthBounds` feature).
    DepthBounds,
    /// A sky quad drawn at viewport depth [1, 1] with LESS_OR_EQUAL behind everything.
    ViewportSky,
    /// A first-person weapon at viewport depth [0, 0.1], the world at [0.1, 1], one dynamic
    /// viewport at [0.5, 1].
    ViewportSplit,
    /// Depth outside [0, 1] (`VK_EXT_depth_range_unrestricted`): a clear to 1.5, the world at
    /// viewport depth [-20, 1.5], a cube at [1.2, 1.4], and a cube beyond the far plane drawn
    /// with depth clamping.
    DepthRangeUnrestricted,
    /// The same cleared to 1.0: what its viewport carries beyond 1 vanishes.
    DepthRangeUnrestrictedClearOne,
    /// Stencil mask (ref 1) and objects drawn with stencil EQUAL / NOT_EQUAL 1.
    Stencil,
    /// The overlap scene recorded into two secondary command buffers.
    Secondary,
    /// The overlap scene as a depth pre-pass subpass and an EQUAL color subpass.
    Subpasses,
    /// The overlap scene with dynamic rendering, then a second loading pass drawing more.
    DynamicRendering,
    /// `dynamic-rendering`'s draws in one rendering recorded as a suspended instance and the
    /// instance resuming it.
    DynamicRenderingSuspended,
    /// The same with the resumed instance in a second primary command buffer.
    DynamicRenderingSuspendedAcross,
    /// `secondary` in a dynamic rendering, its secondaries recorded on threads inheriting
    /// the rendering's formats.
    DynamicRenderingSecondaries,
    /// A shadow map (D32, sampled with a comparison sampler) darkening the ground.
    ShadowMap,
    /// `shadow-map` with both passes drawn from secondaries recorded on threads, half of them
    /// inheriting the render pass without its framebuffer.
    ShadowMapSecondaries,
    /// `shadow-map` whose receiver reads the map's raw depth (texel fetches and a nearest
    /// sample through a plain sampler) and compares it in the shader.
    ShadowMapRaw,
    /// `shadow-map` with an X8_D24 shadow map (promoted in the precise modes, and read through
    /// its X8_D24 twin).
    #[value(name = "shadow-map-x8-d24")]
    ShadowMapX8D24,
    /// `shadow-map` lit by a spot light: a perspective shadow pass, a second camera.
    ShadowMapPerspective,
    /// `shadow-map-perspective` with each pass's draws in secondaries.
    ShadowMapPerspectiveSecondaries,
    /// The overlap scene, then soft particles (the depth attached read-only and sampled at
    /// once) and a post pass sampling the depth (fetch, bilinear, gather).
    DepthReads,
    /// The overlap scene with stencil writes, then a post pass sampling the depth-stencil
    /// image's stencil and depth aspects.
    StencilReads,
    /// The overlap scene, then a later subpass of the same render pass reading its depth as
    /// an input attachment (`subpassLoad`) to shade the bottom quarter, without a depth
    /// attachment.
    DeferredDepth,
    /// `deferred-depth` with the depth also attached read-only in the later subpass, the band
    /// drawn at a fixed depth with LESS_OR_EQUAL.
    DeferredDepthTested,
    /// `deferred-depth` and `deferred-depth-tested` with every pipeline built from
    /// `VK_EXT_graphics_pipeline_library` libraries linked together.
    DeferredDepthLibrary,
    DeferredDepthTestedLibrary,
    /// `deferred-depth` with subpass 0's draws recorded into two secondaries on two threads,
    /// the second inheriting the render pass and subpass without the framebuffer.
    DeferredDepthSecondaries,
    /// `deferred-depth` in one dynamic rendering: its depth read back as an input attachment
    /// in the same rendering after a by-region barrier (`VK_KHR_dynamic_rendering_local_read`),
    /// through the default mapping (an input attachment without `InputAttachmentIndex`).
    DeferredDepthLocalRead,
    /// `deferred-depth-local-read` with the depth mapped to input attachment index 0 in the
    /// pipelines and on the command buffer (`vkCmdSetRenderingInputAttachmentIndicesKHR`).
    DeferredDepthLocalReadIndexed,
    /// `deferred-depth-tested` in one local-read dynamic rendering, as
    /// `deferred-depth-local-read` renders `deferred-depth`.
    DeferredDepthLocalReadTested,
    /// The overlap scene into mip level 0 of a depth image of 3 levels, levels 1 and 2 built
    /// from the level below by a fragment shader writing `gl_FragDepth` (each level sampled
    /// after a barrier of that level alone), then a post pass shading bands from levels 1
    /// and 2.
    DepthMips,
    /// The overlap scene into layer 0 of a 2-layer depth image, the same scene with the near
    /// cube moved into layer 1 (depth only), then a post pass shading a band from each layer
    /// through a 2D-array view.
    DepthLayers,
    /// `depth-layers` with layer 1 rendered twice, each time followed by a barrier of both
    /// layers into `SHADER_READ_ONLY_OPTIMAL`.
    DepthLayersStepwise,
    /// The overlap scene drawn once into both views of a multiview render pass (two eyes, a
    /// 2-layer color and depth image), then a post pass shading a band from each layer's depth.
    Multiview,
    /// `multiview` with dynamic rendering (`VkRenderingInfo::viewMask`).
    MultiviewDynamic,
    /// The overlap scene at 4x MSAA in a `vkCreateRenderPass2` render pass, color and depth
    /// resolved into the main images (`--depth-resolve`).
    MsaaResolve,
    /// The same with dynamic rendering's `resolveMode` / `resolveImageView`.
    MsaaResolveDynamic,
    /// The overlap scene at 4x MSAA with its depth kept (sampled, not resolved), then a post
    /// pass shading the bottom 45% from each pixel's four depth samples.
    DepthReadsMsaa,
    /// A fragment shader writing `gl_FragDepth = 0.5 + 0.5 * gl_FragCoord.z`: a near card
    /// pushed behind a farther one, in front of a far wall.
    FragDepth,
    /// `frag-depth` with every pipeline built from graphics pipeline libraries.
    FragDepthLibrary,
    /// `frag-depth-library` in a dynamic rendering.
    FragDepthLibraryDynamic,
    /// The overlap scene, decals with a static depth bias and a sky at viewport depth [1, 1],
    /// every pipeline linked from `VK_EXT_graphics_pipeline_library` libraries.
    PipelineLibrary,
    /// `pipeline-library` in a dynamic rendering.
    PipelineLibraryDynamic,
    /// Push constants hold only the projection P; vertices are in view space.
    ProjectionOnly,
    /// Push constants hold P * V; vertices are in world space (a far-reaching scene).
    ViewProjection,
    /// Push constants hold a model matrix and a view-projection matrix.
    ModelViewProjectionPair,
    /// HLSL-style layouts: a `RowMajor` MVP, and `position * M`.
    RowMajor,
    /// An OpenGL-convention projection with `negativeOneToOne` depth clip control.
    OpenglDepth,
    /// The application already renders reversed: complementary projection, clear 0, GREATER.
    AlreadyReversed,
    /// Push constants updated in parts between draws.
    PushPartial,
    /// The overlap scene recorded on four threads into secondaries.
    Threads,
    /// Lit boxes: the pushed MVP also feeds the lighting (view vector, face normal, specular),
    /// so a changed depth row changes the colors.
    LitMvp,
    /// Accuracy: seed 001's red mesh over a green plane, half parallel, half sloping down.
    SlopedPlane,
    /// Accuracy: seed 001's terrain patch 600 m over Mars, seen from 10 km, world coordinates.
    MarsPatch,
    /// Accuracy: two interpenetrating tori far from the eye.
    Tori,
    /// Accuracy: pairs of parallel planes over distances and relative separations.
    PlaneStack,
    /// Accuracy: near 1e-3, far 1e7, pairs of surfaces 1 % apart at every decade.
    DeepRange,
    /// Accuracy: coplanar decals held in front of their walls by depth bias alone.
    DecalBias,
    /// Accuracy: boxes from 10 n to 1e6 n, each with its own P * V * M, touching and
    /// intersecting pairs drawn with different matrices; camera far from the origin.
    FarObjects,
}

impl SceneId {
    /// The CLI / report name of the scene.
    pub fn name(self) -> &'static str {
        crate::scenes::entry(self).name
    }

    /// Builds the scene.
    pub fn build(self) -> Scene {
        (crate::scenes::entry(self).build)()
    }
}

/// A perspective camera.
#[derive(Clone, Debug, PartialEq)]
pub struct Camera {
    /// Eye position (world).
    pub eye: DVec3,
    /// Point looked at (world).
    pub target: DVec3,
    /// Up direction (world).
    pub up: DVec3,
    /// Vertical field of view, radians.
    pub fov_y: f64,
    /// Near plane distance (> 0).
    pub near: f64,
    /// Far plane distance (> near).
    pub far: f64,
    /// The depth convention of its projection.
    pub projection: Projection,
}

/// The depth convention of a camera's projection (every one is y-down and maps `near` and
/// `far` to the ends of its depth range).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Projection {
    /// Vulkan standard: z_ndc = 0 at near, 1 at far (what revz expects applications to use).
    Standard,
    /// OpenGL: z_ndc = -1 at near, 1 at far; drawn with `negativeOneToOne` depth clip control,
    /// so the stored depth is (z_ndc + 1) / 2, the same as [`Projection::Standard`]'s.
    OpenGl,
    /// Complementary (reversed finite): z_ndc = 1 at near, 0 at far; drawn with GREATER into a
    /// depth buffer cleared to 0.
    Reversed,
}

impl Projection {
    /// The stored depth (viewport [0, 1]) of a point at view distance `w`, in f64.
    #[cfg(test)]
    pub fn stored_depth(self, near: f64, far: f64, w: f64) -> f64 {
        match self {
            Projection::Standard | Projection::OpenGl => far / (far - near) * (1.0 - near / w),
            Projection::Reversed => near * (far - w) / (w * (far - near)),
        }
    }

    /// Whether clip-space depth runs over [-w, w] (OpenGL) rather than [0, w].
    pub fn negative_one_to_one(self) -> bool {
        self == Projection::OpenGl
    }
}

/// Negates clip-space y: glam's projections are y-up, Vulkan's framebuffer y points down.
pub fn vulkan_y_flip() -> DMat4 {
    DMat4::from_diagonal(DVec4::new(1.0, -1.0, 1.0, 1.0))
}

impl Camera {
    /// World -> view (right-handed, looking down -z).
    pub fn view(&self) -> DMat4 {
        view::look_at_mat4(self.eye, self.target, self.up)
    }

    /// View -> Vulkan clip space (y down) with the camera's depth convention: standard
    /// z_ndc = 0 at `near`, 1 at `far`; OpenGL -1 at `near`, 1 at `far`; reversed 1 at `near`,
    /// 0 at `far`.
    pub fn projection(&self, aspect: f64) -> DMat4 {
        let (fov, near, far) = (self.fov_y, self.near, self.far);
        vulkan_y_flip()
            * match self.projection {
                Projection::Standard => proj::directx::perspective(fov, aspect, near, far),
                Projection::OpenGl => proj::opengl::perspective(fov, aspect, near, far),
                // The [0, 1] perspective with the planes swapped: depth 1 at `near`, 0 at `far`.
                Projection::Reversed => proj::directx::perspective(fov, aspect, far, near),
            }
    }

    /// Unit view direction (world).
    pub fn forward(&self) -> DVec3 {
        (self.target - self.eye).normalize()
    }
}

/// An orthographic light "camera" (shadow maps): standard [0, 1] depth, y down like
/// [`Camera::projection`].
#[derive(Clone, Debug, PartialEq)]
pub struct Light {
    /// Light position (world).
    pub eye: DVec3,
    /// Point looked at (world).
    pub target: DVec3,
    /// Up direction (world; not parallel to the view direction).
    pub up: DVec3,
    /// Half the width and height of the orthographic box; for a perspective light, of its
    /// frustum at the distance of `target`.
    pub half_extent: f64,
    /// A spot light's perspective projection instead of an orthographic one.
    pub perspective: bool,
    /// Near plane distance.
    pub near: f64,
    /// Far plane distance (> near).
    pub far: f64,
    /// The shadow map's depth format ([`crate::target::SHADOW_MAP_FORMAT`] unless a scene
    /// says otherwise).
    pub map_format: ash::vk::Format,
}

impl Light {
    /// World -> light clip space: orthographic or perspective, z = 0 at `near`, 1 at `far`.
    pub fn view_projection(&self) -> DMat4 {
        let h = self.half_extent;
        let projection = if self.perspective {
            let fov_y = 2.0 * (h / (self.target - self.eye).length()).atan();
            proj::directx::perspective(fov_y, 1.0, self.near, self.far)
        } else {
            proj::directx::orthographic(-h, h, -h, h, self.near, self.far)
        };
        vulkan_y_flip() * projection * view::look_at_mat4(self.eye, self.target, self.up)
    }
}

/// How far a multiview pass's second eye sits to the right of the first
/// ([`Scene::view_cameras`]): a wide interocular distance for the overlap scene's units (a
/// meter-sized cube 4 to 8 away), so that the second view's image differs from the first by
/// several pixels of disparity.
pub const MULTIVIEW_EYE_SEPARATION: f64 = 0.2;

/// Which view-projection a draw uses: the pass's target decides.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum View {
    /// The camera's perspective (main passes).
    Camera,
    /// The light's projection (shadow passes).
    Light,
}

/// Generated geometry: f32 positions and u32 triangle-list indices into them.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Mesh {
    /// Vertex positions (model space).
    pub positions: Vec<[f32; 3]>,
    /// Triangle list, indices into `positions`.
    pub indices: Vec<u32>,
}

impl Mesh {
    /// Appends a quad `center ± u ± v`, wound counter-clockwise around `u × v`.
    fn push_quad(&mut self, center: DVec3, u: DVec3, v: DVec3) {
        let base = u32::try_from(self.positions.len()).expect("mesh too large");
        for corner in [
            center - u - v,
            center + u - v,
            center + u + v,
            center - u + v,
        ] {
            self.positions.push(corner.as_vec3().to_array());
        }
        self.indices
            .extend([base, base + 1, base + 2, base, base + 2, base + 3]);
    }

    /// An axis-aligned box centered on the origin: 6 faces of 4 vertices each (so later
    /// scenes can give faces their own attributes), counter-clockwise seen from outside.
    pub fn cuboid(half_extents: DVec3) -> Mesh {
        let (x, y, z) = (
            DVec3::X * half_extents.x,
            DVec3::Y * half_extents.y,
            DVec3::Z * half_extents.z,
        );
        let mut mesh = Mesh::default();
        // (face center, u, v) with u × v along the outward normal.
        for (center, u, v) in [
            (x, y, z),
            (-x, z, y),
            (y, z, x),
            (-y, x, z),
            (z, x, y),
            (-z, y, x),
        ] {
            mesh.push_quad(center, u, v);
        }
        mesh
    }

    /// A rectangle in the xz plane (y = 0) centered on the origin, facing +y.
    pub fn quad(half_width: f64, half_depth: f64) -> Mesh {
        let mut mesh = Mesh::default();
        mesh.push_quad(DVec3::ZERO, DVec3::Z * half_depth, DVec3::X * half_width);
        mesh
    }

    /// A rectangle in the xy plane (z = 0) centered on (x, y), facing +z: walls, decals,
    /// portals.
    pub fn rect_xy(x: f64, y: f64, half_width: f64, half_height: f64) -> Mesh {
        let mut mesh = Mesh::default();
        mesh.push_quad(
            DVec3::new(x, y, 0.0),
            DVec3::X * half_width,
            DVec3::Y * half_height,
        );
        mesh
    }

    /// A full-screen quad for a [`Space::Clip`] object: clip x, y in [-1, 1] at clip depth
    /// `z` (w = 1).
    pub fn clip_quad(z: f64) -> Mesh {
        let mut mesh = Mesh::default();
        mesh.push_quad(DVec3::new(0.0, 0.0, z), DVec3::X, DVec3::Y);
        mesh
    }

    /// The tiles `(i, j)` (for which `keep` is true) of an n x n grid over the rectangle of
    /// [`Mesh::quad`], each tile with its own 4 vertices: two grids built with different
    /// `keep` share the exact vertex positions and triangles of the tiles they both keep, so
    /// those tiles rasterize to identical depths (coplanar overlays).
    pub fn grid(half_width: f64, half_depth: f64, n: u32, keep: impl Fn(u32, u32) -> bool) -> Mesh {
        let mut mesh = Mesh::default();
        let (tile_w, tile_d) = (
            2.0 * half_width / f64::from(n),
            2.0 * half_depth / f64::from(n),
        );
        for i in 0..n {
            for j in 0..n {
                if !keep(i, j) {
                    continue;
                }
                let center = DVec3::new(
                    -half_width + (f64::from(i) + 0.5) * tile_w,
                    0.0,
                    -half_depth + (f64::from(j) + 0.5) * tile_d,
                );
                mesh.push_quad(center, DVec3::Z * tile_d * 0.5, DVec3::X * tile_w * 0.5);
            }
        }
        mesh
    }

    /// The mesh moved by `offset` (model space).
    pub fn translated(mut self, offset: DVec3) -> Mesh {
        for p in &mut self.positions {
            *p = (DVec3::new(f64::from(p[0]), f64::from(p[1]), f64::from(p[2])) + offset)
                .as_vec3()
                .to_array();
        }
        self
    }

    /// The positions as f64 (exactly the f32 values the GPU gets).
    pub fn positions_f64(&self) -> impl Iterator<Item = DVec3> + '_ {
        self.positions
            .iter()
            .map(|p| DVec3::new(f64::from(p[0]), f64::from(p[1]), f64::from(p[2])))
    }

    /// The triangles, as f64 model-space corners.
    #[cfg(test)]
    pub fn triangles(&self) -> impl Iterator<Item = [DVec3; 3]> + '_ {
        let p = |i: u32| {
            let q = self.positions[i as usize];
            DVec3::new(f64::from(q[0]), f64::from(q[1]), f64::from(q[2]))
        };
        self.indices
            .chunks_exact(3)
            .map(move |t| [p(t[0]), p(t[1]), p(t[2])])
    }

    /// Center of the axis-aligned bounding box (model space).
    pub fn bounds_center(&self) -> DVec3 {
        let mut min = DVec3::splat(f64::INFINITY);
        let mut max = DVec3::splat(f64::NEG_INFINITY);
        for p in self.positions_f64() {
            min = min.min(p);
            max = max.max(p);
        }
        if self.positions.is_empty() {
            DVec3::ZERO
        } else {
            (min + max) * 0.5
        }
    }
}

/// One drawn object.
#[derive(Clone, Debug, PartialEq)]
pub struct Object {
    /// A short name for reports and tests.
    pub name: &'static str,
    /// Model-space geometry.
    pub mesh: Mesh,
    /// Model -> world.
    pub model: DMat4,
    /// Flat RGBA color (values k/255, so the UNORM color attachment stores them exactly).
    pub color: [f32; 4],
    /// Whether `model` maps to world space (then the view's projection applies) or directly
    /// to clip space.
    pub space: Space,
}

/// The space an object's model matrix maps to, and where it is applied.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Space {
    /// World space: MVP = P * V * model.
    World,
    /// Clip space: MVP = model, whatever the view (full-screen passes, a hard-coded clip z).
    Clip,
    /// World space, applied on the CPU: the vertex buffer holds `model * p` (computed in f64,
    /// rounded once to f32) and the pushed matrix is P * V.
    WorldBaked,
    /// View space, applied on the CPU: the vertex buffer holds `V * model * p` for the camera
    /// and the pushed matrix is P alone.
    ViewBaked,
}

impl Object {
    /// A world-space object.
    pub fn world(name: &'static str, mesh: Mesh, model: DMat4, color: [f32; 4]) -> Object {
        Object {
            name,
            mesh,
            model,
            color,
            space: Space::World,
        }
    }

    /// A full-screen clip-space quad at clip depth 0.5 (its depth comes from the viewport or
    /// is ignored by the pipeline).
    pub fn full_screen(name: &'static str, color: [f32; 4]) -> Object {
        Object {
            name,
            mesh: Mesh::clip_quad(0.5),
            model: DMat4::IDENTITY,
            color,
            space: Space::Clip,
        }
    }

    /// World-space center of the mesh's bounding box.
    pub fn world_center(&self) -> DVec3 {
        self.model.transform_point3(self.mesh.bounds_center())
    }
}

/// An opaque color from 8-bit components (exactly representable in R8G8B8A8_UNORM).
pub fn rgb8(r: u8, g: u8, b: u8) -> [f32; 4] {
    [
        f32::from(r) / 255.0,
        f32::from(g) / 255.0,
        f32::from(b) / 255.0,
        1.0,
    ]
}

/// Where one object's indices lie in the shared index buffer (arguments of vkCmdDrawIndexed).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DrawRange {
    /// First index in the shared index buffer.
    pub first_index: u32,
    /// Number of indices.
    pub index_count: u32,
    /// Added to each index: the object's first vertex in the shared vertex buffer.
    pub vertex_offset: i32,
}

/// Every object's geometry packed into one vertex array and one index array.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Geometry {
    /// All positions.
    pub positions: Vec<[f32; 3]>,
    /// All indices (relative to each object's `vertex_offset`).
    pub indices: Vec<u32>,
    /// One range per object, in draw order.
    pub draws: Vec<DrawRange>,
}

impl Geometry {
    /// The positions as little-endian bytes (12 bytes per vertex).
    pub fn position_bytes(&self) -> Vec<u8> {
        self.positions
            .iter()
            .flatten()
            .flat_map(|v| v.to_le_bytes())
            .collect()
    }

    /// The indices as little-endian bytes.
    pub fn index_bytes(&self) -> Vec<u8> {
        self.indices.iter().flat_map(|v| v.to_le_bytes()).collect()
    }
}

/// A camera (and optionally a light), objects, and the plan that records them.
#[derive(Clone, Debug, PartialEq)]
pub struct Scene {
    /// The scene's name (as on the CLI).
    pub name: &'static str,
    /// The camera.
    pub camera: Camera,
    /// The light of shadow passes, if any.
    pub light: Option<Light>,
    /// The objects; [`crate::plan::Step::Draw`] names them by index.
    pub objects: Vec<Object>,
    /// What is recorded.
    pub plan: Plan,
}

mod derived;

/// A cube resting on the ground, sunk 0.05 into it (so no face is coplanar with the ground),
/// turned by `yaw` radians about the vertical.
pub fn grounded_cube(
    name: &'static str,
    half: f64,
    x: f64,
    z: f64,
    yaw: f64,
    color: [f32; 4],
) -> Object {
    Object {
        name,
        mesh: Mesh::cuboid(DVec3::splat(half)),
        model: DMat4::from_translation(DVec3::new(x, half - 0.05, z)) * DMat4::from_rotation_y(yaw),
        color,
        space: Space::World,
    }
}

/// The `overlap` scene: three cubes of different sizes at different depths overlapping on
/// screen, a thin tilted slab cutting through the middle cube, and a 20 x 20 ground quad.
pub fn overlap() -> Scene {
    Scene::new("overlap", overlap_camera(), overlap_objects())
}

/// The camera of the `overlap` scene (and of most others): eye (0, 2, 6) looking at the
/// origin, 45 degrees vertical field of view, near 0.1, far 100.
pub fn overlap_camera() -> Camera {
    Camera {
        eye: DVec3::new(0.0, 2.0, 6.0),
        target: DVec3::ZERO,
        up: DVec3::Y,
        fov_y: 45f64.to_radians(),
        near: 0.1,
        far: 100.0,
        projection: Projection::Standard,
    }
}

/// The objects of the `overlap` scene, unsorted.
pub fn overlap_objects() -> Vec<Object> {
    let near_cube = grounded_cube("near cube", 0.5, -0.75, 1.9, 0.35, rgb8(230, 30, 30));
    let middle_cube = grounded_cube("middle cube", 0.75, 0.35, -0.2, -0.45, rgb8(30, 200, 40));
    let far_cube = grounded_cube("far cube", 1.2, -0.55, -3.4, 0.2, rgb8(40, 80, 240));
    let slab = Object {
        name: "slab",
        mesh: Mesh::cuboid(DVec3::new(1.5, 0.06, 0.9)),
        // Centered inside the middle cube, tilted about z and x so that it cuts through two
        // of the cube's visible faces along slanted lines.
        model: DMat4::from_translation(DVec3::new(0.35, 0.8, -0.2))
            * DMat4::from_rotation_z(28f64.to_radians())
            * DMat4::from_rotation_x(25f64.to_radians()),
        color: rgb8(250, 210, 20),
        space: Space::World,
    };
    // The ground extends 20 x 20, from z = -14 (far) to z = 6 (below the eye), so that all of
    // it lies in front of the near plane.
    let ground = Object {
        name: "ground",
        mesh: Mesh::quad(10.0, 10.0),
        model: DMat4::from_translation(DVec3::new(0.0, 0.0, -4.0)),
        color: rgb8(150, 60, 170),
        space: Space::World,
    };
    vec![ground, far_cube, slab, middle_cube, near_cube]
}

#[cfg(test)]
mod tests {
    use super::*;

    const ASPECT: f64 = 1.0;

    fn ndc(mvp: &DMat4, p: DVec3) -> DVec3 {
        let clip = *mvp * p.extend(1.0);
        assert!(clip.w > 0.0, "vertex behind the eye: {p} -> {clip}");
        clip.truncate() / clip.w
    }

    /// NDC bounding rectangle (x, y) of an object.
    fn screen_bounds(scene: &Scene, object: &Object) -> (DVec3, DVec3) {
        let mvp = scene.mvp(object, ASPECT);
        let mut min = DVec3::splat(f64::INFINITY);
        let mut max = DVec3::splat(f64::NEG_INFINITY);
        for p in object.mesh.positions_f64() {
            let q = ndc(&mvp, p);
            min = min.min(q);
            max = max.max(q);
        }
        (min, max)
    }

    fn object<'a>(scene: &'a Scene, name: &str) -> &'a Object {
        scene
            .objects
            .iter()
            .find(|o| o.name == name)
            .unwrap_or_else(|| panic!("no object {name}"))
    }

    fn overlaps_on_screen(scene: &Scene, a: &str, b: &str) -> bool {
        let (amin, amax) = screen_bounds(scene, object(scene, a));
        let (bmin, bmax) = screen_bounds(scene, object(scene, b));
        amin.x < bmax.x && bmin.x < amax.x && amin.y < bmax.y && bmin.y < amax.y
    }

    #[test]
    fn every_vertex_is_between_near_and_far() {
        for id in SceneId::value_variants() {
            let scene = id.build();
            // OpenGL's clip depth runs over [-1, 1]; the others over [0, 1].
            let lowest = if scene.camera.projection.negative_one_to_one() {
                -1.0
            } else {
                0.0
            };
            let clamped = scene.plan.clamped_objects();
            for (n, object) in scene.objects.iter().enumerate() {
                if clamped.contains(&n) {
                    // Drawn with depth clamping, beyond a plane on purpose.
                    continue;
                }
                let mvp = scene.mvp(object, ASPECT);
                for p in scene.vertex_positions(object) {
                    let z = ndc(&mvp, p).z;
                    assert!(
                        (lowest..=1.0).contains(&z),
                        "{}: {}: {p} has depth {z}",
                        scene.name,
                        object.name
                    );
                }
            }
        }
    }

    #[test]
    fn draw_order_is_nearest_first() {
        // The other scenes order their draws deliberately (see `scenes`).
        let scene = overlap();
        let depths: Vec<f64> = scene.objects.iter().map(|o| scene.view_depth(o)).collect();
        assert!(
            depths.windows(2).all(|w| w[0] <= w[1]),
            "view depths not increasing: {depths:?}"
        );
        assert_eq!(scene.objects.first().unwrap().name, "near cube");
        assert_eq!(scene.objects.last().unwrap().name, "ground");
    }

    #[test]
    fn overlap_cubes_overlap_on_screen_and_fill_it() {
        let scene = overlap();
        assert!(overlaps_on_screen(&scene, "near cube", "middle cube"));
        assert!(overlaps_on_screen(&scene, "middle cube", "far cube"));
        assert!(overlaps_on_screen(&scene, "slab", "middle cube"));
        // Everything but the ground spans most of the image, and stays inside it.
        let mut min = DVec3::splat(f64::INFINITY);
        let mut max = DVec3::splat(f64::NEG_INFINITY);
        for o in scene.objects.iter().filter(|o| o.name != "ground") {
            let (lo, hi) = screen_bounds(&scene, o);
            min = min.min(lo);
            max = max.max(hi);
        }
        assert!(max.x - min.x > 1.0 && max.y - min.y > 1.0, "{min} {max}");
        assert!(
            min.x > -1.0 && min.y > -1.0 && max.x < 1.0 && max.y < 1.0,
            "{min} {max}"
        );
    }

    #[test]
    fn slab_cuts_through_the_middle_cube() {
        let scene = overlap();
        let cube = object(&scene, "middle cube");
        let slab = object(&scene, "slab");
        let to_cube = cube.model.inverse() * slab.model;
        let half = 0.75;
        let inside = |p: DVec3| p.abs().max_element() < half;
        let corners: Vec<DVec3> = slab
            .mesh
            .positions_f64()
            .map(|p| to_cube.transform_point3(p))
            .collect();
        assert!(inside(to_cube.transform_point3(DVec3::ZERO)));
        assert!(
            corners.iter().all(|&p| !inside(p)),
            "the slab sticks out on every side"
        );
        // Tilted: its corners are at several heights in the cube's frame.
        let heights: Vec<f64> = corners.iter().map(|p| p.y).collect();
        let spread = heights.iter().cloned().fold(f64::NEG_INFINITY, f64::max)
            - heights.iter().cloned().fold(f64::INFINITY, f64::min);
        assert!(spread > 0.5, "slab not tilted: {heights:?}");
    }

    #[test]
    fn projection_is_vulkan_standard_depth_with_y_down() {
        let camera = overlap().camera;
        let p = camera.projection(ASPECT);
        let at = |z: f64| {
            let c = p * DVec4::new(0.0, 0.0, -z, 1.0);
            c.z / c.w
        };
        assert!(at(camera.near).abs() < 1e-12);
        assert!((at(camera.far) - 1.0).abs() < 1e-12);
        // A point above the view axis lands in the upper half: negative y in Vulkan NDC.
        let c = p * DVec4::new(0.0, 1.0, -5.0, 1.0);
        assert!(c.y / c.w < 0.0);
        // The same as glam's own Vulkan-convention projection.
        let vulkan = proj::vulkan::perspective(camera.fov_y, ASPECT, camera.near, camera.far);
        assert_eq!(p, vulkan);
    }

    #[test]
    fn colors_are_distinct() {
        let scene = overlap();
        for (i, a) in scene.objects.iter().enumerate() {
            for b in &scene.objects[i + 1..] {
                assert_ne!(a.color, b.color, "{} and {}", a.name, b.name);
            }
        }
    }

    #[test]
    fn push_constants_are_rounded_mvp_then_color() {
        let scene = overlap();
        let object = &scene.objects[1];
        let bytes = scene.push_constants(Program::Flat, object, ASPECT);
        let floats: Vec<f32> = bytes
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes(c.try_into().unwrap()))
            .collect();
        let mvp = scene.mvp(object, ASPECT);
        for col in 0..4 {
            for row in 0..4 {
                assert_eq!(floats[col * 4 + row], mvp.col(col)[row] as f32);
            }
        }
        assert_eq!(&floats[16..], &object.color);
    }

    #[test]
    fn geometry_ranges_are_consistent() {
        let scene = overlap();
        let geometry = scene.geometry();
        assert_eq!(geometry.draws.len(), scene.objects.len());
        for (draw, object) in geometry.draws.iter().zip(&scene.objects) {
            let first = draw.first_index as usize;
            let indices = &geometry.indices[first..first + draw.index_count as usize];
            assert_eq!(indices, &object.mesh.indices[..]);
            for &i in indices {
                let v = geometry.positions[draw.vertex_offset as usize + i as usize];
                assert!(object.mesh.positions.contains(&v));
            }
        }
        assert_eq!(
            geometry.position_bytes().len(),
            geometry.positions.len() * 12
        );
    }

    #[test]
    fn cuboid_faces_wind_outward() {
        let mesh = Mesh::cuboid(DVec3::new(1.0, 2.0, 3.0));
        assert_eq!(mesh.positions.len(), 24);
        assert_eq!(mesh.indices.len(), 36);
        for [a, b, c] in mesh.triangles() {
            let normal = (b - a).cross(c - a);
            let centroid = (a + b + c) / 3.0;
            assert!(normal.dot(centroid) > 0.0, "inward triangle {a} {b} {c}");
        }
    }
}
