//! SPIR-V for the layer's unit tests: GLSL compiled with naga (as the tester's shaders are,
//! no coordinate-space adjustment) and SPIR-V assembly through spirv-tools.

use spirv_tools::assembler::{self, Assembler as _};
use spirv_tools::TargetEnv;

/// SPIR-V saved as binary (glslang's `.spv` files, `include_bytes!`'d): its little-endian
/// words.
pub fn words(bytes: &[u8]) -> Vec<u32> {
    bytes
        .chunks_exact(4)
        .map(|w| u32::from_le_bytes([w[0], w[1], w[2], w[3]]))
        .collect()
}

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

/// The shaders the chain tests share.
///
/// A fragment shader that writes `FragDepth` from `FragCoord.z`.
pub const FRAG_DEPTH: &str = "#version 450
    layout(location = 0) out vec4 color;
    void main() {
        color = vec4(gl_FragCoord.xy, 0.0, 1.0);
        gl_FragDepth = 0.5 + 0.5 * gl_FragCoord.z;
    }";

/// A fragment shader that does not compute with depth.
pub const PLAIN: &str = "#version 450
    layout(location = 0) out vec4 color;
    void main() { color = vec4(1.0, 0.5, 0.25, 1.0); }";

/// A vertex shader with a constant position.
pub const VERTEX: &str = "#version 450
    void main() { gl_Position = vec4(0.0, 0.0, 0.5, 1.0); }";

/// A fragment shader of `source`.
pub fn fragment(source: &str) -> Vec<u32> {
    compile_glsl(naga::ShaderStage::Fragment, source)
}

/// [`VERTEX`], compiled.
pub fn vertex() -> Vec<u32> {
    compile_glsl(naga::ShaderStage::Vertex, VERTEX)
}

/// `words` rewritten as revz's variants with the carrier baked in have it (complementary
/// depth of the range the stage fits), checked by spirv-val.
pub fn baked(words: &[u32]) -> Vec<u32> {
    let selector = crate::command_state::derived_selector(
        revz_math::Target::Complementary,
        revz_math::DepthConvention::ZeroToOne,
    );
    let code = crate::shader::position_store::derive_position_store_reading(
        words,
        crate::shader::position_store::CarrierRead::Baked(selector),
    )
    .expect("rewritable")
    .expect("stores Position")
    .code;
    validate(&code);
    code
}

/// A fragment shader that stores `FragDepth` and reads it back: the rewrite refuses it.
pub fn refused_fragment() -> Vec<u32> {
    let text = "OpCapability Shader
        OpMemoryModel Logical GLSL450
        OpEntryPoint Fragment %main \"main\" %coord %depth
        OpExecutionMode %main OriginUpperLeft
        OpExecutionMode %main DepthReplacing
        OpDecorate %coord BuiltIn FragCoord
        OpDecorate %depth BuiltIn FragDepth
        %void = OpTypeVoid
        %fn = OpTypeFunction %void
        %float = OpTypeFloat 32
        %v4 = OpTypeVector %float 4
        %half = OpConstant %float 0.5
        %pin_v4 = OpTypePointer Input %v4
        %pout_f = OpTypePointer Output %float
        %coord = OpVariable %pin_v4 Input
        %depth = OpVariable %pout_f Output
        %main = OpFunction %void None %fn
        %entry = OpLabel
        OpStore %depth %half
        %d = OpLoad %float %depth
        %e = OpFMul %float %d %half
        OpStore %depth %e
        OpReturn
        OpFunctionEnd";
    let words = assemble(text);
    assert!(
        crate::shader::fragment_depth::reverse_fragment_depth(&words).is_err(),
        "the rewrite refuses FragDepth read back"
    );
    words
}

/// A fragment shader reading input attachments, in SPIR-V assembly as glslang writes
/// `subpassLoad`: the shared preamble (a `vec4` output `%out`, the types `%float`, `%uint`,
/// `%int`, `%v4`, `%v2i`, the texel `%origin`, the float subpass image `%fimage` and its pointer
/// `%pf`), then `decorations`, `declarations` and `body` as the entry point's only block.
pub fn input_attachment_fragment(decorations: &str, declarations: &str, body: &str) -> Vec<u32> {
    assemble(&format!(
        "OpCapability Shader
        OpCapability InputAttachment
        OpMemoryModel Logical GLSL450
        OpEntryPoint Fragment %main \"main\" %out
        OpExecutionMode %main OriginUpperLeft
        OpDecorate %out Location 0
        {decorations}
        %void = OpTypeVoid
        %fn = OpTypeFunction %void
        %float = OpTypeFloat 32
        %uint = OpTypeInt 32 0
        %int = OpTypeInt 32 1
        %v4 = OpTypeVector %float 4
        %v2i = OpTypeVector %int 2
        %zero = OpConstant %int 0
        %origin = OpConstantComposite %v2i %zero %zero
        %fimage = OpTypeImage %float SubpassData 0 0 0 2 Unknown
        %pf = OpTypePointer UniformConstant %fimage
        {declarations}
        %pout = OpTypePointer Output %v4
        %out = OpVariable %pout Output
        %main = OpFunction %void None %fn
        %entry = OpLabel
        {body}
        OpReturn
        OpFunctionEnd"
    ))
}

/// A deferred lighting shader: `subpassLoad` of a float input attachment at input attachment
/// index 0 (depth, in the tests' render passes) into the color output.
pub fn depth_input_fragment() -> Vec<u32> {
    input_attachment_fragment(
        "OpDecorate %depth InputAttachmentIndex 0
        OpDecorate %depth DescriptorSet 0
        OpDecorate %depth Binding 0",
        "%depth = OpVariable %pf UniformConstant",
        "%d = OpLoad %fimage %depth
        %r = OpImageRead %v4 %d %origin
        OpStore %out %r",
    )
}

/// [`depth_input_fragment`] with its input attachment undecorated: how a shader reads the
/// depth attachment of a dynamic rendering instance under the default mapping
/// (`VK_KHR_dynamic_rendering_local_read`).
pub fn undecorated_depth_input_fragment() -> Vec<u32> {
    input_attachment_fragment(
        "OpDecorate %depth DescriptorSet 0
        OpDecorate %depth Binding 0",
        "%depth = OpVariable %pf UniformConstant",
        "%d = OpLoad %fimage %depth
        %r = OpImageRead %v4 %d %origin
        OpStore %out %r",
    )
}

/// spirv-val accepts `words` (Vulkan 1.1 environment).
pub fn validate(words: &[u32]) {
    use spirv_tools::val::{self, Validator as _};
    val::create(Some(TargetEnv::Vulkan_1_1))
        .validate(words, None)
        .unwrap_or_else(|e| panic!("spirv-val rejects the module: {e}"));
}
