//! Ground truth, computed (no Vulkan, all f64): for a scene seen by one perspective camera in
//! which the nearest surface wins (every main-pass draw tests LESS with depth writes into a
//! buffer cleared to 1.0, or GREATER into 0.0 for an already reversed projection, full viewport,
//! nothing else touching depth, no fragment shader writing its own depth), which object is
//! visible at every pixel center, the view-space w of that surface there, and whether the pixel
//! is *interior*: its 3 x 3 neighbourhood of pixel centers all see the same object, so that which
//! triangle the rasterizer gives a pixel on a silhouette or an intersection line (its
//! tie-breaking rules, the float32 rounding of vertex positions) cannot matter. At an interior
//! pixel the rendered depth is a function of w alone (`D(w) = k + B / w` for the camera's
//! mapping), which is what the end-to-end tests compare against; the object ids serve any
//! per-pixel correctness measure (which surface should show).
//!
//! w comes from the f64 clip transforms ([`Scene::mvp_in`]) applied to the vertex positions
//! as uploaded (f32 values): what the application *meant*. The GPU evaluates f32-rounded
//! matrices; that difference is part of the float32 error budget the tests state, and using the
//! rounded matrices here would hide it. Screen-space interpolation is exact: for a planar
//! triangle 1/w is an affine function of the screen position, so `1/w = sum(l_i / w_i)` with
//! the screen-space barycentric coordinates `l_i` of the pixel center.
//!
//! Outputs (see `main.rs`): `expected-w.f64` (little-endian f64 per pixel, row-major, top row
//! first; NaN at background or non-interior pixels), `expected-id.u16` (little-endian u16 per
//! pixel: the visible object's index in the scene, [`BACKGROUND`] where nothing is), and the
//! `ground_truth` section of `render.json` ([`GroundTruthReport`]).

use glam::{DMat4, DVec3, DVec4};
use serde::Serialize;

use crate::plan::{Compare, DepthLoad, DepthTest, Program, Step, Target, Viewport};
use crate::scene::{Object, Projection, Scene, View};

/// The id of pixels no object covers.
pub const BACKGROUND: u16 = u16::MAX;

/// What is visible at every pixel center.
#[derive(Clone, Debug, PartialEq)]
pub struct GroundTruth {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// The visible object per pixel ([`BACKGROUND`] for none), row-major, top row first.
    pub ids: Vec<u16>,
    /// The visible surface's view-space w per pixel; NaN at background and non-interior
    /// pixels.
    pub w: Vec<f64>,
    /// The number of interior pixels (those with a finite `w`).
    pub interior: usize,
}

/// A triangle in clip space, with the object it belongs to.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ClipTriangle {
    /// The object's id.
    pub id: u16,
    /// The clip-space corners (w > 0).
    pub corners: [DVec4; 3],
}

/// One drawn object, as `render.json` lists it.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ObjectReport {
    /// The object's id: its index in the scene, as in `expected-id.u16`.
    pub id: u16,
    /// Its name.
    pub name: &'static str,
    /// Its flat color as the UNORM8 color attachment stores it (the shadow receiver darkens
    /// it where it is in shadow).
    pub color: [u8; 4],
    /// The outermost matrix its program pushes, as the shader applies it (`clip = M * v`),
    /// 16 f32 values column-major whatever the storage order: the matrix a layer rewriting
    /// projections sees. Its depth mapping is the object's (an inner model matrix is affine).
    pub pushed_projection: [f32; 16],
    /// The largest `c` over the object's vertices such that the GPU's float32 w (rounded
    /// matrices, float32 arithmetic) is within `(u + gamma_4) * c * w` of the exact one
    /// (u = 2^-24): `sum_i |m_3i v_i| / |w|` for one matrix stage, twice
    /// `sum_i |a_3i| sum_j |b_ij v_j| / |w|` for two (`a * (b * v)`).
    pub w_condition: f64,
}

/// The `ground_truth` section of `render.json`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct GroundTruthReport {
    /// The camera's near plane distance.
    pub near: f64,
    /// The camera's far plane distance.
    pub far: f64,
    /// The clip-space depth convention: `zero-to-one` or `negative-one-to-one`.
    pub depth_convention: &'static str,
    /// Whether the application's own projection is reversed (near at 1, far at 0).
    pub reversed: bool,
    /// The viewport depth range [minDepth, maxDepth] of every draw.
    pub viewport: [f32; 2],
    /// The file with w per pixel (NaN where not interior).
    pub file: &'static str,
    /// The file with the visible object id per pixel.
    pub id_file: &'static str,
    /// The number of interior pixels.
    pub interior_pixels: usize,
    /// Every object drawn into the main target.
    pub objects: Vec<ObjectReport>,
}

/// The file names of the ground truth.
pub const W_FILE: &str = "expected-w.f64";
/// See [`W_FILE`].
pub const ID_FILE: &str = "expected-id.u16";

/// Why a scene has no ground truth (its first rule broken), or the objects drawn into the main
/// target with the program of their first draw there and whether that draw culls back faces.
pub fn applies(scene: &Scene) -> Result<Vec<(usize, Program, bool)>, String> {
    let projection = scene.camera.projection;
    let (compare, clear) = match projection {
        Projection::Reversed => (Compare::Greater, 0.0),
        Projection::Standard | Projection::OpenGl => (Compare::Less, 1.0),
    };
    let plan = &scene.plan;
    let mut drawn: Vec<(usize, Program, bool)> = Vec::new();
    let mut main_passes = 0;
    let mut in_main = false;
    let mut pipeline = None;
    let mut current = None;
    for step in plan.all_steps() {
        match step {
            // A suspended rendering's "next subpass" resumes the same rendering: its draws go
            // on as one rendering's.
            Step::NextSubpass
                if current.is_some_and(|n: usize| {
                    matches!(
                        plan.passes[n].kind,
                        crate::plan::PassKind::DynamicRenderingSuspended { .. }
                    )
                }) => {}
            Step::BeginPass(n) => {
                current = Some(*n);
                let pass = &plan.passes[*n];
                in_main = pass.target == Target::Main;
                if in_main && pass.multisample.is_some() {
                    // The resolved depth is no pixel-center value (sample 0 lies off the
                    // center; other modes combine samples).
                    return Err(format!("main pass {n} is multisampled"));
                }
                if in_main {
                    let expected = if main_passes == 0 {
                        DepthLoad::Clear(clear)
                    } else {
                        DepthLoad::Load
                    };
                    if pass.depth != expected {
                        return Err(format!("main pass {n} loads depth with {:?}", pass.depth));
                    }
                    main_passes += 1;
                }
            }
            Step::Bind(n) => pipeline = Some(*n),
            Step::Draw(n) | Step::DrawPushed(n) if in_main => {
                let spec = pipeline
                    .map(|p| &plan.pipelines[p])
                    .ok_or("a draw without a pipeline")?;
                if spec.program == Program::FragDepth {
                    // The depth tested and stored is the shader's, not the surface's: the
                    // nearest surface need not win, and no depth here is a function of w.
                    return Err(format!("pipeline {} writes FragDepth", spec.name));
                }
                let usual = spec.depth_test == DepthTest::Static(compare)
                    && spec.depth_write
                    && spec.color_write
                    && spec.program != Program::DepthOnly
                    && spec.bias == crate::plan::Bias::Off
                    && spec.bounds == crate::plan::Bounds::Off
                    && spec.stencil.is_none()
                    && matches!(spec.viewport, Viewport::FULL | Viewport::Dynamic)
                    && spec.negative_one_to_one == projection.negative_one_to_one();
                if !usual {
                    return Err(format!("pipeline {} does more than {compare:?}", spec.name));
                }
                if !drawn.iter().any(|(o, _, _)| o == n) {
                    drawn.push((*n, spec.program, spec.cull_back_faces));
                }
            }
            Step::SetViewport {
                min_depth,
                max_depth,
            } if (*min_depth, *max_depth) != (0.0, 1.0) => {
                return Err("a viewport depth range other than [0, 1]".into());
            }
            Step::SetDepthCompareOp(_)
            | Step::SetDepthBias(_)
            | Step::SetDepthBounds { .. }
            | Step::ClearDepthRect { .. }
            | Step::ClearDepthImage { .. }
            | Step::NextSubpass => return Err(format!("{step:?}")),
            _ => {}
        }
    }
    if drawn.is_empty() {
        return Err("nothing is drawn into the main target".into());
    }
    Ok(drawn)
}

/// The ground truth of `scene` rendered at `width` x `height`, with its `render.json` report;
/// an error says why the scene has none.
pub fn compute(
    scene: &Scene,
    width: u32,
    height: u32,
) -> Result<(GroundTruth, GroundTruthReport), String> {
    let drawn = applies(scene)?;
    let aspect = f64::from(width) / f64::from(height);
    let mut triangles = Vec::new();
    let mut objects = Vec::new();
    for &(n, program, cull) in &drawn {
        let object = &scene.objects[n];
        let id = object_id(n)?;
        let mvp = scene.mvp_in(View::Camera, object, aspect);
        let positions = scene.vertex_positions(object);
        let clip: Vec<DVec4> = positions.iter().map(|p| mvp * p.extend(1.0)).collect();
        push_triangles(&mut triangles, id, object, &clip, cull)?;
        let stages = scene.matrix_stages(program, View::Camera, object, aspect);
        objects.push(ObjectReport {
            id,
            name: object.name,
            color: object.color.map(|c| (c * 255.0).round() as u8),
            pushed_projection: scene.pushed_projection(program, object, aspect),
            w_condition: w_condition(&stages, &positions),
        });
    }
    let truth = rasterize(&triangles, width, height);
    let camera = &scene.camera;
    let report = GroundTruthReport {
        near: camera.near,
        far: camera.far,
        depth_convention: if camera.projection.negative_one_to_one() {
            "negative-one-to-one"
        } else {
            "zero-to-one"
        },
        reversed: camera.projection == Projection::Reversed,
        viewport: [0.0, 1.0],
        file: W_FILE,
        id_file: ID_FILE,
        interior_pixels: truth.interior,
        objects,
    };
    Ok((truth, report))
}

/// The ground truth of a scene that may also draw decals with a static depth bias (LESS, no
/// depth writes, coplanar with what they decorate): as [`compute`] for the scene with those
/// pipelines made plain, where an object drawn with a bias wins ties (it is taken a relative
/// 1e-9 nearer than it is). The accuracy checks use it; `render.json` does not (the stored
/// depth of a biased decal is not the mapping of its w).
pub fn compute_ids(scene: &Scene, width: u32, height: u32) -> Result<GroundTruth, String> {
    let mut plain = scene.clone();
    let mut biased_pipelines = Vec::new();
    for (n, pipeline) in plain.plan.pipelines.iter_mut().enumerate() {
        if let crate::plan::Bias::Static(_) = pipeline.bias {
            if pipeline.depth_test != DepthTest::Static(Compare::Less) {
                return Err(format!(
                    "biased pipeline {} does not test LESS",
                    pipeline.name
                ));
            }
            pipeline.bias = crate::plan::Bias::Off;
            pipeline.depth_write = true;
            biased_pipelines.push(n);
        }
    }
    let drawn = applies(&plain)?;
    // Which objects a biased pipeline draws.
    let mut biased = Vec::new();
    let mut pipeline = None;
    for step in plain.plan.all_steps() {
        match step {
            Step::Bind(n) => pipeline = Some(*n),
            Step::Draw(n) | Step::DrawPushed(n)
                if pipeline.is_some_and(|p| biased_pipelines.contains(&p)) =>
            {
                biased.push(*n);
            }
            _ => {}
        }
    }
    let aspect = f64::from(width) / f64::from(height);
    let mut triangles = Vec::new();
    for &(n, _, cull) in &drawn {
        let object = &plain.objects[n];
        let id = object_id(n)?;
        let mvp = plain.mvp_in(View::Camera, object, aspect);
        // Scaling a clip position keeps its screen position and scales its w.
        let scale = if biased.contains(&n) { 1.0 - 1e-9 } else { 1.0 };
        let clip: Vec<DVec4> = plain
            .vertex_positions(object)
            .iter()
            .map(|p| mvp * p.extend(1.0) * scale)
            .collect();
        push_triangles(&mut triangles, id, object, &clip, cull)?;
    }
    Ok(rasterize(&triangles, width, height))
}

/// The id scene object `n` writes (its index; [`BACKGROUND`] is reserved).
fn object_id(n: usize) -> Result<u16, String> {
    u16::try_from(n)
        .ok()
        .filter(|&id| id != BACKGROUND)
        .ok_or_else(|| "too many objects".to_owned())
}

/// Appends `object`'s triangles, from its vertices in clip space `clip`, without the back-facing
/// ones when `cull` is set; every vertex must be in front of the eye (no clipping is modeled).
fn push_triangles(
    triangles: &mut Vec<ClipTriangle>,
    id: u16,
    object: &Object,
    clip: &[DVec4],
    cull: bool,
) -> Result<(), String> {
    for t in object.mesh.indices.chunks_exact(3) {
        let corners = [
            clip[t[0] as usize],
            clip[t[1] as usize],
            clip[t[2] as usize],
        ];
        if corners.iter().any(|c| c.w <= 0.0) {
            return Err(format!("{}: a vertex behind the eye", object.name));
        }
        if cull && !front_facing(&corners) {
            continue;
        }
        triangles.push(ClipTriangle { id, corners });
    }
    Ok(())
}

/// Whether a triangle (w > 0 at its corners) is front-facing for `VK_FRONT_FACE_COUNTER_CLOCKWISE`:
/// Vulkan's area `a = -1/2 sum(x_i y_(i+1) - x_(i+1) y_i)` in framebuffer coordinates (NDC
/// scaled by positive factors: the same sign) is positive. Zero-area triangles are back-facing.
pub fn front_facing(corners: &[DVec4; 3]) -> bool {
    let [(x0, y0), (x1, y1), (x2, y2)] = corners.map(|c| (c.x / c.w, c.y / c.w));
    let twice_shoelace = (x1 - x0) * (y2 - y0) - (x2 - x0) * (y1 - y0);
    -twice_shoelace > 0.0
}

/// [`ObjectReport::w_condition`] of the matrix chain `stages` (outermost first, each applied
/// to the result of the next) over `positions`.
fn w_condition(stages: &[DMat4], positions: &[DVec3]) -> f64 {
    positions
        .iter()
        .map(|p| {
            let v = p.extend(1.0);
            // |a_3.| applied to the running sum of magnitudes of the inner stages.
            let mut magnitudes = v.abs();
            let mut value = v;
            for stage in stages.iter().rev() {
                let abs = DMat4::from_cols(
                    stage.x_axis.abs(),
                    stage.y_axis.abs(),
                    stage.z_axis.abs(),
                    stage.w_axis.abs(),
                );
                magnitudes = abs * magnitudes;
                value = *stage * value;
            }
            stages.len() as f64 * magnitudes.w / value.w.abs()
        })
        .fold(0.0, f64::max)
}

/// The visible triangle's w at every pixel center (the nearest wins), and the interior mask.
pub fn rasterize(triangles: &[ClipTriangle], width: u32, height: u32) -> GroundTruth {
    let (w_px, h_px) = (width as usize, height as usize);
    let mut ids = vec![BACKGROUND; w_px * h_px];
    let mut nearest = vec![f64::INFINITY; w_px * h_px];
    let (fw, fh) = (f64::from(width), f64::from(height));
    for triangle in triangles {
        // Screen positions (Vulkan viewport over the whole target, y down in NDC and pixels).
        let screen = triangle
            .corners
            .map(|c| ((c.x / c.w + 1.0) * 0.5 * fw, (c.y / c.w + 1.0) * 0.5 * fh));
        let [(x0, y0), (x1, y1), (x2, y2)] = screen;
        let area = (x1 - x0) * (y2 - y0) - (x2 - x0) * (y1 - y0);
        if area.abs() < 1e-12 || !area.is_finite() {
            continue; // seen edge-on: covers no pixel center
        }
        let inverse_w = triangle.corners.map(|c| 1.0 / c.w);
        let min_x = x0.min(x1).min(x2).floor().max(0.0) as usize;
        let max_x = (x0.max(x1).max(x2).ceil().min(fw) as usize).min(w_px);
        let min_y = y0.min(y1).min(y2).floor().max(0.0) as usize;
        let max_y = (y0.max(y1).max(y2).ceil().min(fh) as usize).min(h_px);
        for py in min_y..max_y {
            for px in min_x..max_x {
                let (x, y) = (px as f64 + 0.5, py as f64 + 0.5);
                // Barycentric coordinates of the pixel center (edge functions / area).
                let l0 = ((x1 - x) * (y2 - y) - (x2 - x) * (y1 - y)) / area;
                let l1 = ((x2 - x) * (y0 - y) - (x0 - x) * (y2 - y)) / area;
                let l2 = 1.0 - l0 - l1;
                if l0 < 0.0 || l1 < 0.0 || l2 < 0.0 {
                    continue;
                }
                let w = 1.0 / (l0 * inverse_w[0] + l1 * inverse_w[1] + l2 * inverse_w[2]);
                let at = py * w_px + px;
                if w < nearest[at] {
                    nearest[at] = w;
                    ids[at] = triangle.id;
                }
            }
        }
    }
    let mut w = vec![f64::NAN; w_px * h_px];
    let mut interior = 0;
    for py in 0..h_px {
        for px in 0..w_px {
            let at = py * w_px + px;
            let id = ids[at];
            if id == BACKGROUND {
                continue;
            }
            let same = (py.saturating_sub(1)..(py + 2).min(h_px)).all(|y| {
                (px.saturating_sub(1)..(px + 2).min(w_px)).all(|x| ids[y * w_px + x] == id)
            });
            if same {
                w[at] = nearest[at];
                interior += 1;
            }
        }
    }
    GroundTruth {
        width,
        height,
        ids,
        w,
        interior,
    }
}

impl GroundTruth {
    /// `expected-w.f64`: little-endian f64 per pixel.
    pub fn w_bytes(&self) -> Vec<u8> {
        self.w.iter().flat_map(|w| w.to_le_bytes()).collect()
    }

    /// `expected-id.u16`: little-endian u16 per pixel.
    pub fn id_bytes(&self) -> Vec<u8> {
        self.ids.iter().flat_map(|id| id.to_le_bytes()).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{overlap_camera, Camera};
    use glam::dcamera::rh::proj;

    /// A camera at the origin looking down -z (view = identity), 60 degrees, near 0.5.
    fn camera() -> Camera {
        Camera {
            eye: DVec3::ZERO,
            target: DVec3::NEG_Z,
            up: DVec3::Y,
            fov_y: 60f64.to_radians(),
            near: 0.5,
            far: 50.0,
            projection: Projection::Standard,
        }
    }

    /// The two triangles of the quad `corners` (counter-clockwise), in clip space.
    fn quad(id: u16, projection: &DMat4, corners: [DVec3; 4]) -> Vec<ClipTriangle> {
        let c = corners.map(|p| *projection * p.extend(1.0));
        vec![
            ClipTriangle {
                id,
                corners: [c[0], c[1], c[2]],
            },
            ClipTriangle {
                id,
                corners: [c[0], c[2], c[3]],
            },
        ]
    }

    /// The view-space ray through the center of pixel (px, py): a point at -z = 1.
    fn ray(camera: &Camera, aspect: f64, px: usize, py: usize, width: u32, height: u32) -> DVec3 {
        let t = (camera.fov_y / 2.0).tan();
        let x_ndc = (px as f64 + 0.5) / f64::from(width) * 2.0 - 1.0;
        let y_ndc = (py as f64 + 0.5) / f64::from(height) * 2.0 - 1.0;
        // y down in NDC: up in view space is -y_ndc.
        DVec3::new(x_ndc * t * aspect, -y_ndc * t, -1.0)
    }

    #[test]
    fn a_facing_quad_is_at_its_distance_everywhere_inside() {
        let camera = camera();
        let (width, height) = (40, 30);
        let p = camera.projection(f64::from(width) / f64::from(height));
        let d = 7.25;
        let triangles = quad(
            3,
            &p,
            [
                DVec3::new(-2.0, -1.5, -d),
                DVec3::new(2.0, -1.5, -d),
                DVec3::new(2.0, 1.5, -d),
                DVec3::new(-2.0, 1.5, -d),
            ],
        );
        let truth = rasterize(&triangles, width, height);
        assert!(truth.interior > 50, "{}", truth.interior);
        for (at, w) in truth.w.iter().enumerate() {
            if w.is_finite() {
                assert_eq!(truth.ids[at], 3);
                assert!((w - d).abs() < 1e-12 * d, "{w}");
            }
        }
        // The image border rows are background (the quad covers the middle only), and no
        // pixel next to the background is interior.
        assert_eq!(truth.ids[0], BACKGROUND);
        for py in 0..height as usize {
            for px in 0..width as usize {
                let at = py * width as usize + px;
                if truth.ids[at] == BACKGROUND {
                    assert!(truth.w[at].is_nan());
                }
            }
        }
    }

    #[test]
    fn a_tilted_plane_has_the_analytic_w() {
        let camera = camera();
        let (width, height) = (48, 32);
        let aspect = f64::from(width) / f64::from(height);
        let p = camera.projection(aspect);
        // The plane through (0, -1, -4) with normal (0.3, 1, 0.4) (a tilted floor).
        let normal = DVec3::new(0.3, 1.0, 0.4).normalize();
        let point = DVec3::new(0.0, -1.0, -4.0);
        let (u, v) = (
            normal.cross(DVec3::X).normalize(),
            normal.cross(DVec3::Z).normalize(),
        );
        let corners = [
            point - 2.0 * u - 2.0 * v,
            point + 2.0 * u - 2.0 * v,
            point + 2.0 * u + 2.0 * v,
            point - 2.0 * u + 2.0 * v,
        ];
        let truth = rasterize(&quad(0, &p, corners), width, height);
        assert!(truth.interior > 50, "{}", truth.interior);
        let mut checked = 0;
        for py in 0..height as usize {
            for px in 0..width as usize {
                let w = truth.w[py * width as usize + px];
                if !w.is_finite() {
                    continue;
                }
                // Intersect the pixel's ray with the plane: t * n.ray = n.point, w = t.
                let r = ray(&camera, aspect, px, py, width, height);
                let t = normal.dot(point) / normal.dot(r);
                assert!((w - t).abs() <= 1e-12 * t, "pixel ({px}, {py}): {w} vs {t}");
                checked += 1;
            }
        }
        assert_eq!(checked, truth.interior);
    }

    #[test]
    fn the_nearest_surface_wins_and_borders_are_not_interior() {
        let camera = camera();
        let (width, height) = (32, 32);
        let p = camera.projection(1.0);
        let square = |id, d: f64, half: f64| {
            quad(
                id,
                &p,
                [
                    DVec3::new(-half, -half, -d),
                    DVec3::new(half, -half, -d),
                    DVec3::new(half, half, -d),
                    DVec3::new(-half, half, -d),
                ],
            )
        };
        // A small near square in front of a large far one, listed far last.
        let mut triangles = square(1, 3.0, 0.5);
        triangles.extend(square(2, 9.0, 10.0));
        let truth = rasterize(&triangles, width, height);
        let center = 16 * 32 + 16;
        assert_eq!(truth.ids[center], 1);
        assert!((truth.w[center] - 3.0).abs() < 1e-12);
        // Walk right from the center: 1 ... 1 then 2 ... 2; the pixels on either side of the
        // change are not interior.
        let row: Vec<u16> = (0..32).map(|x| truth.ids[16 * 32 + x]).collect();
        let edge = row.iter().rposition(|&id| id == 1).unwrap();
        assert_eq!(row[edge + 1], 2);
        assert!(truth.w[16 * 32 + edge].is_nan() && truth.w[16 * 32 + edge + 1].is_nan());
        assert!((truth.w[16 * 32 + edge + 3] - 9.0).abs() < 1e-12);
        assert_eq!(
            truth.interior,
            truth.w.iter().filter(|w| w.is_finite()).count()
        );
    }

    #[test]
    fn the_standard_mapping_is_what_the_projection_stores() {
        let camera = Camera {
            projection: Projection::Standard,
            ..overlap_camera()
        };
        for projection in [
            Projection::Standard,
            Projection::OpenGl,
            Projection::Reversed,
        ] {
            let camera = Camera {
                projection,
                ..camera.clone()
            };
            let m = camera.projection(1.0);
            for w in [0.1, 0.37, 3.0, 45.0, 100.0] {
                let c = m * DVec4::new(0.2, -0.1, -w, 1.0);
                let z = c.z / c.w;
                let stored = if projection.negative_one_to_one() {
                    (z + 1.0) / 2.0
                } else {
                    z
                };
                let expected = projection.stored_depth(camera.near, camera.far, w);
                assert!((stored - expected).abs() < 1e-12, "{projection:?} {w}");
            }
        }
        // glam's OpenGL projection is what `Projection::OpenGl` uses, y flipped.
        let gl = proj::opengl::perspective(camera.fov_y, 1.5, camera.near, camera.far);
        let ours = Camera {
            projection: Projection::OpenGl,
            ..camera
        }
        .projection(1.5);
        assert_eq!(ours.row(2), gl.row(2));
        assert_eq!(ours.row(1), -gl.row(1));
    }

    #[test]
    fn culling_keeps_what_faces_the_eye() {
        // The quads of these tests wind counter-clockwise seen from the eye (the y-up view
        // space): front-facing through the y-down projection; wound the other way, back-facing.
        let camera = camera();
        let p = camera.projection(1.0);
        let corners = [
            DVec3::new(-1.0, -1.0, -4.0),
            DVec3::new(1.0, -1.0, -4.0),
            DVec3::new(1.0, 1.0, -4.0),
            DVec3::new(-1.0, 1.0, -4.0),
        ];
        for triangle in quad(0, &p, corners) {
            assert!(front_facing(&triangle.corners));
            let [a, b, c] = triangle.corners;
            assert!(!front_facing(&[a, c, b]));
            // Zero area: back-facing, as Vulkan says.
            assert!(!front_facing(&[a, a, b]));
        }
    }

    #[test]
    fn w_condition_of_one_and_two_stages() {
        // w = -z for a camera at the origin: sum |m_3i v_i| / |w| = 1 for any point in front.
        let p = camera().projection(1.0);
        let points = [DVec3::new(1.0, 2.0, -3.0)];
        assert!((w_condition(&[p], &points) - 1.0).abs() < 1e-15);
        // Two stages: a translation by (0, 0, -10) then p: twice (|z| + 10) / w.
        let t = DMat4::from_translation(DVec3::new(0.0, 0.0, -10.0));
        let c = w_condition(&[p, t], &points);
        assert!((c - 2.0 * (3.0 + 10.0) / 13.0).abs() < 1e-12, "{c}");
    }
}
