//! Fragment shaders that compute with depth, rewritten for reversed attachments.
//!
//! A fragment shader that writes `FragDepth` (an impostor, a decal, logarithmic depth) or reads
//! `FragCoord.z` (fog, soft particles) works in standard depth, where no viewport or compare-op
//! change can reach it. [`reverse_fragment_depth`] rewrites such a module for draws into a
//! reversed attachment: every value stored to `FragDepth` goes through d -> 1 - d, every
//! `FragCoord.z` read through z -> 1 - z, and the conservative-depth execution modes
//! `DepthGreater` and `DepthLess` swap. The shader's own arithmetic is untouched, so it
//! computes the standard values it computes natively and the attachment receives their
//! reversal. The pipeline bound for reversed draws uses the rewritten module
//! (`hooks::pipeline`).
//!
//! Word manipulation only, no Vulkan and no full parse. Anything the rewrite does not
//! recognise (a built-in in a block, a pointer to it passed to a function, a dynamic index
//! into `FragCoord`) is refused with a reason, never guessed at.
//!
//! The map is the complementary one, exact in the flip and complementary modes. In infinite
//! mode the attachment holds n/w = 1 - (1 - n/f) D, which depends on the camera's n/f at draw
//! time; a rewritten module bakes one map, so it stores 1 - D there: off by at most n/f.

use std::collections::{HashMap, HashSet};
use std::fmt;

use crate::shader::scan::op::*;
use crate::shader::scan::{
    instructions, instructions_at, is_literal, push, FreshIds, Instruction, HEADER_WORDS,
};

const DECORATION_BUILT_IN: u32 = 11;
const BUILT_IN_FRAG_COORD: u32 = 15;
const BUILT_IN_FRAG_DEPTH: u32 = 22;
const EXECUTION_MODE_DEPTH_GREATER: u32 = 14;
const EXECUTION_MODE_DEPTH_LESS: u32 = 15;
/// The component of `FragCoord` that holds depth.
const Z: u32 = 2;

/// Why a module that computes with depth cannot be rewritten.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Unsupported(pub &'static str);

impl fmt::Display for Unsupported {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.0)
    }
}

/// The module rewritten for a reversed attachment, `None` when it neither writes `FragDepth`
/// nor reads `FragCoord.z` (its draws need no rewrite), or why it cannot be rewritten. Words
/// that are not SPIR-V are `None`: the driver judges them.
pub fn reverse_fragment_depth(words: &[u32]) -> Result<Option<Vec<u32>>, Unsupported> {
    let Some(module) = Module::read(words)? else {
        return Ok(None);
    };
    module.rewrite(words)
}

/// What the rewrite needs to know about a module, from one pass over its words.
#[derive(Debug, Default)]
struct Module {
    /// Variables decorated `BuiltIn FragDepth` / `BuiltIn FragCoord`.
    frag_depth: HashSet<u32>,
    frag_coord: HashSet<u32>,
    /// Type ids: 32-bit floats, vectors (component, count), pointers (pointee), 32-bit ints.
    floats: HashSet<u32>,
    vectors: HashMap<u32, (u32, u32)>,
    pointers: HashMap<u32, u32>,
    ints: HashSet<u32>,
    /// 32-bit integer constants.
    int_constants: HashMap<u32, u32>,
    /// Each global variable's pointer type.
    variables: HashMap<u32, u32>,
    /// Word index of the first `OpFunction` (where the rewrite's constants go).
    functions_at: usize,
}

impl Module {
    /// Reads the declarations; `None` when the words are not SPIR-V or nothing in them is a
    /// depth built-in.
    fn read(words: &[u32]) -> Result<Option<Module>, Unsupported> {
        let Some(instructions) = instructions(words) else {
            return Ok(None);
        };
        let mut module = Module::default();
        let mut at = HEADER_WORDS;
        for instruction in instructions {
            let Instruction { opcode, operands } =
                instruction.map_err(|_| Unsupported("a malformed instruction"))?;
            match (opcode, operands) {
                (OP_DECORATE, &[target, DECORATION_BUILT_IN, built_in]) => match built_in {
                    BUILT_IN_FRAG_DEPTH => {
                        module.frag_depth.insert(target);
                    }
                    BUILT_IN_FRAG_COORD => {
                        module.frag_coord.insert(target);
                    }
                    _ => {}
                },
                (
                    OP_MEMBER_DECORATE,
                    &[_, _, DECORATION_BUILT_IN, BUILT_IN_FRAG_DEPTH | BUILT_IN_FRAG_COORD],
                ) => {
                    return Err(Unsupported("a depth built-in is a block member"));
                }
                (OP_TYPE_FLOAT, &[id, 32, ..]) => {
                    module.floats.insert(id);
                }
                (OP_TYPE_INT, &[id, 32, _]) => {
                    module.ints.insert(id);
                }
                (OP_TYPE_VECTOR, &[id, component, count]) => {
                    module.vectors.insert(id, (component, count));
                }
                (OP_TYPE_POINTER, &[id, _, pointee]) => {
                    module.pointers.insert(id, pointee);
                }
                (OP_CONSTANT, &[ty, id, value]) if module.ints.contains(&ty) => {
                    module.int_constants.insert(id, value);
                }
                (OP_VARIABLE, &[_, id, _, _]) if module.frag_depth.contains(&id) => {
                    // The initializer is the depth of every fragment that stores none.
                    return Err(Unsupported("FragDepth has an initializer"));
                }
                (OP_VARIABLE, &[ty, id, ..]) if module.functions_at == 0 => {
                    module.variables.insert(id, ty);
                }
                (OP_FUNCTION, _) if module.functions_at == 0 => module.functions_at = at,
                _ => {}
            }
            at += operands.len() + 1;
        }
        if module.frag_depth.is_empty() && module.frag_coord.is_empty() {
            return Ok(None);
        }
        Ok(Some(module))
    }

    /// The float type of a built-in variable (a float for `FragDepth`, the component of a
    /// 4-vector for `FragCoord`).
    fn float_of(&self, variable: u32, vector: bool) -> Result<u32, Unsupported> {
        let pointee = self
            .variables
            .get(&variable)
            .and_then(|pointer| self.pointers.get(pointer))
            .ok_or(Unsupported("a depth built-in is not a global variable"))?;
        let float = if vector {
            match self.vectors.get(pointee) {
                Some(&(component, 4)) => component,
                _ => return Err(Unsupported("FragCoord is not a 4-vector")),
            }
        } else {
            *pointee
        };
        if self.floats.contains(&float) {
            Ok(float)
        } else {
            Err(Unsupported("a depth built-in is not a 32-bit float"))
        }
    }

    fn rewrite(&self, words: &[u32]) -> Result<Option<Vec<u32>>, Unsupported> {
        if self.functions_at == 0 {
            return Ok(None);
        }
        let mut float = None;
        for &variable in &self.frag_depth {
            float = Some(self.float_of(variable, false)?);
        }
        for &variable in &self.frag_coord {
            float = Some(self.float_of(variable, true)?);
        }
        let float = float.expect("read() keeps modules with a depth built-in");
        let body = Body::read(self, words)?;
        if !body.changes_anything() {
            return Ok(None);
        }

        // One constant, and at most three ids per edit.
        let needed = 1 + 3 * body.edits();
        let mut ids =
            FreshIds::new(words, needed).ok_or(Unsupported("its id bound leaves no room"))?;
        let mut fresh = || ids.take();
        let one = fresh();
        let mut out = Vec::with_capacity(words.len() + 16 * body.edits());
        out.extend_from_slice(&words[..HEADER_WORDS]);
        let globals = instructions(&words[..self.functions_at]).expect("read() checked the header");
        for Instruction { opcode, operands } in globals.map_while(Result::ok) {
            match (opcode, operands) {
                (OP_EXECUTION_MODE, &[entry, mode]) if is_conservative_depth(mode) => {
                    push(&mut out, opcode, &[entry, swap_conservative_depth(mode)]);
                }
                _ => push(&mut out, opcode, operands),
            }
        }
        push(&mut out, OP_CONSTANT, &[float, one, 1.0f32.to_bits()]);

        let functions = instructions_at(words, self.functions_at);
        for Instruction { opcode, operands } in functions.map_while(Result::ok) {
            match (opcode, operands) {
                (OP_STORE, &[pointer, value, ..]) if self.frag_depth.contains(&pointer) => {
                    // FragDepth = 1 - value.
                    let reversed = fresh();
                    push(&mut out, OP_F_SUB, &[float, reversed, one, value]);
                    let mut store = operands.to_vec();
                    store[1] = reversed;
                    push(&mut out, opcode, &store);
                }
                (OP_LOAD, &[ty, result, pointer, ..]) if body.z_pointers.contains(&pointer) => {
                    // result = 1 - (the value read).
                    let read = fresh();
                    let mut load = operands.to_vec();
                    load[1] = read;
                    push(&mut out, opcode, &load);
                    push(&mut out, OP_F_SUB, &[ty, result, one, read]);
                }
                (OP_LOAD, &[ty, result, ..]) if body.z_read_loads.contains(&result) => {
                    // result = the vector read with its z replaced by 1 - z.
                    let (read, z, reversed) = (fresh(), fresh(), fresh());
                    let mut load = operands.to_vec();
                    load[1] = read;
                    push(&mut out, opcode, &load);
                    push(&mut out, OP_COMPOSITE_EXTRACT, &[float, z, read, Z]);
                    push(&mut out, OP_F_SUB, &[float, reversed, one, z]);
                    push(
                        &mut out,
                        OP_COMPOSITE_INSERT,
                        &[ty, result, reversed, read, Z],
                    );
                }
                _ => push(&mut out, opcode, operands),
            }
        }
        out[3] = ids.bound();
        Ok(Some(out))
    }
}

/// What the function bodies do with the depth built-ins.
#[derive(Debug, Default)]
struct Body {
    /// Stores to `FragDepth`.
    depth_stores: usize,
    /// Pointers to `FragCoord.z` (access chains with the constant index 2).
    z_pointers: HashSet<u32>,
    /// Loads through those pointers.
    z_pointer_loads: usize,
    /// Loads of the whole `FragCoord` whose z component may be used.
    z_read_loads: HashSet<u32>,
}

impl Body {
    /// Reads the instructions from the first `OpFunction` on. Every use of a depth built-in
    /// must be one the rewrite handles: a store to `FragDepth`, a load of `FragCoord` or of an
    /// access chain into it with a constant index.
    fn read(module: &Module, words: &[u32]) -> Result<Body, Unsupported> {
        let all = || instructions_at(words, module.functions_at).map_while(Result::ok);
        let mut body = Body::default();
        // Pass 1: the pointers into FragCoord and the loads of it.
        let mut coord_loads = HashSet::new();
        let mut other_coord_pointers = HashSet::new();
        for Instruction { opcode, operands } in all() {
            match (opcode, operands) {
                (OP_ACCESS_CHAIN | OP_IN_BOUNDS_ACCESS_CHAIN, &[_, result, base, index])
                    if module.frag_coord.contains(&base) =>
                {
                    match module.int_constants.get(&index) {
                        Some(&Z) => {
                            body.z_pointers.insert(result);
                        }
                        Some(_) => {
                            other_coord_pointers.insert(result);
                        }
                        None => return Err(Unsupported("FragCoord is indexed dynamically")),
                    }
                }
                (OP_LOAD, &[_, result, pointer, ..]) if module.frag_coord.contains(&pointer) => {
                    coord_loads.insert(result);
                }
                _ => {}
            }
        }
        // Pass 2: every use of a tracked id is one of the handled forms.
        for Instruction { opcode, operands } in all() {
            let ids_of = || {
                operands
                    .iter()
                    .enumerate()
                    .filter(|&(index, _)| !is_literal(opcode, index))
                    .map(|(_, word)| word)
            };
            let uses = |ids: &HashSet<u32>| ids_of().any(|word| ids.contains(word));
            match (opcode, operands) {
                (OP_LINE | OP_NO_LINE, _) => {}
                (OP_STORE, &[pointer, ..]) if module.frag_depth.contains(&pointer) => {
                    body.depth_stores += 1;
                }
                (OP_ACCESS_CHAIN | OP_IN_BOUNDS_ACCESS_CHAIN, &[_, _, base, _])
                    if module.frag_coord.contains(&base) => {}
                (OP_LOAD, &[_, _, pointer, ..]) if module.frag_coord.contains(&pointer) => {}
                (OP_LOAD, &[_, _, pointer, ..]) if other_coord_pointers.contains(&pointer) => {}
                (OP_LOAD, &[_, _, pointer, ..]) if body.z_pointers.contains(&pointer) => {
                    body.z_pointer_loads += 1;
                }
                (OP_COMPOSITE_EXTRACT, &[_, _, composite, index])
                    if coord_loads.contains(&composite) =>
                {
                    if index == Z {
                        body.z_read_loads.insert(composite);
                    }
                }
                (OP_VECTOR_SHUFFLE, &[_, _, first, second, ref components @ ..])
                    if coord_loads.contains(&first) || coord_loads.contains(&second) =>
                {
                    // Components 0-3 select from the first vector; the second's are counted
                    // after the first's, whose size is known only when it is FragCoord too.
                    if coord_loads.contains(&first) && components.contains(&Z) {
                        body.z_read_loads.insert(first);
                    }
                    if coord_loads.contains(&second) {
                        if coord_loads.contains(&first) && !components.contains(&(4 + Z)) {
                            continue;
                        }
                        body.z_read_loads.insert(second);
                    }
                }
                _ if uses(&module.frag_depth)
                    || uses(&module.frag_coord)
                    || uses(&body.z_pointers)
                    || uses(&other_coord_pointers) =>
                {
                    return Err(Unsupported(
                        "a depth built-in is used other than by a load or a store",
                    ));
                }
                _ => {
                    // Any other use of a loaded FragCoord may read its z.
                    for word in ids_of() {
                        if coord_loads.contains(word) {
                            body.z_read_loads.insert(*word);
                        }
                    }
                }
            }
        }
        Ok(body)
    }

    fn edits(&self) -> usize {
        self.depth_stores + self.z_pointer_loads + self.z_read_loads.len()
    }

    fn changes_anything(&self) -> bool {
        self.edits() > 0
    }
}

fn is_conservative_depth(mode: u32) -> bool {
    matches!(
        mode,
        EXECUTION_MODE_DEPTH_GREATER | EXECUTION_MODE_DEPTH_LESS
    )
}

/// A shader that promises its depth is only pushed back (`DepthGreater`) pushes it toward
/// smaller values once reversed (`DepthLess`), and the other way round.
fn swap_conservative_depth(mode: u32) -> u32 {
    match mode {
        EXECUTION_MODE_DEPTH_GREATER => EXECUTION_MODE_DEPTH_LESS,
        _ => EXECUTION_MODE_DEPTH_GREATER,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shader::test_spirv;
    use proptest::prelude::*;
    use spirv_tools::val::{self, Validator as _};
    use spirv_tools::TargetEnv;

    /// A fragment shader in SPIR-V assembly: FragCoord, FragDepth and a color output, with
    /// `body` as the entry point's only block and `modes` as extra execution modes.
    fn assemble(modes: &str, body: &str) -> Vec<u32> {
        let text = format!(
            "OpCapability Shader
             OpMemoryModel Logical GLSL450
             OpEntryPoint Fragment %main \"main\" %coord %depth %color
             OpExecutionMode %main OriginUpperLeft
             OpExecutionMode %main DepthReplacing
             {modes}
             OpDecorate %coord BuiltIn FragCoord
             OpDecorate %depth BuiltIn FragDepth
             OpDecorate %color Location 0
             %void = OpTypeVoid
             %fn = OpTypeFunction %void
             %float = OpTypeFloat 32
             %v4 = OpTypeVector %float 4
             %int = OpTypeInt 32 1
             %int_2 = OpConstant %int 2
             %int_1 = OpConstant %int 1
             %spec = OpSpecConstant %int 2
             %half = OpConstant %float 0.5
             %quarter = OpConstant %float 0.25
             %pin_v4 = OpTypePointer Input %v4
             %pin_f = OpTypePointer Input %float
             %pout_f = OpTypePointer Output %float
             %pout_v4 = OpTypePointer Output %v4
             %coord = OpVariable %pin_v4 Input
             %depth = OpVariable %pout_f Output
             %color = OpVariable %pout_v4 Output
             %main = OpFunction %void None %fn
             %entry = OpLabel
             {body}
             OpReturn
             OpFunctionEnd"
        );
        test_spirv::assemble(&text)
    }

    /// Compiles a GLSL fragment shader with naga, as the tester's shaders are.
    fn compile_glsl(source: &str) -> Vec<u32> {
        test_spirv::compile_glsl(naga::ShaderStage::Fragment, source)
    }

    fn validate(words: &[u32]) {
        val::create(Some(TargetEnv::Vulkan_1_1))
            .validate(words, None)
            .unwrap_or_else(|e| panic!("spirv-val rejects the rewritten module: {e}"));
    }

    /// Rewrites `words`, which must need it, and checks the result validates.
    fn reversed(words: &[u32]) -> Vec<u32> {
        let out = reverse_fragment_depth(words)
            .expect("rewritable")
            .expect("needs the rewrite");
        validate(&out);
        out
    }

    /// A value of the evaluator below.
    #[derive(Clone, Debug, PartialEq)]
    enum Value {
        Float(f32),
        Int(u32),
        /// Vectors and structs.
        Composite(Vec<Value>),
        /// A variable, or one component of it.
        Pointer(u32, Option<usize>),
    }

    impl Value {
        fn float(&self) -> f32 {
            match self {
                Value::Float(f) => *f,
                other => panic!("not a float: {other:?}"),
            }
        }

        fn parts(self) -> Vec<Value> {
            match self {
                Value::Composite(parts) => parts,
                other => panic!("not a composite: {other:?}"),
            }
        }
    }

    /// A small evaluator of fragment shaders without control flow but branches and calls
    /// (what naga and hand-written tests produce): loads, stores, access chains, composites
    /// and float arithmetic.
    #[derive(Default)]
    struct Machine<'a> {
        code: Vec<Instruction<'a>>,
        values: HashMap<u32, Value>,
        memory: HashMap<u32, Value>,
        /// Instruction index of each label and function.
        labels: HashMap<u32, usize>,
    }

    impl<'a> Machine<'a> {
        /// Runs the entry point with `FragCoord = frag_coord`; returns what it stored to
        /// `FragDepth` (`None` if nothing).
        fn run(words: &'a [u32], frag_coord: [f32; 4]) -> Option<f32> {
            let mut machine = Machine {
                code: instructions(words).unwrap().map(Result::unwrap).collect(),
                ..Machine::default()
            };
            let (mut coord, mut depth, mut entry) = (0, 0, 0);
            let mut ints = HashSet::new();
            for (index, &Instruction { opcode, operands }) in machine.code.iter().enumerate() {
                match (opcode, operands) {
                    (15, &[_, id, ..]) => entry = id,
                    (OP_DECORATE, &[target, DECORATION_BUILT_IN, BUILT_IN_FRAG_COORD]) => {
                        coord = target
                    }
                    (OP_DECORATE, &[target, DECORATION_BUILT_IN, BUILT_IN_FRAG_DEPTH]) => {
                        depth = target
                    }
                    (OP_TYPE_INT, &[id, ..]) => {
                        ints.insert(id);
                    }
                    (OP_CONSTANT, &[ty, id, bits]) => {
                        let constant = if ints.contains(&ty) {
                            Value::Int(bits)
                        } else {
                            Value::Float(f32::from_bits(bits))
                        };
                        machine.values.insert(id, constant);
                    }
                    // OpConstantNull of a float or vector: zero is all a shader here reads.
                    (46, &[_, id]) => {
                        machine.values.insert(id, Value::Float(0.0));
                    }
                    (OP_VARIABLE, &[_, id, ..]) => {
                        machine.values.insert(id, Value::Pointer(id, None));
                    }
                    // OpLabel, OpFunction.
                    (248, &[id]) | (OP_FUNCTION, &[_, id, ..]) => {
                        machine.labels.insert(id, index);
                    }
                    _ => {}
                }
            }
            let frag_coord = frag_coord.iter().map(|&c| Value::Float(c)).collect();
            machine.memory.insert(coord, Value::Composite(frag_coord));
            machine.call(entry);
            machine.memory.get(&depth).map(Value::float)
        }

        fn call(&mut self, function: u32) {
            let mut at = self.labels[&function] + 1;
            loop {
                let Instruction { opcode, operands } = self.code[at];
                at += 1;
                let value = |id: &u32| self.values[id].clone();
                let result = match (opcode, operands) {
                    // OpReturn.
                    (253, _) => return,
                    // OpBranch.
                    (249, &[label]) => {
                        at = self.labels[&label] + 1;
                        None
                    }
                    // OpFunctionCall without arguments.
                    (57, &[_, _, callee]) => {
                        self.call(callee);
                        None
                    }
                    (OP_ACCESS_CHAIN | OP_IN_BOUNDS_ACCESS_CHAIN, &[_, id, base, index]) => {
                        let (Value::Pointer(var, None), Value::Int(index)) =
                            (value(&base), value(&index))
                        else {
                            panic!("unsupported access chain")
                        };
                        Some((id, Value::Pointer(var, Some(index as usize))))
                    }
                    (OP_LOAD, &[_, id, pointer, ..]) => {
                        let Value::Pointer(var, component) = value(&pointer) else {
                            panic!("load of a non-pointer")
                        };
                        let whole = self.memory[&var].clone();
                        Some((
                            id,
                            match component {
                                Some(c) => whole.parts()[c].clone(),
                                None => whole,
                            },
                        ))
                    }
                    (OP_STORE, &[pointer, object, ..]) => {
                        let Value::Pointer(var, None) = value(&pointer) else {
                            panic!("store through a chain")
                        };
                        self.memory.insert(var, value(&object));
                        None
                    }
                    (OP_COMPOSITE_EXTRACT, &[_, id, composite, index]) => {
                        Some((id, value(&composite).parts()[index as usize].clone()))
                    }
                    (OP_COMPOSITE_INSERT, &[_, id, object, composite, index]) => {
                        let mut parts = value(&composite).parts();
                        parts[index as usize] = value(&object);
                        Some((id, Value::Composite(parts)))
                    }
                    // OpCompositeConstruct.
                    (80, &[_, id, ref parts @ ..]) => {
                        Some((id, Value::Composite(parts.iter().map(value).collect())))
                    }
                    (OP_VECTOR_SHUFFLE, &[_, id, a, b, ref components @ ..]) => {
                        let mut both = value(&a).parts();
                        both.extend(value(&b).parts());
                        let picked = components.iter().map(|&c| both[c as usize].clone());
                        Some((id, Value::Composite(picked.collect())))
                    }
                    // OpFAdd, OpFSub, OpFMul, OpFDiv.
                    (129 | 131 | 133 | 136, &[_, id, a, b]) => {
                        let (a, b) = (value(&a).float(), value(&b).float());
                        let r = match opcode {
                            129 => a + b,
                            131 => a - b,
                            133 => a * b,
                            _ => a / b,
                        };
                        Some((id, Value::Float(r)))
                    }
                    // OpLabel.
                    (248, _) => None,
                    _ => panic!("the evaluator does not know opcode {opcode}"),
                };
                if let Some((id, result)) = result {
                    self.values.insert(id, result);
                }
            }
        }
    }

    /// The rewrite stores 1 - (what the original stores) when `FragCoord.z` holds 1 - z.
    fn check_reversal(original: &[u32], rewritten: &[u32], z: f32) {
        let native = Machine::run(original, [3.5, 7.5, z, 1.0]).expect("stores FragDepth");
        let flipped = Machine::run(rewritten, [3.5, 7.5, 1.0 - z, 1.0]).expect("stores FragDepth");
        assert!(
            ((1.0 - native) - flipped).abs() <= 2.0 * f32::EPSILON,
            "z {z}: native {native}, reversed {flipped}"
        );
    }

    const PUSHED_BACK: &str = "#version 450
        layout(location = 0) out vec4 color;
        void main() {
            color = vec4(gl_FragCoord.xy, 0.0, 1.0);
            gl_FragDepth = 0.5 + 0.5 * gl_FragCoord.z;
        }";

    #[test]
    fn a_compiled_shader_stores_the_reversal_of_what_it_computes() {
        let original = compile_glsl(PUSHED_BACK);
        let rewritten = reversed(&original);
        for z in [0.0, 0.25, 0.5, 0.97, 1.0] {
            check_reversal(&original, &rewritten, z);
        }
    }

    proptest! {
        #[test]
        fn every_depth_is_reversed(z in 0.0f32..=1.0) {
            let original = compile_glsl(PUSHED_BACK);
            let rewritten = reversed(&original);
            check_reversal(&original, &rewritten, z);
        }
    }

    #[test]
    fn a_constant_depth_is_reversed() {
        let original = compile_glsl(
            "#version 450
            void main() { gl_FragDepth = 0.25; }",
        );
        let rewritten = reversed(&original);
        assert_eq!(Machine::run(&rewritten, [0.0, 0.0, 0.5, 1.0]), Some(0.75));
    }

    #[test]
    fn an_access_chain_to_z_is_read_reversed() {
        let original = assemble(
            "",
            "%p = OpAccessChain %pin_f %coord %int_2
             %z = OpLoad %float %p
             %d = OpFMul %float %z %half
             OpStore %depth %d",
        );
        let rewritten = reversed(&original);
        for z in [0.0, 0.3, 1.0] {
            check_reversal(&original, &rewritten, z);
        }
    }

    #[test]
    fn conservative_depth_modes_swap() {
        let modes = |words: &[u32]| -> Vec<u32> {
            instructions(words)
                .unwrap()
                .map(Result::unwrap)
                .filter(|i| i.opcode == OP_EXECUTION_MODE)
                .map(|i| i.operands[1])
                .collect()
        };
        let body = "%p = OpAccessChain %pin_f %coord %int_2
                    %z = OpLoad %float %p
                    %d = OpFAdd %float %z %quarter
                    OpStore %depth %d";
        let greater = reversed(&assemble("OpExecutionMode %main DepthGreater", body));
        assert!(modes(&greater).contains(&EXECUTION_MODE_DEPTH_LESS));
        assert!(!modes(&greater).contains(&EXECUTION_MODE_DEPTH_GREATER));
        let less = reversed(&assemble("OpExecutionMode %main DepthLess", body));
        assert!(modes(&less).contains(&EXECUTION_MODE_DEPTH_GREATER));
    }

    #[test]
    fn shaders_that_do_not_compute_with_depth_need_no_rewrite() {
        // FragCoord read for x and y only, FragDepth declared but never written.
        let xy_only = assemble(
            "",
            "%c = OpLoad %v4 %coord
             %s = OpVectorShuffle %v4 %c %c 0 1 3 3
             %x = OpCompositeExtract %float %c 0
             %p = OpAccessChain %pin_f %coord %int_1
             %y = OpLoad %float %p
             OpStore %color %s",
        );
        assert_eq!(reverse_fragment_depth(&xy_only), Ok(None));
        let glsl = compile_glsl(
            "#version 450
            layout(location = 0) out vec4 color;
            void main() { color = vec4(1.0); }",
        );
        assert_eq!(reverse_fragment_depth(&glsl), Ok(None));
        assert_eq!(reverse_fragment_depth(&[]), Ok(None));
        assert_eq!(reverse_fragment_depth(&[1, 2, 3, 4, 5, 6]), Ok(None));
    }

    #[test]
    fn a_whole_frag_coord_used_beyond_x_and_y_is_read_reversed() {
        // The whole vector is passed on: its z may be read.
        let original = assemble(
            "",
            "%c = OpLoad %v4 %coord
             OpStore %color %c
             %s = OpVectorShuffle %v4 %c %c 2 6 0 1
             %z = OpCompositeExtract %float %s 0
             OpStore %depth %z",
        );
        let rewritten = reversed(&original);
        check_reversal(&original, &rewritten, 0.4);
    }

    #[test]
    fn uses_the_rewrite_cannot_follow_are_refused() {
        let refused = |body: &str| reverse_fragment_depth(&assemble("", body));
        // A specialization constant as the index.
        assert!(refused(
            "%p = OpAccessChain %pin_f %coord %spec
             %z = OpLoad %float %p
             OpStore %depth %z"
        )
        .is_err());
        // FragDepth read back.
        assert!(refused(
            "OpStore %depth %half
             %d = OpLoad %float %depth
             %e = OpFMul %float %d %half
             OpStore %depth %e"
        )
        .is_err());
        // Copied as memory.
        assert!(refused("OpCopyMemory %depth %depth").is_err());
    }

    #[test]
    fn a_literal_equal_to_a_built_ins_id_is_not_a_use() {
        // FragDepth is id 4 (ids go by first appearance), and so is GLSL.std.450's FAbs.
        let text = "OpCapability Shader
             %glsl = OpExtInstImport \"GLSL.std.450\"
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
             %pin_v4 = OpTypePointer Input %v4
             %pout_f = OpTypePointer Output %float
             %coord = OpVariable %pin_v4 Input
             %depth = OpVariable %pout_f Output
             %main = OpFunction %void None %fn
             %entry = OpLabel
             %c = OpLoad %v4 %coord
             %z = OpCompositeExtract %float %c 2
             %p = OpExtInst %float %glsl FAbs %z
             OpStore %depth %p
             OpReturn
             OpFunctionEnd";
        let original = test_spirv::assemble(text);
        let frag_depth = Module::read(&original).unwrap().unwrap().frag_depth;
        assert_eq!(frag_depth, HashSet::from([4]), "FragDepth is id 4");
        reversed(&original);
    }

    #[test]
    fn a_frag_depth_initializer_is_refused() {
        let initialized = test_spirv::assemble(
            "OpCapability Shader
                 OpMemoryModel Logical GLSL450
                 OpEntryPoint Fragment %main \"main\" %depth
                 OpExecutionMode %main OriginUpperLeft
                 OpExecutionMode %main DepthReplacing
                 OpDecorate %depth BuiltIn FragDepth
                 %void = OpTypeVoid
                 %fn = OpTypeFunction %void
                 %float = OpTypeFloat 32
                 %quarter = OpConstant %float 0.25
                 %pout_f = OpTypePointer Output %float
                 %depth = OpVariable %pout_f Output %quarter
                 %main = OpFunction %void None %fn
                 %entry = OpLabel
                 OpReturn
                 OpFunctionEnd",
        );
        assert_eq!(
            reverse_fragment_depth(&initialized),
            Err(Unsupported("FragDepth has an initializer"))
        );
    }

    #[test]
    fn truncated_and_mangled_modules_never_panic() {
        let words = compile_glsl(PUSHED_BACK);
        for cut in 0..words.len() {
            let _ = reverse_fragment_depth(&words[..cut]);
        }
        let mut zeroed = words.clone();
        for i in HEADER_WORDS..zeroed.len() {
            let saved = zeroed[i];
            zeroed[i] = 0;
            let _ = reverse_fragment_depth(&zeroed);
            zeroed[i] = saved;
        }
    }

    proptest! {
        #[test]
        fn arbitrary_words_never_panic(
            body in proptest::collection::vec(any::<u32>(), 0..64),
            flips in proptest::collection::vec((any::<prop::sample::Index>(), any::<u32>()), 0..8),
        ) {
            let mut words = compile_glsl(PUSHED_BACK);
            for (index, value) in flips {
                let at = index.index(words.len());
                if at >= HEADER_WORDS {
                    words[at] = value;
                }
            }
            let _ = reverse_fragment_depth(&words);
            let mut random = words[..HEADER_WORDS].to_vec();
            random.extend(body);
            let _ = reverse_fragment_depth(&random);
        }
    }
}
