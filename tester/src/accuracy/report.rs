//! `revz-tester report`: writes, in the output folder,
//!
//! - `report.json`: a JSON object `{ "device", "driver", "rows": [...], "min_separation":
//!   [...], "scenes": [...] }`. One row per (scene, delivery, mode, format) with `scene`,
//!   `delivery` (how the matrices reach the shader: `push`, `ubo`, `ubo-dynamic`, `ssbo`),
//!   `mode`,
//!   `format`, `vk_format`, `promoted_format` (the float format revz logged it promoted the
//!   depth image to, null where it did not), `depth_readback`, `device`,
//!   `wrong_pixel_fraction`, `checked_pixels`, `depth_reversed` (null without depth readback:
//!   the cases where promotion can apply, [`super::depth_readback`]), ..., and
//!   for `plane-stack` `min_rel_separation` per distance, for `far-objects` `decades` (the
//!   checked and wrong pixels of each decade's group). `min_separation` holds one entry per
//!   (delivery, mode, format, distance): measured and model minimum relative separations, their ratio,
//!   and whether they agree within a factor of 2 (or why they cannot be compared); a promoted
//!   row is compared with the model of the format it was stored in. An existing
//!   `report.json` keeps every other top-level key (the benchmark adds `speed`).
//! - `report.md`: the tables (with `far-objects`' per decade); anything after a line `<!-- speed -->` in an existing file is
//!   kept.
//! - `images/<scene>.png`: the expected image and every render side by side (rows: modes,
//!   columns: formats); `images/<scene>-<delivery>.png` for a buffer delivery's renders.
//! - `plots/min-separation-<format>.png`: `plane-stack`'s measured minimum separations (points)
//!   over the model's curves (lines: float32 simulation; grey: storage only), one color per
//!   mode; `plots/min-separation-<format>-<delivery>.png` for a buffer delivery.

use std::fmt::Write as _;
use std::path::Path;

use anyhow::{bail, Context, Result};
use serde::Serialize;
use serde_json::{Map, Value};

use super::conformance::stored_format;
use super::measure::{format_name, Measurement};
use super::model;
use super::scenes::{FAR_DISTANCES, FAR_NEAR, STACK_DISTANCES};
use super::{Mode, FORMATS};
use crate::plan::Delivery;
use crate::target::DepthFormat;

/// The line of `report.md` after which another tool's content is kept.
pub const SPEED_MARKER: &str = "<!-- speed -->";

/// The font the plots are drawn with.
pub const FONT: &str = "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf";

/// One entry of `min_separation`.
#[derive(Clone, Debug, Serialize)]
pub struct SeparationRow {
    /// How `plane-stack` handed its matrices to the shader (`push`, `ubo`, ...).
    pub delivery: &'static str,
    pub mode: &'static str,
    pub format: String,
    /// The float format revz promoted the depth image to (null: not promoted); the model is
    /// that format's.
    pub promoted_format: Option<String>,
    pub distance_over_near: f64,
    /// Measured on `plane-stack` (null: no separation of the scene, up to 0.56, resolved).
    pub min_rel_separation: Option<f64>,
    /// The float32 simulation's (null: nothing below 1 resolves).
    pub model_min_rel_separation: Option<f64>,
    /// The storage-only floor of the format.
    pub storage_min_rel_separation: Option<f64>,
    /// measured / model.
    pub ratio: Option<f64>,
    /// Within a factor of 2 (null where one of the two does not exist).
    pub agrees: Option<bool>,
    /// Why there is no comparison, or what limits it.
    pub note: String,
}

fn find<'a>(
    results: &'a [Measurement],
    scene: &str,
    delivery: &str,
    mode: &str,
    format: &str,
) -> Option<&'a Measurement> {
    results.iter().find(|m| {
        m.scene == scene && m.delivery == delivery && m.mode == mode && m.format == format
    })
}

/// The deliveries in `results`, in [`Delivery::ALL`] order.
pub fn deliveries_in(results: &[Measurement]) -> Vec<&'static str> {
    Delivery::ALL
        .iter()
        .map(|d| d.name())
        .filter(|d| results.iter().any(|m| m.delivery == *d))
        .collect()
}

/// The grid spacing of `plane-stack`'s separations: a measured value is the first grid point
/// at or above the true threshold.
const GRID_STEP: f64 = 1.778_279_41; // 10^(1/4)

/// Compares `plane-stack`'s measurements with the model.
pub fn separations(results: &[Measurement]) -> Vec<SeparationRow> {
    let mut rows = Vec::new();
    let smallest = super::scenes::stack_separations()[0];
    let largest = *super::scenes::stack_separations().last().expect("rows");
    let cases = deliveries_in(results).into_iter().flat_map(|delivery| {
        FORMATS
            .into_iter()
            .flat_map(move |format| Mode::ALL.map(move |mode| (delivery, format, mode)))
    });
    for (delivery, format, mode) in cases {
        let name = format_name(format);
        let Some(m) = find(
            results,
            "plane-stack",
            delivery,
            mode.variant().name(),
            &name,
        ) else {
            continue;
        };
        let Some(points) = &m.min_rel_separation else {
            continue;
        };
        let aspect = f64::from(m.width) / f64::from(m.height);
        let distances: Vec<f64> = points.iter().map(|p| p.distance_over_near).collect();
        // A promoted image stores the float format's values: its model is that format's.
        let stored = clap::ValueEnum::from_str(&stored_format(m), false).unwrap_or(format);
        let simulated = model::simulated(mode.variant(), stored, aspect, &distances);
        let floor = model::storage_only(mode.variant(), stored, &distances);
        for ((p, sim), storage) in points.iter().zip(simulated).zip(floor) {
            let (ratio, agrees, note) = match (p.min_rel_separation, sim) {
                (Some(measured), Some(model)) => {
                    let ratio = measured / model;
                    let agrees = (0.5..=2.0).contains(&ratio)
                        || (measured <= smallest && model <= smallest);
                    let note = if agrees {
                        String::new()
                    } else if measured < model {
                        "below the model: a cell is one pair of planes seen along one bundle of rays, and standard depth's error is a fixed function of position (the rounded matrix), so one cell can be luckier than the model's random pairs".into()
                    } else {
                        "above the model".into()
                    };
                    (Some(ratio), Some(agrees), note)
                }
                (None, None) => (
                    None,
                    None,
                    format!("neither resolves: nothing up to {largest:.2} in the scene, nothing below 1 in the model"),
                ),
                (None, Some(model)) => (
                    None,
                    None,
                    if model > largest / GRID_STEP {
                        format!("the model's {model:.2e} is at or beyond the scene's largest separation {largest:.2}")
                    } else {
                        format!("the model resolves {model:.2e}, the scene nothing up to {largest:.2}")
                    },
                ),
                (Some(measured), None) => (
                    None,
                    None,
                    format!("the scene resolves {measured:.2e}; the model nothing below 1"),
                ),
            };
            rows.push(SeparationRow {
                delivery: m.delivery,
                mode: m.mode,
                format: name.clone(),
                promoted_format: m.promoted_format.clone(),
                distance_over_near: p.distance_over_near,
                min_rel_separation: p.min_rel_separation,
                model_min_rel_separation: sim,
                storage_min_rel_separation: storage,
                ratio,
                agrees,
                note,
            });
        }
    }
    rows
}

/// Writes every output of the report.
pub fn write(out: &Path, results: &[Measurement]) -> Result<()> {
    let separation_rows = separations(results);
    write_json(out, results, &separation_rows)?;
    let images = super::report_images::side_by_side(out, results)?;
    let plots = super::report_images::plots(out, results, &separation_rows)?;
    write_markdown(out, results, &separation_rows, &images, &plots)?;
    for path in ["report.json", "report.md"] {
        println!("wrote: {}", out.join(path).display());
    }
    Ok(())
}

fn device_of(results: &[Measurement]) -> (String, String) {
    results
        .iter()
        .find(|m| !m.device.is_empty())
        .map(|m| (m.device.clone(), m.driver.clone()))
        .unwrap_or_default()
}

fn write_json(
    out: &Path,
    results: &[Measurement],
    separation_rows: &[SeparationRow],
) -> Result<()> {
    let path = out.join("report.json");
    let mut root: Map<String, Value> = match std::fs::read(&path) {
        Ok(bytes) => match serde_json::from_slice(&bytes) {
            Ok(Value::Object(map)) => map,
            _ => bail!("{} exists and is not a JSON object", path.display()),
        },
        Err(_) => Map::new(),
    };
    let (device, driver) = device_of(results);
    root.insert("device".into(), Value::String(device));
    root.insert("driver".into(), Value::String(driver));
    root.insert("rows".into(), serde_json::to_value(results)?);
    root.insert(
        "min_separation".into(),
        serde_json::to_value(separation_rows)?,
    );
    root.insert(
        "accuracy".into(),
        serde_json::json!({
            "metric": "wrong_pixel_fraction: checked pixels (at least one pixel away from any silhouette or intersection where another object shows) that show another object than the nearest one, over the checked pixels",
            "resolved_below": super::measure::RESOLVED_BELOW,
            "stack_distances_over_near": STACK_DISTANCES,
            "stack_separations": super::scenes::stack_separations(),
            "model": "revz_math::model::Simulation of plane-stack's camera, precomposed P * V, 2000 pairs per separation; storage-only: revz_math::model::min_separation_curve",
        }),
    );
    let mut text = serde_json::to_string_pretty(&Value::Object(root))?;
    text.push('\n');
    std::fs::write(&path, text).with_context(|| format!("cannot write {}", path.display()))
}

fn fraction(value: f64) -> String {
    if value == 0.0 {
        "0".into()
    } else {
        format!("{value:.1e}")
    }
}

fn opt(value: Option<f64>) -> String {
    value.map_or("-".into(), |v| format!("{v:.1e}"))
}

fn write_markdown(
    out: &Path,
    results: &[Measurement],
    separation_rows: &[SeparationRow],
    images: &[String],
    plots: &[String],
) -> Result<()> {
    let (device, driver) = device_of(results);
    let formats: Vec<String> = FORMATS
        .iter()
        .map(|f| format_name(*f))
        .filter(|f| results.iter().any(|m| &m.format == f))
        .collect();
    let mut md = String::new();
    let _ = writeln!(md, "# revz accuracy report\n");
    let _ = writeln!(md, "Device: {device} ({driver}).\n");
    let _ = writeln!(
        md,
        "wrong_pixel_fraction per scene, mode, projection delivery and depth format: the checked pixels (at least one pixel away from any silhouette or intersection where another object shows) that show another object than the nearest one. `none` is the application's standard depth without the layer; the others are revz modes. An `R` marks depth read back reversed; `!` a failed render; `as D32_SFLOAT` (or `as D32_SFLOAT_S8_UINT`) a depth image revz promoted to that float format. The cases where promotion can apply (D16, X8_D24 and D24_S8 in the modes that promote) are rendered without depth readback, which would prevent it: they show no `R`. The delivery says how the application hands its matrices to the vertex shader: `push` constants, or buffers (`ubo`: P, V and M apart in a dynamic uniform buffer; `ubo-dynamic`: P * V in a uniform buffer, the model matrix in a dynamic one; `ssbo`: P * V * M in a storage buffer).\n"
    );
    let _ = write!(md, "| scene | mode | delivery |");
    for f in &formats {
        let _ = write!(md, " {f} |");
    }
    md.push_str("\n|---|---|---|");
    for _ in &formats {
        md.push_str("---|");
    }
    md.push('\n');
    let mut scenes: Vec<&str> = Vec::new();
    for m in results {
        if !scenes.contains(&m.scene) {
            scenes.push(m.scene);
        }
    }
    let deliveries = deliveries_in(results);
    for scene in &scenes {
        for (mode, delivery) in Mode::ALL
            .iter()
            .flat_map(|mode| deliveries.iter().map(move |d| (mode.variant().name(), *d)))
        {
            if !results
                .iter()
                .any(|m| m.scene == *scene && m.mode == mode && m.delivery == delivery)
            {
                continue;
            }
            let _ = write!(md, "| {scene} | {mode} | {delivery} |");
            for f in &formats {
                let cell = match find(results, scene, delivery, mode, f) {
                    Some(m) if m.error.is_some() => "!".to_string(),
                    Some(m) => format!(
                        "{}{}{}",
                        fraction(m.wrong_pixel_fraction),
                        if m.depth_reversed == Some(true) {
                            " R"
                        } else {
                            ""
                        },
                        m.promoted_format
                            .as_deref()
                            .map(|f| format!(" as {f}"))
                            .unwrap_or_default()
                    ),
                    None => "".into(),
                };
                let _ = write!(md, " {cell} |");
            }
            md.push('\n');
        }
    }
    let far: Vec<&Measurement> = results
        .iter()
        .filter(|m| m.scene == "far-objects" && m.decades.is_some())
        .collect();
    if !far.is_empty() {
        let _ = writeln!(
            md,
            "\n## Per decade (`far-objects`)\n\nwrong_pixel_fraction of each group (a base, a top box standing on it, a box sunk into it, each with its own P * V * M) by its view distance over the near plane; `-` where the group has no checked pixel.\n"
        );
        md.push_str("| mode | delivery | format |");
        for d in FAR_DISTANCES {
            let _ = write!(md, " {:.0e} n |", d / FAR_NEAR);
        }
        md.push_str("\n|---|---|---|");
        for _ in FAR_DISTANCES {
            md.push_str("---|");
        }
        md.push('\n');
        for m in far {
            let format = match &m.promoted_format {
                Some(promoted) => format!("{} as {promoted}", m.format),
                None => m.format.clone(),
            };
            let _ = write!(md, "| {} | {} | {format} |", m.mode, m.delivery);
            for decade in m.decades.iter().flatten() {
                let cell = if decade.checked == 0 {
                    "-".to_string()
                } else {
                    fraction(decade.wrong_pixel_fraction)
                };
                let _ = write!(md, " {cell} |");
            }
            md.push('\n');
        }
    }
    if !separation_rows.is_empty() {
        let _ = writeln!(
            md,
            "\n## Minimum separation (`plane-stack`)\n\nThe smallest relative separation dz/z at which fewer than 1 % of a cell's checked pixels are wrong (scene grid: 4 per decade, 1e-7 to 0.56), beside the precision model's float32 simulation (grid: 10 per decade) and the format's storage-only floor; `ok` where they agree within a factor of 2.\n"
        );
        md.push_str("| mode | delivery | format | d / n | measured | model | storage | ratio | |\n|---|---|---|---|---|---|---|---|---|\n");
        for r in separation_rows {
            let format = match &r.promoted_format {
                Some(promoted) => format!("{} as {promoted}", r.format),
                None => r.format.clone(),
            };
            let _ = writeln!(
                md,
                "| {} | {} | {} | {:.0e} | {} | {} | {} | {} | {} |",
                r.mode,
                r.delivery,
                format,
                r.distance_over_near,
                opt(r.min_rel_separation),
                opt(r.model_min_rel_separation),
                opt(r.storage_min_rel_separation),
                r.ratio.map_or("-".into(), |v| format!("{v:.2}")),
                match r.agrees {
                    Some(true) => "ok".to_string(),
                    _ => r.note.clone(),
                }
            );
        }
    }
    if !plots.is_empty() {
        md.push_str("\n## Plots\n\n");
        for p in plots {
            let _ = writeln!(md, "![{p}]({p})\n");
        }
    }
    if !images.is_empty() {
        md.push_str("\n## Renders\n\nEach image: the expected objects (top left), then one row per mode (none, flip, complementary, infinite) and one column per format.\n\n");
        for i in images {
            let _ = writeln!(md, "![{i}]({i})\n");
        }
    }
    let path = out.join("report.md");
    if let Ok(old) = std::fs::read_to_string(&path) {
        if let Some(at) = old.find(SPEED_MARKER) {
            md.push('\n');
            md.push_str(&old[at..]);
        }
    }
    std::fs::write(&path, md).with_context(|| format!("cannot write {}", path.display()))
}

/// The formats in `results`, in report order.
pub fn formats_in(results: &[Measurement]) -> Vec<DepthFormat> {
    FORMATS
        .iter()
        .copied()
        .filter(|f| results.iter().any(|m| m.format == format_name(*f)))
        .collect()
}
