//! Tessellation stages that only carry the vertex stage's clip positions on (issue #41): a
//! control stage that copies each `gl_in[i].gl_Position` into `gl_out[j].gl_Position`, and an
//! evaluation stage that interpolates the patch's positions at its tessellation coordinate
//! (`gl_Position = u * gl_in[0].gl_Position + v * gl_in[1].gl_Position + w * ...`), as
//! pipelines that tessellate only to subdivide do.
//!
//! Such stages rasterize an affine combination (weights that sum to 1) of the positions the
//! vertex stage stored, and an affine combination of points on the line `z = k w + B` that the
//! precise path's rewrite stores on lies on it too: `sum a_i (k w_i + B) = k sum a_i w_i + B`.
//! So the vertex stage is the one rewritten (`policy::vertex_stage::LastStage::rewritten`), by
//! its own rules, and the tessellation stages are left as they are, as a geometry stage that
//! passes the positions through is (`position_store::passes_position_through`).
//!
//! What counts as an affine combination, followed value by value in one pass over the
//! functions (definitions come before their uses in a module, `OpPhi` aside, which is not
//! followed):
//! - a load of an input vertex's whole `Position`, and copies of it;
//! - `FMix(a, b, t)` of two affine combinations, `t` a component of `gl_TessCoord` or its
//!   splat (GLSL's `mix`, quads and isolines interpolate with it);
//! - in a triangle domain (`Triangles`, declared by the evaluation stage), the sum of the
//!   three products of affine combinations by the three components of `gl_TessCoord`, each
//!   once (`OpVectorTimesScalar`, or `OpFMul` by a splat), in any order of the additions:
//!   barycentric coordinates sum to 1.
//!
//! Refused (the answer is `false`, and the evaluation stage stays the last one): a store of
//! anything else into `Position`, a component of it stored apart, z of an input position read
//! for anything else (a level of detail computed from depth would change with the rewrite),
//! an input position handed to a function or stored into a variable, a local holding one
//! whose w (or a component not known) is stored apart, and anything this walk does not know.
//! Words only, never panics.
//!
//! The same walk also serves an evaluation stage that projects the patch's positions itself
//! (`gl_Position = P * V * M * mix(..)`, after a vertex stage that hands the object-space
//! position on as `vec4(p, 1.0)` and a control stage that copies it): there the rewrite is
//! the evaluation stage's own, and it needs the vector the projection multiplies to have
//! w = 1, which an affine combination of points with w = 1 has (to the rounding of the
//! weights' sum, as every other coordinate of the interpolated point). [`projected_affine_values`]
//! gives the values that hold such combinations; nothing upstream is rewritten there, so z
//! may be read and other components of a local holding one stored apart (terrain's
//! `pos.y -= height`), its w not.

use std::collections::{HashMap, HashSet};

use crate::shader::scan::op::*;
use crate::shader::scan::{instructions, instructions_at, is_literal, Instruction, HEADER_WORDS};

const MODEL_TESSELLATION_CONTROL: u32 = 1;
const MODEL_TESSELLATION_EVALUATION: u32 = 2;
const DECORATION_BUILT_IN: u32 = 11;
const BUILT_IN_POSITION: u32 = 0;
const BUILT_IN_TESS_COORD: u32 = 13;
const EXECUTION_MODE_TRIANGLES: u32 = 22;
const STORAGE_INPUT: u32 = 1;
const STORAGE_OUTPUT: u32 = 3;
const STORAGE_FUNCTION: u32 = 7;
const OP_COMPOSITE_CONSTRUCT: u32 = 80;
const OP_VECTOR_TIMES_SCALAR: u32 = 142;
const OP_BITCAST: u32 = 124;
/// `GLSL.std.450`'s `FMix`.
const GLSL_STD_FMIX: u32 = 46;

/// Whether a tessellation control module copies the previous stage's positions into its
/// outputs' `Position` and does nothing else with them but read their x, y or w (module
/// docs). `false` where it stores no `Position`, or is no tessellation control module.
pub fn control_passes_positions_through(words: &[u32]) -> bool {
    Walk::read(words, MODEL_TESSELLATION_CONTROL).is_some_and(|walk| walk.keeps_the_line(words))
}

/// Whether a tessellation evaluation module stores into `Position` only affine combinations
/// of the patch's input positions (module docs), reading no z of them otherwise. `false`
/// where it stores no `Position`, or is no tessellation evaluation module.
pub fn evaluation_interpolates_positions(words: &[u32]) -> bool {
    Walk::read(words, MODEL_TESSELLATION_EVALUATION).is_some_and(|walk| walk.keeps_the_line(words))
}

/// The values of a tessellation evaluation module that hold affine combinations of the patch's
/// input positions (module docs), as its projection may multiply them: loads of
/// `gl_in[i].gl_Position` and of locals stored once with one (whose w is not stored apart),
/// their copies, `FMix` of two, barycentric sums in a triangle domain. Empty where the module
/// is no tessellation evaluation module or the words do not read.
pub fn projected_affine_values(words: &[u32]) -> HashSet<u32> {
    Walk::read(words, MODEL_TESSELLATION_EVALUATION)
        .and_then(|walk| walk.follow(words, Purpose::Projected))
        .map(|followed| {
            followed
                .into_iter()
                .filter(|&(_, held)| held == Held::Affine)
                .map(|(id, _)| id)
                .collect()
        })
        .unwrap_or_default()
}

/// What a walk over the functions answers for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Purpose {
    /// The stage only carries the previous stage's clip positions on (rewritten upstream):
    /// every use of a followed value but x, y and w reads refused.
    CarriedOn,
    /// The stage projects the combinations itself: only which values hold them.
    Projected,
}

/// What the walk knows of the module's declarations.
#[derive(Debug, Default)]
struct Walk {
    /// Input arrays of blocks with a `Position` member (`gl_in`): variable -> member.
    input_positions: HashMap<u32, u32>,
    /// Output `Position`s: a block (`gl_out` arrayed in a control stage, `gl_PerVertex` in an
    /// evaluation stage) -> its member; `None` for a variable decorated `Position` itself.
    output_positions: HashMap<u32, Option<u32>>,
    /// `gl_TessCoord`.
    tess_coord: Option<u32>,
    /// The evaluation stage declares a triangle domain.
    triangles: bool,
    /// The id of `GLSL.std.450`.
    glsl_std: Option<u32>,
    /// 32-bit integer constants (access chain indices).
    int_constants: HashMap<u32, u32>,
    /// Word index of the first `OpFunction`.
    functions_at: usize,
    /// The module is an arrayed-output (control) stage.
    control: bool,
}

/// A value the walk follows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Held {
    /// An affine combination of input positions (weights summing to 1).
    Affine,
    /// A sum of affine combinations each multiplied by a distinct `gl_TessCoord` component:
    /// the bits of those components.
    Weighted(u8),
}

impl Walk {
    fn read(words: &[u32], model: u32) -> Option<Walk> {
        let mut walk = Walk {
            control: model == MODEL_TESSELLATION_CONTROL,
            ..Walk::default()
        };
        let mut entry_model = None;
        let mut builtins: HashMap<u32, u32> = HashMap::new();
        let mut member_positions: HashMap<u32, u32> = HashMap::new();
        // Pointer types: id -> (storage class, pointee); arrays: id -> element.
        let mut pointers: HashMap<u32, (u32, u32)> = HashMap::new();
        let mut arrays: HashMap<u32, u32> = HashMap::new();
        let mut ints: HashSet<u32> = HashSet::new();
        let mut at = HEADER_WORDS;
        for instruction in instructions(words)? {
            let Instruction { opcode, operands } = instruction.ok()?;
            if opcode == OP_FUNCTION {
                walk.functions_at = at;
                break;
            }
            at += operands.len() + 1;
            match (opcode, operands) {
                (OP_ENTRY_POINT, &[model, ..]) => {
                    if entry_model.is_some_and(|m| m != model) {
                        return None;
                    }
                    entry_model = Some(model);
                }
                (OP_EXECUTION_MODE, &[_, EXECUTION_MODE_TRIANGLES]) => walk.triangles = true,
                (OP_EXT_INST_IMPORT, &[id, ref name @ ..]) => {
                    let bytes: Vec<u8> = name.iter().flat_map(|w| w.to_le_bytes()).collect();
                    if bytes.starts_with(b"GLSL.std.450\0") {
                        walk.glsl_std = Some(id);
                    }
                }
                (OP_DECORATE, &[target, DECORATION_BUILT_IN, built_in]) => {
                    builtins.insert(target, built_in);
                }
                (OP_MEMBER_DECORATE, &[block, member, DECORATION_BUILT_IN, BUILT_IN_POSITION]) => {
                    member_positions.insert(block, member);
                }
                (OP_TYPE_INT, &[id, 32, _]) => {
                    ints.insert(id);
                }
                (OP_CONSTANT, &[ty, id, value]) if ints.contains(&ty) => {
                    walk.int_constants.insert(id, value);
                }
                (OP_TYPE_ARRAY, &[id, element, _]) => {
                    arrays.insert(id, element);
                }
                (OP_TYPE_POINTER, &[id, class, pointee]) => {
                    pointers.insert(id, (class, pointee));
                }
                (OP_VARIABLE, &[ty, id, class, ..]) => {
                    let Some(&(_, pointee)) = pointers.get(&ty) else {
                        continue;
                    };
                    let element = arrays.get(&pointee).copied();
                    match class {
                        STORAGE_INPUT => {
                            if builtins.get(&id) == Some(&BUILT_IN_TESS_COORD) {
                                walk.tess_coord = Some(id);
                            }
                            if let Some(&member) = element.and_then(|e| member_positions.get(&e)) {
                                walk.input_positions.insert(id, member);
                            } else if builtins.get(&id) == Some(&BUILT_IN_POSITION) {
                                // An input array of positions without a block: not followed.
                                return None;
                            }
                        }
                        STORAGE_OUTPUT => {
                            // The control stage's outputs are arrays (one per control point).
                            let block = if walk.control { element } else { Some(pointee) };
                            if let Some(&member) = block.and_then(|b| member_positions.get(&b)) {
                                walk.output_positions.insert(id, Some(member));
                            } else if builtins.get(&id) == Some(&BUILT_IN_POSITION) {
                                walk.output_positions.insert(id, None);
                            }
                        }
                        _ => {}
                    }
                }
                _ => {}
            }
        }
        (entry_model == Some(model)
            && walk.functions_at != 0
            && !walk.input_positions.is_empty()
            && !walk.output_positions.is_empty())
        .then_some(walk)
    }

    /// The function-local variables stored exactly once in the module and used only as the
    /// pointer of loads and stores, or as the base of an access chain of one index (a
    /// component of a vector).
    /// A local whose w (or a component not known: a dynamic index) is stored apart through
    /// such a chain is none of them: what it holds is not what its one whole store put there.
    /// x, y and z stored apart keep w, and z is refused where the line must be kept. Neither
    /// is a local with an initializer (a second value, on the paths that skip the store), nor
    /// one whose component chain is used other than as the pointer of a load or a store (an
    /// out-parameter: `modf(x, p.w)` writes through it). Also returns the locals with any
    /// component stored apart: none of those holds `gl_TessCoord` as it was loaded.
    fn locals_stored_once(&self, words: &[u32]) -> (HashSet<u32>, HashSet<u32>) {
        let mut locals: HashSet<u32> = HashSet::new();
        let mut component_stored: HashSet<u32> = HashSet::new();
        let mut store_counts: HashMap<u32, u32> = HashMap::new();
        let mut escaped: HashSet<u32> = HashSet::new();
        // Chains of one index: chain -> (base, index).
        let mut chains: HashMap<u32, (u32, u32)> = HashMap::new();
        for Instruction { opcode, operands } in
            instructions_at(words, self.functions_at).map_while(Result::ok)
        {
            match (opcode, operands) {
                (OP_VARIABLE, &[_, id, STORAGE_FUNCTION]) => {
                    locals.insert(id);
                }
                (OP_STORE, &[pointer, value, ..]) => {
                    *store_counts.entry(pointer).or_default() += 1;
                    escaped.insert(value);
                    if let Some(&(base, index)) = chains.get(&pointer) {
                        component_stored.insert(base);
                        if !matches!(self.int_constants.get(&index), Some(0..=2)) {
                            escaped.insert(base);
                        }
                    }
                }
                (OP_LOAD, _) => {}
                (OP_ACCESS_CHAIN | OP_IN_BOUNDS_ACCESS_CHAIN, &[_, id, base, index]) => {
                    chains.insert(id, (base, index));
                }
                _ => escaped.extend(
                    operands
                        .iter()
                        .enumerate()
                        .filter(|&(index, _)| !is_literal(opcode, index))
                        .map(|(_, word)| *word),
                ),
            }
        }
        // A chain that escaped takes its variable with it.
        let escaped_bases: Vec<u32> = chains
            .iter()
            .filter(|(chain, _)| escaped.contains(chain))
            .map(|(_, &(base, _))| base)
            .collect();
        escaped.extend(escaped_bases);
        locals.retain(|l| store_counts.get(l) == Some(&1) && !escaped.contains(l));
        (locals, component_stored)
    }

    /// The walk over the functions (module docs), for a stage that carries the positions on.
    fn keeps_the_line(&self, words: &[u32]) -> bool {
        self.follow(words, Purpose::CarriedOn).is_some()
    }

    /// The walk over the functions (module docs): the values followed, with what each holds;
    /// `None` where `purpose` refuses the stage (for [`Purpose::CarriedOn`], also where it
    /// stores no `Position`).
    fn follow(&self, words: &[u32], purpose: Purpose) -> Option<HashMap<u32, Held>> {
        let carried_on = purpose == Purpose::CarriedOn;
        // Pointers to an input vertex's whole Position, and to its x, y or w.
        let mut input_pointers: HashSet<u32> = HashSet::new();
        let mut input_whole: HashSet<u32> = HashSet::new();
        // Pointers to an output Position, whole.
        let mut output_pointers: HashSet<u32> = HashSet::new();
        // gl_TessCoord's components: pointers, scalars, the vector loaded, splats.
        let mut coord_pointers: HashMap<u32, u32> = HashMap::new();
        let mut coord_vectors: HashSet<u32> = HashSet::new();
        let mut coords: HashMap<u32, u32> = HashMap::new();
        let mut splats: HashMap<u32, u32> = HashMap::new();
        let mut held: HashMap<u32, Held> = HashMap::new();
        let mut stores = 0;
        // Function-local variables stored once (glslang keeps each GLSL local in one): what
        // their one store holds, read back by their loads and their component chains.
        let (locals, component_stored) = self.locals_stored_once(words);
        let mut local_held: HashMap<u32, Held> = HashMap::new();
        let mut local_coords: HashMap<u32, u32> = HashMap::new();
        let mut local_coord_vectors: HashSet<u32> = HashSet::new();
        for instruction in instructions_at(words, self.functions_at) {
            let Ok(Instruction { opcode, operands }) = instruction else {
                return None;
            };
            match (opcode, operands) {
                (OP_ACCESS_CHAIN | OP_IN_BOUNDS_ACCESS_CHAIN, &[_, id, base, ref indices @ ..]) => {
                    if let Some(&member) = self.input_positions.get(&base) {
                        let constant = |i: usize| {
                            indices
                                .get(i)
                                .and_then(|index| self.int_constants.get(index))
                        };
                        match indices.len() {
                            // A vertex's Position, or one of its components but z.
                            2 if constant(1) == Some(&member) => {
                                input_pointers.insert(id);
                                input_whole.insert(id);
                            }
                            3 if constant(1) == Some(&member) => match constant(2) {
                                Some(&c) if c != 2 => {
                                    input_pointers.insert(id);
                                }
                                // z: read where the stage projects (nothing upstream is
                                // rewritten), refused where the line is carried on.
                                _ if !carried_on => {
                                    input_pointers.insert(id);
                                }
                                _ => return None,
                            },
                            // Another member of a vertex.
                            n if n >= 2 && constant(1).is_some() => {}
                            // Not followed: what its loads read is not taken for anything.
                            _ if !carried_on => {}
                            _ => return None,
                        }
                        continue;
                    }
                    if !carried_on && self.output_positions.contains_key(&base) {
                        // What a projecting stage stores is the rewrite's to follow.
                        continue;
                    }
                    if let Some(&member) = self.output_positions.get(&base) {
                        // A component of a Position variable stored apart.
                        let member = member?;
                        // The control stage's outputs: [vertex, member, ..]; the evaluation
                        // stage's block: [member, ..].
                        let member_at = usize::from(self.control);
                        match indices
                            .get(member_at)
                            .and_then(|i| self.int_constants.get(i))
                        {
                            Some(&m) if m == member => {
                                // A component of Position stored apart: refused.
                                if indices.len() != member_at + 1 {
                                    return None;
                                }
                                output_pointers.insert(id);
                            }
                            // Another member (PointSize, ClipDistance).
                            Some(_) => {}
                            // The block whole, or a member index that is not constant.
                            None => return None,
                        }
                        continue;
                    }
                    if local_held.contains_key(&base) {
                        // A component of a local holding a position: x, y or w an ordinary
                        // value; z refused where the line is carried on (locals whose w is
                        // stored apart are not followed: `locals_stored_once`).
                        match *indices {
                            [index] if self.int_constants.get(&index).is_some_and(|&c| c != 2) => {}
                            _ if !carried_on => {}
                            _ => return None,
                        }
                        continue;
                    }
                    if Some(base) == self.tess_coord || local_coord_vectors.contains(&base) {
                        match *indices {
                            [index] => match self.int_constants.get(&index) {
                                Some(&c) if c < 3 => {
                                    coord_pointers.insert(id, c);
                                }
                                _ => return None,
                            },
                            _ => return None,
                        }
                        continue;
                    }
                }
                (OP_LOAD, &[_, id, pointer, ..]) => {
                    if input_whole.contains(&pointer) {
                        held.insert(id, Held::Affine);
                        continue;
                    }
                    if input_pointers.contains(&pointer) {
                        // x, y or w: an ordinary value.
                        continue;
                    }
                    if let Some(&c) = coord_pointers.get(&pointer) {
                        coords.insert(id, c);
                        continue;
                    }
                    if Some(pointer) == self.tess_coord || local_coord_vectors.contains(&pointer) {
                        coord_vectors.insert(id);
                        continue;
                    }
                    if let Some(&h) = local_held.get(&pointer) {
                        held.insert(id, h);
                        continue;
                    }
                    if let Some(&c) = local_coords.get(&pointer) {
                        coords.insert(id, c);
                        continue;
                    }
                }
                (OP_STORE, &[pointer, value, ..]) => {
                    let into_output = output_pointers.contains(&pointer)
                        || (self.output_positions.get(&pointer) == Some(&None));
                    if into_output && carried_on {
                        if held.get(&value) != Some(&Held::Affine) {
                            return None;
                        }
                        stores += 1;
                        continue;
                    }
                    if locals.contains(&pointer) {
                        if let Some(&h) = held.get(&value) {
                            local_held.insert(pointer, h);
                            continue;
                        }
                        if let Some(&c) = coords.get(&value) {
                            local_coords.insert(pointer, c);
                            continue;
                        }
                        if coord_vectors.contains(&value) && !component_stored.contains(&pointer) {
                            local_coord_vectors.insert(pointer);
                            continue;
                        }
                    }
                }
                (OP_COPY_OBJECT | OP_BITCAST, &[_, id, source]) => {
                    if let Some(&h) = held.get(&source) {
                        held.insert(id, h);
                        continue;
                    }
                    if let Some(&c) = coords.get(&source) {
                        coords.insert(id, c);
                        continue;
                    }
                }
                (OP_COMPOSITE_EXTRACT, &[_, id, composite, ref indices @ ..]) => {
                    if held.contains_key(&composite) {
                        // x, y or w of a position: an ordinary value; z: refused where the
                        // line is carried on.
                        if carried_on && !matches!(indices, [0 | 1 | 3]) {
                            return None;
                        }
                        continue;
                    }
                    if coord_vectors.contains(&composite) {
                        if let [c @ 0..=2] = *indices {
                            coords.insert(id, c);
                        }
                        continue;
                    }
                }
                (OP_COMPOSITE_CONSTRUCT, &[_, id, first, ref rest @ ..]) => {
                    if let Some(&c) = coords.get(&first) {
                        if rest.iter().all(|&r| r == first) {
                            splats.insert(id, c);
                            continue;
                        }
                    }
                }
                (OP_VECTOR_TIMES_SCALAR, &[_, id, vector, scalar]) => {
                    if let (Some(Held::Affine), Some(&c)) = (held.get(&vector), coords.get(&scalar))
                    {
                        if self.triangles {
                            held.insert(id, Held::Weighted(1 << c));
                            continue;
                        }
                    }
                }
                (OP_F_MUL, &[_, id, a, b]) => {
                    let weighted = match (held.get(&a), held.get(&b)) {
                        (Some(Held::Affine), None) => splats.get(&b),
                        (None, Some(Held::Affine)) => splats.get(&a),
                        _ => None,
                    };
                    if let (Some(&c), true) = (weighted, self.triangles) {
                        held.insert(id, Held::Weighted(1 << c));
                        continue;
                    }
                }
                (OP_F_ADD, &[_, id, a, b]) => {
                    if let (Some(&Held::Weighted(x)), Some(&Held::Weighted(y))) =
                        (held.get(&a), held.get(&b))
                    {
                        if x & y == 0 {
                            let sum = x | y;
                            held.insert(
                                id,
                                if sum == 0b111 {
                                    Held::Affine
                                } else {
                                    Held::Weighted(sum)
                                },
                            );
                            continue;
                        }
                    }
                }
                // The weight a component of `gl_TessCoord` (or its splat), in [0, 1]: the
                // weights (1 - t) and t then sum to 1 to an ulp (far outside [0, 1] their sum
                // rounds away from 1).
                (OP_EXT_INST, &[_, id, set, GLSL_STD_FMIX, a, b, t])
                    if Some(set) == self.glsl_std
                        && held.get(&a) == Some(&Held::Affine)
                        && held.get(&b) == Some(&Held::Affine)
                        && (coords.contains_key(&t) || splats.contains_key(&t)) =>
                {
                    held.insert(id, Held::Affine);
                    continue;
                }
                _ => {}
            }
            // Any other use of a followed value or pointer, or of `gl_in` or the output
            // Position itself: not only carried on (a projecting stage uses them as it likes:
            // the projection among them).
            if !carried_on {
                continue;
            }
            let mut uses = operands
                .iter()
                .enumerate()
                .filter(|&(index, _)| !is_literal(opcode, index))
                .map(|(_, word)| word);
            if uses.any(|operand| {
                held.contains_key(operand)
                    || input_pointers.contains(operand)
                    || output_pointers.contains(operand)
                    || self.input_positions.contains_key(operand)
                    || self.output_positions.contains_key(operand)
            }) {
                return None;
            }
        }
        (stores > 0 || !carried_on).then_some(held)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shader::test_spirv::words;

    const PASSTHROUGH_TESC: &[u8] =
        include_bytes!("../../../shaders/glslang/position_passthrough.tesc.spv");
    const INTERPOLATING_TESE: &[u8] =
        include_bytes!("../../../shaders/glslang/interpolating.tese.spv");

    #[test]
    fn glslangs_subdividing_stages_carry_the_positions_on() {
        assert!(control_passes_positions_through(&words(PASSTHROUGH_TESC)));
        assert!(evaluation_interpolates_positions(&words(
            INTERPOLATING_TESE
        )));
        // Each answers for its own stage only.
        assert!(!evaluation_interpolates_positions(&words(PASSTHROUGH_TESC)));
        assert!(!control_passes_positions_through(&words(
            INTERPOLATING_TESE
        )));
        // A control stage that passes generic varyings on (no Position), and an evaluation
        // stage that projects its interpolated attribute itself: neither.
        let varyings = words(include_bytes!(
            "../../../shaders/glslang/passthrough.tesc.spv"
        ));
        assert!(!control_passes_positions_through(&varyings));
        let projecting = words(include_bytes!("../../../shaders/glslang/ubo.tese.spv"));
        assert!(!evaluation_interpolates_positions(&projecting));
        // Malformed words.
        assert!(!control_passes_positions_through(&[1, 2, 3]));
        assert!(!evaluation_interpolates_positions(&[]));
    }

    fn data(name: &str) -> Vec<u32> {
        let path = format!(
            "{}/src/shader/test_data/{name}.spv",
            env!("CARGO_MANIFEST_DIR")
        );
        words(&std::fs::read(&path).unwrap_or_else(|e| panic!("{path}: {e}")))
    }

    #[test]
    fn interpolations_are_told_from_other_sums() {
        // Quads: bilinear through mix() is affine.
        assert!(evaluation_interpolates_positions(&data(
            "tessellation_quad_mix"
        )));
        // Barycentric sums through locals, products in any order.
        assert!(evaluation_interpolates_positions(&data(
            "tessellation_vector_weights"
        )));
        // One coordinate twice and another never: weights that do not sum to 1.
        assert!(!evaluation_interpolates_positions(&data(
            "tessellation_repeated_weight"
        )));
        // x + y + z is 1 in a triangle domain only.
        assert!(!evaluation_interpolates_positions(&data(
            "tessellation_quad_weights"
        )));
        // A local holding the interpolation, its y then negated (a flip of the image keeps
        // z = k w + B), or its w doubled (which does not: refused; the walk took the
        // component's store for a read of it before).
        assert!(evaluation_interpolates_positions(&data(
            "tessellation_interpolated_y_written"
        )));
        assert!(!evaluation_interpolates_positions(&data(
            "tessellation_interpolated_w_written"
        )));
    }

    /// Found in review (session 38): three ways a local or a weight stops being what the walk
    /// took it for. Each is refused in both purposes: the stage is not taken to carry the
    /// positions on, and what its projection multiplies is not taken for w = 1.
    #[test]
    fn locals_changed_through_out_parameters_initializers_or_coordinates_are_not_followed() {
        const OP_MATRIX_TIMES_VECTOR: u32 = 145;
        let projected_is_affine = |words: &[u32]| {
            let values = projected_affine_values(words);
            instructions(words)
                .unwrap()
                .filter_map(Result::ok)
                .filter(|i| i.opcode == OP_MATRIX_TIMES_VECTOR)
                .filter_map(|i| i.operands.get(3).copied())
                .any(|vector| values.contains(&vector))
        };
        // `modf(7.5, p.w)`: w written through an out-parameter (the chain handed to an
        // instruction), which the walk took for nothing before.
        assert!(!evaluation_interpolates_positions(&data(
            "tessellation_interpolated_modf_w"
        )));
        assert!(!projected_is_affine(&data("tessellation_projected_modf_w")));
        // `vec3 tc = gl_TessCoord; tc.x = 0.9;`: the weights no longer sum to 1.
        assert!(!evaluation_interpolates_positions(&data(
            "tessellation_interpolated_coord_written"
        )));
        assert!(!projected_is_affine(&data(
            "tessellation_projected_coord_written"
        )));
        // A local with an initializer (w = 0) stored in one branch only: the other path
        // projects the initializer.
        let initialized = crate::shader::test_spirv::assemble(include_str!(
            "test_data/tessellation_projected_initialized_local.spvasm"
        ));
        assert!(!projected_is_affine(&initialized));
    }

    #[test]
    fn projected_interpolations_are_the_values_holding_affine_combinations() {
        const OP_MATRIX_TIMES_VECTOR: u32 = 145;
        // The vectors a module's matrices multiply.
        let multiplied = |words: &[u32]| -> Vec<u32> {
            instructions(words)
                .unwrap()
                .filter_map(Result::ok)
                .filter(|i| i.opcode == OP_MATRIX_TIMES_VECTOR)
                .filter_map(|i| i.operands.get(3).copied())
                .collect()
        };
        // projecting.tese: the load of the local the barycentric sum is stored in (its y
        // displaced apart) is what the projection multiplies.
        let projecting = words(include_bytes!(
            "../../../shaders/glslang/projecting.tese.spv"
        ));
        let values = projected_affine_values(&projecting);
        let vectors = multiplied(&projecting);
        assert_eq!(vectors.len(), 1);
        assert!(values.contains(&vectors[0]), "{values:?} {vectors:?}");
        // A local whose w is written apart holds none (the sums stored into it still are).
        let w_written = data("tessellation_projected_w_written");
        let values = projected_affine_values(&w_written);
        let vectors = multiplied(&w_written);
        assert_eq!(vectors.len(), 1);
        assert!(
            !values.is_empty() && !values.contains(&vectors[0]),
            "{values:?}"
        );
        // Other stages, and malformed words: none.
        assert!(projected_affine_values(&words(PASSTHROUGH_TESC)).is_empty());
        assert!(projected_affine_values(&[1, 2, 3]).is_empty());
    }

    #[test]
    fn control_stages_that_read_depth_or_change_positions_are_refused() {
        // A level of detail from w (the view distance) leaves the line alone; one from z
        // would change with the rewrite.
        assert!(control_passes_positions_through(&data(
            "tessellation_lod_from_w"
        )));
        assert!(!control_passes_positions_through(&data(
            "tessellation_lod_from_z"
        )));
        assert!(!control_passes_positions_through(&data(
            "tessellation_scaled"
        )));
    }
}
