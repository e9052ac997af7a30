//! `Position` written by `OpCopyMemory` from a register, as Wine's vkd3d-shader writes a
//! vertex shader's output (`OpCopyMemory %o0 %r0`: the output register's variable copied into
//! the `BuiltIn Position` output), turned into the load and store it is, which the rewrite and
//! the derived range's trace follow. Word manipulation only; anything but the plain form
//! (a whole `vec4` output decorated `BuiltIn Position`, a source pointing to the same `vec4`
//! type, no memory operands) is left as it is, and refused downstream.

use std::borrow::Cow;
use std::collections::{HashMap, HashSet};

use crate::shader::scan::op::*;
use crate::shader::scan::{instructions, push, HEADER_WORDS};

const DECORATION_BUILT_IN: u32 = 11;
const BUILT_IN_POSITION: u32 = 0;

/// `words` with every plain `OpCopyMemory %position %source` replaced by
/// `%fresh = OpLoad %vec4 %source` and `OpStore %position %fresh` (the id bound grows by one
/// per copy); borrowed as they are where there is none, or where the words do not parse.
pub(super) fn position_copies_as_stores(words: &[u32]) -> Cow<'_, [u32]> {
    let Some(found) = plain_copies(words) else {
        return Cow::Borrowed(words);
    };
    if found.is_empty() {
        return Cow::Borrowed(words);
    }
    let mut out = Vec::with_capacity(words.len() + 3 * found.len());
    out.extend_from_slice(&words[..HEADER_WORDS]);
    let mut bound = words[3];
    let mut at = HEADER_WORDS;
    let Some(walk) = instructions(words) else {
        return Cow::Borrowed(words);
    };
    for instruction in walk {
        let Ok(instruction) = instruction else {
            return Cow::Borrowed(words);
        };
        let length = instruction.operands.len() + 1;
        match found.get(&at) {
            Some(&(vec4, target, source)) => {
                let fresh = bound;
                bound += 1;
                push(&mut out, OP_LOAD, &[vec4, fresh, source]);
                push(&mut out, OP_STORE, &[target, fresh]);
            }
            None => out.extend_from_slice(&words[at..at + length]),
        }
        at += length;
    }
    out[3] = bound;
    Cow::Owned(out)
}

/// The plain copies into `Position` by word index: (the `vec4` type, the target, the source).
/// `None` where the words do not parse.
fn plain_copies(words: &[u32]) -> Option<HashMap<usize, (u32, u32, u32)>> {
    let mut positions: HashSet<u32> = HashSet::new();
    let mut pointees: HashMap<u32, u32> = HashMap::new();
    let mut pointer_types: HashMap<u32, u32> = HashMap::new();
    let mut vec4s: HashSet<u32> = HashSet::new();
    let mut copies: Vec<(usize, u32, u32)> = Vec::new();
    let mut at = HEADER_WORDS;
    for instruction in instructions(words)? {
        let instruction = instruction.ok()?;
        match (instruction.opcode, instruction.operands) {
            (OP_DECORATE, &[id, DECORATION_BUILT_IN, BUILT_IN_POSITION]) => {
                positions.insert(id);
            }
            (OP_TYPE_POINTER, &[id, _, pointee]) => {
                pointees.insert(id, pointee);
            }
            (OP_VARIABLE | OP_ACCESS_CHAIN | OP_IN_BOUNDS_ACCESS_CHAIN, &[ty, id, ..]) => {
                pointer_types.insert(id, ty);
            }
            (OP_TYPE_VECTOR, &[id, _, 4]) => {
                vec4s.insert(id);
            }
            (OP_COPY_MEMORY, &[target, source]) => copies.push((at, target, source)),
            _ => {}
        }
        at += instruction.operands.len() + 1;
    }
    let pointee = |id: u32| pointees.get(pointer_types.get(&id)?).copied();
    Some(
        copies
            .into_iter()
            .filter(|&(_, target, _)| positions.contains(&target))
            .filter_map(|(at, target, source)| {
                let vec4 = pointee(target).filter(|ty| vec4s.contains(ty))?;
                (pointee(source)? == vec4).then_some((at, (vec4, target, source)))
            })
            .collect(),
    )
}
