//! The headless OpenGL context of `gl-render`: EGL, with `libEGL.so.1` loaded at run time (the
//! tester still runs where it is missing; only `gl-render` needs it), on Mesa's surfaceless
//! platform (`EGL_MESA_platform_surfaceless`: no window system, no device node, which is what
//! a CI container has), a desktop OpenGL 3.3 core context made current without any surface
//! (`EGL_KHR_surfaceless_context`; the program renders into its own framebuffer object), and
//! `glow`'s function table loaded through `eglGetProcAddress`.

use anyhow::{bail, Context as _, Result};
use khronos_egl as egl;

/// `EGL_PLATFORM_SURFACELESS_MESA` (EGL_MESA_platform_surfaceless).
const PLATFORM_SURFACELESS_MESA: egl::Enum = 0x31DD;

type Egl = egl::DynamicInstance<egl::EGL1_5>;

/// A current OpenGL context; everything is released on drop.
pub struct GlContext {
    egl: Egl,
    display: egl::Display,
    context: egl::Context,
    /// The GL functions of the current context.
    pub gl: glow::Context,
}

impl std::fmt::Debug for GlContext {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("GlContext").finish_non_exhaustive()
    }
}

impl GlContext {
    /// Loads libEGL, opens the surfaceless display and makes a 3.3 core context current on
    /// this thread. The driver is the one Mesa's loader picks from the environment
    /// (`MESA_LOADER_DRIVER_OVERRIDE`, `GALLIUM_DRIVER`), which the caller sets first.
    pub fn new() -> Result<GlContext> {
        // SAFETY: libEGL.so.1 is the system's EGL library (glvnd's dispatcher); the functions
        // the 1.5 instance requires are looked up by name and checked to exist.
        let egl = unsafe { Egl::load_required() }
            .map_err(|e| anyhow::anyhow!("cannot load libEGL.so.1 (EGL 1.5): {e}"))?;
        let client = egl
            .query_string(None, egl::EXTENSIONS)
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        if !client
            .split(' ')
            .any(|e| e == "EGL_MESA_platform_surfaceless")
        {
            bail!("EGL lacks EGL_MESA_platform_surfaceless (client extensions: {client})");
        }
        // SAFETY: the surfaceless platform takes EGL_DEFAULT_DISPLAY (null) as its native
        // display.
        let display = unsafe {
            egl.get_platform_display(
                PLATFORM_SURFACELESS_MESA,
                egl::DEFAULT_DISPLAY,
                &[egl::ATTRIB_NONE],
            )
        }
        .context("eglGetPlatformDisplay(EGL_PLATFORM_SURFACELESS_MESA)")?;
        egl.initialize(display).context("eglInitialize")?;
        match Self::create(&egl, display) {
            Ok((context, gl)) => Ok(GlContext {
                egl,
                display,
                context,
                gl,
            }),
            Err(e) => {
                let _ = egl.terminate(display);
                Err(e)
            }
        }
    }

    fn create(egl: &Egl, display: egl::Display) -> Result<(egl::Context, glow::Context)> {
        let extensions = egl
            .query_string(Some(display), egl::EXTENSIONS)
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        if !extensions
            .split(' ')
            .any(|e| e == "EGL_KHR_surfaceless_context")
        {
            bail!("the EGL display lacks EGL_KHR_surfaceless_context");
        }
        egl.bind_api(egl::OPENGL_API)
            .context("eglBindAPI(OPENGL)")?;
        // The surfaceless platform's configs are pbuffer configs (eglChooseConfig's default
        // surface type, EGL_WINDOW_BIT, matches none of them).
        let config = egl
            .choose_first_config(
                display,
                &[
                    egl::RENDERABLE_TYPE,
                    egl::OPENGL_BIT,
                    egl::SURFACE_TYPE,
                    egl::PBUFFER_BIT,
                    egl::NONE,
                ],
            )
            .context("eglChooseConfig")?
            .context("no EGL config renders desktop OpenGL")?;
        let context = egl
            .create_context(
                display,
                config,
                None,
                &[
                    egl::CONTEXT_MAJOR_VERSION,
                    3,
                    egl::CONTEXT_MINOR_VERSION,
                    3,
                    egl::CONTEXT_OPENGL_PROFILE_MASK,
                    egl::CONTEXT_OPENGL_CORE_PROFILE_BIT,
                    egl::NONE,
                ],
            )
            .context("eglCreateContext (OpenGL 3.3 core)")?;
        if let Err(e) = egl.make_current(display, None, None, Some(context)) {
            let _ = egl.destroy_context(display, context);
            bail!("eglMakeCurrent without a surface: {e}");
        }
        // SAFETY: the context is current on this thread; eglGetProcAddress returns core and
        // extension functions alike (EGL 1.5), null for unknown names.
        let gl = unsafe {
            glow::Context::from_loader_function(|name| {
                egl.get_proc_address(name)
                    .map_or(std::ptr::null(), |f| f as *const std::ffi::c_void)
            })
        };
        Ok((context, gl))
    }
}

/// `ARB_separate_shader_objects`' entry points, which `glow` does not load: what a separable
/// program and a program pipeline need (`gl-render --separable`).
#[derive(Clone, Copy)]
pub struct SeparateShaderObjects {
    pub program_parameteri: unsafe extern "system" fn(program: u32, name: u32, value: i32),
    pub gen_program_pipelines: unsafe extern "system" fn(count: i32, pipelines: *mut u32),
    pub bind_program_pipeline: unsafe extern "system" fn(pipeline: u32),
    pub use_program_stages: unsafe extern "system" fn(pipeline: u32, stages: u32, program: u32),
}

impl std::fmt::Debug for SeparateShaderObjects {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SeparateShaderObjects")
            .finish_non_exhaustive()
    }
}

impl GlContext {
    /// The current context's `ARB_separate_shader_objects` entry points (core in OpenGL 4.1;
    /// Mesa exposes the extension in 3.3 core contexts).
    pub fn separate_shader_objects(&self) -> Result<SeparateShaderObjects> {
        let load = |name: &str| {
            self.egl
                .get_proc_address(name)
                .with_context(|| format!("{name} is not available"))
        };
        // SAFETY: eglGetProcAddress's functions of these names have these signatures
        // (ARB_separate_shader_objects).
        unsafe {
            Ok(SeparateShaderObjects {
                program_parameteri: std::mem::transmute::<
                    extern "system" fn(),
                    unsafe extern "system" fn(u32, u32, i32),
                >(load("glProgramParameteri")?),
                gen_program_pipelines: std::mem::transmute::<
                    extern "system" fn(),
                    unsafe extern "system" fn(i32, *mut u32),
                >(load("glGenProgramPipelines")?),
                bind_program_pipeline: std::mem::transmute::<
                    extern "system" fn(),
                    unsafe extern "system" fn(u32),
                >(load("glBindProgramPipeline")?),
                use_program_stages: std::mem::transmute::<
                    extern "system" fn(),
                    unsafe extern "system" fn(u32, u32, u32),
                >(load("glUseProgramStages")?),
            })
        }
    }
}

/// `glClipControl` (`ARB_clip_control`, core in OpenGL 4.5), which `glow` does not load.
pub type ClipControl = unsafe extern "system" fn(origin: u32, depth: u32);

impl GlContext {
    /// The current context's `glClipControl` (`gl-render --reversed-z`).
    pub fn clip_control(&self) -> Result<ClipControl> {
        let function = self
            .egl
            .get_proc_address("glClipControl")
            .context("glClipControl is not available")?;
        // SAFETY: eglGetProcAddress's glClipControl has this signature (ARB_clip_control).
        Ok(unsafe { std::mem::transmute::<extern "system" fn(), ClipControl>(function) })
    }
}

impl Drop for GlContext {
    fn drop(&mut self) {
        let _ = self.egl.make_current(self.display, None, None, None);
        let _ = self.egl.destroy_context(self.display, self.context);
        let _ = self.egl.terminate(self.display);
    }
}
