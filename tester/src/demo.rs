//! `revz-tester demo`: what revz does, in about a minute on a 2-core machine (issue #43).
//!
//! The hard cases that matter (seed 001's sloped plane and Mars patch, the deep range, the
//! plane stack), in D24S8 and D32, without revz and with it (infinite reversed-Z by default),
//! rendered and measured against ground truth as the accuracy report does
//! ([`crate::accuracy::run_all`]); then the wrong-pixel table, one labelled picture of a
//! scene rendered without and with revz side by side, and the quick cost figure (the
//! recording thread's instructions of a 10,000-draw frame under callgrind, the smallest of
//! three children per mode, [`crate::bench::quick_instruction_ratios`]). The whole accuracy
//! report and the whole benchmark are their own commands (`cargo xtask report`,
//! `cargo xtask bench`).

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

use anyhow::{Context, Result};
use image::RgbImage;

use crate::accuracy::measure::Measurement;
use crate::accuracy::report_images::{draw_labels, mode_label, Label};
use crate::accuracy::{self, Mode, Selection};
use crate::scene::SceneId;
use crate::target::DepthFormat;

/// The scenes of the demo: where standard depth fails visibly.
const SCENES: [SceneId; 4] = [
    SceneId::SlopedPlane,
    SceneId::MarsPatch,
    SceneId::DeepRange,
    SceneId::PlaneStack,
];

/// The depth formats of the demo: the most common UNORM one (promoted to float by revz) and
/// float.
const FORMATS: [DepthFormat; 2] = [DepthFormat::D24S8, DepthFormat::D32];

/// The scene and format of the side-by-side picture.
const PICTURE: (SceneId, DepthFormat) = (SceneId::MarsPatch, DepthFormat::D24S8);

/// Draws per frame of the cost figure's storm (the bench's largest).
const COST_DRAWS: usize = 10_000;

/// Callgrind children per mode for the cost figure, of which the smallest count is kept.
const COST_RUNS: usize = 3;

/// The picture's tiles are the renders scaled up by this (the report renders 160 x 120).
const PICTURE_SCALE: u32 = 2;

/// `revz-tester demo`.
#[derive(Debug, clap::Args)]
pub struct DemoArgs {
    /// Output directory (created if missing): the renders, report.md / report.json of the
    /// demo's cases, demo.png.
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,

    /// revz's mode for the renders with the layer.
    #[arg(long, value_enum, default_value = "infinite")]
    pub mode: Mode,

    /// Skip the cost figure (it needs valgrind, and takes most of the demo's time).
    #[arg(long)]
    pub no_cost: bool,

    /// The revz layer's manifest directory. Default: `manifests/explicit` next to this
    /// executable (what `cargo xtask build` writes).
    #[arg(long, value_name = "DIR")]
    pub layer_dir: Option<PathBuf>,

    /// Render on the first device whose name contains NAME.
    #[arg(long, value_name = "NAME")]
    pub device: Option<String>,
}

pub fn run(args: &DemoArgs) -> Result<ExitCode> {
    let started = Instant::now();
    let mode = if args.mode == Mode::None {
        Mode::Infinite
    } else {
        args.mode
    };
    let selection = Selection {
        scenes: SCENES.to_vec(),
        modes: vec![Mode::None, mode],
        formats: FORMATS.to_vec(),
        deliveries: Vec::new(),
        layer_dir: args.layer_dir.clone(),
        device: args.device.clone(),
        promote_depth_formats: None,
        depth_readback_always: false,
    };
    println!(
        "== the hard cases: {} scenes x {} x (without revz, {}), against ground truth",
        SCENES.len(),
        FORMATS
            .map(crate::accuracy::measure::format_name)
            .join(", "),
        mode_label(mode)
    );
    let results = accuracy::run_all(&selection, &args.out, 160, 120)?;
    accuracy::report::write(&args.out, &results)?;

    println!();
    println!(
        "== wrong pixels: the fraction of checked pixels that show another object than the \
         nearest (ground truth computed in f64)"
    );
    print!("{}", wrong_pixel_table(&results, mode));

    let picture = args.out.join("demo.png");
    side_by_side(&results, &args.out, mode, &picture)?;
    println!();
    println!(
        "== side by side: {} ({} in {}: left without revz, right {})",
        picture.display(),
        PICTURE.0.name(),
        crate::accuracy::measure::format_name(PICTURE.1),
        mode_label(mode)
    );

    println!();
    if args.no_cost {
        println!("== cost: skipped (--no-cost)");
    } else {
        println!(
            "== cost: instructions on the recording thread of a {COST_DRAWS}-draw frame (one \
             camera, a pushed matrix per draw), against no layer: the smallest of {COST_RUNS} \
             callgrind children per mode (`cargo xtask bench` keeps the smallest of five, and \
             measures times, pipeline creation, driver calls and copies too)"
        );
        match crate::bench::quick_instruction_ratios(
            args.layer_dir.as_deref(),
            args.device.as_deref(),
            COST_DRAWS,
            COST_RUNS,
        )? {
            Some(ratios) => {
                println!("| mode | instructions / no layer's |");
                println!("|---|---:|");
                for (variant, ratio) in ratios.iter().skip(1) {
                    println!("| {} | {ratio:.3} |", variant.name());
                }
            }
            None => println!("valgrind is not installed: no cost figure"),
        }
    }
    println!();
    println!(
        "demo: {:.0} s; every case of the accuracy report: `cargo xtask report`; the whole \
         benchmark: `cargo xtask bench`",
        started.elapsed().as_secs_f64()
    );
    let failed = results.iter().filter(|m| m.error.is_some()).count();
    if failed > 0 {
        eprintln!("demo: {failed} case(s) failed (see above)");
        return Ok(ExitCode::from(1));
    }
    Ok(ExitCode::SUCCESS)
}

fn find(
    results: &[Measurement],
    scene: SceneId,
    format: DepthFormat,
    mode: Mode,
) -> Option<&Measurement> {
    results.iter().find(|m| {
        m.scene == scene.name()
            && m.format == crate::accuracy::measure::format_name(format)
            && m.mode == mode.variant().name()
    })
}

fn percent(m: Option<&Measurement>) -> String {
    match m {
        Some(m) if m.error.is_none() => format!("{:.2}%", 100.0 * m.wrong_pixel_fraction),
        Some(_) => "error".to_owned(),
        None => "-".to_owned(),
    }
}

/// The scene x format table of wrong pixels, without revz and in `mode`.
fn wrong_pixel_table(results: &[Measurement], mode: Mode) -> String {
    let mut table = format!(
        "| scene | depth format | without revz | {} |\n|---|---|---:|---:|\n",
        mode_label(mode)
    );
    for scene in SCENES {
        for format in FORMATS {
            let layered = find(results, scene, format, mode);
            let promoted = layered
                .and_then(|m| m.promoted_format.as_deref())
                .map(|f| format!(" (promoted to {f})"))
                .unwrap_or_default();
            table.push_str(&format!(
                "| {} | {} | {} | {}{promoted} |\n",
                scene.name(),
                crate::accuracy::measure::format_name(format),
                percent(find(results, scene, format, Mode::None)),
                percent(layered),
            ));
        }
    }
    table
}

/// `demo.png`: [`PICTURE`]'s render without revz on the left, in `mode` on the right, each
/// labelled with what it is and its wrong pixels.
fn side_by_side(results: &[Measurement], out: &Path, mode: Mode, picture: &Path) -> Result<()> {
    let (scene, format) = PICTURE;
    let tiles = [Mode::None, mode].map(|m| find(results, scene, format, m));
    let [Some(native), Some(layered)] = tiles else {
        anyhow::bail!("the picture's renders are missing");
    };
    let load = |m: &Measurement| -> Result<RgbImage> {
        let path = out.join(&m.dir).join("color.png");
        let image = image::open(&path)
            .with_context(|| format!("cannot read {}", path.display()))?
            .to_rgb8();
        let (w, h) = image.dimensions();
        Ok(image::imageops::resize(
            &image,
            w * PICTURE_SCALE,
            h * PICTURE_SCALE,
            image::imageops::FilterType::Nearest,
        ))
    };
    let (left, right) = (load(native)?, load(layered)?);
    let (w, h) = left.dimensions();
    const GAP: u32 = 12;
    const TOP: u32 = 72;
    let mut sheet = RgbImage::from_pixel(3 * GAP + 2 * w, TOP + h + GAP, image::Rgb([255; 3]));
    image::imageops::replace(&mut sheet, &left, i64::from(GAP), i64::from(TOP));
    image::imageops::replace(&mut sheet, &right, i64::from(2 * GAP + w), i64::from(TOP));
    let format = |m: &Measurement| {
        m.promoted_format
            .as_deref()
            .map_or(m.vk_format.to_owned(), |f| {
                format!("{} (stored as {f})", m.vk_format)
            })
    };
    let wrong = |m: &Measurement| format!("{:.2}% wrong pixels", 100.0 * m.wrong_pixel_fraction);
    let small = |x: u32, y: u32, text: String| Label {
        size: 12.0,
        ..Label::new(x, y, text)
    };
    let right_x = 2 * GAP + w;
    let labels = [
        Label::new(GAP, 6, format!("{}: without revz", scene.name())),
        small(GAP, 30, format(native)),
        small(GAP, 48, wrong(native)),
        Label::new(
            right_x,
            6,
            format!("{}: {}", scene.name(), mode_label(mode)),
        ),
        small(right_x, 30, format(layered)),
        small(right_x, 48, wrong(layered)),
    ];
    draw_labels(&mut sheet, &labels)?;
    sheet
        .save(picture)
        .with_context(|| format!("cannot write {}", picture.display()))
}
