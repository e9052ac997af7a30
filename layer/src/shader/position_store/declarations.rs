//! The one pass over the words that reads the declarations the `Position` rewrite needs into
//! [`Module`], and the questions asked of them (where `Position` is, type sizes).

use super::*;

impl Module {
    pub(super) fn read(words: &[u32]) -> Result<Option<Module>, Unsupported> {
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
                    if !matches!(
                        model,
                        scan_model::VERTEX
                            | scan_model::TESSELLATION_EVALUATION
                            | scan_model::GEOMETRY
                            | scan_model::MESH_EXT
                    ) {
                        return Err(Unsupported(
                            "the module has an entry point of a stage other than vertex, \
                             tessellation evaluation, geometry or mesh",
                        ));
                    }
                    if !m.entry_functions.is_empty() && m.model != model {
                        return Err(Unsupported(
                            "the module's entry points are of several stages",
                        ));
                    }
                    m.model = model;
                    m.entry_functions.insert(function);
                }
                (CONSTANT_COMPOSITE, &[ty, id, ref constituents @ ..])
                    if !constituents.is_empty()
                        && constituents.iter().all(|c| m.ones.contains(c)) =>
                {
                    m.unit_vectors.insert(id);
                    m.global_opcodes.insert(id, opcode);
                    m.global_types.insert(id, ty);
                }
                (OP_EXT_INST_IMPORT, &[id, ref name @ ..]) => {
                    let bytes: Vec<u8> = name.iter().flat_map(|w| w.to_le_bytes()).collect();
                    if bytes.starts_with(b"GLSL.std.450\0") {
                        m.glsl_std = Some(id);
                    }
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
                (OP_MEMBER_DECORATE, &[ty, member, DECORATION_ROW_MAJOR]) => {
                    m.row_major_members.insert((ty, member));
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
                    if value == 0 {
                        m.zeros.insert(id);
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

    /// Whether the instruction `opcode` in function `function` completes an output vertex,
    /// where the rewrite stores the shadow to `Position`: an entry function's `OpReturn` in a
    /// vertex or tessellation evaluation shader, any `OpEmitVertex` or `OpEmitStreamVertex` in
    /// a geometry shader.
    /// A mesh shader has no such instruction: each vertex's `Position` is rewritten where it
    /// is stored ([`Position::MeshVertices`]).
    pub(super) fn completes_vertex(&self, opcode: u32, function: u32) -> bool {
        match self.model {
            scan_model::GEOMETRY => matches!(opcode, OP_EMIT_VERTEX | OP_EMIT_STREAM_VERTEX),
            scan_model::MESH_EXT => false,
            _ => opcode == OP_RETURN && self.entry_functions.contains(&function),
        }
    }

    /// The `Position` of the entry points.
    pub(super) fn position(&self) -> Result<Option<Position>, Unsupported> {
        let mut found = None;
        for (&id, &(ty, class)) in &self.variables {
            if class != STORAGE_OUTPUT {
                continue;
            }
            let Some(&(_, pointee)) = self.pointers.get(&ty) else {
                continue;
            };
            let this = if self.model == scan_model::MESH_EXT {
                // Per-vertex arrays: of blocks with a Position member, or of Positions.
                let element = self.arrays.get(&pointee).map(|&(element, _)| element);
                match element.and_then(|e| self.position_members.get(&e)) {
                    Some(&member) => Position::MeshVertices {
                        array: id,
                        member: Some(member),
                    },
                    None if self.position_ids.contains(&id) && element.is_some() => {
                        Position::MeshVertices {
                            array: id,
                            member: None,
                        }
                    }
                    None if self.position_ids.contains(&id) => {
                        return Err(Unsupported("a mesh shader's Position is not an array"))
                    }
                    None => continue,
                }
            } else if self.position_ids.contains(&id) {
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

    /// What [`derived_range::find`] needs of the declarations (`vec4`: `Position`'s type).
    pub(super) fn facts<'a>(
        &'a self,
        vec4: u32,
        input_positions: &'a HashMap<u32, u32>,
    ) -> ModuleFacts<'a> {
        ModuleFacts {
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
            zeros: &self.zeros,
            inputs_are_attributes: self.model == scan_model::VERTEX,
            input_positions,
            int_constants: &self.int_constants,
            member_offsets: &self.member_offsets,
            member_matrix_strides: &self.member_matrix_strides,
            row_major_members: &self.row_major_members,
            glsl_std: self.glsl_std,
            entry_functions: &self.entry_functions,
            unit_vectors: &self.unit_vectors,
        }
    }

    /// Input variables that are arrays of blocks with a `Position` member (`gl_in` of a
    /// tessellation or geometry stage), and that member.
    pub(super) fn input_positions(&self) -> HashMap<u32, u32> {
        self.variables
            .iter()
            .filter(|(_, &(_, class))| class == STORAGE_INPUT)
            .filter_map(|(&id, &(ty, _))| {
                let &(_, pointee) = self.pointers.get(&ty)?;
                let &(element, _) = self.arrays.get(&pointee)?;
                let &member = self.position_members.get(&element)?;
                Some((id, member))
            })
            .collect()
    }

    /// The `vec4` type of `position`, where it is one.
    pub(super) fn position_vec4(&self, position: Position) -> Option<u32> {
        let vec4 = match position {
            Position::Variable(var) => {
                let (ty, _) = *self.variables.get(&var)?;
                self.pointers.get(&ty)?.1
            }
            Position::Member { block, member } => {
                let (ty, _) = *self.variables.get(&block)?;
                let pointee = self.pointers.get(&ty)?.1;
                *self.structs.get(&pointee)?.get(member as usize)?
            }
            Position::MeshVertices { array, member } => {
                let (ty, _) = *self.variables.get(&array)?;
                let (element, _) = *self.arrays.get(&self.pointers.get(&ty)?.1)?;
                match member {
                    Some(member) => *self.structs.get(&element)?.get(member as usize)?,
                    None => element,
                }
            }
        };
        self.vec4_float(vec4).map(|_| vec4)
    }

    /// The float type of a 4-vector type.
    pub(super) fn vec4_float(&self, vector: u32) -> Option<u32> {
        match self.vectors.get(&vector) {
            Some(&(float, 4)) if self.floats.contains(&float) => Some(float),
            _ => None,
        }
    }

    /// The byte size of a push-constant member type, where the layout rules make it plain
    /// (`depth` bounds the recursion on malformed modules).
    pub(super) fn size_of(&self, ty: u32, matrix_stride: Option<u32>, depth: u32) -> Option<u32> {
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
}

/// The ids a declaration refers to (not its literals), for the declarations that can refer to
/// a push-constant block, its pointer or its variable; others refer to none of them.
pub(super) fn declaration_ids(opcode: u32, operands: &[u32]) -> impl Iterator<Item = u32> + '_ {
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
pub(super) fn result_id(opcode: u32, operands: &[u32]) -> Option<&u32> {
    match opcode {
        19..=39 => operands.first(),
        OP_CONSTANT..=52 | OP_VARIABLE | OP_FUNCTION => operands.get(1),
        _ => None,
    }
}
