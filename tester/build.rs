//! Compiles the GLSL shaders in `../shaders` to SPIR-V with naga at build time.
//!
//! Every `*.vert` and `*.frag` file becomes `$OUT_DIR/<name>.<stage>.spv` (SPIR-V 1.0). The
//! coordinate-space adjustment of naga's SPIR-V writer (a y negation of `gl_Position`) is off,
//! so the shaders do exactly what their GLSL says. Any naga error fails the build and names
//! the file.
//!
//! One thing naga cannot express: a `RowMajor` matrix (its IR has no matrix layouts, and its
//! GLSL front end rejects `layout(row_major)`). A source line
//! `// revz-build: RowMajor <Struct>.<member>` asks for it: the `ColMajor` decoration naga
//! writes on that member of that struct becomes `RowMajor` (the same one-word instruction, so
//! nothing else moves). The member's memory then holds the matrix's rows, which is what HLSL
//! compilers emit; the shader's arithmetic is unchanged.

use std::path::{Path, PathBuf};
use std::{env, fs};

use naga::back::spv;
use naga::front::glsl;
use naga::valid::{Capabilities, ValidationFlags, Validator};

fn main() {
    let manifest_dir =
        PathBuf::from(env::var_os("CARGO_MANIFEST_DIR").expect("CARGO_MANIFEST_DIR"));
    let out_dir = PathBuf::from(env::var_os("OUT_DIR").expect("OUT_DIR"));
    let shader_dir = manifest_dir.join("..").join("shaders");
    let shader_dir = shader_dir.canonicalize().unwrap_or(shader_dir);
    println!("cargo:rerun-if-changed={}", shader_dir.display());

    let mut sources: Vec<PathBuf> = fs::read_dir(&shader_dir)
        .unwrap_or_else(|e| panic!("cannot read shader directory {}: {e}", shader_dir.display()))
        .map(|entry| entry.expect("shader directory entry").path())
        .filter(|path| stage_of(path).is_some())
        .collect();
    sources.sort();
    if sources.is_empty() {
        panic!("no *.vert or *.frag shaders in {}", shader_dir.display());
    }

    let mut failures = Vec::new();
    for path in &sources {
        println!("cargo:rerun-if-changed={}", path.display());
        if let Err(message) = compile(path, &out_dir) {
            failures.push(message);
        }
    }
    if !failures.is_empty() {
        // Cargo shows a failed build script's stderr: the file names and naga's diagnostics.
        for message in &failures {
            eprintln!("{message}");
        }
        eprintln!("{} shader(s) failed to compile", failures.len());
        std::process::exit(1);
    }
}

/// The naga stage and the file-name stage suffix of a shader source path, if it is one.
fn stage_of(path: &Path) -> Option<(naga::ShaderStage, &'static str)> {
    match path.extension()?.to_str()? {
        "vert" => Some((naga::ShaderStage::Vertex, "vert")),
        "frag" => Some((naga::ShaderStage::Fragment, "frag")),
        _ => None,
    }
}

/// Compiles one GLSL file to `<out_dir>/<name>.<stage>.spv`; the error names the file and
/// carries naga's diagnostic.
fn compile(path: &Path, out_dir: &Path) -> Result<(), String> {
    let (stage, suffix) = stage_of(path).expect("filtered on extension");
    let display = path.display().to_string();
    let source = fs::read_to_string(path).map_err(|e| format!("{display}: cannot read: {e}"))?;

    let module = glsl::Frontend::default()
        .parse(&glsl::Options::from(stage), &source)
        .map_err(|e| {
            format!(
                "{display}: GLSL parse error:\n{}",
                e.emit_to_string_with_path(&source, &display)
            )
        })?;

    let info = Validator::new(ValidationFlags::all(), Capabilities::IMMEDIATES)
        .validate(&module)
        .map_err(|e| {
            format!(
                "{display}: validation error:\n{}",
                e.emit_to_string_with_path(&source, &display)
            )
        })?;

    let options = spv::Options {
        lang_version: (1, 0),
        // No ADJUST_COORDINATE_SPACE: gl_Position is written exactly as the GLSL computes it.
        // DEBUG only adds OpName labels (handy with spirv-dis), LABEL_VARYINGS names the
        // interface variables; neither changes what the shader computes.
        flags: spv::WriterFlags::DEBUG | spv::WriterFlags::LABEL_VARYINGS,
        debug_info: None,
        ..spv::Options::default()
    };
    let mut words = spv::write_vec(&module, &info, &options, None)
        .map_err(|e| format!("{display}: SPIR-V writer error: {e}"))?;
    for line in source.lines() {
        if let Some(target) = line.trim().strip_prefix(ROW_MAJOR_DIRECTIVE) {
            let (structure, member) = target
                .trim()
                .split_once('.')
                .ok_or_else(|| format!("{display}: '{line}': expected <Struct>.<member>"))?;
            make_row_major(&mut words, structure, member)
                .map_err(|e| format!("{display}: '{line}': {e}"))?;
        }
    }

    let stem = path
        .file_stem()
        .and_then(|s| s.to_str())
        .ok_or_else(|| format!("{display}: file name is not UTF-8"))?;
    let out_path = out_dir.join(format!("{stem}.{suffix}.spv"));
    let bytes: Vec<u8> = words.iter().flat_map(|w| w.to_le_bytes()).collect();
    fs::write(&out_path, bytes)
        .map_err(|e| format!("{}: cannot write: {e}", out_path.display()))?;
    Ok(())
}

/// The source directive that makes a matrix member `RowMajor`.
const ROW_MAJOR_DIRECTIVE: &str = "// revz-build: RowMajor ";

/// SPIR-V opcodes and decorations used by [`make_row_major`].
const OP_NAME: u32 = 5;
const OP_MEMBER_NAME: u32 = 6;
const OP_MEMBER_DECORATE: u32 = 72;
const DECORATION_ROW_MAJOR: u32 = 4;
const DECORATION_COL_MAJOR: u32 = 5;

/// The literal string starting at `words[0]` (nul-terminated UTF-8, packed little-endian).
fn literal_string(words: &[u32]) -> String {
    let bytes: Vec<u8> = words
        .iter()
        .flat_map(|w| w.to_le_bytes())
        .take_while(|&b| b != 0)
        .collect();
    String::from_utf8_lossy(&bytes).into_owned()
}

/// One instruction of a module.
struct Instruction<'a> {
    /// Its first word's index in the module.
    at: usize,
    opcode: u32,
    operands: &'a [u32],
}

/// The instructions of a module, after the 5-word header.
fn instructions(words: &[u32]) -> Result<Vec<Instruction<'_>>, String> {
    let mut at = 5;
    let mut out = Vec::new();
    while at < words.len() {
        let count = (words[at] >> 16) as usize;
        if count == 0 || at + count > words.len() {
            return Err(format!("malformed instruction at word {at}"));
        }
        out.push(Instruction {
            at,
            opcode: words[at] & 0xffff,
            operands: &words[at + 1..at + count],
        });
        at += count;
    }
    Ok(out)
}

/// Changes the `ColMajor` decoration of `structure.member` (found through the debug names
/// naga writes) to `RowMajor`.
fn make_row_major(words: &mut [u32], structure: &str, member: &str) -> Result<(), String> {
    let decoration_at = {
        let instructions = instructions(words)?;
        let struct_id = instructions
            .iter()
            .find(|i| {
                i.opcode == OP_NAME
                    && i.operands.len() > 1
                    && literal_string(&i.operands[1..]) == structure
            })
            .map(|i| i.operands[0])
            .ok_or_else(|| format!("no struct named {structure}"))?;
        let member_index = instructions
            .iter()
            .find(|i| {
                i.opcode == OP_MEMBER_NAME
                    && i.operands.len() > 2
                    && i.operands[0] == struct_id
                    && literal_string(&i.operands[2..]) == member
            })
            .map(|i| i.operands[1])
            .ok_or_else(|| format!("{structure} has no member named {member}"))?;
        instructions
            .iter()
            .find(|i| {
                i.opcode == OP_MEMBER_DECORATE
                    && i.operands == [struct_id, member_index, DECORATION_COL_MAJOR]
            })
            // The decoration operand: after the opcode word, the struct id and the member.
            .map(|i| i.at + 3)
            .ok_or_else(|| {
                format!("{structure}.{member} has no ColMajor decoration (not a matrix?)")
            })?
    };
    words[decoration_at] = DECORATION_ROW_MAJOR;
    Ok(())
}
