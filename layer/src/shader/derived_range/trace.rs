//! Which matrix: `Position`'s stores followed back, through copies, bitcasts and variables
//! stored once, to the outermost factor of a matrix-vector product (a matrix, or four columns
//! of a product written out by columns), and the checks that its line is the stored depth's.

#![allow(clippy::wildcard_imports)]

use super::*;

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
    /// Access chains of one constant index into a followed variable (a component of a
    /// vector register, as D3D translators write one): chain -> (variable, component).
    component_chains: HashMap<u32, (u32, u32)>,
    /// Stores through those chains: (variable, component) -> (value, word index).
    component_stores: HashMap<(u32, u32), Vec<(u32, usize)>>,
    /// Followed variables used other than as the pointer of a load or a store or the base
    /// of a component chain, or whose component chains are used other than as the pointer of
    /// a store or a load: their components are not only what is stored through the chains.
    escaped: HashSet<u32>,
    /// Every `Input` variable (never written by the shader: two loads of one read the same).
    input_variables: HashSet<u32>,
    /// Component counts of vector types.
    counts: HashMap<u32, u32>,
    /// Word ranges of loop constructs (from an `OpLoopMerge` to its merge block's label).
    loops: Vec<(usize, usize)>,
    /// Constants whose one word is the bits of 1.0 (a float, or Zink's uint bitcast to one).
    ones: HashSet<u32>,
    /// Constants whose one word is 0: +0.0, or Zink's uint 0 bitcast to it.
    zeros: HashSet<u32>,
    /// `Input` variables (vertex attributes: a fetch of fewer than 4 components gives w = 1).
    inputs: HashSet<u32>,
    /// Input arrays of blocks with a `Position` member, and the member ([`ModuleFacts`]).
    input_positions: HashMap<u32, u32>,
    int_constants: HashMap<u32, u32>,
    /// [`Defs::unit_w`] took a load of the previous stage's `Position` for w = 1.
    assumed_input_w: std::cell::Cell<bool>,
    /// A tessellation evaluation stage's affine combinations of the patch's input positions
    /// (`crate::shader::tessellation_positions::projected_affine_values`): w = 1 where the
    /// positions have it, which the pipeline checks as for a load of one.
    affine_inputs: HashSet<u32>,
    /// The `GLSL.std.450` import.
    glsl_std: Option<u32>,
    unit_vectors: HashSet<u32>,
    /// Each function's `OpReturnValue` values, and the word indices of the calls of each.
    returns: HashMap<u32, Vec<u32>>,
    calls: HashMap<u32, Vec<usize>>,
    /// Where each function starts (word index, function id), in order.
    functions: Vec<(usize, u32)>,
    entry_functions: HashSet<u32>,
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
        | OP_DOT
        | OP_EXT_INST
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
            component_chains: HashMap::new(),
            component_stores: HashMap::new(),
            escaped: HashSet::new(),
            input_variables: module
                .variables
                .iter()
                .filter(|(_, &(_, class))| class == STORAGE_INPUT)
                .map(|(&id, _)| id)
                .collect(),
            initialized: HashSet::new(),
            labels: Vec::new(),
            counts: module
                .vectors
                .iter()
                .map(|(&id, &(_, n))| (id, n))
                .collect(),
            loops: Vec::new(),
            ones: module.ones.clone(),
            zeros: module.zeros.clone(),
            inputs: module
                .variables
                .iter()
                .filter(|(_, &(_, class))| module.inputs_are_attributes && class == STORAGE_INPUT)
                .map(|(&id, _)| id)
                .collect(),
            input_positions: module.input_positions.clone(),
            int_constants: module.int_constants.clone(),
            assumed_input_w: std::cell::Cell::new(false),
            affine_inputs: if module.input_positions.is_empty() {
                HashSet::new()
            } else {
                crate::shader::tessellation_positions::projected_affine_values(words)
            },
            glsl_std: module.glsl_std,
            unit_vectors: module.unit_vectors.clone(),
            returns: HashMap::new(),
            calls: HashMap::new(),
            functions: Vec::new(),
            entry_functions: module.entry_functions.clone(),
        };
        let mut current_function = 0;
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
            // A component chain: one constant index into a followed variable.
            let component_chain = matches!(opcode, OP_ACCESS_CHAIN | OP_IN_BOUNDS_ACCESS_CHAIN)
                && operands.len() == 4
                && defs.followed.contains(&operands[2])
                && defs.int_constants.contains_key(&operands[3]);
            if opcode != OP_VARIABLE {
                for (index, operand) in operands.iter().enumerate() {
                    // A copy's source is read, as a load's pointer is (vkd3d-shader copies
                    // registers into outputs).
                    let pointer_use = matches!(
                        (opcode, index),
                        (OP_LOAD, 2) | (OP_STORE, 0) | (OP_COPY_MEMORY, 1)
                    );
                    if !pointer_use && defs.followed.contains(operand) {
                        defs.chained.insert(*operand);
                        if !(component_chain && index == 2) {
                            defs.escaped.insert(*operand);
                        }
                    }
                    if !pointer_use {
                        if let Some(&(variable, _)) = defs.component_chains.get(operand) {
                            defs.escaped.insert(variable);
                        }
                    }
                }
            }
            if component_chain {
                let component = defs.int_constants[&operands[3]];
                defs.component_chains
                    .insert(operands[1], (operands[2], component));
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
                (OP_STORE, &[pointer, value, ..]) => match defs.component_chains.get(&pointer) {
                    Some(&component) => {
                        defs.component_stores
                            .entry(component)
                            .or_default()
                            .push((value, at));
                    }
                    None => defs.stores.entry(pointer).or_default().push((value, at)),
                },
                (OP_ACCESS_CHAIN | OP_IN_BOUNDS_ACCESS_CHAIN, &[_, _, base, ..]) => {
                    defs.chained.insert(base);
                }
                (OP_COPY_MEMORY, &[target, ..]) => {
                    defs.chained.insert(target);
                }
                (OP_FUNCTION_CALL, &[_, _, callee, ref arguments @ ..]) => {
                    // A pointer argument may be written by the callee.
                    defs.chained.extend(arguments.iter().copied());
                    defs.calls.entry(callee).or_default().push(at);
                }
                (OP_FUNCTION, &[_, id, ..]) => {
                    current_function = id;
                    defs.functions.push((at, id));
                }
                (OP_RETURN_VALUE, &[value]) => {
                    defs.returns
                        .entry(current_function)
                        .or_default()
                        .push(value);
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

    /// Whether the instruction at `at` runs at most once per invocation: it lies outside loops
    /// in an entry function, or in a function called from exactly one place that runs at most
    /// once. A fit that may run again after the value it describes was stored (a helper called
    /// in a loop or from two places, the store skipped in the later run) could describe
    /// another matrix than the stored one.
    fn runs_once(&self, at: usize) -> bool {
        let mut at = at;
        for _ in 0..16 {
            if self.in_loop(at) {
                return false;
            }
            let Some(&(_, function)) = self.functions.iter().rev().find(|&&(start, _)| start <= at)
            else {
                return false;
            };
            if self.entry_functions.contains(&function) {
                return true;
            }
            match self.calls.get(&function).map(Vec::as_slice) {
                Some(&[call]) => at = call,
                _ => return false,
            }
        }
        false
    }

    /// Whether a fit right after word `at` describes the stored vertex: it runs once per
    /// invocation ([`Self::runs_once`]), or each store is emitted in its block
    /// ([`Self::emitted_where_fitted`]). `in_loop` is the reason given where `at` lies in a
    /// loop of its own function.
    fn fitted_once(
        &self,
        stores: &PositionStores,
        at: usize,
        in_loop: &'static str,
    ) -> Result<(), Unsupported> {
        if self.runs_once(at)
            || self.emitted_where_fitted(stores, at)
            || self.stored_where_fitted(stores, at)
        {
            Ok(())
        } else if self.in_loop(at) {
            Err(Unsupported(in_loop))
        } else {
            Err(Unsupported(
                "the projection is applied in a function that may run more than once",
            ))
        }
    }

    /// Whether no block starts between words `from` and `to`.
    fn same_block(&self, from: usize, to: usize) -> bool {
        from < to && !self.labels.iter().any(|&label| from < label && label < to)
    }

    /// Whether a fit right after word `fitted_at` describes every vertex a geometry shader
    /// emits, though it lies in a loop: each whole store of `Position` follows it in its block
    /// and is emitted there (an emit after the store, no block between), so no iteration can
    /// run the leaf again between the store and its emit. A geometry shader's loop over its
    /// input vertices is the usual place of its projection.
    fn emitted_where_fitted(&self, stores: &PositionStores, fitted_at: usize) -> bool {
        !stores.emits.is_empty()
            && stores.whole_at.iter().all(|&store| {
                self.same_block(fitted_at, store)
                    && stores
                        .emits
                        .iter()
                        .any(|&emit| self.same_block(store, emit))
            })
    }

    /// Whether a fit right after word `fitted_at` describes every vertex a mesh shader stores,
    /// though it lies in a loop: each store is rewritten where it is
    /// ([`PositionStores::at_store`]) and follows the fit in its block, so no iteration can run
    /// the leaf again between the fit and the store. A mesh shader's loop over the vertices
    /// its invocation writes is the usual place of its projection.
    fn stored_where_fitted(&self, stores: &PositionStores, fitted_at: usize) -> bool {
        stores.at_store
            && !stores.whole_at.is_empty()
            && stores
                .whole_at
                .iter()
                .all(|&store| self.same_block(fitted_at, store))
    }

    /// Component count of the vector `id` (by its result type), if known.
    fn components(&self, id: u32) -> Option<u32> {
        let (_, _, operands) = self.at.get(&id)?;
        self.counts.get(operands.first()?).copied()
    }

    /// Whether the vector a projection multiplies has w = 1 (what `z' = c_w w + c_1` assumes:
    /// the line's constant term is `B * v.w`): `vec4(p, 1.0)`, an attribute, a product of
    /// such a vector (by affine matrices), through copies, bitcasts and followed variables;
    /// the previous stage's `Position` too, noted in [`Self::assumed_input_w`] for the
    /// pipeline to check.
    fn unit_w(&self, vector: u32, depth: u32) -> bool {
        self.unit_w_of(vector, depth, true)
    }

    /// Whether a value stored into `Position` has w = 1 exactly: `vec4(p, 1.0)` through copies,
    /// bitcasts and followed variables; neither an input (what it holds is the stage before's
    /// or the application's data) nor a product (`through_products`: false).
    fn unit_w_of(&self, vector: u32, depth: u32, through_products: bool) -> bool {
        if depth > 16 {
            return false;
        }
        // An interpolation of the patch's positions (a tessellation evaluation stage that
        // projects them): w = 1 where theirs is, to the rounding of the weights' sum.
        if through_products && self.affine_inputs.contains(&vector) {
            self.assumed_input_w.set(true);
            return true;
        }
        let vector = self.unwrapped(vector);
        if through_products {
            if let Some((_, terms_w_one)) = self.column_source(vector) {
                return match terms_w_one {
                    ColumnW::Folded => true,
                    ColumnW::Of(source) => self.unit_w(source, depth + 1),
                };
            }
        }
        let Some((_, opcode, operands)) = self.at.get(&vector) else {
            return false;
        };
        let next = |id: u32| self.unit_w_of(id, depth + 1, through_products);
        match (*opcode, operands.as_slice()) {
            (OP_COMPOSITE_CONSTRUCT, [.., last]) if operands.len() > 2 => {
                let last = self.unwrapped(*last);
                self.ones.contains(&last)
            }
            (OP_MATRIX_TIMES_VECTOR, &[_, _, _, v]) if through_products => next(v),
            // An offset whose w is 0 added to the position (`vec4(n * d, 0.0) + p`, a
            // displacement along the normal): w + 0 is w, exactly.
            (OP_F_ADD, &[_, _, a, b]) => (self.zero_w(a) && next(b)) || (self.zero_w(b) && next(a)),
            (OP_COPY_OBJECT, &[_, _, source]) => next(source),
            (OP_FUNCTION_CALL, &[_, _, callee, ..]) => self.returned(callee).is_some_and(next),
            (OP_COMPOSITE_EXTRACT, &[_, _, composite, index]) => {
                self.member(composite, index).is_some_and(next)
            }
            (OP_LOAD, &[_, _, pointer, ..]) => {
                if through_products && self.inputs.contains(&pointer) {
                    return true;
                }
                if through_products && self.is_input_position(pointer) {
                    self.assumed_input_w.set(true);
                    return true;
                }
                self.through_local(pointer, self.at_of(vector))
                    .is_some_and(next)
            }
            _ => false,
        }
    }

    /// Whether `vector` is a construct whose last component is the constant +0.0.
    fn zero_w(&self, vector: u32) -> bool {
        match self.at.get(&self.unwrapped(vector)) {
            Some((_, OP_COMPOSITE_CONSTRUCT, operands)) if operands.len() > 2 => operands
                .last()
                .is_some_and(|&last| self.zeros.contains(&self.unwrapped(last))),
            _ => false,
        }
    }

    /// Whether `pointer` is `gl_in[i].gl_Position`: an access chain into an input array of
    /// blocks, at the block's `Position` member.
    fn is_input_position(&self, pointer: u32) -> bool {
        match self.at.get(&pointer) {
            Some((_, OP_ACCESS_CHAIN | OP_IN_BOUNDS_ACCESS_CHAIN, operands)) => {
                match operands.as_slice() {
                    &[_, _, base, _vertex, member] => {
                        self.input_positions.get(&base).is_some_and(|&position| {
                            self.int_constants.get(&member) == Some(&position)
                        })
                    }
                    _ => false,
                }
            }
            _ => false,
        }
    }

    /// The value `id` holds: through copies, bitcasts and loads of variables stored once, as
    /// [`Self::through_local`] follows them.
    fn held(&self, mut id: u32) -> u32 {
        for _ in 0..16 {
            id = self.unwrapped(id);
            match self.at.get(&id) {
                Some((_, OP_COPY_OBJECT, operands)) if operands.len() == 3 => id = operands[2],
                Some((at, OP_LOAD, operands)) if operands.len() >= 3 => {
                    match self.through_local(operands[2], *at) {
                        Some(stored) => id = stored,
                        None => break,
                    }
                }
                _ => break,
            }
        }
        id
    }

    /// The value a load (at word `load_at`) of a local or private variable stored exactly
    /// once, whole, reads; or, for one stored whole more than once (a register reassigned, as
    /// D3D translators write `mul r0, ..; mad r0, .., r0`, and glslang `-O0` a local), the
    /// last store before the load in the load's own block, where no call lies between them (a
    /// function called may store a private variable too).
    fn through_local(&self, pointer: u32, load_at: usize) -> Option<u32> {
        if !self.followed.contains(&pointer) {
            return None;
        }
        if self.chained.contains(&pointer) {
            return self.whole_over_components(pointer, load_at);
        }
        let stores = self.stores.get(&pointer)?;
        if stores.len() > 1 {
            let &(value, store_at) = stores
                .iter()
                .filter(|&&(_, at)| self.same_block(at, load_at))
                .max_by_key(|&&(_, at)| at)?;
            let call_between = self
                .calls
                .values()
                .flatten()
                .any(|&call| store_at < call && call < load_at);
            return (!call_between).then_some(value);
        }
        let &[(value, store_at)] = stores.as_slice() else {
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

    /// [`Self::through_local`] of a register also written one component at a time (Wine's
    /// vkd3d-shader: `r0.x = ...` through a constant-index access chain, later `r0 = fma(...)`
    /// whole): the value of the last whole store before the load in the load's own block,
    /// where no component store and no call lies between them, and the variable is used by
    /// nothing but loads, stores and such chains.
    fn whole_over_components(&self, pointer: u32, load_at: usize) -> Option<u32> {
        if self.escaped.contains(&pointer) {
            return None;
        }
        let &(value, store_at) = self
            .stores
            .get(&pointer)?
            .iter()
            .filter(|&&(_, at)| self.same_block(at, load_at))
            .max_by_key(|&&(_, at)| at)?;
        let between = |at: usize| store_at < at && at < load_at;
        let component_between = self
            .component_stores
            .iter()
            .filter(|(&(variable, _), _)| variable == pointer)
            .flat_map(|(_, stores)| stores)
            .any(|&(_, at)| between(at));
        let call_between = self.calls.values().flatten().any(|&call| between(call));
        (!component_between && !call_between).then_some(value)
    }

    /// The values a load (at word `load_at`) of a vector variable reads in its z and w, where
    /// the shader writes the variable only component by component (D3D translators write a
    /// register so: `dp4 o0.z, v0, cb0[2]` is a dot product stored through an access chain to
    /// `o0`'s third component), each of z and w exactly once; with the same ordering rule as
    /// [`Self::through_local`] (an initialized variable's stores earlier in the load's block).
    fn assembled(&self, pointer: u32, load_at: usize) -> Option<[u32; 2]> {
        if !self.followed.contains(&pointer)
            || self.escaped.contains(&pointer)
            || self.stores.contains_key(&pointer)
        {
            return None;
        }
        let component = |index: u32| {
            let &[(value, store_at)] = self.component_stores.get(&(pointer, index))?.as_slice()
            else {
                return None;
            };
            if self.initialized.contains(&pointer) && !self.same_block(store_at, load_at) {
                return None;
            }
            Some(value)
        };
        Some([component(2)?, component(3)?])
    }

    /// Whether two held values ([`Self::held`]) are the same: one id, or two loads of one
    /// `Input` variable (which the shader cannot write).
    fn same_held(&self, a: u32, b: u32) -> bool {
        let input_loaded = |id: u32| match self.at.get(&id) {
            Some((_, OP_LOAD, operands)) if operands.len() >= 3 => {
                Some(operands[2]).filter(|p| self.input_variables.contains(p))
            }
            _ => None,
        };
        a == b || input_loaded(a).is_some_and(|p| input_loaded(b) == Some(p))
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

    /// Whether `a` and `b` are loads of the same location of a uniform buffer or of push
    /// constants (the same variable, or access chains of the same base and index ids): the
    /// same value, which the shader cannot write.
    fn same_load(&self, module: &ModuleFacts<'_>, a: u32, b: u32) -> bool {
        let pointer = |id: u32| match self.at.get(&id) {
            Some((_, OP_LOAD, operands)) if operands.len() >= 3 => Some(operands[2]),
            _ => None,
        };
        let (Some(pa), Some(pb)) = (pointer(a), pointer(b)) else {
            return false;
        };
        let read_only = matches!(
            source_of(module, self, pa),
            MatrixSource::UniformBuffer | MatrixSource::PushConstants
        );
        let same_place = pa == pb
            || match (self.at.get(&pa), self.at.get(&pb)) {
                (
                    Some((_, OP_ACCESS_CHAIN | OP_IN_BOUNDS_ACCESS_CHAIN, x)),
                    Some((_, OP_ACCESS_CHAIN | OP_IN_BOUNDS_ACCESS_CHAIN, y)),
                ) => x.len() == y.len() && x.len() >= 3 && x[0] == y[0] && x[2..] == y[2..],
                _ => false,
            };
        read_only && same_place
    }

    /// The value a call returns, where revz can tell which: a function with one
    /// `OpReturnValue`, called once in the module, outside loops (its fit then describes the
    /// value the call returned; a function called again could fit another matrix last).
    fn returned(&self, callee: u32) -> Option<u32> {
        let &[value] = self.returns.get(&callee)?.as_slice() else {
            return None;
        };
        let &[call] = self.calls.get(&callee)?.as_slice() else {
            return None;
        };
        self.runs_once(call).then_some(value)
    }

    /// The multiply a whole `Position` value comes from: (matrix, transposed, vector).
    fn multiply(&self, value: u32, depth: u32) -> Option<(u32, bool, u32)> {
        if depth > 16 {
            return None;
        }
        let (_, opcode, operands) = self.at.get(&value)?;
        match (*opcode, operands.as_slice()) {
            (OP_FUNCTION_CALL, &[_, _, callee, ..]) => {
                self.multiply(self.returned(callee)?, depth + 1)
            }
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

    /// What a splat repeats: a component of a vector (`v.xxxx` as a shuffle or a construct of
    /// one extract), or any other scalar (a construct of four copies of it: Mesa's NIR splats
    /// a component the shader computed, `vec4(p.x, p.y + f(p), p.z, 1.0)`, so).
    fn splat(&self, id: u32) -> Option<Splat> {
        let id = self.unwrapped(id);
        match self.at.get(&id)? {
            // A component of the first vector (a larger index selects from the second).
            (_, OP_VECTOR_SHUFFLE, operands) => match operands.as_slice() {
                &[_, _, first, _, i, j, k, l]
                    if i == j && j == k && k == l && i < self.components(first)?.min(4) =>
                {
                    Some(Splat::Component(self.unwrapped(first), i))
                }
                _ => None,
            },
            (_, OP_COMPOSITE_CONSTRUCT, operands) => match operands.as_slice() {
                &[_, _, a, b, c, d] if a == b && b == c && c == d => match self.at.get(&a) {
                    Some((_, OP_COMPOSITE_EXTRACT, e))
                        if e.len() == 4 && e[3] < self.components(e[2])?.min(4) =>
                    {
                        Some(Splat::Component(self.unwrapped(e[2]), e[3]))
                    }
                    // A scalar (never a vector: four vectors would construct a matrix or a
                    // longer vector, which the caller's vec4 product cannot take).
                    _ if self.components(a).is_none() && self.components(id) == Some(4) => {
                        Some(Splat::Scalar)
                    }
                    _ => None,
                },
                _ => None,
            },
            _ => None,
        }
    }

    /// The sum's terms (operands of nested `OpFAdd`s and of `GLSL.std.450` `Fma`s, bitcasts
    /// looked through): each a product's factors, or a term added alone.
    fn terms(&self, id: u32, out: &mut Vec<Term>, depth: u32) -> Option<()> {
        if depth > 8 || out.len() > 4 {
            return None;
        }
        match self.at.get(&self.unwrapped(id)) {
            Some((_, OP_F_ADD, operands)) if operands.len() == 4 => {
                self.terms(operands[2], out, depth + 1)?;
                self.terms(operands[3], out, depth + 1)
            }
            // fma(a, b, c) = a * b + c, rounded once.
            Some((_, OP_EXT_INST, operands))
                if operands.len() == 7
                    && Some(operands[2]) == self.glsl_std
                    && operands[3] == GLSL_STD_FMA =>
            {
                out.push(Term::Product(operands[4], operands[5]));
                self.terms(operands[6], out, depth + 1)
            }
            Some((_, OP_F_MUL, operands)) if operands.len() == 4 => {
                out.push(Term::Product(operands[2], operands[3]));
                Some(())
            }
            // A partial sum kept in a register (`mad r0, v0.xxxx, cb0[0], r0`): the value a
            // store in the load's own block left there, whose terms are then defined where
            // the load is (the fit after the sum's root can use them).
            Some((load_at, OP_LOAD, operands)) if operands.len() >= 3 => {
                match self.through_local_in_block(operands[2], *load_at) {
                    Some(stored) => self.terms(stored, out, depth + 1),
                    None => {
                        out.push(Term::Alone(id));
                        Some(())
                    }
                }
            }
            _ => {
                out.push(Term::Alone(id));
                Some(())
            }
        }
    }

    /// [`Self::through_local`], where the store it follows lies in the load's own block.
    fn through_local_in_block(&self, pointer: u32, load_at: usize) -> Option<u32> {
        let stored = self.through_local(pointer, load_at)?;
        let store_at = self
            .stores
            .get(&pointer)?
            .iter()
            .find(|&&(value, at)| value == stored && self.same_block(at, load_at))?
            .1;
        (store_at < load_at).then_some(stored)
    }

    /// `vec4(dot(r0, v), dot(r1, v), dot(r2, v), dot(r3, v))` (each dot's operands in either
    /// order, through copies and variables stored once): the depth and w rows, the construct
    /// (where the fit goes) and `v`.
    fn row_dots(&self, value: u32, depth: u32) -> Option<([u32; 2], u32, u32)> {
        if depth > 16 {
            return None;
        }
        let value = self.unwrapped(value);
        let (_, opcode, operands) = self.at.get(&value)?;
        match (*opcode, operands.as_slice()) {
            (OP_COMPOSITE_CONSTRUCT, &[_, _, _x, _y, z, w]) => self.dot_rows(z, w, value),
            (OP_COPY_OBJECT, &[_, _, source]) => self.row_dots(source, depth + 1),
            (OP_FUNCTION_CALL, &[_, _, callee, ..]) => {
                self.row_dots(self.returned(callee)?, depth + 1)
            }
            (OP_LOAD, &[_, _, pointer, ..]) => {
                let load_at = self.at_of(value);
                if let Some(stored) = self.through_local(pointer, load_at) {
                    return self.row_dots(stored, depth + 1);
                }
                // A register written component by component: the fit goes after the later
                // of the two dot products (in one block, so that both rows are defined
                // there; the loaded value may be in another function, which the fit's
                // private variable reaches).
                let [z, w] = self.assembled(pointer, load_at)?;
                let (z_dot, w_dot) = (self.unwrapped(z), self.unwrapped(w));
                let (z_at, w_at) = (self.at_of(z_dot), self.at_of(w_dot));
                let (first, last, root) = if z_at < w_at {
                    (z_at, w_at, w_dot)
                } else {
                    (w_at, z_at, z_dot)
                };
                if !self.same_block(first, last) {
                    return None;
                }
                self.dot_rows(z, w, root)
            }
            (OP_COMPOSITE_EXTRACT, &[_, _, composite, index]) => {
                self.row_dots(self.member(composite, index)?, depth + 1)
            }
            _ => None,
        }
    }

    /// [`Self::row_dots`] of the dot products `z` and `w` (the position's depth and w), the
    /// fit placed after `root`.
    fn dot_rows(&self, z: u32, w: u32, root: u32) -> Option<([u32; 2], u32, u32)> {
        // Each dot's operands as used, and as the values they hold (a variable's loads are
        // one value): the held ones tell which operand is shared, the used ones (which
        // dominate the fit) are what the fit reads.
        let dot = |id: u32| match self.at.get(&self.unwrapped(id)) {
            Some((_, OP_DOT, operands)) if operands.len() == 4 => Some((
                [operands[2], operands[3]],
                [self.held(operands[2]), self.held(operands[3])],
            )),
            _ => None,
        };
        let ((z, z_held), (w, w_held)) = (dot(z)?, dot(w)?);
        // The vector both dots share (by index in each), and each one's row.
        let shared = (0..2)
            .flat_map(|i| (0..2).map(move |j| (i, j)))
            .find(|&(i, j)| {
                self.same_held(z_held[i], w_held[j])
                    && !self.same_held(z_held[1 - i], z_held[i])
                    && !self.same_held(w_held[1 - j], w_held[j])
            })?;
        let (i, j) = shared;
        Some(([z[1 - i], w[1 - j]], root, z[i]))
    }

    /// `c0 * v.x + c1 * v.y + c2 * v.z + c3 * v.w` (any order of the terms, `c3` alone where
    /// `v.w` was folded to 1): the columns, and the sum's root (where the fit goes).
    fn column_product(&self, value: u32) -> Option<(Columns, u32)> {
        self.column_parts(value)
            .map(|(columns, root, _)| (columns, root))
    }

    /// [`Self::column_product`]'s vector: its w folded to 1, or the vector the splats take
    /// their components from.
    fn column_source(&self, value: u32) -> Option<(Columns, ColumnW)> {
        self.column_parts(value).map(|(columns, _, w)| (columns, w))
    }

    fn column_parts(&self, value: u32) -> Option<(Columns, u32, ColumnW)> {
        let root = self.unwrapped(value);
        let mut terms = Vec::new();
        self.terms(value, &mut terms, 0)?;
        // Three terms: a component the compiler knew to be 0 dropped with its column
        // (`vec4(p.x, p.y, 0.0, 1.0)`).
        if !(3..=4).contains(&terms.len()) {
            return None;
        }
        let mut columns = [None; 4];
        // Columns times splats of scalars the shader computed, placed below.
        let mut unplaced = Vec::new();
        let mut vector = None;
        let mut bare = None;
        for term in terms {
            let (x, y) = match term {
                // A column times vec4(1.0): the column, as added alone.
                Term::Product(x, y) if self.unit_vectors.contains(&y) => {
                    if bare.replace(x).is_some() {
                        return None;
                    }
                    continue;
                }
                Term::Product(x, y) if self.unit_vectors.contains(&x) => {
                    if bare.replace(y).is_some() {
                        return None;
                    }
                    continue;
                }
                Term::Product(x, y) => (x, y),
                Term::Alone(term) => {
                    if bare.replace(term).is_some() {
                        return None;
                    }
                    continue;
                }
            };
            let (column, splat) = match (self.splat(x), self.splat(y)) {
                (None, Some(splat)) => (x, splat),
                (Some(splat), None) => (y, splat),
                _ => return None,
            };
            let index = match splat {
                // The splats may come from different vectors: the product is the matrix times
                // the vector of their components (vkd3d-shader's gears: x and y from a
                // register a rotation wrote, z and w from the input), and only its w, the one
                // column 3 takes, must be 1 for the fitted line.
                Splat::Component(source, 3) => {
                    vector = Some(source);
                    3
                }
                Splat::Component(_, index) => index,
                Splat::Scalar => {
                    unplaced.push(column);
                    continue;
                }
            };
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
        // A splat of a computed scalar multiplies x, y or z: the fitted line reads columns 0
        // to 2 only through sums over all three (`<r2.xyz, r3.xyz>`, `|r3.xyz|`), so which
        // free place each takes does not matter. The w column must be known (added alone, or
        // a splat of a w): a computed scalar there could be anything.
        for column in unplaced {
            *columns[..3].iter_mut().find(|c| c.is_none())? = Some(column);
        }
        let w_column = columns[3]?;
        let w = if folded {
            ColumnW::Folded
        } else {
            ColumnW::Of(vector?)
        };
        let columns = Columns {
            xyz: [columns[0], columns[1], columns[2]],
            w: w_column,
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

/// A term of a sum ([`Defs::terms`]).
#[derive(Clone, Copy, Debug)]
enum Term {
    /// `x * y`, multiplied alone or fused into an `Fma`.
    Product(u32, u32),
    /// Anything else, added as it is.
    Alone(u32),
}

/// What a splat multiplying a column repeats ([`Defs::splat`]).
#[derive(Clone, Copy, Debug)]
enum Splat {
    /// Component `.1` of vector `.0`: the column's index.
    Component(u32, u32),
    /// A scalar the shader computed: x, y or z of the vector the matrix multiplies.
    Scalar,
}

/// The w of the vector a column-form product multiplies.
#[derive(Clone, Copy, Debug)]
enum ColumnW {
    /// The product's last column is added alone: its w was 1, folded by the compiler.
    Folded,
    /// The vector the splat of the last column comes from (the other splats may come from
    /// others).
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
                let root_at = defs.at[&root].0;
                defs.fitted_once(stores, root_at, "the projection is applied in a loop")?;
                return written_out_leaf(module, &defs, WrittenOut::Columns(columns), root);
            }
            if let Some((rows, root, vector)) = defs.row_dots(*value, 0) {
                if !defs.unit_w(vector, 0) {
                    return Err(Unsupported(
                        "the vector the projection multiplies may not have w = 1",
                    ));
                }
                let root_at = defs.at[&root].0;
                defs.fitted_once(stores, root_at, "the projection is applied in a loop")?;
                return written_out_leaf(module, &defs, WrittenOut::Rows(rows), root);
            }
        }
    }
    let mut leaf: Option<(u32, bool)> = None;
    let mut copies: Vec<u32> = Vec::new();
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
        match leaf {
            None => leaf = Some(found),
            Some(first) if first == found => {}
            // Another load of the same read-only location: the same matrix.
            Some((first, first_transposed))
                if first_transposed == found.1 && defs.same_load(module, first, found.0) =>
            {
                if !copies.contains(&found.0) {
                    copies.push(found.0);
                }
            }
            Some(_) => return Err(Unsupported("Position comes from more than one matrix")),
        }
    }
    let (id, transposed) = leaf.ok_or(Unsupported("Position is never stored whole"))?;
    if copies.len() > MAX_LEAF_COPIES {
        return Err(Unsupported("Position comes from more than one matrix"));
    }
    let mut copy_slots = [None; MAX_LEAF_COPIES];
    for (slot, &copy) in copy_slots.iter_mut().zip(&copies) {
        let (at, ..) = defs.at[&copy];
        defs.fitted_once(stores, at, "the projection is loaded in a loop")?;
        *slot = Some((copy, at));
    }
    // A 4x4 matrix of the position's vec4 columns.
    let matrix_type = match defs.at.get(&id) {
        Some((_, _, operands)) => operands.first().copied(),
        None => None,
    };
    let mut push_slot = None;
    let (insert, source) = match defs.at.get(&id) {
        Some((at, opcode, operands)) => {
            let source = match (*opcode, operands.as_slice()) {
                (OP_PHI | OP_FUNCTION_PARAMETER, _) => {
                    return Err(Unsupported("the matrix is a phi or a parameter"))
                }
                (OP_LOAD, &[_, _, pointer, ..]) => {
                    push_slot = push_constant_slot(module, &defs, pointer, transposed);
                    source_of(module, &defs, pointer)
                }
                // A matrix member of a loaded block (naga loads the whole block).
                (OP_COMPOSITE_EXTRACT, &[_, _, composite, ..]) => match defs.at.get(&composite) {
                    Some((_, OP_LOAD, loaded)) => loaded
                        .get(2)
                        .map_or(MatrixSource::Computed, |&p| source_of(module, &defs, p)),
                    _ => MatrixSource::Computed,
                },
                _ => MatrixSource::Computed,
            };
            defs.fitted_once(stores, *at, "the projection is loaded in a loop")?;
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
        rows: None,
        copies: copy_slots,
        insert,
        source,
        push_slot,
        assumes_input_unit_w: defs.assumed_input_w.get(),
    })
}

/// Where a matrix loaded through `pointer` lies in the push constants: `pointer` is a constant
/// access chain to one member of a push-constant block (no array index), with an offset and a
/// matrix stride. `transposed` (`v * M`): the matrix used is the loaded one's transpose, whose
/// rows are the loaded one's columns. The caller checks the matrix is 4x4.
fn push_constant_slot(
    module: &ModuleFacts<'_>,
    defs: &Defs,
    pointer: u32,
    transposed: bool,
) -> Option<crate::shader::analysis::ProjectionSlot> {
    let (_, opcode, operands) = defs.at.get(&pointer)?;
    let &[_, _, base, index] = operands.as_slice() else {
        return None;
    };
    if !matches!(*opcode, OP_ACCESS_CHAIN | OP_IN_BOUNDS_ACCESS_CHAIN) {
        return None;
    }
    let &(variable_type, class) = module.variables.get(&base)?;
    if class != STORAGE_PUSH_CONSTANT {
        return None;
    }
    let &(_, block) = module.pointers.get(&variable_type)?;
    let member = *module.int_constants.get(&index)?;
    let key = (block, member);
    Some(crate::shader::analysis::ProjectionSlot {
        offset: *module.member_offsets.get(&key)?,
        matrix_stride: *module.member_matrix_strides.get(&key)?,
        row_major: module.row_major_members.contains(&key) != transposed,
        columns: 4,
        rows: 4,
    })
}

/// What a product written out by vectors gives the fit.
#[derive(Clone, Copy, Debug)]
enum WrittenOut {
    /// Its columns (`c0 * v.x + c1 * v.y + c2 * v.z + c3 * v.w`).
    Columns(Columns),
    /// Its depth and w rows (`vec4(dot(r0, v), dot(r1, v), dot(r2, v), dot(r3, v))`).
    Rows([u32; 2]),
}

/// The leaf of a product written out by vectors: each a `vec4` of the position's type, the fit
/// after the product's root (the sum, or the construct of the dots), which every vector
/// dominates.
fn written_out_leaf(
    module: &ModuleFacts<'_>,
    defs: &Defs,
    written: WrittenOut,
    root: u32,
) -> Result<Leaf, Unsupported> {
    let (vectors, refusal): (Vec<u32>, _) = match &written {
        WrittenOut::Columns(columns) => (
            columns.present().collect(),
            "the product's columns are not vec4s",
        ),
        WrittenOut::Rows(rows) => (rows.to_vec(), "the product's rows are not vec4s"),
    };
    let typed = |id: u32| {
        defs.at
            .get(&id)
            .is_some_and(|(_, _, operands)| operands.first() == Some(&module.vec4))
    };
    if !vectors.iter().all(|&v| typed(v)) {
        return Err(Unsupported(refusal));
    }
    let (at, ..) = defs.at[&root];
    let source = values_source(module, defs, vectors[0]);
    let (columns, rows) = match written {
        WrittenOut::Columns(columns) => (Some(columns), None),
        WrittenOut::Rows(rows) => (None, Some(rows)),
    };
    Ok(Leaf {
        id: 0,
        transposed: false,
        columns,
        rows,
        copies: [None; MAX_LEAF_COPIES],
        insert: Insert::After(at),
        source,
        push_slot: None,
        assumes_input_unit_w: defs.assumed_input_w.get(),
    })
}

/// Where a column's or row's values are loaded from (through bitcasts and constructs).
fn values_source(module: &ModuleFacts<'_>, defs: &Defs, value: u32) -> MatrixSource {
    let mut source = MatrixSource::Computed;
    let mut pending = vec![value];
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
            // A column or row of a loaded matrix.
            Some((_, OP_COMPOSITE_EXTRACT, operands)) if operands.len() >= 3 => {
                pending.push(operands[2]);
            }
            _ => {}
        }
    }
    source
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

/// Whether every value the stage stores into `Position` has w = 1 exactly (`vec4(p, 1.0)`,
/// through copies and variables stored once), with no component stored apart but x and y:
/// what a geometry or tessellation evaluation stage that projects `gl_in[i].gl_Position`
/// needs of the stage before it ([`Leaf::assumes_input_unit_w`]). `false` where it stores
/// none.
pub fn stores_unit_w(words: &[u32], module: &ModuleFacts<'_>, stores: &PositionStores) -> bool {
    if stores.copied
        || stores.whole.is_empty()
        || stores
            .components
            .iter()
            .any(|index| !matches!(index, Some(0 | 1)))
    {
        return false;
    }
    let Ok(defs) = Defs::read(words, module) else {
        return false;
    };
    stores
        .whole
        .iter()
        .all(|&value| defs.unit_w_of(value, 0, false))
}

/// Whether the stage only passes the previous stage's `Position` through: it stores
/// `gl_in[i].gl_Position` as loaded (through copies and bitcasts) into every whole `Position`
/// it stores, stores no component apart, and reads no z of those positions otherwise (x, y and
/// w it may: a wireframe overlay's edge distances, a culling test). Such a geometry stage
/// rasterizes the positions the stage before it stored, so that stage's `Position` rewrite
/// reaches the rasterizer unchanged: a copy keeps the line `z = k w + B` the rewrite stores on.
/// `false` where it stores none, reads a position through anything else (a variable, a
/// function, arithmetic), or reaches `gl_in` whole.
pub fn passes_input_position_through(
    words: &[u32],
    module: &ModuleFacts<'_>,
    stores: &PositionStores,
) -> bool {
    if stores.copied || stores.whole.is_empty() || !stores.components.is_empty() {
        return false;
    }
    let Ok(defs) = Defs::read(words, module) else {
        return false;
    };
    let position_stores: HashSet<usize> = stores.whole_at.iter().copied().collect();
    // Values that hold an input `Position`: its loads, their copies and bitcasts.
    let mut held: HashSet<u32> = HashSet::new();
    // Pointers to an input `Position` (loaded whole) or to one of its components other than z.
    let mut pointers: HashSet<u32> = HashSet::new();
    let mut word = HEADER_WORDS;
    for instruction in instructions(words).into_iter().flatten() {
        let Ok(Instruction { opcode, operands }) = instruction else {
            return false;
        };
        let at = word;
        word += operands.len() + 1;
        if at < module.functions_at {
            continue;
        }
        match (opcode, operands) {
            // An access chain into `gl_in`: to a vertex's `Position`, or to one of its
            // components (a constant other than z); to another member, nothing of it.
            (OP_ACCESS_CHAIN | OP_IN_BOUNDS_ACCESS_CHAIN, &[_, id, base, ref indices @ ..])
                if defs.input_positions.contains_key(&base) =>
            {
                let position = defs.input_positions[&base];
                match *indices {
                    [_vertex, member] if defs.int_constants.get(&member) == Some(&position) => {
                        pointers.insert(id);
                    }
                    [_vertex, member, component]
                        if defs.int_constants.get(&member) == Some(&position) =>
                    {
                        match defs.int_constants.get(&component) {
                            Some(&c) if c != 2 => {
                                pointers.insert(id);
                            }
                            _ => return false,
                        }
                    }
                    [_vertex, member, ..]
                        if defs
                            .int_constants
                            .get(&member)
                            .is_some_and(|&m| m != position) => {}
                    // A vertex's block whole, or a member index that is not constant.
                    _ => return false,
                }
                continue;
            }
            (OP_LOAD, &[_, id, pointer, ..]) if pointers.contains(&pointer) => {
                // A whole position is followed; a component (x, y or w) is an ordinary value.
                if defs.is_input_position(pointer) {
                    held.insert(id);
                }
                continue;
            }
            (OP_COPY_OBJECT | OP_BITCAST, &[_, id, source]) if held.contains(&source) => {
                held.insert(id);
                continue;
            }
            (OP_STORE, &[pointer, value, ..]) if held.contains(&value) => {
                if !position_stores.contains(&at) || pointers.contains(&pointer) {
                    return false;
                }
                continue;
            }
            (OP_COMPOSITE_EXTRACT, &[_, _, composite, ref indices @ ..])
                if held.contains(&composite) =>
            {
                if !matches!(indices, [0 | 1 | 3]) {
                    return false;
                }
                continue;
            }
            (OP_VECTOR_SHUFFLE, &[_, _, first, second, ref components @ ..])
                if held.contains(&first) || held.contains(&second) =>
            {
                let Some(first_count) = defs.components(first) else {
                    return false;
                };
                let reads_z = components.iter().any(|&c| {
                    (held.contains(&first) && c == 2)
                        || (held.contains(&second) && c.checked_sub(first_count) == Some(2))
                });
                if reads_z {
                    return false;
                }
                continue;
            }
            _ => {}
        }
        // Any other use of a held position or of a pointer to one (an argument, arithmetic,
        // a store into a variable), or of `gl_in` itself: not only passed through.
        if operands.iter().any(|operand| {
            held.contains(operand)
                || pointers.contains(operand)
                || defs.input_positions.contains_key(operand)
        }) {
            return false;
        }
    }
    stores.whole.iter().all(|value| held.contains(value))
}
