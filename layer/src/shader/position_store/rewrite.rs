//! The rewrite proper: from the declarations and the bodies, the new words (the shadow, the
//! carrier member, the stores before each return, a mesh shader's stores rewritten where they
//! are, and for deriving rewrites the fit of `crate::shader::derived_range`).

use super::body::Body;
use super::declarations::{declaration_ids, result_id};
use super::*;

impl Module {
    pub(super) fn rewrite(
        &self,
        words: &[u32],
        carrier: CarrierRead,
        derive: bool,
    ) -> Result<Rewritten, Unsupported> {
        // A baked carrier leaves the push constants alone: no member appended, no block.
        let pushed_offset = match carrier {
            CarrierRead::Pushed(offset) => Some(offset),
            CarrierRead::Baked(_) => None,
        };
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
            // Stored through the shader's own pointers: no output pointer of revz's.
            Position::MeshVertices { .. } => (
                0,
                self.position_vec4(position)
                    .ok_or(Unsupported("a mesh shader's Position is not a vec4"))?,
            ),
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
        let app_block = match (pushed_offset, push_variables.as_slice()) {
            (None, _) | (Some(_), []) => None,
            (Some(offset), [variable]) => {
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
            (Some(_), _) => return Err(Unsupported("more than one push-constant block")),
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
                return Err(Unsupported("more than one entry point"));
            }
            let input_positions = self.input_positions();
            let facts = self.facts(vec4, &input_positions);
            Some(derived_range::find(words, &facts, &body.stores)?)
        } else {
            None
        };

        // Fresh ids.
        let needed = 36
            + 16 * body.returns
            + 2 * body.private_pointees.len()
            + derived_range::FIT_IDS * (1 + derived_range::MAX_LEAF_COPIES)
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
            None if pushed_offset.is_some() => (fresh(), true),
            None => (0, false),
        };
        let (push_variable, push_block, carrier_member, new_block) = match app_block {
            Some((variable, block, members)) => (variable, block, members, None),
            None if pushed_offset.is_some() => {
                let (block, pointer, variable) = (fresh(), fresh(), fresh());
                (variable, block, 0, Some(pointer))
            }
            None => (0, 0, 0, None),
        };
        let carrier_index = fresh();
        // A baked carrier: its four float constants and the composite of them.
        let baked = match carrier {
            CarrierRead::Baked(values) => Some((values, [0; 4].map(|_| fresh()), fresh())),
            CarrierRead::Pushed(_) => None,
        };
        let carrier_ids = match baked {
            Some((_, _, composite)) => CarrierIds::Constant(composite),
            None => CarrierIds::Pushed {
                push_vec4,
                push_variable,
                carrier_index,
            },
        };
        // The shadow: for a variable, the variable itself (now private) and a new output in
        // its place; for a block member, a new private variable.
        let (shadow, output) = match position {
            Position::Variable(var) => (var, fresh()),
            Position::Member { block, .. } => (fresh(), block),
            Position::MeshVertices { .. } => (0, 0),
        };
        let member_index = match position {
            Position::Member { member, .. } => Some((fresh(), member)),
            Position::Variable(_) | Position::MeshVertices { .. } => None,
        };
        let mesh_vertices = matches!(position, Position::MeshVertices { .. });
        let out_vec4 = if out_pointer != 0 || mesh_vertices {
            (out_pointer, false)
        } else {
            (fresh(), true)
        };
        let types = Types {
            float,
            vec4,
            carrier: carrier_ids,
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
                if let Some(offset) = pushed_offset {
                    push(
                        &mut out,
                        OP_MEMBER_DECORATE,
                        &[push_block, carrier_member, DECORATION_OFFSET, offset],
                    );
                }
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
                match baked {
                    None => push(&mut out, OP_CONSTANT, &[int, carrier_index, carrier_member]),
                    Some((values, ids, composite)) => {
                        for (id, value) in ids.into_iter().zip(values) {
                            push(&mut out, OP_CONSTANT, &[float, id, value.to_bits()]);
                        }
                        let mut operands = vec![vec4, composite];
                        operands.extend_from_slice(&ids);
                        push(&mut out, CONSTANT_COMPOSITE, &operands);
                    }
                }
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
                    // No shadow; the fit's private variable needs the pointer type.
                    Position::MeshVertices { .. } => {
                        if new_private_vec4 {
                            push(
                                &mut out,
                                OP_TYPE_POINTER,
                                &[private_vec4, STORAGE_PRIVATE, vec4],
                            );
                        }
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
                        if pushed_offset.is_some()
                            && (new_block.is_some() || !interface.contains(&push_variable))
                        {
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
                (OP_STORE, &[pointer, value, ref rest @ ..])
                    if in_functions && body.store_sites.contains(&at) =>
                {
                    // A mesh vertex's Position, rewritten where it is stored.
                    let stored = stored_depth(&mut out, &mut fresh, value, types, fit.as_ref());
                    let mut store = vec![pointer, stored];
                    store.extend_from_slice(rest);
                    push(&mut out, opcode, &store);
                }
                _ if self.completes_vertex(opcode, current_function) => {
                    let value = fresh();
                    push(&mut out, OP_LOAD, &[vec4, value, shadow]);
                    let stored = stored_depth(&mut out, &mut fresh, value, types, fit.as_ref());
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
            if let Some(fit) = &fit {
                for (after, code) in &fit.copies {
                    if *after == at {
                        out.extend_from_slice(code);
                    }
                }
            }
        }
        if fit_at_entry {
            return Err(Unsupported("the entry point has no block for the fit"));
        }
        out[3] = bound;
        Ok((out, fit.map(|f| f.leaf)))
    }
}

/// Emits `value` with its z replaced by `c_z * z + c_w * w + c_1` of revz's carrier (loaded
/// from the push constants, or the baked constant; the fit's values where a deriving rewrite's
/// selector picks them), and returns the id of the `vec4` to store.
fn stored_depth<F: FnMut() -> u32>(
    out: &mut Vec<u32>,
    fresh: &mut F,
    value: u32,
    types: Types,
    fit: Option<&Fit>,
) -> u32 {
    let Types { float, vec4, .. } = types;
    let [carrier_pointer, carrier, c_z, c_w, c_1, z, w, scaled_z, scaled_w, sum, depth, stored] =
        [0; 12].map(|_| fresh());
    let carrier = match types.carrier {
        CarrierIds::Pushed {
            push_vec4,
            push_variable,
            carrier_index,
        } => {
            push(
                out,
                OP_ACCESS_CHAIN,
                &[push_vec4, carrier_pointer, push_variable, carrier_index],
            );
            push(out, OP_LOAD, &[vec4, carrier, carrier_pointer]);
            carrier
        }
        CarrierIds::Constant(composite) => composite,
    };
    push(out, OP_COMPOSITE_EXTRACT, &[float, c_z, carrier, 0]);
    push(out, OP_COMPOSITE_EXTRACT, &[float, c_w, carrier, 1]);
    push(out, OP_COMPOSITE_EXTRACT, &[float, c_1, carrier, 2]);
    let [c_z, c_w, c_1] = match fit {
        Some(fit) => fit.select_at_return(out, types, carrier, [c_z, c_w, c_1], fresh),
        None => [c_z, c_w, c_1],
    };
    push(out, OP_COMPOSITE_EXTRACT, &[float, z, value, 2]);
    push(out, OP_COMPOSITE_EXTRACT, &[float, w, value, 3]);
    push(out, OP_F_MUL, &[float, scaled_z, c_z, z]);
    push(out, OP_F_MUL, &[float, scaled_w, c_w, w]);
    push(out, OP_F_ADD, &[float, sum, scaled_z, scaled_w]);
    push(out, OP_F_ADD, &[float, depth, sum, c_1]);
    push(out, OP_COMPOSITE_INSERT, &[vec4, stored, depth, value, 2]);
    stored
}
