//! Vertex shaders rewritten to store reversed depth into `Position` (issue #14, `shared/DESIGN.md`
//! section 2 as corrected in [`crate::precise`]): the precise path changes the depth where it is
//! made, and nothing else.
//!
//! [`rewrite_position_store`] turns the module's `Position` output into a private variable (the
//! *shadow*) that every load, store and access chain of the shader keeps using unchanged, and
//! adds, where the stage's output vertex is complete, one store of the shadow to the real
//! `Position` with its z replaced:
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
//! dynamic index into the block, more than one push-constant block, an entry point of another
//! stage than vertex, tessellation evaluation or geometry, or of two of them)
//! is refused with a reason, never guessed at; the pipeline's draws then take the flip path.
//!
//! Where the output vertex is complete depends on the stage (issue #41): before every
//! `OpReturn` of an entry point in a vertex or tessellation evaluation shader (one vertex per
//! invocation), before every `OpEmitVertex` / `OpEmitStreamVertex` of a geometry shader (in
//! any function: each emits the outputs as they are then; its returns emit nothing). Mesh
//! shaders (per-vertex `Position` arrays) are not rewritten.
//!
//! # Files
//! - this file: the entry points and `Module`, the declarations the rewrite needs;
//! - `declarations.rs`: the one pass over the words that fills `Module`;
//! - `body.rs`: what the function bodies do with `Position` (redirected chains, returns, stores);
//! - `rewrite.rs`: the rewrite proper, which emits the new words.

use std::collections::{HashMap, HashSet};
use std::fmt;

use crate::shader::derived_range::{
    self, CarrierIds, Fit, Insert, MatrixSource, ModuleFacts, PositionStores, Types,
};
use crate::shader::scan::model as scan_model;
use crate::shader::scan::op::*;
use crate::shader::scan::{instructions, is_literal, push, Instruction, HEADER_WORDS};

const STORAGE_PRIVATE: u32 = 6;
const STORAGE_OUTPUT: u32 = 3;
const STORAGE_INPUT: u32 = 1;
const CONSTANT_COMPOSITE: u32 = 44;
const STORAGE_PUSH_CONSTANT: u32 = 9;
const DECORATION_BLOCK: u32 = 2;
const DECORATION_ARRAY_STRIDE: u32 = 6;
const DECORATION_MATRIX_STRIDE: u32 = 7;
const DECORATION_BUILT_IN: u32 = 11;
const DECORATION_ROW_MAJOR: u32 = 4;
const DECORATION_OFFSET: u32 = 35;
const BUILT_IN_POSITION: u32 = 0;
/// SPIR-V 1.4: entry point interfaces list every global variable they use.
const VERSION_1_4: u32 = 0x0001_0400;

/// Why a module cannot get the `Position` rewrite.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Unsupported(pub &'static str);

impl fmt::Display for Unsupported {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.0)
    }
}

/// The module with its `Position` stores rewritten to read revz's carrier at byte `offset` of
/// the push constants (16-byte aligned), `None` when no entry point outputs `Position`,
/// or why it cannot be rewritten. Never panics, never reads past the words.
pub fn rewrite_position_store(words: &[u32], offset: u32) -> Result<Option<Vec<u32>>, Unsupported> {
    rewrite(words, CarrierRead::Pushed(offset), false).map(|code| code.map(|(code, _)| code))
}

/// Where a rewritten stage reads revz's carrier.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum CarrierRead {
    /// The 16 bytes revz reserves at this offset of the push constants (16-byte aligned),
    /// appended to the module's push-constant block: revz pushes each draw's values.
    Pushed(u32),
    /// A constant of the code: the values of one kind of draw, baked into a pipeline variant
    /// (issue #41: a layout whose push constants leave no room for the pushed carrier). The
    /// module's push-constant block is left as it is.
    Baked([f32; 4]),
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
    derive_position_store(words, offset)
        .map(|rewrite| rewrite.map(|rewrite| (rewrite.code, rewrite.source)))
}

/// A deriving rewrite ([`derive_position_store`]).
#[derive(Debug)]
pub struct DerivingRewrite {
    pub code: Vec<u32>,
    /// Where the matrix the stage fits comes from.
    pub source: MatrixSource,
    /// Where it lies in the push constants, where the stage loads it whole from a member of
    /// its push-constant block ([`derived_range::Leaf::push_slot`]).
    pub push_slot: Option<crate::shader::analysis::ProjectionSlot>,
    /// The matrix multiplies the previous stage's `Position` (`gl_in[i].gl_Position`): its w
    /// is 1 only where that stage stores w = 1 ([`stores_position_w_one`]), which the
    /// pipeline must check.
    pub assumes_input_unit_w: bool,
}

/// [`rewrite_position_store_deriving`], with what the rewrite assumes of the stage before.
pub fn derive_position_store(
    words: &[u32],
    offset: u32,
) -> Result<Option<DerivingRewrite>, Unsupported> {
    derive_position_store_reading(words, CarrierRead::Pushed(offset))
}

/// [`derive_position_store`] with the carrier read from `carrier`: [`CarrierRead::Baked`]
/// makes the stage of a variant that stores the derived depth its selector names (w: 1
/// complementary, 2 infinite) without any push constant of revz's.
pub fn derive_position_store_reading(
    words: &[u32],
    carrier: CarrierRead,
) -> Result<Option<DerivingRewrite>, Unsupported> {
    rewrite(words, carrier, true).map(|code| {
        code.map(|(code, leaf)| DerivingRewrite {
            code,
            source: leaf.map_or(MatrixSource::Computed, |l| l.source),
            push_slot: leaf.and_then(|l| l.push_slot),
            assumes_input_unit_w: leaf.is_some_and(|l| l.assumes_input_unit_w),
        })
    })
}

/// Whether every value the module's entry point stores into `Position` has w = 1 exactly
/// (`vec4(p, 1.0)`): what a later stage that projects its `gl_in[i].gl_Position` needs
/// ([`DerivingRewrite::assumes_input_unit_w`]). `false` for a module revz cannot read, or
/// that stores no `Position`. Never panics.
pub fn stores_position_w_one(words: &[u32]) -> bool {
    position_stores_answer(words, derived_range::stores_unit_w)
}

/// Whether the module's entry point only passes the previous stage's `Position` through
/// (`derived_range::passes_input_position_through`): a geometry stage that copies
/// `gl_in[i].gl_Position` into each vertex it emits, reading no z of it otherwise. `false` for a
/// module revz cannot read, or that stores no `Position`. Never panics.
pub fn passes_position_through(words: &[u32]) -> bool {
    position_stores_answer(words, derived_range::passes_input_position_through)
}

/// What `question` answers of the module's `Position` stores (its copies taken as stores);
/// `false` for a module revz cannot read, or that stores no `Position`.
fn position_stores_answer(
    words: &[u32],
    question: impl FnOnce(
        &[u32],
        &derived_range::ModuleFacts<'_>,
        &derived_range::PositionStores,
    ) -> bool,
) -> bool {
    let words = &*copies::position_copies_as_stores(words);
    let Ok(Some(module)) = Module::read(words) else {
        return false;
    };
    let Ok(Some(position)) = module.position() else {
        return false;
    };
    let Some(vec4) = module.position_vec4(position) else {
        return false;
    };
    let Ok(body) = body::Body::read(&module, words, position) else {
        return false;
    };
    let input_positions = module.input_positions();
    question(words, &module.facts(vec4, &input_positions), &body.stores)
}

/// A rewritten module, and the leaf its fit reads (deriving rewrites).
type Rewritten = (Vec<u32>, Option<derived_range::Leaf>);

fn rewrite(
    words: &[u32],
    carrier: CarrierRead,
    derive: bool,
) -> Result<Option<Rewritten>, Unsupported> {
    if matches!(carrier, CarrierRead::Pushed(offset) if offset % 16 != 0) {
        return Err(Unsupported("the carrier offset is not 16-byte aligned"));
    }
    let words = copies::position_copies_as_stores(words);
    let Some(module) = Module::read(&words)? else {
        return Ok(None);
    };
    module.rewrite(&words, carrier, derive).map(Some)
}

/// Where the shader's `Position` lives.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Position {
    /// A `vec4` output variable decorated `BuiltIn Position` (naga, DXC).
    Variable(u32),
    /// Member `member` of an output block (`gl_PerVertex`, glslang): the block variable.
    Member { block: u32, member: u32 },
    /// A mesh shader's per-vertex output array: member `member` of each block of it
    /// (`gl_MeshVerticesEXT`, glslang), or each element itself where `member` is `None` (an
    /// array of `vec4` decorated `BuiltIn Position`, DXC). Each vertex's `Position` is
    /// rewritten where it is stored whole: a mesh shader's invocations share their outputs,
    /// so no invocation has a vertex complete at any one instruction.
    MeshVertices { array: u32, member: Option<u32> },
}

/// The declarations the rewrite needs, from one pass over the words.
#[derive(Debug, Default)]
struct Module {
    version: u32,
    /// The entry points' execution model (`scan::model`: vertex, tessellation evaluation or
    /// geometry; any other, or two of them, refuses).
    model: u32,
    /// The entry function ids.
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
    /// Members decorated `RowMajor`.
    row_major_members: HashSet<(u32, u32)>,
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
    /// 32-bit constants whose word is 0, the bits of +0.0 (the w of an offset added to a
    /// position keeps its w).
    zeros: HashSet<u32>,
    /// The `GLSL.std.450` extended instruction set (`Fma` in a product written by columns).
    glsl_std: Option<u32>,
    /// Constant composites whose every constituent is 1.0.
    unit_vectors: HashSet<u32>,
}

mod body;
mod copies;
mod declarations;
mod rewrite;

#[cfg(test)]
mod tests;
