//! The range a rewritten vertex stage derives from the matrix it loads (issue #16): where
//! revz cannot read the projection on the CPU (a uniform or storage buffer, a specialization
//! constant, a literal), the vertex stage fits the depth line of the outermost matrix it
//! multiplies into `Position` and stores reversed depth of that line.
//!
//! This module owns the two halves of that, word-level like [`crate::shader::position_store`], which
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
//!   precise values), 1 complementary, 2 infinite, 3 and 4 the same for a [-1, 1] line. Where
//!   the guard refuses, or before a fit runs, the return stores the flip mapping: `z' = w - z`
//!   (`(w - z) / 2` for 3 and 4).
//!
//! Why after the leaf's definition and not after the multiply: the leaf dominates every use
//! of it, also where it was reached through a local variable, so the fit is valid SSA there.
//!
//! Files: this one holds what both halves share (the leaf, where the matrix comes from, the
//! module's facts); `trace` follows `Position` back to the leaf ([`find`]); `fit` writes the
//! fit and the selection at the returns ([`Fit`]).

mod fit;
mod trace;

use std::collections::{HashMap, HashSet};

use revz_math::shader_fit::{
    AFFINE_W_TOLERANCE_SQUARED, FLIP_IN_SHADER, RESIDUAL_TOLERANCE_SQUARED,
};

use crate::shader::position_store::Unsupported;
use crate::shader::scan::op::*;
use crate::shader::scan::{instructions, push, Instruction, HEADER_WORDS};

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
const OP_DOT: u32 = 148;
const OP_RETURN_VALUE: u32 = 254;
/// `GLSL.std.450`'s `Fma` (`a * b + c`).
const GLSL_STD_FMA: u32 = 50;
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

/// The columns of a matrix-vector product written out by columns ([`Leaf::columns`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Columns {
    /// The columns multiplying x, y and z, in any order (the fitted line reads them only
    /// through sums over all three); `None` for one the compiler dropped with a component it
    /// knew to be 0 (`vec4(p.x, p.y, 0.0, 1.0)`): a column of zeros.
    pub xyz: [Option<u32>; 3],
    /// The column multiplying w (1: added alone, or times a w shown to be 1).
    pub w: u32,
}

impl Columns {
    /// The columns the product has, x to w.
    pub fn present(&self) -> impl Iterator<Item = u32> + '_ {
        self.xyz.iter().flatten().copied().chain([self.w])
    }

    /// Column `index` (0 to 3), `None` where it is a column of zeros.
    #[must_use]
    pub fn get(&self, index: usize) -> Option<u32> {
        match index {
            0..=2 => self.xyz[index],
            _ => Some(self.w),
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
    /// The matrix as the `vec4` columns of a product written out as
    /// `c0 * v.x + c1 * v.y + c2 * v.z + c3 * v.w` (Mesa's NIR, so Zink's SPIR-V), each sum
    /// fused or not.
    pub columns: Option<Columns>,
    /// The matrix's depth and w rows as `vec4`s, of a product written out as four dot
    /// products `vec4(dot(r0, v), dot(r1, v), dot(r2, v), dot(r3, v))` (translated HLSL, D3D
    /// bytecode's `dp4`).
    pub rows: Option<[u32; 2]>,
    pub insert: Insert,
    pub source: MatrixSource,
    /// Where the matrix lies in the push constants, where the stage loads it whole from a
    /// member of its push-constant block (a constant access chain, no array index): the CPU
    /// can read it from the pushed bytes as it reads a vertex stage's
    /// (`crate::shader::analysis`, which reads no later stage). `None` otherwise.
    pub push_slot: Option<crate::shader::analysis::ProjectionSlot>,
    /// Other loads of the same matrix (the same read-only location, loaded again by code
    /// written without a loop: a geometry shader's `P * p` before each emit), each with the
    /// word index of its definition: the fit runs after each of them too. Empty: none.
    pub copies: [Option<(u32, usize)>; MAX_LEAF_COPIES],
    /// The vector the matrix multiplies is the previous stage's `Position` (`gl_in[i]
    /// .gl_Position` in a geometry or tessellation evaluation shader): its w is 1 only where
    /// that stage stores w = 1 ([`stores_unit_w`]), which the pipeline checks.
    pub assumes_input_unit_w: bool,
}

/// The most other loads of the matrix a fit is repeated after ([`Leaf::copies`]): a geometry
/// shader emitting a strip of up to eight vertices written out one by one.
pub const MAX_LEAF_COPIES: usize = 7;

/// How `Position` is stored, as [`crate::shader::position_store`]'s body pass saw it.
#[derive(Debug, Default)]
pub struct PositionStores {
    /// Values stored into the whole `Position`, and the word index of each store.
    pub whole: Vec<u32>,
    pub whole_at: Vec<usize>,
    /// Word indices of a geometry shader's emits (empty in other stages): a store followed
    /// by an emit in its own block is emitted before the loop can run the leaf again.
    pub emits: Vec<usize>,
    /// Components stored alone (`None`: a dynamic or nested index).
    pub components: Vec<Option<u32>>,
    /// `OpCopyMemory` into or out of it.
    pub copied: bool,
    /// Each whole store is rewritten where it is (a mesh shader's vertices): a fit describes
    /// the stored vertex where it precedes the store in the store's block.
    pub at_store: bool,
}

pub use fit::{CarrierIds, Fit, Types, FIT_IDS, RETURN_IDS};
pub use trace::{find, passes_input_position_through, stores_unit_w};

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
    /// 32-bit constants whose word is 0 (+0.0, or Zink's uint 0 bitcast to it).
    pub zeros: &'a HashSet<u32>,
    /// The stage's inputs are vertex attributes (a vertex shader): a fetch of fewer than four
    /// components gives w = 1. A later stage's inputs are what the stage before stored.
    pub inputs_are_attributes: bool,
    /// Input variables that are arrays of blocks with a `Position` member (`gl_in`): the
    /// variable and the member's index.
    pub input_positions: &'a HashMap<u32, u32>,
    /// 32-bit integer constants: id -> value.
    pub int_constants: &'a HashMap<u32, u32>,
    /// Member decorations: (struct, member) -> `Offset` / `MatrixStride`; the members
    /// decorated `RowMajor`.
    pub member_offsets: &'a HashMap<(u32, u32), u32>,
    pub member_matrix_strides: &'a HashMap<(u32, u32), u32>,
    pub row_major_members: &'a HashSet<(u32, u32)>,
    /// The `GLSL.std.450` import, if the module has one (`Fma`).
    pub glsl_std: Option<u32>,
    /// The entry points' functions (which run once per invocation).
    pub entry_functions: &'a HashSet<u32>,
    /// Constant vectors whose every component is 1.0: a column times one of them is the
    /// column (an optimizer's `c3 * vec4(v.w)` with `v.w` folded to 1).
    pub unit_vectors: &'a HashSet<u32>,
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
