//! The `Position` rewrite on the shapes compilers emit (naga: a `BuiltIn Position` variable;
//! glslang: a `gl_PerVertex` block), each result checked by spirv-val and read back by naga,
//! and the refusals.

use spirv_tools::val::{self, Validator as _};
use spirv_tools::TargetEnv;

use super::*;
use crate::shader::scan::instructions;
use crate::shader::test_spirv::{assemble, compile_glsl, validate};

const OFFSET: u32 = 112;

/// `scene.vert`'s shape, plus a view vector computed from the same `Position` value.
const LIT: &str = "#version 450
    layout(push_constant) uniform PushConstants { mat4 mvp; vec4 color; } pc;
    layout(location = 0) in vec3 position;
    layout(location = 0) out vec3 view_vec;
    void main() {
        vec4 pos = pc.mvp * vec4(position, 1.0);
        gl_Position = pos;
        view_vec = -pos.xyz;
    }";

fn rewritten(words: &[u32]) -> Vec<u32> {
    let out = rewrite_position_store(words, OFFSET)
        .expect("rewritable")
        .expect("has a Position");
    validate(&out);
    out
}

/// The instructions of `words` with `opcode`, as (opcode, operands) copies.
fn with_opcode(words: &[u32], opcode: u32) -> Vec<Vec<u32>> {
    instructions(words)
        .expect("SPIR-V")
        .map_while(Result::ok)
        .filter(|i| i.opcode == opcode)
        .map(|i| i.operands.to_vec())
        .collect()
}

/// The rewritten module's carrier: the member decorated at [`OFFSET`], and its block has it as
/// its last member.
fn assert_carrier(out: &[u32]) {
    let offsets: Vec<_> = with_opcode(out, OP_MEMBER_DECORATE)
        .into_iter()
        .filter(|d| d[2] == DECORATION_OFFSET && d[3] == OFFSET)
        .collect();
    assert_eq!(offsets.len(), 1, "one member at the carrier offset");
    let (block, member) = (offsets[0][0], offsets[0][1]);
    let structs = with_opcode(out, OP_TYPE_STRUCT);
    let members = structs.iter().find(|s| s[0] == block).expect("the block");
    assert_eq!(
        members.len() - 2,
        member as usize,
        "the carrier is the last member"
    );
}

#[test]
fn a_position_variable_becomes_private_and_a_new_output_takes_its_place() {
    let words = compile_glsl(naga::ShaderStage::Vertex, LIT);
    validate(&words);
    let out = rewritten(&words);
    assert_carrier(&out);
    let built_ins: Vec<_> = with_opcode(&out, OP_DECORATE)
        .into_iter()
        .filter(|d| d[1..] == [DECORATION_BUILT_IN, BUILT_IN_POSITION])
        .collect();
    assert_eq!(built_ins.len(), 1);
    let variables = with_opcode(&out, OP_VARIABLE);
    let output = variables
        .iter()
        .find(|v| v[1] == built_ins[0][0])
        .expect("the new output");
    assert_eq!(output[2], STORAGE_OUTPUT);
    let privates =
        |variables: &[Vec<u32>]| variables.iter().filter(|v| v[2] == STORAGE_PRIVATE).count();
    assert_eq!(
        privates(&variables),
        privates(&with_opcode(&words, OP_VARIABLE)) + 1,
        "the shadow"
    );
    // One epilogue per return: a store to the new output.
    let stores = with_opcode(&out, OP_STORE);
    assert!(stores.iter().any(|s| s[0] == output[1]));
    // naga reads it back, with the push-constant block one member longer.
    let module = naga::front::spv::parse_u8_slice(
        bytemuck_words(&out).as_slice(),
        &naga::front::spv::Options::default(),
    )
    .expect("naga reads the rewrite");
    let pc = module
        .global_variables
        .iter()
        .find(|(_, g)| g.space == naga::AddressSpace::Immediate)
        .expect("push constants");
    let naga::TypeInner::Struct { members, span } = &module.types[pc.1.ty].inner else {
        panic!("a struct");
    };
    // naga wraps the application's block in a struct: revz's member follows it.
    assert_eq!(members.last().map(|m| m.offset), Some(OFFSET));
    assert!(*span >= OFFSET + 16);
}

fn bytemuck_words(words: &[u32]) -> Vec<u8> {
    words.iter().flat_map(|w| w.to_le_bytes()).collect()
}

/// glslang's shape: `gl_PerVertex` with `Position` as member 0, a component store after the
/// whole one (`gl_Position.y = -gl_Position.y`), `invariant`, and a helper function.
const PER_VERTEX: &str = "OpCapability Shader
    OpMemoryModel Logical GLSL450
    OpEntryPoint Vertex %main \"main\" %_ %position
    OpMemberDecorate %gl_PerVertex 0 BuiltIn Position
    OpMemberDecorate %gl_PerVertex 1 BuiltIn PointSize
    OpMemberDecorate %gl_PerVertex 0 Invariant
    OpDecorate %gl_PerVertex Block
    OpMemberDecorate %PC 0 ColMajor
    OpMemberDecorate %PC 0 Offset 0
    OpMemberDecorate %PC 0 MatrixStride 16
    OpMemberDecorate %PC 1 Offset 64
    OpDecorate %PC Block
    OpDecorate %position Location 0
    %void = OpTypeVoid
    %fn = OpTypeFunction %void
    %float = OpTypeFloat 32
    %v4 = OpTypeVector %float 4
    %v3 = OpTypeVector %float 3
    %mat4 = OpTypeMatrix %v4 4
    %int = OpTypeInt 32 1
    %uint = OpTypeInt 32 0
    %int_0 = OpConstant %int 0
    %uint_1 = OpConstant %uint 1
    %one = OpConstant %float 1
    %gl_PerVertex = OpTypeStruct %v4 %float
    %p_out_pv = OpTypePointer Output %gl_PerVertex
    %_ = OpVariable %p_out_pv Output
    %PC = OpTypeStruct %mat4 %v4
    %p_pc = OpTypePointer PushConstant %PC
    %pc = OpVariable %p_pc PushConstant
    %p_pc_mat4 = OpTypePointer PushConstant %mat4
    %p_in_v3 = OpTypePointer Input %v3
    %position = OpVariable %p_in_v3 Input
    %p_out_v4 = OpTypePointer Output %v4
    %p_out_f = OpTypePointer Output %float
    %main = OpFunction %void None %fn
    %entry = OpLabel
    %mp = OpAccessChain %p_pc_mat4 %pc %int_0
    %m = OpLoad %mat4 %mp
    %p = OpLoad %v3 %position
    %p4 = OpCompositeConstruct %v4 %p %one
    %clip = OpMatrixTimesVector %v4 %m %p4
    %gp = OpAccessChain %p_out_v4 %_ %int_0
    OpStore %gp %clip
    %yp = OpAccessChain %p_out_f %_ %int_0 %uint_1
    %y = OpLoad %float %yp
    %ny = OpFNegate %float %y
    OpStore %yp %ny
    OpReturn
    OpFunctionEnd";

#[test]
fn a_per_vertex_member_is_redirected_to_a_shadow_with_component_stores_kept() {
    let words = assemble(PER_VERTEX);
    validate(&words);
    let out = rewritten(&words);
    assert_carrier(&out);
    // The component chain now starts at the shadow, typed private.
    let chains = with_opcode(&out, OP_ACCESS_CHAIN);
    let privates: Vec<_> = with_opcode(&out, OP_VARIABLE)
        .into_iter()
        .filter(|v| v[2] == STORAGE_PRIVATE)
        .collect();
    assert_eq!(privates.len(), 1);
    let shadow = privates[0][1];
    assert!(chains.iter().any(|c| c[2] == shadow && c.len() == 4));
    assert!(!with_opcode(&out, OP_COPY_OBJECT).is_empty());
}

#[test]
fn a_module_without_push_constants_gets_revz_block() {
    let words = compile_glsl(
        naga::ShaderStage::Vertex,
        "#version 450
        layout(location = 0) in vec3 position;
        void main() { gl_Position = vec4(position, 1.0); }",
    );
    let out = rewritten(&words);
    assert_carrier(&out);
}

#[test]
fn spirv_1_4_interfaces_list_the_shadow_and_the_carrier() {
    let validate_1_4 = |words: &[u32]| {
        val::create(Some(TargetEnv::Vulkan_1_2))
            .validate(words, None)
            .unwrap_or_else(|e| panic!("spirv-val rejects the 1.4 module: {e}"));
    };
    // From 1.4 the push constants are in the interface too.
    let per_vertex = PER_VERTEX.replace("%_ %position", "%_ %position %pc");
    for text in [invariant(), per_vertex] {
        let mut words = assemble(&text);
        words[1] = VERSION_1_4;
        validate_1_4(&words);
        let out = rewrite_position_store(&words, OFFSET)
            .expect("rewritable")
            .expect("has a Position");
        validate_1_4(&out);
    }
}

/// A vertex module whose entry point stores the constant `%c` (a vec4 of 0.5) into a
/// `BuiltIn Position` variable `%pos`: `annotations` after its decoration, `declarations`
/// after the float, vec4 and constant types.
fn position_module(annotations: &str, declarations: &str) -> String {
    format!(
        "OpCapability Shader
        OpMemoryModel Logical GLSL450
        OpEntryPoint Vertex %main \"main\" %pos
        OpDecorate %pos BuiltIn Position
        {annotations}
        %void = OpTypeVoid
        %fn = OpTypeFunction %void
        %float = OpTypeFloat 32
        %v4 = OpTypeVector %float 4
        %half = OpConstant %float 0.5
        %c = OpConstantComposite %v4 %half %half %half %half
        {declarations}
        %p_out_v4 = OpTypePointer Output %v4
        %pos = OpVariable %p_out_v4 Output
        %main = OpFunction %void None %fn
        %entry = OpLabel
        OpStore %pos %c
        OpReturn
        OpFunctionEnd"
    )
}

/// A `Position` variable decorated `Invariant`, without push constants.
fn invariant() -> String {
    position_module("OpDecorate %pos Invariant", "")
}

#[test]
fn invariant_moves_to_the_new_output() {
    let out = rewritten(&assemble(&invariant()));
    let decorations = with_opcode(&out, OP_DECORATE);
    let built_in = decorations
        .iter()
        .find(|d| d[1..] == [DECORATION_BUILT_IN, BUILT_IN_POSITION])
        .expect("BuiltIn Position")[0];
    assert!(
        decorations.iter().any(|d| d[..] == [built_in, 18]),
        "Invariant"
    );
}

#[test]
fn what_the_rewrite_does_not_recognise_is_refused() {
    let refused = |text: &str, why: &'static str| {
        let words = assemble(text);
        validate(&words);
        assert_eq!(
            rewrite_position_store(&words, OFFSET),
            Err(Unsupported(why)),
            "{text}"
        );
    };
    // Two push-constant blocks (each entry point may use one).
    refused(
        &position_module(
            "OpMemberDecorate %PC 0 Offset 0
            OpDecorate %PC Block",
            "%PC = OpTypeStruct %v4
            %p_pc = OpTypePointer PushConstant %PC
            %pc1 = OpVariable %p_pc PushConstant
            %pc2 = OpVariable %p_pc PushConstant",
        ),
        "more than one push-constant block",
    );
    // A push-constant block whose members reach the carrier's bytes.
    refused(
        "OpCapability Shader
        OpMemoryModel Logical GLSL450
        OpEntryPoint Vertex %main \"main\" %pos
        OpDecorate %pos BuiltIn Position
        OpMemberDecorate %PC 0 Offset 0
        OpMemberDecorate %PC 1 Offset 112
        OpDecorate %PC Block
        %void = OpTypeVoid
        %fn = OpTypeFunction %void
        %float = OpTypeFloat 32
        %v4 = OpTypeVector %float 4
        %int = OpTypeInt 32 1
        %int_1 = OpConstant %int 1
        %PC = OpTypeStruct %v4 %v4
        %p_pc = OpTypePointer PushConstant %PC
        %pc = OpVariable %p_pc PushConstant
        %p_pc_v4 = OpTypePointer PushConstant %v4
        %p_out_v4 = OpTypePointer Output %v4
        %pos = OpVariable %p_out_v4 Output
        %main = OpFunction %void None %fn
        %entry = OpLabel
        %cp = OpAccessChain %p_pc_v4 %pc %int_1
        %c = OpLoad %v4 %cp
        OpStore %pos %c
        OpReturn
        OpFunctionEnd",
        "the push-constant block reaches revz's carrier bytes",
    );
    // The whole gl_PerVertex block stored at once.
    refused(
        &PER_VERTEX.replace(
            "%gp = OpAccessChain %p_out_v4 %_ %int_0
    OpStore %gp %clip",
            "%block = OpCompositeConstruct %gl_PerVertex %clip %one
    OpStore %_ %block",
        ),
        "Position is used other than by loads, stores and access chains",
    );
    assert_eq!(
        rewrite_position_store(&assemble(PER_VERTEX), 100),
        Err(Unsupported("the carrier offset is not 16-byte aligned"))
    );
}

#[test]
fn modules_without_position_or_not_spirv_are_left_alone() {
    assert_eq!(rewrite_position_store(&[], OFFSET), Ok(None));
    assert_eq!(
        rewrite_position_store(&[1, 2, 3, 4, 5, 6], OFFSET),
        Ok(None)
    );
    let fragment = crate::shader::test_spirv::fragment(crate::shader::test_spirv::PLAIN);
    assert!(
        rewrite_position_store(&fragment, OFFSET).is_err(),
        "a fragment entry point"
    );
}

// ---------------------------------------------------------------------------------------------
// The derived range (`crate::shader::derived_range`): projections the CPU cannot read.

fn derived(words: &[u32]) -> (Vec<u32>, MatrixSource) {
    let (out, source) = rewrite_position_store_deriving(words, OFFSET)
        .expect("rewritable")
        .expect("has a Position");
    validate(&out);
    // naga reads it back: the fit is ordinary SPIR-V.
    naga::front::spv::Frontend::new(out.iter().copied(), &Default::default())
        .parse()
        .expect("naga reads the rewritten module");
    (out, source)
}

/// `ubo.projection * ubo.view * ubo.model * p` from a dynamic uniform buffer block.
const UBO_PVM: &str = "#version 450
    layout(set = 0, binding = 0) uniform Object { mat4 projection; mat4 view; mat4 model; vec4 color; } ubo;
    layout(location = 0) in vec3 position;
    layout(location = 0) out vec4 color;
    void main() {
        gl_Position = ubo.projection * ubo.view * ubo.model * vec4(position, 1.0);
        color = ubo.color;
    }";

/// An offset whose w is 0 added to the position the projection multiplies (a displacement
/// along the normal in view space, as glmark2's `terrain` does): its w stays 1.
#[test]
fn an_offset_of_w_zero_keeps_the_projected_vector_s_w() {
    let displaced = |w: &str| {
        format!(
            "#version 450
    layout(set = 0, binding = 0) uniform Object {{ mat4 projection; mat4 view; float d; }} ubo;
    layout(location = 0) in vec3 position;
    layout(location = 1) in vec3 normal;
    void main() {{
        vec4 p = ubo.view * vec4(position, 1.0);
        gl_Position = ubo.projection * (vec4(normal * ubo.d, {w}) + p);
    }}"
        )
    };
    let words = compile_glsl(naga::ShaderStage::Vertex, &displaced("0.0"));
    let (_, source) = derived(&words);
    assert_eq!(source, MatrixSource::UniformBuffer);
    // A w of 0.5 added: the vector's w is 1.5.
    let words = compile_glsl(naga::ShaderStage::Vertex, &displaced("0.5"));
    assert_eq!(
        derive_position_store(&words, OFFSET).map(|r| r.map(|r| r.source)),
        Err(Unsupported(
            "the vector the projection multiplies may not have w = 1"
        ))
    );
}

#[test]
fn a_uniform_buffer_projection_is_fitted_from_its_outermost_factor() {
    let words = compile_glsl(naga::ShaderStage::Vertex, UBO_PVM);
    let (out, source) = derived(&words);
    assert_eq!(source, MatrixSource::UniformBuffer);
    // The fit is decorated NoContraction and stores into a private vec4 the returns read.
    let no_contraction = with_opcode(&out, OP_DECORATE)
        .into_iter()
        .filter(|d| d.get(1) == Some(&42))
        .count();
    assert!(
        no_contraction >= 30,
        "{no_contraction} NoContraction decorations"
    );
    // The leaf is the projection: the fit's extractions read member 0 of the loaded block
    // (naga loads the block, extracts P, V and M, and evaluates (P * V) * M left to right).
    let extracts = with_opcode(&out, OP_COMPOSITE_EXTRACT);
    let fitted = extracts
        .iter()
        .find(|e| e.len() == 5)
        .map(|e| e[2])
        .expect("the fit extracts matrix elements");
    let member = extracts
        .iter()
        .find(|e| e[1] == fitted)
        .expect("the leaf is an extraction");
    assert_eq!(member[3], 0, "the projection, member 0");
    // The carrier-only rewrite of the same module still works and has no fit.
    let plain = rewrite_position_store(&words, OFFSET).unwrap().unwrap();
    validate(&plain);
    assert!(with_opcode(&plain, OP_DECORATE)
        .iter()
        .all(|d| d.get(1) != Some(&42)));
}

#[test]
fn storage_buffers_constants_and_row_vectors_are_fitted() {
    let ssbo = "#version 450
        struct Item { mat4 mvp; vec4 color; };
        layout(set = 0, binding = 0) readonly buffer Objects { Item items[]; } objects;
        layout(location = 0) in vec3 position;
        void main() {
            gl_Position = objects.items[gl_InstanceIndex].mvp * vec4(position, 1.0);
        }";
    let (_, source) = derived(&compile_glsl(naga::ShaderStage::Vertex, ssbo));
    assert_eq!(source, MatrixSource::StorageBuffer);
    let row_vector = "#version 450
        layout(set = 0, binding = 0) uniform Frame { mat4 view_proj; } frame;
        layout(location = 0) in vec3 position;
        void main() {
            vec4 clip = vec4(position, 1.0) * frame.view_proj;
            gl_Position = clip;
        }";
    let (_, source) = derived(&compile_glsl(naga::ShaderStage::Vertex, row_vector));
    assert_eq!(source, MatrixSource::UniformBuffer);
}

#[test]
fn depth_that_is_not_one_matrix_line_is_refused() {
    let refused = |body: &str, reason: &str| {
        let source = format!(
            "#version 450
            layout(set = 0, binding = 0) uniform Frame {{ mat4 a; mat4 b; }} frame;
            layout(location = 0) in vec3 position;
            void main() {{ {body} }}"
        );
        let words = compile_glsl(naga::ShaderStage::Vertex, &source);
        assert_eq!(
            rewrite_position_store_deriving(&words, OFFSET).map(|r| r.map(|(_, s)| s)),
            Err(Unsupported(match reason {
                "z" => "Position's z or w is stored on its own",
                "not" => "Position is not a matrix times a vector",
                _ => "Position comes from more than one matrix",
            })),
            "{body}"
        );
    };
    // naga passes Position through a private written component-wise: not followed.
    refused(
        "gl_Position = frame.a * vec4(position, 1.0);
         gl_Position.z = (gl_Position.z + gl_Position.w) * 0.5;",
        "not",
    );
    refused("gl_Position = vec4(position, 1.0);", "not");
    // naga stores its private Position twice: not followed either.
    refused(
        "if (position.x > 0.0) { gl_Position = frame.a * vec4(position, 1.0); }
         else { gl_Position = frame.b * vec4(position, 1.0); }",
        "not",
    );
}

#[test]
fn a_store_to_position_z_refuses_and_one_to_y_does_not() {
    // glslang's shape: components stored through chains into the gl_PerVertex member.
    let (_, source) = derived(&assemble(PER_VERTEX));
    assert_eq!(source, MatrixSource::PushConstants);
    let z = PER_VERTEX.replace(
        "%yp = OpAccessChain %p_out_f %_ %int_0 %uint_1",
        "%yp = OpAccessChain %p_out_f %_ %int_0 %uint_2",
    );
    let z = z.replace(
        "%uint_1 = OpConstant %uint 1",
        "%uint_1 = OpConstant %uint 1\n    %uint_2 = OpConstant %uint 2",
    );
    assert_eq!(
        rewrite_position_store_deriving(&assemble(&z), OFFSET).map(|r| r.map(|(_, s)| s)),
        Err(Unsupported("Position's z or w is stored on its own"))
    );
}

/// Zink's SPIR-V 1.5 (assembled for Vulkan 1.2).
fn zink_module(text: &str) -> Vec<u32> {
    use spirv_tools::assembler::{self, Assembler as _};
    assembler::create(Some(TargetEnv::Vulkan_1_2))
        .assemble(text, assembler::AssemblerOptions::default())
        .expect("Zink's module assembles")
        .as_words()
        .to_vec()
}

/// Validates SPIR-V 1.5 with the Vulkan memory model and scalar block layout (Zink's uint
/// arrays): Vulkan 1.2's rules with scalarBlockLayout.
fn validate_zink(words: &[u32]) {
    let options = val::ValidatorOptions {
        scalar_block_layout: true,
        ..Default::default()
    };
    val::create(Some(TargetEnv::Vulkan_1_2))
        .validate(words, Some(options))
        .unwrap_or_else(|e| panic!("spirv-val rejects the module: {e}"));
}

#[test]
fn zinks_column_by_column_product_is_fitted_from_the_projections_columns() {
    // Zink's vertex stage for `u_projection * u_view * u_model * vec4(position, 1)`: uniforms
    // as uint loads bitcast to vec4 columns, each product written out as column FMuls by
    // splats summed with FAdds (tester/src/gl/zink_vertex.spvasm.txt).
    let words = zink_module(include_str!("../test_data/zink_vertex.spvasm"));
    let (out, source) = rewrite_position_store_deriving(&words, OFFSET)
        .expect("rewritable")
        .expect("has a Position");
    validate_zink(&words);
    validate_zink(&out);
    assert_eq!(source, MatrixSource::UniformBuffer);
    assert!(with_opcode(&out, OP_DECORATE)
        .iter()
        .any(|d| d.get(1) == Some(&42)));
}

#[test]
fn zinks_products_of_computed_components_and_of_a_dropped_column_are_fitted() {
    // `vec4(p.x, p.y + u_zero * p.x, p.z, 1.0)`: column 1 times a splat of a computed scalar;
    // `vec4(p.x, p.y, 0.0, 1.0)`: the z column dropped (glmark2 through Zink: conditionals,
    // function, loop; shadow). Both took the flip path before session 33 ("Position is not a
    // matrix times a vector").
    for (name, text) in [
        (
            "computed component",
            include_str!("../test_data/zink_computed_component.spvasm"),
        ),
        (
            "dropped column",
            include_str!("../test_data/zink_dropped_column.spvasm"),
        ),
        (
            "an offset of w 0",
            include_str!("../test_data/zink_offset_w_zero.spvasm"),
        ),
    ] {
        let words = zink_module(text);
        let (out, source) = rewrite_position_store_deriving(&words, OFFSET)
            .unwrap_or_else(|e| panic!("{name}: {e:?}"))
            .expect("has a Position");
        validate_zink(&words);
        validate_zink(&out);
        assert_eq!(source, MatrixSource::UniformBuffer, "{name}");
    }
    // The w column times a splat of a computed scalar (`vec4(p.xyz, fract(p.x))`, say): the
    // vector's w is not shown to be 1, so nothing is fitted. Made from the dropped-column
    // module: its innermost product's w column, added alone there, multiplied by a splat of
    // `fract(p.x)`.
    let dropped = include_str!("../test_data/zink_dropped_column.spvasm");
    let bare = "        %104 = OpBitcast %v4float %102\n";
    assert!(dropped.contains(bare), "the innermost product's w column");
    let scaled = dropped.replacen(
        bare,
        "       %w_bits = OpCompositeExtract %uint %34 0\n\
         %w_x = OpBitcast %float %w_bits\n\
         %w_fract = OpExtInst %float %1 Fract %w_x\n\
         %w_u = OpBitcast %uint %w_fract\n\
         %w_splat_u = OpCompositeConstruct %v4uint %w_u %w_u %w_u %w_u\n\
         %w_splat = OpBitcast %v4float %w_splat_u\n\
         %w_column = OpBitcast %v4float %102\n\
         %104 = OpFMul %v4float %w_column %w_splat\n",
        1,
    );
    let words = zink_module(&scaled);
    validate_zink(&words);
    assert_eq!(
        rewrite_position_store_deriving(&words, OFFSET).map(|r| r.map(|(_, s)| s)),
        Err(Unsupported(
            "the vector the projection multiplies may not have w = 1"
        ))
    );
}

/// glslang output saved as binary (`layer/src/test_data/*.spv`).
fn binary(bytes: &[u8]) -> Vec<u32> {
    crate::shader::test_spirv::words(bytes)
}

#[test]
fn shapes_a_review_found_are_refused_not_rewritten_wrongly() {
    let reason = |words: &[u32]| {
        rewrite_position_store_deriving(words, OFFSET)
            .map(|r| r.map(|(_, s)| s))
            .err()
    };
    // A splat built from an extract of component 7 of an array: no panic, no fit.
    let splat = assemble(include_str!("../test_data/splat_index_7.spvasm"));
    assert!(reason(&splat).is_some());
    // glslang -gVS: a push block `{ uint index; }` declared before vec4 and named by debug
    // info before vec4: moving the block would leave the debug info referring forward.
    let debug = binary(include_bytes!(
        "../test_data/push_block_first_debug_info.spv"
    ));
    assert_eq!(
        reason(&debug),
        Some(Unsupported(
            "the push-constant block precedes vec4 and is referred to before it"
        ))
    );
    // `p[i] * v` in a loop, the chosen iteration's value stored: the fit would describe the
    // last iteration.
    let looped = binary(include_bytes!("../test_data/projection_in_a_loop.spv"));
    assert!(reason(&looped).is_some(), "a projection applied in a loop");
    // `P * (V * vec4(dir, 0.0))`: a point at infinity, whose depth is not `k w + B`.
    let direction = binary(include_bytes!("../test_data/direction_w_zero.spv"));
    assert_eq!(
        reason(&direction),
        Some(Unsupported(
            "the vector the projection multiplies may not have w = 1"
        ))
    );
    // Each of them is valid SPIR-V, left as it is.
    for words in [&debug, &looped, &direction] {
        let options = val::ValidatorOptions::default();
        val::create(Some(TargetEnv::Vulkan_1_2))
            .validate(words, Some(options))
            .expect("the input is valid");
    }
}

// ---------------------------------------------------------------------------------------------
// The last pre-rasterization stage after the vertex stage (issue #41): tessellation evaluation
// and geometry shaders, from glslang (the tester's own, `shaders/glslang/`, and shapes saved in
// `test_data/`, each with its GLSL beside it).

/// The words before each instruction with `opcode`: (previous opcode, its operands).
fn preceding(words: &[u32], opcode: u32) -> Vec<(u32, Vec<u32>)> {
    let all: Vec<_> = instructions(words)
        .expect("SPIR-V")
        .map_while(Result::ok)
        .map(|i| (i.opcode, i.operands.to_vec()))
        .collect();
    all.windows(2)
        .filter(|pair| pair[1].0 == opcode)
        .map(|pair| pair[0].clone())
        .collect()
}

/// A deriving rewrite of a later stage, checked by spirv-val (naga reads no such stage).
fn derived_later(words: &[u32]) -> (Vec<u32>, MatrixSource) {
    let (out, source) = rewrite_position_store_deriving(words, OFFSET)
        .expect("rewritable")
        .expect("has a Position");
    validate(&out);
    (out, source)
}

#[test]
fn which_stages_store_position_with_w_one() {
    let stores = |body: &str| {
        let source = format!(
            "#version 450
            layout(set = 0, binding = 0) uniform Frame {{ mat4 p; }} frame;
            layout(location = 0) in vec3 position;
            layout(location = 1) in vec4 attribute;
            void main() {{ {body} }}"
        );
        stores_position_w_one(&compile_glsl(naga::ShaderStage::Vertex, &source))
    };
    assert!(stores("gl_Position = vec4(position, 1.0);"));
    assert!(stores(
        "vec4 p = vec4(position * 2.0, 1.0); gl_Position = p;"
    ));
    // A projection's w, an attribute's data, a w written apart: not shown to be 1.
    assert!(!stores("gl_Position = frame.p * vec4(position, 1.0);"));
    assert!(!stores("gl_Position = attribute;"));
    assert!(!stores(
        "gl_Position = vec4(position, 1.0); gl_Position.w = attribute.w;"
    ));
    assert!(!stores("gl_Position = vec4(position, attribute.w);"));
    // glslang's vertex stages of the tester's geometry and tessellation deliveries.
    let position = binary(include_bytes!(
        "../../../../shaders/glslang/ubo_position.vert.spv"
    ));
    assert!(stores_position_w_one(&position));
    let later = binary(include_bytes!(
        "../../../../shaders/glslang/ubo_later.vert.spv"
    ));
    assert!(!stores_position_w_one(&later));
    // No Position stored, or not SPIR-V.
    assert!(!stores("gl_Position.x = position.x;"));
    assert!(!stores_position_w_one(&[1, 2, 3]));
}

#[test]
fn a_geometry_shader_stores_reversed_depth_before_each_emit_in_its_loop() {
    let words = binary(include_bytes!("../../../../shaders/glslang/ubo.geom.spv"));
    // The projection is loaded in the loop over the input vertices, and each store is emitted
    // in its own block: the fit describes every emitted vertex.
    let (out, source) = derived_later(&words);
    assert_eq!(source, MatrixSource::UniformBuffer);
    // It projects gl_in's Position: the pipeline checks the vertex stage's w.
    assert!(
        derive_position_store(&words, OFFSET)
            .unwrap()
            .unwrap()
            .assumes_input_unit_w
    );
    let before_emits = preceding(&out, OP_EMIT_VERTEX);
    assert_eq!(before_emits.len(), 1, "the emit is kept, once");
    assert!(
        before_emits.iter().all(|(opcode, _)| *opcode == OP_STORE),
        "the shadow goes to Position right before the emit"
    );
    // The return emits nothing: no store before it.
    assert!(preceding(&out, OP_RETURN)
        .iter()
        .all(|(opcode, _)| *opcode != OP_STORE));
    // The carrier-only rewrite of it too.
    let plain = rewrite_position_store(&words, OFFSET).unwrap().unwrap();
    validate(&plain);
    assert_carrier(&plain);
    assert_eq!(preceding(&plain, OP_EMIT_VERTEX)[0].0, OP_STORE);
}

#[test]
fn a_tessellation_evaluation_shader_stores_reversed_depth_at_its_return() {
    let words = binary(include_bytes!("../../../../shaders/glslang/ubo.tese.spv"));
    let (out, source) = derived_later(&words);
    assert_eq!(source, MatrixSource::UniformBuffer);
    let before_returns = preceding(&out, OP_RETURN);
    assert_eq!(before_returns.len(), 1);
    assert_eq!(before_returns[0].0, OP_STORE);
}

#[test]
fn geometry_shaders_with_push_constant_projections_and_viewports_are_fitted() {
    // An instanced geometry shader, one viewport per invocation, the projection indexed by the
    // invocation in push constants: the stage fits the matrix it loads.
    let words = binary(include_bytes!("../test_data/geometry_push_viewports.spv"));
    // 128 bytes of matrices: the carrier at 240, as on a device with 256 bytes.
    let (out, source) = rewrite_position_store_deriving(&words, 240)
        .expect("rewritable")
        .expect("has a Position");
    validate(&out);
    assert_eq!(source, MatrixSource::PushConstants);
    assert_eq!(preceding(&out, OP_EMIT_VERTEX)[0].0, OP_STORE);
}

#[test]
fn geometry_shapes_whose_emitted_depth_the_fit_may_not_describe_are_refused() {
    let reason = |words: &[u32]| {
        rewrite_position_store_deriving(words, 240)
            .map(|r| r.map(|(_, s)| s))
            .err()
    };
    // The store in a branch, the emit after it: an iteration that skips the store emits the
    // previous iteration's position, which the fit (run again) may not describe.
    let conditional = binary(include_bytes!("../test_data/geometry_conditional.spv"));
    assert_eq!(
        reason(&conditional),
        Some(Unsupported("the projection is loaded in a loop"))
    );
    // `view_proj * gl_in[i].gl_Position`: fitted, on the condition that the stage before
    // stores w = 1 (the pipeline checks it).
    let clip_input = binary(include_bytes!("../test_data/geometry_clip_input.spv"));
    let rewrite = derive_position_store(&clip_input, 240).unwrap().unwrap();
    assert!(rewrite.assumes_input_unit_w);
    validate(&rewrite.code);
    // Three emits written out with two matrices: not one line.
    let two = binary(include_bytes!("../test_data/geometry_two_matrices.spv"));
    assert_eq!(
        reason(&two),
        Some(Unsupported("Position comes from more than one matrix"))
    );
    // A module of two stages is not rewritten.
    let vertex = compile_glsl(naga::ShaderStage::Vertex, UBO_PVM);
    assert!(crate::shader::scan::declares_position_stage_entry_point(
        &conditional
    ));
    assert!(!crate::shader::scan::declares_vertex_entry_point(
        &conditional
    ));
    assert!(crate::shader::scan::declares_vertex_entry_point(&vertex));
}

#[test]
fn projections_written_as_dot_products_or_fused_columns_are_fitted() {
    // glslang -Os: vec4(dot(r0, p), dot(p, r1), dot(r2, p), dot(p, r3)), the rows in a
    // uniform buffer of vec4s.
    let rows = binary(include_bytes!("../test_data/rows_dot.spv"));
    let (out, source) = derived(&rows);
    assert_eq!(source, MatrixSource::UniformBuffer);
    // The fit reads the depth and w rows: its extractions come from two loaded vec4s.
    let extracts = with_opcode(&out, OP_COMPOSITE_EXTRACT);
    let fitted: HashSet<u32> = extracts
        .iter()
        .filter(|e| e.len() == 4 && e[3] < 4)
        .map(|e| e[2])
        .collect();
    assert!(fitted.len() >= 2, "{fitted:?}");
    // glslang -Os: fma(c3, vec4(1.0), fma(c2, p.zzzz, fma(c1, p.yyyy, c0 * p.xxxx))), the
    // matrix in push constants (a derived rewrite fits it in the stage too).
    let fused = binary(include_bytes!("../test_data/columns_fma.spv"));
    let (_, source) = derived(&fused);
    assert_eq!(source, MatrixSource::PushConstants);
}

#[test]
fn dot_products_that_do_not_share_one_vector_or_have_no_unit_w_are_refused() {
    let refused = |body: &str| {
        let source = format!(
            "#version 450
            layout(set = 0, binding = 0) uniform Frame {{ vec4 rows[4]; }} frame;
            layout(location = 0) in vec3 position;
            layout(location = 1) in vec4 other;
            void main() {{ vec4 p = vec4(position, 1.0); {body} }}"
        );
        rewrite_position_store_deriving(&compile_glsl(naga::ShaderStage::Vertex, &source), OFFSET)
            .err()
    };
    // z and w from dots of different vectors: no one matrix.
    assert!(refused(
        "gl_Position = vec4(dot(frame.rows[0], p), dot(frame.rows[1], p), \
         dot(frame.rows[2], p), dot(frame.rows[3], other));"
    )
    .is_some());
    // The vector's w is not shown to be 1.
    let w = refused(
        "vec4 q = vec4(position, other.w); gl_Position = vec4(dot(frame.rows[0], q), \
         dot(frame.rows[1], q), dot(frame.rows[2], q), dot(frame.rows[3], q));",
    );
    assert_eq!(
        w,
        Some(Unsupported(
            "the vector the projection multiplies may not have w = 1"
        ))
    );
    // The same through naga's own SPIR-V: fitted.
    assert!(refused(
        "gl_Position = vec4(dot(frame.rows[0], p), dot(frame.rows[1], p), \
         dot(frame.rows[2], p), dot(frame.rows[3], p));"
    )
    .is_none());
}

#[test]
fn a_projection_applied_in_a_function_called_once_is_fitted() {
    // glslang -O0: `gl_Position = project(position)`, the product in the callee.
    let called = binary(include_bytes!("../test_data/function_call.spv"));
    let (out, source) = derived(&called);
    assert_eq!(source, MatrixSource::UniformBuffer);
    validate(&out);
    // Called twice, with different matrices: the fit would describe the last call.
    let twice = binary(include_bytes!("../test_data/function_called_twice.spv"));
    assert_eq!(
        rewrite_position_store_deriving(&twice, OFFSET).err(),
        Some(Unsupported("Position is not a matrix times a vector"))
    );
}

#[test]
fn a_geometry_shader_written_out_without_a_loop_fits_after_each_load_of_its_matrix() {
    // Three emits, each with its own load of the same uniform matrix (glslang -O0): the fit
    // runs after each load, renumbered.
    let unrolled = binary(include_bytes!("../test_data/geometry_unrolled.spv"));
    let (out, source) = derived_later(&unrolled);
    assert_eq!(source, MatrixSource::UniformBuffer);
    let private_stores = |words: &[u32]| {
        let privates: HashSet<u32> = with_opcode(words, OP_VARIABLE)
            .into_iter()
            .filter(|v| v[2] == STORAGE_PRIVATE)
            .map(|v| v[1])
            .collect();
        with_opcode(words, OP_STORE)
            .iter()
            .filter(|s| privates.contains(&s[0]))
            .count()
    };
    // Stores straight into private variables: the fits' derived carrier (the shader's own
    // stores go to the shadow through access chains), three here, one in the looped shader.
    let (looped, _) = derived_later(&binary(include_bytes!(
        "../../../../shaders/glslang/ubo.geom.spv"
    )));
    assert_eq!(private_stores(&out), 3, "three fits");
    assert_eq!(private_stores(&looped), 1, "one fit");
    for (_, before) in preceding(&out, OP_EMIT_VERTEX) {
        assert!(!before.is_empty());
    }
    assert_eq!(preceding(&out, OP_EMIT_VERTEX).len(), 3);
}

#[test]
fn a_fit_in_a_function_that_may_run_again_after_the_store_is_refused() {
    let reason = |bytes: &[u8]| {
        rewrite_position_store_deriving(&binary(bytes), OFFSET)
            .map(|r| r.map(|(_, s)| s))
            .err()
    };
    // Each stores one call's value and runs the projection again (with another matrix)
    // after it: the fit would describe the later run.
    for (name, bytes) in [
        (
            "a helper called twice, storing once",
            &include_bytes!("../test_data/function_called_from_a_helper_called_twice.spv")[..],
        ),
        (
            "a private matrix set by a function called twice",
            &include_bytes!("../test_data/function_private_matrix_set_twice.spv")[..],
        ),
        (
            "a function called in its caller's loop",
            &include_bytes!("../test_data/function_called_in_a_caller_loop.spv")[..],
        ),
        (
            "a chain of calls in a loop",
            &include_bytes!("../test_data/function_chain_called_in_a_loop.spv")[..],
        ),
    ] {
        assert!(reason(bytes).is_some(), "{name}: accepted");
    }
    // A projection as dot products in a function called once from the entry point: fitted.
    let (_, source) = derived(&binary(include_bytes!(
        "../test_data/function_dot_rows_in_a_callee.spv"
    )));
    assert_eq!(source, MatrixSource::UniformBuffer);
}

/// As D3D bytecode translators (DXVK) write a vertex shader: the output register a private
/// `vec4` written one component at a time by dot products with a constant buffer's `vec4`
/// rows, in a function the entry point calls before it copies the register into `Position`
/// (glslang, `-O0`: each dot loads the input again). Fitted after the later dot product; a
/// register whose z or w is written twice, also written whole, or reached otherwise than
/// through its components is refused.
#[test]
fn a_register_written_component_by_component_is_fitted() {
    let (out, source) = derived(&binary(include_bytes!(
        "../test_data/components_assembled.spv"
    )));
    assert_eq!(source, MatrixSource::UniformBuffer);
    // The fit reads the depth and w rows: extractions from two loaded vec4s.
    let fitted: HashSet<u32> = with_opcode(&out, OP_COMPOSITE_EXTRACT)
        .iter()
        .filter(|e| e.len() == 4 && e[3] < 4)
        .map(|e| e[2])
        .collect();
    assert!(fitted.len() >= 2, "{fitted:?}");
    let outcome = |body: &str| {
        let source = format!(
            "#version 450
            layout(set = 0, binding = 0) uniform Frame {{ vec4 rows[4]; }} frame;
            layout(location = 0) in vec4 v0;
            vec4 o0;
            void main() {{ {body} gl_Position = o0; }}"
        );
        rewrite_position_store_deriving(&compile_glsl(naga::ShaderStage::Vertex, &source), OFFSET)
            .map(|r| r.map(|(_, s)| s))
    };
    let rows = "o0.x = dot(v0, frame.rows[0]); o0.y = dot(v0, frame.rows[1]);
        o0.z = dot(v0, frame.rows[2]); o0.w = dot(frame.rows[3], v0);";
    assert_eq!(
        outcome(rows).ok().flatten(),
        Some(MatrixSource::UniformBuffer),
        "naga's SPIR-V of the same"
    );
    for (name, body) in [
        (
            "z written twice",
            format!("{rows} o0.z = dot(v0, frame.rows[1]);"),
        ),
        ("also written whole", format!("o0 = vec4(0.0); {rows}")),
        (
            "a row of another vector",
            rows.replace("dot(frame.rows[3], v0)", "dot(frame.rows[3], v0.yxzw)"),
        ),
    ] {
        assert!(outcome(&body).is_err(), "{name}: accepted");
    }
}

/// `scene.vert`'s projection with push constants that fill 128 bytes (a tint array after the
/// matrix): no room for revz's carrier at [`OFFSET`].
const PUSH_FULL: &str = "#version 450
    layout(push_constant) uniform PushConstants { mat4 mvp; vec4 tint[4]; } pc;
    layout(location = 0) in vec3 position;
    layout(location = 0) out vec4 color;
    void main() {
        gl_Position = pc.mvp * vec4(position, 1.0);
        color = pc.tint[3];
    }";

#[test]
fn a_baked_carrier_leaves_the_push_constants_as_they_are() {
    let words = compile_glsl(naga::ShaderStage::Vertex, PUSH_FULL);
    // The pushed carrier has no room.
    assert_eq!(
        derive_position_store(&words, OFFSET).unwrap_err(),
        Unsupported("the push-constant block reaches revz's carrier bytes")
    );
    let baked = [1.0, 0.0, 0.0, 1.0];
    let rewrite = derive_position_store_reading(&words, CarrierRead::Baked(baked))
        .expect("rewritable")
        .expect("has a Position");
    assert_eq!(rewrite.source, MatrixSource::PushConstants);
    let out = rewrite.code;
    validate(&out);
    naga::front::spv::Frontend::new(out.iter().copied(), &Default::default())
        .parse()
        .expect("naga reads the rewritten module");
    // The application's block, its members and their offsets, unchanged; no other block.
    let blocks = |words: &[u32]| {
        let decorated: Vec<u32> = with_opcode(words, OP_DECORATE)
            .into_iter()
            .filter(|d| d[1] == DECORATION_BLOCK)
            .map(|d| d[0])
            .collect();
        let structs: Vec<Vec<u32>> = with_opcode(words, OP_TYPE_STRUCT)
            .into_iter()
            .filter(|s| decorated.contains(&s[0]))
            .collect();
        let offsets: Vec<Vec<u32>> = with_opcode(words, OP_MEMBER_DECORATE)
            .into_iter()
            .filter(|d| d[2] == DECORATION_OFFSET)
            .collect();
        (structs, offsets)
    };
    assert_eq!(blocks(&out), blocks(&words));
    let push_variables = |words: &[u32]| {
        with_opcode(words, OP_VARIABLE)
            .into_iter()
            .filter(|v| v[2] == STORAGE_PUSH_CONSTANT)
            .count()
    };
    assert_eq!(push_variables(&out), 1);
    // The carrier is a constant composite of the baked values, and nothing loads one from
    // push constants: the only push-constant access chains are the application's matrix and
    // tint.
    let constants: std::collections::HashMap<u32, u32> = with_opcode(&out, OP_CONSTANT)
        .into_iter()
        .filter(|c| c.len() == 3)
        .map(|c| (c[1], c[2]))
        .collect();
    let baked_bits = baked.map(f32::to_bits);
    let composite = with_opcode(&out, CONSTANT_COMPOSITE)
        .into_iter()
        .find(|c| {
            c.len() == 6
                && c[2..]
                    .iter()
                    .map(|id| constants.get(id).copied())
                    .eq(baked_bits.iter().map(|&b| Some(b)))
        })
        .expect("the baked carrier");
    let loads_of_composite = with_opcode(&out, OP_COMPOSITE_EXTRACT)
        .into_iter()
        .filter(|e| e[2] == composite[1])
        .count();
    assert!(loads_of_composite >= 4, "the stores read the baked carrier");
    let push_chains = |words: &[u32]| {
        let variables: Vec<u32> = with_opcode(words, OP_VARIABLE)
            .into_iter()
            .filter(|v| v[2] == STORAGE_PUSH_CONSTANT)
            .map(|v| v[1])
            .collect();
        with_opcode(words, OP_ACCESS_CHAIN)
            .into_iter()
            .filter(|c| variables.contains(&c[2]))
            .count()
    };
    assert_eq!(push_chains(&out), push_chains(&words));
}

/// fxc's `mul(v, M)` as D3D bytecode translators (DXVK) write it, compiled by glslang: a
/// register reassigned by a multiply and three multiply-adds of the matrix's columns by splats
/// of the input; as written, with a block boundary before the register's last load.
const REGISTER_SPLIT: &str = include_str!("../test_data/register_reassigned_split.spvasm");

#[test]
fn a_register_reassigned_by_multiply_adds_of_the_columns_is_fitted() {
    let whole = REGISTER_SPLIT.replace(
        "               OpBranch %split\n      %split = OpLabel\n",
        "",
    );
    assert_ne!(whole, REGISTER_SPLIT);
    let (out, source) = derived(&assemble(&whole));
    assert_eq!(source, MatrixSource::UniformBuffer);
    validate(&out);
    // The tester's `ssbo-columns` (glslang, a storage buffer, the instance's matrix).
    let glslang = include_bytes!("../../../../shaders/glslang/ssbo_columns.vert.spv");
    let (out, source) = derived(&binary(glslang));
    assert_eq!(source, MatrixSource::StorageBuffer);
    validate(&out);
    // The last load in a block of its own reads no store of its block: refused.
    assert_eq!(
        derive_position_store(&assemble(REGISTER_SPLIT), OFFSET).unwrap_err(),
        Unsupported("Position is not a matrix times a vector")
    );
}

/// spirv-val for Vulkan 1.2 (mesh shaders need SPIR-V 1.4).
fn validate_1_2(words: &[u32]) {
    val::create(Some(TargetEnv::Vulkan_1_2))
        .validate(words, None)
        .unwrap_or_else(|e| panic!("spirv-val rejects the module: {e}"));
}

#[test]
fn a_mesh_shader_stores_reversed_depth_where_it_stores_each_vertex() {
    // The tester's mesh delivery (glslang): each invocation projects its triangle's three
    // corners in a loop, the matrix loaded from push constants in the loop's body.
    let words = binary(include_bytes!("../../../../shaders/glslang/mesh.mesh.spv"));
    let rewrite = derive_position_store(&words, OFFSET)
        .expect("rewritable")
        .expect("has a Position");
    validate_1_2(&rewrite.code);
    assert_eq!(rewrite.source, MatrixSource::PushConstants);
    assert!(!rewrite.assumes_input_unit_w);
    // Every store of a vertex's Position stores the rewritten value: a composite insert of
    // the new depth right before it, and the store of the original value is gone.
    let stores = with_opcode(&rewrite.code, OP_STORE);
    let inserted: Vec<u32> = with_opcode(&rewrite.code, OP_COMPOSITE_INSERT)
        .iter()
        .map(|i| i[1])
        .collect();
    let position_stores: Vec<_> = stores.iter().filter(|s| inserted.contains(&s[1])).collect();
    assert_eq!(position_stores.len(), 1, "one store in the corner loop");
    assert_eq!(
        preceding(&rewrite.code, OP_STORE)
            .iter()
            .filter(|(opcode, _)| *opcode == OP_COMPOSITE_INSERT)
            .count(),
        1
    );
    // Nothing is stored at the return (no shadow), and the interface lists the fit's variable.
    assert!(preceding(&rewrite.code, OP_RETURN)
        .iter()
        .all(|(opcode, _)| *opcode != OP_STORE));
    // The carrier-only and the baked rewrites of it too.
    let plain = rewrite_position_store(&words, OFFSET).unwrap().unwrap();
    validate_1_2(&plain);
    assert_carrier(&plain);
    let baked = derive_position_store_reading(&words, CarrierRead::Baked([0.0, 0.0, 0.0, 1.0]))
        .unwrap()
        .unwrap();
    validate_1_2(&baked.code);
}

#[test]
fn mesh_shaders_whose_stored_depth_the_rewrite_cannot_follow_are_refused() {
    let reason = |bytes: &[u8]| {
        derive_position_store(&binary(bytes), OFFSET)
            .map(|r| r.map(|r| r.source))
            .err()
    };
    assert_eq!(
        reason(include_bytes!("../test_data/mesh_component_store.spv")),
        Some(Unsupported(
            "a component of a mesh vertex's Position is stored on its own"
        ))
    );
    assert_eq!(
        reason(include_bytes!("../test_data/mesh_read_back.spv")),
        Some(Unsupported("a mesh vertex's Position is read back"))
    );
    // A store in a block after the matrix's: another iteration could load it again between.
    assert_eq!(
        reason(include_bytes!("../test_data/mesh_two_stores.spv")),
        Some(Unsupported("the projection is loaded in a loop"))
    );
}

#[test]
fn a_mesh_shader_with_an_array_of_positions_as_dxc_writes_it_is_rewritten_where_it_stores() {
    use spirv_tools::assembler::{self, Assembler as _};
    let text = include_str!("../test_data/mesh_position_array.spvasm");
    let words = assembler::create(Some(TargetEnv::Vulkan_1_2))
        .assemble(text, assembler::AssemblerOptions::default())
        .expect("assembles")
        .as_words()
        .to_vec();
    validate_1_2(&words);
    let rewrite = derive_position_store(&words, OFFSET)
        .expect("rewritable")
        .expect("has a Position");
    validate_1_2(&rewrite.code);
    assert_eq!(rewrite.source, MatrixSource::PushConstants);
    // The one store of a corner's position stores the rewritten value.
    assert_eq!(
        preceding(&rewrite.code, OP_STORE)
            .iter()
            .filter(|(opcode, _)| *opcode == OP_COMPOSITE_INSERT)
            .count(),
        1
    );
}

#[test]
fn a_matrix_loaded_whole_from_a_push_constant_member_is_located_for_the_cpu() {
    let slot = |words: &[u32]| {
        derive_position_store(words, OFFSET)
            .expect("rewritable")
            .expect("has a Position")
            .push_slot
    };
    let column_major = Some(crate::shader::analysis::ProjectionSlot {
        offset: 0,
        matrix_stride: 16,
        row_major: false,
        columns: 4,
        rows: 4,
    });
    // The mesh and geometry deliveries: `pc.mvp` at byte 0 of their push-constant block.
    let mesh = binary(include_bytes!("../../../../shaders/glslang/mesh.mesh.spv"));
    assert_eq!(slot(&mesh), column_major);
    let geometry = binary(include_bytes!("../../../../shaders/glslang/push.geom.spv"));
    assert_eq!(slot(&geometry), column_major);
    // A uniform buffer's matrix, and push constants indexed by the invocation: none.
    let ubo = binary(include_bytes!("../../../../shaders/glslang/ubo.geom.spv"));
    assert_eq!(slot(&ubo), None);
    let indexed = binary(include_bytes!("../test_data/geometry_push_viewports.spv"));
    let indexed = derive_position_store(&indexed, 240).unwrap().unwrap();
    assert_eq!(indexed.push_slot, None);
    // A row-major member read as `v * M`: the matrix used is its transpose, whose rows are
    // the member's columns.
    let row_major_vector = binary(include_bytes!("../test_data/row_major_vector_push.spv"));
    let found = slot(&row_major_vector).expect("located");
    assert!(
        !found.row_major,
        "rows of the member, columns of the matrix used"
    );
}

/// A vertex shader in the shape Wine's vkd3d-shader writes D3D bytecode (its `vkd3d-gears`
/// demo's, measured: refused as "Position is copied as memory" before session 32): registers
/// written a component at a time and then whole, splats from two vectors, the output register
/// `OpCopyMemory`'d into `Position`.
const REGISTER_COPIED: &str = include_str!("../test_data/register_copied.spvasm");

#[test]
fn a_register_copied_into_position_as_vkd3d_shader_writes_it_is_fitted() {
    let words = assemble(REGISTER_COPIED);
    let (out, source) = derived(&words);
    assert_eq!(source, MatrixSource::UniformBuffer);
    // The copy into Position became a load and a store (rewritten); the other output's copy
    // is left as it was.
    assert_eq!(with_opcode(&words, OP_COPY_MEMORY).len(), 2);
    assert_eq!(with_opcode(&out, OP_COPY_MEMORY).len(), 1);
    // The carrier-only rewrite (a projection the CPU reads) follows the copy too.
    let plain = rewrite_position_store(&words, OFFSET).unwrap().unwrap();
    validate(&plain);
    assert_carrier(&plain);
    // Why the deriving rewrite refuses the module with `from` replaced by `to` (which must
    // change it).
    let refusal = |from: &str, to: &str| {
        let edited = REGISTER_COPIED.replace(from, to);
        assert_ne!(edited, REGISTER_COPIED);
        derive_position_store(&assemble(&edited), OFFSET).unwrap_err()
    };
    // A component store between the register's last whole store and the copy: what is copied
    // is not the product's value.
    assert_eq!(
        refusal(
            "               OpCopyMemory %o0 %r0\n",
            "               OpStore %r0x %vx\n               OpCopyMemory %o0 %r0\n",
        ),
        Unsupported("Position is not a matrix times a vector")
    );
    // The last column's splat from a register whose w is not known to be 1: refused.
    assert_eq!(
        refusal(
            "%wwww = OpVectorShuffle %vec4 %l6 %l6 3 3 3 3",
            "%wwww = OpVectorShuffle %vec4 %l2 %l2 3 3 3 3",
        ),
        Unsupported("the vector the projection multiplies may not have w = 1")
    );
    // A copy of another type, or with memory operands, is left as a copy: refused as before.
    assert_eq!(
        refusal(
            "               OpCopyMemory %o0 %r0\n",
            "               OpCopyMemory %o0 %r0 Aligned 16\n",
        ),
        Unsupported("Position is copied as memory")
    );
}

/// A geometry stage that only passes `gl_in[i].gl_Position` through (glslang): the stage before
/// it is the one to rewrite. Reading x, y and w of the positions (a wireframe overlay's edge
/// distances) keeps it so; reading z, or emitting a computed position, does not.
#[test]
fn a_geometry_stage_passing_the_positions_through_is_told_from_one_that_computes_with_them() {
    let passes = |bytes: &[u8]| passes_position_through(&binary(bytes));
    assert!(passes(include_bytes!(
        "../test_data/geometry_passthrough.spv"
    )));
    assert!(passes(include_bytes!(
        "../test_data/geometry_wireframe.spv"
    )));
    assert!(!passes(include_bytes!("../test_data/geometry_reads_z.spv")));
    assert!(!passes(include_bytes!(
        "../test_data/geometry_midpoint.spv"
    )));
    // A geometry stage that projects its input (`view_proj * gl_in[i].gl_Position`), and a
    // vertex stage: neither passes positions through.
    assert!(!passes(include_bytes!(
        "../test_data/geometry_clip_input.spv"
    )));
    assert!(!passes_position_through(&compile_glsl(
        naga::ShaderStage::Vertex,
        UBO_PVM
    )));
    // Malformed words: no.
    assert!(!passes_position_through(&[
        0x0723_0203,
        0x0001_0000,
        0,
        10,
        0,
        0xffff_0001
    ]));
}

/// A tessellation evaluation stage that projects the patch's positions itself (glslang):
/// `P * V * M * (u * p0 + v * p1 + w * p2)` with y displaced apart (`projecting.tese`, the
/// tester's `ubo-projecting-tessellation`), and terrain's quads (`mix` of the four corners, y
/// lowered by a height map, `projection * modelview`). Fitted in the stage on the condition
/// that the patch's positions have w = 1 (the pipeline checks the stages before). A local
/// whose w is written apart after its interpolation is no longer known to have w = 1.
#[test]
fn a_tessellation_evaluation_stage_projecting_its_interpolated_positions_is_fitted() {
    for bytes in [
        &include_bytes!("../../../../shaders/glslang/projecting.tese.spv")[..],
        &include_bytes!("../test_data/tessellation_projected_quad_mix.spv")[..],
    ] {
        let words = binary(bytes);
        let rewrite = derive_position_store(&words, 240)
            .expect("rewritable")
            .expect("has a Position");
        assert!(rewrite.assumes_input_unit_w);
        assert_eq!(rewrite.source, MatrixSource::UniformBuffer);
        validate(&rewrite.code);
    }
    let w_written = binary(include_bytes!(
        "../test_data/tessellation_projected_w_written.spv"
    ));
    assert_eq!(
        rewrite_position_store_deriving(&w_written, 240)
            .map(|r| r.map(|(_, s)| s))
            .err(),
        Some(Unsupported(
            "the vector the projection multiplies may not have w = 1"
        ))
    );
}
