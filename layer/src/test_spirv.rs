//! SPIR-V for the layer's unit tests: GLSL compiled with naga (as the tester's shaders are,
//! no coordinate-space adjustment) and SPIR-V assembly through spirv-tools.

use spirv_tools::assembler::{self, Assembler as _};
use spirv_tools::TargetEnv;

/// Compiles GLSL of `stage` with naga's front end and SPIR-V back end.
pub fn compile_glsl(stage: naga::ShaderStage, source: &str) -> Vec<u32> {
    let mut frontend = naga::front::glsl::Frontend::default();
    let module = frontend
        .parse(&naga::front::glsl::Options::from(stage), source)
        .unwrap_or_else(|e| panic!("GLSL: {e:?}"));
    let info = naga::valid::Validator::new(
        naga::valid::ValidationFlags::all(),
        naga::valid::Capabilities::all(),
    )
    .validate(&module)
    .unwrap_or_else(|e| panic!("validation: {e:?}"));
    let options = naga::back::spv::Options {
        flags: naga::back::spv::WriterFlags::empty(),
        ..Default::default()
    };
    naga::back::spv::write_vec(&module, &info, &options, None).expect("spv-out")
}

/// Assembles SPIR-V text (Vulkan 1.1 environment).
pub fn assemble(text: &str) -> Vec<u32> {
    assembler::create(Some(TargetEnv::Vulkan_1_1))
        .assemble(text, assembler::AssemblerOptions::default())
        .unwrap_or_else(|e| panic!("assembly: {e}\n{text}"))
        .as_words()
        .to_vec()
}
