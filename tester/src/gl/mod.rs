//! `revz-tester gl-render` (issue #16): the tester's scenes drawn by a small OpenGL program,
//! headless, so that what OpenGL applications reaching Vulkan (and revz) through Zink render
//! is judged against the same ground truth as the Vulkan renders. This file owns the
//! subcommand: the environment that picks the driver for this process (`--zink`: Mesa's Zink
//! on lavapipe; `--revz MODE`: revz injected under Zink), the outputs, and the measurement,
//! made by the accuracy code itself ([`crate::accuracy::measure`]). [`context`]: EGL;
//! [`draw`]: the GL program.
//!
//! What selects Zink on lavapipe with Mesa 22.3 on the surfaceless EGL platform without a
//! render node (found by trying): `MESA_LOADER_DRIVER_OVERRIDE=zink` (EGL loads `zink_dri.so`
//! instead of `swrast`, i.e. llvmpipe; `GALLIUM_DRIVER=zink` does the same on the software
//! path) *and* `LIBGL_ALWAYS_SOFTWARE=1`: Zink's `choose_pdev` takes a
//! `VK_PHYSICAL_DEVICE_TYPE_CPU` device only when `LIBGL_ALWAYS_SOFTWARE` (or
//! `D3D_ALWAYS_SOFTWARE`) is set, and without it eglInitialize fails ("DRI2: failed to create
//! screen"). `VK_DRIVER_FILES` (`VK_ICD_FILENAMES` for older loaders) holds the Vulkan loader
//! to lavapipe's ICD.

pub mod context;
pub mod draw;

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{bail, ensure, Context as _, Result};
use serde::Serialize;

use crate::accuracy::measure::{self, Measurement, Truth};
use crate::readback::{self, Frame};
use crate::scene::SceneId;
use crate::target::DepthFormat;

/// Where Debian's mesa-vulkan-drivers puts lavapipe's ICD manifest.
const ICD_DIRS: [&str; 2] = ["/usr/share/vulkan/icd.d", "/etc/vulkan/icd.d"];

/// `revz-tester gl-render`.
#[derive(Debug, clap::Args)]
pub struct GlRenderArgs {
    /// Scene to render (flat-colored standard-depth scenes: sloped-plane, plane-stack,
    /// overlap, tori, ...).
    #[arg(long, value_enum, default_value = "overlap")]
    pub scene: SceneId,

    /// Output directory (created if missing): color.png, depth.png, depth.f32, the ground
    /// truth (expected-w.f64, expected-id.u16, expected.png) and measurement.json.
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,

    /// Width [default: the accuracy report's, 160 (plane-stack 480); other scenes 256].
    #[arg(long, value_parser = clap::value_parser!(u32).range(16..=8192))]
    pub width: Option<u32>,

    /// Height [default: the accuracy report's, 120 (plane-stack 360); other scenes 256].
    #[arg(long, value_parser = clap::value_parser!(u32).range(16..=8192))]
    pub height: Option<u32>,

    /// Render through Zink on lavapipe (sets MESA_LOADER_DRIVER_OVERRIDE=zink,
    /// GALLIUM_DRIVER=zink, LIBGL_ALWAYS_SOFTWARE=1, and VK_DRIVER_FILES / VK_ICD_FILENAMES to
    /// lavapipe's ICD).
    /// Without it: whatever Mesa picks from the environment (llvmpipe by default).
    #[arg(long)]
    pub zink: bool,

    /// Draw the scene with a separable program per stage in a program pipeline
    /// (`ARB_separate_shader_objects`), as engines that mix shader stages do: Zink from Mesa
    /// 24 on compiles such stages on their own first, as unlinked shader objects where the
    /// Vulkan driver has `VK_EXT_shader_object` (Mesa 25.0's lavapipe), and links a pipeline
    /// in the background.
    #[arg(long)]
    pub separable: bool,

    /// The vertex shader builds the position it projects from components it computed
    /// (`vec4(position.x, position.y + u_zero * position.x, position.z, 1.0)`, `u_zero` left
    /// 0), as glmark2's `conditionals`, `function` and `loop` scenes do: Mesa's NIR splats the
    /// computed y for its column, not a component of a vector; and adds an offset of w 0 in
    /// view space before the projection (`vec4(u_zero * position, 0.0)`), as glmark2's
    /// `terrain` displaces its vertices. Not with `--separable`.
    #[arg(long, conflicts_with = "separable")]
    pub computed_position: bool,

    /// A compute shader (GL 4.3) writes a storage buffer before the scene draws and again
    /// before each post pass draws, in the same batch: Zink binds its compute descriptors
    /// (descriptor buffers on a driver with `VK_EXT_descriptor_buffer`) before revz converts
    /// the depth for the post pass (which then runs in the scene's batch, before the scene is
    /// read back). The buffer is read back after the frame, and the render fails unless every
    /// dispatch's sums are in it.
    #[arg(long)]
    pub compute_first: bool,

    /// Render reversed depth as OpenGL applications do themselves: `glClipControl(GL_LOWER_LEFT,
    /// GL_ZERO_TO_ONE)`, `glClearDepth(0)`, `GL_GREATER`, and a projection onto complementary
    /// depth in [0, 1] (near 1, far 0) into the float32 depth buffer. revz must leave such an
    /// application's depth alone (it decides so at its first clear to 0: Zink creates its
    /// pipelines only at the first draw). Not with `--post`.
    #[arg(long, conflicts_with = "post")]
    pub reversed_z: bool,

    /// The Vulkan driver manifest Zink renders on [default: the system's lavapipe,
    /// lvp_icd*.json in the standard ICD directories]: a newer lavapipe, say (`cargo xtask
    /// setup` extracts Mesa 25.0's beside Debian 12's, with Mesa 25.0's Zink:
    /// tests/tests/zink.rs).
    #[arg(long, value_name = "JSON")]
    pub icd: Option<PathBuf>,

    /// Inject revz in this mode under Zink (implies --zink): VK_ADD_LAYER_PATH,
    /// VK_INSTANCE_LAYERS, REVZ_MODE; REVZ_LOG=debug, REVZ_REVERSE_OBSERVABLE=copies and
    /// REVZ_COPY_VALUES=stored (the stored depth is what is judged) unless already set.
    #[arg(long, value_name = "MODE", value_parser = ["off", "flip", "complementary", "infinite"])]
    pub revz: Option<String>,

    /// After the scene, a pass that samples its depth (the depth attachment is then a texture):
    /// `fetch` (texelFetch, the value spread over the colors), `compare` (a shadow sampler
    /// against 0.98), `blit` (glBlitFramebuffer of the depth into another depth texture, and
    /// mirrored into a third, each read back and fetched: blit-depth.f32,
    /// blit-mirrored-depth.f32, post-mirrored.png), `mipmap` (glGenerateMipmap of the depth
    /// texture, level 1 read back and fetched: mip1-depth.f32, half size); its color is
    /// written to post.png. Or `texels`: D16, D24 and D24S8 textures filled with known texels
    /// and read by fetches and shadow lookups (texels-d16.f32, texels-d24.f32,
    /// texels-d24s8.f32: fetched, LEQUAL, GEQUAL, reference, a texel).
    #[arg(long, value_enum, value_name = "PASS")]
    pub post: Option<draw::PostPass>,

    /// The revz layer's manifest directory [default: manifests/explicit next to this
    /// executable, what `cargo xtask build` writes].
    #[arg(long, value_name = "DIR")]
    pub layer_dir: Option<PathBuf>,
}

/// `measurement.json`.
#[derive(Debug, Serialize)]
struct Report<'a> {
    gl_renderer: &'a str,
    gl_version: &'a str,
    /// The driver-selecting variables as this process had them.
    environment: Vec<(&'static str, Option<String>)>,
    measurement: &'a Measurement,
}

/// The variables [`set_environment`] may set, reported in `measurement.json`.
const REPORTED_ENV: [&str; 11] = [
    "MESA_LOADER_DRIVER_OVERRIDE",
    "GALLIUM_DRIVER",
    "LIBGL_ALWAYS_SOFTWARE",
    "VK_DRIVER_FILES",
    "VK_ICD_FILENAMES",
    "VK_ADD_LAYER_PATH",
    "VK_INSTANCE_LAYERS",
    "REVZ_MODE",
    "REVZ_LOG",
    "REVZ_REVERSE_OBSERVABLE",
    "REVZ_COPY_VALUES",
];

/// lavapipe's ICD manifest.
fn lavapipe_icd() -> Result<PathBuf> {
    for dir in ICD_DIRS {
        let Ok(entries) = std::fs::read_dir(dir) else {
            continue;
        };
        let mut found: Vec<PathBuf> = entries
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| {
                p.file_name()
                    .and_then(|n| n.to_str())
                    .is_some_and(|n| n.starts_with("lvp_icd") && n.ends_with(".json"))
            })
            .collect();
        found.sort();
        if let Some(icd) = found.into_iter().next() {
            return Ok(icd);
        }
    }
    bail!(
        "no lavapipe ICD (lvp_icd*.json) in {} (install mesa-vulkan-drivers)",
        ICD_DIRS.join(" or ")
    )
}

/// Sets this process's driver environment before libEGL is loaded (nothing else runs yet:
/// the process is single-threaded here).
fn set_environment(args: &GlRenderArgs) -> Result<()> {
    if !(args.zink || args.revz.is_some()) {
        return Ok(());
    }
    let icd = match &args.icd {
        Some(icd) => icd.clone(),
        None => lavapipe_icd()?,
    };
    std::env::set_var("MESA_LOADER_DRIVER_OVERRIDE", "zink");
    std::env::set_var("GALLIUM_DRIVER", "zink");
    // Zink picks a CPU Vulkan device only when asked for software rendering.
    std::env::set_var("LIBGL_ALWAYS_SOFTWARE", "1");
    std::env::set_var("VK_DRIVER_FILES", &icd);
    std::env::set_var("VK_ICD_FILENAMES", &icd);
    if let Some(mode) = &args.revz {
        let dir = match &args.layer_dir {
            Some(dir) => dir.clone(),
            None => std::env::current_exe()
                .context("cannot find the tester's own executable")?
                .parent()
                .context("the tester's executable has no directory")?
                .join("manifests/explicit"),
        };
        if !dir.join("VkLayer_revz.json").is_file() {
            bail!(
                "no revz layer manifest in {} (run `cargo xtask build`, or pass --layer-dir)",
                dir.display()
            );
        }
        std::env::set_var("VK_ADD_LAYER_PATH", &dir);
        std::env::set_var("VK_INSTANCE_LAYERS", crate::variants::LAYER_NAME);
        std::env::set_var("REVZ_MODE", mode);
        for (name, default) in [
            ("REVZ_LOG", "debug"),
            ("REVZ_REVERSE_OBSERVABLE", "copies"),
            ("REVZ_COPY_VALUES", "stored"),
        ] {
            if std::env::var_os(name).is_none() {
                std::env::set_var(name, default);
            }
        }
    }
    Ok(())
}

/// The render size: the accuracy report's for its scenes, else 256 x 256.
fn size(args: &GlRenderArgs) -> (u32, u32) {
    let (w, h) = if crate::accuracy::SCENES.contains(&args.scene) {
        crate::accuracy::scene_size(args.scene, 160, 120)
    } else {
        (256, 256)
    };
    (args.width.unwrap_or(w), args.height.unwrap_or(h))
}

/// The `mode` column of the measurement.
fn mode_name(args: &GlRenderArgs) -> &'static str {
    match args.revz.as_deref() {
        Some("off") => "zink-revz-off",
        Some("flip") => "zink-revz-flip",
        Some("complementary") => "zink-revz-complementary",
        Some(_) => "zink-revz-infinite",
        None if args.zink => "zink",
        None => "gl",
    }
}

/// `revz-tester gl-render`.
pub fn run(args: &GlRenderArgs) -> Result<ExitCode> {
    set_environment(args)?;
    let (width, height) = size(args);
    let scene = args.scene.build();
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot create output directory {}", args.out.display()))?;

    let frame = {
        let context = context::GlContext::new().context("cannot create an OpenGL context")?;
        let separable = if args.separable {
            Some(context.separate_shader_objects()?)
        } else {
            None
        };
        let clip_control = if args.reversed_z {
            Some(context.clip_control()?)
        } else {
            None
        };
        draw::render(
            &context.gl,
            &scene,
            width,
            height,
            args.post,
            separable.as_ref(),
            args.computed_position,
            clip_control,
            args.compute_first,
        )?
    };
    println!("GL renderer: {} ({})", frame.renderer, frame.version);
    let out = &args.out;
    let written = readback::write_images(
        out,
        &Frame {
            width,
            height,
            depth_format: DepthFormat::D32,
            rgba: frame.rgba.clone(),
            depth: Some(frame.depth.clone()),
        },
        1.0,
    )?;
    for path in written {
        println!("wrote: {}", path.display());
    }

    for post in &frame.post {
        let image = image::RgbaImage::from_raw(width, height, post.rgba.clone())
            .context("the post pass's read-back has the wrong size")?;
        let path = out.join(post.file);
        image
            .save(&path)
            .with_context(|| format!("cannot write {}", path.display()))?;
        println!("wrote: {}", path.display());
    }
    for post in &frame.post_depth {
        ensure!(
            post.depth.len()
                == post.width as usize * post.height as usize * post.components as usize,
            "{}: the read-back has the wrong size",
            post.file
        );
        let bytes: Vec<u8> = post.depth.iter().flat_map(|d| d.to_le_bytes()).collect();
        write(&out.join(post.file), &bytes)?;
    }

    let truth = Truth::new(args.scene, width, height)?;
    for (name, bytes) in [
        (crate::ground_truth::W_FILE, truth.truth.w_bytes()),
        (crate::ground_truth::ID_FILE, truth.truth.id_bytes()),
    ] {
        write(&out.join(name), &bytes)?;
    }
    let expected = out.join("expected.png");
    truth.expected_image().save(&expected)?;
    println!("wrote: {}", expected.display());
    let color = image::RgbaImage::from_raw(width, height, frame.rgba.clone())
        .context("color read-back has the wrong size")?;
    let mut m = Measurement::blank(
        args.scene.name(),
        mode_name(args),
        DepthFormat::D32,
        width,
        height,
    );
    // The matrices are GLSL uniforms (Zink: a uniform buffer).
    m.delivery = "gl-uniforms";
    m.device = frame.renderer.clone();
    m.driver = frame.version.clone();
    m.dir = out.display().to_string();
    measure::compare(&mut m, &truth, &color, Some(&frame.depth))?;
    print_measurement(&m);

    let report = Report {
        gl_renderer: &frame.renderer,
        gl_version: &frame.version,
        environment: REPORTED_ENV
            .iter()
            .map(|&name| (name, std::env::var(name).ok()))
            .collect(),
        measurement: &m,
    };
    let mut json = serde_json::to_string_pretty(&report)?;
    json.push('\n');
    write(&out.join("measurement.json"), json.as_bytes())?;
    Ok(ExitCode::SUCCESS)
}

fn write(path: &Path, bytes: &[u8]) -> Result<()> {
    std::fs::write(path, bytes).with_context(|| format!("cannot write {}", path.display()))?;
    println!("wrote: {}", path.display());
    Ok(())
}

/// One line as the accuracy commands print it, and `plane-stack`'s minimum separations.
fn print_measurement(m: &Measurement) {
    println!(
        "{} {}: wrong {:.3e} ({} of {} checked), depth reversed {}",
        m.scene,
        m.mode,
        m.wrong_pixel_fraction,
        m.wrong_pixels,
        m.checked_pixels,
        m.depth_reversed
            .map_or_else(|| "?".to_string(), |r| r.to_string())
    );
    for point in m.min_rel_separation.iter().flatten() {
        println!(
            "  distance {:>7.0e} n: minimum relative separation {}",
            point.distance_over_near,
            point
                .min_rel_separation
                .map_or_else(|| "none resolves".to_string(), |s| format!("{s:.2e}"))
        );
    }
}
