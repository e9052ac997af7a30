//! The fit's SPIR-V: `revz_math::shader_fit::fit_in_shader` and the carrier it makes, in the
//! same float32 operations and order, each `NoContraction`, and the selection at each return.

#![allow(clippy::wildcard_imports)]

use super::*;

/// The fit's SPIR-V, made before the module is written (its arithmetic ids must be decorated
/// in the annotation section, ahead of the code).
#[derive(Debug)]
pub struct Fit {
    pub leaf: Leaf,
    /// `OpTypeBool`: the module's, or a new one (`new_bool`).
    pub bool_type: u32,
    new_bool: bool,
    /// The private `vec4` holding the derived carrier, and its initializer.
    pub derived: u32,
    init: u32,
    /// Float constants: (id, value).
    constants: Vec<(u32, f32)>,
    half: u32,
    minus_half: u32,
    two_and_a_half: u32,
    zero: u32,
    one: u32,
    minus_one: u32,
    /// The fit's instructions, ending with the store of the derived carrier.
    pub code: Vec<u32>,
    /// The same instructions for each other load of the matrix ([`Leaf::copies`]), renumbered,
    /// with the word index they go after.
    pub copies: Vec<(usize, Vec<u32>)>,
    /// The arithmetic results, decorated `NoContraction`.
    exact: Vec<u32>,
}

/// The ids a module's types give the fit.
#[derive(Clone, Copy, Debug)]
pub struct Types {
    pub float: u32,
    pub vec4: u32,
    pub carrier: CarrierIds,
}

/// How the rewritten code gets revz's carrier `vec4`.
#[derive(Clone, Copy, Debug)]
pub enum CarrierIds {
    /// Loaded from push constants: the pointer type to a push-constant `vec4`, the
    /// push-constant variable, and the carrier's member index constant.
    Pushed {
        push_vec4: u32,
        push_variable: u32,
        carrier_index: u32,
    },
    /// A constant composite (a variant's baked carrier).
    Constant(u32),
}

/// A builder of float instructions that records the arithmetic results.
struct Code<'f, F: FnMut() -> u32> {
    words: Vec<u32>,
    exact: Vec<u32>,
    fresh: &'f mut F,
    float: u32,
}

impl<F: FnMut() -> u32> Code<'_, F> {
    fn op(&mut self, opcode: u32, x: u32, y: u32) -> u32 {
        let id = (self.fresh)();
        push(&mut self.words, opcode, &[self.float, id, x, y]);
        self.exact.push(id);
        id
    }

    fn typed(&mut self, opcode: u32, ty: u32, operands: &[u32]) -> u32 {
        let id = (self.fresh)();
        let mut all = vec![ty, id];
        all.extend_from_slice(operands);
        push(&mut self.words, opcode, &all);
        id
    }

    /// `((x0 y0 + x1 y1) + x2 y2)`, as `fit_in_shader` evaluates it.
    fn dot3(&mut self, x: [u32; 3], y: [u32; 3]) -> u32 {
        let p0 = self.op(OP_F_MUL, x[0], y[0]);
        let p1 = self.op(OP_F_MUL, x[1], y[1]);
        let sum = self.op(OP_F_ADD, p0, p1);
        let p2 = self.op(OP_F_MUL, x[2], y[2]);
        self.op(OP_F_ADD, sum, p2)
    }
}

/// An upper bound on the ids [`Fit::new`] and one [`Fit::select_at_return`] take.
pub const FIT_IDS: usize = 100;
/// Ids each [`Fit::select_at_return`] takes.
pub const RETURN_IDS: usize = 17;

impl Fit {
    pub fn new<F: FnMut() -> u32>(
        leaf: Leaf,
        bool_type: Option<u32>,
        types: Types,
        fresh: &mut F,
    ) -> Fit {
        let (bool_type, new_bool) = match bool_type {
            Some(id) => (id, false),
            None => (fresh(), true),
        };
        let mut constant = |value: f32| (fresh(), value);
        let zero = constant(0.0);
        let one = constant(1.0);
        let minus_one = constant(-1.0);
        let half = constant(0.5);
        let minus_half = constant(-0.5);
        let two = constant(2.0);
        let two_and_a_half = constant(2.5);
        let four = constant(4.0);
        let residual = constant(RESIDUAL_TOLERANCE_SQUARED);
        let affine = constant(AFFINE_W_TOLERANCE_SQUARED);
        let infinity = constant(f32::INFINITY);
        let minus_infinity = constant(f32::NEG_INFINITY);
        let (derived, init) = (fresh(), fresh());
        let Types {
            float,
            vec4,
            carrier,
        } = types;
        let mut code = Code {
            words: Vec::new(),
            exact: Vec::new(),
            fresh,
            float,
        };
        // The depth row a and the w row b of the column-vector matrix.
        let element = |code: &mut Code<'_, F>, row: u32, column: u32| {
            if let Some(rows) = leaf.rows {
                return code.typed(
                    OP_COMPOSITE_EXTRACT,
                    float,
                    &[rows[row as usize - 2], column],
                );
            }
            if let Some(columns) = leaf.columns {
                return match columns.get(column as usize) {
                    Some(vector) => code.typed(OP_COMPOSITE_EXTRACT, float, &[vector, row]),
                    // A column the compiler dropped (its component was 0): zeros.
                    None => zero.0,
                };
            }
            let indices = if leaf.transposed {
                [row, column]
            } else {
                [column, row]
            };
            code.typed(
                OP_COMPOSITE_EXTRACT,
                float,
                &[leaf.id, indices[0], indices[1]],
            )
        };
        let a: [u32; 4] = std::array::from_fn(|j| element(&mut code, 2, j as u32));
        let b: [u32; 4] = std::array::from_fn(|j| element(&mut code, 3, j as u32));
        let xyz = |v: [u32; 4]| [v[0], v[1], v[2]];
        let bb = code.dot3(xyz(b), xyz(b));
        let aa = code.dot3(xyz(a), xyz(a));
        let ab = code.dot3(xyz(a), xyz(b));
        let k = code.op(OP_F_DIV, ab, bb);
        let e: [u32; 3] = std::array::from_fn(|i| {
            let m = code.op(OP_F_MUL, k, b[i]);
            code.op(OP_F_SUB, a[i], m)
        });
        let ee = code.dot3(e, e);
        let kb3 = code.op(OP_F_MUL, k, b[3]);
        let b_fit = code.op(OP_F_SUB, a[3], kb3);
        let bw2 = code.op(OP_F_MUL, b[3], b[3]);
        let affine_bound = code.op(OP_F_MUL, affine.0, bw2);
        let tolerance = code.op(OP_F_MUL, residual.0, aa);
        // The guard, on the line as fitted, each comparison false for NaN.
        let conditions = [
            (OP_F_ORD_GREATER_THAN, bb, zero.0),
            (OP_F_ORD_GREATER_THAN_EQUAL, bb, affine_bound),
            (OP_F_ORD_LESS_THAN_EQUAL, ee, tolerance),
            (OP_F_ORD_GREATER_THAN, k, zero.0),
            (OP_F_ORD_LESS_THAN, k, infinity.0),
            (OP_F_ORD_LESS_THAN, b_fit, zero.0),
            (OP_F_ORD_GREATER_THAN, b_fit, minus_infinity.0),
        ]
        .map(|(opcode, x, y)| code.typed(opcode, bool_type, &[x, y]));
        let accepted = conditions[1..].iter().fold(conditions[0], |all, &c| {
            code.typed(OP_LOGICAL_AND, bool_type, &[all, c])
        });
        // The selector (the pushed carrier's w): 1 and 3 complementary, 2 and 4 infinite; 3
        // and 4 for a line in [-1, 1] clip depth, converted to [0, 1]
        // (`revz_math::shader_fit::zero_to_one`).
        let carrier = match carrier {
            CarrierIds::Pushed {
                push_vec4,
                push_variable,
                carrier_index,
            } => {
                let pointer =
                    code.typed(OP_ACCESS_CHAIN, push_vec4, &[push_variable, carrier_index]);
                code.typed(OP_LOAD, vec4, &[pointer])
            }
            CarrierIds::Constant(id) => id,
        };
        let selector = code.typed(OP_COMPOSITE_EXTRACT, float, &[carrier, 3]);
        let gl = code.typed(
            OP_F_ORD_GREATER_THAN,
            bool_type,
            &[selector, two_and_a_half.0],
        );
        let is_two = code.typed(OP_F_ORD_EQUAL, bool_type, &[selector, two.0]);
        let is_four = code.typed(OP_F_ORD_EQUAL, bool_type, &[selector, four.0]);
        let infinite = code.typed(OP_LOGICAL_OR, bool_type, &[is_two, is_four]);
        let k_plus_one = code.op(OP_F_ADD, k, one.0);
        let k_gl = code.op(OP_F_MUL, k_plus_one, half.0);
        let b_gl = code.op(OP_F_MUL, b_fit, half.0);
        let k = code.typed(OP_SELECT, float, &[gl, k_gl, k]);
        let b_fit = code.typed(OP_SELECT, float, &[gl, b_gl, b_fit]);
        let one_minus_k = code.op(OP_F_SUB, one.0, k);
        let neg_b = code.typed(OP_F_NEGATE, float, &[b_fit]);
        code.exact.push(neg_b);
        let near = code.op(OP_F_DIV, neg_b, k);
        let c_w = code.typed(OP_SELECT, float, &[infinite, zero.0, one_minus_k]);
        let c_1 = code.typed(OP_SELECT, float, &[infinite, near, neg_b]);
        let [flip_z, flip_w, flip_1] = FLIP_IN_SHADER;
        // The flip mapping's entries are 0, 1 and -1.
        let id_of = |value: f32| {
            if value == 0.0 {
                zero.0
            } else if value == 1.0 {
                one.0
            } else {
                minus_one.0
            }
        };
        // A refused fit: the flip mapping, halved where the clip depth is [-1, 1] and revz set
        // [0, 1] for the draw (`z' = (w - z) / 2`).
        let flip_z_gl = code.typed(OP_SELECT, float, &[gl, minus_half.0, id_of(flip_z)]);
        let flip_w_gl = code.typed(OP_SELECT, float, &[gl, half.0, id_of(flip_w)]);
        let out_z = code.typed(OP_SELECT, float, &[accepted, zero.0, flip_z_gl]);
        let out_w = code.typed(OP_SELECT, float, &[accepted, c_w, flip_w_gl]);
        let out_1 = code.typed(OP_SELECT, float, &[accepted, c_1, id_of(flip_1)]);
        // w = 1: the fit ran (the initializer's 0 says it did not, [`Self::select_at_return`]).
        let value = code.typed(OP_COMPOSITE_CONSTRUCT, vec4, &[out_z, out_w, out_1, one.0]);
        push(&mut code.words, OP_STORE, &[derived, value]);
        let Code {
            words, mut exact, ..
        } = code;
        let copies = leaf
            .copies
            .iter()
            .flatten()
            .map(|&(copy, at)| (at, renumbered(&words, &mut exact, leaf.id, copy, fresh)))
            .collect();
        Fit {
            leaf,
            bool_type,
            new_bool,
            derived,
            init,
            constants: vec![
                zero,
                one,
                minus_one,
                half,
                minus_half,
                two,
                two_and_a_half,
                four,
                residual,
                affine,
                infinity,
                minus_infinity,
            ],
            half: half.0,
            minus_half: minus_half.0,
            two_and_a_half: two_and_a_half.0,
            zero: zero.0,
            one: one.0,
            minus_one: minus_one.0,
            code: words,
            copies,
            exact,
        }
    }

    /// `OpDecorate ... NoContraction` for every arithmetic result (annotation section).
    pub fn decorations(&self, out: &mut Vec<u32>) {
        for &id in &self.exact {
            push(out, OP_DECORATE, &[id, DECORATION_NO_CONTRACTION]);
        }
    }

    /// The constants, the bool type and the private variable (declaration section, after
    /// the float, `vec4` and the private `vec4` pointer type are declared).
    pub fn declarations(&self, out: &mut Vec<u32>, float: u32, vec4: u32, private_vec4: u32) {
        if self.new_bool {
            push(out, OP_TYPE_BOOL, &[self.bool_type]);
        }
        for &(id, value) in &self.constants {
            push(out, OP_CONSTANT, &[float, id, value.to_bits()]);
        }
        let id_of = |value: f32| {
            self.constants
                .iter()
                .find(|&&(_, v)| v == value)
                .map_or(0, |&(id, _)| id)
        };
        let [c_z, c_w, c_1] = FLIP_IN_SHADER;
        push(
            out,
            OP_CONSTANT_COMPOSITE,
            &[
                vec4,
                self.init,
                id_of(c_z),
                id_of(c_w),
                id_of(c_1),
                id_of(0.0),
            ],
        );
        push(
            out,
            OP_VARIABLE,
            &[private_vec4, self.derived, STORAGE_PRIVATE, self.init],
        );
    }

    /// At a return: the carrier components `(c_z, c_w, c_1)` to store with, the pushed ones
    /// (`pushed`, from the loaded `carrier`) where its selector is 0, the derived ones
    /// otherwise.
    pub fn select_at_return<F: FnMut() -> u32>(
        &self,
        out: &mut Vec<u32>,
        types: Types,
        carrier: u32,
        pushed: [u32; 3],
        fresh: &mut F,
    ) -> [u32; 3] {
        let Types { float, vec4, .. } = types;
        let (selector, use_derived, derived) = (fresh(), fresh(), fresh());
        push(out, OP_COMPOSITE_EXTRACT, &[float, selector, carrier, 3]);
        // 0.5: between the selector 0 of pushed values and the derived ones (1 to 4).
        push(
            out,
            OP_F_ORD_GREATER_THAN,
            &[self.bool_type, use_derived, selector, self.half],
        );
        push(out, OP_LOAD, &[vec4, derived, self.derived]);
        // The fit did not run before this return (its w is the initializer's 0): the flip
        // mapping, halved for a [-1, 1] line (selectors 3, 4).
        let (ran_w, ran, gl, flip_z, flip_w) = (fresh(), fresh(), fresh(), fresh(), fresh());
        push(out, OP_COMPOSITE_EXTRACT, &[float, ran_w, derived, 3]);
        push(
            out,
            OP_F_ORD_GREATER_THAN,
            &[self.bool_type, ran, ran_w, self.half],
        );
        push(
            out,
            OP_F_ORD_GREATER_THAN,
            &[self.bool_type, gl, selector, self.two_and_a_half],
        );
        push(
            out,
            OP_SELECT,
            &[float, flip_z, gl, self.minus_half, self.minus_one],
        );
        push(out, OP_SELECT, &[float, flip_w, gl, self.half, self.one]);
        let fallback = [flip_z, flip_w, self.zero];
        std::array::from_fn(|i| {
            let (component, known, selected) = (fresh(), fresh(), fresh());
            push(
                out,
                OP_COMPOSITE_EXTRACT,
                &[float, component, derived, i as u32],
            );
            push(out, OP_SELECT, &[float, known, ran, component, fallback[i]]);
            push(
                out,
                OP_SELECT,
                &[float, selected, use_derived, known, pushed[i]],
            );
            selected
        })
    }
}

/// `code` again with `leaf` replaced by `copy` and every id it defines renumbered (SSA: each id
/// is defined once in a module); the renumbered arithmetic joins `exact`.
fn renumbered<F: FnMut() -> u32>(
    code: &[u32],
    exact: &mut Vec<u32>,
    leaf: u32,
    copy: u32,
    fresh: &mut F,
) -> Vec<u32> {
    let mut map: HashMap<u32, u32> = HashMap::from([(leaf, copy)]);
    let mut out = Vec::with_capacity(code.len());
    for instruction in crate::shader::scan::instructions_at(code, 0) {
        let Ok(Instruction { opcode, operands }) = instruction else {
            break;
        };
        let mut new = operands.to_vec();
        // Every instruction of the fit but its final store has a result type and id.
        let defines = opcode != OP_STORE && new.len() >= 2;
        if defines {
            let id = fresh();
            if exact.contains(&new[1]) {
                exact.push(id);
            }
            map.insert(new[1], id);
            new[1] = id;
        }
        for (index, word) in new.iter_mut().enumerate() {
            if (defines && index <= 1) || crate::shader::scan::is_literal(opcode, index) {
                continue;
            }
            if let Some(&mapped) = map.get(word) {
                *word = mapped;
            }
        }
        push(&mut out, opcode, &new);
    }
    out
}
