//! The benchmark's part of the report: the `speed` key of `report.json` (read, modified,
//! written: every other key belongs to `revz-tester report`), the table after the
//! `<!-- speed -->` marker of `report.md`, and `overhead-vs-error.png` (frame CPU-time ratio
//! against an accuracy figure, one point per mode).

use std::path::Path;

use anyhow::{Context, Result};
use serde_json::{json, Map, Value};

/// The line of `report.md` after which the speed table goes.
pub const MARKER: &str = "<!-- speed -->";
const FONT: &str = "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf";
const PLOT: &str = "overhead-vs-error.png";

/// The accuracy rows use mode `none` for no layer; `off` passes everything through, so it
/// renders what no layer renders.
fn accuracy_mode(mode: &str) -> &str {
    if mode == "off" {
        "none"
    } else {
        mode
    }
}

fn is_d32(row: &Value) -> bool {
    match row.get("format").and_then(Value::as_str) {
        None => true,
        Some(f) => f.eq_ignore_ascii_case("d32") || f.eq_ignore_ascii_case("D32_SFLOAT"),
    }
}

fn same_name(a: &str, b: &str) -> bool {
    a.replace('_', "-")
        .eq_ignore_ascii_case(&b.replace('_', "-"))
}

/// `wrong_pixel_fraction` of `scene` in `mode` (D32) from the accuracy rows.
fn wrong_fraction(report: &Value, scene: &str, mode: &str) -> Option<f64> {
    report.get("rows")?.as_array()?.iter().find_map(|row| {
        let ok = row
            .get("scene")
            .and_then(Value::as_str)
            .is_some_and(|s| same_name(s, scene))
            && row.get("mode").and_then(Value::as_str) == Some(accuracy_mode(mode))
            && is_d32(row);
        ok.then(|| row.get("wrong_pixel_fraction")?.as_f64())?
    })
}

/// `min_rel_separation` at z = 1e4 n in `mode` (D32) from the accuracy report.
fn min_separation(report: &Value, mode: &str) -> Option<f64> {
    report
        .get("min_separation")?
        .as_array()?
        .iter()
        .find_map(|row| {
            let d = row.get("distance_over_near")?.as_f64()?;
            let ok = (d / 1e4 - 1.0).abs() < 1e-3
                && row.get("mode").and_then(Value::as_str) == Some(accuracy_mode(mode))
                && is_d32(row);
            ok.then(|| row.get("min_rel_separation")?.as_f64())?
        })
}

/// Adds the accuracy figures to the speed rows, writes report.json, report.md and the plot;
/// returns the table (markdown) printed at the end.
pub fn integrate(
    out: &Path,
    device: &str,
    driver: &str,
    compare_op: &str,
    speed: &[Value],
    draws: &[usize],
) -> Result<String> {
    let json_path = out.join("report.json");
    let mut report: Value = match std::fs::read_to_string(&json_path) {
        Ok(text) => serde_json::from_str(&text)
            .with_context(|| format!("{} is not JSON", json_path.display()))?,
        Err(_) => json!({ "device": device, "driver": driver }),
    };
    if !report.is_object() {
        report = json!({ "device": device, "driver": driver });
    }
    let rows: Vec<Value> = speed
        .iter()
        .map(|row| {
            let mut row = row.clone();
            let mode = row["mode"].as_str().unwrap_or("").to_owned();
            let map = row.as_object_mut().expect("speed rows are objects");
            map.insert(
                "mars_patch_wrong_fraction".into(),
                json!(wrong_fraction(&report, "mars-patch", &mode)),
            );
            map.insert(
                "sloped_plane_wrong_fraction".into(),
                json!(wrong_fraction(&report, "sloped-plane", &mode)),
            );
            map.insert(
                "min_rel_separation_1e4n".into(),
                json!(min_separation(&report, &mode)),
            );
            row
        })
        .collect();
    let object: &mut Map<String, Value> = report.as_object_mut().expect("checked above");
    object.insert("speed".into(), Value::Array(rows.clone()));
    std::fs::write(&json_path, serde_json::to_string_pretty(&report)? + "\n")
        .with_context(|| format!("cannot write {}", json_path.display()))?;
    println!("wrote: {}", json_path.display());

    let plot_note = match plot(&out.join(PLOT), &rows) {
        Ok(note) => {
            println!("wrote: {}", out.join(PLOT).display());
            note
        }
        Err(e) => format!("The plot could not be drawn: {e:#}."),
    };
    let table = table(device, driver, compare_op, &rows, draws);
    let md_path = out.join("report.md");
    let existing = std::fs::read_to_string(&md_path).unwrap_or_default();
    let mut md = match existing.find(MARKER) {
        Some(at) => existing[..at + MARKER.len()].to_owned(),
        None if existing.is_empty() => MARKER.to_owned(),
        None => format!("{}\n\n{MARKER}", existing.trim_end()),
    };
    md.push_str("\n\n");
    md.push_str(&table);
    md.push_str(&format!(
        "\n![overhead against error]({PLOT})\n\n{plot_note}\n"
    ));
    std::fs::write(&md_path, md).with_context(|| format!("cannot write {}", md_path.display()))?;
    println!("wrote: {}", md_path.display());
    Ok(table)
}

fn fmt(value: &Value, digits: usize) -> String {
    match value.as_f64() {
        Some(v) if v.is_finite() => format!("{v:.digits$}"),
        _ => "-".into(),
    }
}

/// A median with its spread over rounds: `1.684 (1.60-1.75)`; the median alone where the
/// row has no spread for `key`.
fn fmt_spread(row: &Value, key: &str, digits: usize) -> String {
    let median = fmt(&row[key], digits);
    let spread = &row["spread"][key];
    match (spread[0].as_f64(), spread[1].as_f64()) {
        (Some(min), Some(max)) if median != "-" => {
            let d = digits.min(2);
            format!("{median} ({min:.d$}-{max:.d$})")
        }
        _ => median,
    }
}

fn fmt_sci(value: &Value) -> String {
    match value.as_f64() {
        Some(v) if v.is_finite() => format!("{v:.2e}"),
        _ => "-".into(),
    }
}

/// The markdown speed table.
fn table(device: &str, driver: &str, compare_op: &str, rows: &[Value], draws: &[usize]) -> String {
    let largest = draws.iter().copied().max().unwrap_or(0);
    let others: Vec<usize> = draws.iter().copied().filter(|&n| n != largest).collect();
    let mut s = format!("## Speed: {device} ({driver}), `compare_op = {compare_op}`\n\n");
    s.push_str(
        "Ratios against no layer measured in the same run (median over rounds of per-round \
         ratios, with the smallest and largest round's in parentheses); ns per call and bytes \
         are differences with no layer. Frame CPU time: the recording thread's CPU time to \
         record and submit one frame (release build).\n\n",
    );
    let mut header = format!("| mode | frame CPU ratio ({largest} draws) |");
    for n in &others {
        header.push_str(&format!(" frame CPU ratio ({n}) |"));
    }
    header.push_str(&format!(
        " frame CPU ratio ({largest}, a projection per draw) | frame CPU ratio ({largest}, depth profile on) |"
    ));
    header.push_str(
        " frame wall ratio | frame instructions ratio (callgrind, smallest of 5) | \
         frame instructions ratio (a projection per draw) | pipeline creation ratio | \
         pipeline creation ratio (one code) | ns / push (one camera) | \
         ns / push (a new camera each) | ns / draw | \
         ns / bind | instructions / push (one camera) | instructions / push (a new camera each) | \
         instructions / draw | instructions / bind | driver calls / frame (largest storm) | depth copy wall ratio (1 MP, D32) | depth copy extra ms / MP | \
         depth copy wall ratio (1 MP, D24S8) | read twin refresh extra ms / MP | refresh in native copies | \
         4-sample refresh extra ms / MP | 4-sample refresh in native copies | \
         bytes / pipeline | \
         bytes / command buffer | heap growth / frame | mars-patch wrong | sloped-plane wrong | \
         min separation at 1e4 n |\n",
    );
    s.push_str(&header);
    let columns = header.matches('|').count() - 1;
    s.push_str(&"|---".repeat(columns));
    s.push_str("|\n");
    for row in rows {
        let mut line = format!(
            "| {} | {} |",
            row["mode"].as_str().unwrap_or("?"),
            fmt_spread(row, "frame_cpu_ratio", 3)
        );
        for n in &others {
            line.push_str(&format!(
                " {} |",
                fmt(&row["by_draws"][n.to_string()]["frame_cpu_ratio"], 3)
            ));
        }
        line.push_str(&format!(
            " {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |\n",
            fmt_spread(row, "frame_cpu_ratio_projection_per_draw", 3),
            fmt_spread(row, "frame_cpu_ratio_with_report", 3),
            fmt(&row["frame_wall_ratio"], 3),
            fmt(&row["frame_instructions_ratio"], 4),
            fmt(&row["frame_instructions_ratio_projection_per_draw"], 4),
            fmt_spread(row, "pipeline_creation_ratio", 3),
            fmt_spread(row, "pipeline_creation_ratio_repeated_code", 3),
            fmt_spread(row, "ns_per_push_one_camera", 1),
            fmt_spread(row, "ns_per_push_constant", 1),
            fmt_spread(row, "ns_per_draw", 1),
            fmt_spread(row, "ns_per_bind", 1),
            fmt(&row["instructions_per_push_one_camera"], 0),
            fmt(&row["instructions_per_push_new_camera"], 0),
            fmt(&row["instructions_per_draw"], 0),
            fmt(&row["instructions_per_bind"], 0),
            fmt(&row["driver_calls_per_frame"], 0),
            fmt_spread(row, "depth_copy_wall_ratio", 3),
            fmt(&row["depth_copy_extra_ms_per_megapixel"], 2),
            fmt_spread(row, "depth_copy_d24s8_wall_ratio", 3),
            fmt(&row["depth_refresh_extra_ms_per_megapixel"], 2),
            fmt(&row["depth_refresh_in_native_copies"], 2),
            fmt(&row["depth_refresh_msaa_extra_ms_per_megapixel"], 2),
            fmt(&row["depth_refresh_msaa_in_native_copies"], 2),
            fmt(&row["bytes_per_pipeline"], 0),
            fmt(&row["bytes_per_command_buffer"], 0),
            fmt(&row["heap_growth_per_frame"], 0),
            fmt_sci(&row["mars_patch_wrong_fraction"]),
            fmt_sci(&row["sloped_plane_wrong_fraction"]),
            fmt_sci(&row["min_rel_separation_1e4n"]),
        ));
        s.push_str(&line);
    }
    s
}

/// Plots frame CPU ratio (x) against the first accuracy figure present (y), one point per
/// mode; returns the sentence report.md says about it.
fn plot(path: &Path, rows: &[Value]) -> Result<String> {
    use plotters::prelude::*;

    let candidates = [
        (
            "mars_patch_wrong_fraction",
            "mars-patch wrong-pixel fraction (D32)",
        ),
        (
            "sloped_plane_wrong_fraction",
            "sloped-plane wrong-pixel fraction (D32)",
        ),
        (
            "min_rel_separation_1e4n",
            "min relative separation at 1e4 n (D32)",
        ),
    ];
    let chosen = candidates
        .iter()
        .find(|(key, _)| rows.iter().any(|r| r[*key].as_f64().is_some()));
    let (key, y_label, note) = match chosen {
        Some((key, label)) => (
            *key,
            *label,
            format!("Overhead (frame CPU-time ratio) against {label}, one point per mode."),
        ),
        None => (
            "ns_per_push_constant",
            "ns per push constant (no accuracy figures)",
            "No accuracy figures were found in report.json (run `revz-tester report` first): \
             the plot shows overhead against ns per push constant instead."
                .to_owned(),
        ),
    };
    let points: Vec<(String, f64, f64)> = rows
        .iter()
        .filter_map(|r| {
            Some((
                r["mode"].as_str()?.to_owned(),
                r["frame_cpu_ratio"].as_f64()?,
                r[key].as_f64().unwrap_or(0.0),
            ))
        })
        .collect();

    let font = std::fs::read(FONT).with_context(|| format!("cannot read the font {FONT}"))?;
    plotters::style::register_font("sans-serif", FontStyle::Normal, Box::leak(font.into()))
        .map_err(|_| anyhow::anyhow!("{FONT} is not a usable font"))?;
    let (x_min, x_max) = range(points.iter().map(|p| p.1), 0.02);
    let (y_min, y_max) = range(points.iter().map(|p| p.2), 0.0);
    let root = BitMapBackend::new(path, (800, 560)).into_drawing_area();
    root.fill(&WHITE)?;
    let mut chart = ChartBuilder::on(&root)
        .caption("revz: overhead against error", ("sans-serif", 24))
        .margin(16)
        .x_label_area_size(48)
        .y_label_area_size(80)
        .build_cartesian_2d(x_min..x_max, y_min..y_max)?;
    chart
        .configure_mesh()
        .x_desc("frame CPU-time ratio against no layer")
        .y_desc(y_label)
        .label_style(("sans-serif", 14))
        .draw()?;
    let colors = [BLACK, RGBColor(120, 120, 120), BLUE, RED, GREEN];
    for (i, (mode, x, y)) in points.iter().enumerate() {
        let color = colors[i % colors.len()];
        let point = EmptyElement::at((*x, *y))
            + Circle::new((0, 0), 6, color.filled())
            + Text::new(
                mode.clone(),
                (9, -18),
                ("sans-serif", 16).into_font().color(&color),
            );
        chart.draw_series(std::iter::once(point))?;
    }
    root.present()?;
    Ok(note)
}

/// A plotting range around `values` with some margin (at least `min_span` wide).
fn range(values: impl Iterator<Item = f64>, min_span: f64) -> (f64, f64) {
    let (lo, hi) = values
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(v), b.max(v))
        });
    if !lo.is_finite() {
        return (0.0, 1.0);
    }
    let span = (hi - lo).max(min_span).max(hi.abs() * 0.1).max(1e-12);
    (lo - span * 0.15, hi + span * 0.25)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn medians_show_their_spread_where_the_row_has_one() {
        let row = json!({
            "frame_cpu_ratio": 1.684,
            "ns_per_draw": 44.7,
            "spread": {"frame_cpu_ratio": [1.6012, 1.7549], "ns_per_draw": null},
        });
        assert_eq!(fmt_spread(&row, "frame_cpu_ratio", 3), "1.684 (1.60-1.75)");
        assert_eq!(fmt_spread(&row, "ns_per_draw", 1), "44.7");
        assert_eq!(fmt_spread(&json!({}), "frame_cpu_ratio", 3), "-");
    }

    #[test]
    fn accuracy_figures_are_found_by_scene_mode_and_format() {
        let report = json!({
            "rows": [
                {"scene": "mars-patch", "mode": "none", "format": "d32", "wrong_pixel_fraction": 0.5},
                {"scene": "mars-patch", "mode": "none", "format": "d16", "wrong_pixel_fraction": 0.9},
                {"scene": "mars-patch", "mode": "infinite", "format": "D32_SFLOAT", "wrong_pixel_fraction": 0.0},
            ],
            "min_separation": [
                {"mode": "flip", "format": "d32", "distance_over_near": 10000.0, "min_rel_separation": 1e-3},
                {"mode": "flip", "format": "d32", "distance_over_near": 100.0, "min_rel_separation": 1e-6},
            ],
        });
        assert_eq!(wrong_fraction(&report, "mars-patch", "off"), Some(0.5));
        assert_eq!(wrong_fraction(&report, "mars-patch", "infinite"), Some(0.0));
        assert_eq!(wrong_fraction(&report, "sloped-plane", "none"), None);
        assert_eq!(min_separation(&report, "flip"), Some(1e-3));
        assert_eq!(min_separation(&report, "none"), None);
    }

    #[test]
    fn the_markdown_keeps_what_precedes_the_marker() {
        let dir = std::env::temp_dir().join(format!("revz-bench-md-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join("report.md"), "# Accuracy\n\ntext\n").unwrap();
        std::fs::write(dir.join("report.json"), r#"{"device": "d", "rows": []}"#).unwrap();
        let speed = vec![json!({"mode": "none", "frame_cpu_ratio": 1.0})];
        for _ in 0..2 {
            integrate(&dir, "d", "drv", "dynamic", &speed, &[10]).unwrap();
        }
        let md = std::fs::read_to_string(dir.join("report.md")).unwrap();
        assert!(md.starts_with("# Accuracy\n\ntext\n\n<!-- speed -->\n"));
        assert_eq!(md.matches(MARKER).count(), 1);
        assert_eq!(md.matches("## Speed").count(), 1);
        let json: Value =
            serde_json::from_str(&std::fs::read_to_string(dir.join("report.json")).unwrap())
                .unwrap();
        assert_eq!(json["rows"], json!([]));
        assert_eq!(json["speed"][0]["mode"], "none");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
