//! Which push-constant bytes hold the projection a vertex-stage shader applies to `Position`.
//!
//! `shared/DESIGN.md` section 2 ("Shader analysis"): the precise path rewrites a projection
//! in `vkCmdPushConstants`, so it must know exactly which bytes of the push-constant block the
//! shader multiplies into `Position`. Only the OUTERMOST matrix of the multiplication chain is
//! a candidate (an orthographic projection and a model matrix cannot be told apart by value, so
//! inner matrices are never rewritten).
//!
//! The analysis runs in two steps:
//! 1. [`has_push_constants`]: a linear scan of the words for an `OpVariable` in the
//!    `PushConstant` storage class. Modules without one (most of them) never reach naga.
//! 2. [`analyze`]: naga's `spv-in` front end builds the IR, and the data flow into the
//!    entry point's `Position` output is followed backwards: through the entry-point wrapper
//!    naga generates (which returns a struct built from `Private` globals), through stores to
//!    private and local variables, through function calls and arguments, down a chain of
//!    `Multiply` expressions to the outermost matrix. When that matrix is a `Load` of a member
//!    (possibly nested in structs or arrays) of the push-constant global, its byte range is the
//!    [`ProjectionSlot`].
//!
//! # Convention of [`ProjectionSlot`]
//! The slot describes the matrix `M` *as the shader uses it*: `clip = M * v` (column-vector
//! convention), whatever the source language wrote:
//! - `M * v` (GLSL) with a column-major member: `row_major = false`;
//! - a member decorated `RowMajor` (naga loads it as `transpose(stored)`): `row_major = true`;
//! - `v * X` (HLSL `mul(v, X)` style, vector on the left) is `clip = transpose(X) * v`, so `M`
//!   is `X` transposed: the storage order is reported flipped, as is an explicit `transpose()`.
//!
//! So with `row_major == false`, element `M[row][col]` is at
//! `offset + col * matrix_stride + row * 4`; with `row_major == true` it is at
//! `offset + row * matrix_stride + col * 4` (for 32-bit floats). `columns` and `rows` are
//! those of `M` (a projection is 4 x 4).
//!
//! naga's IR drops the `RowMajor` and `MatrixStride` member decorations (it loads a `RowMajor`
//! member through a pointer as `transpose(Load)`, but not when the whole block is loaded as one
//! value), so both are read straight from the words for the member the IR path designates; the
//! byte offset comes from naga's struct member offsets. naga's `spv-in` rejects any stride but
//! the natural one, which is also the fallback.
//!
//! # Limitations
//! - The chain must be made of `Multiply`s only. `M * v + offset`, a matrix scaled by a scalar,
//!   a matrix built from columns, or a dynamically indexed array of matrices are not followed
//!   (the answer is [`Analysis::NotFromPushConstants`]).
//! - A variable stored more than once counts only when every store leads to the same slot.
//! - The `Position` output is found through the entry point's result (naga has no output
//!   globals); with several push-constant variables in a module they are matched to naga's
//!   globals by order.
//! - naga cannot parse every module (e.g. Slang's `DrawParameters` capability): such modules
//!   are [`Analysis::Unreadable`] and take the flip path.

use std::panic::{catch_unwind, AssertUnwindSafe};

use naga::{
    AddressSpace, BinaryOperator, Binding, BuiltIn, Expression, Function, Handle, MathFunction,
    Module, ShaderStage, Statement, TypeInner,
};

use crate::shader::scan::{instructions, Instruction};

/// `OpVariable`.
const OP_VARIABLE: u32 = 59;
/// `StorageClass PushConstant`.
const STORAGE_CLASS_PUSH_CONSTANT: u32 = 9;
/// `OpTypeArray`, `OpTypeRuntimeArray`, `OpTypeStruct`, `OpTypePointer`.
const OP_TYPE_ARRAY: u32 = 28;
const OP_TYPE_RUNTIME_ARRAY: u32 = 29;
const OP_TYPE_STRUCT: u32 = 30;
const OP_TYPE_POINTER: u32 = 32;
/// `OpMemberDecorate`.
const OP_MEMBER_DECORATE: u32 = 72;
/// `Decoration RowMajor`, `Decoration MatrixStride`.
const DECORATION_ROW_MAJOR: u32 = 4;
const DECORATION_MATRIX_STRIDE: u32 = 7;
/// How deep the backwards data-flow walk may go before giving up (guards against cycles such as
/// `x = x * M` in a loop, and against pathological modules).
const MAX_DEPTH: u32 = 64;

/// Where the projection sits in the push-constant block (see the module docs for the
/// convention).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct ProjectionSlot {
    /// Byte offset of the matrix from the start of the push-constant block.
    pub offset: u32,
    /// Bytes between consecutive columns (`row_major == false`) or rows (`row_major == true`)
    /// of `M`.
    pub matrix_stride: u32,
    /// Whether the rows of `M` (as used in `clip = M * v`) are contiguous in memory.
    pub row_major: bool,
    /// Columns of `M`.
    pub columns: u8,
    /// Rows of `M`.
    pub rows: u8,
}

/// What the analysis found for one entry point.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Analysis {
    /// The module declares no push-constant variable (found without parsing it).
    NoPushConstants,
    /// The outermost matrix applied to `Position` is this push-constant member.
    Projection(ProjectionSlot),
    /// `Position` does not come from a push-constant matrix (uniform buffer, no matrix, a
    /// data flow the analysis does not follow, or no such entry point).
    NotFromPushConstants,
    /// naga could not read the module (or panicked on it): the message says why.
    Unreadable(String),
}

/// Whether the module declares a variable in the `PushConstant` storage class. A linear scan of
/// the words; a module that is not SPIR-V (bad magic, truncated instruction) answers `false`
/// without reading past the end.
pub fn has_push_constants(words: &[u32]) -> bool {
    scan_push_constants(words).unwrap_or(false)
}

/// The pre-filter proper: `Err` when the words are not a well-formed instruction stream up to
/// the first push-constant variable (or the end).
fn scan_push_constants(words: &[u32]) -> Result<bool, String> {
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
struct SpirvLayout {
    /// Pointee type of each push-constant variable, in module order.
    push_constants: Vec<u32>,
    /// `OpTypePointer`: pointer id -> pointee id.
    pointers: std::collections::HashMap<u32, u32>,
    /// `OpTypeStruct`: struct id -> member type ids.
    structs: std::collections::HashMap<u32, Vec<u32>>,
    /// `OpTypeArray` / `OpTypeRuntimeArray`: array id -> element id.
    arrays: std::collections::HashMap<u32, u32>,
    /// `OpMemberDecorate RowMajor` on (struct id, member).
    row_major: std::collections::HashSet<(u32, u32)>,
    /// `OpMemberDecorate MatrixStride` on (struct id, member).
    matrix_stride: std::collections::HashMap<(u32, u32), u32>,
}

impl SpirvLayout {
    /// Scans the words (already checked well-formed enough by naga).
    fn scan(words: &[u32]) -> Self {
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
    fn member(&self, ordinal: usize, path: &[u32]) -> Option<(u32, u32)> {
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

/// Finds which push-constant member is the outermost matrix of the multiplication chain that
/// produces the `Position` output of `entry_point` (a vertex-stage module, or the last
/// pre-rasterization stage). Never panics.
pub fn analyze(words: &[u32], entry_point: &str, stage: ShaderStage) -> Analysis {
    match scan_push_constants(words) {
        Ok(true) => {}
        Ok(false) => return Analysis::NoPushConstants,
        Err(message) => return Analysis::Unreadable(message),
    }
    let module = match parse(words) {
        Ok(module) => module,
        Err(message) => return Analysis::Unreadable(message),
    };
    match catch_unwind(AssertUnwindSafe(|| {
        let layout = SpirvLayout::scan(words);
        analyze_module(&module, &layout, entry_point, stage)
    })) {
        Ok(analysis) => analysis,
        Err(_) => Analysis::Unreadable("the analysis panicked on naga's IR".to_owned()),
    }
}

/// [`analyze`] for every vertex entry point of a module, parsing it once (at shader module
/// creation, when the pipeline that will name an entry point is not known yet). A module
/// without push constants answers an empty list without being parsed; `Err` says why naga
/// could not read it. Never panics.
pub fn analyze_vertex_entry_points(words: &[u32]) -> Result<Vec<(String, Analysis)>, String> {
    if !scan_push_constants(words)? {
        return Ok(Vec::new());
    }
    let stripped = crate::shader::scan::for_analysis(words);
    let words = stripped.as_deref().unwrap_or(words);
    let module = parse(words)?;
    catch_unwind(AssertUnwindSafe(|| {
        let layout = SpirvLayout::scan(words);
        module
            .entry_points
            .iter()
            .filter(|ep| ep.stage == ShaderStage::Vertex)
            .map(|ep| {
                let analysis = analyze_module(&module, &layout, &ep.name, ShaderStage::Vertex);
                (ep.name.clone(), analysis)
            })
            .collect()
    }))
    .map_err(|_| "the analysis panicked on naga's IR".to_owned())
}

/// Parses the module with naga's `spv-in`, turning errors and panics into a message.
fn parse(words: &[u32]) -> Result<Module, String> {
    let options = naga::front::spv::Options {
        // Keep `Position` as the module writes it: no y flip inserted into the wrapper.
        adjust_coordinate_space: false,
        strict_capabilities: false,
        block_ctx_dump_prefix: None,
    };
    let parsed = catch_unwind(AssertUnwindSafe(|| {
        naga::front::spv::Frontend::new(words.iter().copied(), &options).parse()
    }));
    match parsed {
        Ok(Ok(module)) => Ok(module),
        Ok(Err(error)) => Err(format!("naga spv-in: {error}")),
        Err(payload) => {
            let detail = payload
                .downcast_ref::<&str>()
                .map(|s| (*s).to_owned())
                .or_else(|| payload.downcast_ref::<String>().cloned())
                .unwrap_or_default();
            Err(format!("naga spv-in panicked: {detail}"))
        }
    }
}

/// The analysis proper, on a parsed module.
fn analyze_module(
    module: &Module,
    layout: &SpirvLayout,
    entry_point: &str,
    stage: ShaderStage,
) -> Analysis {
    let Some(index) = module
        .entry_points
        .iter()
        .position(|ep| ep.name == entry_point && ep.stage == stage)
    else {
        return Analysis::NotFromPushConstants;
    };
    let walker = Walker { module, layout };
    let function = Func::Entry(index);
    let f = walker.function(function);
    let Some(result) = &f.result else {
        return Analysis::NotFromPushConstants;
    };
    // The output is either the whole result (a `Position` binding on it) or one member of a
    // result struct.
    let member = match result.binding {
        Some(Binding::BuiltIn(BuiltIn::Position { .. })) => None,
        _ => match &module.types[result.ty].inner {
            TypeInner::Struct { members, .. } => {
                match members.iter().position(|m| {
                    matches!(m.binding, Some(Binding::BuiltIn(BuiltIn::Position { .. })))
                }) {
                    Some(i) => Some(i as u32),
                    None => return Analysis::NotFromPushConstants,
                }
            }
            _ => return Analysis::NotFromPushConstants,
        },
    };
    let mut returns = Vec::new();
    collect_returns(&f.body, &mut returns);
    let found = walker.merge(returns.into_iter().map(|value| {
        let value = Value {
            func: function,
            expr: value,
        };
        match member {
            None => walker.position(value, 0),
            Some(i) => walker.component(value, &[i], Target::Position, 0),
        }
    }));
    match found {
        Found::Slot(slot) => Analysis::Projection(slot),
        Found::None => Analysis::NotFromPushConstants,
    }
}

/// A function of the module: an entry point (its function is inline) or a regular one.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Func {
    Entry(usize),
    Regular(Handle<Function>),
}

/// An expression in the arena of a function.
#[derive(Clone, Copy, Debug)]
struct Value {
    func: Func,
    expr: Handle<Expression>,
}

/// The root of a memory location.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Root {
    Global(Handle<naga::GlobalVariable>),
    Local(Func, Handle<naga::LocalVariable>),
}

/// A memory location: a variable and a path of constant indices into it.
#[derive(Clone, Debug, PartialEq, Eq)]
struct Place {
    root: Root,
    path: Vec<u32>,
}

/// What the walk found for a value.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Found {
    Slot(ProjectionSlot),
    None,
}

/// What a value is expected to be, once reached through variables and calls.
#[derive(Clone, Copy, Debug)]
enum Target {
    /// The clip-space position: a vector, the result of `M * v`.
    Position,
    /// A matrix of the chain; `transposed` when the chain uses it transposed.
    Matrix { transposed: bool },
}

struct Walker<'m> {
    module: &'m Module,
    layout: &'m SpirvLayout,
}

impl<'m> Walker<'m> {
    fn function(&self, func: Func) -> &'m Function {
        match func {
            Func::Entry(i) => &self.module.entry_points[i].function,
            Func::Regular(h) => &self.module.functions[h],
        }
    }

    fn all_functions(&self) -> impl Iterator<Item = Func> + '_ {
        self.module
            .functions
            .iter()
            .map(|(h, _)| Func::Regular(h))
            .chain((0..self.module.entry_points.len()).map(Func::Entry))
    }

    fn expr(&self, value: Value) -> &'m Expression {
        &self.function(value.func).expressions[value.expr]
    }

    /// Whether the value's type is a matrix (types of expressions are resolved on demand,
    /// only for the few expressions the walk visits).
    fn is_matrix(&self, value: Value, depth: u32) -> bool {
        self.matrix_shape(value, depth).is_some()
    }

    /// The (columns, rows) of a matrix-typed value, when the walk can tell.
    fn matrix_shape(&self, value: Value, depth: u32) -> Option<(u8, u8)> {
        if depth > MAX_DEPTH {
            return None;
        }
        let f = self.function(value.func);
        if let Some(place) = self.loaded_place(value) {
            let ty = self.place_type(&place)?;
            return match self.module.types[ty].inner {
                TypeInner::Matrix { columns, rows, .. } => Some((columns as u8, rows as u8)),
                _ => None,
            };
        }
        let inner = match *self.expr(value) {
            Expression::Math {
                fun: MathFunction::Transpose,
                arg,
                ..
            } => {
                let (c, r) = self.matrix_shape(
                    Value {
                        func: value.func,
                        expr: arg,
                    },
                    depth + 1,
                )?;
                return Some((r, c));
            }
            Expression::Binary {
                op: BinaryOperator::Multiply,
                left,
                right,
            } => {
                let l = self.matrix_shape(
                    Value {
                        func: value.func,
                        expr: left,
                    },
                    depth + 1,
                )?;
                let r = self.matrix_shape(
                    Value {
                        func: value.func,
                        expr: right,
                    },
                    depth + 1,
                )?;
                return Some((r.0, l.1));
            }
            Expression::CallResult(callee) => {
                let ty = self.module.functions[callee].result.as_ref()?.ty;
                &self.module.types[ty].inner
            }
            Expression::FunctionArgument(i) => &self.module.types[f.arguments[i as usize].ty].inner,
            Expression::Compose { ty, .. } => &self.module.types[ty].inner,
            _ => return None,
        };
        match *inner {
            TypeInner::Matrix { columns, rows, .. } => Some((columns as u8, rows as u8)),
            _ => None,
        }
    }

    /// The type stored at a place.
    fn place_type(&self, place: &Place) -> Option<Handle<naga::Type>> {
        let mut ty = match place.root {
            Root::Global(g) => self.module.global_variables[g].ty,
            Root::Local(func, l) => self.function(func).local_variables[l].ty,
        };
        for &index in &place.path {
            ty = match self.module.types[ty].inner {
                TypeInner::Struct { ref members, .. } => members.get(index as usize)?.ty,
                TypeInner::Array { base, .. } => base,
                _ => return None,
            };
        }
        Some(ty)
    }

    /// The place a pointer expression designates, when all its indices are constants.
    fn place(&self, pointer: Value) -> Option<Place> {
        let mut path = Vec::new();
        let mut at = pointer.expr;
        let f = self.function(pointer.func);
        let root = loop {
            match f.expressions[at] {
                Expression::GlobalVariable(g) => break Root::Global(g),
                Expression::LocalVariable(l) => break Root::Local(pointer.func, l),
                Expression::AccessIndex { base, index } => {
                    path.push(index);
                    at = base;
                }
                Expression::Access { base, index } => {
                    path.push(self.constant_index(Value {
                        func: pointer.func,
                        expr: index,
                    })?);
                    at = base;
                }
                _ => return None,
            }
        };
        path.reverse();
        Some(Place { root, path })
    }

    /// The place a value was loaded from: a `Load`, or constant indices into a loaded value
    /// (naga writes `pc.m` both as `Load(AccessIndex(pc, m))` and as
    /// `AccessIndex(Load(pc), m)`).
    fn loaded_place(&self, value: Value) -> Option<Place> {
        let mut path = Vec::new();
        let mut at = value.expr;
        let f = self.function(value.func);
        let mut place = loop {
            match f.expressions[at] {
                Expression::Load { pointer } => {
                    break self.place(Value {
                        func: value.func,
                        expr: pointer,
                    })?
                }
                Expression::AccessIndex { base, index } => {
                    path.push(index);
                    at = base;
                }
                Expression::Access { base, index } => {
                    path.push(self.constant_index(Value {
                        func: value.func,
                        expr: index,
                    })?);
                    at = base;
                }
                _ => return None,
            }
        };
        path.reverse();
        place.path.extend(path);
        Some(place)
    }

    /// The value of a constant integer index expression.
    fn constant_index(&self, value: Value) -> Option<u32> {
        let literal = match *self.expr(value) {
            Expression::Literal(l) => l,
            Expression::Constant(c) => {
                match self.module.global_expressions[self.module.constants[c].init] {
                    Expression::Literal(l) => l,
                    _ => return None,
                }
            }
            _ => return None,
        };
        match literal {
            naga::Literal::U32(v) => Some(v),
            naga::Literal::I32(v) => u32::try_from(v).ok(),
            naga::Literal::U64(v) => u32::try_from(v).ok(),
            naga::Literal::I64(v) => u32::try_from(v).ok(),
            _ => None,
        }
    }

    /// Combines the findings of several sources of one value: a slot only when they all agree.
    fn merge(&self, found: impl Iterator<Item = Found>) -> Found {
        let mut result = None;
        for f in found {
            match (result, f) {
                (_, Found::None) => return Found::None,
                (None, slot) => result = Some(slot),
                (Some(a), b) if a == b => {}
                _ => return Found::None,
            }
        }
        result.unwrap_or(Found::None)
    }

    /// Dispatches on the target kind.
    fn follow(&self, value: Value, target: Target, depth: u32) -> Found {
        match target {
            Target::Position => self.position(value, depth),
            Target::Matrix { transposed } => self.matrix(value, transposed, depth),
        }
    }

    /// The clip-space position `value`: find the outermost matrix applied to it.
    fn position(&self, value: Value, depth: u32) -> Found {
        if depth > MAX_DEPTH {
            return Found::None;
        }
        let at = |expr| Value {
            func: value.func,
            expr,
        };
        match *self.expr(value) {
            Expression::Binary {
                op: BinaryOperator::Multiply,
                left,
                right,
            } => {
                if self.is_matrix(at(left), depth + 1) {
                    self.matrix(at(left), false, depth + 1)
                } else if self.is_matrix(at(right), depth + 1) {
                    // `v * X` is `transpose(X) * v`.
                    self.matrix(at(right), true, depth + 1)
                } else {
                    Found::None
                }
            }
            _ => self.through(value, &[], Target::Position, depth),
        }
    }

    /// The matrix `value` of the chain (used transposed when `transposed`): find its outermost
    /// factor and whether it is a push-constant member.
    fn matrix(&self, value: Value, transposed: bool, depth: u32) -> Found {
        if depth > MAX_DEPTH {
            return Found::None;
        }
        let at = |expr| Value {
            func: value.func,
            expr,
        };
        match *self.expr(value) {
            Expression::Binary {
                op: BinaryOperator::Multiply,
                left,
                right,
            } => {
                let (l, r) = (at(left), at(right));
                if !(self.is_matrix(l, depth + 1) && self.is_matrix(r, depth + 1)) {
                    // A matrix scaled by a scalar is not a member's bytes any more.
                    return Found::None;
                }
                // (A * B) applied to v: A is outermost; transposed, (A * B)^T = B^T * A^T.
                if transposed {
                    self.matrix(r, true, depth + 1)
                } else {
                    self.matrix(l, false, depth + 1)
                }
            }
            Expression::Math {
                fun: MathFunction::Transpose,
                arg,
                ..
            } => {
                // naga loads a `RowMajor` member through a pointer as `transpose(Load)`, to
                // compensate for its IR having column-major matrices only. That transpose is
                // not the shader's: the slot reads the decoration itself.
                if let Expression::Load { pointer } = *self.expr(at(arg)) {
                    if let Some(place) = self.place(at(pointer)) {
                        if let Some((true, _)) = self.push_constant_layout(&place) {
                            return self.slot(&place, transposed);
                        }
                    }
                }
                self.matrix(at(arg), !transposed, depth + 1)
            }
            _ => {
                if let Some(place) = self.loaded_place(value) {
                    if let Root::Global(g) = place.root {
                        if self.module.global_variables[g].space == AddressSpace::Immediate {
                            return self.slot(&place, transposed);
                        }
                    }
                }
                self.through(value, &[], Target::Matrix { transposed }, depth)
            }
        }
    }

    /// The slot of a matrix loaded from the push-constant global at `place`.
    fn slot(&self, place: &Place, transposed: bool) -> Found {
        let Root::Global(g) = place.root else {
            return Found::None;
        };
        let mut ty = self.module.global_variables[g].ty;
        let mut offset = 0u32;
        for &index in &place.path {
            match self.module.types[ty].inner {
                TypeInner::Struct { ref members, .. } => {
                    let Some(member) = members.get(index as usize) else {
                        return Found::None;
                    };
                    offset += member.offset;
                    ty = member.ty;
                }
                TypeInner::Array { base, stride, .. } => {
                    offset += index * stride;
                    ty = base;
                }
                _ => return Found::None,
            }
        }
        let TypeInner::Matrix {
            columns,
            rows,
            scalar,
        } = self.module.types[ty].inner
        else {
            return Found::None;
        };
        let (row_major_storage, stride) = self.push_constant_layout(place).unwrap_or((false, None));
        // naga's spv-in accepts only the natural stride (a column padded like a vector), so
        // that is the answer when the decoration cannot be found.
        let padded_rows: u32 = if rows as u32 == 2 { 2 } else { 4 };
        let matrix_stride = stride.unwrap_or(padded_rows * u32::from(scalar.width));
        // The SPIR-V value X is stored with its columns (or rows, `RowMajor`) contiguous; the
        // matrix as used, M, is X or, when transposed, X^T.
        let (columns, rows) = (columns as u8, rows as u8);
        let (columns, rows) = if transposed {
            (rows, columns)
        } else {
            (columns, rows)
        };
        Found::Slot(ProjectionSlot {
            offset,
            matrix_stride,
            row_major: row_major_storage != transposed,
            columns,
            rows,
        })
    }

    /// For a place in a push-constant global: whether its matrix member is decorated
    /// `RowMajor`, and its `MatrixStride`, read from the words.
    fn push_constant_layout(&self, place: &Place) -> Option<(bool, Option<u32>)> {
        let Root::Global(g) = place.root else {
            return None;
        };
        if self.module.global_variables[g].space != AddressSpace::Immediate {
            return None;
        }
        let ordinal = self
            .module
            .global_variables
            .iter()
            .filter(|(_, var)| var.space == AddressSpace::Immediate)
            .position(|(handle, _)| handle == g)?;
        let member = self.layout.member(ordinal, &place.path)?;
        Some((
            self.layout.row_major.contains(&member),
            self.layout.matrix_stride.get(&member).copied(),
        ))
    }

    /// Follows a value through variables, calls and arguments (with `member` a path still to
    /// take into it), then continues as `target`.
    fn through(&self, value: Value, member: &[u32], target: Target, depth: u32) -> Found {
        if depth > MAX_DEPTH {
            return Found::None;
        }
        match *self.expr(value) {
            Expression::Load { pointer } => {
                let Some(mut place) = self.place(Value {
                    func: value.func,
                    expr: pointer,
                }) else {
                    return Found::None;
                };
                place.path.extend_from_slice(member);
                self.place_value(&place, target, depth + 1)
            }
            Expression::CallResult(callee) => {
                let mut returns = Vec::new();
                collect_returns(&self.module.functions[callee].body, &mut returns);
                let func = Func::Regular(callee);
                self.merge(
                    returns.into_iter().map(|expr| {
                        self.component(Value { func, expr }, member, target, depth + 1)
                    }),
                )
            }
            Expression::FunctionArgument(i) => {
                let Func::Regular(callee) = value.func else {
                    return Found::None;
                };
                let calls = self.call_sites(callee);
                if calls.is_empty() {
                    return Found::None;
                }
                self.merge(calls.into_iter().map(|(caller, arguments)| {
                    match arguments.get(i as usize) {
                        Some(&expr) => {
                            self.component(Value { func: caller, expr }, member, target, depth + 1)
                        }
                        None => Found::None,
                    }
                }))
            }
            Expression::Compose { ref components, .. } if !member.is_empty() => {
                match components.get(member[0] as usize) {
                    Some(&expr) => self.component(
                        Value {
                            func: value.func,
                            expr,
                        },
                        &member[1..],
                        target,
                        depth + 1,
                    ),
                    None => Found::None,
                }
            }
            Expression::AccessIndex { base, index } => {
                // A member of a struct value (e.g. of a call result).
                let mut path = vec![index];
                path.extend_from_slice(member);
                self.through(
                    Value {
                        func: value.func,
                        expr: base,
                    },
                    &path,
                    target,
                    depth + 1,
                )
            }
            _ => Found::None,
        }
    }

    /// The `member` path of `value`, continued as `target`.
    fn component(&self, value: Value, member: &[u32], target: Target, depth: u32) -> Found {
        if member.is_empty() {
            self.follow(value, target, depth)
        } else {
            self.through(value, member, target, depth)
        }
    }

    /// What was stored at `place`: every store to it (or to an enclosing location, taking the
    /// remaining path into the stored value), in any function for a global, in its function
    /// for a local.
    fn place_value(&self, place: &Place, target: Target, depth: u32) -> Found {
        let functions: Vec<Func> = match place.root {
            Root::Global(_) => self.all_functions().collect(),
            Root::Local(func, _) => vec![func],
        };
        let mut sources = Vec::new();
        for func in functions {
            let f = self.function(func);
            let mut stores = Vec::new();
            collect_stores(&f.body, &mut stores);
            for (pointer, stored) in stores {
                let Some(stored_place) = self.place(Value {
                    func,
                    expr: pointer,
                }) else {
                    continue;
                };
                if stored_place.root != place.root {
                    continue;
                }
                if let Some(rest) = place.path.strip_prefix(stored_place.path.as_slice()) {
                    sources.push((Value { func, expr: stored }, rest.to_vec()));
                }
            }
        }
        // A local's initializer counts when nothing is stored to it (naga's spv-in gives
        // locals a zero initializer that the first store overwrites).
        if let (true, Root::Local(func, l)) = (sources.is_empty(), place.root) {
            if let Some(init) = self.function(func).local_variables[l].init {
                sources.push((Value { func, expr: init }, place.path.clone()));
            }
        }
        if sources.is_empty() {
            return Found::None;
        }
        self.merge(
            sources
                .into_iter()
                .map(|(value, rest)| self.component(value, &rest, target, depth + 1)),
        )
    }

    /// Every call to `callee`: the calling function and its argument expressions.
    fn call_sites(&self, callee: Handle<Function>) -> Vec<(Func, Vec<Handle<Expression>>)> {
        let mut sites = Vec::new();
        for func in self.all_functions() {
            let mut calls = Vec::new();
            collect_calls(&self.function(func).body, callee, &mut calls);
            sites.extend(calls.into_iter().map(|arguments| (func, arguments)));
        }
        sites
    }
}

/// Calls `visit` on every statement of a block, nested blocks included.
fn walk_block<'a>(block: &'a naga::Block, visit: &mut dyn FnMut(&'a Statement)) {
    for statement in block.iter() {
        visit(statement);
        match statement {
            Statement::Block(inner) => walk_block(inner, visit),
            Statement::If { accept, reject, .. } => {
                walk_block(accept, visit);
                walk_block(reject, visit);
            }
            Statement::Switch { cases, .. } => {
                for case in cases {
                    walk_block(&case.body, visit);
                }
            }
            Statement::Loop {
                body, continuing, ..
            } => {
                walk_block(body, visit);
                walk_block(continuing, visit);
            }
            _ => {}
        }
    }
}

fn collect_returns(block: &naga::Block, out: &mut Vec<Handle<Expression>>) {
    walk_block(block, &mut |statement| {
        if let Statement::Return { value: Some(value) } = *statement {
            out.push(value);
        }
    });
}

fn collect_stores(block: &naga::Block, out: &mut Vec<(Handle<Expression>, Handle<Expression>)>) {
    walk_block(block, &mut |statement| {
        if let Statement::Store { pointer, value } = *statement {
            out.push((pointer, value));
        }
    });
}

fn collect_calls(
    block: &naga::Block,
    callee: Handle<Function>,
    out: &mut Vec<Vec<Handle<Expression>>>,
) {
    walk_block(block, &mut |statement| {
        if let Statement::Call {
            function,
            ref arguments,
            ..
        } = *statement
        {
            if function == callee {
                out.push(arguments.clone());
            }
        }
    });
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shader::scan::{HEADER_WORDS, MAGIC};

    /// Compiles a GLSL vertex shader to SPIR-V with naga (no coordinate-space adjustment).
    fn compile(source: &str) -> Vec<u32> {
        crate::shader::test_spirv::compile_glsl(ShaderStage::Vertex, source)
    }

    fn analyze_glsl(source: &str) -> Analysis {
        analyze(&compile(source), "main", ShaderStage::Vertex)
    }

    fn column_major_mat4(offset: u32) -> Analysis {
        Analysis::Projection(ProjectionSlot {
            offset,
            matrix_stride: 16,
            row_major: false,
            columns: 4,
            rows: 4,
        })
    }

    /// A module whose matrix members are all decorated `RowMajor` instead of `ColMajor` (naga's
    /// GLSL front end has no `layout(row_major)`; the SPIR-V is patched instead).
    fn make_row_major(mut words: Vec<u32>) -> Vec<u32> {
        const OP_MEMBER_DECORATE: u32 = 72;
        const ROW_MAJOR: u32 = 4;
        const COL_MAJOR: u32 = 5;
        let mut at = HEADER_WORDS;
        let mut patched = 0;
        while at < words.len() {
            let count = (words[at] >> 16) as usize;
            if words[at] & 0xffff == OP_MEMBER_DECORATE && count == 4 && words[at + 3] == COL_MAJOR
            {
                words[at + 3] = ROW_MAJOR;
                patched += 1;
            }
            at += count;
        }
        assert!(patched > 0, "no ColMajor decoration to patch");
        words
    }

    const HEADER: &str = "#version 450\nlayout(location = 0) in vec3 position;\n";

    fn shader(declarations: &str, body: &str) -> String {
        format!("{HEADER}{declarations}\nvoid main() {{\n    vec4 pos = vec4(position, 1.0);\n    {body}\n}}\n")
    }

    #[test]
    fn scene_vert_mvp_at_offset_0() {
        // Case 1, both as written in the brief and as the scene's real shader.
        let inline = shader(
            "layout(push_constant) uniform PC { mat4 mvp; vec4 color; } pc;",
            "gl_Position = pc.mvp * vec4(position, 1.0);",
        );
        assert_eq!(analyze_glsl(&inline), column_major_mat4(0));
        let scene = include_str!("../../../shaders/scene.vert");
        assert_eq!(analyze_glsl(scene), column_major_mat4(0));
    }

    #[test]
    fn member_after_another_member() {
        let source = shader(
            "layout(push_constant) uniform PC { mat4 model; mat4 mvp; } pc;",
            "gl_Position = pc.mvp * pos;",
        );
        assert_eq!(analyze_glsl(&source), column_major_mat4(64));
        let source = shader(
            "layout(push_constant) uniform PC { vec4 tint; mat4 mvp; } pc;",
            "gl_Position = pc.mvp * pos;",
        );
        assert_eq!(analyze_glsl(&source), column_major_mat4(16));
    }

    #[test]
    fn nested_struct_member() {
        let source = shader(
            "struct Camera { vec4 eye; mat4 view_proj; };\n\
             layout(push_constant) uniform PC { mat4 model; Camera camera; } pc;",
            "gl_Position = pc.camera.view_proj * pc.model * pos;",
        );
        assert_eq!(analyze_glsl(&source), column_major_mat4(80));
    }

    #[test]
    fn outermost_of_a_chain() {
        let declarations =
            "layout(push_constant) uniform PC { mat4 model; mat4 view; mat4 proj; } pc;";
        for body in [
            "gl_Position = pc.proj * (pc.view * pos);",
            "gl_Position = pc.proj * pc.view * pos;",
            "gl_Position = pc.proj * pc.view * pc.model * pos;",
            "gl_Position = pc.proj * (pc.view * (pc.model * pos));",
            "gl_Position = (pc.proj * pc.view) * (pc.model * pos);",
        ] {
            assert_eq!(
                analyze_glsl(&shader(declarations, body)),
                column_major_mat4(128),
                "{body}"
            );
        }
    }

    #[test]
    fn through_locals_and_function_calls() {
        let declarations = "layout(push_constant) uniform PC { mat4 view; mat4 proj; } pc;\n\
             vec4 apply(mat4 m, vec4 p) { return m * p; }\n\
             mat4 combined() { return pc.proj * pc.view; }";
        for body in [
            "mat4 m = pc.proj * pc.view; gl_Position = m * pos;",
            "vec4 clip = pc.proj * (pc.view * pos); gl_Position = clip;",
            "gl_Position = apply(pc.proj, pc.view * pos);",
            "gl_Position = combined() * pos;",
        ] {
            assert_eq!(
                analyze_glsl(&shader(declarations, body)),
                column_major_mat4(64),
                "{body}"
            );
        }
    }

    #[test]
    fn row_major_member() {
        let source = shader(
            "layout(push_constant) uniform PC { vec4 color; mat4 mvp; } pc;",
            "gl_Position = pc.mvp * pos;",
        );
        let words = make_row_major(compile(&source));
        let expected = ProjectionSlot {
            offset: 16,
            matrix_stride: 16,
            row_major: true,
            columns: 4,
            rows: 4,
        };
        assert_eq!(
            analyze(&words, "main", ShaderStage::Vertex),
            Analysis::Projection(expected)
        );
    }

    #[test]
    fn vector_on_the_left_is_the_transposed_use() {
        let declarations = "layout(push_constant) uniform PC { mat4 a; mat4 b; } pc;";
        let transposed = |offset| {
            Analysis::Projection(ProjectionSlot {
                offset,
                matrix_stride: 16,
                row_major: true,
                columns: 4,
                rows: 4,
            })
        };
        // `v * B` = `B^T * v`; `v * A * B` = `(A B)^T v` = `B^T A^T v`: B is outermost.
        for (body, offset) in [
            ("gl_Position = pos * pc.b;", 64),
            ("gl_Position = pos * pc.a * pc.b;", 64),
            ("gl_Position = pos * (pc.a * pc.b);", 64),
            ("gl_Position = transpose(pc.a) * pos;", 0),
        ] {
            assert_eq!(
                analyze_glsl(&shader(declarations, body)),
                transposed(offset),
                "{body}"
            );
        }
        // HLSL style on a row-major member: two flips, the matrix is used as stored.
        let words = make_row_major(compile(&shader(declarations, "gl_Position = pos * pc.b;")));
        assert_eq!(
            analyze(&words, "main", ShaderStage::Vertex),
            column_major_mat4(64)
        );
    }

    #[test]
    fn projection_from_a_uniform_buffer_is_not_from_push_constants() {
        let declarations = "layout(set = 0, binding = 0) uniform Camera { mat4 proj; } camera;\n\
             layout(push_constant) uniform PC { mat4 model; } pc;";
        for body in [
            "gl_Position = camera.proj * pc.model * pos;",
            "gl_Position = camera.proj * pos;",
            "gl_Position = pos;",
            "gl_Position = 2.0 * pc.model * pos;",
            "gl_Position = pc.model * pos + vec4(1.0);",
        ] {
            assert_eq!(
                analyze_glsl(&shader(declarations, body)),
                Analysis::NotFromPushConstants,
                "{body}"
            );
        }
    }

    #[test]
    fn unknown_entry_point_or_stage() {
        let words = compile(include_str!("../../../shaders/scene.vert"));
        assert_eq!(
            analyze(&words, "other", ShaderStage::Vertex),
            Analysis::NotFromPushConstants
        );
        assert_eq!(
            analyze(&words, "main", ShaderStage::Fragment),
            Analysis::NotFromPushConstants
        );
    }

    #[test]
    fn no_push_constants_skips_naga() {
        let source = "#version 450\n\
             layout(set = 0, binding = 0) uniform Camera { mat4 proj; } camera;\n\
             layout(location = 0) in vec3 position;\n\
             void main() { gl_Position = camera.proj * vec4(position, 1.0); }\n";
        let words = compile(source);
        assert!(!has_push_constants(&words));
        assert_eq!(
            analyze(&words, "main", ShaderStage::Vertex),
            Analysis::NoPushConstants
        );
        assert!(has_push_constants(&compile(include_str!(
            "../../../shaders/scene.vert"
        ))));
        // Well-formed words naga would reject (an unknown opcode): the pre-filter answers
        // without parsing.
        let bogus = [MAGIC, 0x0001_0000, 0, 10, 0, (2 << 16) | 0xfff0, 7];
        assert!(!has_push_constants(&bogus));
        assert_eq!(
            analyze(&bogus, "main", ShaderStage::Vertex),
            Analysis::NoPushConstants
        );
        // An OpVariable in another storage class is not a push-constant block.
        let uniform = [
            MAGIC,
            0x0001_0000,
            0,
            10,
            0,
            (4 << 16) | OP_VARIABLE,
            1,
            2,
            2,
        ];
        assert!(!has_push_constants(&uniform));
        let push = [
            MAGIC,
            0x0001_0000,
            0,
            10,
            0,
            (4 << 16) | OP_VARIABLE,
            1,
            2,
            9,
        ];
        assert!(has_push_constants(&push));
    }

    #[test]
    fn unreadable_modules_never_panic() {
        let is_unreadable = |a: &Analysis| matches!(a, Analysis::Unreadable(_));
        assert!(is_unreadable(&analyze(&[], "main", ShaderStage::Vertex)));
        assert!(is_unreadable(&analyze(
            &[1, 2, 3, 4, 5, 6],
            "main",
            ShaderStage::Vertex
        )));
        // A push-constant variable followed by garbage.
        let garbage = [
            MAGIC,
            0x0001_0000,
            0,
            10,
            0,
            (4 << 16) | OP_VARIABLE,
            1,
            2,
            9,
            0xdead_beef,
        ];
        assert!(is_unreadable(&analyze(
            &garbage,
            "main",
            ShaderStage::Vertex
        )));
        // Every truncation of a real module: cut inside an instruction it is unreadable; cut
        // between two, naga may read a module without the function bodies (then `Position`
        // comes from nowhere), but never finds a projection.
        let words = compile(include_str!("../../../shaders/scene.vert"));
        for len in 0..words.len() {
            let analysis = analyze(&words[..len], "main", ShaderStage::Vertex);
            assert!(
                !matches!(analysis, Analysis::Projection(_)),
                "{len}: {analysis:?}"
            );
        }
        let mut boundaries = vec![];
        let mut at = HEADER_WORDS;
        while at < words.len() {
            boundaries.push(at);
            at += (words[at] >> 16) as usize;
        }
        let cut = boundaries[boundaries.len() / 2] + 1;
        assert!(is_unreadable(&analyze(
            &words[..cut],
            "main",
            ShaderStage::Vertex
        )));
        // Random corruption: any answer is fine, as long as there is one.
        let mut state = 0x9e37_79b9_7f4a_7c15_u64;
        for _ in 0..300 {
            let mut corrupted = words.clone();
            for _ in 0..3 {
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                let at = HEADER_WORDS + (state as usize) % (words.len() - HEADER_WORDS);
                corrupted[at] ^= 1 << ((state >> 32) % 32);
            }
            let _ = analyze(&corrupted, "main", ShaderStage::Vertex);
        }
    }

    /// A string operand: UTF-8, NUL-terminated, padded to whole words.
    fn string_words(text: &str) -> Vec<u32> {
        let mut bytes = text.as_bytes().to_vec();
        bytes.resize((bytes.len() / 4 + 1) * 4, 0);
        bytes
            .chunks_exact(4)
            .map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect()
    }

    #[test]
    fn what_naga_rejects_but_the_analysis_does_not_need_is_removed_first() {
        // The scene shader with a Slang/DXC-style preamble naga refuses: a capability it does
        // not list, an extension it does not know, and a non-semantic instruction set.
        let mut words = compile(include_str!("../../../shaders/scene.vert"));
        let bound = words[3];
        words[3] = bound + 1;
        let mut preamble = vec![(2 << 16) | 17, 4427]; // OpCapability DrawParameters
        let extension = string_words("SPV_KHR_shader_draw_parameters");
        preamble.push(((extension.len() as u32 + 1) << 16) | 10);
        preamble.extend(extension);
        let set = string_words("NonSemantic.DebugPrintf");
        preamble.push(((set.len() as u32 + 2) << 16) | 11);
        preamble.push(bound);
        preamble.extend(set);
        words.splice(HEADER_WORDS..HEADER_WORDS, preamble);

        assert!(parse(&words).is_err(), "naga alone rejects the module");
        let entries = analyze_vertex_entry_points(&words).expect("readable once stripped");
        assert_eq!(entries, vec![("main".to_owned(), column_major_mat4(0))]);
        // Stripping keeps a module naga already reads as it is.
        let plain = compile(include_str!("../../../shaders/scene.vert"));
        let stripped = crate::shader::scan::for_analysis(&plain);
        assert!(stripped.is_none_or(|words| parse(&words).is_ok()));
    }
}
