//! What the analysis reads straight from the SPIR-V words, without naga: whether a module has
//! push constants at all (the pre-filter that keeps most modules away from naga), and the
//! `RowMajor` / `MatrixStride` member decorations that naga's IR does not keep.

use std::collections::{HashMap, HashSet};

use crate::shader::scan::op::{
    OP_MEMBER_DECORATE, OP_TYPE_ARRAY, OP_TYPE_POINTER, OP_TYPE_RUNTIME_ARRAY, OP_TYPE_STRUCT,
    OP_VARIABLE,
};
use crate::shader::scan::{instructions, Instruction};

/// `StorageClass PushConstant`.
const STORAGE_CLASS_PUSH_CONSTANT: u32 = 9;
/// `Decoration RowMajor`, `Decoration MatrixStride`.
const DECORATION_ROW_MAJOR: u32 = 4;
const DECORATION_MATRIX_STRIDE: u32 = 7;

/// The pre-filter proper: `Err` when the words are not a well-formed instruction stream up to
/// the first push-constant variable (or the end).
pub(super) fn scan_push_constants(words: &[u32]) -> Result<bool, String> {
    let instructions =
        instructions(words).ok_or_else(|| "not a SPIR-V module (bad header)".to_owned())?;
    for instruction in instructions {
        let Instruction { opcode, operands } =
            instruction.map_err(|at| format!("malformed instruction at word {at}"))?;
        if opcode == OP_VARIABLE
            && operands.len() >= 3
            && operands[2] == STORAGE_CLASS_PUSH_CONSTANT
        {
            return Ok(true);
        }
    }
    Ok(false)
}

/// The layout decorations naga's IR does not keep, read straight from the words: for each
/// push-constant variable (in module order, which is also the order of naga's `Immediate`
/// globals), its struct type, and the member types and matrix decorations of every struct.
#[derive(Debug, Default)]
pub(super) struct SpirvLayout {
    /// Pointee type of each push-constant variable, in module order.
    push_constants: Vec<u32>,
    /// `OpTypePointer`: pointer id -> pointee id.
    pointers: HashMap<u32, u32>,
    /// `OpTypeStruct`: struct id -> member type ids.
    structs: HashMap<u32, Vec<u32>>,
    /// `OpTypeArray` / `OpTypeRuntimeArray`: array id -> element id.
    arrays: HashMap<u32, u32>,
    /// `OpMemberDecorate RowMajor` on (struct id, member).
    pub(super) row_major: HashSet<(u32, u32)>,
    /// `OpMemberDecorate MatrixStride` on (struct id, member).
    pub(super) matrix_stride: HashMap<(u32, u32), u32>,
}

impl SpirvLayout {
    /// Scans the words (already checked well-formed enough by naga).
    pub(super) fn scan(words: &[u32]) -> Self {
        let mut layout = Self::default();
        let mut push_pointer_types = Vec::new();
        let all = instructions(words).into_iter().flatten();
        for Instruction { opcode, operands } in all.map_while(Result::ok) {
            match opcode {
                OP_VARIABLE
                    if operands.len() >= 3 && operands[2] == STORAGE_CLASS_PUSH_CONSTANT =>
                {
                    push_pointer_types.push(operands[0]);
                }
                OP_TYPE_POINTER if operands.len() == 3 => {
                    layout.pointers.insert(operands[0], operands[2]);
                }
                OP_TYPE_STRUCT if !operands.is_empty() => {
                    layout.structs.insert(operands[0], operands[1..].to_vec());
                }
                OP_TYPE_ARRAY | OP_TYPE_RUNTIME_ARRAY if operands.len() >= 2 => {
                    layout.arrays.insert(operands[0], operands[1]);
                }
                OP_MEMBER_DECORATE if operands.len() >= 3 => {
                    let key = (operands[0], operands[1]);
                    match operands[2] {
                        DECORATION_ROW_MAJOR => {
                            layout.row_major.insert(key);
                        }
                        DECORATION_MATRIX_STRIDE if operands.len() >= 4 => {
                            layout.matrix_stride.insert(key, operands[3]);
                        }
                        _ => {}
                    }
                }
                _ => {}
            }
        }
        layout.push_constants = push_pointer_types
            .iter()
            .filter_map(|pointer| layout.pointers.get(pointer).copied())
            .collect();
        layout
    }

    /// The (struct id, member) whose decorations apply to the matrix at `path` in the
    /// `ordinal`-th push-constant variable: the last struct member on the path.
    pub(super) fn member(&self, ordinal: usize, path: &[u32]) -> Option<(u32, u32)> {
        let mut ty = *self.push_constants.get(ordinal)?;
        let mut member = None;
        for &index in path {
            if let Some(members) = self.structs.get(&ty) {
                member = Some((ty, index));
                ty = *members.get(index as usize)?;
            } else {
                ty = *self.arrays.get(&ty)?;
            }
        }
        member
    }
}
