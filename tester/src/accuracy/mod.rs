//! Accuracy (issue #6): hard-case scenes against ground truth, the precision model beside the
//! measurements, the report, and conformance for CI.
//!
//! Both commands render every (scene, mode, depth format) as a child tester process
//! ([`crate::variants`]): `none` (no layer: standard depth), and revz in `flip`,
//! `complementary` and `infinite` mode, each with depth readback allowed
//! (`REVZ_REVERSE_OBSERVABLE=copies`), the layer's log at `info` and the validation layer on
//! (a validation message fails the render).
//!
//! Depth format promotion (issue #15): revz creates a D16, X8_D24 or D24_S8 depth image in a
//! float format (D32_SFLOAT, D32_SFLOAT_S8_UINT) where its `promote_depth_formats` setting says
//! so; a readback of such an image converts the float values back to the application's UNORM
//! format (issue #40), which would hide the precision measured here. The cases where promotion
//! can apply ([`promotable`]: those formats in `complementary` and
//! `infinite`, the setting's `auto`; every layer mode with `--promote-depth-formats always`)
//! are therefore rendered with `--no-depth-readback` ([`depth_readback`]; with `never` too, so
//! that a render with `never` differs from the default's by the setting alone): their color is
//! measured, their depth is not (`depth_reversed` is null there), and the row's
//! `promoted_format` says what the layer logged it promoted the image to (null where it did
//! not). Every other case reads depth back.
//! [`measure`] compares each render with the scene's ground truth:
//! `wrong_pixel_fraction` is the fraction of checked pixels (interior: at least one pixel away
//! from any silhouette or intersection where another object shows) that show another object
//! than the nearest one.
//!
//!
//! Projection deliveries (issue #16): every scene hands its matrices to the vertex shader in
//! push constants (`push`). `--deliveries` adds the buffer deliveries (`ubo`: P, V and M apart
//! in a dynamic uniform buffer; `ubo-dynamic`: P * V in a uniform buffer and the model matrix
//! in a dynamic one; `ssbo`: P * V * M in a storage buffer; `all`: the three and `push`) for
//! the scenes of [`DELIVERY_SCENES`], every selected mode and format; each row names its
//! `delivery`. The default is `push` alone: the three buffer deliveries of those five scenes
//! would add 300 renders to the 140 of the default report (about three times its runtime),
//! and conformance's bounds for them need the layer's buffer path (until then its reversed
//! rows take the flip path and fail their tight bounds). `tori` and `decal-bias` are rendered
//! with push constants only (a scene the buffer deliveries do not cover is skipped when
//! `push` is not selected).
//!
//! - `report` ([`report()`]): `report.json`, `report.md`, the renders side by side per scene, and
//!   plots of `plane-stack`'s measured minimum separations over the model's curves.
//! - `conformance` ([`conformance()`]): every case against a stated bound; JUnit XML and JSON;
//!   a one-line summary; exit status 1 on any failure.

pub mod conformance;
pub mod measure;
pub mod model;
pub mod report;
pub mod report_images;
pub mod scenes;

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::Result;
use clap::ValueEnum;

use crate::plan::Delivery;
use crate::scene::SceneId;
use crate::target::DepthFormat;
use crate::variants::{Runner, Variant};
use measure::{Case, Measurement, Truth};

/// The accuracy scenes, in report order.
pub const SCENES: [SceneId; 7] = [
    SceneId::SlopedPlane,
    SceneId::MarsPatch,
    SceneId::Tori,
    SceneId::PlaneStack,
    SceneId::DeepRange,
    SceneId::DecalBias,
    SceneId::FarObjects,
];

/// The accuracy scenes the buffer deliveries are rendered for (`--deliveries`): those whose
/// precision depends on how the projection reaches the shader (seed 001's two cases, the
/// minimum separation, the deep range, objects with their own matrices far away).
pub const DELIVERY_SCENES: [SceneId; 5] = [
    SceneId::SlopedPlane,
    SceneId::MarsPatch,
    SceneId::PlaneStack,
    SceneId::DeepRange,
    SceneId::FarObjects,
];

/// A `--deliveries` value: one delivery, or `all` of them.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, ValueEnum)]
pub enum DeliveryChoice {
    /// Push constants (every scene).
    Push,
    /// P, V and M apart in a dynamic uniform buffer.
    Ubo,
    /// P * V in a uniform buffer, the model matrix in a dynamic one.
    UboDynamic,
    /// P * V * M in a storage buffer indexed by the instance.
    Ssbo,
    /// The storage buffer of ssbo, each matrix as its rows, applied as four dot products.
    SsboRows,
    /// The rows of ssbo-rows, applied as DXVK writes a D3D vertex shader (an output register
    /// written one component at a time).
    SsboRegisters,
    /// The buffer of ssbo, applied as fxc's `mul(v, M)` and DXVK write it (a register
    /// reassigned by multiply-adds of the columns).
    SsboColumns,
    /// The buffer of ssbo, applied as Wine's vkd3d-shader writes a D3D vertex shader, with
    /// D3D's depth clamp and clipping (needs VK_EXT_depth_clip_enable).
    SsboVkd3d,
    /// The push constants of push, in a range per stage.
    PushSplit,
    /// The push constants of push-split, the fragment stage's range to byte 128.
    PushFull,
    /// The push constants of push, applied in a geometry shader.
    PushGeometry,
    /// The blocks of ubo, applied in a geometry shader.
    UboGeometry,
    /// ubo, its projected positions passed through a geometry shader.
    UboPassthroughGeometry,
    /// The blocks of ubo, applied in a tessellation evaluation shader.
    UboTessellation,
    /// ubo, its projected positions copied and interpolated by tessellation stages.
    UboInterpolatingTessellation,
    /// The blocks of ubo, applied in a tessellation evaluation shader to the patch's
    /// interpolated positions.
    UboProjectingTessellation,
    /// ubo's blocks applied in a geometry shader to positions a tessellation evaluation
    /// shader interpolated.
    UboTessellatedGeometry,
    /// The push constants of push, the flat program bound as vertex and fragment shader
    /// objects (needs VK_EXT_shader_object).
    ShaderObjects,
    /// The push constants of push, applied in a mesh shader (needs VK_EXT_mesh_shader).
    Mesh,
    /// mesh's shader as a shader object (needs VK_EXT_shader_object and VK_EXT_mesh_shader).
    MeshShaderObjects,
    /// shader-objects' shaders created linked in one call (needs VK_EXT_shader_object).
    LinkedShaderObjects,
    /// ubo-tessellation's shaders as shader objects created linked in one call (needs
    /// VK_EXT_shader_object and tessellationShader).
    LinkedTessellationShaderObjects,
    /// ubo-passthrough-geometry's shaders as unlinked shader objects (needs
    /// VK_EXT_shader_object and geometryShader).
    PassthroughGeometryShaderObjects,
    /// ubo-geometry's shaders as unlinked shader objects, the geometry shader projecting
    /// gl_in (needs VK_EXT_shader_object and geometryShader).
    ProjectingGeometryShaderObjects,
    /// push, push-split, push-full, push-geometry, ubo, ubo-dynamic, ssbo, ssbo-rows, ssbo-registers, ssbo-columns, ssbo-vkd3d,
    /// ubo-geometry, ubo-passthrough-geometry, ubo-tessellation,
    /// ubo-interpolating-tessellation, ubo-projecting-tessellation and ubo-tessellated-geometry
    /// (not shader-objects, mesh,
    /// mesh-shader-objects, linked-shader-objects, linked-tessellation-shader-objects nor
    /// passthrough-geometry-shader-objects nor projecting-geometry-shader-objects, which need
    /// extensions).
    All,
}

impl DeliveryChoice {
    fn deliveries(self) -> &'static [Delivery] {
        match self {
            DeliveryChoice::Push => &[Delivery::Push],
            DeliveryChoice::Ubo => &[Delivery::Ubo],
            DeliveryChoice::UboDynamic => &[Delivery::UboDynamic],
            DeliveryChoice::Ssbo => &[Delivery::Ssbo],
            DeliveryChoice::SsboRows => &[Delivery::SsboRows],
            DeliveryChoice::SsboRegisters => &[Delivery::SsboRegisters],
            DeliveryChoice::SsboColumns => &[Delivery::SsboColumns],
            DeliveryChoice::SsboVkd3d => &[Delivery::SsboVkd3d],
            DeliveryChoice::PushSplit => &[Delivery::PushSplit],
            DeliveryChoice::PushFull => &[Delivery::PushFull],
            DeliveryChoice::PushGeometry => &[Delivery::PushGeometry],
            DeliveryChoice::UboGeometry => &[Delivery::UboGeometry],
            DeliveryChoice::UboPassthroughGeometry => &[Delivery::UboPassthroughGeometry],
            DeliveryChoice::UboTessellation => &[Delivery::UboTessellation],
            DeliveryChoice::UboInterpolatingTessellation => {
                &[Delivery::UboInterpolatingTessellation]
            }
            DeliveryChoice::UboProjectingTessellation => &[Delivery::UboProjectingTessellation],
            DeliveryChoice::UboTessellatedGeometry => &[Delivery::UboTessellatedGeometry],
            DeliveryChoice::ShaderObjects => &[Delivery::ShaderObjects],
            DeliveryChoice::Mesh => &[Delivery::Mesh],
            DeliveryChoice::MeshShaderObjects => &[Delivery::MeshShaderObjects],
            DeliveryChoice::LinkedShaderObjects => &[Delivery::LinkedShaderObjects],
            DeliveryChoice::LinkedTessellationShaderObjects => {
                &[Delivery::LinkedTessellationShaderObjects]
            }
            DeliveryChoice::PassthroughGeometryShaderObjects => {
                &[Delivery::PassthroughGeometryShaderObjects]
            }
            DeliveryChoice::ProjectingGeometryShaderObjects => {
                &[Delivery::ProjectingGeometryShaderObjects]
            }
            DeliveryChoice::All => Delivery::PORTABLE,
        }
    }
}

/// Every depth format, in report order.
pub const FORMATS: [DepthFormat; 5] = [
    DepthFormat::D16,
    DepthFormat::X8D24,
    DepthFormat::D24S8,
    DepthFormat::D32,
    DepthFormat::D32S8,
];

/// A mode of the report: no layer, or revz in one of its reversing modes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, ValueEnum)]
pub enum Mode {
    /// No layer: the application's standard depth.
    None,
    Flip,
    Complementary,
    Infinite,
}

impl Mode {
    pub const ALL: [Mode; 4] = [Mode::None, Mode::Flip, Mode::Complementary, Mode::Infinite];

    pub fn variant(self) -> Variant {
        match self {
            Mode::None => Variant::NoLayer,
            Mode::Flip => Variant::Flip,
            Mode::Complementary => Variant::Complementary,
            Mode::Infinite => Variant::Infinite,
        }
    }
}

/// revz's `promote_depth_formats` setting (`REVZ_PROMOTE_DEPTH_FORMATS`), as the commands pass
/// it to the layer's children.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, ValueEnum)]
pub enum Promotion {
    /// The layer's default: promote in `complementary` and `infinite`, not in `flip`.
    Auto,
    /// Promote in every reversing mode.
    Always,
    /// Never promote.
    Never,
}

impl Promotion {
    /// The value of `REVZ_PROMOTE_DEPTH_FORMATS`.
    pub fn name(self) -> &'static str {
        match self {
            Promotion::Auto => "auto",
            Promotion::Always => "always",
            Promotion::Never => "never",
        }
    }
}

/// Whether revz may promote the depth image of `format` in `mode` under `setting` (`None`: the
/// layer's default, `auto`): the formats it promotes (D16_UNORM, X8_D24_UNORM_PACK32,
/// D24_UNORM_S8_UINT; the tester has no D16_UNORM_S8_UINT), in the modes the setting promotes
/// in, provided the image has no transfer usage ([`depth_readback`]).
pub fn promotable(mode: Mode, format: DepthFormat, setting: Option<Promotion>) -> bool {
    let format_promotes = matches!(
        format,
        DepthFormat::D16 | DepthFormat::X8D24 | DepthFormat::D24S8
    );
    let mode_promotes = match setting.unwrap_or(Promotion::Auto) {
        Promotion::Auto => matches!(mode, Mode::Complementary | Mode::Infinite),
        Promotion::Always => mode != Mode::None,
        Promotion::Never => false,
    };
    format_promotes && mode_promotes
}

/// Whether a case reads its depth image back: not where revz may promote it under `setting` or
/// under its default, so that what is measured is the stored float precision (a readback of a
/// promoted image hands over its values rounded into the application's UNORM format, issue #40).
/// A case the default promotes is rendered without readback under `never` too: `never` then
/// changes nothing but the setting, and shows what promotion is worth.
/// (`--depth-readback-always` reads every case back.)
pub fn depth_readback(mode: Mode, format: DepthFormat, setting: Option<Promotion>) -> bool {
    !(promotable(mode, format, setting) || promotable(mode, format, None))
}

/// What both commands render.
#[derive(Debug, Clone, clap::Args)]
pub struct Selection {
    /// Scenes (comma-separated). Default: all seven accuracy scenes.
    #[arg(long, value_enum, value_delimiter = ',')]
    pub scenes: Vec<SceneId>,

    /// Modes (comma-separated). Default: none, flip, complementary, infinite.
    #[arg(long, value_enum, value_delimiter = ',')]
    pub modes: Vec<Mode>,

    /// Depth formats (comma-separated). Default: every format.
    #[arg(long, value_enum, value_delimiter = ',')]
    pub formats: Vec<DepthFormat>,

    /// Projection deliveries (comma-separated): push, push-split, push-full, push-geometry, ubo,
    /// ubo-dynamic, ssbo,
    /// ssbo-rows, ssbo-registers, ssbo-columns, ubo-geometry, ubo-passthrough-geometry,
    /// ubo-tessellation, ubo-interpolating-tessellation, ubo-projecting-tessellation,
    /// ubo-tessellated-geometry, or all. The deliveries other than
    /// push are
    /// rendered for sloped-plane, mars-patch, plane-stack, deep-range and far-objects.
    /// Default: push.
    #[arg(long, value_enum, value_delimiter = ',', value_name = "DELIVERIES")]
    pub deliveries: Vec<DeliveryChoice>,

    /// The revz layer's manifest directory. Default: `manifests/explicit` next to this
    /// executable (what `cargo xtask build` writes).
    #[arg(long, value_name = "DIR")]
    pub layer_dir: Option<PathBuf>,

    /// Render on the first device whose name contains NAME (as the tester's `--device`).
    #[arg(long, value_name = "NAME")]
    pub device: Option<String>,

    /// revz's `promote_depth_formats` for the layer's renders (REVZ_PROMOTE_DEPTH_FORMATS).
    /// Default: not set (the layer's default, auto). Cases the setting lets revz promote are
    /// rendered without depth readback.
    #[arg(long, value_enum, value_name = "WHEN")]
    pub promote_depth_formats: Option<Promotion>,

    /// Read depth back in every case, promotable ones included (their depth is then the stored
    /// values rounded into the application's UNORM format by revz's converted copy, not the
    /// float precision the report measures): shows that a readback no longer changes what
    /// promotion gives (issue #40).
    #[arg(long)]
    pub depth_readback_always: bool,
}

impl Selection {
    fn scenes(&self) -> Vec<SceneId> {
        if self.scenes.is_empty() {
            SCENES.to_vec()
        } else {
            self.scenes.clone()
        }
    }

    fn modes(&self) -> Vec<Mode> {
        if self.modes.is_empty() {
            Mode::ALL.to_vec()
        } else {
            self.modes.clone()
        }
    }

    fn formats(&self) -> Vec<DepthFormat> {
        if self.formats.is_empty() {
            FORMATS.to_vec()
        } else {
            self.formats.clone()
        }
    }

    /// The selected deliveries, in [`Delivery::ALL`] order, without repeats.
    fn deliveries(&self) -> Vec<Delivery> {
        if self.deliveries.is_empty() {
            return vec![Delivery::Push];
        }
        Delivery::ALL
            .into_iter()
            .filter(|d| {
                self.deliveries
                    .iter()
                    .any(|choice| choice.deliveries().contains(d))
            })
            .collect()
    }
}

/// The deliveries of `deliveries` rendered for `scene`: all of them for
/// [`DELIVERY_SCENES`], push alone (if selected) for the others.
pub fn scene_deliveries(scene: SceneId, deliveries: &[Delivery]) -> Vec<Delivery> {
    deliveries
        .iter()
        .copied()
        .filter(|&d| d == Delivery::Push || DELIVERY_SCENES.contains(&scene))
        .collect()
}

/// `revz-tester report`.
#[derive(Debug, clap::Args)]
pub struct ReportArgs {
    /// Output directory (created if missing).
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,

    /// Render width (`plane-stack` renders at 3 times this size).
    #[arg(long, default_value_t = 160, value_parser = clap::value_parser!(u32).range(16..=4096))]
    pub width: u32,

    /// Render height.
    #[arg(long, default_value_t = 120, value_parser = clap::value_parser!(u32).range(16..=4096))]
    pub height: u32,

    #[command(flatten)]
    pub selection: Selection,
}

/// `revz-tester conformance`.
#[derive(Debug, clap::Args)]
pub struct ConformanceArgs {
    /// Output directory (created if missing): conformance.json, junit.xml, the renders.
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,

    /// Render width (`plane-stack` renders at 3 times this size).
    #[arg(long, default_value_t = 96, value_parser = clap::value_parser!(u32).range(16..=4096))]
    pub width: u32,

    /// Render height.
    #[arg(long, default_value_t = 72, value_parser = clap::value_parser!(u32).range(16..=4096))]
    pub height: u32,

    #[command(flatten)]
    pub selection: Selection,
}

/// The render size of a scene: `plane-stack` needs about a hundred pixels per cell (27 rows,
/// 6 columns), so it renders at three times the size.
pub fn scene_size(scene: SceneId, width: u32, height: u32) -> (u32, u32) {
    match scene {
        SceneId::PlaneStack => (width * 3, height * 3),
        _ => (width, height),
    }
}

/// The (delivery, format, mode) of a scene's cases, in rendering order.
fn cases(deliveries: &[Delivery], selection: &Selection) -> Vec<(Delivery, DepthFormat, Mode)> {
    let mut cases = Vec::new();
    for &delivery in deliveries {
        for format in selection.formats() {
            for mode in selection.modes() {
                cases.push((delivery, format, mode));
            }
        }
    }
    cases
}

/// Renders and measures every selected case, scene by scene; prints one line per case.
pub fn run_all(
    selection: &Selection,
    out: &Path,
    width: u32,
    height: u32,
) -> Result<Vec<Measurement>> {
    std::fs::create_dir_all(out)?;
    let runner = Runner::locate(selection.layer_dir.as_deref())?;
    let mut results = Vec::new();
    for scene in selection.scenes() {
        let deliveries = scene_deliveries(scene, &selection.deliveries());
        if deliveries.is_empty() {
            println!(
                "{}: skipped (the buffer deliveries cover {})",
                scene.name(),
                DELIVERY_SCENES.map(|s| s.name()).join(", ")
            );
            continue;
        }
        let (w, h) = scene_size(scene, width, height);
        let truth = Truth::new(scene, w, h)?;
        let dir = format!("renders/{}", scene.name());
        std::fs::create_dir_all(out.join(&dir))?;
        truth
            .expected_image()
            .save(out.join(&dir).join("expected.png"))?;
        for (delivery, format, mode) in cases(&deliveries, selection) {
            let case = Case {
                scene,
                delivery,
                variant: mode.variant(),
                format,
                width: w,
                height: h,
                depth_readback: selection.depth_readback_always
                    || depth_readback(mode, format, selection.promote_depth_formats),
                promote_depth_formats: selection.promote_depth_formats,
            };
            // Push renders keep their folder names; the others are prefixed.
            let prefix = match delivery {
                Delivery::Push => String::new(),
                other => format!("{}-", other.name()),
            };
            let case_dir = format!(
                "{dir}/{prefix}{}-{}",
                mode.variant().name(),
                measure::format_name(format)
            );
            let m = measure::measure(
                &runner,
                selection.device.as_deref(),
                &case,
                &truth,
                out,
                &case_dir,
            )?;
            println!(
                "{:<13} {:<11} {:<13} {:<7} wrong {:>9.3e} of {:>6} checked, reversed {:<5}{}{}",
                m.scene,
                m.delivery,
                m.mode,
                m.format,
                m.wrong_pixel_fraction,
                m.checked_pixels,
                match m.depth_reversed {
                    Some(r) => r.to_string(),
                    None if !m.depth_readback => "-".into(),
                    None => "?".into(),
                },
                m.promoted_format
                    .as_deref()
                    .map(|f| format!(" promoted to {f}"))
                    .unwrap_or_default(),
                m.error
                    .as_deref()
                    .map(|e| format!("  ERROR {e}"))
                    .unwrap_or_default()
            );
            results.push(m);
        }
    }
    if results.is_empty() {
        anyhow::bail!("no case selected (the buffer deliveries cover only some scenes)");
    }
    Ok(results)
}

pub fn report(args: &ReportArgs) -> Result<ExitCode> {
    let results = run_all(&args.selection, &args.out, args.width, args.height)?;
    report::write(&args.out, &results)?;
    Ok(ExitCode::SUCCESS)
}

pub fn conformance(args: &ConformanceArgs) -> Result<ExitCode> {
    let results = run_all(&args.selection, &args.out, args.width, args.height)?;
    conformance::finish(&args.out, &results)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn promotion_applies_to_unorm_formats_in_the_modes_the_setting_names() {
        use DepthFormat::{D16, D24S8, D32, D32S8, X8D24};
        for format in [D16, X8D24, D24S8] {
            for setting in [None, Some(Promotion::Auto)] {
                assert!(promotable(Mode::Complementary, format, setting));
                assert!(promotable(Mode::Infinite, format, setting));
                assert!(!promotable(Mode::Flip, format, setting));
                assert!(!promotable(Mode::None, format, setting));
            }
            assert!(promotable(Mode::Flip, format, Some(Promotion::Always)));
            assert!(!promotable(Mode::None, format, Some(Promotion::Always)));
            for mode in Mode::ALL {
                assert!(!promotable(mode, format, Some(Promotion::Never)));
            }
        }
        for format in [D32, D32S8] {
            for mode in Mode::ALL {
                assert!(!promotable(mode, format, Some(Promotion::Always)));
                assert!(depth_readback(mode, format, Some(Promotion::Always)));
            }
        }
        // `never` renders the default's promotable cases without readback too.
        assert!(!depth_readback(Mode::Infinite, D16, Some(Promotion::Never)));
        assert!(depth_readback(Mode::Flip, D16, Some(Promotion::Never)));
        assert!(!depth_readback(Mode::Flip, D16, Some(Promotion::Always)));
        assert!(depth_readback(Mode::None, D24S8, Some(Promotion::Always)));
    }
}
