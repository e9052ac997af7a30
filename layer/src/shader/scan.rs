//! The one instruction walker ([`instructions`]) every word scan in the layer uses, the copy
//! of a module the shader analysis reads ([`for_analysis`]), and the opcodes and operand rules
//! the word-level rewriters share ([`op`], [`is_literal`], [`push`]). Cheap facts read straight
//! from SPIR-V words, without parsing the module.

/// `OpExtension`, `OpExtInstImport`, `OpExtInst`, `OpCapability`.
const OP_EXTENSION: u32 = 10;
const OP_EXT_INST_IMPORT: u32 = 11;
const OP_EXT_INST: u32 = 12;
const OP_CAPABILITY: u32 = 17;
/// `Capability Shader`.
const CAPABILITY_SHADER: u32 = 1;
/// The SPIR-V magic number (first word of every module).
pub const MAGIC: u32 = 0x0723_0203;
/// Words in a module header.
pub const HEADER_WORDS: usize = 5;

/// One instruction of a module: its opcode and the words after the opcode word.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Instruction<'a> {
    pub opcode: u32,
    pub operands: &'a [u32],
}

/// The instructions of a module after its header, in order. Yields `Err(word index)` once, at
/// the first malformed instruction (a zero word count, or one running past the end), and
/// then stops: a scan never reads past the end of the words.
#[derive(Clone, Debug)]
pub struct Instructions<'a> {
    words: &'a [u32],
    at: usize,
}

/// Walks the instructions of `words`; `None` when the words do not start with a SPIR-V
/// header.
pub fn instructions(words: &[u32]) -> Option<Instructions<'_>> {
    (words.len() >= HEADER_WORDS && words[0] == MAGIC).then(|| instructions_at(words, HEADER_WORDS))
}

/// The execution models of the stages whose `Position` revz rewrites: vertex, tessellation
/// evaluation, geometry and mesh (what can be the last pre-rasterization stage; NVIDIA's
/// mesh shaders are not rewritten).
pub mod model {
    pub const VERTEX: u32 = 0;
    pub const TESSELLATION_CONTROL: u32 = 1;
    pub const TESSELLATION_EVALUATION: u32 = 2;
    pub const GEOMETRY: u32 = 3;
    /// `MeshEXT` (`VK_EXT_mesh_shader`).
    pub const MESH_EXT: u32 = 5365;
}

/// Whether `words` declare an entry point of the vertex stage (`OpEntryPoint Vertex`): only
/// such modules are parsed for a projection in push constants (naga reads no tessellation or
/// geometry stage). Malformed words answer `true`, so the analysis that follows reports them.
pub fn declares_vertex_entry_point(words: &[u32]) -> bool {
    declares_entry_point(words, |m| m == model::VERTEX)
}

/// Whether `words` declare an entry point of the geometry stage. Malformed words answer `true`
/// (what follows reads them and says so).
pub fn declares_geometry_entry_point(words: &[u32]) -> bool {
    declares_entry_point(words, |m| m == model::GEOMETRY)
}

/// Whether `words` declare an entry point of a tessellation stage (control or evaluation).
/// Malformed words answer `true` (what follows reads them and says so).
pub fn declares_tessellation_entry_point(words: &[u32]) -> bool {
    declares_entry_point(words, |m| {
        matches!(
            m,
            model::TESSELLATION_CONTROL | model::TESSELLATION_EVALUATION
        )
    })
}

/// Whether `words` declare an entry point of a stage whose `Position` revz rewrites
/// ([`model`]): vertex, tessellation evaluation, geometry or mesh. Malformed words answer
/// `true`, so the analysis or rewrite that follows reports them.
pub fn declares_position_stage_entry_point(words: &[u32]) -> bool {
    declares_entry_point(words, |m| {
        matches!(
            m,
            model::VERTEX | model::TESSELLATION_EVALUATION | model::GEOMETRY | model::MESH_EXT
        )
    })
}

fn declares_entry_point(words: &[u32], wanted: impl Fn(u32) -> bool) -> bool {
    const OP_EXTENSION: u32 = 10;
    const OP_EXT_INST_IMPORT: u32 = 11;
    const OP_MEMORY_MODEL: u32 = 14;
    const OP_CAPABILITY: u32 = 17;
    let Some(instructions) = instructions(words) else {
        return true;
    };
    for instruction in instructions {
        let Ok(instruction) = instruction else {
            return true;
        };
        match instruction.opcode {
            op::OP_ENTRY_POINT if instruction.operands.first().is_some_and(|&m| wanted(m)) => {
                return true
            }
            // Only capabilities, extensions, imports and the memory model come before the
            // entry points, and everything else after them (SPIR-V 2.4, logical layout).
            op::OP_ENTRY_POINT
            | OP_CAPABILITY
            | OP_EXTENSION
            | OP_EXT_INST_IMPORT
            | OP_MEMORY_MODEL => {}
            _ => return false,
        }
    }
    false
}

/// Walks the instructions of `words` from word `at` on, which must be where an instruction
/// starts (the header already checked).
pub fn instructions_at(words: &[u32], at: usize) -> Instructions<'_> {
    Instructions { words, at }
}

impl<'a> Iterator for Instructions<'a> {
    type Item = Result<Instruction<'a>, usize>;

    fn next(&mut self) -> Option<Self::Item> {
        let at = self.at;
        let first = *self.words.get(at)?;
        let count = (first >> 16) as usize;
        if count == 0 || at + count > self.words.len() {
            self.at = self.words.len();
            return Some(Err(at));
        }
        self.at += count;
        Some(Ok(Instruction {
            opcode: first & 0xffff,
            operands: &self.words[at + 1..at + count],
        }))
    }
}

/// A copy of a module with what the shader analysis never needs removed, so that naga reads
/// modules it would otherwise reject (`shared/DESIGN.md` section 2: Slang's `DrawParameters`,
/// `NonSemantic.DebugPrintf`, extensions naga does not list): every `OpCapability` but
/// `Shader`, every `OpExtension`, and the non-semantic instruction sets with their
/// `OpExtInst`s (non-semantic results are never operands of semantic instructions). The data
/// flow into `Position` is untouched. `None` when there is nothing to remove or the words are
/// not well-formed (the analysis then sees the module as it is). The module the driver gets is
/// never changed.
pub fn for_analysis(words: &[u32]) -> Option<Vec<u32>> {
    let mut non_semantic = Vec::new();
    let mut removed = false;
    let mut out = words.get(..HEADER_WORDS)?.to_vec();
    for instruction in instructions(words)? {
        let Instruction { opcode, operands } = instruction.ok()?;
        let remove = match opcode {
            OP_CAPABILITY => operands.first() != Some(&CAPABILITY_SHADER),
            OP_EXTENSION => true,
            OP_EXT_INST_IMPORT => {
                let name: Vec<u8> = operands
                    .iter()
                    .skip(1)
                    .flat_map(|w| w.to_le_bytes())
                    .take_while(|&b| b != 0)
                    .collect();
                let is_non_semantic = name.starts_with(b"NonSemantic.");
                if is_non_semantic {
                    non_semantic.extend(operands.first().copied());
                }
                is_non_semantic
            }
            OP_EXT_INST => operands
                .get(2)
                .is_some_and(|set| non_semantic.contains(set)),
            _ => false,
        };
        if remove {
            removed = true;
        } else {
            out.push(((operands.len() as u32 + 1) << 16) | opcode);
            out.extend_from_slice(operands);
        }
    }
    removed.then_some(out)
}

/// The opcodes the word-level rewriters ([`crate::shader::fragment_depth`], [`crate::shader::position_store`])
/// read and write (SPIR-V specification, section 3.52).
pub mod op {
    pub const OP_NAME: u32 = 5;
    pub const OP_MEMBER_NAME: u32 = 6;
    pub const OP_LINE: u32 = 8;
    pub const OP_EXT_INST_IMPORT: u32 = 11;
    pub const OP_EXT_INST: u32 = 12;
    pub const OP_ENTRY_POINT: u32 = 15;
    pub const OP_EXECUTION_MODE: u32 = 16;
    pub const OP_TYPE_INT: u32 = 21;
    pub const OP_TYPE_FLOAT: u32 = 22;
    pub const OP_TYPE_VECTOR: u32 = 23;
    pub const OP_TYPE_MATRIX: u32 = 24;
    pub const OP_TYPE_ARRAY: u32 = 28;
    pub const OP_TYPE_RUNTIME_ARRAY: u32 = 29;
    pub const OP_TYPE_STRUCT: u32 = 30;
    pub const OP_TYPE_POINTER: u32 = 32;
    pub const OP_CONSTANT: u32 = 43;
    pub const OP_FUNCTION: u32 = 54;
    pub const OP_FUNCTION_CALL: u32 = 57;
    pub const OP_VARIABLE: u32 = 59;
    pub const OP_LOAD: u32 = 61;
    pub const OP_STORE: u32 = 62;
    pub const OP_COPY_MEMORY: u32 = 63;
    pub const OP_ACCESS_CHAIN: u32 = 65;
    pub const OP_IN_BOUNDS_ACCESS_CHAIN: u32 = 66;
    pub const OP_DECORATE: u32 = 71;
    pub const OP_MEMBER_DECORATE: u32 = 72;
    pub const OP_VECTOR_SHUFFLE: u32 = 79;
    pub const OP_COMPOSITE_EXTRACT: u32 = 81;
    pub const OP_COMPOSITE_INSERT: u32 = 82;
    pub const OP_COPY_OBJECT: u32 = 83;
    pub const OP_F_ADD: u32 = 129;
    pub const OP_F_SUB: u32 = 131;
    pub const OP_F_MUL: u32 = 133;
    pub const OP_LOOP_MERGE: u32 = 246;
    pub const OP_SELECTION_MERGE: u32 = 247;
    pub const OP_SWITCH: u32 = 251;
    pub const OP_RETURN: u32 = 253;
    pub const OP_EMIT_VERTEX: u32 = 218;
    pub const OP_EMIT_STREAM_VERTEX: u32 = 220;
    pub const OP_NO_LINE: u32 = 317;
}

/// Whether operand `index` of an instruction in a function body is a literal rather than an
/// id, for the instructions whose literals could otherwise be taken for a tracked id (a
/// GLSL.std.450 instruction number, a composite index, a memory operand, a switch case, a
/// constant's value, a storage class, a function control mask). Others count every operand as a possible id: a false match refuses a
/// module, never rewrites it wrongly.
pub fn is_literal(opcode: u32, index: usize) -> bool {
    use op::*;
    match opcode {
        OP_NAME | OP_MEMBER_NAME => true,
        OP_EXT_INST => index == 3,
        OP_LOAD | OP_COMPOSITE_EXTRACT => index >= 3,
        OP_STORE | OP_COPY_MEMORY => index >= 2,
        OP_COMPOSITE_INSERT | OP_VECTOR_SHUFFLE => index >= 4,
        OP_SELECTION_MERGE => index >= 1,
        OP_LOOP_MERGE => index >= 2,
        // Selector, default, then (literal, label) pairs.
        OP_SWITCH => index >= 2 && index % 2 == 0,
        OP_CONSTANT => index >= 2,
        // A variable's storage class; a function's control mask.
        OP_VARIABLE | OP_FUNCTION => index == 2,
        _ => false,
    }
}

/// Ids past a module's bound, handed out one at a time by the word-level rewriters; the new
/// bound goes into the rewritten header once every id is taken ([`FreshIds::bound`]).
#[derive(Debug)]
pub struct FreshIds {
    next: u32,
}

impl FreshIds {
    /// Room for `needed` ids past the bound of `words` (whose header was read), or `None`
    /// where the bound would overflow.
    pub fn new(words: &[u32], needed: usize) -> Option<FreshIds> {
        let bound = *words.get(3)?;
        u32::try_from(needed)
            .ok()
            .and_then(|needed| bound.checked_add(needed))
            .map(|_| FreshIds { next: bound })
    }

    /// The next id. The new bound covers every id taken ([`Self::bound`]); past the largest
    /// id (a rewriter that took more than it reserved, on a module whose bound is near it)
    /// it panics, in release builds too (the panic is caught at the entry point and the
    /// module is left as it is), rather than wrap around to an id the module defines.
    pub fn take(&mut self) -> u32 {
        let id = self.next;
        self.next = id.checked_add(1).expect("the module's ids run out");
        id
    }

    /// The module's bound with every id taken.
    pub fn bound(&self) -> u32 {
        self.next
    }
}

/// The tessellation execution modes a module declares (SPIR-V's `OpExecutionMode`), each
/// category as its mode number: what a tessellation control and evaluation stage may split
/// between them where they are linked, and what an evaluation stage alone must hold unlinked.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TessellationModes {
    /// `Triangles` (22), `Quads` (24) or `Isolines` (25).
    pub subdivision: Option<u32>,
    /// `SpacingEqual` (1), `SpacingFractionalEven` (2) or `SpacingFractionalOdd` (3).
    pub spacing: Option<u32>,
    /// `VertexOrderCw` (4) or `VertexOrderCcw` (5).
    pub order: Option<u32>,
    /// `PointMode` (10).
    pub point_mode: bool,
}

/// The tessellation modes `words` declare; `None` for words that are no SPIR-V module, are
/// malformed, or declare one category twice with different modes (several entry points:
/// which one a shader uses is not looked at).
pub fn tessellation_modes(words: &[u32]) -> Option<TessellationModes> {
    let mut modes = TessellationModes::default();
    let set = |slot: &mut Option<u32>, mode: u32| match *slot {
        Some(old) if old != mode => None,
        _ => {
            *slot = Some(mode);
            Some(())
        }
    };
    for instruction in instructions(words)? {
        let instruction = instruction.ok()?;
        if instruction.opcode != op::OP_EXECUTION_MODE {
            continue;
        }
        let &mode = instruction.operands.get(1)?;
        match mode {
            22 | 24 | 25 => set(&mut modes.subdivision, mode)?,
            1..=3 => set(&mut modes.spacing, mode)?,
            4 | 5 => set(&mut modes.order, mode)?,
            10 => modes.point_mode = true,
            _ => {}
        }
    }
    Some(modes)
}

/// Appends one instruction to `out`.
pub fn push(out: &mut Vec<u32>, opcode: u32, operands: &[u32]) {
    out.push(((operands.len() as u32 + 1) << 16) | opcode);
    out.extend_from_slice(operands);
}

#[cfg(test)]
mod tests {
    use super::*;

    fn module(body: &[u32]) -> Vec<u32> {
        let mut words = vec![MAGIC, 0x0001_0000, 0, 100, 0];
        words.extend_from_slice(body);
        words
    }

    #[test]
    fn tessellation_modes_are_read_per_category() {
        let mode = |entry: u32, mode: u32| [(3 << 16) | op::OP_EXECUTION_MODE, entry, mode];
        let words = module(&[mode(1, 22), mode(1, 1), mode(1, 5), mode(1, 10)].concat());
        assert_eq!(
            tessellation_modes(&words),
            Some(TessellationModes {
                subdivision: Some(22),
                spacing: Some(1),
                order: Some(5),
                point_mode: true,
            })
        );
        // Output vertices (26) and the other modes are no tessellation category.
        let words = module(&[(4 << 16) | op::OP_EXECUTION_MODE, 1, 26, 3]);
        assert_eq!(
            tessellation_modes(&words),
            Some(TessellationModes::default())
        );
        // Two entry points that disagree, malformed words, no module.
        let words = module(&[mode(1, 22), mode(2, 24)].concat());
        assert_eq!(tessellation_modes(&words), None);
        assert_eq!(tessellation_modes(&module(&[0])), None);
        assert_eq!(tessellation_modes(&[1, 2, 3]), None);
        // glslang's: the evaluation stage of the tester's `ubo-tessellation` declares all
        // three categories, its control stage none.
        let glslang = |bytes: &[u8]| crate::shader::test_spirv::words(bytes);
        let words = glslang(include_bytes!("../../../shaders/glslang/ubo.tese.spv"));
        assert_eq!(
            tessellation_modes(&words),
            Some(TessellationModes {
                subdivision: Some(22),
                spacing: Some(1),
                order: Some(5),
                point_mode: false,
            })
        );
        let words = glslang(include_bytes!(
            "../../../shaders/glslang/passthrough.tesc.spv"
        ));
        assert_eq!(
            tessellation_modes(&words),
            Some(TessellationModes::default())
        );
    }

    #[test]
    fn only_modules_with_a_vertex_entry_point_are_analyzed() {
        use crate::shader::test_spirv::compile_glsl;
        use naga::ShaderStage;
        let vertex = compile_glsl(
            ShaderStage::Vertex,
            "#version 450\nvoid main() { gl_Position = vec4(0.0); }",
        );
        let fragment = compile_glsl(
            ShaderStage::Fragment,
            "#version 450\nlayout(location = 0) out vec4 c;\nvoid main() { c = vec4(1.0); }",
        );
        let compute = compile_glsl(
            ShaderStage::Compute,
            "#version 450\nlayout(local_size_x = 1) in;\nvoid main() {}",
        );
        assert!(declares_vertex_entry_point(&vertex));
        assert!(!declares_vertex_entry_point(&fragment));
        assert!(!declares_vertex_entry_point(&compute));
        // Words that are not a module, or break off: the analysis says why.
        assert!(declares_vertex_entry_point(&[1, 2, 3]));
        assert!(declares_vertex_entry_point(&module(&[0x0005_0011])));
    }

    #[test]
    fn malformed_modules_are_not_read_past_their_end() {
        fn walk(words: &[u32]) -> Option<Vec<Result<Instruction<'_>, usize>>> {
            instructions(words).map(Iterator::collect)
        }
        assert_eq!(walk(&[]), None);
        assert_eq!(walk(&[1, 2, 3, 4, 5, 6]), None);
        // An instruction of 9 words with 1 present, and a zero word count: one error each.
        assert_eq!(
            walk(&module(&[(9 << 16) | 71, 7])),
            Some(vec![Err(HEADER_WORDS)])
        );
        assert_eq!(walk(&module(&[0, 0])), Some(vec![Err(HEADER_WORDS)]));
        let name = [(3 << 16) | 5, 7, 0];
        assert_eq!(
            walk(&module(&name)),
            Some(vec![Ok(Instruction {
                opcode: 5,
                operands: &[7, 0]
            })])
        );
    }
}
