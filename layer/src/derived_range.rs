//! The range a rewritten vertex stage derives from the matrix it loads (issue #16): where
//! revz cannot read the projection on the CPU (a uniform or storage buffer, a specialization
//! constant, a literal), the vertex stage fits the depth line of the outermost matrix it
//! multiplies into `Position` and stores reversed depth of that line.
//!
//! This module owns the two halves of that, word-level like [`crate::position_store`], which
//! calls it:
//!
//! - [`find`]: which matrix. Every store of a whole `Position` value must trace back (through
//!   copies and function-local variables stored once) to `M * v` (`OpMatrixTimesVector`) or
//!   `v * M` (`OpVectorTimesMatrix`); the outermost factor of `M` (down `OpMatrixTimesMatrix`
//!   and `OpTranspose`) is the *leaf*, one id for all stores. A store to `Position.z` or `.w`,
//!   a whole store of anything else, or two leaves refuse: the shader's depth would not be the
//!   leaf's line.
//! - [`Fit`]: the SPIR-V of `revz_math::shader_fit::fit_in_shader` and `derived_carrier`, the
//!   same float32 operations in the same order, each `NoContraction`, written right after the
//!   leaf's definition (or at the entry for a constant leaf) into a private `vec4` that the
//!   `Position` store at each return reads in place of the pushed carrier when the pushed
//!   carrier's w (the *selector*) says so: 0 the pushed carrier (flip, native, the CPU's
//!   precise values), 1 complementary, 2 infinite. Until a fit runs, and where the guard
//!   refuses, the private holds the flip mapping `(-1, 1, 0)`: `z' = w - z`.
//!
//! Why after the leaf's definition and not after the multiply: the leaf dominates every use
//! of it, also where it was reached through a local variable, so the fit is valid SSA there.

use std::collections::{HashMap, HashSet};

use revz_math::shader_fit::{
    AFFINE_W_TOLERANCE_SQUARED, FLIP_IN_SHADER, RESIDUAL_TOLERANCE_SQUARED,
};

use crate::position_store::Unsupported;
use crate::spirv_scan::op::*;
use crate::spirv_scan::{instructions, push, Instruction, HEADER_WORDS};

const OP_TYPE_BOOL: u32 = 20;
const OP_CONSTANT_COMPOSITE: u32 = 44;
const OP_CONSTANT_NULL: u32 = 46;
const OP_SPEC_CONSTANT_COMPOSITE: u32 = 51;
const OP_FUNCTION_PARAMETER: u32 = 55;
const OP_LABEL: u32 = 248;
const OP_LOOP_MERGE: u32 = 246;
const STORAGE_INPUT: u32 = 1;
const OP_PHI: u32 = 245;
const OP_TRANSPOSE: u32 = 84;
const OP_BITCAST: u32 = 124;
const OP_COMPOSITE_CONSTRUCT: u32 = 80;
const OP_F_NEGATE: u32 = 127;
const OP_F_DIV: u32 = 136;
const OP_VECTOR_TIMES_MATRIX: u32 = 144;
const OP_MATRIX_TIMES_VECTOR: u32 = 145;
const OP_MATRIX_TIMES_MATRIX: u32 = 146;
const OP_LOGICAL_OR: u32 = 166;
const OP_LOGICAL_AND: u32 = 167;
const OP_F_ORD_EQUAL: u32 = 180;
const OP_SELECT: u32 = 169;
const OP_F_ORD_LESS_THAN: u32 = 184;
const OP_F_ORD_GREATER_THAN: u32 = 186;
const OP_F_ORD_LESS_THAN_EQUAL: u32 = 188;
const OP_F_ORD_GREATER_THAN_EQUAL: u32 = 190;
const DECORATION_NO_CONTRACTION: u32 = 42;
const STORAGE_UNIFORM_CONSTANT: u32 = 0;
const STORAGE_UNIFORM: u32 = 2;
const STORAGE_PUSH_CONSTANT: u32 = 9;
const STORAGE_PRIVATE: u32 = 6;
const STORAGE_STORAGE_BUFFER: u32 = 12;
const DECORATION_BUFFER_BLOCK: u32 = 3;

/// Where the leaf matrix comes from, for the log.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MatrixSource {
    UniformBuffer,
    StorageBuffer,
    /// Push constants the CPU path could not use (dynamically indexed, or a second block).
    PushConstants,
    Constant,
    SpecializationConstant,
    /// Computed in the shader (a function parameter's matrix, a matrix built from columns).
    Computed,
}

impl MatrixSource {
    pub fn describe(self) -> &'static str {
        match self {
            MatrixSource::UniformBuffer => "a uniform buffer",
            MatrixSource::StorageBuffer => "a storage buffer",
            MatrixSource::PushConstants => "push constants",
            MatrixSource::Constant => "a constant",
            MatrixSource::SpecializationConstant => "a specialization constant",
            MatrixSource::Computed => "a matrix the shader computes",
        }
    }
}

/// Where the fit goes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Insert {
    /// Right after the instruction at this word index (the leaf's definition).
    After(usize),
    /// At the start of each entry function's first block, after its variables (a leaf
    /// declared outside functions: a constant).
    EntryStart,
}

/// The matrix whose line the shader fits.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Leaf {
    /// The matrix (unused where `columns` is set).
    pub id: u32,
    /// `v * M`: the rows of the column-vector matrix are the leaf's columns.
    pub transposed: bool,
    /// The matrix as four `vec4` columns of a product written out as
    /// `c0 * v.x + c1 * v.y + c2 * v.z + c3 * v.w` (Mesa's NIR, so Zink's SPIR-V).
    pub columns: Option<[u32; 4]>,
    pub insert: Insert,
    pub source: MatrixSource,
}

/// How `Position` is stored, as [`crate::position_store`]'s body pass saw it.
#[derive(Debug, Default)]
pub struct PositionStores {
    /// Values stored into the whole `Position`.
    pub whole: Vec<u32>,
    /// Components stored alone (`None`: a dynamic or nested index).
    pub components: Vec<Option<u32>>,
    /// `OpCopyMemory` into or out of it.
    pub copied: bool,
}

/// What the function bodies define: result id -> (word index, opcode, operands).
struct Defs {
    at: HashMap<u32, (usize, u32, Vec<u32>)>,
    /// Stores into variables: variable -> (value, word index).
    stores: HashMap<u32, Vec<(u32, usize)>>,
    /// Function variables with an initializer: a load may read it where the store did not
    /// run, so they are followed only from a store earlier in the load's own block.
    initialized: HashSet<u32>,
    /// Word indices of `OpLabel`s (block starts), in order.
    labels: Vec<usize>,
    /// Function-local variables, and the module's private ones (naga's SPIR-V passes every
    /// output through a private global that a wrapper entry point copies out).
    followed: HashSet<u32>,
    /// Variables reached through an access chain (a component may be written apart), or used
    /// other than as the pointer of a load or a store: never followed.
    chained: HashSet<u32>,
    /// Component counts of vector types.
    counts: HashMap<u32, u32>,
    /// Word ranges of loop constructs (from an `OpLoopMerge` to its merge block's label).
    loops: Vec<(usize, usize)>,
    /// Constants whose one word is the bits of 1.0 (a float, or Zink's uint bitcast to one).
    ones: HashSet<u32>,
    /// `Input` variables (vertex attributes: a fetch of fewer than 4 components gives w = 1).
    inputs: HashSet<u32>,
}

fn result_of(opcode: u32, operands: &[u32]) -> Option<u32> {
    match opcode {
        OP_BITCAST
        | OP_F_ADD
        | OP_F_MUL
        | OP_VECTOR_SHUFFLE
        | OP_LOAD
        | OP_COPY_OBJECT
        | OP_MATRIX_TIMES_VECTOR
        | OP_VECTOR_TIMES_MATRIX
        | OP_MATRIX_TIMES_MATRIX
        | OP_TRANSPOSE
        | OP_ACCESS_CHAIN
        | OP_IN_BOUNDS_ACCESS_CHAIN
        | OP_VARIABLE
        | OP_PHI
        | OP_FUNCTION_PARAMETER
        | OP_COMPOSITE_CONSTRUCT
        | OP_COMPOSITE_EXTRACT
        | OP_FUNCTION_CALL => operands.get(1).copied(),
        _ => None,
    }
}

impl Defs {
    fn read(words: &[u32], module: &ModuleFacts<'_>) -> Result<Defs, Unsupported> {
        let functions_at = module.functions_at;
        let mut defs = Defs {
            at: HashMap::new(),
            stores: HashMap::new(),
            followed: module
                .variables
                .iter()
                .filter(|(_, &(_, class))| class == STORAGE_PRIVATE)
                .map(|(&id, _)| id)
                .collect(),
            chained: HashSet::new(),
            initialized: HashSet::new(),
            labels: Vec::new(),
            counts: module
                .vectors
                .iter()
                .map(|(&id, &(_, n))| (id, n))
                .collect(),
            loops: Vec::new(),
            ones: module.ones.clone(),
            inputs: module
                .variables
                .iter()
                .filter(|(_, &(_, class))| class == STORAGE_INPUT)
                .map(|(&id, _)| id)
                .collect(),
        };
        let mut open_loops: Vec<(u32, usize)> = Vec::new();
        let mut word = HEADER_WORDS;
        for instruction in instructions(words).into_iter().flatten() {
            let Instruction { opcode, operands } =
                instruction.map_err(|_| Unsupported("a malformed instruction"))?;
            let at = word;
            word += operands.len() + 1;
            if at < functions_at {
                continue;
            }
            // A followed variable used other than as the pointer of a load or a store (an
            // alias, an argument, a debug reference): its value is not only what is stored.
            if opcode != OP_VARIABLE {
                for (index, operand) in operands.iter().enumerate() {
                    let pointer_use = matches!((opcode, index), (OP_LOAD, 2) | (OP_STORE, 0));
                    if !pointer_use && defs.followed.contains(operand) {
                        defs.chained.insert(*operand);
                    }
                }
            }
            match (opcode, operands) {
                (OP_LOOP_MERGE, &[merge, ..]) => open_loops.push((merge, at)),
                (OP_LABEL, &[label]) => {
                    defs.labels.push(at);
                    while let Some(index) = open_loops.iter().position(|&(m, _)| m == label) {
                        let (_, start) = open_loops.remove(index);
                        defs.loops.push((start, at));
                    }
                }
                (OP_VARIABLE, &[_, id, _, ref initializer @ ..]) => {
                    defs.followed.insert(id);
                    if !initializer.is_empty() {
                        defs.initialized.insert(id);
                    }
                }
                (OP_STORE, &[pointer, value, ..]) => {
                    defs.stores.entry(pointer).or_default().push((value, at));
                }
                (OP_ACCESS_CHAIN | OP_IN_BOUNDS_ACCESS_CHAIN, &[_, _, base, ..]) => {
                    defs.chained.insert(base);
                }
                (OP_COPY_MEMORY, &[target, ..]) => {
                    defs.chained.insert(target);
                }
                (OP_FUNCTION_CALL, &[_, _, _, ref arguments @ ..]) => {
                    // A pointer argument may be written by the callee.
                    defs.chained.extend(arguments.iter().copied());
                }
                _ => {}
            }
            if let Some(id) = result_of(opcode, operands) {
                defs.at.insert(id, (at, opcode, operands.to_vec()));
            }
        }
        // Loops still open at the end of the words (malformed): to the end.
        defs.loops
            .extend(open_loops.into_iter().map(|(_, start)| (start, usize::MAX)));
        Ok(defs)
    }

    /// Whether the instruction at `at` lies in a loop construct: a fit there may describe
    /// another iteration than the one whose value is stored.
    fn in_loop(&self, at: usize) -> bool {
        self.loops
            .iter()
            .any(|&(start, end)| start < at && at < end)
    }

    /// Component count of the vector `id` (by its result type), if known.
    fn components(&self, id: u32) -> Option<u32> {
        let (_, _, operands) = self.at.get(&id)?;
        self.counts.get(operands.first()?).copied()
    }

    /// Whether the vector a projection multiplies has w = 1 (what `z' = c_w w + c_1` assumes:
    /// the line's constant term is `B * v.w`): `vec4(p, 1.0)`, an attribute, a product of
    /// such a vector (by affine matrices), through copies, bitcasts and followed variables.
    fn unit_w(&self, vector: u32, depth: u32) -> bool {
        if depth > 16 {
            return false;
        }
        let vector = self.unwrapped(vector);
        if let Some((_, terms_w_one)) = self.column_source(vector) {
            return match terms_w_one {
                ColumnW::Folded => true,
                ColumnW::Of(source) => self.unit_w(source, depth + 1),
            };
        }
        let Some((_, opcode, operands)) = self.at.get(&vector) else {
            return false;
        };
        match (*opcode, operands.as_slice()) {
            (OP_COMPOSITE_CONSTRUCT, [.., last]) if operands.len() > 2 => {
                let last = self.unwrapped(*last);
                self.ones.contains(&last)
            }
            (OP_MATRIX_TIMES_VECTOR, &[_, _, _, v]) => self.unit_w(v, depth + 1),
            (OP_COPY_OBJECT, &[_, _, source]) => self.unit_w(source, depth + 1),
            (OP_COMPOSITE_EXTRACT, &[_, _, composite, index]) => self
                .member(composite, index)
                .is_some_and(|m| self.unit_w(m, depth + 1)),
            (OP_LOAD, &[_, _, pointer, ..]) => {
                self.inputs.contains(&pointer)
                    || self
                        .through_local(pointer, self.at_of(vector))
                        .is_some_and(|stored| self.unit_w(stored, depth + 1))
            }
            _ => false,
        }
    }

    /// The value a load (at word `load_at`) of a local or private variable stored exactly
    /// once, whole, reads.
    fn through_local(&self, pointer: u32, load_at: usize) -> Option<u32> {
        if !self.followed.contains(&pointer) || self.chained.contains(&pointer) {
            return None;
        }
        let &[(value, store_at)] = self.stores.get(&pointer)?.as_slice() else {
            return None;
        };
        if self.initialized.contains(&pointer) {
            // The store must run before the load: earlier in the same block.
            let same_block = store_at < load_at
                && !self
                    .labels
                    .iter()
                    .any(|&label| store_at < label && label < load_at);
            if !same_block {
                return None;
            }
        }
        Some(value)
    }

    /// The word index of `id`'s definition (0 where unknown).
    fn at_of(&self, id: u32) -> usize {
        self.at.get(&id).map_or(0, |(at, ..)| *at)
    }

    /// Member `index` of a composite built by `OpCompositeConstruct` (naga's wrapper builds
    /// the entry point's output struct so).
    fn member(&self, composite: u32, index: u32) -> Option<u32> {
        match self.at.get(&composite) {
            Some((_, OP_COMPOSITE_CONSTRUCT, operands)) => {
                operands.get(2 + index as usize).copied()
            }
            _ => None,
        }
    }

    /// The multiply a whole `Position` value comes from: (matrix, transposed, vector).
    fn multiply(&self, value: u32, depth: u32) -> Option<(u32, bool, u32)> {
        if depth > 16 {
            return None;
        }
        let (_, opcode, operands) = self.at.get(&value)?;
        match (*opcode, operands.as_slice()) {
            (OP_MATRIX_TIMES_VECTOR, &[_, _, matrix, vector]) => Some((matrix, false, vector)),
            (OP_VECTOR_TIMES_MATRIX, &[_, _, vector, matrix]) => Some((matrix, true, vector)),
            (OP_COPY_OBJECT, &[_, _, source]) => self.multiply(source, depth + 1),
            (OP_LOAD, &[_, _, pointer, ..]) => {
                self.multiply(self.through_local(pointer, self.at_of(value))?, depth + 1)
            }
            (OP_COMPOSITE_EXTRACT, &[_, _, composite, index]) => {
                self.multiply(self.member(composite, index)?, depth + 1)
            }
            _ => None,
        }
    }

    /// `id` without the `OpBitcast`s around it (Zink passes every value through uint
    /// vectors and back: the bits, so the values, are the same).
    fn unwrapped(&self, mut id: u32) -> u32 {
        for _ in 0..16 {
            match self.at.get(&id) {
                Some((_, OP_BITCAST, operands)) if operands.len() == 3 => id = operands[2],
                _ => break,
            }
        }
        id
    }

    /// The component a splat repeats (`v.xxxx` as a shuffle or a construct of one extract)
    /// and the vector it comes from.
    fn splat(&self, id: u32) -> Option<(u32, u32)> {
        match self.at.get(&self.unwrapped(id))? {
            // A component of the first vector (a larger index selects from the second).
            (_, OP_VECTOR_SHUFFLE, operands) => match operands.as_slice() {
                &[_, _, first, _, i, j, k, l]
                    if i == j && j == k && k == l && i < self.components(first)?.min(4) =>
                {
                    Some((self.unwrapped(first), i))
                }
                _ => None,
            },
            (_, OP_COMPOSITE_CONSTRUCT, operands) => match operands.as_slice() {
                &[_, _, a, b, c, d] if a == b && b == c && c == d => match self.at.get(&a)? {
                    (_, OP_COMPOSITE_EXTRACT, e)
                        if e.len() == 4 && e[3] < self.components(e[2])?.min(4) =>
                    {
                        Some((self.unwrapped(e[2]), e[3]))
                    }
                    _ => None,
                },
                _ => None,
            },
            _ => None,
        }
    }

    /// The sum's terms (operands of nested `OpFAdd`s, bitcasts looked through).
    fn terms(&self, id: u32, out: &mut Vec<u32>, depth: u32) -> Option<()> {
        if depth > 8 || out.len() > 4 {
            return None;
        }
        match self.at.get(&self.unwrapped(id)) {
            Some((_, OP_F_ADD, operands)) if operands.len() == 4 => {
                self.terms(operands[2], out, depth + 1)?;
                self.terms(operands[3], out, depth + 1)
            }
            _ => {
                out.push(id);
                Some(())
            }
        }
    }

    /// `c0 * v.x + c1 * v.y + c2 * v.z + c3 * v.w` (any order of the terms, `c3` alone where
    /// `v.w` was folded to 1): the columns, and the sum's root (where the fit goes).
    fn column_product(&self, value: u32) -> Option<([u32; 4], u32)> {
        self.column_parts(value)
            .map(|(columns, root, _)| (columns, root))
    }

    /// [`Self::column_product`]'s vector: its w folded to 1, or the vector the splats take
    /// their components from.
    fn column_source(&self, value: u32) -> Option<([u32; 4], ColumnW)> {
        self.column_parts(value).map(|(columns, _, w)| (columns, w))
    }

    fn column_parts(&self, value: u32) -> Option<([u32; 4], u32, ColumnW)> {
        let root = self.unwrapped(value);
        let mut terms = Vec::new();
        self.terms(value, &mut terms, 0)?;
        if terms.len() != 4 {
            return None;
        }
        let mut columns = [None; 4];
        let mut vector = None;
        let mut bare = None;
        for term in terms {
            let product = match self.at.get(&self.unwrapped(term)) {
                Some((_, OP_F_MUL, operands)) if operands.len() == 4 => {
                    Some((operands[2], operands[3]))
                }
                _ => None,
            };
            let Some((x, y)) = product else {
                if bare.replace(term).is_some() {
                    return None;
                }
                continue;
            };
            let (column, (source, index)) = match (self.splat(x), self.splat(y)) {
                (None, Some(splat)) => (x, splat),
                (Some(splat), None) => (y, splat),
                _ => return None,
            };
            if vector.replace(source).is_some_and(|v| v != source) {
                return None;
            }
            if columns[index as usize].replace(column).is_some() {
                return None;
            }
        }
        let folded = bare.is_some();
        if let Some(term) = bare {
            if columns[3].replace(term).is_some() {
                return None;
            }
        }
        let columns = [columns[0]?, columns[1]?, columns[2]?, columns[3]?];
        let w = if folded {
            ColumnW::Folded
        } else {
            ColumnW::Of(vector?)
        };
        self.at.contains_key(&root).then_some((columns, root, w))
    }

    /// The outermost factor of `matrix` (for `transposed`, the use `v * matrix`).
    fn leaf(&self, matrix: u32, transposed: bool, depth: u32) -> (u32, bool) {
        if depth > 16 {
            return (matrix, transposed);
        }
        let Some((_, opcode, operands)) = self.at.get(&matrix) else {
            return (matrix, transposed);
        };
        match (*opcode, operands.as_slice()) {
            // M = A * B applied to a column vector: A is applied last; to a row vector
            // (v * (A * B)), B is.
            (OP_MATRIX_TIMES_MATRIX, &[_, _, a, b]) => {
                self.leaf(if transposed { b } else { a }, transposed, depth + 1)
            }
            (OP_TRANSPOSE, &[_, _, x]) => self.leaf(x, !transposed, depth + 1),
            (OP_COPY_OBJECT, &[_, _, x]) => self.leaf(x, transposed, depth + 1),
            (OP_LOAD, &[_, _, pointer, ..]) => {
                match self.through_local(pointer, self.at_of(matrix)) {
                    Some(stored) => self.leaf(stored, transposed, depth + 1),
                    None => (matrix, transposed),
                }
            }
            _ => (matrix, transposed),
        }
    }

    /// The storage class the pointer chain of a load starts from.
    fn pointer_class(&self, module: &ModuleFacts<'_>, pointer: u32, depth: u32) -> Option<u32> {
        if depth > 16 {
            return None;
        }
        if let Some(&(_, class)) = module.variables.get(&pointer) {
            return Some(class);
        }
        let (_, opcode, operands) = self.at.get(&pointer)?;
        match (*opcode, operands.as_slice()) {
            (OP_ACCESS_CHAIN | OP_IN_BOUNDS_ACCESS_CHAIN, &[_, _, base, ..]) => {
                self.pointer_class(module, base, depth + 1)
            }
            _ => None,
        }
    }
}

/// What [`find`] needs of the module's declarations.
#[derive(Debug)]
pub struct ModuleFacts<'a> {
    pub functions_at: usize,
    /// Global variables: id -> (pointer type, storage class).
    pub variables: &'a HashMap<u32, (u32, u32)>,
    /// Declarations outside functions: id -> opcode (constants, spec constants), and their
    /// result types.
    pub global_opcodes: &'a HashMap<u32, u32>,
    pub global_types: &'a HashMap<u32, u32>,
    /// Ids decorated `BufferBlock` (storage buffers before SPIR-V 1.3's `StorageBuffer`).
    pub buffer_blocks: &'a HashSet<u32>,
    /// Pointer types: id -> (storage class, pointee).
    pub pointers: &'a HashMap<u32, (u32, u32)>,
    /// Matrix types: id -> (column type, count).
    pub matrices: &'a HashMap<u32, (u32, u32)>,
    /// The `vec4` of floats `Position` is.
    pub vec4: u32,
    /// Vector types: id -> (component type, count).
    pub vectors: &'a HashMap<u32, (u32, u32)>,
    /// 32-bit constants whose word is the bits of 1.0.
    pub ones: &'a HashSet<u32>,
}

/// The w of the vector a column-form product multiplies.
#[derive(Clone, Copy, Debug)]
enum ColumnW {
    /// The product's last column is added alone: its w was 1, folded by the compiler.
    Folded,
    /// The vector the splats come from.
    Of(u32),
}

/// The leaf matrix of every whole `Position` store, or why the shader's depth is not one
/// matrix's line.
pub fn find(
    words: &[u32],
    module: &ModuleFacts<'_>,
    stores: &PositionStores,
) -> Result<Leaf, Unsupported> {
    if stores.copied {
        return Err(Unsupported("Position is copied as memory"));
    }
    if stores
        .components
        .iter()
        .any(|index| !matches!(index, Some(0 | 1)))
    {
        return Err(Unsupported("Position's z or w is stored on its own"));
    }
    let defs = Defs::read(words, module)?;
    if let [value] = stores.whole.as_slice() {
        if defs.multiply(*value, 0).is_none() {
            if let Some((columns, root)) = defs.column_product(*value) {
                if !defs.unit_w(*value, 0) {
                    return Err(Unsupported(
                        "the vector the projection multiplies may not have w = 1",
                    ));
                }
                if defs.in_loop(defs.at[&root].0) {
                    return Err(Unsupported("the projection is applied in a loop"));
                }
                return column_leaf(module, &defs, columns, root);
            }
        }
    }
    let mut leaf: Option<(u32, bool)> = None;
    for &value in &stores.whole {
        let (matrix, transposed, vector) = defs
            .multiply(value, 0)
            .ok_or(Unsupported("Position is not a matrix times a vector"))?;
        if !defs.unit_w(vector, 0) {
            return Err(Unsupported(
                "the vector the projection multiplies may not have w = 1",
            ));
        }
        let found = defs.leaf(matrix, transposed, 0);
        if leaf.is_some_and(|l| l != found) {
            return Err(Unsupported("Position comes from more than one matrix"));
        }
        leaf = Some(found);
    }
    let (id, transposed) = leaf.ok_or(Unsupported("Position is never stored whole"))?;
    // A 4x4 matrix of the position's vec4 columns.
    let matrix_type = match defs.at.get(&id) {
        Some((_, _, operands)) => operands.first().copied(),
        None => None,
    };
    let (insert, source) = match defs.at.get(&id) {
        Some((at, opcode, operands)) => {
            let source = match (*opcode, operands.as_slice()) {
                (OP_PHI | OP_FUNCTION_PARAMETER, _) => {
                    return Err(Unsupported("the matrix is a phi or a parameter"))
                }
                (OP_LOAD, &[_, _, pointer, ..]) => source_of(module, &defs, pointer),
                // A matrix member of a loaded block (naga loads the whole block).
                (OP_COMPOSITE_EXTRACT, &[_, _, composite, ..]) => match defs.at.get(&composite) {
                    Some((_, OP_LOAD, loaded)) => loaded
                        .get(2)
                        .map_or(MatrixSource::Computed, |&p| source_of(module, &defs, p)),
                    _ => MatrixSource::Computed,
                },
                _ => MatrixSource::Computed,
            };
            if defs.in_loop(*at) {
                return Err(Unsupported("the projection is loaded in a loop"));
            }
            (Insert::After(*at), source)
        }
        None => {
            let source = match module.global_opcodes.get(&id) {
                Some(&(OP_CONSTANT_COMPOSITE | OP_CONSTANT_NULL)) => MatrixSource::Constant,
                Some(&OP_SPEC_CONSTANT_COMPOSITE) => MatrixSource::SpecializationConstant,
                _ => {
                    return Err(Unsupported(
                        "the matrix is not defined where revz can see it",
                    ))
                }
            };
            (Insert::EntryStart, source)
        }
    };
    let matrix_type = matrix_type.or_else(|| module.global_types.get(&id).copied());
    let square = matrix_type.is_some_and(|ty| module.matrices.get(&ty) == Some(&(module.vec4, 4)));
    if !square {
        return Err(Unsupported("the matrix is not a 4x4 float matrix"));
    }
    Ok(Leaf {
        id,
        transposed,
        columns: None,
        insert,
        source,
    })
}

/// The leaf of a product written out by columns: each a `vec4` of the position's type, the fit
/// after the sum's root (which every column dominates).
fn column_leaf(
    module: &ModuleFacts<'_>,
    defs: &Defs,
    columns: [u32; 4],
    root: u32,
) -> Result<Leaf, Unsupported> {
    let typed = |id: u32| {
        defs.at
            .get(&id)
            .is_some_and(|(_, _, operands)| operands.first() == Some(&module.vec4))
    };
    if !columns.iter().all(|&c| typed(c)) {
        return Err(Unsupported("the product's columns are not vec4s"));
    }
    let (at, ..) = defs.at[&root];
    // Where the first column's values are loaded from.
    let mut source = MatrixSource::Computed;
    let mut pending = vec![columns[0]];
    for _ in 0..16 {
        let Some(id) = pending.pop() else { break };
        match defs.at.get(&id) {
            Some((_, OP_LOAD, operands)) => {
                if let Some(&pointer) = operands.get(2) {
                    source = source_of(module, defs, pointer);
                }
                break;
            }
            Some((_, OP_BITCAST | OP_COMPOSITE_CONSTRUCT, operands)) => {
                pending.extend(operands.iter().skip(2).rev());
            }
            _ => {}
        }
    }
    Ok(Leaf {
        id: 0,
        transposed: false,
        columns: Some(columns),
        insert: Insert::After(at),
        source,
    })
}

/// Where a loaded pointer points: the storage class its access chain starts in.
fn source_of(module: &ModuleFacts<'_>, defs: &Defs, pointer: u32) -> MatrixSource {
    match defs.pointer_class(module, pointer, 0) {
        Some(STORAGE_STORAGE_BUFFER) => MatrixSource::StorageBuffer,
        Some(STORAGE_UNIFORM) => {
            let block = buffer_block_of(module, pointer, defs);
            if block {
                MatrixSource::StorageBuffer
            } else {
                MatrixSource::UniformBuffer
            }
        }
        Some(STORAGE_PUSH_CONSTANT) => MatrixSource::PushConstants,
        Some(STORAGE_UNIFORM_CONSTANT) | None => MatrixSource::Computed,
        Some(_) => MatrixSource::Computed,
    }
}

/// Whether a `Uniform` pointer chain starts at a `BufferBlock` variable (a storage buffer in
/// SPIR-V before 1.3).
fn buffer_block_of(module: &ModuleFacts<'_>, pointer: u32, defs: &Defs) -> bool {
    let mut current = pointer;
    for _ in 0..16 {
        if let Some(&(ty, _)) = module.variables.get(&current) {
            let pointee = module.pointers.get(&ty).map(|&(_, p)| p);
            return pointee.is_some_and(|p| module.buffer_blocks.contains(&p));
        }
        match defs.at.get(&current) {
            Some((_, OP_ACCESS_CHAIN | OP_IN_BOUNDS_ACCESS_CHAIN, operands)) => {
                match operands.get(2) {
                    Some(&base) => current = base,
                    None => return false,
                }
            }
            _ => return false,
        }
    }
    false
}

/// The fit's SPIR-V, made before the module is written (its arithmetic ids must be decorated
/// in the annotation section, ahead of the code).
#[derive(Debug)]
pub struct Fit {
    pub leaf: Leaf,
    /// `OpTypeBool`: the module's, or a new one (`new_bool`).
    pub bool_type: u32,
    new_bool: bool,
    /// The private `vec4` holding the derived carrier, and its initializer.
    pub derived: u32,
    init: u32,
    /// Float constants: (id, value).
    constants: Vec<(u32, f32)>,
    half: u32,
    minus_half: u32,
    two_and_a_half: u32,
    zero: u32,
    one: u32,
    minus_one: u32,
    /// The fit's instructions, ending with the store of the derived carrier.
    pub code: Vec<u32>,
    /// The arithmetic results, decorated `NoContraction`.
    exact: Vec<u32>,
}

/// The ids a module's types give the fit.
#[derive(Clone, Copy, Debug)]
pub struct Types {
    pub float: u32,
    pub vec4: u32,
    /// Pointer to a push-constant `vec4`, the push-constant variable, and the carrier's
    /// member index constant.
    pub push_vec4: u32,
    pub push_variable: u32,
    pub carrier_index: u32,
}

/// A builder of float instructions that records the arithmetic results.
struct Code<'f, F: FnMut() -> u32> {
    words: Vec<u32>,
    exact: Vec<u32>,
    fresh: &'f mut F,
    float: u32,
}

impl<F: FnMut() -> u32> Code<'_, F> {
    fn op(&mut self, opcode: u32, x: u32, y: u32) -> u32 {
        let id = (self.fresh)();
        push(&mut self.words, opcode, &[self.float, id, x, y]);
        self.exact.push(id);
        id
    }

    fn typed(&mut self, opcode: u32, ty: u32, operands: &[u32]) -> u32 {
        let id = (self.fresh)();
        let mut all = vec![ty, id];
        all.extend_from_slice(operands);
        push(&mut self.words, opcode, &all);
        id
    }

    /// `((x0 y0 + x1 y1) + x2 y2)`, as `fit_in_shader` evaluates it.
    fn dot3(&mut self, x: [u32; 3], y: [u32; 3]) -> u32 {
        let p0 = self.op(OP_F_MUL, x[0], y[0]);
        let p1 = self.op(OP_F_MUL, x[1], y[1]);
        let sum = self.op(OP_F_ADD, p0, p1);
        let p2 = self.op(OP_F_MUL, x[2], y[2]);
        self.op(OP_F_ADD, sum, p2)
    }
}

/// An upper bound on the ids [`Fit::new`] and one [`Fit::select_at_return`] take.
pub const FIT_IDS: usize = 100;
/// Ids each [`Fit::select_at_return`] takes.
pub const RETURN_IDS: usize = 17;

impl Fit {
    pub fn new<F: FnMut() -> u32>(
        leaf: Leaf,
        bool_type: Option<u32>,
        types: Types,
        fresh: &mut F,
    ) -> Fit {
        let (bool_type, new_bool) = match bool_type {
            Some(id) => (id, false),
            None => (fresh(), true),
        };
        let mut constant = |value: f32| (fresh(), value);
        let zero = constant(0.0);
        let one = constant(1.0);
        let minus_one = constant(-1.0);
        let half = constant(0.5);
        let minus_half = constant(-0.5);
        let two = constant(2.0);
        let two_and_a_half = constant(2.5);
        let four = constant(4.0);
        let residual = constant(RESIDUAL_TOLERANCE_SQUARED);
        let affine = constant(AFFINE_W_TOLERANCE_SQUARED);
        let infinity = constant(f32::INFINITY);
        let minus_infinity = constant(f32::NEG_INFINITY);
        let (derived, init) = (fresh(), fresh());
        let Types {
            float,
            vec4,
            push_vec4,
            push_variable,
            carrier_index,
        } = types;
        let mut code = Code {
            words: Vec::new(),
            exact: Vec::new(),
            fresh,
            float,
        };
        // The depth row a and the w row b of the column-vector matrix.
        let element = |code: &mut Code<'_, F>, row: u32, column: u32| {
            if let Some(columns) = leaf.columns {
                return code.typed(
                    OP_COMPOSITE_EXTRACT,
                    float,
                    &[columns[column as usize], row],
                );
            }
            let indices = if leaf.transposed {
                [row, column]
            } else {
                [column, row]
            };
            code.typed(
                OP_COMPOSITE_EXTRACT,
                float,
                &[leaf.id, indices[0], indices[1]],
            )
        };
        let a: [u32; 4] = std::array::from_fn(|j| element(&mut code, 2, j as u32));
        let b: [u32; 4] = std::array::from_fn(|j| element(&mut code, 3, j as u32));
        let xyz = |v: [u32; 4]| [v[0], v[1], v[2]];
        let bb = code.dot3(xyz(b), xyz(b));
        let aa = code.dot3(xyz(a), xyz(a));
        let ab = code.dot3(xyz(a), xyz(b));
        let k = code.op(OP_F_DIV, ab, bb);
        let e: [u32; 3] = std::array::from_fn(|i| {
            let m = code.op(OP_F_MUL, k, b[i]);
            code.op(OP_F_SUB, a[i], m)
        });
        let ee = code.dot3(e, e);
        let kb3 = code.op(OP_F_MUL, k, b[3]);
        let b_fit = code.op(OP_F_SUB, a[3], kb3);
        let bw2 = code.op(OP_F_MUL, b[3], b[3]);
        let affine_bound = code.op(OP_F_MUL, affine.0, bw2);
        let tolerance = code.op(OP_F_MUL, residual.0, aa);
        // The guard, on the line as fitted, each comparison false for NaN.
        let conditions = [
            (OP_F_ORD_GREATER_THAN, bb, zero.0),
            (OP_F_ORD_GREATER_THAN_EQUAL, bb, affine_bound),
            (OP_F_ORD_LESS_THAN_EQUAL, ee, tolerance),
            (OP_F_ORD_GREATER_THAN, k, zero.0),
            (OP_F_ORD_LESS_THAN, k, infinity.0),
            (OP_F_ORD_LESS_THAN, b_fit, zero.0),
            (OP_F_ORD_GREATER_THAN, b_fit, minus_infinity.0),
        ]
        .map(|(opcode, x, y)| code.typed(opcode, bool_type, &[x, y]));
        let accepted = conditions[1..].iter().fold(conditions[0], |all, &c| {
            code.typed(OP_LOGICAL_AND, bool_type, &[all, c])
        });
        // The selector (the pushed carrier's w): 1 and 3 complementary, 2 and 4 infinite; 3
        // and 4 for a line in [-1, 1] clip depth, converted to [0, 1]
        // (`revz_math::shader_fit::zero_to_one`).
        let pointer = code.typed(OP_ACCESS_CHAIN, push_vec4, &[push_variable, carrier_index]);
        let carrier = code.typed(OP_LOAD, vec4, &[pointer]);
        let selector = code.typed(OP_COMPOSITE_EXTRACT, float, &[carrier, 3]);
        let gl = code.typed(
            OP_F_ORD_GREATER_THAN,
            bool_type,
            &[selector, two_and_a_half.0],
        );
        let is_two = code.typed(OP_F_ORD_EQUAL, bool_type, &[selector, two.0]);
        let is_four = code.typed(OP_F_ORD_EQUAL, bool_type, &[selector, four.0]);
        let infinite = code.typed(OP_LOGICAL_OR, bool_type, &[is_two, is_four]);
        let k_plus_one = code.op(OP_F_ADD, k, one.0);
        let k_gl = code.op(OP_F_MUL, k_plus_one, half.0);
        let b_gl = code.op(OP_F_MUL, b_fit, half.0);
        let k = code.typed(OP_SELECT, float, &[gl, k_gl, k]);
        let b_fit = code.typed(OP_SELECT, float, &[gl, b_gl, b_fit]);
        let one_minus_k = code.op(OP_F_SUB, one.0, k);
        let neg_b = code.typed(OP_F_NEGATE, float, &[b_fit]);
        code.exact.push(neg_b);
        let near = code.op(OP_F_DIV, neg_b, k);
        let c_w = code.typed(OP_SELECT, float, &[infinite, zero.0, one_minus_k]);
        let c_1 = code.typed(OP_SELECT, float, &[infinite, near, neg_b]);
        let [flip_z, flip_w, flip_1] = FLIP_IN_SHADER;
        // The flip mapping's entries are 0, 1 and -1.
        let id_of = |value: f32| {
            if value == 0.0 {
                zero.0
            } else if value == 1.0 {
                one.0
            } else {
                minus_one.0
            }
        };
        // A refused fit: the flip mapping, halved where the clip depth is [-1, 1] and revz set
        // [0, 1] for the draw (`z' = (w - z) / 2`).
        let flip_z_gl = code.typed(OP_SELECT, float, &[gl, minus_half.0, id_of(flip_z)]);
        let flip_w_gl = code.typed(OP_SELECT, float, &[gl, half.0, id_of(flip_w)]);
        let out_z = code.typed(OP_SELECT, float, &[accepted, zero.0, flip_z_gl]);
        let out_w = code.typed(OP_SELECT, float, &[accepted, c_w, flip_w_gl]);
        let out_1 = code.typed(OP_SELECT, float, &[accepted, c_1, id_of(flip_1)]);
        // w = 1: the fit ran (the initializer's 0 says it did not, [`Self::select_at_return`]).
        let value = code.typed(OP_COMPOSITE_CONSTRUCT, vec4, &[out_z, out_w, out_1, one.0]);
        push(&mut code.words, OP_STORE, &[derived, value]);
        let Code { words, exact, .. } = code;
        Fit {
            leaf,
            bool_type,
            new_bool,
            derived,
            init,
            constants: vec![
                zero,
                one,
                minus_one,
                half,
                minus_half,
                two,
                two_and_a_half,
                four,
                residual,
                affine,
                infinity,
                minus_infinity,
            ],
            half: half.0,
            minus_half: minus_half.0,
            two_and_a_half: two_and_a_half.0,
            zero: zero.0,
            one: one.0,
            minus_one: minus_one.0,
            code: words,
            exact,
        }
    }

    /// `OpDecorate ... NoContraction` for every arithmetic result (annotation section).
    pub fn decorations(&self, out: &mut Vec<u32>) {
        for &id in &self.exact {
            push(out, OP_DECORATE, &[id, DECORATION_NO_CONTRACTION]);
        }
    }

    /// The constants, the bool type and the private variable (declaration section, after
    /// the float, `vec4` and the private `vec4` pointer type are declared).
    pub fn declarations(&self, out: &mut Vec<u32>, float: u32, vec4: u32, private_vec4: u32) {
        if self.new_bool {
            push(out, OP_TYPE_BOOL, &[self.bool_type]);
        }
        for &(id, value) in &self.constants {
            push(out, OP_CONSTANT, &[float, id, value.to_bits()]);
        }
        let id_of = |value: f32| {
            self.constants
                .iter()
                .find(|&&(_, v)| v == value)
                .map_or(0, |&(id, _)| id)
        };
        let [c_z, c_w, c_1] = FLIP_IN_SHADER;
        push(
            out,
            OP_CONSTANT_COMPOSITE,
            &[
                vec4,
                self.init,
                id_of(c_z),
                id_of(c_w),
                id_of(c_1),
                id_of(0.0),
            ],
        );
        push(
            out,
            OP_VARIABLE,
            &[private_vec4, self.derived, STORAGE_PRIVATE, self.init],
        );
    }

    /// At a return: the carrier components `(c_z, c_w, c_1)` to store with, the pushed ones
    /// (`pushed`, from the loaded `carrier`) where its selector is 0, the derived ones
    /// otherwise.
    pub fn select_at_return<F: FnMut() -> u32>(
        &self,
        out: &mut Vec<u32>,
        types: Types,
        carrier: u32,
        pushed: [u32; 3],
        fresh: &mut F,
    ) -> [u32; 3] {
        let Types { float, vec4, .. } = types;
        let (selector, use_derived, derived) = (fresh(), fresh(), fresh());
        push(out, OP_COMPOSITE_EXTRACT, &[float, selector, carrier, 3]);
        // 0.5: between the selector 0 of pushed values and the derived ones (1 to 4).
        push(
            out,
            OP_F_ORD_GREATER_THAN,
            &[self.bool_type, use_derived, selector, self.half],
        );
        push(out, OP_LOAD, &[vec4, derived, self.derived]);
        // The fit did not run before this return (its w is the initializer's 0): the flip
        // mapping, halved for a [-1, 1] line (selectors 3, 4).
        let (ran_w, ran, gl, flip_z, flip_w) = (fresh(), fresh(), fresh(), fresh(), fresh());
        push(out, OP_COMPOSITE_EXTRACT, &[float, ran_w, derived, 3]);
        push(
            out,
            OP_F_ORD_GREATER_THAN,
            &[self.bool_type, ran, ran_w, self.half],
        );
        push(
            out,
            OP_F_ORD_GREATER_THAN,
            &[self.bool_type, gl, selector, self.two_and_a_half],
        );
        push(
            out,
            OP_SELECT,
            &[float, flip_z, gl, self.minus_half, self.minus_one],
        );
        push(out, OP_SELECT, &[float, flip_w, gl, self.half, self.one]);
        let fallback = [flip_z, flip_w, self.zero];
        std::array::from_fn(|i| {
            let (component, known, selected) = (fresh(), fresh(), fresh());
            push(
                out,
                OP_COMPOSITE_EXTRACT,
                &[float, component, derived, i as u32],
            );
            push(out, OP_SELECT, &[float, known, ran, component, fallback[i]]);
            push(
                out,
                OP_SELECT,
                &[float, selected, use_derived, known, pushed[i]],
            );
            selected
        })
    }
}

/// `OpTypeBool`, `BufferBlock`, and the constant opcodes a constant leaf can be, for the
/// caller's declaration pass.
pub const TYPE_BOOL: u32 = OP_TYPE_BOOL;
pub const BUFFER_BLOCK: u32 = DECORATION_BUFFER_BLOCK;
pub const LABEL: u32 = OP_LABEL;

/// Declarations outside functions a constant leaf matrix can be.
pub fn is_matrix_constant(opcode: u32) -> bool {
    matches!(
        opcode,
        OP_CONSTANT_COMPOSITE | OP_CONSTANT_NULL | OP_SPEC_CONSTANT_COMPOSITE
    )
}
