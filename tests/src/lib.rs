//! Harness for the end-to-end tests: runs `revz-tester` as a child process on lavapipe, with
//! the Khronos validation layer, with or without the revz layer, and reads back what it wrote:
//! the images, the depth values, and for scenes that have one the tester's computed ground
//! truth ([`GroundTruth`]), against which [`compare_depth`] checks depth pixel by pixel.
//!
//! The binaries and manifests come from `cargo xtask build` (which `cargo xtask test` runs
//! first): the harness finds them next to the test executable, in the same profile directory.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// The layer's name, as the manifests declare it.
pub const LAYER_NAME: &str = "VK_LAYER_REVZ_reverse_z";
/// The line the layer logs at `info` when an instance loads it.
pub const LOADED_LINE: &str = "loaded as VK_LAYER_REVZ_reverse_z: mode ";

/// Every depth format the tester accepts, by its command-line name.
pub const DEPTH_FORMATS: [&str; 5] = ["d16", "x8-d24", "d24-s8", "d32", "d32-s8"];
/// Every `REVZ_MODE` value.
pub const MODES: [&str; 4] = ["off", "flip", "complementary", "infinite"];

/// Environment variables that would change what a child sees if inherited from the caller.
const SCRUBBED_ENV: &[&str] = &[
    "REVZ_MODE",
    "REVZ_LOG",
    "REVZ_LOG_FILE",
    "ENABLE_REVZ",
    "DISABLE_REVZ",
    "VK_INSTANCE_LAYERS",
    "VK_LOADER_LAYERS_ENABLE",
    "VK_LOADER_LAYERS_DISABLE",
    "VK_ADD_LAYER_PATH",
    "VK_LAYER_PATH",
    "REVZ_CONFIG",
    "REVZ_FAR_CLIP",
    "REVZ_REVERSE_OBSERVABLE",
    "REVZ_PROMOTE_DEPTH_FORMATS",
    "REVZ_REPORT",
    "XDG_CONFIG_HOME",
    "XDG_DATA_HOME",
    "VK_LAYER_SETTINGS_PATH",
];

/// Paths to what `cargo xtask build` produced.
#[derive(Debug, Clone)]
pub struct Harness {
    pub tester: PathBuf,
    pub xtask: PathBuf,
    pub library: PathBuf,
    pub explicit_manifest_dir: PathBuf,
    pub implicit_manifest_dir: PathBuf,
    pub scratch: PathBuf,
}

impl Harness {
    /// Finds the build output; panics with what to run when it is missing.
    pub fn locate() -> Harness {
        let exe = std::env::current_exe().expect("test executable path");
        // target/<profile>/deps/e2e-<hash>
        let profile_dir = exe
            .parent()
            .and_then(Path::parent)
            .expect("test executable lives in target/<profile>/deps");
        let harness = Harness {
            tester: profile_dir.join("revz-tester"),
            xtask: profile_dir.join("xtask"),
            library: profile_dir.join("libVkLayer_revz.so"),
            explicit_manifest_dir: profile_dir.join("manifests/explicit"),
            implicit_manifest_dir: profile_dir.join("manifests/implicit"),
            scratch: profile_dir.join("revz-e2e"),
        };
        for needed in [
            &harness.tester,
            &harness.xtask,
            &harness.library,
            &harness.explicit_manifest_dir.join("VkLayer_revz.json"),
        ] {
            assert!(
                needed.exists(),
                "{} is missing: run the tests with `cargo xtask test`, which builds the layer, \
                 the tester and the manifests first",
                needed.display()
            );
        }
        harness
    }

    /// The driver manifest of the newer lavapipe `cargo xtask setup` extracts beside the
    /// system's on Debian 12 (`target/lavapipe-backports`), for what Mesa 22.3's lavapipe
    /// lacks (`VK_EXT_shader_object`); `None` where there is none (a system whose own
    /// lavapipe is new enough renders those tests itself).
    pub fn newer_lavapipe(&self) -> Option<PathBuf> {
        let target = self.tester.parent()?.parent()?;
        let icd = target.join("lavapipe-backports/lvp_icd.json");
        icd.exists().then_some(icd)
    }

    /// `command` rendering on [`Harness::newer_lavapipe`] where there is one.
    pub fn on_newer_lavapipe<'a>(&self, command: &'a mut Command) -> &'a mut Command {
        if let Some(icd) = self.newer_lavapipe() {
            command
                .env("VK_DRIVER_FILES", &icd)
                .env("VK_ICD_FILENAMES", &icd);
        }
        command
    }

    /// The newer Zink `cargo xtask setup` extracts beside the newer lavapipe (Mesa 25.0's
    /// OpenGL drivers, `xtask/src/system.rs`), where it did.
    pub fn newer_zink(&self) -> Option<NewerZink> {
        let icd = self.newer_lavapipe()?;
        let dir = icd.parent()?.to_path_buf();
        let egl = dir.join("zink_egl_vendor.json");
        let libraries = dir.join("root/usr/lib/x86_64-linux-gnu");
        (egl.exists() && libraries.join("dri/zink_dri.so").exists()).then_some(NewerZink {
            icd,
            egl,
            libraries,
        })
    }

    /// `revz-tester report` on lavapipe with the explicit revz layer's manifests, into `out`,
    /// with `args` (scenes, modes, formats, deliveries), on [`Harness::newer_lavapipe`] where
    /// `newer_lavapipe`; panics with its output unless it exits 0. Its `report.json`.
    pub fn report(&self, out: &Path, args: &[&str], newer_lavapipe: bool) -> serde_json::Value {
        let mut command = clean_command(&self.tester);
        command
            .arg("report")
            .arg("--out")
            .arg(out)
            .args(["--device", "llvmpipe"])
            .arg("--layer-dir")
            .arg(&self.explicit_manifest_dir)
            .args(args);
        if newer_lavapipe {
            self.on_newer_lavapipe(&mut command);
        }
        let output = command.output().expect("start revz-tester report");
        let text = format!(
            "{}{}",
            String::from_utf8_lossy(&output.stdout),
            String::from_utf8_lossy(&output.stderr)
        );
        assert_eq!(output.status.code(), Some(0), "{text}");
        serde_json::from_slice(&std::fs::read(out.join("report.json")).expect("report.json"))
            .expect("JSON")
    }

    /// A fresh, empty directory for one test's files.
    pub fn scratch_dir(&self, name: &str) -> PathBuf {
        let dir = self.scratch.join(name);
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).expect("create scratch dir");
        dir
    }

    /// A tester command on lavapipe with validation, writing into `out`, with a clean
    /// environment (no inherited layer or revz variables).
    pub fn tester(&self, depth_format: &str, out: &Path) -> Command {
        let mut command = clean_command(&self.tester);
        command.args(self.tester_args(depth_format, out));
        command
    }

    /// The arguments of [`Harness::tester`], for running the tester through another program.
    pub fn tester_args(&self, depth_format: &str, out: &Path) -> Vec<std::ffi::OsString> {
        let mut args: Vec<std::ffi::OsString> = [
            "--validation",
            "--device",
            "llvmpipe",
            "--depth-format",
            depth_format,
        ]
        .map(Into::into)
        .to_vec();
        args.push("--out".into());
        args.push(out.into());
        args
    }

    /// An `xtask` command (the already-built binary: no nested cargo) with a clean environment.
    pub fn xtask(&self) -> Command {
        clean_command(&self.xtask)
    }

    /// Adds the explicit revz layer (above validation) to `command`.
    pub fn with_layer<'a>(&self, command: &'a mut Command) -> &'a mut Command {
        command
            .env("VK_ADD_LAYER_PATH", &self.explicit_manifest_dir)
            .env("VK_INSTANCE_LAYERS", LAYER_NAME)
    }

    /// Runs the tester and returns its render; panics with its output if it failed.
    pub fn render(&self, mut command: Command, out: &Path) -> Render {
        let output = command.output().expect("start revz-tester");
        let render = Render {
            dir: out.to_path_buf(),
            output,
        };
        render.assert_clean();
        render
    }
}

/// A command for `program` without the inherited variables that would change what it does.
pub fn clean_command(program: &Path) -> Command {
    let mut command = Command::new(program);
    for name in SCRUBBED_ENV {
        command.env_remove(name);
    }
    command
}

/// Mesa 25.0's Zink and lavapipe, beside the system's ([`Harness::newer_zink`]).
#[derive(Clone, Debug)]
pub struct NewerZink {
    /// The newer lavapipe's driver manifest.
    pub icd: PathBuf,
    /// The EGL vendor manifest of its libEGL.
    pub egl: PathBuf,
    /// Its libraries (libgallium, libEGL_mesa, libgbm), and its `dri/` drivers.
    pub libraries: PathBuf,
}

impl NewerZink {
    /// `command`, a `revz-tester gl-render` with its subcommand given, rendering through this
    /// Zink on this lavapipe.
    pub fn apply<'a>(&self, command: &'a mut Command) -> &'a mut Command {
        command
            .arg("--icd")
            .arg(&self.icd)
            .env("LD_LIBRARY_PATH", &self.libraries)
            .env("LIBGL_DRIVERS_PATH", self.libraries.join("dri"))
            .env("__EGL_VENDOR_LIBRARY_FILENAMES", &self.egl)
    }
}

/// One finished tester run.
#[derive(Debug)]
pub struct Render {
    pub dir: PathBuf,
    pub output: Output,
}

impl Render {
    pub fn stdout(&self) -> String {
        String::from_utf8_lossy(&self.output.stdout).into_owned()
    }

    pub fn stderr(&self) -> String {
        String::from_utf8_lossy(&self.output.stderr).into_owned()
    }

    /// Fails with a diagnosis unless the tester succeeded with zero validation messages.
    pub fn assert_clean(&self) {
        let (stdout, stderr) = (self.stdout(), self.stderr());
        let context = format!("--- stdout\n{stdout}\n--- stderr\n{stderr}");
        if stderr.contains("VK_LAYER_KHRONOS_validation not found") {
            panic!("the Khronos validation layer is missing: apt-get install vulkan-validationlayers\n{context}");
        }
        if stderr.contains("no device") || stderr.contains("No Vulkan") {
            panic!(
                "lavapipe is missing: apt-get install mesa-vulkan-drivers libvulkan1\n{context}"
            );
        }
        match self.output.status.code() {
            Some(0) => {}
            Some(2) => panic!("validation messages were reported\n{context}"),
            _ => panic!("revz-tester failed ({})\n{context}", self.output.status),
        }
        assert!(
            stdout.contains("device: llvmpipe"),
            "the render did not run on lavapipe\n{context}"
        );
        let json = self.json();
        assert_eq!(json["validation_messages"], 0, "{context}");
    }

    /// The mode named by the layer's load line, if the layer logged one.
    pub fn loaded_mode(&self) -> Option<String> {
        let stderr = self.stderr();
        let line = stderr.lines().find(|line| line.contains(LOADED_LINE))?;
        let rest = &line[line.find(LOADED_LINE)? + LOADED_LINE.len()..];
        let mode: String = rest.chars().take_while(char::is_ascii_alphabetic).collect();
        Some(mode)
    }

    pub fn json(&self) -> serde_json::Value {
        let text = std::fs::read_to_string(self.dir.join("render.json")).expect("render.json");
        serde_json::from_str(&text).expect("render.json parses")
    }

    /// The color image as decoded RGBA8 pixels.
    pub fn color(&self) -> image::RgbaImage {
        image::open(self.dir.join("color.png"))
            .expect("color.png")
            .to_rgba8()
    }

    /// Every view of the render, view 0 (this directory) first: a multiview render's view n
    /// is in `view<n>/`, with its layer's color and depth and the ground truth of its own
    /// camera (`render.json`'s `views`).
    pub fn views(&self) -> Vec<Render> {
        let views = self.json()["views"].as_u64().expect("views");
        (0..views)
            .map(|view| Render {
                dir: match view {
                    0 => self.dir.clone(),
                    n => self.dir.join(format!("view{n}")),
                },
                output: self.output.clone(),
            })
            .collect()
    }

    /// The decoded depth values, exactly as the tester read them back.
    pub fn depth(&self) -> Vec<f32> {
        let bytes = std::fs::read(self.dir.join("depth.f32")).expect("depth.f32");
        bytes
            .chunks_exact(4)
            .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
            .collect()
    }
}

/// Counts positions where two images differ, for a readable failure message.
pub fn differing_pixels(a: &image::RgbaImage, b: &image::RgbaImage) -> usize {
    assert_eq!(a.dimensions(), b.dimensions());
    a.pixels().zip(b.pixels()).filter(|(x, y)| x != y).count()
}

/// Pixels of `b` whose channels differ from `a`'s by more than `levels` (of 255).
pub fn pixels_off_by_more_than(a: &image::RgbaImage, b: &image::RgbaImage, levels: u8) -> usize {
    assert_eq!(a.dimensions(), b.dimensions());
    a.pixels()
        .zip(b.pixels())
        .filter(|(x, y)| x.0.iter().zip(y.0).any(|(p, q)| p.abs_diff(q) > levels))
        .count()
}

/// The resolution bound within which a flip-path depth equals 1 - the native depth, per
/// format: the rasterizer computes the flipped value from vertex depths that carry the
/// standard mapping's float32 rounding near 1 (about 6e-8), and fixed-point formats round
/// D and 1 - D to their grid independently.
pub fn flip_tolerance(depth_format: &str) -> f32 {
    match depth_format {
        "d16" => 2.0 / 65535.0,
        "x8-d24" | "d24-s8" => 3.0 / 16_777_215.0,
        _ => 3e-7,
    }
}

/// The most color pixels a flip-path render may differ from the native one, per format.
/// D16's grid is coarse enough (1.5e-5) that surfaces closer than one step (intersection lines)
/// resolve differently when D and 1 - D round to it: at most 3 pixels per scene were seen on
/// lavapipe (21 over all scenes); every other format must match exactly.
pub fn flip_color_tolerance(depth_format: &str) -> usize {
    match depth_format {
        "d16" => 8,
        _ => 0,
    }
}

/// Counts depth values that are not bit-identical.
pub fn differing_depths(a: &[f32], b: &[f32]) -> usize {
    assert_eq!(a.len(), b.len());
    a.iter()
        .zip(b)
        .filter(|(x, y)| x.to_bits() != y.to_bits())
        .count()
}

/// The object id of pixels where nothing is drawn (in `expected-id.u16`).
pub const BACKGROUND: u16 = u16::MAX;

/// One object of the ground truth (`render.json`'s `ground_truth.objects`).
#[derive(Debug, Clone, PartialEq)]
pub struct TruthObject {
    /// Its index in the scene (the id in `expected-id.u16`).
    pub id: u16,
    /// Its name.
    pub name: String,
    /// Its flat RGBA8 color.
    pub color: [u8; 4],
    /// The outermost matrix the application pushes for it, as the shader applies it
    /// (`clip = M * v`), column-major f32: what a projection-rewriting layer sees.
    pub pushed_projection: [f32; 16],
    /// The GPU's float32 w is within `(u + gamma_4) * w_condition * w` of the exact one.
    pub w_condition: f64,
}

/// The ground truth the tester computed for a render (`expected-w.f64`, `expected-id.u16` and
/// the `ground_truth` section of `render.json`).
#[derive(Debug, Clone, PartialEq)]
pub struct GroundTruth {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// The camera's near plane.
    pub near: f64,
    /// The camera's far plane.
    pub far: f64,
    /// The application's clip depth is OpenGL's [-1, 1].
    pub negative_one_to_one: bool,
    /// The application's projection is already reversed.
    pub reversed: bool,
    /// The visible object per pixel ([`BACKGROUND`] for none).
    pub ids: Vec<u16>,
    /// The visible surface's exact view-space w at interior pixels, NaN elsewhere.
    pub w: Vec<f64>,
    /// The objects drawn into the main target.
    pub objects: Vec<TruthObject>,
}

impl GroundTruth {
    /// The object with id `id`.
    pub fn object(&self, id: u16) -> &TruthObject {
        self.objects
            .iter()
            .find(|o| o.id == id)
            .unwrap_or_else(|| panic!("no object {id} in the ground truth"))
    }

    /// The number of interior pixels.
    pub fn interior(&self) -> usize {
        self.w.iter().filter(|w| w.is_finite()).count()
    }

    /// The background pixels whose 3 x 3 neighbourhood is all background (no silhouette near).
    pub fn open_background(&self) -> Vec<usize> {
        let (width, height) = (self.width, self.height);
        (0..width * height)
            .filter(|&at| {
                let (x, y) = (at % width, at / width);
                (y.saturating_sub(1)..(y + 2).min(height)).all(|ny| {
                    (x.saturating_sub(1)..(x + 2).min(width))
                        .all(|nx| self.ids[ny * width + nx] == BACKGROUND)
                })
            })
            .collect()
    }
}

impl Render {
    /// The tester's ground truth for this render; panics if the scene has none.
    pub fn ground_truth(&self) -> GroundTruth {
        let json = self.json();
        let truth = &json["ground_truth"];
        assert!(
            truth.is_object(),
            "scene {} has no ground truth: {json}",
            json["scene"]
        );
        let number = |v: &serde_json::Value| v.as_f64().expect("a number");
        let (width, height) = (
            json["width"].as_u64().expect("width") as usize,
            json["height"].as_u64().expect("height") as usize,
        );
        let read = |key: &str| {
            let name = truth[key].as_str().expect("a file name");
            std::fs::read(self.dir.join(name)).unwrap_or_else(|e| panic!("{name}: {e}"))
        };
        let w: Vec<f64> = read("file")
            .chunks_exact(8)
            .map(|b| f64::from_le_bytes(b.try_into().expect("8 bytes")))
            .collect();
        let ids: Vec<u16> = read("id_file")
            .chunks_exact(2)
            .map(|b| u16::from_le_bytes([b[0], b[1]]))
            .collect();
        assert_eq!(w.len(), width * height, "expected-w.f64 has the wrong size");
        assert_eq!(
            ids.len(),
            width * height,
            "expected-id.u16 has the wrong size"
        );
        let objects = truth["objects"]
            .as_array()
            .expect("objects")
            .iter()
            .map(|o| {
                let values: Vec<f32> = o["pushed_projection"]
                    .as_array()
                    .expect("pushed_projection")
                    .iter()
                    .map(|v| number(v) as f32)
                    .collect();
                let color: Vec<u8> = o["color"]
                    .as_array()
                    .expect("color")
                    .iter()
                    .map(|v| v.as_u64().expect("a color component") as u8)
                    .collect();
                TruthObject {
                    id: o["id"].as_u64().expect("id") as u16,
                    name: o["name"].as_str().expect("name").to_owned(),
                    color: color.try_into().expect("RGBA"),
                    pushed_projection: values.try_into().expect("16 values"),
                    w_condition: number(&o["w_condition"]),
                }
            })
            .collect();
        let ground_truth = GroundTruth {
            width,
            height,
            near: number(&truth["near"]),
            far: number(&truth["far"]),
            negative_one_to_one: truth["depth_convention"] == "negative-one-to-one",
            reversed: truth["reversed"] == true,
            ids,
            w,
            objects,
        };
        assert_eq!(
            ground_truth.interior() as u64,
            truth["interior_pixels"].as_u64().expect("interior_pixels")
        );
        ground_truth
    }
}

/// How the depth read back compares with a reference at the interior pixels.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct DepthComparison {
    /// Interior pixels checked.
    pub checked: usize,
    /// Pixels outside their bound.
    pub failures: usize,
    /// The largest |depth - reference| / bound (< 1 everywhere means the check holds).
    pub worst_ratio: f64,
    /// The largest |depth - reference| / |reference|.
    pub worst_relative: f64,
    /// The pixel with the worst ratio, described.
    pub worst: String,
}

impl DepthComparison {
    /// Whether every pixel is within its bound.
    pub fn holds(&self) -> bool {
        self.checked > 0 && self.failures == 0
    }
}

/// Compares `depth` with `reference(object, w) = (value, bound)` at every interior pixel of
/// `truth`.
pub fn compare_depth(
    depth: &[f32],
    truth: &GroundTruth,
    mut reference: impl FnMut(&TruthObject, f64) -> (f64, f64),
) -> DepthComparison {
    assert_eq!(
        depth.len(),
        truth.w.len(),
        "depth and ground truth sizes differ"
    );
    let mut result = DepthComparison::default();
    for (at, (&stored, &w)) in depth.iter().zip(&truth.w).enumerate() {
        if !w.is_finite() {
            continue;
        }
        let object = truth.object(truth.ids[at]);
        let (value, bound) = reference(object, w);
        let error = (f64::from(stored) - value).abs();
        result.checked += 1;
        // NaN (a reference or a depth that is not a number) counts as a failure.
        let within = error <= bound;
        if !within {
            result.failures += 1;
        }
        result.worst_relative = result.worst_relative.max(error / value.abs());
        let ratio = error / bound;
        if ratio > result.worst_ratio || ratio.is_nan() {
            result.worst_ratio = ratio;
            result.worst = format!(
                "pixel ({}, {}) on {}: w {w:.6}, depth {stored:e}, reference {value:e}, \
                 error {error:.3e} = {:.3e} relative, bound {bound:.3e}",
                at % truth.width,
                at / truth.width,
                object.name,
                error / value.abs(),
            );
        }
    }
    result
}

/// What is wrong with `layered`, a render of `native`'s scene through revz, where it must keep
/// the native colors: its depth attachment not reversed (its log says so per image), or
/// colors that differ where the ground truth does not explain it
/// ([`unexplained_color_differences`]). `what` names the case in the problems and in the
/// record printed (shown with `--nocapture`).
pub fn native_colors_problems(
    native: &Render,
    layered: &Render,
    truth: &GroundTruth,
    what: &str,
) -> Vec<String> {
    let mut problems = Vec::new();
    let log = layered.stderr();
    if !log.contains("): reversed") {
        problems.push(format!(
            "{what}: the depth attachment was not reversed: {log}"
        ));
    }
    let (a, b) = (native.color(), layered.color());
    let unexplained = unexplained_color_differences(&a, &b, truth);
    eprintln!(
        "{what}: {} color pixels differ from the native render, {} unexplained",
        differing_pixels(&a, &b),
        unexplained.len()
    );
    if !unexplained.is_empty() {
        problems.push(format!(
            "{what}: {} pixels differ where the ground truth does not explain it: {}",
            unexplained.len(),
            unexplained
                .iter()
                .take(8)
                .cloned()
                .collect::<Vec<_>>()
                .join("; ")
        ));
    }
    problems
}

/// The pixels where `layered`'s colors differ from `native`'s that the ground truth does not
/// explain, described. A difference is explained at a pixel that is not interior (a silhouette
/// or an intersection line: two surfaces meet near its center) where `layered` shows the
/// object that is exactly nearest at the pixel center: a depth tie that `native` resolved with
/// less precision. At interior pixels the colors must be identical.
pub fn unexplained_color_differences(
    native: &image::RgbaImage,
    layered: &image::RgbaImage,
    truth: &GroundTruth,
) -> Vec<String> {
    assert_eq!(native.dimensions(), layered.dimensions());
    let width = truth.width;
    native
        .pixels()
        .zip(layered.pixels())
        .enumerate()
        .filter(|(_, (a, b))| a != b)
        .filter_map(|(at, (a, b))| {
            let id = truth.ids[at];
            let exact = (id != BACKGROUND).then(|| truth.object(id));
            let explained = truth.w[at].is_nan() && exact.is_some_and(|o| o.color == b.0);
            (!explained).then(|| {
                format!(
                    "pixel ({}, {}): {:?} natively, {:?} layered, {} exactly{}",
                    at % width,
                    at / width,
                    a.0,
                    b.0,
                    exact.map_or("background", |o| o.name.as_str()),
                    if truth.w[at].is_nan() {
                        ""
                    } else {
                        " (interior)"
                    },
                )
            })
        })
        .collect()
}
