//! What the function bodies of a module do with `Position`: the access chains that point into
//! it, the returns of vertex entry points, and what is stored into it.

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
