//! The accuracy scenes (issue #6): hard cases for depth precision, each drawn by one
//! perspective camera where the nearest surface wins, so that the ground truth
//! ([`crate::ground_truth`]) says for every pixel which object must show.
//!
//! | scene | what makes it hard |
//! |---|---|
//! | `sloped-plane` | seed 001's test: a red mesh over a green plane, half parallel, half sloping down until it touches the plane at its right edge; red drawn first; a rotated camera with real numbers in its view matrix |
//! | `mars-patch` | seed 001's Mars case: a camera 10 km above the surface looking down at a slant, a terrain patch 600 m and more above it, vertices in world coordinates 3390 km from the origin, P * V precomposed in the push constants |
//! | `tori` | two interpenetrating tori 6000 near-plane distances away (intersection curves) |
//! | `plane-stack` | pairs of parallel planes at 10 n to 1e6 n, relative separations swept over decades (the minimum-separation measurement) |
//! | `deep-range` | n = 1e-3, f = 1e7: pairs of parallel surfaces 1 % apart at every decade from 1e-2 to 1e6 |
//! | `decal-bias` | coplanar decals on walls at 2 to 800 held apart only by depth bias |
//! | `far-objects` | boxes from 10 n to 1e6 n, each with its own P * V * M; touching and shallowly intersecting pairs drawn with different matrices; camera 3.4 km from the origin; unsorted draws |
//!
//! Every object's color is unique within its scene, so a rendered pixel's color names the
//! object that shows there (`crate::accuracy` maps colors back to ids).

use glam::{DMat4, DVec3};

use crate::plan::{Bias, Compare, DepthBias, DepthTest, PassSpec, PipelineSpec, Plan, Step};
use crate::scene::{rgb8, Camera, Mesh, Object, Projection, Scene, Space};

/// A distinct opaque color per index (up to 512): what objects of generated scenes wear.
pub fn id_color(index: usize) -> [f32; 4] {
    let level = |v: usize| u8::try_from(40 + (v % 8) * 30).expect("fits");
    rgb8(level(index), level(index / 8), level(index / 64))
}

/// A scene drawn in the objects' given order with one standard pipeline (LESS, writes).
fn in_order(name: &'static str, camera: Camera, objects: Vec<Object>) -> Scene {
    let plan = Plan::single_pass(objects.len());
    Scene {
        name,
        camera,
        light: None,
        objects,
        plan,
    }
}

/// A mesh from explicit corners (each quad counter-clockwise seen from its front).
fn quads(quads: &[[DVec3; 4]]) -> Mesh {
    let mut mesh = Mesh::default();
    for quad in quads {
        let base = u32::try_from(mesh.positions.len()).expect("small mesh");
        for p in quad {
            mesh.positions.push(p.as_vec3().to_array());
        }
        mesh.indices
            .extend([base, base + 1, base + 2, base, base + 2, base + 3]);
    }
    mesh
}

/// Height of the red mesh's parallel half above the green plane in `sloped-plane`.
pub const SLOPED_PLANE_GAP: f64 = 1.5;

/// `sloped-plane` (seed 001, Figure 2): a 300 x 300 red mesh over a 500 x 500 green plane
/// (y = 0); its left half parallel to the plane 1.5 above it, its right half sloping down
/// until it touches the plane along its right edge. Red is drawn first, so a green pixel
/// inside the red square is a depth inversion (a green fragment computed nearer than the red
/// one), not a tie. The camera (eye (230.5, 610.25, 870.75), looking at (10.3, 0, -5.7), 25
/// degrees, near 0.01, far 1e4) is rotated, so the view matrix holds inexact reals; the square
/// is about 1.1e5 near-plane distances away, where standard depth with a precomposed float32
/// MVP needs a relative separation of about 1e-2 and the gap gives 2.5e-3.
pub fn sloped_plane() -> Scene {
    let camera = Camera {
        eye: DVec3::new(230.5, 610.25, 870.75),
        target: DVec3::new(10.3, 0.0, -5.7),
        up: DVec3::Y,
        fov_y: 25f64.to_radians(),
        near: 0.01,
        far: 1.0e4,
        projection: Projection::Standard,
    };
    let (h, s) = (SLOPED_PLANE_GAP, 150.0);
    let p = DVec3::new;
    let red = quads(&[
        // The parallel half (x in [-150, 0]), then the sloping half (x in [0, 150]).
        [p(-s, h, s), p(0.0, h, s), p(0.0, h, -s), p(-s, h, -s)],
        [p(0.0, h, s), p(s, 0.0, s), p(s, 0.0, -s), p(0.0, h, -s)],
    ]);
    let objects = vec![
        Object::world("red mesh", red, DMat4::IDENTITY, rgb8(220, 30, 30)),
        Object::world(
            "green plane",
            Mesh::quad(250.0, 250.0),
            DMat4::IDENTITY,
            rgb8(30, 190, 40),
        ),
    ];
    in_order("sloped-plane", camera, objects)
}

/// Distance of the `mars-patch` site from the world origin, meters. (At Mars' radius,
/// 3390 km, the float32 P * V no longer carries the near plane: its depth row's constant
/// `k * t_w + B` rounds `B = -k n` away (`u * 3.4e6 = 0.2` against n = 0.2), so no layer can
/// read the projection's planes from it; 1000 km keeps B to 15 %.)
pub const SITE_DISTANCE: f64 = 1.0e6;

/// The lowest height of the terrain patch above the surface, meters.
pub const PATCH_HEIGHT: f64 = 600.0;

/// Local frame at the site of `mars-patch`: columns east, north, up, origin on the surface.
pub fn mars_site() -> DMat4 {
    let up = DVec3::new(0.3, 0.8, 0.52).normalize();
    let east = DVec3::Y.cross(up).normalize();
    let north = up.cross(east);
    DMat4::from_cols(
        east.extend(0.0),
        north.extend(0.0),
        up.extend(0.0),
        (up * SITE_DISTANCE).extend(1.0),
    )
}

/// `mars-patch` (seed 001, Figure 1): a flat 30 x 30 km piece of surface and a 4 x 4 km terrain
/// patch (16 x 16 cells, heights 600 to 900 m above the surface), both with their vertices in
/// world coordinates 1000 km from the origin ([`SITE_DISTANCE`]; a float32 vertex is good to
/// 3 cm) and P * V precomposed in the push constants. The camera is 10 km above the surface
/// and 8 km south of the patch, looking down at it at a slant, near 0.2 m, far 100 km: the
/// 600 m gap is 5 % of the 12 km distance, and standard depth still inverts it (its depth
/// row's float32 dot product with 1000 km coordinates is off by about 0.06 m of clip z).
pub fn mars_patch() -> Scene {
    let site = mars_site();
    let at = |east: f64, north: f64, up: f64| site.transform_point3(DVec3::new(east, north, up));
    let camera = Camera {
        eye: at(0.0, -8000.0, 10_000.0),
        target: at(0.0, 0.0, PATCH_HEIGHT),
        up: site.z_axis.truncate(),
        fov_y: 40f64.to_radians(),
        near: 0.2,
        far: 1.0e5,
        projection: Projection::Standard,
    };
    // The terrain: a height field over the local (east, north) plane.
    let cells = 16;
    let half = 2000.0;
    let step = 2.0 * half / f64::from(cells);
    let height =
        |e: f64, n: f64| PATCH_HEIGHT + 150.0 * (1.0 + (e / 700.0).sin() * (n / 900.0).cos());
    let mut patch = Mesh::default();
    for j in 0..=cells {
        for i in 0..=cells {
            let (e, n) = (-half + f64::from(i) * step, -half + f64::from(j) * step);
            patch
                .positions
                .push(DVec3::new(e, n, height(e, n)).as_vec3().to_array());
        }
    }
    let row = cells + 1;
    for j in 0..cells {
        for i in 0..cells {
            let a = j * row + i;
            patch
                .indices
                .extend([a, a + 1, a + row + 1, a, a + row + 1, a + row]);
        }
    }
    let ground = quads(&[[
        DVec3::new(-15_000.0, -15_000.0, 0.0),
        DVec3::new(15_000.0, -15_000.0, 0.0),
        DVec3::new(15_000.0, 15_000.0, 0.0),
        DVec3::new(-15_000.0, 15_000.0, 0.0),
    ]]);
    let baked = |name, mesh, color| Object {
        name,
        mesh,
        model: site,
        color,
        space: Space::WorldBaked,
    };
    let objects = vec![
        baked("terrain patch", patch, rgb8(200, 90, 40)),
        baked("surface", ground, rgb8(120, 110, 180)),
    ];
    in_order("mars-patch", camera, objects)
}

/// A torus around the local y axis (major radius `major`, tube radius `minor`).
pub fn torus(major: f64, minor: f64, segments: u32, sides: u32) -> Mesh {
    let mut mesh = Mesh::default();
    let tau = std::f64::consts::TAU;
    for i in 0..segments {
        let u = tau * f64::from(i) / f64::from(segments);
        for j in 0..sides {
            let v = tau * f64::from(j) / f64::from(sides);
            let r = major + minor * v.cos();
            mesh.positions.push(
                DVec3::new(r * u.cos(), minor * v.sin(), r * u.sin())
                    .as_vec3()
                    .to_array(),
            );
        }
    }
    let at = |i: u32, j: u32| (i % segments) * sides + (j % sides);
    for i in 0..segments {
        for j in 0..sides {
            let (a, b, c, d) = (at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
            mesh.indices.extend([a, b, c, a, c, d]);
        }
    }
    mesh
}

/// `tori`: two interpenetrating tori (major radius 10, tube 3.5), one lying flat, one standing
/// and shifted by 8 so that its tube passes through the other's, 60 away from a camera with
/// near 0.01 (6000 n): the intersection curves are where surfaces come arbitrarily close.
pub fn tori() -> Scene {
    let camera = Camera {
        eye: DVec3::new(21.3, 33.7, 47.9),
        target: DVec3::new(4.1, 0.3, -0.7),
        up: DVec3::Y,
        fov_y: 40f64.to_radians(),
        near: 0.01,
        far: 1000.0,
        projection: Projection::Standard,
    };
    let objects = vec![
        Object::world(
            "flat torus",
            torus(10.0, 3.5, 48, 24),
            DMat4::from_rotation_y(0.3),
            rgb8(230, 160, 30),
        ),
        Object::world(
            "standing torus",
            torus(10.0, 3.5, 48, 24),
            DMat4::from_translation(DVec3::new(8.0, 0.0, 0.0))
                * DMat4::from_rotation_x(std::f64::consts::FRAC_PI_2),
            rgb8(40, 120, 230),
        ),
    ];
    in_order("tori", camera, objects)
}

/// The view distances of `plane-stack`, in near-plane distances.
pub const STACK_DISTANCES: [f64; 6] = [10.0, 1e2, 1e3, 1e4, 1e5, 1e6];

/// Relative separations per decade of `plane-stack`.
pub const STACK_PER_DECADE: i32 = 4;

/// The relative separations of `plane-stack`: 1e-7 to 10^-0.25, 4 per decade (27 values).
pub fn stack_separations() -> Vec<f64> {
    (0..27)
        .map(|i| 10f64.powf(-7.0 + f64::from(i) / f64::from(STACK_PER_DECADE)))
        .collect()
}

/// Near plane of `plane-stack` (its far plane is 1e6, as in `DESIGN.md` section 3).
pub const STACK_NEAR: f64 = 0.1;

/// The aspect ratio `plane-stack`'s cells are laid out for (render it at 4:3).
pub const STACK_ASPECT: f64 = 4.0 / 3.0;

/// One cell of `plane-stack`: the column (distance) and row (separation), and the object
/// indices of its front and back planes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StackCell {
    /// Index into [`STACK_DISTANCES`].
    pub column: usize,
    /// Index into [`stack_separations`].
    pub row: usize,
    /// The front plane's object index.
    pub front: usize,
    /// The back plane's object index.
    pub back: usize,
}

/// The camera of `plane-stack`: at the world origin, rotated (yaw 37.3, pitch -21.7 degrees),
/// 50 degrees, near 0.1, far 1e6.
pub fn stack_camera() -> Camera {
    let (yaw, pitch) = (37.3f64.to_radians(), (-21.7f64).to_radians());
    let forward = DVec3::new(
        -yaw.sin() * pitch.cos(),
        pitch.sin(),
        -yaw.cos() * pitch.cos(),
    );
    Camera {
        eye: DVec3::ZERO,
        target: forward,
        up: DVec3::Y,
        fov_y: 50f64.to_radians(),
        near: STACK_NEAR,
        far: 1.0e6,
        projection: Projection::Standard,
    }
}

/// The cells of `plane-stack` (back planes are objects 0..cells, front planes follow).
pub fn stack_cells() -> Vec<StackCell> {
    let rows = stack_separations().len();
    let count = STACK_DISTANCES.len() * rows;
    let mut cells = Vec::new();
    for column in 0..STACK_DISTANCES.len() {
        for row in 0..rows {
            let k = column * rows + row;
            cells.push(StackCell {
                column,
                row,
                front: count + k,
                back: k,
            });
        }
    }
    cells
}

/// `plane-stack`: the screen is a grid of cells, one column per distance d of
/// [`STACK_DISTANCES`] (times the near plane 0.1) and one row per relative separation s of
/// [`stack_separations`]. A cell holds a pair of parallel planes covering exactly the cell: the
/// front one tilted so that its view depth runs from d to 1.1 d across the cell (as the
/// model's pairs spread over [z, 1.1 z]), the back one the front scaled by 1 + s about the eye
/// (on every ray exactly (1 + s) times as far). The back planes are drawn first, so a front
/// pixel must win the depth test strictly: a tie counts as wrong, as in the model. The camera
/// sits at the world origin, rotated; world positions are float32 and P * V is precomposed,
/// as in `revz_math::model::Simulation`.
pub fn plane_stack() -> Scene {
    let camera = stack_camera();
    let view_to_world = camera.view().inverse();
    let t = (camera.fov_y / 2.0).tan();
    let separations = stack_separations();
    let (columns, rows) = (STACK_DISTANCES.len(), separations.len());
    // A point on the ray through NDC (x, y) (y down) at view depth w, in world space.
    let point = |x: f64, y: f64, w: f64| {
        view_to_world.transform_point3(DVec3::new(x * t * STACK_ASPECT * w, -y * t * w, -w))
    };
    let mut backs = Vec::new();
    let mut fronts = Vec::new();
    for (column, &d) in STACK_DISTANCES.iter().enumerate() {
        let d = d * STACK_NEAR;
        for (row, &s) in separations.iter().enumerate() {
            let x0 = -1.0 + 2.0 * column as f64 / columns as f64;
            let x1 = x0 + 2.0 / columns as f64;
            let y0 = -1.0 + 2.0 * row as f64 / rows as f64;
            let y1 = y0 + 2.0 / rows as f64;
            let corners = |scale: f64| {
                [
                    point(x0, y1, d * scale),
                    point(x1, y1, 1.1 * d * scale),
                    point(x1, y0, 1.1 * d * scale),
                    point(x0, y0, d * scale),
                ]
            };
            let k = column * rows + row;
            backs.push(Object::world(
                "back plane",
                quads(&[corners(1.0 + s)]),
                DMat4::IDENTITY,
                id_color(k),
            ));
            fronts.push(Object::world(
                "front plane",
                quads(&[corners(1.0)]),
                DMat4::IDENTITY,
                id_color(columns * rows + k),
            ));
        }
    }
    backs.extend(fronts);
    in_order("plane-stack", camera, backs)
}

/// The view distances of the pairs of `deep-range`.
pub const DEEP_DISTANCES: [f64; 9] = [1e-2, 1e-1, 1.0, 10.0, 1e2, 1e3, 1e4, 1e5, 1e6];

/// `deep-range`: near 1e-3, far 1e7; at each distance d of [`DEEP_DISTANCES`] (10 n to
/// 1e9 n), in a 3 x 3 grid on screen, a tilted backdrop and a smaller plate parallel to it, 1 %
/// of d in front (drawn back to front). The camera looks down -z from the origin, slightly
/// rotated.
pub fn deep_range() -> Scene {
    let camera = Camera {
        eye: DVec3::ZERO,
        target: DVec3::new(0.031, -0.017, -1.0),
        up: DVec3::new(0.05, 1.0, 0.0),
        fov_y: 50f64.to_radians(),
        near: 1e-3,
        far: 1e7,
        projection: Projection::Standard,
    };
    let view_to_world = camera.view().inverse();
    let t = (camera.fov_y / 2.0).tan();
    let aspect = 4.0 / 3.0;
    let mut backs = Vec::new();
    let mut fronts = Vec::new();
    for (i, &d) in DEEP_DISTANCES.iter().enumerate() {
        let (cx, cy) = ((i % 3) as f64 - 1.0, (i / 3) as f64 - 1.0);
        // Cell center in view space at depth d; the cell is a third of the screen wide.
        let center = DVec3::new(cx * 2.0 / 3.0 * t * aspect * d, -cy * 2.0 / 3.0 * t * d, -d);
        let cell = 2.0 / 3.0 * t * d;
        let frame = view_to_world
            * DMat4::from_translation(center)
            * DMat4::from_rotation_y(0.3)
            * DMat4::from_rotation_x(0.2);
        backs.push(Object::world(
            "backdrop",
            Mesh::rect_xy(0.0, 0.0, 0.42 * cell * aspect, 0.42 * cell),
            frame,
            id_color(2 * i),
        ));
        fronts.push(Object::world(
            "plate",
            Mesh::rect_xy(0.0, 0.0, 0.25 * cell * aspect, 0.25 * cell),
            frame * DMat4::from_translation(DVec3::new(0.0, 0.0, 0.01 * d)),
            id_color(2 * i + 1),
        ));
    }
    backs.extend(fronts);
    in_order("deep-range", camera, backs)
}

/// The bias of `decal-bias` (standard depth: negative pulls toward the camera).
pub const DECAL_BIAS: DepthBias = DepthBias {
    constant: -16.0,
    slope: -4.0,
    clamp: 0.0,
};

/// `decal-bias`: walls at view distances 2, 20, 200 and 800 (near 0.1, far 1000), two facing
/// the camera and two slanted, each with two decals in its plane (the same model matrix,
/// local z = 0: exactly coplanar) drawn after the walls with LESS, no depth writes and a
/// static depth bias (constant -16, slope -4) pulling them toward the camera. Only the bias
/// keeps a decal in front of its wall.
pub fn decal_bias() -> Scene {
    let camera = Camera {
        eye: DVec3::ZERO,
        target: DVec3::new(0.02, 0.01, -1.0),
        up: DVec3::Y,
        fov_y: 50f64.to_radians(),
        near: 0.1,
        far: 1000.0,
        projection: Projection::Standard,
    };
    let t = (camera.fov_y / 2.0).tan();
    let aspect = 4.0 / 3.0;
    let mut walls = Vec::new();
    let mut decals = Vec::new();
    for (i, (d, turn)) in [(2.0, 0.0), (20.0, 1.0), (200.0, 0.15), (800.0, -0.9)]
        .into_iter()
        .enumerate()
    {
        let (cx, cy) = ((i % 2) as f64 - 0.5, (i / 2) as f64 - 0.5);
        let half = 0.4 * t * d;
        let model = DMat4::from_translation(DVec3::new(cx * t * aspect * d, -cy * t * d, -d))
            * DMat4::from_rotation_y(turn);
        walls.push(Object::world(
            "wall",
            Mesh::rect_xy(0.0, 0.0, half * 0.8, half),
            model,
            id_color(3 * i),
        ));
        for (k, (x, y)) in [(-0.35, 0.3), (0.3, -0.35)].into_iter().enumerate() {
            decals.push(Object::world(
                "decal",
                Mesh::rect_xy(x * half, y * half, 0.3 * half, 0.25 * half),
                model,
                id_color(3 * i + 1 + k),
            ));
        }
    }
    let wall_count = walls.len();
    let decal_count = decals.len();
    walls.extend(decals);
    let standard = PipelineSpec::standard("standard", 0);
    let decal = PipelineSpec {
        depth_test: DepthTest::Static(Compare::Less),
        depth_write: false,
        bias: Bias::Static(DECAL_BIAS),
        ..PipelineSpec::standard("decal", 0)
    };
    let mut steps = vec![Step::BeginPass(0), Step::Bind(0)];
    steps.extend((0..wall_count).map(Step::Draw));
    steps.push(Step::Bind(1));
    steps.extend((wall_count..wall_count + decal_count).map(Step::Draw));
    steps.push(Step::EndPass);
    Scene {
        name: "decal-bias",
        camera,
        light: None,
        objects: walls,
        plan: Plan {
            passes: vec![PassSpec::clear(1.0)],
            pipelines: vec![standard, decal],
            steps,
        },
    }
}

/// Near plane of `far-objects` (its far plane is 1e6, as `plane-stack`'s).
pub const FAR_NEAR: f64 = 0.1;

/// The view distances of the groups of `far-objects`, one per decade: 10 n to 1e6 n.
pub const FAR_DISTANCES: [f64; 6] = [1.0, 10.0, 1e2, 1e3, 1e4, 1e5];

/// The order `far-objects` draws its groups in (indices into [`FAR_DISTANCES`]): neither
/// nearest nor farthest first, as an application that does not sort.
pub const FAR_DRAW_ORDER: [usize; 6] = [3, 0, 5, 1, 4, 2];

/// The aspect ratio `far-objects`' groups are laid out for (render it at 4:3).
pub const FAR_ASPECT: f64 = 4.0 / 3.0;

/// The names of each group's objects, per decade of [`FAR_DISTANCES`]: (base, top, sunk box).
const FAR_NAMES: [[&str; 3]; 6] = [
    ["base at 1e1 n", "top at 1e1 n", "sunk box at 1e1 n"],
    ["base at 1e2 n", "top at 1e2 n", "sunk box at 1e2 n"],
    ["base at 1e3 n", "top at 1e3 n", "sunk box at 1e3 n"],
    ["base at 1e4 n", "top at 1e4 n", "sunk box at 1e4 n"],
    ["base at 1e5 n", "top at 1e5 n", "sunk box at 1e5 n"],
    ["base at 1e6 n", "top at 1e6 n", "sunk box at 1e6 n"],
];

/// The camera of `far-objects`: at (1234.5, 87.25, -3210.75), far from the world origin,
/// heading 33.7 degrees left of -z and looking 30 degrees down, 50 degrees, near 0.1, far 1e6.
pub fn far_objects_camera() -> Camera {
    let (yaw, pitch) = (33.7f64.to_radians(), (-30f64).to_radians());
    let forward = DVec3::new(
        -yaw.sin() * pitch.cos(),
        pitch.sin(),
        -yaw.cos() * pitch.cos(),
    );
    let eye = DVec3::new(1234.5, 87.25, -3210.75);
    Camera {
        eye,
        target: eye + forward,
        up: DVec3::Y,
        fov_y: 50f64.to_radians(),
        near: FAR_NEAR,
        far: 1.0e6,
        projection: Projection::Standard,
    }
}

/// The objects of `far-objects` in drawing order, each with the index of its decade in
/// [`FAR_DISTANCES`].
pub fn far_layout() -> Vec<(usize, Object)> {
    let camera = far_objects_camera();
    let view_to_world = camera.view().inverse();
    let t = (camera.fov_y / 2.0).tan();
    // The groups' frames turn their +z toward the camera (horizontally), then 0.55 rad more,
    // so that the front (+z) and right (+x) faces of every base are seen.
    let forward = camera.forward();
    let heading = (-forward.x).atan2(-forward.z) + 0.55;
    let mut objects = Vec::new();
    for (g, &decade) in FAR_DRAW_ORDER.iter().enumerate() {
        let d = FAR_DISTANCES[decade];
        // A 3 x 2 grid of cells on screen (NDC, y down), one decade per cell; the lower row,
        // seen more steeply from above, a little higher than its cell's center.
        let (x, y) = (
            (decade % 3) as f64 * 2.0 / 3.0 - 2.0 / 3.0,
            [-0.5, 0.44][decade / 3],
        );
        let anchor =
            view_to_world.transform_point3(DVec3::new(x * t * FAR_ASPECT * d, -y * t * d, -d));
        let frame = DMat4::from_translation(anchor - DVec3::Y * (0.055 * d))
            * DMat4::from_rotation_y(heading);
        let scaled = |x: f64, y: f64, z: f64| DVec3::new(x, y, z) * (0.92 * d);
        let [base_name, top_name, sunk_name] = FAR_NAMES[decade];
        let base = Object::world(
            base_name,
            Mesh::cuboid(scaled(0.14, 0.07, 0.12)),
            frame,
            id_color(3 * decade),
        );
        // Standing on the base: its bottom face (local y = -0.06 d) in the plane of the base's
        // top face (0.07 d), turned 0.4 rad, its footprint inside the top face.
        let top = Object::world(
            top_name,
            Mesh::cuboid(scaled(0.05, 0.06, 0.045)),
            frame
                * DMat4::from_translation(scaled(0.06, 0.13, -0.045))
                * DMat4::from_rotation_y(0.4),
            id_color(3 * decade + 1),
        );
        // Sunk into the base's front top edge, left of the top box, turned a little about
        // every axis: its top face crosses the base's top face, and its front face the base's
        // front face, at 0.03 to 0.05 rad, along slanted lines (where the two surfaces are as
        // close as the pixels allow).
        let sunk = Object::world(
            sunk_name,
            Mesh::cuboid(scaled(0.05, 0.04, 0.05)),
            frame
                * DMat4::from_translation(scaled(-0.075, 0.0315, 0.0715))
                * DMat4::from_rotation_y(0.04)
                * DMat4::from_rotation_x(0.03)
                * DMat4::from_rotation_z(0.05),
            id_color(3 * decade + 2),
        );
        let group = [base, top, sunk];
        // The order inside a group changes from group to group too.
        for k in 0..3 {
            objects.push((decade, group[(k + g) % 3].clone()));
        }
    }
    objects
}

/// `far-objects`: a city of boxes, one group per decade of [`FAR_DISTANCES`] (view distances
/// 10 n to 1e6 n, near 0.1, far 1e6) in a 3 x 2 grid on screen, each sized with its distance:
/// a base box, a top box standing on it (touching: its bottom face in the plane of the base's
/// top face) and a box sunk into the base's front top edge, turned 0.03 to 0.05 rad about
/// every axis (intersecting: its top and front faces cross the base's along slanted lines).
/// Each object has its own model matrix, so its own precomposed P * V * M in the push
/// constants. The camera is 3.4 km from the world origin, looking 30 degrees down; the groups
/// are drawn in the order of [`FAR_DRAW_ORDER`], and inside each group in an order that
/// changes from group to group.
///
/// What makes it hard: where two objects meet (the top box's edges on the base's top face,
/// the sunk box's crossings with the base's faces) their surfaces are as close as the pixels
/// allow (a few 1e-4 of their distance at the checked pixels next to the crossings), and they
/// are drawn with different matrices. Standard depth cannot resolve them from 1e4 n on (its
/// float32 P * V * M gives depth near 1 to about 1e-7); reversed float depth can, but only if
/// every object's depth follows one mapping: a layer that recovers the camera's range from
/// each object's float32 matrix alone (whose depth row's translation carries n to a few % at
/// 1e6 n) gives every object its own, and at 1e5 n and 1e6 n the surfaces of different objects
/// cross where they are not meant to. See `conformance::bound` for the numbers.
pub fn far_objects() -> Scene {
    let objects = far_layout().into_iter().map(|(_, o)| o).collect();
    in_order("far-objects", far_objects_camera(), objects)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::View;

    fn ndc_box(scene: &Scene, index: usize, aspect: f64) -> ([f64; 3], [f64; 3]) {
        let o = &scene.objects[index];
        let mvp = scene.mvp_in(View::Camera, o, aspect);
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for p in scene.vertex_positions(o) {
            let c = mvp * p.extend(1.0);
            assert!(c.w > 0.0, "{}: {} behind the eye", scene.name, o.name);
            for (a, v) in [c.x / c.w, c.y / c.w, c.z / c.w].into_iter().enumerate() {
                lo[a] = lo[a].min(v);
                hi[a] = hi[a].max(v);
            }
        }
        (lo, hi)
    }

    #[test]
    fn colors_are_unique_in_every_accuracy_scene() {
        for scene in [
            sloped_plane(),
            mars_patch(),
            tori(),
            plane_stack(),
            deep_range(),
            decal_bias(),
            far_objects(),
        ] {
            let mut colors: Vec<[u8; 4]> = scene
                .objects
                .iter()
                .map(|o| o.color.map(|c| (c * 255.0).round() as u8))
                .collect();
            let n = colors.len();
            colors.sort_unstable();
            colors.dedup();
            assert_eq!(colors.len(), n, "{}", scene.name);
        }
    }

    #[test]
    fn the_red_square_is_on_screen_and_its_touching_edge_on_the_right() {
        let scene = sloped_plane();
        let (lo, hi) = ndc_box(&scene, 0, 4.0 / 3.0);
        assert!(lo[0] > -0.95 && hi[0] < 0.95 && lo[1] > -0.95 && hi[1] < 0.95);
        assert!(hi[0] - lo[0] > 0.6, "{lo:?} {hi:?}");
        let o = &scene.objects[0];
        let mvp = scene.mvp_in(View::Camera, o, 4.0 / 3.0);
        let c = mvp * DVec3::new(150.0, 0.0, 0.0).extend(1.0);
        assert!(c.x / c.w > 0.2, "{}", c.x / c.w);
    }

    #[test]
    fn the_mars_patch_floats_in_view_far_from_the_origin() {
        let scene = mars_patch();
        let (lo, hi) = ndc_box(&scene, 0, 4.0 / 3.0);
        assert!(lo[0] > -1.0 && hi[0] < 1.0 && lo[1] > -1.0 && hi[1] < 1.0);
        for p in scene.vertex_positions(&scene.objects[0]) {
            assert!(p.length() > 0.9 * SITE_DISTANCE);
        }
        let distance = (scene.camera.target - scene.camera.eye).length();
        assert!((10_000.0..15_000.0).contains(&distance), "{distance}");
    }

    #[test]
    fn stack_pairs_cover_the_same_cell() {
        let scene = plane_stack();
        for cell in stack_cells() {
            let (flo, fhi) = ndc_box(&scene, cell.front, STACK_ASPECT);
            let (blo, bhi) = ndc_box(&scene, cell.back, STACK_ASPECT);
            for a in 0..2 {
                assert!((flo[a] - blo[a]).abs() < 1e-5 && (fhi[a] - bhi[a]).abs() < 1e-5);
            }
        }
    }

    /// Each decade's three objects, in the base's frame: (base, top, sunk box) vertices.
    fn far_groups() -> Vec<(usize, [Vec<DVec3>; 3], [DMat4; 3])> {
        let layout = far_layout();
        (0..FAR_DISTANCES.len())
            .map(|decade| {
                let of = |name: &str| {
                    layout
                        .iter()
                        .map(|(_, o)| o)
                        .find(|o| o.name == name)
                        .unwrap_or_else(|| panic!("no {name}"))
                };
                let objects = FAR_NAMES[decade].map(of);
                let to_base = objects[0].model.inverse();
                let vertices = objects.map(|o| {
                    o.mesh
                        .positions_f64()
                        .map(|p| (to_base * o.model).transform_point3(p))
                        .collect::<Vec<_>>()
                });
                (decade, vertices, objects.map(|o| o.model))
            })
            .collect()
    }

    #[test]
    fn far_objects_groups_fill_one_cell_each_from_10_n_to_1e6_n() {
        let scene = far_objects();
        let camera = &scene.camera;
        assert!(
            camera.eye.length() > 3000.0,
            "the camera is near the origin"
        );
        assert_eq!((camera.near, camera.far), (FAR_NEAR, 1.0e6));
        let decades: Vec<usize> = far_layout().iter().map(|(d, _)| *d).collect();
        assert_eq!(decades.len(), scene.objects.len());
        for (n, &decade) in decades.iter().enumerate() {
            let d = FAR_DISTANCES[decade];
            let (lo, hi) = ndc_box(&scene, n, FAR_ASPECT);
            // Inside its cell of the 3 x 2 grid, with a margin.
            let (x0, y0) = (
                -1.0 + (decade % 3) as f64 * 2.0 / 3.0,
                -1.0 + (decade / 3) as f64,
            );
            assert!(
                lo[0] > x0 + 0.01 && hi[0] < x0 + 2.0 / 3.0 - 0.01,
                "{}: x {lo:?} {hi:?}",
                scene.objects[n].name
            );
            assert!(
                lo[1] > y0 + 0.01 && hi[1] < y0 + 1.0 - 0.01,
                "{}: y {lo:?} {hi:?}",
                scene.objects[n].name
            );
            // Its view distances within 20 % of the decade's.
            let o = &scene.objects[n];
            let mvp = scene.mvp_in(View::Camera, o, FAR_ASPECT);
            for p in scene.vertex_positions(o) {
                let w = (mvp * p.extend(1.0)).w;
                assert!((0.8 * d..1.2 * d).contains(&w), "{}: w {w}", o.name);
            }
        }
        // 10 n to 1e6 n, one decade each.
        for (d, next) in FAR_DISTANCES.iter().zip(&FAR_DISTANCES[1..]) {
            assert_eq!(next / d, 10.0);
        }
        assert_eq!(FAR_DISTANCES[0] / FAR_NEAR, 10.0);
        // Every decade shows a good number of checked pixels at the conformance size.
        let truth = crate::ground_truth::compute_ids(&scene, 96, 72).unwrap();
        for decade in 0..FAR_DISTANCES.len() {
            let checked = (0..truth.ids.len())
                .filter(|&at| truth.w[at].is_finite())
                .filter(|&at| decades[usize::from(truth.ids[at])] == decade)
                .count();
            assert!(checked > 150, "decade {decade}: {checked} checked pixels");
        }
    }

    #[test]
    fn far_objects_are_drawn_unsorted_each_with_its_own_matrix() {
        let scene = far_objects();
        let depths: Vec<f64> = scene.objects.iter().map(|o| scene.view_depth(o)).collect();
        let rising = depths.windows(2).filter(|w| w[0] < w[1]).count();
        assert!(
            rising > 2 && rising < depths.len() - 3,
            "nearly sorted: {depths:?}"
        );
        for (i, a) in scene.objects.iter().enumerate() {
            for b in &scene.objects[i + 1..] {
                assert_ne!(a.model, b.model, "{} and {}", a.name, b.name);
            }
        }
        // Inside a group, the order changes from group to group.
        let layout = far_layout();
        let firsts: Vec<&str> = layout
            .chunks(3)
            .map(|g| g[0].1.name.split(" at ").next().unwrap())
            .collect();
        assert!(
            firsts.contains(&"base") && firsts.contains(&"top"),
            "{firsts:?}"
        );
        assert!(firsts.contains(&"sunk box"), "{firsts:?}");
    }

    #[test]
    fn far_tops_stand_on_their_bases_and_sunk_boxes_cross_them() {
        let camera = far_objects_camera();
        for (decade, [base, top, sunk], [base_model, ..]) in far_groups() {
            let d = FAR_DISTANCES[decade];
            let max = |v: &[DVec3], f: fn(DVec3) -> f64| {
                v.iter().copied().map(f).fold(f64::NEG_INFINITY, f64::max)
            };
            let min = |v: &[DVec3], f: fn(DVec3) -> f64| {
                v.iter().copied().map(f).fold(f64::INFINITY, f64::min)
            };
            let (bx, by, bz) = (
                max(&base, |p| p.x),
                max(&base, |p| p.y),
                max(&base, |p| p.z),
            );
            let close = |a: f64, b: f64| (a - b).abs() <= 1e-6 * d;
            // The top's bottom face lies in the plane of the base's top face (to the rounding of
            // f32 vertices), its footprint well inside it.
            let bottom: Vec<DVec3> = top
                .iter()
                .copied()
                .filter(|p| p.y < by + 0.01 * d)
                .collect();
            assert_eq!(bottom.len(), 12, "decade {decade}: the top's bottom face");
            for p in &bottom {
                assert!(close(p.y, by), "decade {decade}: {p} on {by}");
                assert!(
                    p.x.abs() < bx - 0.01 * d && p.z.abs() < bz - 0.01 * d,
                    "{p}"
                );
            }
            // The sunk box crosses the base's top and front faces and nothing else: some of its
            // corners above the top face, some below; some in front of the front face, some
            // behind; all inside the base's sides, its bottom and back; apart from the top box.
            let above = sunk.iter().filter(|p| p.y > by).count();
            let in_front = sunk.iter().filter(|p| p.z > bz).count();
            assert!(
                above > 0 && above < sunk.len(),
                "decade {decade}: {above} above"
            );
            assert!(
                in_front > 0 && in_front < sunk.len(),
                "decade {decade}: {in_front}"
            );
            assert!(
                min(&sunk, |p| p.x) > -bx && max(&sunk, |p| p.x) < bx,
                "decade {decade}"
            );
            assert!(
                min(&sunk, |p| p.y) > -by && min(&sunk, |p| p.z) > -bz,
                "decade {decade}"
            );
            assert!(
                max(&sunk, |p| p.x) < min(&top, |p| p.x),
                "decade {decade}: sunk meets top"
            );
            // Seen from above and in front: the eye is above the base's top face and in front
            // of its front face.
            let eye = base_model.inverse().transform_point3(camera.eye);
            assert!(eye.y > by && eye.z > bz, "decade {decade}: eye at {eye}");
        }
    }
}
