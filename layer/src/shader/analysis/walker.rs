//! The backwards data-flow walk through naga's IR: from the entry point's `Position` output,
//! through the wrapper naga generates, variables, calls and arguments, down the chain of
//! `Multiply`s to the outermost matrix, and to its push-constant member (see the module docs of
//! `crate::shader::analysis` for what is followed and what is not).

use naga::{
    AddressSpace, BinaryOperator, Binding, BuiltIn, Expression, Function, Handle, MathFunction,
    Module, ShaderStage, Statement, TypeInner,
};

use super::layout::SpirvLayout;
use super::{Analysis, ProjectionSlot};

/// How deep the backwards data-flow walk may go before giving up (guards against cycles such as
/// `x = x * M` in a loop, and against pathological modules).
const MAX_DEPTH: u32 = 64;

/// The analysis proper, on a parsed module.
pub(super) fn analyze_module(
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
