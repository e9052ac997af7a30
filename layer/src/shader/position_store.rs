//! Vertex shaders rewritten to store reversed depth into `Position` (issue #14, `shared/DESIGN.md`
//! section 2 as corrected in [`crate::precise`]): the precise path changes the depth where it is
//! made, and nothing else.
//!
//! [`rewrite_position_store`] turns the module's `Position` output into a private variable (the
//! *shadow*) that every load, store and access chain of the shader keeps using unchanged, and
//! adds, before every `OpReturn` of each vertex entry point, one store of the shadow to the
//! real `Position` with its z replaced:
//!
//! ```text
//! Position = (x, y, c_z * z + c_w * w + c_1, w)      (c_z, c_w, c_1) = revz's carrier
//! ```
//!
//! x, y, w and every other output keep the shader's values exactly, and every value the shader
//! computes (lighting from the same matrix, a view vector from `Position` itself) is computed
//! from the application's bytes. The carrier is a `vec4` revz appends to the module's
//! push-constant block at byte [`crate::precise::Carrier::offset`], which revz reserves in every
//! pipeline layout ([`crate::precise::Carrier`]) and pushes per draw: `(0, k', B', 0)` for a
//! reversed projection (`z' = k' w + B'` from the camera's (n, f) in f64, rounded once) and
//! `(1, 0, 0, 0)` on the flip path, where `1 * z + 0 * w + 0` is z exactly, so one rewritten
//! module serves both paths.
//!
//! Word manipulation only, no Vulkan and no full parse. What the rewrite does not recognise (a
//! pointer to `Position` passed to a function, a whole `gl_PerVertex` block stored at once, a
//! dynamic index into the block, more than one push-constant block, a non-vertex entry point)
//! is refused with a reason, never guessed at; the pipeline's draws then take the flip path.

use std::collections::{HashMap, HashSet};
use std::fmt;

use crate::shader::derived_range::{
    self, Fit, Insert, MatrixSource, ModuleFacts, PositionStores, Types,
};
use crate::shader::scan::op::*;
use crate::shader::scan::{instructions, is_literal, push, Instruction, HEADER_WORDS};

const STORAGE_PRIVATE: u32 = 6;
const STORAGE_OUTPUT: u32 = 3;
const STORAGE_PUSH_CONSTANT: u32 = 9;
const DECORATION_BLOCK: u32 = 2;
const DECORATION_ARRAY_STRIDE: u32 = 6;
const DECORATION_MATRIX_STRIDE: u32 = 7;
const DECORATION_BUILT_IN: u32 = 11;
const DECORATION_OFFSET: u32 = 35;
const BUILT_IN_POSITION: u32 = 0;
const EXECUTION_MODEL_VERTEX: u32 = 0;
/// SPIR-V 1.4: entry point interfaces list every global variable they use.
const VERSION_1_4: u32 = 0x0001_0400;

/// Why a vertex module cannot get the `Position` rewrite.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Unsupported(pub &'static str);

impl fmt::Display for Unsupported {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.0)
    }
}

/// The module with its `Position` stores rewritten to read revz's carrier at byte `offset` of
/// the push constants (16-byte aligned), `None` when no vertex entry point outputs `Position`,
/// or why it cannot be rewritten. Never panics, never reads past the words.
pub fn rewrite_position_store(words: &[u32], offset: u32) -> Result<Option<Vec<u32>>, Unsupported> {
    rewrite(words, offset, false).map(|code| code.map(|(code, _)| code))
}

/// [`rewrite_position_store`] for a module whose projection revz cannot read on the CPU: the
/// stage also fits the depth line of the outermost matrix it multiplies into `Position`
/// ([`crate::shader::derived_range`]) and stores reversed depth of that line where the pushed
/// carrier's w selects it (1 complementary, 2 infinite; 0 keeps the pushed carrier, as in
/// [`rewrite_position_store`]). Also says where that matrix comes from.
pub fn rewrite_position_store_deriving(
    words: &[u32],
    offset: u32,
) -> Result<Option<(Vec<u32>, MatrixSource)>, Unsupported> {
    rewrite(words, offset, true)
        .map(|code| code.map(|(code, source)| (code, source.unwrap_or(MatrixSource::Computed))))
}

/// A rewritten module, and the source of the matrix it fits (deriving rewrites).
type Rewritten = (Vec<u32>, Option<MatrixSource>);

fn rewrite(words: &[u32], offset: u32, derive: bool) -> Result<Option<Rewritten>, Unsupported> {
    if offset % 16 != 0 {
        return Err(Unsupported("the carrier offset is not 16-byte aligned"));
    }
    let Some(module) = Module::read(words)? else {
        return Ok(None);
    };
    module.rewrite(words, offset, derive).map(Some)
}

/// Where the shader's `Position` lives.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Position {
    /// A `vec4` output variable decorated `BuiltIn Position` (naga, DXC).
    Variable(u32),
    /// Member `member` of an output block (`gl_PerVertex`, glslang): the block variable.
    Member { block: u32, member: u32 },
}

/// The declarations the rewrite needs, from one pass over the words.
#[derive(Debug, Default)]
struct Module {
    version: u32,
    /// Vertex entry points: the entry function ids. Any other execution model refuses.
    entry_functions: HashSet<u32>,
    /// Ids decorated `BuiltIn Position`, and (struct, member) pairs member-decorated so.
    position_ids: HashSet<u32>,
    position_members: HashMap<u32, u32>,
    /// 32-bit float types.
    floats: HashSet<u32>,
    /// (component, count) of vector types.
    vectors: HashMap<u32, (u32, u32)>,
    /// 32-bit int types (signedness).
    ints: Vec<(u32, u32)>,
    /// Pointer types: id -> (storage class, pointee), and the reverse.
    pointers: HashMap<u32, (u32, u32)>,
    pointer_of: HashMap<(u32, u32), u32>,
    /// Struct types and their member types.
    structs: HashMap<u32, Vec<u32>>,
    /// Matrix and array types (element or column type, count id or count).
    matrices: HashMap<u32, (u32, u32)>,
    arrays: HashMap<u32, (u32, u32)>,
    /// Int constants (id -> value).
    int_constants: HashMap<u32, u32>,
    /// Global variables: id -> (pointer type, storage class).
    variables: HashMap<u32, (u32, u32)>,
    /// Member decorations: (struct, member) -> Offset / MatrixStride; type -> ArrayStride.
    member_offsets: HashMap<(u32, u32), u32>,
    member_matrix_strides: HashMap<(u32, u32), u32>,
    array_strides: HashMap<u32, u32>,
    /// Where each id is declared (word index), for declaration-order checks.
    declared_at: HashMap<u32, usize>,
    /// Word index of the first `OpFunction`.
    functions_at: usize,
    /// Word index of the first annotation (`OpDecorate`-family): where revz's decorations go
    /// (a module with a `Position` output has at least its `BuiltIn` one).
    annotations_at: Option<usize>,
    /// Every operand of type declarations that names a type (to find where a struct is used).
    type_uses: Vec<u32>,
    /// Constant composites and null constants outside functions: id -> (opcode, type), for a
    /// constant matrix the derived range fits (`crate::shader::derived_range`).
    global_opcodes: HashMap<u32, u32>,
    global_types: HashMap<u32, u32>,
    /// `OpTypeBool`, if declared.
    bool_type: Option<u32>,
    /// Types decorated `BufferBlock`.
    buffer_blocks: HashSet<u32>,
    /// 32-bit constants whose word is the bits of 1.0 (`crate::shader::derived_range`'s w = 1 test).
    ones: HashSet<u32>,
}

impl Module {
    fn read(words: &[u32]) -> Result<Option<Module>, Unsupported> {
        let Some(all) = instructions(words) else {
            return Ok(None);
        };
        let mut m = Module {
            version: words[1],
            ..Module::default()
        };
        let mut word = HEADER_WORDS;
        for instruction in all {
            let Instruction { opcode, operands } =
                instruction.map_err(|_| Unsupported("a malformed instruction"))?;
            let at = word;
            word += operands.len() + 1;
            if m.functions_at != 0 {
                continue;
            }
            if matches!(opcode, OP_DECORATE | OP_MEMBER_DECORATE) && m.annotations_at.is_none() {
                m.annotations_at = Some(at);
            }
            match (opcode, operands) {
                (OP_ENTRY_POINT, &[model, function, ..]) => {
                    if model != EXECUTION_MODEL_VERTEX {
                        return Err(Unsupported("the module has a non-vertex entry point"));
                    }
                    m.entry_functions.insert(function);
                }
                (OP_DECORATE, &[target, DECORATION_BUILT_IN, BUILT_IN_POSITION]) => {
                    m.position_ids.insert(target);
                }
                (OP_DECORATE, &[target, DECORATION_ARRAY_STRIDE, stride]) => {
                    m.array_strides.insert(target, stride);
                }
                (OP_MEMBER_DECORATE, &[ty, member, DECORATION_BUILT_IN, BUILT_IN_POSITION]) => {
                    m.position_members.insert(ty, member);
                }
                (OP_MEMBER_DECORATE, &[ty, member, DECORATION_OFFSET, offset]) => {
                    m.member_offsets.insert((ty, member), offset);
                }
                (OP_MEMBER_DECORATE, &[ty, member, DECORATION_MATRIX_STRIDE, stride]) => {
                    m.member_matrix_strides.insert((ty, member), stride);
                }
                (OP_TYPE_FLOAT, &[id, 32, ..]) => {
                    m.floats.insert(id);
                }
                (OP_TYPE_INT, &[id, 32, signed]) => m.ints.push((id, signed)),
                (OP_TYPE_VECTOR, &[id, component, count]) => {
                    m.vectors.insert(id, (component, count));
                    m.type_uses.push(component);
                }
                (OP_TYPE_MATRIX, &[id, column, count]) => {
                    m.matrices.insert(id, (column, count));
                    m.type_uses.push(column);
                }
                (OP_TYPE_ARRAY, &[id, element, length]) => {
                    m.arrays.insert(id, (element, length));
                    m.type_uses.push(element);
                }
                (OP_TYPE_RUNTIME_ARRAY, &[_, element]) => m.type_uses.push(element),
                (OP_TYPE_STRUCT, &[id, ref members @ ..]) => {
                    m.structs.insert(id, members.to_vec());
                    m.type_uses.extend_from_slice(members);
                }
                (OP_TYPE_POINTER, &[id, class, pointee]) => {
                    m.pointers.insert(id, (class, pointee));
                    m.pointer_of.entry((class, pointee)).or_insert(id);
                }
                (OP_CONSTANT, &[ty, id, value]) => {
                    if m.ints.iter().any(|&(t, _)| t == ty) {
                        m.int_constants.insert(id, value);
                    }
                    if value == 1.0f32.to_bits() {
                        m.ones.insert(id);
                    }
                }
                (OP_VARIABLE, &[ty, id, class, ..]) => {
                    m.variables.insert(id, (ty, class));
                }
                (derived_range::TYPE_BOOL, &[id]) => m.bool_type = Some(id),
                (OP_DECORATE, &[target, derived_range::BUFFER_BLOCK]) => {
                    m.buffer_blocks.insert(target);
                }
                (opcode, &[ty, id, ..]) if derived_range::is_matrix_constant(opcode) => {
                    m.global_opcodes.insert(id, opcode);
                    m.global_types.insert(id, ty);
                }
                (OP_FUNCTION, _) => m.functions_at = at,
                _ => {}
            }
            if let Some(&id) = result_id(opcode, operands) {
                m.declared_at.insert(id, at);
            }
        }
        if m.functions_at == 0 || m.entry_functions.is_empty() {
            return Ok(None);
        }
        Ok(Some(m))
    }

    /// The `Position` of the vertex entry points.
    fn position(&self) -> Result<Option<Position>, Unsupported> {
        let mut found = None;
        for (&id, &(ty, class)) in &self.variables {
            if class != STORAGE_OUTPUT {
                continue;
            }
            let Some(&(_, pointee)) = self.pointers.get(&ty) else {
                continue;
            };
            let this = if self.position_ids.contains(&id) {
                Position::Variable(id)
            } else if let Some(&member) = self.position_members.get(&pointee) {
                Position::Member { block: id, member }
            } else {
                continue;
            };
            if found.is_some() {
                return Err(Unsupported("more than one Position output"));
            }
            found = Some(this);
        }
        Ok(found)
    }

    /// The float type of a 4-vector type.
    fn vec4_float(&self, vector: u32) -> Option<u32> {
        match self.vectors.get(&vector) {
            Some(&(float, 4)) if self.floats.contains(&float) => Some(float),
            _ => None,
        }
    }

    /// The byte size of a push-constant member type, where the layout rules make it plain
    /// (`depth` bounds the recursion on malformed modules).
    fn size_of(&self, ty: u32, matrix_stride: Option<u32>, depth: u32) -> Option<u32> {
        if depth > 16 {
            return None;
        }
        if self.floats.contains(&ty) || self.ints.iter().any(|&(t, _)| t == ty) {
            return Some(4);
        }
        if let Some(&(component, count)) = self.vectors.get(&ty) {
            return self.size_of(component, None, depth + 1)?.checked_mul(count);
        }
        if let Some(&(column, count)) = self.matrices.get(&ty) {
            let column_size = self.size_of(column, None, depth + 1)?;
            let stride = matrix_stride?;
            // Column-major: `count` columns `stride` apart; row-major is at most as large.
            return stride
                .checked_mul(count.checked_sub(1)?)?
                .checked_add(column_size.max(stride));
        }
        if let Some(&(_, length)) = self.arrays.get(&ty) {
            let length = *self.int_constants.get(&length)?;
            return self.array_strides.get(&ty)?.checked_mul(length);
        }
        if let Some(members) = self.structs.get(&ty) {
            let mut end = 0u32;
            for (index, &member) in members.iter().enumerate() {
                let key = (ty, index as u32);
                let start = *self.member_offsets.get(&key)?;
                let size = self.size_of(
                    member,
                    self.member_matrix_strides.get(&key).copied(),
                    depth + 1,
                )?;
                end = end.max(start.checked_add(size)?);
            }
            return Some(end);
        }
        None
    }

    fn rewrite(&self, words: &[u32], offset: u32, derive: bool) -> Result<Rewritten, Unsupported> {
        let Some(position) = self.position()? else {
            return Err(Unsupported("no Position output"));
        };
        // The position's vec4 type and its float.
        let (out_pointer, vec4) = match position {
            Position::Variable(var) => {
                let (ty, _) = self.variables[&var];
                let (_, pointee) = self.pointers[&ty];
                (ty, pointee)
            }
            Position::Member { block, member } => {
                let (ty, _) = self.variables[&block];
                let (_, pointee) = self.pointers[&ty];
                let vec4 = *self
                    .structs
                    .get(&pointee)
                    .and_then(|members| members.get(member as usize))
                    .ok_or(Unsupported("the Position member is not in its block"))?;
                let out_pointer = self
                    .pointer_of
                    .get(&(STORAGE_OUTPUT, vec4))
                    .copied()
                    .unwrap_or(0);
                (out_pointer, vec4)
            }
        };
        let float = self
            .vec4_float(vec4)
            .ok_or(Unsupported("Position is not a vec4 of 32-bit floats"))?;
        let body = Body::read(self, words, position)?;

        // The push-constant block: the application's (revz appends a member) or revz's own.
        let push_variables: Vec<u32> = self
            .variables
            .iter()
            .filter(|(_, &(_, class))| class == STORAGE_PUSH_CONSTANT)
            .map(|(&id, _)| id)
            .collect();
        let app_block = match push_variables.as_slice() {
            [] => None,
            [variable] => {
                let (ty, _) = self.variables[variable];
                let &(_, block) = self
                    .pointers
                    .get(&ty)
                    .ok_or(Unsupported("the push constants have no pointer type"))?;
                let members = self
                    .structs
                    .get(&block)
                    .ok_or(Unsupported("the push constants are not a struct"))?;
                if self.type_uses.contains(&block)
                    || self
                        .pointers
                        .values()
                        .any(|&(class, pointee)| pointee == block && class != STORAGE_PUSH_CONSTANT)
                {
                    return Err(Unsupported("the push-constant block type has other uses"));
                }
                for index in 0..members.len() as u32 {
                    let start = *self
                        .member_offsets
                        .get(&(block, index))
                        .ok_or(Unsupported("a push-constant member has no offset"))?;
                    let size = self
                        .size_of(
                            members[index as usize],
                            self.member_matrix_strides.get(&(block, index)).copied(),
                            0,
                        )
                        .ok_or(Unsupported("a push-constant member of unknown size"))?;
                    if start.saturating_add(size) > offset {
                        return Err(Unsupported(
                            "the push-constant block reaches revz's carrier bytes",
                        ));
                    }
                }
                Some((*variable, block, members.len() as u32))
            }
            _ => return Err(Unsupported("more than one push-constant block")),
        };
        // A push-constant block declared before `vec4` (Zink's) cannot take a `vec4` member
        // where it is: the block, its pointer types and its variable move to the end of the
        // declarations (nothing else declared refers to them: checked above for the block).
        let relocated: Option<Vec<u32>> = app_block
            .filter(|&(_, block, _)| self.declared_at.get(&vec4) > self.declared_at.get(&block))
            .map(|(_, block, _)| {
                self.pointers
                    .iter()
                    .filter(|(_, &(class, pointee))| {
                        class == STORAGE_PUSH_CONSTANT && pointee == block
                    })
                    .map(|(&id, _)| id)
                    .collect()
            });
        if let (Some(pointers), Some((variable, block, _))) = (&relocated, app_block) {
            // Nothing declared between the block and the functions may refer to what moves
            // (a debug-info `OpExtInst` naming the variable, a function type taking the
            // pointer, a null constant of the block): it would refer forward.
            let moved: HashSet<u32> = pointers.iter().copied().chain([block, variable]).collect();
            let from = self.declared_at.get(&block).copied().unwrap_or(0);
            let mut word = HEADER_WORDS;
            for instruction in instructions(words).into_iter().flatten() {
                let Ok(Instruction { opcode, operands }) = instruction else {
                    return Err(Unsupported("a malformed instruction"));
                };
                let at = word;
                word += operands.len() + 1;
                if at <= from || at >= self.functions_at {
                    continue;
                }
                let is_moved = result_id(opcode, operands).is_some_and(|id| moved.contains(id));
                if !is_moved && declaration_ids(opcode, operands).any(|o| moved.contains(&o)) {
                    return Err(Unsupported(
                        "the push-constant block precedes vec4 and is referred to before it",
                    ));
                }
            }
        }
        let positions_private = self.pointer_of.get(&(STORAGE_PRIVATE, vec4)).copied();
        if let (Position::Variable(var), Some(private)) = (position, positions_private) {
            if self.declared_at.get(&private) > self.declared_at.get(&var) {
                return Err(Unsupported("a private vec4 pointer type follows Position"));
            }
        }

        // The matrix a deriving rewrite fits, before anything is allocated: a refusal here
        // leaves the module to the flip path.
        let leaf = if derive {
            if self.entry_functions.len() != 1 {
                return Err(Unsupported("more than one vertex entry point"));
            }
            let facts = ModuleFacts {
                functions_at: self.functions_at,
                variables: &self.variables,
                global_opcodes: &self.global_opcodes,
                global_types: &self.global_types,
                buffer_blocks: &self.buffer_blocks,
                pointers: &self.pointers,
                matrices: &self.matrices,
                vec4,
                vectors: &self.vectors,
                ones: &self.ones,
            };
            Some(derived_range::find(words, &facts, &body.stores)?)
        } else {
            None
        };

        // Fresh ids.
        let needed = 32
            + 16 * body.returns
            + 2 * body.private_pointees.len()
            + derived_range::FIT_IDS
            + derived_range::RETURN_IDS * body.returns;
        let mut bound = words[3];
        if bound.checked_add(needed as u32).is_none() {
            return Err(Unsupported("its id bound leaves no room"));
        }
        let mut fresh = || {
            bound += 1;
            bound - 1
        };
        let int = self.ints.first().map(|&(id, _)| id);
        let (int, new_int) = match int {
            Some(id) => (id, None),
            None => {
                let id = fresh();
                (id, Some(id))
            }
        };
        let private_vec4 = positions_private.unwrap_or_else(&mut fresh);
        let new_private_vec4 = positions_private.is_none();
        // Pointer types into the shadow other than the vec4 itself (a component's).
        let mut private_pointers: HashMap<u32, (u32, bool)> = HashMap::new();
        for &pointee in &body.private_pointees {
            let existing = self.pointer_of.get(&(STORAGE_PRIVATE, pointee)).copied();
            let entry = match existing {
                Some(id) => (id, false),
                None if pointee == vec4 => (private_vec4, false),
                None => (fresh(), true),
            };
            private_pointers.insert(pointee, entry);
        }
        let push_vec4 = self.pointer_of.get(&(STORAGE_PUSH_CONSTANT, vec4)).copied();
        let (push_vec4, new_push_vec4) = match push_vec4 {
            Some(id) => (id, false),
            None => (fresh(), true),
        };
        let (push_variable, push_block, carrier_member, new_block) = match app_block {
            Some((variable, block, members)) => (variable, block, members, None),
            None => {
                let (block, pointer, variable) = (fresh(), fresh(), fresh());
                (variable, block, 0, Some(pointer))
            }
        };
        let carrier_index = fresh();
        // The shadow: for a variable, the variable itself (now private) and a new output in
        // its place; for a block member, a new private variable.
        let (shadow, output) = match position {
            Position::Variable(var) => (var, fresh()),
            Position::Member { block, .. } => (fresh(), block),
        };
        let member_index = match position {
            Position::Member { member, .. } => Some((fresh(), member)),
            Position::Variable(_) => None,
        };
        let out_vec4 = if out_pointer != 0 {
            (out_pointer, false)
        } else {
            (fresh(), true)
        };
        let types = Types {
            float,
            vec4,
            push_vec4,
            push_variable,
            carrier_index,
        };
        let fit = leaf.map(|leaf| Fit::new(leaf, self.bool_type, types, &mut fresh));
        let fit_after = match fit.as_ref().map(|f| f.leaf.insert) {
            Some(Insert::After(at)) => Some(at),
            _ => None,
        };
        let mut fit_at_entry = fit
            .as_ref()
            .is_some_and(|f| f.leaf.insert == Insert::EntryStart);
        let mut entry_label_seen = false;

        let mut out = Vec::with_capacity(words.len() + 64 + 24 * body.returns);
        out.extend_from_slice(&words[..HEADER_WORDS]);
        let annotations_at = self
            .annotations_at
            .ok_or(Unsupported("the module has no decorations"))?;
        let mut word = HEADER_WORDS;
        let all = instructions(words).ok_or(Unsupported("not SPIR-V"))?;
        let mut current_function = 0;
        for instruction in all {
            let Instruction { opcode, operands } =
                instruction.map_err(|_| Unsupported("a malformed instruction"))?;
            let at = word;
            word += operands.len() + 1;
            if at == annotations_at {
                // revz's decorations, first among the annotations.
                if let Position::Variable(_) = position {
                    // The output in the variable's place takes its built-in decoration (and
                    // any other, below).
                    push(
                        &mut out,
                        OP_DECORATE,
                        &[output, DECORATION_BUILT_IN, BUILT_IN_POSITION],
                    );
                }
                if new_block.is_some() {
                    push(&mut out, OP_DECORATE, &[push_block, DECORATION_BLOCK]);
                }
                push(
                    &mut out,
                    OP_MEMBER_DECORATE,
                    &[push_block, carrier_member, DECORATION_OFFSET, offset],
                );
                if let Some(fit) = &fit {
                    fit.decorations(&mut out);
                }
            }
            if at == self.functions_at {
                // New types, constants and variables, after every declaration.
                if let Some(id) = new_int {
                    push(&mut out, OP_TYPE_INT, &[id, 32, 1]);
                }
                for (&pointee, &(id, new)) in &private_pointers {
                    if new {
                        push(&mut out, OP_TYPE_POINTER, &[id, STORAGE_PRIVATE, pointee]);
                    }
                }
                if new_push_vec4 {
                    push(
                        &mut out,
                        OP_TYPE_POINTER,
                        &[push_vec4, STORAGE_PUSH_CONSTANT, vec4],
                    );
                }
                if out_vec4.1 {
                    push(
                        &mut out,
                        OP_TYPE_POINTER,
                        &[out_vec4.0, STORAGE_OUTPUT, vec4],
                    );
                }
                if let (Some(pointers), Some((variable, block, _))) = (&relocated, app_block) {
                    let mut members = self.structs[&block].clone();
                    members.insert(0, block);
                    members.push(vec4);
                    push(&mut out, OP_TYPE_STRUCT, &members);
                    for &pointer in pointers {
                        push(
                            &mut out,
                            OP_TYPE_POINTER,
                            &[pointer, STORAGE_PUSH_CONSTANT, block],
                        );
                    }
                    let (ty, _) = self.variables[&variable];
                    push(
                        &mut out,
                        OP_VARIABLE,
                        &[ty, variable, STORAGE_PUSH_CONSTANT],
                    );
                }
                if let Some(pointer) = new_block {
                    push(&mut out, OP_TYPE_STRUCT, &[push_block, vec4]);
                    push(
                        &mut out,
                        OP_TYPE_POINTER,
                        &[pointer, STORAGE_PUSH_CONSTANT, push_block],
                    );
                    push(
                        &mut out,
                        OP_VARIABLE,
                        &[pointer, push_variable, STORAGE_PUSH_CONSTANT],
                    );
                }
                push(&mut out, OP_CONSTANT, &[int, carrier_index, carrier_member]);
                if let Some((id, member)) = member_index {
                    push(&mut out, OP_CONSTANT, &[int, id, member]);
                }
                match position {
                    Position::Variable(_) => {
                        push(
                            &mut out,
                            OP_VARIABLE,
                            &[out_pointer, output, STORAGE_OUTPUT],
                        );
                    }
                    Position::Member { .. } => {
                        if new_private_vec4 {
                            push(
                                &mut out,
                                OP_TYPE_POINTER,
                                &[private_vec4, STORAGE_PRIVATE, vec4],
                            );
                        }
                        push(
                            &mut out,
                            OP_VARIABLE,
                            &[private_vec4, shadow, STORAGE_PRIVATE],
                        );
                    }
                }
                if let Some(fit) = &fit {
                    fit.declarations(&mut out, float, vec4, private_vec4);
                }
            }
            let in_functions = at >= self.functions_at;
            if fit_at_entry && self.entry_functions.contains(&current_function) {
                // A constant matrix: the fit opens the entry's first block, after its
                // variables.
                if opcode == derived_range::LABEL {
                    entry_label_seen = true;
                } else if entry_label_seen && !matches!(opcode, OP_VARIABLE | OP_LINE | OP_NO_LINE)
                {
                    if let Some(fit) = &fit {
                        out.extend_from_slice(&fit.code);
                    }
                    fit_at_entry = false;
                }
            }
            match (opcode, operands) {
                (OP_ENTRY_POINT, &[model, function, ref rest @ ..]) => {
                    // Keep the name, then the interface: below 1.4 only Input and Output
                    // variables (the shadow leaves it), from 1.4 every global used.
                    let name_words = rest
                        .iter()
                        .position(|w| w.to_le_bytes().contains(&0))
                        .map_or(rest.len(), |i| i + 1);
                    let (name, interface) = rest.split_at(name_words);
                    let mut operands = vec![model, function];
                    operands.extend_from_slice(name);
                    let modern = self.version >= VERSION_1_4;
                    for &id in interface {
                        if !modern && matches!(position, Position::Variable(v) if v == id) {
                            continue;
                        }
                        operands.push(id);
                    }
                    if matches!(position, Position::Variable(_)) {
                        operands.push(output);
                    }
                    if modern {
                        if matches!(position, Position::Member { .. }) {
                            operands.push(shadow);
                        }
                        if let Some(fit) = &fit {
                            operands.push(fit.derived);
                        }
                        if new_block.is_some() || !interface.contains(&push_variable) {
                            operands.push(push_variable);
                        }
                    }
                    push(&mut out, opcode, &operands);
                }
                (OP_DECORATE, &[target, ref rest @ ..]) if matches!(position, Position::Variable(v) if v == target) =>
                {
                    // Every decoration of the output (BuiltIn, Invariant, ...) moves to the
                    // new output; the built-in one was written above.
                    if rest.first() != Some(&DECORATION_BUILT_IN) {
                        let mut moved = vec![output];
                        moved.extend_from_slice(rest);
                        push(&mut out, opcode, &moved);
                    }
                }
                (OP_TYPE_STRUCT, &[id, ..]) if app_block.is_some() && id == push_block => {
                    if relocated.is_none() {
                        let mut members = operands.to_vec();
                        members.push(vec4);
                        push(&mut out, opcode, &members);
                    }
                }
                (OP_TYPE_POINTER, &[id, ..])
                    if relocated.as_ref().is_some_and(|p| p.contains(&id)) => {}
                (OP_VARIABLE, &[_, id, STORAGE_PUSH_CONSTANT, ..])
                    if !in_functions && relocated.is_some() && id == push_variable => {}
                (OP_VARIABLE, &[_, id, STORAGE_OUTPUT, ref init @ ..])
                    if !in_functions && matches!(position, Position::Variable(v) if v == id) =>
                {
                    if new_private_vec4 {
                        push(
                            &mut out,
                            OP_TYPE_POINTER,
                            &[private_vec4, STORAGE_PRIVATE, vec4],
                        );
                    }
                    let mut shadow_decl = vec![private_vec4, id, STORAGE_PRIVATE];
                    shadow_decl.extend_from_slice(init);
                    push(&mut out, opcode, &shadow_decl);
                }
                (OP_FUNCTION, &[_, id, ..]) => {
                    current_function = id;
                    push(&mut out, opcode, operands);
                }
                (
                    OP_ACCESS_CHAIN | OP_IN_BOUNDS_ACCESS_CHAIN,
                    &[ty, result, base, first, ref rest @ ..],
                ) if in_functions && body.redirected.contains(&result) => {
                    let pointee = self.pointers.get(&ty).map_or(0, |&(_, p)| p);
                    let private = private_pointers.get(&pointee).map_or(private_vec4, |p| p.0);
                    match position {
                        Position::Member { block, .. } if base == block => {
                            // The Position member of the block: the shadow, then any further
                            // indices.
                            if rest.is_empty() {
                                push(&mut out, OP_COPY_OBJECT, &[private, result, shadow]);
                            } else {
                                let mut chain = vec![private, result, shadow];
                                chain.extend_from_slice(rest);
                                push(&mut out, opcode, &chain);
                            }
                        }
                        _ => {
                            // Into the shadow: the same chain, typed as a private pointer.
                            let mut chain = vec![private, result, base, first];
                            chain.extend_from_slice(rest);
                            push(&mut out, opcode, &chain);
                        }
                    }
                }
                (OP_RETURN, _) if self.entry_functions.contains(&current_function) => {
                    let [value, carrier_pointer, carrier, c_z, c_w, c_1, z, w, scaled_z, scaled_w, sum, depth, stored] =
                        [0; 13].map(|_| fresh());
                    push(&mut out, OP_LOAD, &[vec4, value, shadow]);
                    push(
                        &mut out,
                        OP_ACCESS_CHAIN,
                        &[push_vec4, carrier_pointer, push_variable, carrier_index],
                    );
                    push(&mut out, OP_LOAD, &[vec4, carrier, carrier_pointer]);
                    push(&mut out, OP_COMPOSITE_EXTRACT, &[float, c_z, carrier, 0]);
                    push(&mut out, OP_COMPOSITE_EXTRACT, &[float, c_w, carrier, 1]);
                    push(&mut out, OP_COMPOSITE_EXTRACT, &[float, c_1, carrier, 2]);
                    let [c_z, c_w, c_1] = match &fit {
                        Some(fit) => fit.select_at_return(
                            &mut out,
                            types,
                            carrier,
                            [c_z, c_w, c_1],
                            &mut fresh,
                        ),
                        None => [c_z, c_w, c_1],
                    };
                    push(&mut out, OP_COMPOSITE_EXTRACT, &[float, z, value, 2]);
                    push(&mut out, OP_COMPOSITE_EXTRACT, &[float, w, value, 3]);
                    push(&mut out, OP_F_MUL, &[float, scaled_z, c_z, z]);
                    push(&mut out, OP_F_MUL, &[float, scaled_w, c_w, w]);
                    push(&mut out, OP_F_ADD, &[float, sum, scaled_z, scaled_w]);
                    push(&mut out, OP_F_ADD, &[float, depth, sum, c_1]);
                    push(
                        &mut out,
                        OP_COMPOSITE_INSERT,
                        &[vec4, stored, depth, value, 2],
                    );
                    match member_index {
                        Some((index, _)) => {
                            let pointer = fresh();
                            push(
                                &mut out,
                                OP_ACCESS_CHAIN,
                                &[out_vec4.0, pointer, output, index],
                            );
                            push(&mut out, OP_STORE, &[pointer, stored]);
                        }
                        None => push(&mut out, OP_STORE, &[output, stored]),
                    }
                    push(&mut out, opcode, operands);
                }
                _ => push(&mut out, opcode, operands),
            }
            if fit_after == Some(at) {
                if let Some(fit) = &fit {
                    out.extend_from_slice(&fit.code);
                }
            }
        }
        if fit_at_entry {
            return Err(Unsupported("the entry point has no block for the fit"));
        }
        out[3] = bound;
        Ok((out, fit.map(|f| f.leaf.source)))
    }
}

/// What the function bodies do with `Position`.
#[derive(Debug, Default)]
struct Body {
    /// Access chains whose result points into the shadow (their result type becomes a
    /// private pointer, and a chain into the block's Position member starts at the shadow).
    redirected: HashSet<u32>,
    /// The pointee types of those chains.
    private_pointees: HashSet<u32>,
    /// `OpReturn`s in vertex entry functions.
    returns: usize,
    /// What is stored into `Position` (for the derived range).
    stores: PositionStores,
}

impl Body {
    fn read(module: &Module, words: &[u32], position: Position) -> Result<Body, Unsupported> {
        let mut body = Body::default();
        // Pointers into the shadow: the variable (which becomes it), or what chains into the
        // block's Position member.
        let mut shadowed: HashSet<u32> = HashSet::new();
        let block = match position {
            Position::Variable(var) => {
                shadowed.insert(var);
                None
            }
            Position::Member { block, member } => Some((block, member)),
        };
        // Pointers to the whole Position, and to one component (its constant index, `None`
        // for a dynamic or nested one).
        let mut whole: HashSet<u32> = shadowed.clone();
        let mut component: HashMap<u32, Option<u32>> = HashMap::new();
        let mut word = HEADER_WORDS;
        let mut current_function = 0;
        let mut entry_called = false;
        for instruction in instructions(words).into_iter().flatten() {
            let Instruction { opcode, operands } =
                instruction.map_err(|_| Unsupported("a malformed instruction"))?;
            let at = word;
            word += operands.len() + 1;
            if at < module.functions_at {
                continue;
            }
            let ids_of = || {
                operands
                    .iter()
                    .enumerate()
                    .filter(|&(index, _)| !is_literal(opcode, index))
                    .map(|(_, word)| *word)
            };
            match (opcode, operands) {
                (OP_FUNCTION, &[_, id, ..]) => current_function = id,
                (OP_RETURN, _) if module.entry_functions.contains(&current_function) => {
                    body.returns += 1;
                }
                (OP_FUNCTION_CALL, &[_, _, callee, ..])
                    if module.entry_functions.contains(&callee) =>
                {
                    // OpFunctionCall of an entry point: its epilogue would run mid-shader.
                    entry_called = true;
                }
                (OP_LINE | OP_NO_LINE, _) => {}
                (OP_ACCESS_CHAIN | OP_IN_BOUNDS_ACCESS_CHAIN, &[ty, result, base, first, ..])
                    if Some(base) == block.map(|(b, _)| b) =>
                {
                    let (_, member) = block.expect("matched");
                    match module.int_constants.get(&first) {
                        Some(&index) if index == member => {
                            let pointee = module.pointers.get(&ty).map_or(0, |&(_, p)| p);
                            body.redirected.insert(result);
                            body.private_pointees.insert(pointee);
                            shadowed.insert(result);
                            match operands.get(4) {
                                None => {
                                    whole.insert(result);
                                }
                                Some(index) => {
                                    let nested = operands.len() > 5;
                                    let index = module.int_constants.get(index).copied();
                                    component.insert(result, index.filter(|_| !nested));
                                }
                            }
                        }
                        Some(_) => {}
                        None => return Err(Unsupported("the output block is indexed dynamically")),
                    }
                }
                (OP_ACCESS_CHAIN | OP_IN_BOUNDS_ACCESS_CHAIN, &[ty, result, base, ..])
                    if shadowed.contains(&base) =>
                {
                    let pointee = module.pointers.get(&ty).map_or(0, |&(_, p)| p);
                    body.redirected.insert(result);
                    body.private_pointees.insert(pointee);
                    shadowed.insert(result);
                    if operands[3..].iter().any(|i| shadowed.contains(i)) {
                        return Err(Unsupported("Position is used as an index"));
                    }
                    let index = if whole.contains(&base) && operands.len() == 4 {
                        module.int_constants.get(&operands[3]).copied()
                    } else {
                        None
                    };
                    component.insert(result, index);
                }
                (OP_LOAD, &[_, _, pointer, ..]) if shadowed.contains(&pointer) => {}
                (OP_STORE, &[pointer, value, ..]) if shadowed.contains(&pointer) => {
                    if shadowed.contains(&value) {
                        return Err(Unsupported("a pointer to Position is stored"));
                    }
                    if whole.contains(&pointer) {
                        body.stores.whole.push(value);
                    } else {
                        body.stores
                            .components
                            .push(component.get(&pointer).copied().flatten());
                    }
                }
                (OP_COPY_MEMORY, &[target, source, ..])
                    if shadowed.contains(&target) || shadowed.contains(&source) =>
                {
                    body.stores.copied = true;
                }
                _ => {
                    let uses =
                        |id: u32| shadowed.contains(&id) || block.is_some_and(|(b, _)| b == id);
                    if ids_of().any(uses) {
                        return Err(Unsupported(
                            "Position is used other than by loads, stores and access chains",
                        ));
                    }
                }
            }
        }
        if entry_called {
            return Err(Unsupported("an entry point is called as a function"));
        }
        Ok(body)
    }
}

/// The ids a declaration refers to (not its literals), for the declarations that can refer to
/// a push-constant block, its pointer or its variable; others refer to none of them.
fn declaration_ids(opcode: u32, operands: &[u32]) -> impl Iterator<Item = u32> + '_ {
    const OP_TYPE_FUNCTION: u32 = 33;
    const OP_CONSTANT_COMPOSITE: u32 = 44;
    const OP_CONSTANT_NULL: u32 = 46;
    const OP_SPEC_CONSTANT_COMPOSITE: u32 = 51;
    const OP_UNDEF: u32 = 1;
    let ids: &[u32] = match opcode {
        // Result id first, then ids (a pointer's storage class is a literal).
        OP_TYPE_POINTER => operands.get(2..).unwrap_or_default(),
        OP_TYPE_STRUCT | OP_TYPE_ARRAY | OP_TYPE_RUNTIME_ARRAY | OP_TYPE_FUNCTION => {
            operands.get(1..).unwrap_or_default()
        }
        // Result type, result id, then ids.
        OP_CONSTANT_COMPOSITE | OP_SPEC_CONSTANT_COMPOSITE => operands,
        OP_CONSTANT_NULL | OP_UNDEF => operands.get(..1).unwrap_or_default(),
        // Result type, id, storage class (literal), initializer.
        OP_VARIABLE => operands.get(3..).unwrap_or_default(),
        // Result type, id, set, instruction number (literal), then ids (debug info).
        OP_EXT_INST => operands.get(2..).unwrap_or_default(),
        _ => &[],
    };
    let skip_literal = opcode == OP_EXT_INST;
    ids.iter()
        .enumerate()
        .filter(move |&(i, _)| !(skip_literal && i == 1))
        .map(|(_, &id)| id)
}

/// The result id of an instruction, for the declarations that have one.
fn result_id(opcode: u32, operands: &[u32]) -> Option<&u32> {
    match opcode {
        19..=39 => operands.first(),
        OP_CONSTANT..=52 | OP_VARIABLE | OP_FUNCTION => operands.get(1),
        _ => None,
    }
}

#[cfg(test)]
#[path = "position_store_tests.rs"]
mod tests;
