//! Compiles the GLSL shaders in `../shaders` to SPIR-V with naga at build time.
//!
//! Every `*.vert` and `*.frag` file becomes `$OUT_DIR/<name>.<stage>.spv` (SPIR-V 1.0). The
//! coordinate-space adjustment of naga's SPIR-V writer (a y negation of `gl_Position`) is off,
//! so the shaders do exactly what their GLSL says. Any naga error fails the build and names
//! the file.

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
    let words = spv::write_vec(&module, &info, &options, None)
        .map_err(|e| format!("{display}: SPIR-V writer error: {e}"))?;

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
