//! The SPIR-V modules compiled by `build.rs` from `shaders/*.vert|frag` (GLSL 450, naga,
//! SPIR-V 1.0, no y flip), embedded in the binary.

use std::io::Cursor;

use anyhow::{Context, Result};

/// One embedded shader module.
#[derive(Clone, Copy, Debug)]
pub struct ShaderSource {
    /// `<name>.<stage>`, e.g. `scene.vert`.
    pub name: &'static str,
    /// The SPIR-V, as bytes.
    pub bytes: &'static [u8],
}

impl ShaderSource {
    /// The SPIR-V words (checks the magic number and alignment).
    pub fn words(&self) -> Result<Vec<u32>> {
        ash::util::read_spv(&mut Cursor::new(self.bytes))
            .with_context(|| format!("embedded SPIR-V of {} is malformed", self.name))
    }
}

macro_rules! shader {
    ($name:literal) => {
        ShaderSource {
            name: $name,
            bytes: include_bytes!(concat!(env!("OUT_DIR"), "/", $name, ".spv")),
        }
    };
}

/// `scene.vert`: `gl_Position = pc.mvp * vec4(position, 1.0)`.
pub const SCENE_VERT: ShaderSource = shader!("scene.vert");
/// `scene.frag`: writes `pc.color`.
pub const SCENE_FRAG: ShaderSource = shader!("scene.frag");
/// `frag_depth.frag`: writes `pc.color` (the push constants of `scene.vert`) and
/// `gl_FragDepth = 0.5 + 0.5 * gl_FragCoord.z` (`DepthReplacing`): reads the rasterized depth
/// and stores the surface pushed back to (1 + D) / 2.
pub const FRAG_DEPTH_FRAG: ShaderSource = shader!("frag_depth.frag");

/// `shadow_receiver.vert`: `scene.vert` plus the light-space position (a uniform-buffer light
/// MVP indexed by `gl_InstanceIndex`).
pub const SHADOW_RECEIVER_VERT: ShaderSource = shader!("shadow_receiver.vert");
/// `shadow_receiver.frag`: `pc.color` darkened where a comparison sample of the shadow map
/// says the fragment is shadowed.
pub const SHADOW_RECEIVER_FRAG: ShaderSource = shader!("shadow_receiver.frag");
/// `shadow_receiver_raw.frag`: the same darkening from the map's raw depth values (a texel
/// fetch and a gather through a plain sampler, compared in the shader).
pub const SHADOW_RECEIVER_RAW_FRAG: ShaderSource = shader!("shadow_receiver_raw.frag");

/// `row_major.vert`: `gl_Position = pc.mvp * vec4(position, 1.0)` with `mvp` decorated
/// `RowMajor` (its rows consecutive in memory, as HLSL compilers lay matrices out).
pub const ROW_MAJOR_VERT: ShaderSource = shader!("row_major.vert");
/// `row_vector.vert`: `gl_Position = vec4(position, 1.0) * pc.mvp_transposed` (HLSL's
/// `mul(v, M)`): the same bytes as `row_major.vert`, reached by another SPIR-V instruction.
pub const ROW_VECTOR_VERT: ShaderSource = shader!("row_vector.vert");

/// `mvp_pair.vert`: `gl_Position = pc.view_proj * (pc.model * vec4(position, 1.0))`, two
/// push-constant matrices; passes the instance index (the object's index) on.
pub const MVP_PAIR_VERT: ShaderSource = shader!("mvp_pair.vert");
/// `mvp_pair.frag`: the object's color from a uniform buffer of colors.
pub const MVP_PAIR_FRAG: ShaderSource = shader!("mvp_pair.frag");

/// `lit_mvp.vert`: `pos = pc.mvp * vec4(position, 1.0)` (the push constants of `scene.vert`),
/// `gl_Position = pos` and the view vector `-pos.xyz` passed on: the pushed matrix also serves
/// the lighting.
pub const LIT_MVP_VERT: ShaderSource = shader!("lit_mvp.vert");
/// `lit_mvp.frag`: `pc.color` lit by a fixed light (ambient, diffuse, Phong specular), the face
/// normal from the screen-space derivatives of the view vector (`lit_shade` in the scene unit
/// tests is its f64 model).
pub const LIT_MVP_FRAG: ShaderSource = shader!("lit_mvp.frag");

/// `ubo.vert`: `gl_Position = ubo.projection * ubo.view * ubo.model * vec4(position, 1.0)`
/// from one dynamic uniform block per object (P, V and M apart); passes the block's color on.
pub const UBO_VERT: ShaderSource = shader!("ubo.vert");
/// `ubo_dynamic.vert`: `gl_Position = frame.view_proj * object.model * vec4(position, 1.0)`,
/// P * V in a uniform buffer, the model matrix in a dynamic one; passes the object's color on.
pub const UBO_DYNAMIC_VERT: ShaderSource = shader!("ubo_dynamic.vert");
/// `ssbo.vert`: `gl_Position = objects.items[gl_InstanceIndex].mvp * vec4(position, 1.0)` from
/// a read-only storage buffer; passes the item's color on.
pub const SSBO_VERT: ShaderSource = shader!("ssbo.vert");
/// `flat_color.frag`: writes the flat color passed on by the buffer deliveries' vertex shaders.
pub const FLAT_COLOR_FRAG: ShaderSource = shader!("flat_color.frag");

/// A module compiled by glslang (`shaders/glslang/`: naga's GLSL front end reads no
/// tessellation or geometry stage), committed beside its source; `glslang_outputs_are_current`
/// checks them against the source where `glslangValidator` is installed.
macro_rules! glslang_shader {
    ($name:literal) => {
        ShaderSource {
            name: $name,
            bytes: include_bytes!(concat!(
                env!("CARGO_MANIFEST_DIR"),
                "/../shaders/glslang/",
                $name,
                ".spv"
            )),
        }
    };
}

/// `ubo_later.vert` (glslang): hands the object-space position on to the tessellation stages
/// as a varying; writes no `gl_Position`.
pub const UBO_LATER_VERT: ShaderSource = glslang_shader!("ubo_later.vert");
/// `ubo_position.vert` (glslang): `gl_Position = vec4(position, 1.0)`, which the geometry
/// stage projects.
pub const UBO_POSITION_VERT: ShaderSource = glslang_shader!("ubo_position.vert");
/// `ubo.geom` (glslang): the `ubo` delivery's `((P * V) * M) * gl_in[i].gl_Position` in a
/// geometry shader (the vertex stage's position, w = 1), emitting each triangle as it is from
/// a loop over its vertices; passes the color on.
pub const UBO_GEOM: ShaderSource = glslang_shader!("ubo.geom");
/// `passthrough.geom` (glslang): passes each triangle of `ubo.vert`'s projected positions
/// through as it is (`gl_Position = gl_in[i].gl_Position`), with its color.
pub const PASSTHROUGH_GEOM: ShaderSource = glslang_shader!("passthrough.geom");
/// `push.geom` (glslang): `scene.vert`'s push constants, `pc.mvp * gl_in[i].gl_Position` in a
/// geometry shader (the vertex stage's position, w = 1), emitted in a loop.
pub const PUSH_GEOM: ShaderSource = glslang_shader!("push.geom");
/// `passthrough.tesc` (glslang): one patch per triangle, every tessellation level 1.
pub const PASSTHROUGH_TESC: ShaderSource = glslang_shader!("passthrough.tesc");
/// `ubo.tese` (glslang): the `ubo` delivery's product in a tessellation evaluation shader, at
/// the patch's corners; passes the color on.
pub const UBO_TESE: ShaderSource = glslang_shader!("ubo.tese");
/// `position_passthrough.tesc` (glslang): after `ubo.vert`, one patch per triangle, the clip
/// positions and colors copied as they are, every tessellation level 1.
pub const POSITION_PASSTHROUGH_TESC: ShaderSource = glslang_shader!("position_passthrough.tesc");
/// `interpolating.tese` (glslang): the patch's clip positions interpolated at the patch point
/// with its barycentric coordinates (at level 1 a corner exactly).
pub const INTERPOLATING_TESE: ShaderSource = glslang_shader!("interpolating.tese");
/// `corner_positions.tesc` (glslang): after `ubo_position.vert`, one patch per triangle, the
/// object-space positions copied as they are, every tessellation level 1.
pub const CORNER_POSITIONS_TESC: ShaderSource = glslang_shader!("corner_positions.tesc");
/// `corner_interpolating.tese` (glslang): after `corner_positions.tesc`, the patch's
/// object-space positions interpolated at the patch point (w = 1 kept), for `ubo.geom` to
/// project.
pub const CORNER_INTERPOLATING_TESE: ShaderSource = glslang_shader!("corner_interpolating.tese");
/// `projecting.tese` (glslang): the patch's positions interpolated at the patch point,
/// displaced along y by a term 0 at the corners, and projected with the `ubo` block.
pub const PROJECTING_TESE: ShaderSource = glslang_shader!("projecting.tese");

/// `ssbo_rows.vert` (glslang): the `ssbo` delivery's matrix stored as its rows and applied as
/// four dot products, `vec4(dot(r0, p), dot(r1, p), dot(r2, p), dot(r3, p))`; passes the
/// color on.
pub const SSBO_ROWS_VERT: ShaderSource = glslang_shader!("ssbo_rows.vert");

/// `ssbo_registers.vert` (glslang): `ssbo_rows.vert`'s rows applied as D3D bytecode
/// translators write it: a private output register written one component at a time by four
/// dot products in a function the entry point calls, then copied into `gl_Position`.
pub const SSBO_REGISTERS_VERT: ShaderSource = glslang_shader!("ssbo_registers.vert");

/// `ssbo_columns.vert` (glslang): `ssbo.vert`'s buffer applied as fxc's `mul(v, M)` and D3D
/// bytecode translators write it: a register reassigned by a multiply and three
/// multiply-adds of the matrix's columns by splats of the input.
pub const SSBO_COLUMNS_VERT: ShaderSource = glslang_shader!("ssbo_columns.vert");

/// A module written as SPIR-V assembly (`shaders/spvasm/`: a translator's shape, not a
/// compiler's), committed assembled beside its source; `spvasm_outputs_are_current` checks
/// them against the source where `spirv-as` is installed.
macro_rules! spvasm_shader {
    ($name:literal) => {
        ShaderSource {
            name: $name,
            bytes: include_bytes!(concat!(
                env!("CARGO_MANIFEST_DIR"),
                "/../shaders/spvasm/",
                $name,
                ".spv"
            )),
        }
    };
}

/// `ssbo_vkd3d.vert.spvasm`: `ssbo.vert`'s buffer applied in the shape Wine's vkd3d-shader
/// writes a translated D3D vertex shader: registers written a component at a time and then
/// whole by multiply-adds of the columns by splats of two registers, the output register
/// copied into `Position` with `OpCopyMemory`; passes the color on.
pub const SSBO_VKD3D_VERT: ShaderSource = spvasm_shader!("ssbo_vkd3d.vert");

/// `depth_input_undecorated.frag.spvasm`: `depth_input.frag` as glslang compiles it, less its
/// `InputAttachmentIndex` decoration (GLSL cannot leave it out): the input attachment that
/// dynamic rendering local read's default mapping gives the depth attachment (no
/// `VkRenderingInputAttachmentIndexInfo` in the pipeline), shaded as `depth_input.frag` shades.
pub const DEPTH_INPUT_UNDECORATED_FRAG: ShaderSource =
    spvasm_shader!("depth_input_undecorated.frag");

/// `mesh.mesh` (glslang, SPIR-V 1.5 for Vulkan 1.2: `VK_EXT_mesh_shader`): `scene.vert`'s push
/// constants and product in a mesh shader, each workgroup 32 triangles of the draw fetched
/// from the scene's index and position arrays in storage buffers (the `mesh` delivery).
pub const MESH_MESH: ShaderSource = glslang_shader!("mesh.mesh");

/// `split_mvp.vert` (glslang): `scene.vert` with only the matrix in its push constants
/// (bytes 0..64, the vertex stage's own range).
pub const SPLIT_MVP_VERT: ShaderSource = glslang_shader!("split_mvp.vert");
/// `split_color.frag` (glslang): `scene.frag` reading the color at bytes 64..80 (the fragment
/// stage's own range).
pub const SPLIT_COLOR_FRAG: ShaderSource = glslang_shader!("split_color.frag");

/// `soft_particle.vert`: `scene.vert`, with the clip position kept in a local, stored and its
/// w (the view distance) handed on.
pub const SOFT_PARTICLE_VERT: ShaderSource = shader!("soft_particle.vert");
/// `soft_particle.frag`: `pc.color` faded where the scene's depth (a texel fetch of the main
/// depth image, attached read-only) lies close behind the particle.
pub const SOFT_PARTICLE_FRAG: ShaderSource = shader!("soft_particle.frag");
/// `depth_post.frag` (glslang, for `textureGather`): the bottom quarter of the image shaded by
/// the main depth's view distance, read with a texel fetch, a bilinear sample and a gather.
pub const DEPTH_POST_FRAG: ShaderSource = glslang_shader!("depth_post.frag");

/// `depth_tiles.comp` (glslang: `tester/build.rs` compiles no compute stage): each 4 x 4
/// tile's nearest and farthest depth of the main depth image, into a storage buffer.
pub const DEPTH_TILES_COMP: ShaderSource = glslang_shader!("depth_tiles.comp");
/// `depth_tiles_post.frag` (glslang: its storage buffer is a `BufferBlock` in the Uniform
/// class, which Vulkan 1.0 takes without `VK_KHR_storage_buffer_storage_class`): the top
/// quarter of the image shaded from those tiles.
pub const DEPTH_TILES_POST_FRAG: ShaderSource = glslang_shader!("depth_tiles_post.frag");

/// `depth_input.frag` (glslang): the fragments drawn shaded by the main depth's view distance,
/// read as an input attachment (`subpassLoad`) in the subpass after the one that wrote it.
pub const DEPTH_INPUT_FRAG: ShaderSource = glslang_shader!("depth_input.frag");

/// `depth_mips_post.frag` (glslang: naga's GLSL front end lacks
/// `GL_EXT_samplerless_texture_functions`): the bottom quarter of the image shaded by the view
/// distance of mip level 1 of the main depth, the top quarter by that of level 2.
pub const DEPTH_MIPS_POST_FRAG: ShaderSource = glslang_shader!("depth_mips_post.frag");
/// `depth_layers_post.frag` (glslang): the bottom quarter of the image shaded by the view
/// distance of array layer 0 of the main depth, the quarter above it by that of layer 1
/// (a `texture2DArray`).
pub const DEPTH_LAYERS_POST_FRAG: ShaderSource = glslang_shader!("depth_layers_post.frag");
/// `depth_post_ms.frag` (glslang): the bottom 45% of the image shaded by the view
/// distances of the nearest and farthest of each pixel's samples of a multisampled depth image
/// (texel fetches of each sample of a `texture2DMS`).
pub const DEPTH_POST_MS_FRAG: ShaderSource = glslang_shader!("depth_post_ms.frag");

/// `multiview.vert` (glslang: naga's GLSL front end has no `GL_EXT_multiview`): `gl_Position =
/// views.view_projection[gl_ViewIndex] * pc.model * vec4(position, 1.0)`, the views'
/// view-projections in a uniform buffer indexed by the view, the model matrix pushed (and the
/// color after it, which `scene.frag` reads).
pub const MULTIVIEW_VERT: ShaderSource = glslang_shader!("multiview.vert");

/// `stencil_post.frag`: a band across the middle of the image shaded by the main depth-stencil
/// image's stencil value and depth (texel fetches of each aspect).
pub const STENCIL_POST_FRAG: ShaderSource = shader!("stencil_post.frag");

/// Every embedded module.
#[cfg(test)]
pub const ALL: &[ShaderSource] = &[
    SCENE_VERT,
    SCENE_FRAG,
    FRAG_DEPTH_FRAG,
    SHADOW_RECEIVER_VERT,
    SHADOW_RECEIVER_FRAG,
    SHADOW_RECEIVER_RAW_FRAG,
    ROW_MAJOR_VERT,
    ROW_VECTOR_VERT,
    MVP_PAIR_VERT,
    MVP_PAIR_FRAG,
    LIT_MVP_VERT,
    LIT_MVP_FRAG,
    UBO_VERT,
    UBO_DYNAMIC_VERT,
    SSBO_VERT,
    FLAT_COLOR_FRAG,
    UBO_LATER_VERT,
    UBO_POSITION_VERT,
    UBO_GEOM,
    PASSTHROUGH_GEOM,
    PUSH_GEOM,
    PASSTHROUGH_TESC,
    UBO_TESE,
    POSITION_PASSTHROUGH_TESC,
    INTERPOLATING_TESE,
    CORNER_POSITIONS_TESC,
    CORNER_INTERPOLATING_TESE,
    PROJECTING_TESE,
    SSBO_ROWS_VERT,
    SSBO_REGISTERS_VERT,
    SSBO_COLUMNS_VERT,
    MESH_MESH,
    SPLIT_MVP_VERT,
    SPLIT_COLOR_FRAG,
    SOFT_PARTICLE_VERT,
    SOFT_PARTICLE_FRAG,
    DEPTH_POST_FRAG,
    DEPTH_TILES_COMP,
    DEPTH_TILES_POST_FRAG,
    DEPTH_INPUT_FRAG,
    DEPTH_MIPS_POST_FRAG,
    DEPTH_LAYERS_POST_FRAG,
    DEPTH_POST_MS_FRAG,
    MULTIVIEW_VERT,
    STENCIL_POST_FRAG,
];

/// The glslang modules: (source file under `shaders/glslang/`, module).
#[cfg(test)]
pub const GLSLANG: &[(&str, ShaderSource)] = &[
    ("ubo_later.vert", UBO_LATER_VERT),
    ("ubo_position.vert", UBO_POSITION_VERT),
    ("ubo.geom", UBO_GEOM),
    ("passthrough.geom", PASSTHROUGH_GEOM),
    ("push.geom", PUSH_GEOM),
    ("passthrough.tesc", PASSTHROUGH_TESC),
    ("ubo.tese", UBO_TESE),
    ("position_passthrough.tesc", POSITION_PASSTHROUGH_TESC),
    ("interpolating.tese", INTERPOLATING_TESE),
    ("corner_positions.tesc", CORNER_POSITIONS_TESC),
    ("corner_interpolating.tese", CORNER_INTERPOLATING_TESE),
    ("projecting.tese", PROJECTING_TESE),
    ("ssbo_rows.vert", SSBO_ROWS_VERT),
    ("ssbo_registers.vert", SSBO_REGISTERS_VERT),
    ("ssbo_columns.vert", SSBO_COLUMNS_VERT),
    ("mesh.mesh", MESH_MESH),
    ("split_mvp.vert", SPLIT_MVP_VERT),
    ("split_color.frag", SPLIT_COLOR_FRAG),
    ("depth_post.frag", DEPTH_POST_FRAG),
    ("depth_tiles.comp", DEPTH_TILES_COMP),
    ("depth_tiles_post.frag", DEPTH_TILES_POST_FRAG),
    ("depth_input.frag", DEPTH_INPUT_FRAG),
    ("depth_mips_post.frag", DEPTH_MIPS_POST_FRAG),
    ("depth_layers_post.frag", DEPTH_LAYERS_POST_FRAG),
    ("depth_post_ms.frag", DEPTH_POST_MS_FRAG),
    ("multiview.vert", MULTIVIEW_VERT),
];

#[cfg(test)]
mod tests {
    use super::*;
    use spirv_tools::val::{self, Validator as _};
    use spirv_tools::TargetEnv;

    #[test]
    fn every_module_passes_spirv_val() {
        let validator = val::create(Some(TargetEnv::Vulkan_1_1));
        // Mesh shaders need SPIR-V 1.4 (Vulkan 1.2 on).
        let validator_1_2 = val::create(Some(TargetEnv::Vulkan_1_2));
        let mut failures = Vec::new();
        for shader in ALL {
            let words = shader.words().expect("readable SPIR-V");
            let validator = match target_env(shader.name) {
                "vulkan1.2" => &validator_1_2,
                _ => &validator,
            };
            if let Err(error) = validator.validate(&words, None) {
                failures.push(format!("{}: {error}", shader.name));
            }
        }
        assert!(
            failures.is_empty(),
            "spirv-val failed:\n{}",
            failures.join("\n")
        );
    }

    /// The committed glslang outputs are what the committed sources compile to (the command
    /// in `shaders/glslang/README.md`). `glslangValidator` comes with `cargo xtask setup`
    /// (`glslang-tools`); where it is missing the test says so and checks nothing else.
    #[test]
    fn glslang_outputs_are_current() {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../shaders/glslang");
        let scratch = std::env::temp_dir().join(format!("revz-glslang-{}", std::process::id()));
        std::fs::create_dir_all(&scratch).unwrap();
        for (source, module) in GLSLANG {
            let out = scratch.join(format!("{source}.spv"));
            let run = std::process::Command::new("glslangValidator")
                .args(["-V", "--target-env", target_env(source), "-o"])
                .arg(&out)
                .arg(dir.join(source))
                .output();
            let Ok(run) = run else {
                eprintln!("glslangValidator is not installed: cannot recompile {source}");
                continue;
            };
            assert!(
                run.status.success(),
                "{source}: {}",
                String::from_utf8_lossy(&run.stdout)
            );
            let compiled = std::fs::read(&out).unwrap();
            assert!(
                compiled == module.bytes,
                "shaders/glslang/{source}.spv is not what {source} compiles to: rerun the \
                 command in shaders/glslang/README.md"
            );
        }
        std::fs::remove_dir_all(&scratch).ok();
    }

    /// The modules written as SPIR-V assembly (`shaders/spvasm/`), committed assembled.
    const SPVASM: [(&str, ShaderSource); 2] = [
        ("ssbo_vkd3d.vert.spvasm", SSBO_VKD3D_VERT),
        (
            "depth_input_undecorated.frag.spvasm",
            DEPTH_INPUT_UNDECORATED_FRAG,
        ),
    ];

    #[test]
    fn spvasm_outputs_are_current() {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../shaders/spvasm");
        let scratch = std::env::temp_dir().join(format!("revz-spvasm-{}", std::process::id()));
        std::fs::create_dir_all(&scratch).unwrap();
        for (source, module) in SPVASM {
            let out = scratch.join(format!("{source}.spv"));
            let run = std::process::Command::new("spirv-as")
                .args(["--target-env", "vulkan1.0", "-o"])
                .arg(&out)
                .arg(dir.join(source))
                .output();
            let Ok(run) = run else {
                eprintln!("spirv-as is not installed: cannot reassemble {source}");
                continue;
            };
            assert!(
                run.status.success(),
                "{source}: {}",
                String::from_utf8_lossy(&run.stderr)
            );
            let assembled = std::fs::read(&out).unwrap();
            assert!(
                assembled == module.bytes,
                "shaders/spvasm/{}.spv is not what {source} assembles to: rerun the command in \
                 shaders/spvasm/README.md",
                source.trim_end_matches(".spvasm")
            );
            // And it is valid for Vulkan 1.0.
            let valid = std::process::Command::new("spirv-val")
                .args(["--target-env", "vulkan1.0"])
                .arg(&out)
                .status()
                .unwrap();
            assert!(valid.success(), "{source} does not validate");
        }
        std::fs::remove_dir_all(&scratch).ok();
    }

    /// The `--target-env` a glslang source compiles for: Vulkan 1.0, and 1.2 for mesh shaders
    /// (`shaders/glslang/README.md`).
    fn target_env(source: &str) -> &'static str {
        if source.ends_with(".mesh") {
            "vulkan1.2"
        } else {
            "vulkan1.0"
        }
    }

    #[test]
    fn the_validator_rejects_a_broken_module() {
        // The SPIR-V header with a zero id bound and no instructions: invalid. Guards against a
        // validator that silently accepts everything.
        let broken = [0x0723_0203u32, 0x0001_0000, 0, 0, 0];
        let validator = val::create(Some(TargetEnv::Vulkan_1_1));
        assert!(validator.validate(broken, None).is_err());
    }

    /// The (struct id, member, decoration) of every `OpMemberDecorate` without literals.
    fn member_decorations(words: &[u32]) -> Vec<(u32, u32, u32)> {
        let mut at = 5;
        let mut out = Vec::new();
        while at < words.len() {
            let count = (words[at] >> 16) as usize;
            assert!(count > 0);
            if words[at] & 0xffff == 72 && count == 4 {
                out.push((words[at + 1], words[at + 2], words[at + 3]));
            }
            at += count;
        }
        out
    }

    #[test]
    fn the_row_major_matrix_is_decorated_row_major() {
        const ROW_MAJOR: u32 = 4;
        const COL_MAJOR: u32 = 5;
        let decorations = member_decorations(&ROW_MAJOR_VERT.words().unwrap());
        // Exactly one matrix member, member 0, and it is RowMajor.
        let layouts: Vec<_> = decorations
            .iter()
            .filter(|d| d.2 == ROW_MAJOR || d.2 == COL_MAJOR)
            .collect();
        assert_eq!(layouts.len(), 1, "{decorations:?}");
        assert_eq!((layouts[0].1, layouts[0].2), (0, ROW_MAJOR));
        // The other shaders keep naga's ColMajor.
        for shader in [SCENE_VERT, ROW_VECTOR_VERT, MVP_PAIR_VERT, LIT_MVP_VERT] {
            let decorations = member_decorations(&shader.words().unwrap());
            assert!(
                decorations.iter().all(|d| d.2 != ROW_MAJOR),
                "{}: {decorations:?}",
                shader.name
            );
        }
    }

    /// Every instruction of a module as (opcode, operands).
    fn instructions(words: &[u32]) -> Vec<(u32, &[u32])> {
        let mut at = 5;
        let mut out = Vec::new();
        while at < words.len() {
            let count = (words[at] >> 16) as usize;
            assert!(count > 0);
            out.push((words[at] & 0xffff, &words[at + 1..at + count]));
            at += count;
        }
        out
    }

    #[test]
    fn only_the_frag_depth_shader_writes_and_reads_depth_and_the_depth_readers_their_fragment() {
        const OP_EXECUTION_MODE: u32 = 16;
        const OP_DECORATE: u32 = 71;
        const DEPTH_REPLACING: u32 = 12;
        const BUILT_IN: u32 = 11;
        const FRAG_COORD: u32 = 15;
        const FRAG_DEPTH: u32 = 22;
        for shader in ALL {
            let words = shader.words().unwrap();
            let instructions = instructions(&words);
            let has = |opcode: u32, tail: &[u32]| {
                instructions
                    .iter()
                    .any(|(op, operands)| *op == opcode && operands.ends_with(tail))
            };
            let frag_depth = shader.name == FRAG_DEPTH_FRAG.name;
            // Writing FragDepth needs the DepthReplacing execution mode.
            assert_eq!(
                has(OP_DECORATE, &[BUILT_IN, FRAG_DEPTH]),
                frag_depth,
                "{}",
                shader.name
            );
            assert_eq!(
                has(OP_EXECUTION_MODE, &[DEPTH_REPLACING]),
                frag_depth,
                "{}",
                shader.name
            );
            // The depth readers use `gl_FragCoord.xy` to find their texel (never its z).
            let reads_depth_image = [
                SOFT_PARTICLE_FRAG.name,
                DEPTH_POST_FRAG.name,
                DEPTH_TILES_POST_FRAG.name,
                STENCIL_POST_FRAG.name,
                DEPTH_POST_MS_FRAG.name,
                DEPTH_MIPS_POST_FRAG.name,
                DEPTH_LAYERS_POST_FRAG.name,
            ]
            .contains(&shader.name);
            assert_eq!(
                has(OP_DECORATE, &[BUILT_IN, FRAG_COORD]),
                frag_depth || reads_depth_image,
                "{}",
                shader.name
            );
        }
    }

    #[test]
    fn the_buffer_deliveries_declare_no_push_constants() {
        const OP_VARIABLE: u32 = 59;
        const PUSH_CONSTANT: u32 = 9;
        const UNIFORM: u32 = 2;
        const STORAGE_BUFFER: u32 = 12;
        // (module, its buffer variables' storage class, how many)
        for (shader, class, count) in [
            (UBO_VERT, UNIFORM, 1),
            (UBO_DYNAMIC_VERT, UNIFORM, 2),
            (SSBO_VERT, STORAGE_BUFFER, 1),
            (FLAT_COLOR_FRAG, UNIFORM, 0),
            (UBO_LATER_VERT, UNIFORM, 0),
            (UBO_POSITION_VERT, UNIFORM, 0),
            (UBO_GEOM, UNIFORM, 1),
            (PASSTHROUGH_GEOM, UNIFORM, 0),
            (PASSTHROUGH_TESC, UNIFORM, 0),
            (POSITION_PASSTHROUGH_TESC, UNIFORM, 0),
            (INTERPOLATING_TESE, UNIFORM, 0),
            (CORNER_POSITIONS_TESC, UNIFORM, 0),
            (CORNER_INTERPOLATING_TESE, UNIFORM, 0),
            (PROJECTING_TESE, UNIFORM, 1),
            (UBO_TESE, UNIFORM, 1),
            // glslang for Vulkan 1.0 (SPIR-V 1.0): a `BufferBlock` in the Uniform class.
            (SSBO_ROWS_VERT, UNIFORM, 1),
            (SSBO_REGISTERS_VERT, UNIFORM, 1),
            (SSBO_COLUMNS_VERT, UNIFORM, 1),
        ] {
            let words = shader.words().unwrap();
            let classes: Vec<u32> = instructions(&words)
                .iter()
                .filter(|(op, _)| *op == OP_VARIABLE)
                .map(|(_, operands)| operands[2])
                .collect();
            assert!(!classes.contains(&PUSH_CONSTANT), "{}", shader.name);
            assert_eq!(
                classes.iter().filter(|&&c| c == class).count(),
                count,
                "{}: {classes:?}",
                shader.name
            );
        }
        // The scene shader does use them (the check sees them).
        let words = SCENE_VERT.words().unwrap();
        assert!(instructions(&words)
            .iter()
            .any(|(op, operands)| *op == OP_VARIABLE && operands[2] == PUSH_CONSTANT));
    }

    #[test]
    fn every_shader_source_is_embedded() {
        let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../shaders");
        let mut sources: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .filter(|n| n.ends_with(".vert") || n.ends_with(".frag"))
            .collect();
        sources.sort();
        let glslang: Vec<&str> = GLSLANG.iter().map(|(_, s)| s.name).collect();
        let mut embedded: Vec<&str> = ALL
            .iter()
            .map(|s| s.name)
            .filter(|name| !glslang.contains(name))
            .collect();
        embedded.sort();
        assert_eq!(sources, embedded);
        // And every glslang source, under its own directory.
        let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../shaders/glslang");
        let mut sources: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .filter(|n| !n.ends_with(".spv") && !n.ends_with(".md"))
            .collect();
        sources.sort();
        let mut glslang: Vec<&str> = GLSLANG.iter().map(|(source, _)| *source).collect();
        glslang.sort();
        assert_eq!(sources, glslang);
    }
}
