//! What the function bodies of a module do with `Position`: the access chains that point into
//! it, the returns of vertex entry points, and what is stored into it (where a mesh shader
//! stores a vertex's `Position`, each store).

use super::*;

/// What the function bodies do with `Position`.
#[derive(Debug, Default)]
pub(super) struct Body {
    /// Access chains whose result points into the shadow (their result type becomes a
    /// private pointer, and a chain into the block's Position member starts at the shadow).
    pub(super) redirected: HashSet<u32>,
    /// The pointee types of those chains.
    pub(super) private_pointees: HashSet<u32>,
    /// Where the shadow goes to `Position` ([`Module::completes_vertex`]): the `OpReturn`s of
    /// vertex and tessellation evaluation entry functions, a geometry shader's emits.
    pub(super) returns: usize,
    /// What is stored into `Position` (for the derived range).
    pub(super) stores: PositionStores,
    /// A mesh shader's stores of a whole vertex `Position` (word indices): each is rewritten
    /// where it is ([`Position::MeshVertices`]), and counted in `returns`.
    pub(super) store_sites: HashSet<usize>,
}

impl Body {
    pub(super) fn read(
        module: &Module,
        words: &[u32],
        position: Position,
    ) -> Result<Body, Unsupported> {
        let mut body = Body::default();
        // Pointers into the shadow: the variable (which becomes it), or what chains into the
        // block's Position member.
        let mut shadowed: HashSet<u32> = HashSet::new();
        let (block, mesh) = match position {
            Position::Variable(var) => {
                shadowed.insert(var);
                (None, None)
            }
            Position::Member { block, member } => (Some((block, member)), None),
            Position::MeshVertices { array, member } => (None, Some((array, member))),
        };
        body.stores.at_store = mesh.is_some();
        // Pointers to one mesh vertex's whole Position.
        let mut vertex_positions: HashSet<u32> = HashSet::new();
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
                (
                    OP_ACCESS_CHAIN | OP_IN_BOUNDS_ACCESS_CHAIN,
                    &[_, result, base, _, ref rest @ ..],
                ) if Some(base) == mesh.map(|(array, _)| array) => {
                    let (_, member) = mesh.expect("matched");
                    let constant = |id: &u32| module.int_constants.get(id).copied();
                    match (member, rest) {
                        // The vertex's Position itself (a block's member, or the element).
                        (Some(member), [index]) if constant(index) == Some(member) => {
                            vertex_positions.insert(result);
                        }
                        (None, []) => {
                            vertex_positions.insert(result);
                        }
                        (Some(member), [index, ..]) if constant(index) == Some(member) => {
                            return Err(Unsupported(
                                "a component of a mesh vertex's Position is stored on its own",
                            ))
                        }
                        (None, [_, ..]) => {
                            return Err(Unsupported(
                                "a component of a mesh vertex's Position is stored on its own",
                            ))
                        }
                        // Another member of the vertex's block (PointSize, ClipDistance).
                        (Some(_), [index, ..]) if constant(index).is_some() => {}
                        (Some(_), [_, ..]) => {
                            return Err(Unsupported("a mesh vertex's block is indexed dynamically"))
                        }
                        (Some(_), []) => {
                            return Err(Unsupported("a mesh vertex's block is used whole"))
                        }
                    }
                }
                (OP_LOAD, &[_, _, pointer, ..]) if vertex_positions.contains(&pointer) => {
                    return Err(Unsupported("a mesh vertex's Position is read back"));
                }
                (OP_STORE, &[pointer, value, ..]) if vertex_positions.contains(&pointer) => {
                    body.stores.whole.push(value);
                    body.stores.whole_at.push(at);
                    body.store_sites.insert(at);
                    body.returns += 1;
                }
                _ if module.completes_vertex(opcode, current_function) => {
                    body.returns += 1;
                    if opcode != OP_RETURN {
                        body.stores.emits.push(at);
                    }
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
                        body.stores.whole_at.push(at);
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
                    let uses = |id: u32| {
                        shadowed.contains(&id)
                            || block.is_some_and(|(b, _)| b == id)
                            || mesh.is_some_and(|(array, _)| array == id)
                            || vertex_positions.contains(&id)
                    };
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
