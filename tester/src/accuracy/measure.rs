//! One accuracy measurement: render a scene in one mode and depth format (a child tester
//! process, through [`Runner`]), then compare every checked pixel's color with the object the
//! ground truth says is visible there.
//!
//! Checked pixels are the interior ones of the ground truth (an object, and the same object at
//! all 8 neighbouring pixel centers): at least one pixel away from any silhouette edge or
//! intersection line where another object shows. A checked pixel whose color is not the
//! expected object's is a depth error. The rendered color names an object because every object
//! of a scene has its own color (`render.json` lists them).
//!
//! The child runs with revz's log at `info` (`REVZ_LOG`; on stderr, kept in the render's
//! `log.txt`), where the layer says once per depth image whether it reversed it and, when it
//! promoted it to a float format, which one (`... (D16_UNORM, 480x360): reversed, promoted to
//! D32_SFLOAT (N more bytes)`): [`promoted_format`] reads the main depth image's line.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::process::Output;

use anyhow::{Context, Result};
use serde::Serialize;

use super::Promotion;
use crate::ground_truth::{self, GroundTruth, BACKGROUND};
use crate::plan::Delivery;
use crate::scene::SceneId;
use crate::target::DepthFormat;
use crate::variants::{Runner, Variant};

/// Fraction of wrong checked pixels below which a separation counts as resolved (as
/// `revz_math::model::WRONG_ORDER_LIMIT`).
pub const RESOLVED_BELOW: f64 = 0.01;

/// The id of a color no object of the scene wears.
const UNKNOWN: u16 = u16::MAX - 1;

/// What to render.
#[derive(Clone, Debug)]
pub struct Case {
    pub scene: SceneId,
    /// How the scene hands its matrices to the shader (`--delivery`).
    pub delivery: Delivery,
    pub variant: Variant,
    pub format: DepthFormat,
    pub width: u32,
    pub height: u32,
    /// Whether the depth image is read back (else the child runs with `--no-depth-readback`,
    /// and the image has no transfer usage, so revz may promote it).
    pub depth_readback: bool,
    /// revz's `promote_depth_formats` (`REVZ_PROMOTE_DEPTH_FORMATS`); `None`: not set.
    pub promote_depth_formats: Option<Promotion>,
}

/// The outcome of one case.
#[derive(Clone, Debug, Serialize)]
pub struct Measurement {
    pub scene: &'static str,
    /// How the scene handed its matrices to the shader: `push` (push constants), `ubo`,
    /// `ubo-dynamic`, `ssbo` (buffers; issue #16).
    pub delivery: &'static str,
    /// `none` (no layer: standard depth), `flip`, `complementary`, `infinite`.
    pub mode: &'static str,
    /// The CLI name of the depth format (`d32`, ...).
    pub format: String,
    /// Its Vulkan name.
    pub vk_format: &'static str,
    /// The Vulkan name of the format revz logged it promoted the depth image to
    /// (`D32_SFLOAT`, `D32_SFLOAT_S8_UINT`); null where it did not promote it.
    pub promoted_format: Option<String>,
    /// Whether the depth image was read back (false where promotion can apply: the readback's
    /// TRANSFER_SRC usage would prevent it).
    pub depth_readback: bool,
    pub device: String,
    pub driver: String,
    pub width: u32,
    pub height: u32,
    /// Interior pixels compared with the ground truth.
    pub checked_pixels: usize,
    /// Checked pixels that show another object than the ground truth's.
    pub wrong_pixels: usize,
    /// `wrong_pixels / checked_pixels` (1 when the render failed).
    pub wrong_pixel_fraction: f64,
    /// Whether the depth read back decreases with distance (null when it cannot tell, and
    /// where depth was not read back).
    pub depth_reversed: Option<bool>,
    /// Validation messages the child counted.
    pub validation_messages: u32,
    /// Why the child rendered without validation (a validation layer older than an extension
    /// the case needs: `render.json`'s `validation_skipped`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub validation_skipped: Option<String>,
    /// Why the render failed, if it did (validation messages included).
    pub error: Option<String>,
    /// The render's folder, relative to the output folder.
    pub dir: String,
    /// `plane-stack`: per cell, (column, row, checked, wrong).
    #[serde(skip)]
    pub cells: Vec<CellResult>,
    /// `plane-stack`: the smallest relative separation from which on every larger one of the
    /// scene resolves (fewer than 1 % of the cell wrong), per distance.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub min_rel_separation: Option<Vec<StackPoint>>,
    /// `far-objects`: the checked and wrong pixels of each decade's group.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub decades: Option<Vec<DecadeResult>>,
}

impl Measurement {
    /// A case of `scene` in `mode` not measured yet: nothing checked, everything wrong, depth
    /// read back, no device; [`compare`] fills the counts.
    pub fn blank(
        scene: &'static str,
        mode: &'static str,
        format: DepthFormat,
        width: u32,
        height: u32,
    ) -> Measurement {
        Measurement {
            scene,
            delivery: "push",
            mode,
            format: format_name(format),
            vk_format: format.vk_name(),
            promoted_format: None,
            depth_readback: true,
            device: String::new(),
            driver: String::new(),
            width,
            height,
            checked_pixels: 0,
            wrong_pixels: 0,
            wrong_pixel_fraction: 1.0,
            depth_reversed: None,
            validation_messages: 0,
            validation_skipped: None,
            error: None,
            dir: String::new(),
            cells: Vec::new(),
            min_rel_separation: None,
            decades: None,
        }
    }
}

/// One `far-objects` group's count: the checked pixels whose expected object is one of the
/// group's.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct DecadeResult {
    /// The group's view distance over the near plane.
    pub distance_over_near: f64,
    pub checked: usize,
    pub wrong: usize,
    /// `wrong / checked` (1 when nothing is checked).
    pub wrong_pixel_fraction: f64,
}

/// One `plane-stack` cell's count.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct CellResult {
    pub column: usize,
    pub row: usize,
    pub checked: usize,
    pub wrong: usize,
}

/// A measured minimum separation at one distance.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct StackPoint {
    pub distance_over_near: f64,
    /// Null when no separation of the scene resolves.
    pub min_rel_separation: Option<f64>,
}

/// The CLI name of a depth format.
pub fn format_name(format: DepthFormat) -> String {
    clap::ValueEnum::to_possible_value(&format)
        .map(|v| v.get_name().to_string())
        .unwrap_or_else(|| format.vk_name().to_string())
}

/// The format revz logged it promoted the `vk_format` depth image of `width` x `height` to:
/// the Vulkan name after `promoted to ` on that image's line (`depth image 0x.. (D16_UNORM,
/// 480x360): reversed, promoted to D32_SFLOAT (N more bytes)`, or `): native, because ...;
/// promoted to ...`); `None` when no such line says it was promoted.
pub fn promoted_format(log: &str, vk_format: &str, width: u32, height: u32) -> Option<String> {
    const PROMOTED: &str = "promoted to ";
    let image = format!("({vk_format}, {width}x{height}): ");
    log.lines()
        .filter(|line| line.contains("depth image") && line.contains(&image))
        .find_map(|line| {
            let at = line.find(PROMOTED)? + PROMOTED.len();
            let name: String = line[at..]
                .chars()
                .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
                .collect();
            (!name.is_empty()).then_some(name)
        })
}

/// The scene's ground truth at a size (computed once per scene and size).
pub struct Truth {
    pub truth: GroundTruth,
    /// Color (RGBA8) -> object id.
    colors: HashMap<[u8; 4], u16>,
}

impl Truth {
    pub fn new(id: SceneId, width: u32, height: u32) -> Result<Truth> {
        let scene = id.build();
        let truth = ground_truth::compute_ids(&scene, width, height)
            .map_err(|e| anyhow::anyhow!("scene {} has no ground truth: {e}", scene.name))?;
        let mut colors = HashMap::new();
        for (n, object) in scene.objects.iter().enumerate() {
            let rgba = object.color.map(|c| (c * 255.0).round() as u8);
            let id = u16::try_from(n).context("too many objects")?;
            if colors.insert(rgba, id).is_some() {
                anyhow::bail!("scene {}: two objects share the color {rgba:?}", scene.name);
            }
        }
        Ok(Truth { truth, colors })
    }

    /// The object a rendered color shows ([`BACKGROUND`] for the clear color, `UNKNOWN` for
    /// a color no object wears).
    fn id_of(&self, rgba: [u8; 4]) -> u16 {
        match self.colors.get(&rgba) {
            Some(&id) => id,
            None if rgba == crate::render::CLEAR_COLOR.map(|c| (c * 255.0).round() as u8) => {
                BACKGROUND
            }
            None => UNKNOWN,
        }
    }

    /// Whether pixel `at` is checked.
    fn checked(&self, at: usize) -> bool {
        self.truth.w[at].is_finite()
    }

    /// An RGBA image of what should show (each object in its color, background black).
    pub fn expected_image(&self) -> image::RgbaImage {
        let colors: HashMap<u16, [u8; 4]> = self.colors.iter().map(|(c, id)| (*id, *c)).collect();
        let (w, h) = (self.truth.width, self.truth.height);
        image::RgbaImage::from_fn(w, h, |x, y| {
            let id = self.truth.ids[(y * w + x) as usize];
            image::Rgba(colors.get(&id).copied().unwrap_or([0, 0, 0, 255]))
        })
    }
}

/// Runs one case into `out/dir` and measures it against `truth` (computed at the case's size).
pub fn measure(
    runner: &Runner,
    device: Option<&str>,
    case: &Case,
    truth: &Truth,
    out: &Path,
    dir: &str,
) -> Result<Measurement> {
    let render_dir = out.join(dir);
    std::fs::create_dir_all(&render_dir)
        .with_context(|| format!("cannot create {}", render_dir.display()))?;
    let format = format_name(case.format);
    let (width, height) = (case.width.to_string(), case.height.to_string());
    let render_dir_str = render_dir.to_string_lossy().into_owned();
    let mut args = vec![
        "--scene",
        case.scene.name(),
        "--delivery",
        case.delivery.name(),
        "--depth-format",
        &format,
        "--width",
        &width,
        "--height",
        &height,
        "--validation",
        "--out",
        &render_dir_str,
    ];
    if let Some(device) = device {
        args.extend(["--device", device]);
    }
    if !case.depth_readback {
        args.push("--no-depth-readback");
    }
    // The stored values are what is measured: copies hand them over unconverted.
    let mut settings = vec![
        ("REVZ_REVERSE_OBSERVABLE", "copies"),
        ("REVZ_COPY_VALUES", "stored"),
        ("REVZ_LOG", "info"),
    ];
    if let Some(promotion) = case.promote_depth_formats {
        settings.push(("REVZ_PROMOTE_DEPTH_FORMATS", promotion.name()));
    }
    let output: Output = runner
        .command(case.variant, &args, &settings)
        .output()
        .context("cannot run the tester as a child process")?;
    let log = format!(
        "{}{}",
        String::from_utf8_lossy(&output.stdout),
        String::from_utf8_lossy(&output.stderr)
    );
    std::fs::write(render_dir.join("log.txt"), &log).ok();
    let mut m = Measurement::blank(
        case.scene.name(),
        case.variant.name(),
        case.format,
        case.width,
        case.height,
    );
    m.delivery = case.delivery.name();
    m.promoted_format = promoted_format(&log, case.format.vk_name(), case.width, case.height);
    m.depth_readback = case.depth_readback;
    m.dir = dir.to_string();
    let code = output.status.code();
    if code != Some(0) && code != Some(2) {
        let last = log
            .lines()
            .rev()
            .find(|l| !l.trim().is_empty())
            .unwrap_or("");
        m.error = Some(format!("render failed ({:?}): {last}", output.status));
        return Ok(m);
    }
    let json: serde_json::Value = serde_json::from_slice(
        &std::fs::read(render_dir.join("render.json")).context("no render.json")?,
    )
    .context("render.json is not JSON")?;
    m.device = json["device"].as_str().unwrap_or("").to_string();
    m.driver = json["driver"].as_str().unwrap_or("").to_string();
    m.validation_messages = json["validation_messages"].as_u64().unwrap_or(0) as u32;
    m.validation_skipped = json["validation_skipped"].as_str().map(str::to_owned);
    if code == Some(2) || m.validation_messages > 0 {
        m.error = Some(format!(
            "{} validation message(s) (see {dir}/log.txt)",
            m.validation_messages.max(1)
        ));
    }
    let color = image::open(render_dir.join("color.png"))
        .context("cannot read color.png")?
        .to_rgba8();
    let depth = case
        .depth_readback
        .then(|| read_f32(&render_dir.join("depth.f32")).ok())
        .flatten();
    compare(&mut m, truth, &color, depth.as_deref())?;
    Ok(m)
}

fn read_f32(path: &PathBuf) -> Result<Vec<f32>> {
    let bytes = std::fs::read(path).with_context(|| format!("cannot read {}", path.display()))?;
    Ok(bytes
        .chunks_exact(4)
        .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        .collect())
}

/// Fills the pixel counts, the fraction, the reversal and the plane-stack cells of `m` from a
/// rendered color image (and its depth, top row first, where read back); `gl-render` measures
/// its OpenGL renders with it too.
pub fn compare(
    m: &mut Measurement,
    truth: &Truth,
    color: &image::RgbaImage,
    depth: Option<&[f32]>,
) -> Result<()> {
    let (w, h) = (truth.truth.width, truth.truth.height);
    anyhow::ensure!(
        color.dimensions() == (w, h),
        "color.png is {:?}, expected {w}x{h}",
        color.dimensions()
    );
    let mut checked = 0;
    let mut wrong = 0;
    let mut rendered = vec![BACKGROUND; (w * h) as usize];
    // (w, depth) of the nearest and farthest correctly shown checked pixels.
    let mut nearest: Option<(f64, f32)> = None;
    let mut farthest: Option<(f64, f32)> = None;
    for (at, pixel) in color.pixels().enumerate() {
        let id = truth.id_of(pixel.0);
        rendered[at] = id;
        if !truth.checked(at) {
            continue;
        }
        checked += 1;
        if id != truth.truth.ids[at] {
            wrong += 1;
            continue;
        }
        if let Some(d) = depth.and_then(|d| d.get(at)) {
            let wv = truth.truth.w[at];
            if nearest.is_none_or(|(n, _)| wv < n) {
                nearest = Some((wv, *d));
            }
            if farthest.is_none_or(|(f, _)| wv > f) {
                farthest = Some((wv, *d));
            }
        }
    }
    m.checked_pixels = checked;
    m.wrong_pixels = wrong;
    m.wrong_pixel_fraction = if checked == 0 {
        1.0
    } else {
        wrong as f64 / checked as f64
    };
    m.depth_reversed = match (nearest, farthest) {
        (Some((wn, dn)), Some((wf, df))) if wf > wn * 1.001 && dn != df => Some(dn > df),
        // Every checked depth the same (D16 far away): the scenes keep their surfaces beyond
        // 10 n, where standard depth is above 0.9 and reversed depth below 0.1.
        (Some((_, dn)), _) => Some(dn < 0.5),
        _ => None,
    };
    if m.scene == "plane-stack" {
        stack_cells(m, truth, &rendered);
    }
    if m.scene == "far-objects" {
        m.decades = Some(far_decades(truth, &rendered));
    }
    Ok(())
}

/// Counts the checked and wrong pixels of each `far-objects` group.
fn far_decades(truth: &Truth, rendered: &[u16]) -> Vec<DecadeResult> {
    use super::scenes::{far_layout, FAR_DISTANCES, FAR_NEAR};
    let decade_of: Vec<usize> = far_layout().into_iter().map(|(d, _)| d).collect();
    let mut counts = vec![(0, 0); FAR_DISTANCES.len()];
    for (at, &shown) in rendered.iter().enumerate() {
        if !truth.checked(at) {
            continue;
        }
        let Some(&decade) = decade_of.get(usize::from(truth.truth.ids[at])) else {
            continue;
        };
        counts[decade].0 += 1;
        if shown != truth.truth.ids[at] {
            counts[decade].1 += 1;
        }
    }
    FAR_DISTANCES
        .iter()
        .zip(counts)
        .map(|(&d, (checked, wrong))| DecadeResult {
            distance_over_near: d / FAR_NEAR,
            checked,
            wrong,
            wrong_pixel_fraction: if checked == 0 {
                1.0
            } else {
                wrong as f64 / checked as f64
            },
        })
        .collect()
}

/// Counts the `plane-stack` cells and finds the smallest resolved separation per distance.
fn stack_cells(m: &mut Measurement, truth: &Truth, rendered: &[u16]) {
    use super::scenes::{stack_cells, stack_separations, STACK_DISTANCES};
    let cells = stack_cells();
    let mut by_front: HashMap<u16, usize> = HashMap::new();
    for (k, cell) in cells.iter().enumerate() {
        by_front.insert(cell.front as u16, k);
    }
    let mut results: Vec<CellResult> = cells
        .iter()
        .map(|c| CellResult {
            column: c.column,
            row: c.row,
            checked: 0,
            wrong: 0,
        })
        .collect();
    for (at, &shown) in rendered.iter().enumerate() {
        if !truth.checked(at) {
            continue;
        }
        if let Some(&k) = by_front.get(&truth.truth.ids[at]) {
            results[k].checked += 1;
            if shown != truth.truth.ids[at] {
                results[k].wrong += 1;
            }
        }
    }
    let separations = stack_separations();
    let points = STACK_DISTANCES
        .iter()
        .enumerate()
        .map(|(column, &d)| {
            let ok = |row: usize| {
                results
                    .iter()
                    .find(|r| r.column == column && r.row == row)
                    .is_some_and(|r| {
                        r.checked > 0 && (r.wrong as f64) < RESOLVED_BELOW * r.checked as f64
                    })
            };
            // The smallest separation from which on every larger one resolves too: one cell
            // is one deterministic pair of planes, and standard depth's rounding can land a
            // lucky cell far below the separation it needs in general.
            let first = (0..separations.len())
                .rev()
                .take_while(|&row| ok(row))
                .last();
            StackPoint {
                distance_over_near: d,
                min_rel_separation: first.map(|row| separations[row]),
            }
        })
        .collect();
    m.cells = results;
    m.min_rel_separation = Some(points);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_promoted_format_is_read_from_the_main_depth_image_line() {
        let log = "\
[revz INFO] loaded as VK_LAYER_REVZ_reverse_z: mode complementary
[revz INFO] depth image 0x5 (D32_SFLOAT, 512x512): native, because shaders read it (SAMPLED)
[revz INFO] depth image 0x6 (D24_UNORM_S8_UINT, 160x120): reversed, promoted to D32_SFLOAT_S8_UINT (38400 more bytes)
";
        assert_eq!(
            promoted_format(log, "D24_UNORM_S8_UINT", 160, 120).as_deref(),
            Some("D32_SFLOAT_S8_UINT")
        );
        // Another image's size or format is not the main image.
        assert_eq!(promoted_format(log, "D24_UNORM_S8_UINT", 96, 72), None);
        assert_eq!(promoted_format(log, "D16_UNORM", 160, 120), None);
        let native = "[revz INFO] depth image 0x7 (D16_UNORM, 96x72): native, because it is \
                      resolved into native; promoted to D32_SFLOAT (13824 more bytes)";
        assert_eq!(
            promoted_format(native, "D16_UNORM", 96, 72).as_deref(),
            Some("D32_SFLOAT")
        );
        // Without promotion the lines end as before issue #15.
        let plain = "[revz INFO] depth image 0x8 (D16_UNORM, 96x72): reversed";
        assert_eq!(promoted_format(plain, "D16_UNORM", 96, 72), None);
    }
}
