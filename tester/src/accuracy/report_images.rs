//! The report's pictures: renders side by side, and the minimum-separation plots.

use std::path::Path;

use anyhow::{anyhow, Context, Result};
use image::RgbImage;
use plotters::prelude::*;

use super::measure::{format_name, Measurement};
use super::model;
use super::report::{deliveries_in, formats_in, SeparationRow, FONT};
use super::Mode;

/// Pixels between tiles.
const GAP: u32 = 4;

/// The suffix of a delivery's images and plots: none for push constants, `-<delivery>` else.
fn suffix(delivery: &str) -> String {
    if delivery == "push" {
        String::new()
    } else {
        format!("-{delivery}")
    }
}

/// The width of the row labels left of a sheet's tiles, and the height of the column labels
/// above them.
const ROW_LABELS: u32 = 150;
const COLUMN_LABELS: u32 = 26;

/// What a sheet's row of `mode` shows, as its label says it.
pub fn mode_label(mode: Mode) -> &'static str {
    match mode {
        Mode::None => "without revz",
        Mode::Flip => "revz flip",
        Mode::Complementary => "revz complementary",
        Mode::Infinite => "revz infinite",
    }
}

/// `images/<scene>.png` for every scene (`images/<scene>-<delivery>.png` for a buffer
/// delivery): the expected image, then one row per mode and one column per format, each row
/// and column labelled in the picture. Returns the paths written, relative to `out`.
pub fn side_by_side(out: &Path, results: &[Measurement]) -> Result<Vec<String>> {
    let formats = formats_in(results);
    let mut sheets: Vec<(&str, &str)> = Vec::new();
    for delivery in deliveries_in(results) {
        for m in results {
            if m.delivery == delivery && !sheets.contains(&(m.scene, delivery)) {
                sheets.push((m.scene, delivery));
            }
        }
    }
    std::fs::create_dir_all(out.join("images"))?;
    let mut written = Vec::new();
    for (scene, delivery) in sheets {
        let expected = image::open(out.join(format!("renders/{scene}/expected.png")))
            .context("no expected.png")?
            .to_rgb8();
        let (w, h) = expected.dimensions();
        let modes: Vec<Mode> = Mode::ALL
            .into_iter()
            .filter(|mode| {
                results.iter().any(|m| {
                    m.scene == scene && m.delivery == delivery && m.mode == mode.variant().name()
                })
            })
            .collect();
        let columns = formats.len().max(1) as u32;
        let rows = 1 + modes.len() as u32;
        let mut sheet = RgbImage::from_pixel(
            ROW_LABELS + columns * (w + GAP) + GAP,
            COLUMN_LABELS + rows * (h + GAP) + GAP,
            image::Rgb([255, 255, 255]),
        );
        let tile_at = |row: u32, column: u32| {
            (
                ROW_LABELS + GAP + column * (w + GAP),
                COLUMN_LABELS + GAP + row * (h + GAP),
            )
        };
        let (x, y) = tile_at(0, 0);
        image::imageops::replace(&mut sheet, &expected, i64::from(x), i64::from(y));
        let mut labels = vec![Label::new(
            GAP,
            tile_at(0, 0).1 + h / 2,
            "ground truth".to_owned(),
        )];
        for (c, format) in formats.iter().enumerate() {
            let (x, _) = tile_at(0, c as u32);
            labels.push(Label::new(x, 4, format_name(*format).to_owned()));
        }
        for (r, mode) in modes.iter().enumerate() {
            let (_, y) = tile_at(r as u32 + 1, 0);
            labels.push(Label::new(GAP, y + h / 2, mode_label(*mode).to_owned()));
            for (c, format) in formats.iter().enumerate() {
                let Some(m) = results.iter().find(|m| {
                    m.scene == scene
                        && m.delivery == delivery
                        && m.mode == mode.variant().name()
                        && m.format == format_name(*format)
                }) else {
                    continue;
                };
                let Ok(tile) = image::open(out.join(&m.dir).join("color.png")) else {
                    continue;
                };
                let (x, y) = tile_at(r as u32 + 1, c as u32);
                image::imageops::replace(&mut sheet, &tile.to_rgb8(), i64::from(x), i64::from(y));
            }
        }
        draw_labels(&mut sheet, &labels)?;
        let rel = format!("images/{scene}{}.png", suffix(delivery));
        sheet
            .save(out.join(&rel))
            .with_context(|| format!("cannot write {rel}"))?;
        written.push(rel);
    }
    Ok(written)
}

/// A line of text drawn on a picture: its top left corner, in pixels.
#[derive(Clone, Debug)]
pub struct Label {
    pub x: u32,
    pub y: u32,
    pub text: String,
    /// Font size in pixels.
    pub size: f64,
}

impl Label {
    /// A label in the sheets' size.
    pub fn new(x: u32, y: u32, text: String) -> Label {
        Label {
            x,
            y,
            text,
            size: 16.0,
        }
    }
}

/// Draws `labels` in black onto `picture` (the plot font, [`font`]).
pub fn draw_labels(picture: &mut RgbImage, labels: &[Label]) -> Result<()> {
    font()?;
    let (w, h) = picture.dimensions();
    let root = BitMapBackend::with_buffer(picture.as_mut(), (w, h)).into_drawing_area();
    for label in labels {
        let style = ("sans-serif", label.size).into_font().color(&BLACK);
        root.draw_text(&label.text, &style, (label.x as i32, label.y as i32))
            .map_err(|e| anyhow!("{e}"))?;
    }
    root.present().map_err(|e| anyhow!("{e}"))?;
    Ok(())
}

/// Registers the plot font once; a clear error when it is missing.
pub fn font() -> Result<()> {
    static REGISTERED: std::sync::OnceLock<std::result::Result<(), String>> =
        std::sync::OnceLock::new();
    REGISTERED
        .get_or_init(|| {
            let bytes = std::fs::read(FONT).map_err(|e| {
                format!("cannot read the plot font {FONT} ({e}): install fonts-dejavu-core (`cargo xtask setup`)")
            })?;
            plotters::style::register_font("sans-serif", FontStyle::Normal, Box::leak(bytes.into_boxed_slice()))
                .map_err(|_| format!("{FONT} is not a usable font"))
        })
        .clone()
        .map_err(|e| anyhow!(e))
}

/// A chart of the relative separation dz/z (1e-8 to 2) over the view distance in near-plane
/// distances (`distances`), both on log axes, its mesh drawn: the accuracy report's plots and
/// the precision view's (`crate::precision`).
pub fn separation_chart<'a, DB: DrawingBackend + 'a>(
    area: &'a DrawingArea<DB, plotters::coord::Shift>,
    caption: String,
    caption_size: u32,
    distances: std::ops::Range<f64>,
) -> Result<SeparationChart<'a, DB>> {
    let mut chart = ChartBuilder::on(area)
        .caption(caption, ("sans-serif", caption_size))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(distances.log_scale(), (1e-8f64..2.0).log_scale())
        .map_err(|e| anyhow!("{e}"))?;
    chart
        .configure_mesh()
        .x_desc("view distance / near")
        .y_desc("relative separation dz/z")
        .x_label_formatter(&|v| format!("{v:.0e}"))
        .y_label_formatter(&|v| format!("{v:.0e}"))
        .draw()
        .map_err(|e| anyhow!("{e}"))?;
    Ok(chart)
}

/// What [`separation_chart`] makes.
pub type SeparationChart<'a, DB> = ChartContext<'a, DB, Cartesian2d<LogCoord<f64>, LogCoord<f64>>>;

/// The series' labels in the upper left of `chart`, in a font of `size` pixels.
pub fn legend<'a, DB: DrawingBackend + 'a>(
    chart: &mut SeparationChart<'a, DB>,
    size: u32,
) -> Result<()> {
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperLeft)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .label_font(("sans-serif", size))
        .draw()
        .map_err(|e| anyhow!("{e}"))
}

fn mode_color(mode: &str) -> RGBColor {
    match mode {
        "none" => RGBColor(200, 40, 40),
        "flip" => RGBColor(230, 150, 20),
        "complementary" => RGBColor(40, 140, 60),
        _ => RGBColor(40, 80, 220),
    }
}

/// `plots/min-separation-<format>.png` per format (`...-<format>-<delivery>.png` for a buffer
/// delivery): measured points over the model's lines.
pub fn plots(out: &Path, results: &[Measurement], rows: &[SeparationRow]) -> Result<Vec<String>> {
    if rows.is_empty() {
        return Ok(Vec::new());
    }
    font()?;
    std::fs::create_dir_all(out.join("plots"))?;
    let mut written = Vec::new();
    let sheets = deliveries_in(results).into_iter().flat_map(|delivery| {
        formats_in(results)
            .into_iter()
            .map(move |format| (delivery, format))
    });
    for (delivery, format) in sheets {
        let name = format_name(format);
        let rows: Vec<&SeparationRow> = rows
            .iter()
            .filter(|r| r.format == name && r.delivery == delivery)
            .collect();
        if rows.is_empty() {
            continue;
        }
        let rel = format!("plots/min-separation-{name}{}.png", suffix(delivery));
        let path = out.join(&rel);
        {
            let root = BitMapBackend::new(&path, (720, 480)).into_drawing_area();
            root.fill(&WHITE).map_err(|e| anyhow!("{e}"))?;
            let caption = format!(
                "plane-stack {name}{}: minimum dz/z resolved (points) vs model (lines)",
                if delivery == "push" {
                    String::new()
                } else {
                    format!(" ({delivery})")
                }
            );
            let mut chart = separation_chart(&root, caption, 18, 3.0..3e6)?;
            // The storage-only floor (grey), dense.
            let dense: Vec<f64> = (0..=22)
                .map(|i| 10f64.powf(1.0 + f64::from(i) / 4.0))
                .collect();
            for mode in Mode::ALL {
                let mode_name = mode.variant().name();
                let color = mode_color(mode_name);
                let mine: Vec<&&SeparationRow> =
                    rows.iter().filter(|r| r.mode == mode_name).collect();
                if mine.is_empty() {
                    continue;
                }
                let floor = model::storage_only(mode.variant(), format, &dense);
                chart
                    .draw_series(LineSeries::new(
                        dense
                            .iter()
                            .zip(floor)
                            .filter_map(|(d, v)| v.map(|v| (*d, v))),
                        color.mix(0.35).stroke_width(1),
                    ))
                    .map_err(|e| anyhow!("{e}"))?;
                chart
                    .draw_series(LineSeries::new(
                        mine.iter().filter_map(|r| {
                            r.model_min_rel_separation
                                .map(|v| (r.distance_over_near, v))
                        }),
                        color.stroke_width(2),
                    ))
                    .map_err(|e| anyhow!("{e}"))?
                    .label(format!("{mode_name}: model (thin: storage only)"))
                    .legend(move |(x, y)| {
                        PathElement::new(vec![(x, y), (x + 16, y)], color.stroke_width(2))
                    });
                chart
                    .draw_series(mine.iter().filter_map(|r| {
                        r.min_rel_separation
                            .map(|v| Circle::new((r.distance_over_near, v), 5, color.filled()))
                    }))
                    .map_err(|e| anyhow!("{e}"))?
                    .label(format!("{mode_name}: measured"))
                    .legend(move |(x, y)| Circle::new((x + 8, y), 4, color.filled()));
            }
            legend(&mut chart, 12)?;
            root.present().map_err(|e| anyhow!("{e}"))?;
        }
        written.push(rel);
    }
    Ok(written)
}
