//! The OpenGL program of `gl-render`: a scene of the tester drawn as an ordinary OpenGL 3.3
//! application would, into a framebuffer object (an RGBA8 color renderbuffer and a
//! GL_DEPTH_COMPONENT32F depth renderbuffer), with standard GL depth (glClearDepth(1), GL_LESS,
//! the default glDepthRange), the matrices as separate GLSL uniforms (`u_projection`, `u_view`,
//! `u_model`), the projection GL's own: clip z in [-w, w] from the scene camera's near, far and
//! field of view, y up. Both are read back with glReadPixels and turned top row first, which
//! lines the render up pixel for pixel with the Vulkan renders and the ground truth: the
//! Vulkan projection is GL's depth-remapped and y-negated, and GL's bottom-up window rows
//! reversed put every pixel center at the same NDC as Vulkan's top-down framebuffer rows.

use anyhow::{bail, ensure, Context as _, Result};
use glam::dcamera::rh::proj;
use glam::DMat4;
use glow::HasContext as _;

use crate::plan::Program;
use crate::scene::{Projection, Scene, Space};

/// The vertex shader: what an OpenGL application with separate matrices writes.
pub const VERTEX_SHADER: &str = "#version 330 core
layout(location = 0) in vec3 position;
uniform mat4 u_projection;
uniform mat4 u_view;
uniform mat4 u_model;
void main() {
    gl_Position = u_projection * u_view * u_model * vec4(position, 1.0);
}
";

/// [`VERTEX_SHADER`] with the position built from a component it computes, and an offset of
/// w 0 added before the projection (`gl-render --computed-position`): `u_zero` is never set,
/// so GL's 0 (the same position, bit for bit, for finite coordinates), which no compiler can
/// fold.
pub const COMPUTED_POSITION_VERTEX_SHADER: &str = "#version 330 core
layout(location = 0) in vec3 position;
uniform mat4 u_projection;
uniform mat4 u_view;
uniform mat4 u_model;
uniform float u_zero;
void main() {
    vec4 p = vec4(position.x, position.y + u_zero * position.x, position.z, 1.0);
    vec4 offset = vec4(u_zero * position, 0.0);
    gl_Position = u_projection * (u_view * u_model * p + offset);
}
";

/// [`VERTEX_SHADER`] for a separable program (`--separable`): `gl_PerVertex` redeclared, as
/// separable programs need for the built-ins they write.
pub const SEPARABLE_VERTEX_SHADER: &str = "#version 330 core
#extension GL_ARB_separate_shader_objects : require
layout(location = 0) in vec3 position;
uniform mat4 u_projection;
uniform mat4 u_view;
uniform mat4 u_model;
out gl_PerVertex { vec4 gl_Position; };
void main() {
    gl_Position = u_projection * u_view * u_model * vec4(position, 1.0);
}
";

/// [`FRAGMENT_SHADER`] for a separable program.
pub const SEPARABLE_FRAGMENT_SHADER: &str = "#version 330 core
#extension GL_ARB_separate_shader_objects : require
uniform vec4 u_color;
out vec4 color;
void main() {
    color = u_color;
}
";

/// The scene's shaders: one program, or (`--separable`) a separable program per stage in a
/// program pipeline, as `ARB_separate_shader_objects` applications do (Zink compiles such
/// shaders on their own first: with `VK_EXT_shader_object`, as shader objects).
#[derive(Clone, Copy, Debug)]
enum ScenePrograms {
    Linked(glow::Program),
    Separate {
        vertex: glow::Program,
        fragment: glow::Program,
        pipeline: u32,
    },
}

/// The fragment shader: each object's flat color.
pub const FRAGMENT_SHADER: &str = "#version 330 core
uniform vec4 u_color;
out vec4 color;
void main() {
    color = u_color;
}
";

/// A post pass that samples the scene's depth (`--post`), as engines and GL programs do (fog,
/// soft edges, shadow tests): the depth attachment is then a texture, not a renderbuffer, and
/// a full-screen pass writes a color image from it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum PostPass {
    /// `texelFetch` of the depth texture (no compare), the value spread over the colors:
    /// `smoothstep(0.95, 1.0, d)` and finer bands, so that a depth off by more than a few
    /// units shows.
    Fetch,
    /// A `sampler2DShadow` (GL_COMPARE_REF_TO_TEXTURE, GL_LEQUAL) against 0.98 with linear
    /// filtering (a percentage-closer lookup): white where the depth is at least 0.98.
    Compare,
    /// `glBlitFramebuffer` of the depth (GL_DEPTH_BUFFER_BIT, GL_NEAREST) into a depth-only
    /// framebuffer of another depth texture of the same size, and mirrored (x flipped) into a
    /// third; each read back with glReadPixels (`blit-depth.f32`, `blit-mirrored-depth.f32`)
    /// and sampled as `fetch` does (`post.png`, `post-mirrored.png`).
    Blit,
    /// The depth texture has a full mip chain (glTexStorage2D,
    /// GL_NEAREST_MIPMAP_NEAREST); after the scene, glGenerateMipmap, then level 1 read back
    /// with glReadPixels (`mip1-depth.f32`, half the size) and sampled with
    /// `texelFetch(.., 1)` as `fetch` does, each level-1 texel over 2 x 2 pixels (`post.png`).
    Mipmap,
    /// Depth textures of the UNORM formats (GL_DEPTH_COMPONENT16, GL_DEPTH_COMPONENT24,
    /// GL_DEPTH24_STENCIL8), the size of the render, filled by glTexImage2D with known texels
    /// ([`texel_value`]) and read by one pass per format into an RGBA32F target: the texel
    /// fetched (`texelFetch`), a shadow lookup with GL_LEQUAL and one with GL_GEQUAL against
    /// the texel's own value as the reference (1 where the texel reads as what was uploaded,
    /// as piglit's `depth-tex-compare` checks), and that reference; read back as float32
    /// (`texels-d16.f32`, `texels-d24.f32`, `texels-d24s8.f32`, four values a texel, top row
    /// first). The scene's depth is not read.
    Texels,
}

/// The UNORM depth formats [`PostPass::Texels`] fills: (file, internal format, bits).
pub const TEXEL_FORMATS: [(&str, u32, u32); 3] = [
    ("texels-d16.f32", glow::DEPTH_COMPONENT16, 16),
    ("texels-d24.f32", glow::DEPTH_COMPONENT24, 24),
    ("texels-d24s8.f32", glow::DEPTH24_STENCIL8, 24),
];

/// The UNORM value of texel `index` of a [`PostPass::Texels`] texture of `bits`: 0, 1, 2, the
/// largest and the one below it first, then a multiplicative hash spread over the whole
/// range (every high and low bit pattern shows up).
pub fn texel_value(index: u32, bits: u32) -> u32 {
    let max = (1u32 << bits) - 1;
    match index {
        0..=2 => index,
        3 => max,
        4 => max - 1,
        _ => index.wrapping_mul(2_654_435_761) >> (32 - bits),
    }
}

/// [`PostPass::Texels`]'s fragment shader: the same texture bound to three units (through
/// sampler objects: no compare, GL_LEQUAL, GL_GEQUAL), the reference values in a fourth.
const POST_TEXELS_SHADER: &str = "#version 330 core
uniform sampler2D u_depth;
uniform sampler2DShadow u_less_equal;
uniform sampler2DShadow u_greater_equal;
uniform sampler2D u_reference;
out vec4 result;
void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    float reference = texelFetch(u_reference, p, 0).r;
    vec2 uv = (vec2(p) + 0.5) / vec2(textureSize(u_depth, 0));
    result = vec4(
        texelFetch(u_depth, p, 0).r,
        texture(u_less_equal, vec3(uv, reference)),
        texture(u_greater_equal, vec3(uv, reference)),
        reference);
}
";

/// The post pass's full-screen triangle (no vertex buffer: `gl_VertexID`).
const POST_VERTEX_SHADER: &str = "#version 330 core
void main() {
    vec2 p = vec2(float((gl_VertexID << 1) & 2), float(gl_VertexID & 2));
    gl_Position = vec4(p * 2.0 - 1.0, 0.0, 1.0);
}
";

/// [`PostPass::Fetch`]'s fragment shader.
const POST_FETCH_SHADER: &str = "#version 330 core
uniform sampler2D u_depth;
out vec4 color;
void main() {
    float d = texelFetch(u_depth, ivec2(gl_FragCoord.xy), 0).r;
    color = vec4(smoothstep(0.95, 1.0, d), fract(d * 64.0), fract(d * 1024.0), 1.0);
}
";

/// [`PostPass::Mipmap`]'s fragment shader: [`POST_FETCH_SHADER`] at level `u_level`, each of
/// its texels over 2^`u_level` x 2^`u_level` pixels.
const POST_FETCH_LEVEL_SHADER: &str = "#version 330 core
uniform sampler2D u_depth;
uniform int u_level;
out vec4 color;
void main() {
    float d = texelFetch(u_depth, ivec2(gl_FragCoord.xy) >> u_level, u_level).r;
    color = vec4(smoothstep(0.95, 1.0, d), fract(d * 64.0), fract(d * 1024.0), 1.0);
}
";

/// [`PostPass::Compare`]'s fragment shader.
const POST_COMPARE_SHADER: &str = "#version 330 core
uniform sampler2DShadow u_depth;
uniform vec2 u_size;
out vec4 color;
void main() {
    float lit = texture(u_depth, vec3(gl_FragCoord.xy / u_size, 0.98));
    color = vec4(vec3(lit), 1.0);
}
";

/// What was rendered and read back.
#[derive(Debug)]
pub struct GlFrame {
    /// RGBA8, row-major, top row first.
    pub rgba: Vec<u8>,
    /// Window depth per pixel, row-major, top row first.
    pub depth: Vec<f32>,
    /// The post passes' colors, where one ran.
    pub post: Vec<PostImage>,
    /// Depth the post pass made and read back (`--post blit`: the blits' destinations;
    /// `--post mipmap`: level 1), or the values it read (`--post texels`).
    pub post_depth: Vec<PostDepth>,
    /// GL_RENDERER.
    pub renderer: String,
    /// GL_VERSION.
    pub version: String,
}

/// One post pass's color, the size of the render.
#[derive(Debug)]
pub struct PostImage {
    /// The file it goes to (`post.png`, ...).
    pub file: &'static str,
    /// RGBA8, row-major, top row first.
    pub rgba: Vec<u8>,
}

/// Depth a post pass made, as glReadPixels(GL_DEPTH_COMPONENT, GL_FLOAT) returns it (or
/// `components` float32 values a pixel, as [`PostPass::Texels`] reads them).
#[derive(Debug)]
pub struct PostDepth {
    /// The file it goes to (`blit-depth.f32`, ...).
    pub file: &'static str,
    pub width: u32,
    pub height: u32,
    /// Values per pixel: 1, or 4 for [`PostPass::Texels`].
    pub components: u32,
    /// Row-major, top row first.
    pub depth: Vec<f32>,
}

/// The matrices one object's draw sets: (u_projection, u_view, u_model), each rounded once
/// from f64 to f32 as an application holding f64 math would upload them.
pub fn matrices(scene: &Scene, space: Space, model: DMat4, aspect: f64) -> Result<[DMat4; 3]> {
    let camera = &scene.camera;
    let projection = proj::opengl::perspective(camera.fov_y, aspect, camera.near, camera.far);
    Ok(match space {
        Space::World => [projection, camera.view(), model],
        // The vertex buffer holds the baked positions (`Scene::vertex_positions`).
        Space::WorldBaked => [projection, camera.view(), DMat4::IDENTITY],
        Space::ViewBaked => [projection, DMat4::IDENTITY, DMat4::IDENTITY],
        Space::Clip => bail!("clip-space objects (Vulkan clip y) are not drawn through GL"),
    })
}

/// The projection of `gl-render --reversed-z`: the scene camera's onto depth in [0, 1]
/// (`GL_ZERO_TO_ONE`, y up), complemented: near at 1, far at 0 (clip z = w - z of the
/// standard one), as applications that reverse depth themselves write it.
pub fn reversed_projection(scene: &Scene, aspect: f64) -> DMat4 {
    let camera = &scene.camera;
    let mut projection = proj::directx::perspective(camera.fov_y, aspect, camera.near, camera.far);
    for column in [
        &mut projection.x_axis,
        &mut projection.y_axis,
        &mut projection.z_axis,
        &mut projection.w_axis,
    ] {
        column.z = column.w - column.z;
    }
    projection
}

/// The objects drawn, in draw order: refuses scenes that do more than GL_LESS into depth
/// cleared to 1 with the flat program and no culling (the ground truth's rule, and what this
/// program draws).
fn drawn(scene: &Scene) -> Result<Vec<usize>> {
    if scene.camera.projection != Projection::Standard {
        bail!(
            "scene '{}' has a {:?} projection: gl-render draws standard-depth scenes",
            scene.name,
            scene.camera.projection
        );
    }
    let drawn = crate::ground_truth::applies(scene).map_err(|why| {
        anyhow::anyhow!(
            "scene '{}' is more than nearest-surface-wins ({why})",
            scene.name
        )
    })?;
    drawn
        .into_iter()
        .map(|(object, program, cull)| {
            ensure!(
                program == Program::Flat && !cull,
                "scene '{}' draws object {object} with {program:?}{}: gl-render has the flat \
                 program only, without culling",
                scene.name,
                if cull { " and culling" } else { "" }
            );
            Ok(object)
        })
        .collect()
}

/// Renders `scene` at `width` x `height` with the current context's GL and reads it back.
/// With `separable`, the scene's stages are separable programs in a program pipeline; with
/// `computed_position`, the vertex shader is [`COMPUTED_POSITION_VERTEX_SHADER`]; with
/// `reversed_z` (the context's `glClipControl`), the application's own reversed depth
/// ([`reversed_projection`], a clear to 0, `GL_GREATER`).
#[allow(clippy::too_many_arguments)]
pub fn render(
    gl: &glow::Context,
    scene: &Scene,
    width: u32,
    height: u32,
    post: Option<PostPass>,
    separable: Option<&super::context::SeparateShaderObjects>,
    computed_position: bool,
    reversed_z: Option<super::context::ClipControl>,
    compute_first: bool,
) -> Result<GlFrame> {
    let objects = drawn(scene)?;
    let aspect = f64::from(width) / f64::from(height);
    let (w, h) = (
        i32::try_from(width).context("width")?,
        i32::try_from(height).context("height")?,
    );
    let geometry = scene.geometry();
    // SAFETY: every call below is made on the thread whose context is current, with objects
    // this function created, slices of the sizes GL reads or writes, and is checked with
    // glGetError at the end.
    unsafe {
        let renderer = gl.get_parameter_string(glow::RENDERER);
        let version = gl.get_parameter_string(glow::VERSION);
        let programs = match separable {
            None => {
                let vertex = if computed_position {
                    COMPUTED_POSITION_VERTEX_SHADER
                } else {
                    VERTEX_SHADER
                };
                ScenePrograms::Linked(link_program(gl, vertex, FRAGMENT_SHADER)?)
            }
            Some(sso) => {
                let vertex = link_separable(gl, sso, glow::VERTEX_SHADER, SEPARABLE_VERTEX_SHADER)?;
                let fragment =
                    link_separable(gl, sso, glow::FRAGMENT_SHADER, SEPARABLE_FRAGMENT_SHADER)?;
                let mut pipeline = 0;
                (sso.gen_program_pipelines)(1, &mut pipeline);
                ensure!(pipeline != 0, "glGenProgramPipelines made none");
                (sso.use_program_stages)(pipeline, glow::VERTEX_SHADER_BIT, vertex.0.get());
                (sso.use_program_stages)(pipeline, glow::FRAGMENT_SHADER_BIT, fragment.0.get());
                ScenePrograms::Separate {
                    vertex,
                    fragment,
                    pipeline,
                }
            }
        };

        let (framebuffer, color) = color_target(gl, w, h)?;
        // A renderbuffer, or a texture where a post pass samples it.
        let (depth, depth_texture) = if post.is_some() {
            let texture = if post == Some(PostPass::Mipmap) {
                let levels = mip_levels(w, h);
                let texture = depth_texture(gl, w, h, levels)?;
                gl.tex_parameter_i32(
                    glow::TEXTURE_2D,
                    glow::TEXTURE_MIN_FILTER,
                    glow::NEAREST_MIPMAP_NEAREST as i32,
                );
                texture
            } else {
                depth_texture(gl, w, h, 1)?
            };
            if post == Some(PostPass::Compare) {
                gl.tex_parameter_i32(
                    glow::TEXTURE_2D,
                    glow::TEXTURE_COMPARE_MODE,
                    glow::COMPARE_REF_TO_TEXTURE as i32,
                );
                gl.tex_parameter_i32(
                    glow::TEXTURE_2D,
                    glow::TEXTURE_COMPARE_FUNC,
                    glow::LEQUAL as i32,
                );
                gl.tex_parameter_i32(
                    glow::TEXTURE_2D,
                    glow::TEXTURE_MIN_FILTER,
                    glow::LINEAR as i32,
                );
                gl.tex_parameter_i32(
                    glow::TEXTURE_2D,
                    glow::TEXTURE_MAG_FILTER,
                    glow::LINEAR as i32,
                );
            }
            gl.framebuffer_texture_2d(
                glow::FRAMEBUFFER,
                glow::DEPTH_ATTACHMENT,
                glow::TEXTURE_2D,
                Some(texture),
                0,
            );
            (None, Some(texture))
        } else {
            let depth = gl.create_renderbuffer().map_err(anyhow::Error::msg)?;
            gl.bind_renderbuffer(glow::RENDERBUFFER, Some(depth));
            gl.renderbuffer_storage(glow::RENDERBUFFER, glow::DEPTH_COMPONENT32F, w, h);
            gl.framebuffer_renderbuffer(
                glow::FRAMEBUFFER,
                glow::DEPTH_ATTACHMENT,
                glow::RENDERBUFFER,
                Some(depth),
            );
            (Some(depth), None)
        };
        let status = gl.check_framebuffer_status(glow::FRAMEBUFFER);
        ensure!(
            status == glow::FRAMEBUFFER_COMPLETE,
            "framebuffer incomplete (0x{status:x})"
        );

        let vao = gl.create_vertex_array().map_err(anyhow::Error::msg)?;
        gl.bind_vertex_array(Some(vao));
        let vertices = gl.create_buffer().map_err(anyhow::Error::msg)?;
        gl.bind_buffer(glow::ARRAY_BUFFER, Some(vertices));
        gl.buffer_data_u8_slice(
            glow::ARRAY_BUFFER,
            &geometry.position_bytes(),
            glow::STATIC_DRAW,
        );
        gl.enable_vertex_attrib_array(0);
        gl.vertex_attrib_pointer_f32(0, 3, glow::FLOAT, false, 12, 0);
        let indices = gl.create_buffer().map_err(anyhow::Error::msg)?;
        gl.bind_buffer(glow::ELEMENT_ARRAY_BUFFER, Some(indices));
        gl.buffer_data_u8_slice(
            glow::ELEMENT_ARRAY_BUFFER,
            &geometry.index_bytes(),
            glow::STATIC_DRAW,
        );

        gl.viewport(0, 0, w, h);
        gl.disable(glow::DITHER);
        gl.enable(glow::DEPTH_TEST);
        gl.depth_mask(true);
        let [r, g, b, a] = crate::render::CLEAR_COLOR;
        gl.clear_color(r, g, b, a);
        match reversed_z {
            Some(clip_control) => {
                clip_control(glow::LOWER_LEFT, glow::ZERO_TO_ONE);
                gl.depth_func(glow::GREATER);
                gl.clear_depth(0.0);
            }
            None => {
                gl.depth_func(glow::LESS);
                gl.clear_depth(1.0);
            }
        }
        gl.clear(glow::COLOR_BUFFER_BIT | glow::DEPTH_BUFFER_BIT);
        let compute = if compute_first {
            let writer = ComputeWriter::new(gl)?;
            writer.dispatch(gl);
            Some(writer)
        } else {
            None
        };

        // The programs holding the matrices' and the color's uniforms.
        let (matrix_program, color_program) = match programs {
            ScenePrograms::Linked(program) => {
                gl.use_program(Some(program));
                (program, program)
            }
            ScenePrograms::Separate {
                vertex,
                fragment,
                pipeline,
            } => {
                gl.use_program(None);
                if let Some(sso) = separable {
                    (sso.bind_program_pipeline)(pipeline);
                }
                (vertex, fragment)
            }
        };
        let (u_projection, u_view, u_model, u_color) = (
            gl.get_uniform_location(matrix_program, "u_projection"),
            gl.get_uniform_location(matrix_program, "u_view"),
            gl.get_uniform_location(matrix_program, "u_model"),
            gl.get_uniform_location(color_program, "u_color"),
        );
        for n in objects {
            let object = &scene.objects[n];
            let [p, v, m] = matrices(scene, object.space, object.model, aspect)?;
            let p = if reversed_z.is_some() {
                reversed_projection(scene, aspect)
            } else {
                p
            };
            let cols = |m: DMat4| m.as_mat4().to_cols_array();
            // A linked program's uniforms set as before `--separable` existed (the bound
            // program's); separable programs' by name (`glProgramUniform*`).
            let linked = matches!(programs, ScenePrograms::Linked(_));
            let matrix = |location: &Option<glow::UniformLocation>, values: &[f32]| {
                if linked {
                    gl.uniform_matrix_4_f32_slice(location.as_ref(), false, values);
                } else {
                    gl.program_uniform_matrix_4_f32_slice(
                        matrix_program,
                        location.as_ref(),
                        false,
                        values,
                    );
                }
            };
            matrix(&u_projection, &cols(p));
            matrix(&u_view, &cols(v));
            matrix(&u_model, &cols(m));
            if linked {
                gl.uniform_4_f32_slice(u_color.as_ref(), &object.color);
            } else {
                gl.program_uniform_4_f32_slice(color_program, u_color.as_ref(), &object.color);
            }
            let range = geometry.draws[n];
            gl.draw_elements_base_vertex(
                glow::TRIANGLES,
                i32::try_from(range.index_count).context("index count")?,
                glow::UNSIGNED_INT,
                i32::try_from(range.first_index * 4).context("index offset")?,
                range.vertex_offset,
            );
        }
        // With `compute_first`, the post pass follows the draws in the same batch (after the
        // compute pass's second dispatch), as a frame's SSAO pass would: Zink then records the
        // depth's barrier and revz's refresh after its compute binds in one command buffer
        // (the scene read back first, a batch of its own, would let Zink hoist the barrier
        // into its barrier command buffer, where no compute state is bound).
        let early_post = match (compute.as_ref(), post, depth_texture) {
            (Some(compute), Some(pass), Some(texture)) => Some(
                post_passes(gl, pass, framebuffer, texture, (w, h), Some(compute))
                    .context("the post pass")?,
            ),
            _ => None,
        };
        gl.finish();
        gl.bind_framebuffer(glow::FRAMEBUFFER, Some(framebuffer));

        let pixels = (width * height) as usize;
        gl.pixel_store_i32(glow::PACK_ALIGNMENT, 1);
        let rgba = read_rgba(gl, w, h, pixels);
        let mut depth_bytes = vec![0u8; pixels * 4];
        gl.read_pixels(
            0,
            0,
            w,
            h,
            glow::DEPTH_COMPONENT,
            glow::FLOAT,
            glow::PixelPackData::Slice(Some(&mut depth_bytes)),
        );
        let (post_images, post_depth) = match (early_post, post, depth_texture) {
            (Some(made), _, _) => made,
            (None, Some(pass), Some(texture)) => {
                post_passes(gl, pass, framebuffer, texture, (w, h), None)
                    .context("the post pass")?
            }
            _ => (Vec::new(), Vec::new()),
        };
        let error = gl.get_error();
        if let Some(compute) = compute {
            compute.check(gl)?;
            compute.delete(gl);
        }

        gl.delete_buffer(indices);
        gl.delete_buffer(vertices);
        gl.delete_vertex_array(vao);
        if let Some(depth) = depth {
            gl.delete_renderbuffer(depth);
        }
        if let Some(texture) = depth_texture {
            gl.delete_texture(texture);
        }
        gl.delete_renderbuffer(color);
        gl.delete_framebuffer(framebuffer);
        match programs {
            ScenePrograms::Linked(program) => gl.delete_program(program),
            ScenePrograms::Separate {
                vertex, fragment, ..
            } => {
                // The pipeline stays with the context, destroyed with it.
                gl.delete_program(vertex);
                gl.delete_program(fragment);
            }
        }
        ensure!(error == glow::NO_ERROR, "GL error 0x{error:x}");

        let row = width as usize;
        let depth: Vec<f32> = depth_bytes
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect();
        Ok(GlFrame {
            rgba: top_row_first(&rgba, row * 4),
            depth: top_row_first(&depth, row),
            post: post_images,
            post_depth,
            renderer,
            version,
        })
    }
}

/// `--compute-first`'s compute pass: a GL 4.3 compute shader that adds
/// `COMPUTE_STEP + i` to word `i` of a storage buffer (zeroed at its creation) at each
/// dispatch, as a culling or particle pass before a frame's draws would; [`Self::check`] reads
/// the buffer back after the frame and fails unless every dispatch's sums are there (the
/// compute state Zink bound, and revz's restoring of it, worked).
struct ComputeWriter {
    program: glow::Program,
    buffer: glow::Buffer,
    dispatches: std::cell::Cell<u32>,
}

/// Words of [`ComputeWriter`]'s buffer (one work group).
const COMPUTE_WORDS: usize = 64;
/// What each dispatch adds to every word, besides the word's index.
const COMPUTE_STEP: u32 = 1000;

const COMPUTE_SHADER: &str = "#version 430 core
layout(local_size_x = 64) in;
layout(std430, binding = 0) buffer Words { uint words[]; };
void main() {
    uint i = gl_GlobalInvocationID.x;
    words[i] += 1000u + i; // COMPUTE_STEP
}
";

impl ComputeWriter {
    /// # Safety
    /// The caller's context is current.
    unsafe fn new(gl: &glow::Context) -> Result<ComputeWriter> {
        // SAFETY: the caller's contract; objects made here.
        unsafe {
            let shader = compile(gl, glow::COMPUTE_SHADER, COMPUTE_SHADER, "compute")?;
            let program = gl.create_program().map_err(anyhow::Error::msg)?;
            gl.attach_shader(program, shader);
            gl.link_program(program);
            gl.delete_shader(shader);
            if !gl.get_program_link_status(program) {
                let log = gl.get_program_info_log(program);
                gl.delete_program(program);
                bail!("compute program link failed: {log}");
            }
            let buffer = gl.create_buffer().map_err(anyhow::Error::msg)?;
            gl.bind_buffer(glow::SHADER_STORAGE_BUFFER, Some(buffer));
            gl.buffer_data_u8_slice(
                glow::SHADER_STORAGE_BUFFER,
                &[0u8; COMPUTE_WORDS * 4],
                glow::DYNAMIC_READ,
            );
            Ok(ComputeWriter {
                program,
                buffer,
                dispatches: std::cell::Cell::new(0),
            })
        }
    }

    /// One dispatch. It leaves its program bound: callers bind their draw's program after it
    /// (the program bound before may be one deleted since, which GL frees once unbound).
    ///
    /// # Safety
    /// The caller's context is current.
    unsafe fn dispatch(&self, gl: &glow::Context) {
        // SAFETY: the caller's contract; objects of this writer.
        unsafe {
            gl.use_program(Some(self.program));
            gl.bind_buffer_base(glow::SHADER_STORAGE_BUFFER, 0, Some(self.buffer));
            gl.dispatch_compute(1, 1, 1);
            gl.memory_barrier(glow::SHADER_STORAGE_BARRIER_BIT | glow::BUFFER_UPDATE_BARRIER_BIT);
        }
        self.dispatches.set(self.dispatches.get() + 1);
    }

    /// Fails unless word `i` holds `dispatches * (COMPUTE_STEP + i)`.
    ///
    /// # Safety
    /// The caller's context is current.
    unsafe fn check(&self, gl: &glow::Context) -> Result<()> {
        let mut bytes = [0u8; COMPUTE_WORDS * 4];
        // SAFETY: the caller's contract; a buffer of this size.
        unsafe {
            gl.bind_buffer(glow::SHADER_STORAGE_BUFFER, Some(self.buffer));
            gl.get_buffer_sub_data(glow::SHADER_STORAGE_BUFFER, 0, &mut bytes);
        }
        let dispatches = self.dispatches.get();
        for (i, word) in bytes.chunks_exact(4).enumerate() {
            let got = u32::from_le_bytes([word[0], word[1], word[2], word[3]]);
            let want = dispatches * (COMPUTE_STEP + i as u32);
            ensure!(
                got == want,
                "the compute pass's word {i} reads {got} after {dispatches} dispatches, not {want}"
            );
        }
        Ok(())
    }

    /// # Safety
    /// The caller's context is current.
    unsafe fn delete(self, gl: &glow::Context) {
        // SAFETY: the caller's contract; objects of this writer.
        unsafe {
            gl.delete_buffer(self.buffer);
            gl.delete_program(self.program);
        }
    }
}

/// GL's rows (bottom row first) in the tester's order (top row first).
fn top_row_first<T: Copy>(rows: &[T], row: usize) -> Vec<T> {
    rows.chunks_exact(row).rev().flatten().copied().collect()
}

/// The levels of a full mip chain of `w` x `h`.
fn mip_levels(w: i32, h: i32) -> i32 {
    let largest = w.max(h).max(1);
    32 - largest.leading_zeros() as i32
}

/// A GL_DEPTH_COMPONENT32F texture of `w` x `h` with `levels` levels (glTexStorage2D where
/// more than one, glTexImage2D otherwise), nearest filtering, clamped, bound to TEXTURE_2D.
///
/// # Safety
/// The caller's context is current.
unsafe fn depth_texture(gl: &glow::Context, w: i32, h: i32, levels: i32) -> Result<glow::Texture> {
    // SAFETY: the caller's contract; the texture is made here.
    unsafe {
        let texture = gl.create_texture().map_err(anyhow::Error::msg)?;
        gl.bind_texture(glow::TEXTURE_2D, Some(texture));
        if levels > 1 {
            gl.tex_storage_2d(glow::TEXTURE_2D, levels, glow::DEPTH_COMPONENT32F, w, h);
        } else {
            gl.tex_image_2d(
                glow::TEXTURE_2D,
                0,
                glow::DEPTH_COMPONENT32F as i32,
                w,
                h,
                0,
                glow::DEPTH_COMPONENT,
                glow::FLOAT,
                glow::PixelUnpackData::Slice(None),
            );
        }
        for (name, value) in [
            (glow::TEXTURE_MIN_FILTER, glow::NEAREST),
            (glow::TEXTURE_MAG_FILTER, glow::NEAREST),
            (glow::TEXTURE_WRAP_S, glow::CLAMP_TO_EDGE),
            (glow::TEXTURE_WRAP_T, glow::CLAMP_TO_EDGE),
        ] {
            gl.tex_parameter_i32(glow::TEXTURE_2D, name, value as i32);
        }
        Ok(texture)
    }
}

/// A depth-only framebuffer of `texture`'s `level` (no color: draw and read buffers NONE),
/// bound to GL_FRAMEBUFFER.
///
/// # Safety
/// The caller's context is current; `texture` is a depth texture with that level.
unsafe fn depth_framebuffer(
    gl: &glow::Context,
    texture: glow::Texture,
    level: i32,
) -> Result<glow::Framebuffer> {
    // SAFETY: the caller's contract; the framebuffer is made here.
    unsafe {
        let framebuffer = gl.create_framebuffer().map_err(anyhow::Error::msg)?;
        gl.bind_framebuffer(glow::FRAMEBUFFER, Some(framebuffer));
        gl.framebuffer_texture_2d(
            glow::FRAMEBUFFER,
            glow::DEPTH_ATTACHMENT,
            glow::TEXTURE_2D,
            Some(texture),
            level,
        );
        gl.draw_buffer(glow::NONE);
        gl.read_buffer(glow::NONE);
        let status = gl.check_framebuffer_status(glow::FRAMEBUFFER);
        ensure!(
            status == glow::FRAMEBUFFER_COMPLETE,
            "depth-only framebuffer incomplete (0x{status:x})"
        );
        Ok(framebuffer)
    }
}

/// The depth of the framebuffer bound to GL_READ_FRAMEBUFFER (`w` x `h`) as
/// glReadPixels(GL_DEPTH_COMPONENT, GL_FLOAT) returns it, top row first.
///
/// # Safety
/// The caller's context is current, with a framebuffer of at least `w` x `h` bound for reading.
unsafe fn read_depth(gl: &glow::Context, w: i32, h: i32) -> Vec<f32> {
    let mut bytes = vec![0u8; w as usize * h as usize * 4];
    // SAFETY: the caller's contract; the slice holds the w x h floats GL writes.
    unsafe {
        gl.pixel_store_i32(glow::PACK_ALIGNMENT, 1);
        gl.read_pixels(
            0,
            0,
            w,
            h,
            glow::DEPTH_COMPONENT,
            glow::FLOAT,
            glow::PixelPackData::Slice(Some(&mut bytes)),
        );
    }
    let depth: Vec<f32> = bytes
        .chunks_exact(4)
        .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        .collect();
    top_row_first(&depth, w as usize)
}

/// What `pass` makes after the scene: its colors and the depth it reads back.
///
/// # Safety
/// The caller's context is current; `scene_framebuffer` is the scene's framebuffer and
/// `texture` its depth texture (with a full mip chain for [`PostPass::Mipmap`]).
unsafe fn post_passes(
    gl: &glow::Context,
    pass: PostPass,
    scene_framebuffer: glow::Framebuffer,
    texture: glow::Texture,
    (w, h): (i32, i32),
    compute: Option<&ComputeWriter>,
) -> Result<(Vec<PostImage>, Vec<PostDepth>)> {
    let image = |file, rgba: Vec<u8>| PostImage {
        file,
        rgba: top_row_first(&rgba, w as usize * 4),
    };
    // SAFETY: the caller's contract; objects made here.
    unsafe {
        match pass {
            PostPass::Fetch | PostPass::Compare => {
                let fragment = if pass == PostPass::Fetch {
                    POST_FETCH_SHADER
                } else {
                    POST_COMPARE_SHADER
                };
                let rgba = post_pass(gl, fragment, texture, (0, w, h), compute)?;
                Ok((vec![image("post.png", rgba)], Vec::new()))
            }
            PostPass::Blit => {
                let (mut images, mut depths) = (Vec::new(), Vec::new());
                for (mirrored, post_file, depth_file) in [
                    (false, "post.png", "blit-depth.f32"),
                    (true, "post-mirrored.png", "blit-mirrored-depth.f32"),
                ] {
                    let copy = depth_texture(gl, w, h, 1)?;
                    let framebuffer = depth_framebuffer(gl, copy, 0)?;
                    gl.bind_framebuffer(glow::READ_FRAMEBUFFER, Some(scene_framebuffer));
                    gl.bind_framebuffer(glow::DRAW_FRAMEBUFFER, Some(framebuffer));
                    let (x0, x1) = if mirrored { (w, 0) } else { (0, w) };
                    gl.blit_framebuffer(
                        0,
                        0,
                        w,
                        h,
                        x0,
                        0,
                        x1,
                        h,
                        glow::DEPTH_BUFFER_BIT,
                        glow::NEAREST,
                    );
                    gl.bind_framebuffer(glow::FRAMEBUFFER, Some(framebuffer));
                    gl.finish();
                    depths.push(PostDepth {
                        file: depth_file,
                        width: w as u32,
                        height: h as u32,
                        components: 1,
                        depth: read_depth(gl, w, h),
                    });
                    let rgba = post_pass(gl, POST_FETCH_SHADER, copy, (0, w, h), compute)?;
                    images.push(image(post_file, rgba));
                    gl.delete_framebuffer(framebuffer);
                    gl.delete_texture(copy);
                }
                Ok((images, depths))
            }
            PostPass::Mipmap => {
                gl.bind_framebuffer(glow::FRAMEBUFFER, None);
                gl.active_texture(glow::TEXTURE0);
                gl.bind_texture(glow::TEXTURE_2D, Some(texture));
                gl.generate_mipmap(glow::TEXTURE_2D);
                let error = gl.get_error();
                ensure!(
                    error == glow::NO_ERROR,
                    "glGenerateMipmap of the GL_DEPTH_COMPONENT32F texture: GL error 0x{error:x}"
                );
                let (lw, lh) = ((w >> 1).max(1), (h >> 1).max(1));
                let framebuffer = depth_framebuffer(gl, texture, 1)?;
                gl.finish();
                let depth = PostDepth {
                    file: "mip1-depth.f32",
                    width: lw as u32,
                    height: lh as u32,
                    components: 1,
                    depth: read_depth(gl, lw, lh),
                };
                gl.delete_framebuffer(framebuffer);
                let rgba = post_pass(gl, POST_FETCH_LEVEL_SHADER, texture, (1, w, h), compute)?;
                Ok((vec![image("post.png", rgba)], vec![depth]))
            }
            PostPass::Texels => {
                let mut read = Vec::new();
                for (file, internal_format, bits) in TEXEL_FORMATS {
                    let values = texels_pass(gl, internal_format, bits, w, h)
                        .with_context(|| format!("the texels of {file}"))?;
                    read.push(PostDepth {
                        file,
                        width: w as u32,
                        height: h as u32,
                        components: 4,
                        depth: top_row_first(&values, w as usize * 4),
                    });
                }
                Ok((Vec::new(), read))
            }
        }
    }
}

/// One format of [`PostPass::Texels`]: the texture filled, read by the pass, its RGBA32F
/// target read back (bottom row first).
///
/// # Safety
/// The caller's context is current.
unsafe fn texels_pass(
    gl: &glow::Context,
    internal_format: u32,
    bits: u32,
    w: i32,
    h: i32,
) -> Result<Vec<f32>> {
    let texels = w as u32 * h as u32;
    let max = f64::from((1u32 << bits) - 1);
    let references: Vec<f32> = (0..texels)
        .map(|i| (f64::from(texel_value(i, bits)) / max) as f32)
        .collect();
    let bytes = |words: &[u32]| -> Vec<u8> { words.iter().flat_map(|w| w.to_ne_bytes()).collect() };
    // SAFETY: the caller's contract; objects made here, slices of the sizes GL reads or writes.
    unsafe {
        gl.pixel_store_i32(glow::UNPACK_ALIGNMENT, 4);
        let texture = gl.create_texture().map_err(anyhow::Error::msg)?;
        gl.active_texture(glow::TEXTURE0);
        gl.bind_texture(glow::TEXTURE_2D, Some(texture));
        // The stencil format takes its depth packed with a stencil byte (exact integers); the
        // others their values as floats, which GL rounds to the nearest UNORM integer: the
        // uploaded one, within 2^-25 of it.
        let (format, kind, data) = if internal_format == glow::DEPTH24_STENCIL8 {
            let packed: Vec<u32> = (0..texels)
                .map(|i| (texel_value(i, bits) << 8) | (i & 0xFF))
                .collect();
            (glow::DEPTH_STENCIL, glow::UNSIGNED_INT_24_8, bytes(&packed))
        } else {
            let floats: Vec<u32> = references.iter().map(|r| r.to_bits()).collect();
            (glow::DEPTH_COMPONENT, glow::FLOAT, bytes(&floats))
        };
        gl.tex_image_2d(
            glow::TEXTURE_2D,
            0,
            internal_format as i32,
            w,
            h,
            0,
            format,
            kind,
            glow::PixelUnpackData::Slice(Some(&data)),
        );
        let reference = gl.create_texture().map_err(anyhow::Error::msg)?;
        gl.active_texture(glow::TEXTURE3);
        gl.bind_texture(glow::TEXTURE_2D, Some(reference));
        let reference_bytes: Vec<u8> = references.iter().flat_map(|r| r.to_ne_bytes()).collect();
        gl.tex_image_2d(
            glow::TEXTURE_2D,
            0,
            glow::R32F as i32,
            w,
            h,
            0,
            glow::RED,
            glow::FLOAT,
            glow::PixelUnpackData::Slice(Some(&reference_bytes)),
        );
        let mut samplers = Vec::new();
        for compare in [None, Some(glow::LEQUAL), Some(glow::GEQUAL), None] {
            let sampler = gl.create_sampler().map_err(anyhow::Error::msg)?;
            for (name, value) in [
                (glow::TEXTURE_MIN_FILTER, glow::NEAREST),
                (glow::TEXTURE_MAG_FILTER, glow::NEAREST),
                (glow::TEXTURE_WRAP_S, glow::CLAMP_TO_EDGE),
                (glow::TEXTURE_WRAP_T, glow::CLAMP_TO_EDGE),
            ] {
                gl.sampler_parameter_i32(sampler, name, value as i32);
            }
            if let Some(func) = compare {
                gl.sampler_parameter_i32(
                    sampler,
                    glow::TEXTURE_COMPARE_MODE,
                    glow::COMPARE_REF_TO_TEXTURE as i32,
                );
                gl.sampler_parameter_i32(sampler, glow::TEXTURE_COMPARE_FUNC, func as i32);
            }
            samplers.push(sampler);
        }
        for (unit, sampler) in samplers.iter().enumerate() {
            gl.bind_sampler(unit as u32, Some(*sampler));
            if unit < 3 {
                gl.active_texture(glow::TEXTURE0 + unit as u32);
                gl.bind_texture(glow::TEXTURE_2D, Some(texture));
            }
        }
        let program = link_program(gl, POST_VERTEX_SHADER, POST_TEXELS_SHADER)?;
        gl.use_program(Some(program));
        for (unit, name) in ["u_depth", "u_less_equal", "u_greater_equal", "u_reference"]
            .into_iter()
            .enumerate()
        {
            gl.uniform_1_i32(gl.get_uniform_location(program, name).as_ref(), unit as i32);
        }
        let framebuffer = gl.create_framebuffer().map_err(anyhow::Error::msg)?;
        gl.bind_framebuffer(glow::FRAMEBUFFER, Some(framebuffer));
        let target = gl.create_renderbuffer().map_err(anyhow::Error::msg)?;
        gl.bind_renderbuffer(glow::RENDERBUFFER, Some(target));
        gl.renderbuffer_storage(glow::RENDERBUFFER, glow::RGBA32F, w, h);
        gl.framebuffer_renderbuffer(
            glow::FRAMEBUFFER,
            glow::COLOR_ATTACHMENT0,
            glow::RENDERBUFFER,
            Some(target),
        );
        let status = gl.check_framebuffer_status(glow::FRAMEBUFFER);
        ensure!(
            status == glow::FRAMEBUFFER_COMPLETE,
            "RGBA32F framebuffer incomplete (0x{status:x})"
        );
        gl.disable(glow::DEPTH_TEST);
        gl.draw_arrays(glow::TRIANGLES, 0, 3);
        gl.finish();
        let mut read = vec![0u8; texels as usize * 16];
        gl.pixel_store_i32(glow::PACK_ALIGNMENT, 4);
        gl.read_pixels(
            0,
            0,
            w,
            h,
            glow::RGBA,
            glow::FLOAT,
            glow::PixelPackData::Slice(Some(&mut read)),
        );
        let error = gl.get_error();
        for (unit, sampler) in samplers.into_iter().enumerate() {
            gl.bind_sampler(unit as u32, None);
            gl.delete_sampler(sampler);
        }
        gl.active_texture(glow::TEXTURE0);
        gl.delete_renderbuffer(target);
        gl.delete_framebuffer(framebuffer);
        gl.delete_program(program);
        gl.delete_texture(reference);
        gl.delete_texture(texture);
        ensure!(error == glow::NO_ERROR, "GL error 0x{error:x}");
        Ok(read
            .chunks_exact(4)
            .map(|c| f32::from_ne_bytes([c[0], c[1], c[2], c[3]]))
            .collect())
    }
}

/// A post pass: a second framebuffer with an RGBA8 color renderbuffer, the depth texture
/// bound to unit 0, one full-screen triangle of `fragment`, read back (bottom row first).
///
/// # Safety
/// The caller's context is current; `texture` is a depth texture (with `level` where
/// `fragment` reads `u_level`).
unsafe fn post_pass(
    gl: &glow::Context,
    fragment: &str,
    texture: glow::Texture,
    (level, w, h): (i32, i32, i32),
    compute: Option<&ComputeWriter>,
) -> Result<Vec<u8>> {
    let pixels = w as usize * h as usize;
    // SAFETY: the caller's contract; objects made here, slices of the sizes GL writes.
    unsafe {
        let program = link_program(gl, POST_VERTEX_SHADER, fragment)?;
        let (framebuffer, color) = color_target(gl, w, h)?;
        if let Some(compute) = compute {
            compute.dispatch(gl);
        }
        gl.disable(glow::DEPTH_TEST);
        gl.use_program(Some(program));
        gl.active_texture(glow::TEXTURE0);
        gl.bind_texture(glow::TEXTURE_2D, Some(texture));
        gl.uniform_1_i32(gl.get_uniform_location(program, "u_depth").as_ref(), 0);
        if let Some(size) = gl.get_uniform_location(program, "u_size") {
            gl.uniform_2_f32(Some(&size), w as f32, h as f32);
        }
        if let Some(u_level) = gl.get_uniform_location(program, "u_level") {
            gl.uniform_1_i32(Some(&u_level), level);
        }
        gl.draw_arrays(glow::TRIANGLES, 0, 3);
        gl.finish();
        let rgba = read_rgba(gl, w, h, pixels);
        gl.delete_renderbuffer(color);
        gl.delete_framebuffer(framebuffer);
        gl.delete_program(program);
        Ok(rgba)
    }
}

/// A framebuffer with an RGBA8 color renderbuffer of `w` x `h` as its color attachment 0,
/// bound.
///
/// # Safety
/// The caller's context is current.
unsafe fn color_target(
    gl: &glow::Context,
    w: i32,
    h: i32,
) -> Result<(glow::Framebuffer, glow::Renderbuffer)> {
    // SAFETY: the caller's contract; objects made here.
    unsafe {
        let framebuffer = gl.create_framebuffer().map_err(anyhow::Error::msg)?;
        gl.bind_framebuffer(glow::FRAMEBUFFER, Some(framebuffer));
        let color = gl.create_renderbuffer().map_err(anyhow::Error::msg)?;
        gl.bind_renderbuffer(glow::RENDERBUFFER, Some(color));
        gl.renderbuffer_storage(glow::RENDERBUFFER, glow::RGBA8, w, h);
        gl.framebuffer_renderbuffer(
            glow::FRAMEBUFFER,
            glow::COLOR_ATTACHMENT0,
            glow::RENDERBUFFER,
            Some(color),
        );
        Ok((framebuffer, color))
    }
}

/// The bound framebuffer's color, RGBA8, bottom row first (`pixels` = `w` x `h`).
///
/// # Safety
/// The caller's context is current, with a framebuffer of at least `w` x `h` bound.
unsafe fn read_rgba(gl: &glow::Context, w: i32, h: i32, pixels: usize) -> Vec<u8> {
    let mut rgba = vec![0u8; pixels * 4];
    // SAFETY: the caller's contract; the slice holds the w x h RGBA8 pixels GL writes.
    unsafe {
        gl.read_pixels(
            0,
            0,
            w,
            h,
            glow::RGBA,
            glow::UNSIGNED_BYTE,
            glow::PixelPackData::Slice(Some(&mut rgba)),
        );
    }
    rgba
}

/// Compiles `source` as a shader of `kind` (`name` says which in the error).
///
/// # Safety
/// The GL context must be current on this thread.
unsafe fn compile(gl: &glow::Context, kind: u32, source: &str, name: &str) -> Result<glow::Shader> {
    // SAFETY: the caller's context is current.
    unsafe {
        let shader = gl.create_shader(kind).map_err(anyhow::Error::msg)?;
        gl.shader_source(shader, source);
        gl.compile_shader(shader);
        if !gl.get_shader_compile_status(shader) {
            bail!(
                "the {name} shader does not compile: {}",
                gl.get_shader_info_log(shader)
            );
        }
        Ok(shader)
    }
}

/// Links `shaders` into `program` (the position attribute at location 0), releases them, and
/// checks the link (`what` names the program in the error).
///
/// # Safety
/// The GL context must be current on this thread; `shaders` are its, compiled.
unsafe fn link(
    gl: &glow::Context,
    program: glow::Program,
    shaders: &[glow::Shader],
    what: &str,
) -> Result<glow::Program> {
    // SAFETY: the caller's context is current.
    unsafe {
        for &shader in shaders {
            gl.attach_shader(program, shader);
        }
        gl.bind_attrib_location(program, 0, "position");
        gl.link_program(program);
        for &shader in shaders {
            gl.detach_shader(program, shader);
            gl.delete_shader(shader);
        }
        if !gl.get_program_link_status(program) {
            bail!("{what} does not link: {}", gl.get_program_info_log(program));
        }
        Ok(program)
    }
}

/// Compiles `source` as a separable program of one stage (`kind`).
///
/// # Safety
/// The GL context must be current on this thread.
unsafe fn link_separable(
    gl: &glow::Context,
    sso: &super::context::SeparateShaderObjects,
    kind: u32,
    source: &str,
) -> Result<glow::Program> {
    // SAFETY: the caller's context is current.
    unsafe {
        let shader = compile(gl, kind, source, "separable")?;
        let program = gl.create_program().map_err(anyhow::Error::msg)?;
        (sso.program_parameteri)(program.0.get(), glow::PROGRAM_SEPARABLE, 1);
        link(gl, program, &[shader], "a separable program")
    }
}

/// Compiles and links the two shaders.
///
/// # Safety
/// The GL context must be current on this thread.
unsafe fn link_program(gl: &glow::Context, vertex: &str, fragment: &str) -> Result<glow::Program> {
    // SAFETY: the caller's context is current.
    unsafe {
        let program = gl.create_program().map_err(anyhow::Error::msg)?;
        let shaders = [
            compile(gl, glow::VERTEX_SHADER, vertex, "vertex")?,
            compile(gl, glow::FRAGMENT_SHADER, fragment, "fragment")?,
        ];
        link(gl, program, &shaders, "the program")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_gl_projection_is_the_vulkan_one_with_y_negated_and_depth_remapped() {
        // Where the ground truth's Vulkan clip position lands, GL's lands at the same x, -y
        // and the same window depth (z_ndc + 1) / 2 = Vulkan's z_ndc.
        for id in [
            crate::scene::SceneId::SlopedPlane,
            crate::scene::SceneId::PlaneStack,
        ] {
            let scene = id.build();
            let aspect = 4.0 / 3.0;
            for object in &scene.objects {
                let vulkan = scene.mvp_in(crate::scene::View::Camera, object, aspect);
                let [p, v, m] = matrices(&scene, object.space, object.model, aspect).unwrap();
                let gl = p * v * m;
                for q in scene.vertex_positions(object) {
                    let a = vulkan * q.extend(1.0);
                    let b = gl * q.extend(1.0);
                    let (a, b) = (a / a.w, b / b.w);
                    let close = |x: f64, y: f64| (x - y).abs() <= 1e-9 * (1.0 + x.abs());
                    assert!(close(a.x, b.x) && close(a.y, -b.y), "{a} {b}");
                    assert!(close(a.z, (b.z + 1.0) / 2.0), "{a} {b}");
                }
            }
        }
    }

    #[test]
    fn rows_are_turned_top_first() {
        assert_eq!(
            top_row_first(&[1, 2, 3, 4, 5, 6], 2),
            vec![5, 6, 3, 4, 1, 2]
        );
    }
}
