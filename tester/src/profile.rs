//! `revz-tester profile <report.json>`: revz's depth profile (the layer's `report` setting,
//! `layer/src/profile.rs`) as a person reads it: the summary line, the depth images and their
//! decisions, the pipelines and their paths, the cameras, the draws per path of the last frames,
//! and a bar chart of those draws (`--png`). Also prints, after a render with `REVZ_REPORT`
//! set, the summary of the profile this process left ([`print_own_summary`]).

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use plotters::prelude::*;
use serde_json::Value;

/// Reads a depth profile and prints it.
#[derive(Debug, clap::Args)]
pub struct ProfileArgs {
    /// The profile revz wrote (`REVZ_REPORT`).
    pub report: PathBuf,
    /// Also draw the draws per path of each kept frame into this PNG (with `--precision`: the
    /// precision plot instead).
    #[arg(long, value_name = "FILE")]
    pub png: Option<PathBuf>,
    /// Instead of the tables: for each camera revz recognised, the smallest depth separation
    /// that resolves at each distance under each policy (none, flip, complementary, infinite)
    /// and storage (the images' own formats, D24, D32F), from the precision model; the policy
    /// and storage in force marked.
    #[arg(long)]
    pub precision: bool,
    /// With `--precision`: one more camera, of this near plane (for a projection revz's
    /// profile does not name: one in a uniform or storage buffer).
    #[arg(long, value_name = "N", requires = "precision")]
    pub near: Option<f64>,
    /// With `--near`: its far plane (default: infinite).
    #[arg(long, value_name = "F", requires = "near")]
    pub far: Option<f64>,
    /// With `--precision`: also write its numbers as JSON into this file.
    #[arg(long, value_name = "FILE", requires = "precision")]
    pub json: Option<PathBuf>,
}

fn read(path: &Path) -> Result<Value> {
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("cannot read the profile {}", path.display()))?;
    serde_json::from_str(&text).with_context(|| format!("{} is not JSON", path.display()))
}

fn text(value: &Value) -> String {
    match value {
        Value::String(s) => s.clone(),
        Value::Null => "-".to_owned(),
        other => other.to_string(),
    }
}

/// A profile's `draws` object as `precise / flip / native`.
fn draws(value: &Value) -> String {
    format!(
        "{} / {} / {}",
        text(&value["precise"]),
        text(&value["flip"]),
        text(&value["native"])
    )
}

/// The tables of a profile.
pub fn render_tables(profile: &Value) -> String {
    let mut out = String::new();
    let line = |out: &mut String, s: String| {
        out.push_str(&s);
        out.push('\n');
    };
    let app = &profile["application"];
    line(
        &mut out,
        format!(
            "revz {} in {} ({} / {}, Vulkan {})",
            text(&profile["revz"]),
            text(&app["executable"]),
            text(&app["application_name"]),
            text(&app["engine_name"]),
            text(&app["api_version"])
        ),
    );
    line(&mut out, format!("summary: {}", text(&profile["summary"])));
    line(&mut out, String::new());
    line(&mut out, "| setting | value | from |".into());
    line(&mut out, "|---|---|---|".into());
    for s in profile["settings"].as_array().into_iter().flatten() {
        line(
            &mut out,
            format!(
                "| {} | {} | {} |",
                text(&s["name"]),
                text(&s["value"]),
                text(&s["from"])
            ),
        );
    }
    line(&mut out, String::new());
    line(
        &mut out,
        "| depth image | format | promoted | size | samples | depth | why native | draws \
         (precise / flip / native) |"
            .into(),
    );
    line(&mut out, "|---|---|---|---|---|---|---|---|".into());
    for i in profile["images"].as_array().into_iter().flatten() {
        line(
            &mut out,
            format!(
                "| {} | {} | {} | {}x{} | {} | {} | {} | {} |",
                text(&i["handle"]),
                text(&i["format"]),
                text(&i["promoted_format"]),
                text(&i["width"]),
                text(&i["height"]),
                text(&i["samples"]),
                text(&i["depth"]),
                text(&i["reason"]),
                draws(&i["draws"])
            ),
        );
    }
    line(&mut out, String::new());
    line(
        &mut out,
        "| pipeline | kind | path | projection | variants | draws (precise / flip / native) |"
            .into(),
    );
    line(&mut out, "|---|---|---|---|---|---|".into());
    for p in profile["pipelines"].as_array().into_iter().flatten() {
        let variants = [
            ("reversed", "reversed_variant"),
            ("promoted", "promoted_variant"),
        ]
        .iter()
        .filter(|(_, key)| p[*key] == Value::Bool(true))
        .map(|(name, _)| *name)
        .collect::<Vec<_>>()
        .join(", ");
        line(
            &mut out,
            format!(
                "| {} | {} | {} | {} | {} | {} |",
                text(&p["handle"]),
                text(&p["kind"]),
                text(&p["path"]),
                text(&p["projection"]),
                if variants.is_empty() { "-" } else { &variants },
                draws(&p["draws"])
            ),
        );
    }
    line(&mut out, String::new());
    line(
        &mut out,
        "| camera | near | far | convention | delivered | matrices matched |".into(),
    );
    line(&mut out, "|---|---|---|---|---|---|".into());
    for (index, c) in profile["cameras"]
        .as_array()
        .into_iter()
        .flatten()
        .enumerate()
    {
        line(
            &mut out,
            format!(
                "| {index} | {} | {} | {} | {} | {} |",
                text(&c["near"]),
                if c["far"].is_null() {
                    "infinite".to_owned()
                } else {
                    text(&c["far"])
                },
                text(&c["convention"]),
                text(&c["delivered"]),
                text(&c["matrices_matched"])
            ),
        );
    }
    let totals = &profile["totals"];
    let reasons = totals["flip_reasons"].as_array().into_iter().flatten();
    let mut reasons = reasons.peekable();
    if reasons.peek().is_some() {
        // What would help most: the flip path's draws by reason.
        line(&mut out, String::new());
        line(
            &mut out,
            "| flip path because | pipelines | draws | of all draws |".into(),
        );
        line(&mut out, "|---|---|---|---|".into());
        for r in reasons {
            line(
                &mut out,
                format!(
                    "| {} | {} | {} | {:.1}% |",
                    text(&r["reason"]),
                    text(&r["pipelines"]),
                    text(&r["draws"]),
                    100.0 * r["fraction_of_draws"].as_f64().unwrap_or(0.0)
                ),
            );
        }
    }
    line(&mut out, String::new());
    line(
        &mut out,
        format!(
            "draws: {} precise, {} flip, {} native over {} frames ({} submissions)",
            text(&totals["draws"]["precise"]),
            text(&totals["draws"]["flip"]),
            text(&totals["draws"]["native"]),
            text(&totals["frames"]),
            text(&totals["submissions"])
        ),
    );
    out
}

/// Draws per path per kept frame, as stacked bars.
fn chart(profile: &Value, png: &Path) -> Result<()> {
    crate::accuracy::report_images::font()?;
    let frames: Vec<(u64, [u64; 3])> = profile["frames"]
        .as_array()
        .into_iter()
        .flatten()
        .map(|f| {
            let d = &f["draws"];
            let n = |k: &str| d[k].as_u64().unwrap_or(0);
            (
                f["frame"].as_u64().unwrap_or(0),
                [n("precise"), n("flip"), n("native")],
            )
        })
        .collect();
    let top = frames
        .iter()
        .map(|(_, d)| d.iter().sum::<u64>())
        .max()
        .unwrap_or(1)
        .max(1);
    let root = BitMapBackend::new(png, (800, 400)).into_drawing_area();
    root.fill(&WHITE)?;
    let first = frames.first().map_or(0, |f| f.0);
    let last = frames.last().map_or(1, |f| f.0 + 1);
    let mut chart = ChartBuilder::on(&root)
        .caption("revz: draws per path per frame", ("sans-serif", 20))
        .margin(10)
        .x_label_area_size(30)
        .y_label_area_size(50)
        .build_cartesian_2d(first..last.max(first + 1), 0..top + top / 10 + 1)?;
    chart
        .configure_mesh()
        .x_desc("frame")
        .y_desc("draws")
        .draw()?;
    let colors = [
        RGBColor(40, 80, 220),
        RGBColor(230, 150, 20),
        RGBColor(150, 150, 150),
    ];
    let names = ["precise", "flip", "native"];
    for (path, &color) in colors.iter().enumerate() {
        let bars = frames.iter().map(|(frame, d)| {
            let below: u64 = d[..path].iter().sum();
            Rectangle::new(
                [(*frame, below), (frame + 1, below + d[path])],
                color.filled(),
            )
        });
        chart
            .draw_series(bars)?
            .label(names[path])
            .legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 10, y + 5)], color.filled()));
    }
    chart
        .configure_series_labels()
        .background_style(WHITE)
        .border_style(BLACK)
        .draw()?;
    root.present()?;
    Ok(())
}

/// `revz-tester profile`.
pub fn run(args: &ProfileArgs) -> Result<std::process::ExitCode> {
    let profile = read(&args.report)?;
    if args.precision {
        let given = args.near.map(|near| crate::precision::GivenCamera {
            near,
            far: args.far,
        });
        let precision = crate::precision::of_profile(&profile, given)?;
        print!("{}", crate::precision::render(&precision));
        if let Some(json) = &args.json {
            std::fs::write(json, serde_json::to_string_pretty(&precision)? + "\n")
                .with_context(|| format!("cannot write {}", json.display()))?;
            println!("wrote: {}", json.display());
        }
        if let Some(png) = &args.png {
            crate::precision::plot(&precision, png)?;
            println!("wrote: {}", png.display());
        }
        return Ok(std::process::ExitCode::SUCCESS);
    }
    print!("{}", render_tables(&profile));
    if let Some(png) = &args.png {
        chart(&profile, png)?;
        println!("wrote: {}", png.display());
    }
    Ok(std::process::ExitCode::SUCCESS)
}

/// After a render with `REVZ_REPORT` set (revz wrote its profile when the device was
/// destroyed): prints the profile's summary line, `revz: precise 100% of draws, ...`.
pub fn print_own_summary() {
    let Some(report) = std::env::var_os("REVZ_REPORT").map(PathBuf::from) else {
        return;
    };
    let pid = format!("-{}-", std::process::id());
    let files: Vec<PathBuf> = if report.is_dir() {
        std::fs::read_dir(&report)
            .into_iter()
            .flatten()
            .flatten()
            .map(|entry| entry.path())
            .filter(|p| {
                p.file_name()
                    .and_then(|n| n.to_str())
                    .is_some_and(|n| n.contains(&pid) && n.ends_with(".json"))
            })
            .collect()
    } else {
        vec![report]
    };
    for file in files {
        if let Ok(profile) = read(&file) {
            println!("revz: {} ({})", text(&profile["summary"]), file.display());
        }
    }
}
