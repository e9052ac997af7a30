//! `revz-tester profile <report.json> --precision`: what each depth policy would buy an
//! application revz ran on, from its depth profile alone.
//!
//! The profile names every camera revz recognised (near, far, convention, whether the
//! application reverses depth itself) and every depth image's format. For each camera this
//! module asks the precision model of `revz_math::model` (the float32 simulation of the vertex
//! path that the accuracy report checks against `plane-stack`'s measurements) for the smallest
//! relative separation dz/z that resolves at each decade of distance from the near plane to
//! the far one (to 1e6 near-plane distances for an infinite far plane, and for the `infinite`
//! policy, which removes the far plane), under each policy revz offers (`none`, `flip`,
//! `complementary`, `infinite`) and each storage (the application's own formats, D24, D32F).
//! The policy and storage in force in the profiled run are marked.
//!
//! What the model assumes that the profile does not say: the camera at the world's origin
//! (a camera far from it loses more to the float32 rounding of a precomposed P*V*M), a
//! 60-degree, 16:9 frustum, P*V*M precomposed and pushed as one matrix, and Vulkan's [0, 1]
//! depth (an OpenGL application's [-1, 1] has the same stored grid after the viewport
//! transform). Where the application reverses depth itself, revz leaves its depth as it is:
//! every policy then gives what `none` gives.

use std::path::Path;

use anyhow::{anyhow, Result};
use glam::{DQuat, EulerRot};
use plotters::prelude::*;

use crate::accuracy::report_images::{legend, separation_chart};
use revz_math::model::{Camera, Mapping, Simulation, StorageFormat, VertexTransform};
use revz_math::VisibleRange;
use serde::Serialize;
use serde_json::Value;

/// Surface pairs per tried separation: enough for the 1% threshold to about one grid step of
/// the simulation, small enough for a profile with a few cameras to print in seconds.
const PAIRS: usize = 1000;

/// The farthest distance shown, in near-plane distances, where the far plane is infinite or
/// removed.
const INFINITE_REACH: f64 = 1e6;

/// A policy revz offers (its `mode` setting, `none` being no reversal at all).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Policy {
    None,
    Flip,
    Complementary,
    Infinite,
}

impl Policy {
    const ALL: [Policy; 4] = [
        Policy::None,
        Policy::Flip,
        Policy::Complementary,
        Policy::Infinite,
    ];

    fn name(self) -> &'static str {
        match self {
            Policy::None => "none",
            Policy::Flip => "flip",
            Policy::Complementary => "complementary",
            Policy::Infinite => "infinite",
        }
    }

    /// The policy of revz's `mode` setting (`off` reverses nothing: `none`).
    fn of_mode(mode: &str) -> Option<Policy> {
        match mode {
            "off" => Some(Policy::None),
            "flip" => Some(Policy::Flip),
            "complementary" => Some(Policy::Complementary),
            "infinite" => Some(Policy::Infinite),
            _ => None,
        }
    }

    /// The depth mapping the policy stores for a camera, and whether it removes the far plane.
    /// `flip` stores 1 - D of the standard mapping: the same grid as standard depth, so the
    /// same precision. An application that reverses depth itself keeps its own mapping.
    fn mapping(self, app_reversed: bool, infinite_far: bool) -> (Mapping, bool) {
        let own = if app_reversed {
            if infinite_far {
                Mapping::InfiniteReversed
            } else {
                Mapping::Complementary
            }
        } else {
            Mapping::Standard
        };
        match self {
            _ if app_reversed => (own, infinite_far),
            Policy::None | Policy::Flip => (own, infinite_far),
            Policy::Complementary => (Mapping::Complementary, infinite_far),
            Policy::Infinite => (Mapping::InfiniteReversed, true),
        }
    }
}

/// A storage the table compares: a depth format's grid.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum Storage {
    D16,
    D24,
    D32F,
}

impl Storage {
    fn name(self) -> &'static str {
        match self {
            Storage::D16 => "D16",
            Storage::D24 => "D24",
            Storage::D32F => "D32F",
        }
    }

    fn format(self) -> StorageFormat {
        match self {
            Storage::D16 => StorageFormat::D16,
            Storage::D24 => StorageFormat::D24,
            Storage::D32F => StorageFormat::D32F,
        }
    }

    /// The grid of a Vulkan depth format's name as the profile writes it.
    fn of_format(name: &str) -> Option<Storage> {
        if name.starts_with("D16") {
            Some(Storage::D16)
        } else if name.contains("D24") {
            Some(Storage::D24)
        } else if name.starts_with("D32") {
            Some(Storage::D32F)
        } else {
            None
        }
    }
}

/// One row of a camera's table: a policy in a storage, and the smallest resolvable dz/z at
/// each of the camera's distances (`None`: nothing up to dz = z resolves, or the distance is
/// beyond the policy's far plane).
#[derive(Clone, Debug, Serialize)]
pub struct Row {
    pub policy: Policy,
    pub storage: Storage,
    /// The policy and storage of the profiled run.
    pub in_force: bool,
    pub min_rel_separation: Vec<Option<f64>>,
}

/// What the model says for one camera of the profile.
#[derive(Clone, Debug, Serialize)]
pub struct CameraPrecision {
    /// Which camera: `camera <index in the profile's cameras>`, or `given` for the one of
    /// `--near` / `--far`.
    pub camera: String,
    pub near: f64,
    /// `None`: the camera's projection has an infinite far plane.
    pub far: Option<f64>,
    /// The application renders reversed depth itself (revz leaves it).
    pub app_reversed: bool,
    /// The distances of the columns, in near-plane distances.
    pub distances_over_near: Vec<f64>,
    pub rows: Vec<Row>,
}

/// A camera the profile does not name, from the command line (`--near`, `--far`): revz reads
/// cameras from pushed matrices only; a projection in a buffer (OpenGL through Zink, most
/// engines) has its range fitted by the vertex stage on the device, where revz's host side
/// never sees it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GivenCamera {
    pub near: f64,
    /// `None`: an infinite far plane.
    pub far: Option<f64>,
}

/// The precision tables of a whole profile.
#[derive(Clone, Debug, Serialize)]
pub struct Precision {
    /// revz's mode in the profiled run.
    pub mode: String,
    /// The storage in force (the promoted format where revz promoted the depth images).
    pub storage_in_force: Option<Storage>,
    pub cameras: Vec<CameraPrecision>,
}

/// Decades from 1 near-plane distance to `reach` (inclusive where it is one), in near-plane
/// distances.
fn decades(reach: f64) -> Vec<f64> {
    (0..=12)
        .map(|k| 10f64.powi(k))
        .take_while(|&d| d <= reach * (1.0 + 1e-9))
        .collect()
}

/// The camera the model assumes: at the origin, 60 degrees, 16:9, looking neither along an
/// axis nor level (yaw 30, pitch -20 degrees). An axis-aligned camera would flatter every
/// policy: its view rotation is exact in float32, where an application's camera rotation
/// mixes every world coordinate into depth and rounds.
fn model_camera() -> Camera {
    let (yaw, pitch) = (30f64.to_radians(), (-20f64).to_radians());
    Camera {
        orientation: DQuat::from_euler(EulerRot::YXZ, yaw, pitch, 0.0),
        ..Camera::default()
    }
}

/// The model's smallest resolvable dz/z for one policy and storage at `distances` (in
/// near-plane distances); `None` beyond the mapping's far plane.
fn separations(
    mapping: Mapping,
    storage: Storage,
    range: VisibleRange,
    distances: &[f64],
) -> Vec<Option<f64>> {
    let simulation = Simulation {
        camera: model_camera(),
        range,
        mapping,
        format: storage.format(),
        transform: VertexTransform::Precomposed,
        pairs: PAIRS,
        seed: 1,
    };
    distances
        .iter()
        .map(|&d| simulation.min_separation(d * range.near()).ok().flatten())
        .collect()
}

/// The storages a profile's tables compare: the formats its depth images are created with,
/// then D24 and D32F.
fn storages(profile: &Value) -> Vec<Storage> {
    let mut storages = Vec::new();
    let own = profile["images"]
        .as_array()
        .into_iter()
        .flatten()
        .filter_map(|image| image["format"].as_str().and_then(Storage::of_format));
    for storage in own.chain([Storage::D24, Storage::D32F]) {
        if !storages.contains(&storage) {
            storages.push(storage);
        }
    }
    storages
}

/// The storage the profiled run stored depth in: the first reversed image's promoted format,
/// or its own (the first image's where none is reversed).
fn storage_in_force(profile: &Value) -> Option<Storage> {
    let images: Vec<&Value> = profile["images"].as_array().into_iter().flatten().collect();
    let image = images
        .iter()
        .find(|i| i["depth"] == "reversed")
        .or(images.first())?;
    image["promoted_format"]
        .as_str()
        .or(image["format"].as_str())
        .and_then(Storage::of_format)
}

/// The model's tables for every camera of `profile`.
///
/// # Errors
///
/// A camera whose near plane is not positive and finite, or whose far is not beyond it.
pub fn of_profile(profile: &Value, given: Option<GivenCamera>) -> Result<Precision> {
    let mode = profile["settings"]
        .as_array()
        .into_iter()
        .flatten()
        .find(|s| s["name"] == "mode")
        .and_then(|s| s["value"].as_str())
        .unwrap_or("")
        .to_owned();
    let policy_in_force = Policy::of_mode(&mode);
    let storage_in_force = storage_in_force(profile);
    let storages = storages(profile);
    let mut cameras = Vec::new();
    let recognised = profile["cameras"]
        .as_array()
        .into_iter()
        .flatten()
        .enumerate()
        .map(
            |(index, camera)| -> Result<(String, f64, Option<f64>, bool)> {
                let near = camera["near"]
                    .as_f64()
                    .ok_or_else(|| anyhow!("camera {index} has no near plane"))?;
                Ok((
                    format!("camera {index}"),
                    near,
                    camera["far"].as_f64(),
                    camera["direction"] == "Reversed",
                ))
            },
        );
    let given = given.map(|g| Ok(("given".to_owned(), g.near, g.far, false)));
    for camera in recognised.chain(given) {
        let (name, near, far, app_reversed) = camera?;
        let finite = match far {
            Some(far) => VisibleRange::new(near, far),
            None => VisibleRange::infinite(near),
        }
        .map_err(|e| anyhow!("{name}: {e:?}"))?;
        let infinite = VisibleRange::infinite(near).map_err(|e| anyhow!("{name}: {e:?}"))?;
        // The simulation's nearer surfaces spread a tenth beyond the distance: the last column
        // leaves that room before a finite far plane.
        let reach = far.map_or(INFINITE_REACH, |far| far / near / 1.1);
        let any_removes_far = Policy::ALL
            .iter()
            .any(|p| p.mapping(app_reversed, far.is_none()).1);
        let distances = decades(if any_removes_far {
            reach.max(INFINITE_REACH)
        } else {
            reach
        });
        let mut rows = Vec::new();
        for policy in Policy::ALL {
            let (mapping, removes_far) = policy.mapping(app_reversed, far.is_none());
            let range = if removes_far { infinite } else { finite };
            let limit = if removes_far { INFINITE_REACH } else { reach };
            let shown: Vec<f64> = distances
                .iter()
                .copied()
                .filter(|&d| d <= limit * (1.0 + 1e-9))
                .collect();
            for &storage in &storages {
                let mut values = separations(mapping, storage, range, &shown);
                values.resize(distances.len(), None);
                rows.push(Row {
                    policy,
                    storage,
                    in_force: Some(policy) == policy_in_force && Some(storage) == storage_in_force,
                    min_rel_separation: values,
                });
            }
        }
        cameras.push(CameraPrecision {
            camera: name,
            near,
            far,
            app_reversed,
            distances_over_near: distances,
            rows,
        });
    }
    Ok(Precision {
        mode,
        storage_in_force,
        cameras,
    })
}

fn cell(value: Option<f64>) -> String {
    value.map_or_else(|| "-".to_owned(), |v| format!("{v:.1e}"))
}

/// The tables as text (markdown).
pub fn render(precision: &Precision) -> String {
    let mut out = String::new();
    out.push_str(
        "smallest separation dz/z that resolves at each distance (in near-plane distances n), \
         per policy and storage: float32 vertex path simulated (P*V*M precomposed, camera \
         at the origin turned 30 degrees and tilted 20, 60-degree 16:9 frustum, fewer than 1% \
         of pairs in the wrong order); * the policy and storage in force; - nothing up to \
         dz = z resolves, or beyond the far plane\n",
    );
    if precision.cameras.is_empty() {
        out.push_str(
            "\nno camera recognised: revz reads cameras from pushed matrices only (a projection \
             in a buffer has its range fitted on the device); give one with --near and --far\n",
        );
    }
    for camera in &precision.cameras {
        out.push('\n');
        out.push_str(&format!(
            "{}: near {:.4e}, far {}{}\n",
            camera.camera,
            camera.near,
            camera
                .far
                .map_or_else(|| "infinite".to_owned(), |f| format!("{f:.4e}")),
            if camera.app_reversed {
                " (the application reverses depth itself: revz leaves it, every policy is none)"
            } else {
                ""
            }
        ));
        let header: Vec<String> = camera
            .distances_over_near
            .iter()
            .map(|d| format!("{d:.0e} n"))
            .collect();
        out.push_str(&format!("| policy | storage | {} |\n", header.join(" | ")));
        out.push_str(&format!(
            "|---|---|{}\n",
            "---:|".repeat(camera.distances_over_near.len())
        ));
        for row in &camera.rows {
            let cells: Vec<String> = row.min_rel_separation.iter().map(|v| cell(*v)).collect();
            out.push_str(&format!(
                "| {}{} | {} | {} |\n",
                row.policy.name(),
                if row.in_force { " *" } else { "" },
                row.storage.name(),
                cells.join(" | ")
            ));
        }
    }
    out
}

fn policy_color(policy: Policy) -> RGBColor {
    match policy {
        Policy::None => RGBColor(200, 40, 40),
        Policy::Flip => RGBColor(230, 150, 20),
        Policy::Complementary => RGBColor(40, 140, 60),
        Policy::Infinite => RGBColor(40, 80, 220),
    }
}

/// One plot per camera, stacked: dz/z over distance, a line per policy and storage (dashes
/// for D16, thin for D24, thick for D32F), the one in force marked with dots.
pub fn plot(precision: &Precision, png: &Path) -> Result<()> {
    crate::accuracy::report_images::font()?;
    let panels = precision.cameras.len().max(1);
    let height = 420 * panels as u32;
    let root = BitMapBackend::new(png, (820, height)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| anyhow!("{e}"))?;
    let areas = root.split_evenly((panels, 1));
    for (camera, area) in precision.cameras.iter().zip(&areas) {
        let reach = camera
            .distances_over_near
            .last()
            .copied()
            .unwrap_or(10.0)
            .max(10.0);
        let caption = format!(
            "{} (near {:.3e}, far {}): smallest dz/z resolved, per policy and storage",
            camera.camera,
            camera.near,
            camera
                .far
                .map_or_else(|| "infinite".to_owned(), |f| format!("{f:.3e}"))
        );
        let mut chart = separation_chart(area, caption, 16, 0.8..reach * 1.25)?;
        for row in &camera.rows {
            let color = policy_color(row.policy);
            let points: Vec<(f64, f64)> = camera
                .distances_over_near
                .iter()
                .zip(&row.min_rel_separation)
                .filter_map(|(d, v)| v.map(|v| (*d, v)))
                .collect();
            let width = match row.storage {
                Storage::D16 => 1,
                Storage::D24 => 2,
                Storage::D32F => 4,
            };
            let style = if row.storage == Storage::D16 {
                color.mix(0.5).stroke_width(width)
            } else {
                color.stroke_width(width)
            };
            let label = format!(
                "{} {}{}",
                row.policy.name(),
                row.storage.name(),
                if row.in_force { " (in force)" } else { "" }
            );
            chart
                .draw_series(LineSeries::new(points.clone(), style))
                .map_err(|e| anyhow!("{e}"))?
                .label(label)
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], style));
            if row.in_force {
                chart
                    .draw_series(points.iter().map(|&p| Circle::new(p, 5, BLACK.filled())))
                    .map_err(|e| anyhow!("{e}"))?;
            }
        }
        legend(&mut chart, 11)?;
    }
    root.present().map_err(|e| anyhow!("{e}"))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    fn profile(direction: &str, far: Value) -> Value {
        json!({
            "settings": [{"name": "mode", "value": "infinite", "from": "default"}],
            "images": [{"format": "D24_UNORM_S8_UINT", "promoted_format": "D32_SFLOAT_S8_UINT",
                        "depth": "reversed"}],
            "cameras": [{"near": 0.1, "far": far, "direction": direction,
                         "convention": "ZeroToOne"}],
        })
    }

    #[test]
    fn every_policy_and_storage_gets_a_row_and_the_run_in_force_is_marked() {
        let precision = of_profile(&profile("Standard", json!(1000.0)), None).unwrap();
        assert_eq!(precision.storage_in_force, Some(Storage::D32F));
        let camera = &precision.cameras[0];
        // D24 (the image's own) and D32F, four policies.
        assert_eq!(camera.rows.len(), 8);
        let marked: Vec<&Row> = camera.rows.iter().filter(|r| r.in_force).collect();
        assert_eq!(marked.len(), 1);
        assert_eq!(
            (marked[0].policy, marked[0].storage),
            (Policy::Infinite, Storage::D32F)
        );
        // The infinite policy removes the far plane: the columns reach 1e6 n, the finite
        // policies stop before far (1e4 n) and show nothing beyond.
        assert_eq!(camera.distances_over_near.last(), Some(&1e6));
        let standard = camera
            .rows
            .iter()
            .find(|r| r.policy == Policy::None && r.storage == Storage::D24)
            .unwrap();
        assert!(standard.min_rel_separation[4..].iter().all(Option::is_none));
        let infinite = marked[0];
        assert!(infinite.min_rel_separation.iter().all(Option::is_some));
        let text = render(&precision);
        assert!(text.contains("| infinite * | D32F |"), "{text}");
    }

    #[test]
    fn reversed_float_depth_beats_standard_float_depth_far_away() {
        let precision = of_profile(&profile("Standard", json!(1000.0)), None).unwrap();
        let rows = &precision.cameras[0].rows;
        let at = |policy, storage, column: usize| {
            rows.iter()
                .find(|r| r.policy == policy && r.storage == storage)
                .unwrap()
                .min_rel_separation[column]
        };
        // 1000 n: standard float32 depth crowds near 1, complementary spreads it.
        let standard = at(Policy::None, Storage::D32F, 3).unwrap_or(1.0);
        let complementary = at(Policy::Complementary, Storage::D32F, 3).unwrap();
        assert!(
            complementary * 10.0 < standard,
            "{complementary} vs {standard}"
        );
        // flip keeps standard depth's grid.
        assert_eq!(
            at(Policy::Flip, Storage::D32F, 3),
            at(Policy::None, Storage::D32F, 3)
        );
    }

    #[test]
    fn an_application_that_reverses_depth_itself_gets_its_own_mapping_under_every_policy() {
        let precision = of_profile(&profile("Reversed", Value::Null), None).unwrap();
        let camera = &precision.cameras[0];
        assert!(camera.app_reversed);
        let of = |policy| {
            camera
                .rows
                .iter()
                .find(|r| r.policy == policy && r.storage == Storage::D32F)
                .unwrap()
                .min_rel_separation
                .clone()
        };
        for policy in Policy::ALL {
            assert_eq!(of(policy), of(Policy::None));
        }
    }

    #[test]
    fn a_profile_without_cameras_says_so() {
        let empty = json!({"settings": [], "images": [], "cameras": []});
        let precision = of_profile(&empty, None).unwrap();
        assert!(render(&precision).contains("no camera recognised"));
        // A camera given on the command line gets its table, with the storages compared.
        let given = GivenCamera {
            near: 0.5,
            far: None,
        };
        let precision = of_profile(&empty, Some(given)).unwrap();
        assert_eq!(precision.cameras.len(), 1);
        assert_eq!(precision.cameras[0].camera, "given");
        assert_eq!(precision.cameras[0].far, None);
        assert_eq!(precision.cameras[0].rows.len(), 8);
        assert!(render(&precision).contains("given: near 5.0000e-1, far infinite"));
    }
}
