//! Which push-constant bytes hold the projection a vertex-stage shader applies to `Position`.
//!
//! `shared/DESIGN.md` section 2 ("Shader analysis"): the precise path rewrites a projection
//! in `vkCmdPushConstants`, so it must know exactly which bytes of the push-constant block the
//! shader multiplies into `Position`. Only the OUTERMOST matrix of the multiplication chain is
//! a candidate (an orthographic projection and a model matrix cannot be told apart by value, so
//! inner matrices are never rewritten).
//!
//! The analysis runs in two steps:
//! 1. [`has_push_constants`]: a linear scan of the words for an `OpVariable` in the
//!    `PushConstant` storage class. Modules without one (most of them) never reach naga.
//! 2. [`analyze`]: naga's `spv-in` front end builds the IR, and the data flow into the
//!    entry point's `Position` output is followed backwards: through the entry-point wrapper
//!    naga generates (which returns a struct built from `Private` globals), through stores to
//!    private and local variables, through function calls and arguments, down a chain of
//!    `Multiply` expressions to the outermost matrix. When that matrix is a `Load` of a member
//!    (possibly nested in structs or arrays) of the push-constant global, its byte range is the
//!    [`ProjectionSlot`].
//!
//! # Convention of [`ProjectionSlot`]
//! The slot describes the matrix `M` *as the shader uses it*: `clip = M * v` (column-vector
//! convention), whatever the source language wrote:
//! - `M * v` (GLSL) with a column-major member: `row_major = false`;
//! - a member decorated `RowMajor` (naga loads it as `transpose(stored)`): `row_major = true`;
//! - `v * X` (HLSL `mul(v, X)` style, vector on the left) is `clip = transpose(X) * v`, so `M`
//!   is `X` transposed: the storage order is reported flipped, as is an explicit `transpose()`.
//!
//! So with `row_major == false`, element `M[row][col]` is at
//! `offset + col * matrix_stride + row * 4`; with `row_major == true` it is at
//! `offset + row * matrix_stride + col * 4` (for 32-bit floats). `columns` and `rows` are
//! those of `M` (a projection is 4 x 4).
//!
//! naga's IR drops the `RowMajor` and `MatrixStride` member decorations (it loads a `RowMajor`
//! member through a pointer as `transpose(Load)`, but not when the whole block is loaded as one
//! value), so both are read straight from the words for the member the IR path designates; the
//! byte offset comes from naga's struct member offsets. naga's `spv-in` rejects any stride but
//! the natural one, which is also the fallback.
//!
//! # Limitations
//! - The chain must be made of `Multiply`s only. `M * v + offset`, a matrix scaled by a scalar,
//!   a matrix built from columns, or a dynamically indexed array of matrices are not followed
//!   (the answer is [`Analysis::NotFromPushConstants`]).
//! - A variable stored more than once counts only when every store leads to the same slot.
//! - The `Position` output is found through the entry point's result (naga has no output
//!   globals); with several push-constant variables in a module they are matched to naga's
//!   globals by order.
//! - naga cannot parse every module (e.g. Slang's `DrawParameters` capability): such modules
//!   are [`Analysis::Unreadable`] and take the flip path.
//!
//! # Files
//! - `layout.rs`: what is read straight from the words, without naga: the push-constant
//!   pre-filter and the member decorations naga's IR drops;
//! - `walker.rs`: the backwards walk through naga's IR from `Position` to the matrix.

mod layout;
mod walker;

use std::panic::{catch_unwind, AssertUnwindSafe};

use naga::{Module, ShaderStage};

use layout::{scan_push_constants, SpirvLayout};
use walker::analyze_module;

/// Where the projection sits in the push-constant block (see the module docs for the
/// convention).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct ProjectionSlot {
    /// Byte offset of the matrix from the start of the push-constant block.
    pub offset: u32,
    /// Bytes between consecutive columns (`row_major == false`) or rows (`row_major == true`)
    /// of `M`.
    pub matrix_stride: u32,
    /// Whether the rows of `M` (as used in `clip = M * v`) are contiguous in memory.
    pub row_major: bool,
    /// Columns of `M`.
    pub columns: u8,
    /// Rows of `M`.
    pub rows: u8,
}

/// What the analysis found for one entry point.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Analysis {
    /// The module declares no push-constant variable (found without parsing it).
    NoPushConstants,
    /// The outermost matrix applied to `Position` is this push-constant member.
    Projection(ProjectionSlot),
    /// `Position` does not come from a push-constant matrix (uniform buffer, no matrix, a
    /// data flow the analysis does not follow, or no such entry point).
    NotFromPushConstants,
    /// naga could not read the module (or panicked on it): the message says why.
    Unreadable(String),
}

/// Whether the module declares a variable in the `PushConstant` storage class. A linear scan of
/// the words; a module that is not SPIR-V (bad magic, truncated instruction) answers `false`
/// without reading past the end.
pub fn has_push_constants(words: &[u32]) -> bool {
    scan_push_constants(words).unwrap_or(false)
}

/// Finds which push-constant member is the outermost matrix of the multiplication chain that
/// produces the `Position` output of `entry_point` (a vertex-stage module, or the last
/// pre-rasterization stage). Never panics.
pub fn analyze(words: &[u32], entry_point: &str, stage: ShaderStage) -> Analysis {
    match scan_push_constants(words) {
        Ok(true) => {}
        Ok(false) => return Analysis::NoPushConstants,
        Err(message) => return Analysis::Unreadable(message),
    }
    let module = match parse(words) {
        Ok(module) => module,
        Err(message) => return Analysis::Unreadable(message),
    };
    match catch_unwind(AssertUnwindSafe(|| {
        let layout = SpirvLayout::scan(words);
        analyze_module(&module, &layout, entry_point, stage)
    })) {
        Ok(analysis) => analysis,
        Err(_) => Analysis::Unreadable("the analysis panicked on naga's IR".to_owned()),
    }
}

/// [`analyze`] for every vertex entry point of a module, parsing it once (at shader module
/// creation, when the pipeline that will name an entry point is not known yet). A module
/// without push constants answers an empty list without being parsed; `Err` says why naga
/// could not read it. Never panics.
pub fn analyze_vertex_entry_points(words: &[u32]) -> Result<Vec<(String, Analysis)>, String> {
    if !scan_push_constants(words)? {
        return Ok(Vec::new());
    }
    let stripped = crate::shader::scan::for_analysis(words);
    let words = stripped.as_deref().unwrap_or(words);
    let module = parse(words)?;
    catch_unwind(AssertUnwindSafe(|| {
        let layout = SpirvLayout::scan(words);
        module
            .entry_points
            .iter()
            .filter(|ep| ep.stage == ShaderStage::Vertex)
            .map(|ep| {
                let analysis = analyze_module(&module, &layout, &ep.name, ShaderStage::Vertex);
                (ep.name.clone(), analysis)
            })
            .collect()
    }))
    .map_err(|_| "the analysis panicked on naga's IR".to_owned())
}

/// Parses the module with naga's `spv-in`, turning errors and panics into a message.
fn parse(words: &[u32]) -> Result<Module, String> {
    let options = naga::front::spv::Options {
        // Keep `Position` as the module writes it: no y flip inserted into the wrapper.
        adjust_coordinate_space: false,
        strict_capabilities: false,
        block_ctx_dump_prefix: None,
    };
    let parsed = catch_unwind(AssertUnwindSafe(|| {
        naga::front::spv::Frontend::new(words.iter().copied(), &options).parse()
    }));
    match parsed {
        Ok(Ok(module)) => Ok(module),
        Ok(Err(error)) => Err(format!("naga spv-in: {error}")),
        Err(payload) => {
            let detail = payload
                .downcast_ref::<&str>()
                .map(|s| (*s).to_owned())
                .or_else(|| payload.downcast_ref::<String>().cloned())
                .unwrap_or_default();
            Err(format!("naga spv-in panicked: {detail}"))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shader::scan::op::OP_VARIABLE;
    use crate::shader::scan::{HEADER_WORDS, MAGIC};

    /// Compiles a GLSL vertex shader to SPIR-V with naga (no coordinate-space adjustment).
    fn compile(source: &str) -> Vec<u32> {
        crate::shader::test_spirv::compile_glsl(ShaderStage::Vertex, source)
    }

    fn analyze_glsl(source: &str) -> Analysis {
        analyze(&compile(source), "main", ShaderStage::Vertex)
    }

    fn column_major_mat4(offset: u32) -> Analysis {
        Analysis::Projection(ProjectionSlot {
            offset,
            matrix_stride: 16,
            row_major: false,
            columns: 4,
            rows: 4,
        })
    }

    /// A module whose matrix members are all decorated `RowMajor` instead of `ColMajor` (naga's
    /// GLSL front end has no `layout(row_major)`; the SPIR-V is patched instead).
    fn make_row_major(mut words: Vec<u32>) -> Vec<u32> {
        const OP_MEMBER_DECORATE: u32 = 72;
        const ROW_MAJOR: u32 = 4;
        const COL_MAJOR: u32 = 5;
        let mut at = HEADER_WORDS;
        let mut patched = 0;
        while at < words.len() {
            let count = (words[at] >> 16) as usize;
            if words[at] & 0xffff == OP_MEMBER_DECORATE && count == 4 && words[at + 3] == COL_MAJOR
            {
                words[at + 3] = ROW_MAJOR;
                patched += 1;
            }
            at += count;
        }
        assert!(patched > 0, "no ColMajor decoration to patch");
        words
    }

    const HEADER: &str = "#version 450\nlayout(location = 0) in vec3 position;\n";

    fn shader(declarations: &str, body: &str) -> String {
        format!("{HEADER}{declarations}\nvoid main() {{\n    vec4 pos = vec4(position, 1.0);\n    {body}\n}}\n")
    }

    #[test]
    fn scene_vert_mvp_at_offset_0() {
        // Case 1, both as written in the brief and as the scene's real shader.
        let inline = shader(
            "layout(push_constant) uniform PC { mat4 mvp; vec4 color; } pc;",
            "gl_Position = pc.mvp * vec4(position, 1.0);",
        );
        assert_eq!(analyze_glsl(&inline), column_major_mat4(0));
        let scene = include_str!("../../../../shaders/scene.vert");
        assert_eq!(analyze_glsl(scene), column_major_mat4(0));
    }

    #[test]
    fn member_after_another_member() {
        let source = shader(
            "layout(push_constant) uniform PC { mat4 model; mat4 mvp; } pc;",
            "gl_Position = pc.mvp * pos;",
        );
        assert_eq!(analyze_glsl(&source), column_major_mat4(64));
        let source = shader(
            "layout(push_constant) uniform PC { vec4 tint; mat4 mvp; } pc;",
            "gl_Position = pc.mvp * pos;",
        );
        assert_eq!(analyze_glsl(&source), column_major_mat4(16));
    }

    #[test]
    fn nested_struct_member() {
        let source = shader(
            "struct Camera { vec4 eye; mat4 view_proj; };\n\
             layout(push_constant) uniform PC { mat4 model; Camera camera; } pc;",
            "gl_Position = pc.camera.view_proj * pc.model * pos;",
        );
        assert_eq!(analyze_glsl(&source), column_major_mat4(80));
    }

    #[test]
    fn outermost_of_a_chain() {
        let declarations =
            "layout(push_constant) uniform PC { mat4 model; mat4 view; mat4 proj; } pc;";
        for body in [
            "gl_Position = pc.proj * (pc.view * pos);",
            "gl_Position = pc.proj * pc.view * pos;",
            "gl_Position = pc.proj * pc.view * pc.model * pos;",
            "gl_Position = pc.proj * (pc.view * (pc.model * pos));",
            "gl_Position = (pc.proj * pc.view) * (pc.model * pos);",
        ] {
            assert_eq!(
                analyze_glsl(&shader(declarations, body)),
                column_major_mat4(128),
                "{body}"
            );
        }
    }

    #[test]
    fn through_locals_and_function_calls() {
        let declarations = "layout(push_constant) uniform PC { mat4 view; mat4 proj; } pc;\n\
             vec4 apply(mat4 m, vec4 p) { return m * p; }\n\
             mat4 combined() { return pc.proj * pc.view; }";
        for body in [
            "mat4 m = pc.proj * pc.view; gl_Position = m * pos;",
            "vec4 clip = pc.proj * (pc.view * pos); gl_Position = clip;",
            "gl_Position = apply(pc.proj, pc.view * pos);",
            "gl_Position = combined() * pos;",
        ] {
            assert_eq!(
                analyze_glsl(&shader(declarations, body)),
                column_major_mat4(64),
                "{body}"
            );
        }
    }

    #[test]
    fn row_major_member() {
        let source = shader(
            "layout(push_constant) uniform PC { vec4 color; mat4 mvp; } pc;",
            "gl_Position = pc.mvp * pos;",
        );
        let words = make_row_major(compile(&source));
        let expected = ProjectionSlot {
            offset: 16,
            matrix_stride: 16,
            row_major: true,
            columns: 4,
            rows: 4,
        };
        assert_eq!(
            analyze(&words, "main", ShaderStage::Vertex),
            Analysis::Projection(expected)
        );
    }

    #[test]
    fn vector_on_the_left_is_the_transposed_use() {
        let declarations = "layout(push_constant) uniform PC { mat4 a; mat4 b; } pc;";
        let transposed = |offset| {
            Analysis::Projection(ProjectionSlot {
                offset,
                matrix_stride: 16,
                row_major: true,
                columns: 4,
                rows: 4,
            })
        };
        // `v * B` = `B^T * v`; `v * A * B` = `(A B)^T v` = `B^T A^T v`: B is outermost.
        for (body, offset) in [
            ("gl_Position = pos * pc.b;", 64),
            ("gl_Position = pos * pc.a * pc.b;", 64),
            ("gl_Position = pos * (pc.a * pc.b);", 64),
            ("gl_Position = transpose(pc.a) * pos;", 0),
        ] {
            assert_eq!(
                analyze_glsl(&shader(declarations, body)),
                transposed(offset),
                "{body}"
            );
        }
        // HLSL style on a row-major member: two flips, the matrix is used as stored.
        let words = make_row_major(compile(&shader(declarations, "gl_Position = pos * pc.b;")));
        assert_eq!(
            analyze(&words, "main", ShaderStage::Vertex),
            column_major_mat4(64)
        );
    }

    #[test]
    fn projection_from_a_uniform_buffer_is_not_from_push_constants() {
        let declarations = "layout(set = 0, binding = 0) uniform Camera { mat4 proj; } camera;\n\
             layout(push_constant) uniform PC { mat4 model; } pc;";
        for body in [
            "gl_Position = camera.proj * pc.model * pos;",
            "gl_Position = camera.proj * pos;",
            "gl_Position = pos;",
            "gl_Position = 2.0 * pc.model * pos;",
            "gl_Position = pc.model * pos + vec4(1.0);",
        ] {
            assert_eq!(
                analyze_glsl(&shader(declarations, body)),
                Analysis::NotFromPushConstants,
                "{body}"
            );
        }
    }

    #[test]
    fn unknown_entry_point_or_stage() {
        let words = compile(include_str!("../../../../shaders/scene.vert"));
        assert_eq!(
            analyze(&words, "other", ShaderStage::Vertex),
            Analysis::NotFromPushConstants
        );
        assert_eq!(
            analyze(&words, "main", ShaderStage::Fragment),
            Analysis::NotFromPushConstants
        );
    }

    #[test]
    fn no_push_constants_skips_naga() {
        let source = "#version 450\n\
             layout(set = 0, binding = 0) uniform Camera { mat4 proj; } camera;\n\
             layout(location = 0) in vec3 position;\n\
             void main() { gl_Position = camera.proj * vec4(position, 1.0); }\n";
        let words = compile(source);
        assert!(!has_push_constants(&words));
        assert_eq!(
            analyze(&words, "main", ShaderStage::Vertex),
            Analysis::NoPushConstants
        );
        assert!(has_push_constants(&compile(include_str!(
            "../../../../shaders/scene.vert"
        ))));
        // Well-formed words naga would reject (an unknown opcode): the pre-filter answers
        // without parsing.
        let bogus = [MAGIC, 0x0001_0000, 0, 10, 0, (2 << 16) | 0xfff0, 7];
        assert!(!has_push_constants(&bogus));
        assert_eq!(
            analyze(&bogus, "main", ShaderStage::Vertex),
            Analysis::NoPushConstants
        );
        // An OpVariable in another storage class is not a push-constant block.
        let uniform = [
            MAGIC,
            0x0001_0000,
            0,
            10,
            0,
            (4 << 16) | OP_VARIABLE,
            1,
            2,
            2,
        ];
        assert!(!has_push_constants(&uniform));
        let push = [
            MAGIC,
            0x0001_0000,
            0,
            10,
            0,
            (4 << 16) | OP_VARIABLE,
            1,
            2,
            9,
        ];
        assert!(has_push_constants(&push));
    }

    #[test]
    fn unreadable_modules_never_panic() {
        let is_unreadable = |a: &Analysis| matches!(a, Analysis::Unreadable(_));
        assert!(is_unreadable(&analyze(&[], "main", ShaderStage::Vertex)));
        assert!(is_unreadable(&analyze(
            &[1, 2, 3, 4, 5, 6],
            "main",
            ShaderStage::Vertex
        )));
        // A push-constant variable followed by garbage.
        let garbage = [
            MAGIC,
            0x0001_0000,
            0,
            10,
            0,
            (4 << 16) | OP_VARIABLE,
            1,
            2,
            9,
            0xdead_beef,
        ];
        assert!(is_unreadable(&analyze(
            &garbage,
            "main",
            ShaderStage::Vertex
        )));
        // Every truncation of a real module: cut inside an instruction it is unreadable; cut
        // between two, naga may read a module without the function bodies (then `Position`
        // comes from nowhere), but never finds a projection.
        let words = compile(include_str!("../../../../shaders/scene.vert"));
        for len in 0..words.len() {
            let analysis = analyze(&words[..len], "main", ShaderStage::Vertex);
            assert!(
                !matches!(analysis, Analysis::Projection(_)),
                "{len}: {analysis:?}"
            );
        }
        let mut boundaries = vec![];
        let mut at = HEADER_WORDS;
        while at < words.len() {
            boundaries.push(at);
            at += (words[at] >> 16) as usize;
        }
        let cut = boundaries[boundaries.len() / 2] + 1;
        assert!(is_unreadable(&analyze(
            &words[..cut],
            "main",
            ShaderStage::Vertex
        )));
        // Random corruption: any answer is fine, as long as there is one.
        let mut state = 0x9e37_79b9_7f4a_7c15_u64;
        for _ in 0..300 {
            let mut corrupted = words.clone();
            for _ in 0..3 {
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                let at = HEADER_WORDS + (state as usize) % (words.len() - HEADER_WORDS);
                corrupted[at] ^= 1 << ((state >> 32) % 32);
            }
            let _ = analyze(&corrupted, "main", ShaderStage::Vertex);
        }
    }

    /// A string operand: UTF-8, NUL-terminated, padded to whole words.
    fn string_words(text: &str) -> Vec<u32> {
        let mut bytes = text.as_bytes().to_vec();
        bytes.resize((bytes.len() / 4 + 1) * 4, 0);
        bytes
            .chunks_exact(4)
            .map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect()
    }

    #[test]
    fn what_naga_rejects_but_the_analysis_does_not_need_is_removed_first() {
        // The scene shader with a Slang/DXC-style preamble naga refuses: a capability it does
        // not list, an extension it does not know, and a non-semantic instruction set.
        let mut words = compile(include_str!("../../../../shaders/scene.vert"));
        let bound = words[3];
        words[3] = bound + 1;
        let mut preamble = vec![(2 << 16) | 17, 4427]; // OpCapability DrawParameters
        let extension = string_words("SPV_KHR_shader_draw_parameters");
        preamble.push(((extension.len() as u32 + 1) << 16) | 10);
        preamble.extend(extension);
        let set = string_words("NonSemantic.DebugPrintf");
        preamble.push(((set.len() as u32 + 2) << 16) | 11);
        preamble.push(bound);
        preamble.extend(set);
        words.splice(HEADER_WORDS..HEADER_WORDS, preamble);

        assert!(parse(&words).is_err(), "naga alone rejects the module");
        let entries = analyze_vertex_entry_points(&words).expect("readable once stripped");
        assert_eq!(entries, vec![("main".to_owned(), column_major_mat4(0))]);
        // Stripping keeps a module naga already reads as it is.
        let plain = compile(include_str!("../../../../shaders/scene.vert"));
        let stripped = crate::shader::scan::for_analysis(&plain);
        assert!(stripped.is_none_or(|words| parse(&words).is_ok()));
    }
}
