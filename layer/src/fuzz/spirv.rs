//! The SPIR-V targets: the vertex-stage analysis (`crate::shader::analysis`), the fragment depth
//! rewrite (`fragment_depth`) and the input attachment rewrite (`input_depth`), on mutated
//! real modules (glslang's, committed under `layer/fuzz-seeds/` and `shaders/`; naga's,
//! compiled from `shaders/` at test time; assembled deferred lighting shapes) and, for the
//! fragment depth rewrite, fragment shaders generated as GLSL and compiled with naga.

use std::collections::HashMap;
use std::panic::catch_unwind;
use std::sync::Mutex;

use naga::ShaderStage;
use spirv_tools::val::{self, Validator as _};
use spirv_tools::TargetEnv;

use super::{hash_of, mutate_bytes, Counter, Rng, Target};
use crate::shader::analysis::{analyze, analyze_vertex_entry_points, has_push_constants, Analysis};
use crate::shader::fragment_depth::reverse_fragment_depth;
use crate::shader::scan::{self, instructions, MAGIC};

/// Committed glslang modules (see `layer/fuzz-seeds/generate.sh`).
macro_rules! seed_files {
    ($($name:literal),* $(,)?) => {
        &[$(include_bytes!(concat!("../../fuzz-seeds/", $name)).as_slice()),*]
    };
}

const VERTEX_SEEDS: &[&[u8]] = seed_files!(
    "scene.vert.spv",
    "mvp_pair.vert.spv",
    "camera_debug.vert.spv",
    "camera_opt.vert.spv",
    "uniform.vert.spv",
    "draw_parameters.vert.spv",
    "row_major.vert.spv",
    "row_vector.vert.spv",
);

/// glslang modules of the later stages and translated shapes the `Position` rewrite follows
/// (issue #41): the tester's geometry, tessellation and mesh stages, and the unit tests'
/// shapes.
const LATER_STAGE_SEEDS: &[&[u8]] = &[
    include_bytes!("../../../shaders/glslang/ubo.geom.spv"),
    include_bytes!("../../../shaders/glslang/push.geom.spv"),
    include_bytes!("../../../shaders/glslang/ubo.tese.spv"),
    include_bytes!("../../../shaders/glslang/ssbo_rows.vert.spv"),
    include_bytes!("../../../shaders/glslang/ssbo_registers.vert.spv"),
    include_bytes!("../../../shaders/glslang/ssbo_columns.vert.spv"),
    include_bytes!("../../../shaders/glslang/mesh.mesh.spv"),
    include_bytes!("../shader/test_data/mesh_two_stores.spv"),
    include_bytes!("../shader/test_data/components_assembled.spv"),
    include_bytes!("../shader/test_data/geometry_unrolled.spv"),
    include_bytes!("../shader/test_data/geometry_push_viewports.spv"),
    include_bytes!("../shader/test_data/rows_dot.spv"),
    include_bytes!("../shader/test_data/columns_fma.spv"),
    include_bytes!("../shader/test_data/function_call.spv"),
    include_bytes!("../../../shaders/glslang/passthrough.geom.spv"),
    include_bytes!("../shader/test_data/geometry_wireframe.spv"),
    // Tessellation stages that carry the positions on (`tessellation_positions`).
    include_bytes!("../../../shaders/glslang/position_passthrough.tesc.spv"),
    include_bytes!("../../../shaders/glslang/interpolating.tese.spv"),
    include_bytes!("../shader/test_data/tessellation_quad_mix.spv"),
    include_bytes!("../shader/test_data/tessellation_vector_weights.spv"),
    include_bytes!("../shader/test_data/tessellation_lod_from_w.spv"),
    // Evaluation stages projecting the patch's interpolated positions (session 38).
    include_bytes!("../../../shaders/glslang/projecting.tese.spv"),
    include_bytes!("../shader/test_data/tessellation_projected_quad_mix.spv"),
    include_bytes!("../shader/test_data/tessellation_projected_w_written.spv"),
];

const FRAGMENT_SEEDS: &[&[u8]] = seed_files!(
    "frag_depth.frag.spv",
    "fog.frag.spv",
    "fog_opt.frag.spv",
    "decal_debug.frag.spv",
    "impostor.frag.spv",
);

pub fn to_words(bytes: &[u8]) -> Vec<u32> {
    bytes
        .chunks(4)
        .map(|chunk| {
            let mut word = [0u8; 4];
            word[..chunk.len()].copy_from_slice(chunk);
            u32::from_le_bytes(word)
        })
        .collect()
}

pub fn to_bytes(words: &[u32]) -> Vec<u8> {
    words.iter().flat_map(|w| w.to_le_bytes()).collect()
}

/// GLSL compiled with naga (as `test_spirv::compile_glsl`), `None` where naga refuses it.
fn compile_glsl(stage: ShaderStage, source: &str) -> Option<Vec<u32>> {
    catch_unwind(|| {
        let module = naga::front::glsl::Frontend::default()
            .parse(&naga::front::glsl::Options::from(stage), source)
            .ok()?;
        let info = naga::valid::Validator::new(
            naga::valid::ValidationFlags::all(),
            naga::valid::Capabilities::all(),
        )
        .validate(&module)
        .ok()?;
        let options = naga::back::spv::Options {
            flags: naga::back::spv::WriterFlags::empty(),
            ..Default::default()
        };
        naga::back::spv::write_vec(&module, &info, &options, None).ok()
    })
    .ok()
    .flatten()
}

fn seeds(files: &[&[u8]], stage: ShaderStage, glsl: &[&str]) -> Vec<Vec<u8>> {
    let mut seeds: Vec<Vec<u8>> = files.iter().map(|file| file.to_vec()).collect();
    for source in glsl {
        let words = compile_glsl(stage, source).expect("the seed shaders compile with naga");
        seeds.push(to_bytes(&words));
    }
    seeds
}

/// Word indices where the well-formed instructions after the header start.
fn boundaries(words: &[u32]) -> Vec<usize> {
    let mut at = scan::HEADER_WORDS;
    let mut starts = Vec::new();
    let Some(all) = instructions(words) else {
        return starts;
    };
    for instruction in all {
        let Ok(instruction) = instruction else { break };
        starts.push(at);
        at += 1 + instruction.operands.len();
    }
    starts
}

/// Words a module's fields often hold: small literals, storage classes, decorations,
/// built-ins, execution modes, limits.
const INTERESTING: &[u32] = &[
    0,
    1,
    2,
    3,
    4,
    5,
    7,
    9,
    11,
    14,
    15,
    16,
    22,
    32,
    35,
    64,
    0xffff,
    0x1_0000,
    0x7fff_ffff,
    0x8000_0000,
    0xffff_ffff,
    0x3f80_0000,
    MAGIC,
    0x0001_0000,
    0x0001_0600,
];

/// Opcodes the code under test looks at (to retarget an instruction).
const OPCODES: &[u32] = &[
    0, 8, 11, 12, 14, 15, 16, 17, 21, 22, 23, 24, 28, 29, 30, 32, 43, 44, 46, 54, 55, 56, 57, 59,
    60, 61, 62, 65, 66, 71, 72, 79, 80, 81, 82, 129, 131, 133, 145, 146, 147, 148, 245, 246, 247,
    248, 249, 250, 251, 253, 254, 317, 330,
];

/// Synthetic instructions worth inserting: line info, decorations of depth and position
/// built-ins, matrix layouts, conservative depth, push-constant variables.
fn synthetic(rng: &mut Rng, bound: u32) -> Vec<u32> {
    let id = |rng: &mut Rng| rng.below(bound.max(2) as usize + 2) as u32;
    let op = |count: u32, opcode: u32| (count << 16) | opcode;
    match rng.below(9) {
        0 => vec![
            op(4, 8),
            id(rng),
            rng.below(100) as u32,
            rng.below(80) as u32,
        ],
        1 => vec![op(1, 317)],
        2 => vec![op(4, 71), id(rng), 11, *rng.pick(&[0, 15, 22, 1, 42])],
        3 => vec![
            op(5, 72),
            id(rng),
            rng.below(4) as u32,
            11,
            *rng.pick(&[0, 15, 22]),
        ],
        4 => vec![op(4, 72), id(rng), rng.below(4) as u32, *rng.pick(&[4, 5])],
        5 => vec![
            op(5, 72),
            id(rng),
            rng.below(4) as u32,
            7,
            *rng.pick(INTERESTING),
        ],
        6 => vec![op(3, 16), id(rng), *rng.pick(&[12, 14, 15, 16])],
        7 => vec![op(4, 59), id(rng), id(rng), 9],
        _ => vec![op(1, 0)],
    }
}

/// A random instruction of the module: where it starts and its word count.
fn pick_instruction(rng: &mut Rng, starts: &[usize], words: &[u32]) -> Option<(usize, usize)> {
    if starts.is_empty() {
        return None;
    }
    let at = *rng.pick(starts);
    Some((at, (words[at] >> 16) as usize))
}

/// Word-level SPIR-V mutations: bit flips, interesting words, operands replaced by other ids,
/// instructions deleted, duplicated, moved, retargeted, inserted from other modules, splices
/// of two modules, truncations and bound changes.
pub fn mutate_spirv(rng: &mut Rng, corpus: &[Vec<u8>], input: &mut Vec<u8>) {
    let mut words = to_words(input);
    let rounds = if rng.one_in(3) { 2 + rng.below(3) } else { 1 };
    for _ in 0..rounds {
        if words.len() < scan::HEADER_WORDS {
            words = to_words(rng.pick(corpus).as_slice());
            continue;
        }
        let bound = words[3];
        let starts = boundaries(&words);
        let len = words.len();
        match rng.below(14) {
            0 => {
                let at = rng.below(len);
                words[at] ^= 1 << rng.below(32);
            }
            1 => {
                let at = rng.below(len);
                words[at] = match rng.below(3) {
                    0 => *rng.pick(INTERESTING),
                    1 => bound.wrapping_add(rng.below(3) as u32).wrapping_sub(1),
                    _ => rng.below(bound.max(1) as usize) as u32,
                };
            }
            2 => {
                // An operand replaced by another id: mostly still a module that parses.
                if let Some((at, count)) = pick_instruction(rng, &starts, &words) {
                    if count > 1 {
                        let operand = at + 1 + rng.below(count - 1);
                        words[operand] = 1 + rng.below(bound.max(2) as usize - 1) as u32;
                    }
                }
            }
            3 => {
                if let Some((at, count)) = pick_instruction(rng, &starts, &words) {
                    words.drain(at..at + count);
                }
            }
            4 => {
                if let Some((at, count)) = pick_instruction(rng, &starts, &words) {
                    let copy = words[at..at + count].to_vec();
                    let to = *rng.pick(&starts);
                    words.splice(to..to, copy);
                }
            }
            5 => {
                // Move an instruction.
                if let Some((at, count)) = pick_instruction(rng, &starts, &words) {
                    let moved: Vec<u32> = words.drain(at..at + count).collect();
                    let starts = boundaries(&words);
                    let to = starts
                        .get(rng.below(starts.len()))
                        .copied()
                        .unwrap_or(len - count);
                    words.splice(to..to, moved);
                }
            }
            6 => {
                // Retarget an instruction to another opcode, same operands.
                if let Some((at, _)) = pick_instruction(rng, &starts, &words) {
                    words[at] = (words[at] & 0xffff_0000) | rng.pick(OPCODES);
                }
            }
            7 => {
                // Change an instruction's word count.
                if let Some((at, count)) = pick_instruction(rng, &starts, &words) {
                    let new = match rng.below(3) {
                        0 => 0,
                        1 => count + 1,
                        _ => count.saturating_sub(1),
                    };
                    words[at] = ((new as u32) << 16) | (words[at] & 0xffff);
                }
            }
            8 => {
                // An instruction of another module.
                let other = to_words(rng.pick(corpus).as_slice());
                let other_starts = boundaries(&other);
                if !other_starts.is_empty() && !starts.is_empty() {
                    let from = *rng.pick(&other_starts);
                    let count = (other[from] >> 16) as usize;
                    let to = *rng.pick(&starts);
                    words.splice(to..to, other[from..from + count].iter().copied());
                }
            }
            9 => {
                // The head of this module and the tail of another.
                let other = to_words(rng.pick(corpus).as_slice());
                let other_starts = boundaries(&other);
                if !other_starts.is_empty() && !starts.is_empty() {
                    let cut = *rng.pick(&starts);
                    let from = *rng.pick(&other_starts);
                    words.truncate(cut);
                    words.extend_from_slice(&other[from..]);
                    words[3] = words[3].max(other[3]);
                }
            }
            10 => words.truncate(rng.below(len + 1)),
            11 => {
                words[3] = match rng.below(4) {
                    0 => 0,
                    1 => u32::MAX - rng.below(4) as u32,
                    2 => bound.wrapping_sub(1),
                    _ => bound.wrapping_add(1 + rng.below(100) as u32),
                }
            }
            _ => {
                if !starts.is_empty() {
                    let to = *rng.pick(&starts);
                    words.splice(to..to, synthetic(rng, bound));
                }
            }
        }
    }
    *input = to_bytes(&words);
    if rng.one_in(64) {
        // A length that is not a whole number of words.
        input.truncate(input.len().saturating_sub(1 + rng.below(3)));
    }
    if rng.one_in(200) {
        mutate_bytes(rng, corpus, input, &["\u{0}"]);
    }
}

pub static VERTEX_PROJECTIONS: Counter = Counter::new("projections found");
pub static VERTEX_PARSED: Counter = Counter::new("parsed by naga");
pub static VERTEX_STORES_VALIDATED: Counter =
    Counter::new("Position rewrites of valid modules validated");
pub static VERTEX_COUNTERS: &[&Counter] = &[
    &VERTEX_PROJECTIONS,
    &VERTEX_PARSED,
    &VERTEX_STORES_VALIDATED,
];

/// A message's shape for the outcome hash: its words without numbers.
fn shape(message: &str) -> String {
    let words: String = message.chars().filter(|c| !c.is_ascii_digit()).collect();
    words
        .split_whitespace()
        .take(5)
        .collect::<Vec<_>>()
        .join(" ")
}

fn analysis_shape(analysis: &Analysis) -> String {
    match analysis {
        Analysis::Unreadable(message) => format!("unreadable {}", shape(message)),
        other => format!("{other:?}"),
    }
}

/// The vertex analysis never panics, agrees with its own pre-filter, answers the same for an
/// entry point through `analyze` as through `analyze_vertex_entry_points` (on the copy the
/// latter reads), and the copy stripped for naga answers as the module does wherever naga
/// reads the module itself.
fn check_vertex(bytes: &[u8]) -> Result<u64, String> {
    let words = to_words(bytes);
    let has = has_push_constants(&words);
    let main = analyze(&words, "main", ShaderStage::Vertex);
    let entries = analyze_vertex_entry_points(&words);
    if !has {
        if !matches!(main, Analysis::NoPushConstants | Analysis::Unreadable(_)) {
            return Err(format!("no push constants, but analyze answers {main:?}"));
        }
        if matches!(&entries, Ok(list) if !list.is_empty()) {
            return Err(format!(
                "no push constants, but entry points are analyzed: {entries:?}"
            ));
        }
    } else if main == Analysis::NoPushConstants {
        return Err("has_push_constants, but analyze answers NoPushConstants".to_owned());
    }
    let stripped = scan::for_analysis(&words);
    let read = stripped.as_deref().unwrap_or(&words);
    if let Ok(list) = &entries {
        if has {
            VERTEX_PARSED.add();
        }
        for (name, analysis) in list {
            if let Analysis::Projection(slot) = analysis {
                VERTEX_PROJECTIONS.add();
                if !(2..=4).contains(&slot.columns) || !(2..=4).contains(&slot.rows) {
                    return Err(format!("{name}: a projection of a non-matrix: {slot:?}"));
                }
            }
            let alone = analyze(read, name, ShaderStage::Vertex);
            if &alone != analysis {
                return Err(format!(
                    "entry point {name}: analyze_vertex_entry_points answers {analysis:?}, \
                     analyze on the same words {alone:?}"
                ));
            }
        }
    }
    if stripped.is_some() && !matches!(main, Analysis::Unreadable(_)) {
        let on_copy = analyze(read, "main", ShaderStage::Vertex);
        if on_copy != main {
            return Err(format!(
                "the copy stripped for analysis answers {on_copy:?}, the module {main:?}"
            ));
        }
    }
    // The Position rewrite never panics, and what it returns passes spirv-val wherever the
    // module does.
    let stored = match crate::shader::position_store::rewrite_position_store(&words, 112) {
        Ok(Some(out)) => {
            if validates(&words).is_ok() {
                if let Err(message) = validates(&out) {
                    return Err(format!("the Position rewrite of a valid module: {message}"));
                }
                VERTEX_STORES_VALIDATED.add();
            }
            "rewritten".to_owned()
        }
        Ok(None) => "unchanged".to_owned(),
        Err(reason) => reason.0.to_owned(),
    };
    // The same for the deriving rewrite (projections in buffers, `crate::shader::derived_range`).
    let derived = match crate::shader::position_store::rewrite_position_store_deriving(&words, 112)
    {
        Ok(Some((out, source))) => {
            if validates(&words).is_ok() {
                if let Err(message) = validates(&out) {
                    return Err(format!("the deriving rewrite of a valid module: {message}"));
                }
                VERTEX_STORES_VALIDATED.add();
            }
            format!("derived from {source:?}")
        }
        Ok(None) => "unchanged".to_owned(),
        Err(reason) => reason.0.to_owned(),
    };
    // And with the carrier baked in (a layout without room for it, a shader object): the
    // module's push-constant block is left as it is.
    let baked = crate::shader::position_store::CarrierRead::Baked([0.0, 0.0, 0.0, 1.0]);
    let baked = match crate::shader::position_store::derive_position_store_reading(&words, baked) {
        Ok(Some(rewrite)) => {
            if validates(&words).is_ok() {
                if let Err(message) = validates(&rewrite.code) {
                    return Err(format!("the baked rewrite of a valid module: {message}"));
                }
                VERTEX_STORES_VALIDATED.add();
            }
            format!("baked, from {:?}", rewrite.source)
        }
        Ok(None) => "unchanged".to_owned(),
        Err(reason) => reason.0.to_owned(),
    };
    // The facts a later stage's pipeline asks of a module never panic either (and a module
    // that passes its positions through stores some).
    let w_one = crate::shader::position_store::stores_position_w_one(&words);
    let passes = crate::shader::position_store::passes_position_through(&words);
    let carried = (
        crate::shader::tessellation_positions::control_passes_positions_through(&words),
        crate::shader::tessellation_positions::evaluation_interpolates_positions(&words),
    );
    let entries_shape = match &entries {
        Ok(list) => list
            .iter()
            .map(|(_, a)| analysis_shape(a))
            .collect::<Vec<_>>()
            .join(","),
        Err(message) => shape(message),
    };
    Ok(hash_of(&(
        has,
        analysis_shape(&main),
        entries_shape,
        stored,
        derived,
        baked,
        w_one,
        passes,
        carried,
    )))
}

pub fn vertex_target() -> Target {
    Target {
        name: "vertex_analysis",
        extension: "spv",
        seeds: seeds(
            &[VERTEX_SEEDS, LATER_STAGE_SEEDS].concat(),
            ShaderStage::Vertex,
            &[
                include_str!("../../../shaders/scene.vert"),
                include_str!("../../../shaders/mvp_pair.vert"),
                include_str!("../../../shaders/row_vector.vert"),
                include_str!("../../../shaders/shadow_receiver.vert"),
                include_str!("../../../shaders/ubo.vert"),
                include_str!("../../../shaders/ubo_dynamic.vert"),
                include_str!("../../../shaders/ssbo.vert"),
            ],
        ),
        mutate: mutate_spirv,
        check: check_vertex,
        max_len: 64 << 10,
        counters: VERTEX_COUNTERS,
    }
}

pub static FRAGMENT_REWRITTEN: Counter = Counter::new("rewritten");
pub static FRAGMENT_VALIDATED: Counter = Counter::new("rewrites of valid modules validated");
pub static FRAGMENT_REFUSED: Counter = Counter::new("refused");
pub static FRAGMENT_GENERATED: Counter = Counter::new("generated by GLSL");
pub static FRAGMENT_COUNTERS: &[&Counter] = &[
    &FRAGMENT_REWRITTEN,
    &FRAGMENT_VALIDATED,
    &FRAGMENT_REFUSED,
    &FRAGMENT_GENERATED,
];

/// spirv-val's verdict on a module (Vulkan 1.3, which takes SPIR-V 1.0 to 1.6), cached: it
/// runs as a process.
fn validates(words: &[u32]) -> Result<(), String> {
    static CACHE: Mutex<Option<HashMap<u64, Result<(), String>>>> = Mutex::new(None);
    let key = hash_of(&words);
    if let Some(verdict) = CACHE
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .get_or_insert_with(HashMap::new)
        .get(&key)
    {
        return verdict.clone();
    }
    let verdict = val::create(Some(TargetEnv::Vulkan_1_3))
        .validate(words, None)
        .map_err(|e| e.to_string());
    let mut cache = CACHE.lock().unwrap_or_else(|e| e.into_inner());
    let cache = cache.get_or_insert_with(HashMap::new);
    if cache.len() > 100_000 {
        cache.clear();
    }
    cache.insert(key, verdict.clone());
    verdict
}

/// The rewrite never panics; a module it returns keeps the header (but a larger bound), is a
/// whole instruction stream holding every instruction of the original, and passes spirv-val
/// wherever the original does.
fn check_fragment(bytes: &[u8]) -> Result<u64, String> {
    let words = to_words(bytes);
    let out = match reverse_fragment_depth(&words) {
        Ok(None) => return Ok(hash_of(&"unchanged")),
        Err(reason) => {
            FRAGMENT_REFUSED.add();
            return Ok(hash_of(&reason.0));
        }
        Ok(Some(out)) => out,
    };
    FRAGMENT_REWRITTEN.add();
    if rewrite_problem(&words, &out)?.is_some() {
        FRAGMENT_VALIDATED.add();
    }
    Ok(hash_of(&("rewritten", out.len() - words.len())))
}

/// A random fragment shader that computes with depth, in GLSL: `gl_FragCoord` read whole, by
/// component and by swizzle, through locals and functions; `gl_FragDepth` written in
/// branches, loops and functions.
fn generate_fragment(rng: &mut Rng) -> String {
    fn float(rng: &mut Rng, depth: u32) -> String {
        let leaf = depth == 0 || rng.one_in(3);
        if leaf {
            return match rng.below(9) {
                0 => "gl_FragCoord.z".to_owned(),
                1 => "gl_FragCoord.w".to_owned(),
                2 => "gl_FragCoord.x".to_owned(),
                3 => "coord.z".to_owned(),
                4 => "gl_FragCoord.zw.x".to_owned(),
                5 => "pc.bias".to_owned(),
                6 => "acc".to_owned(),
                7 => "dot(gl_FragCoord, vec4(0.25))".to_owned(),
                _ => format!("{:.3}", rng.below(1000) as f32 / 1000.0),
            };
        }
        let (a, b) = (float(rng, depth - 1), float(rng, depth - 1));
        match rng.below(6) {
            0 => format!("({a} + {b})"),
            1 => format!("({a} * {b})"),
            2 => format!("({a} - {b})"),
            3 => format!("clamp({a}, 0.0, 1.0)"),
            4 => format!("shade({a})"),
            _ => format!("pick(gl_FragCoord).y * {b}"),
        }
    }
    fn statement(rng: &mut Rng, depth: u32) -> String {
        match rng.below(if depth == 0 { 3 } else { 7 }) {
            0 => format!("gl_FragDepth = {};", float(rng, 2)),
            1 => format!("acc += {};", float(rng, 2)),
            2 => format!(
                "out_color = vec4(gl_FragCoord.xyz * {}, 1.0);",
                float(rng, 1)
            ),
            3 => format!(
                "if ({} > {}) {{ {} }} else {{ {} }}",
                float(rng, 1),
                float(rng, 1),
                statement(rng, depth - 1),
                statement(rng, depth - 1)
            ),
            4 => format!(
                "for (int i = 0; i < {}; i++) {{ {} }}",
                1 + rng.below(3),
                statement(rng, depth - 1)
            ),
            5 => format!("if ({} > 0.9) {{ discard; }}", float(rng, 1)),
            _ => "store_depth(acc);".to_owned(),
        }
    }
    let body: Vec<String> = (0..1 + rng.below(5)).map(|_| statement(rng, 2)).collect();
    let last = if rng.one_in(3) {
        String::new()
    } else {
        format!("gl_FragDepth = {};", float(rng, 2))
    };
    format!(
        "#version 450
layout(location = 0) out vec4 out_color;
layout(push_constant) uniform PC {{ vec4 fog; float bias; }} pc;
float shade(float d) {{ return d * 0.5 + gl_FragCoord.z * 0.25; }}
vec4 pick(vec4 c) {{ return c.zyxw; }}
void store_depth(float d) {{ gl_FragDepth = d; }}
void main() {{
    vec4 coord = gl_FragCoord;
    float acc = 0.0;
    out_color = vec4(0.0);
    {}
    {last}
}}
",
        body.join("\n    ")
    )
}

fn mutate_fragment(rng: &mut Rng, corpus: &[Vec<u8>], input: &mut Vec<u8>) {
    if rng.one_in(4) {
        let source = generate_fragment(rng);
        if let Some(words) = compile_glsl(ShaderStage::Fragment, &source) {
            FRAGMENT_GENERATED.add();
            *input = to_bytes(&words);
            if rng.one_in(2) {
                return;
            }
        }
    }
    mutate_spirv(rng, corpus, input);
}

pub fn fragment_target() -> Target {
    Target {
        name: "fragment_rewrite",
        extension: "spv",
        seeds: seeds(
            FRAGMENT_SEEDS,
            ShaderStage::Fragment,
            &[
                include_str!("../../../shaders/frag_depth.frag"),
                include_str!("../../../shaders/scene.frag"),
            ],
        ),
        mutate: mutate_fragment,
        check: check_fragment,
        max_len: 64 << 10,
        counters: FRAGMENT_COUNTERS,
    }
}

/// The invariants of a word-level rewrite `out` of `words`: the header kept (but a larger
/// bound), a whole instruction stream holding every instruction of the original in order,
/// and spirv-val's acceptance wherever it accepts the original. `Ok(Some(()))` where the
/// rewrite of a valid module was validated.
fn rewrite_problem(words: &[u32], out: &[u32]) -> Result<Option<()>, String> {
    if out.len() < words.len() || out[..3] != words[..3] || out[4] != words[4] || out[3] < words[3]
    {
        return Err(format!(
            "the header changed or words were lost: {:x?} -> {:x?}, {} -> {} words",
            &words[..5],
            &out[..5.min(out.len())],
            words.len(),
            out.len()
        ));
    }
    let walked: Result<Vec<_>, usize> = instructions(out).expect("a header").collect();
    let walked = walked.map_err(|at| format!("the rewrite is malformed at word {at}"))?;
    let original: Vec<_> = instructions(words)
        .expect("a header")
        .map_while(Result::ok)
        .collect();
    // Every original instruction, in order (the edited ones keep their opcode).
    let mut rest = walked.iter();
    for instruction in &original {
        if !rest.any(|o| o.opcode == instruction.opcode) {
            return Err(format!(
                "the rewrite lost an instruction of opcode {}",
                instruction.opcode
            ));
        }
    }
    if validates(words).is_err() {
        return Ok(None);
    }
    validates(out)
        .map(Some)
        .map_err(|error| format!("spirv-val accepts the module but rejects its rewrite: {error}"))
}

/// Deferred lighting shaders that read depth as input attachments, assembled: a color input
/// (index 0), depth (index 1, or undecorated as dynamic rendering's default mapping maps it),
/// a stencil input read as integers, and a texture declared among them (a UniformConstant
/// variable that is no input attachment), the reads through copies and a local variable.
fn input_attachment_seeds() -> Vec<Vec<u8>> {
    let shape = |depth_index: &str, texture_first: bool| {
        let texture = "%simage = OpTypeImage %float 2D 0 0 0 1 Unknown
             %sampled = OpTypeSampledImage %simage
             %ps = OpTypePointer UniformConstant %sampled
             %shadow = OpVariable %ps UniformConstant";
        let inputs = "%uv4 = OpTypeVector %uint 4
             %uimage = OpTypeImage %uint SubpassData 0 0 0 2 Unknown
             %pu = OpTypePointer UniformConstant %uimage
             %albedo = OpVariable %pf UniformConstant
             %depth = OpVariable %pf UniformConstant
             %stencil = OpVariable %pu UniformConstant
             %pff = OpTypePointer Function %float";
        let declarations = if texture_first {
            format!("{texture}\n{inputs}")
        } else {
            format!("{inputs}\n{texture}")
        };
        let words = crate::shader::test_spirv::input_attachment_fragment(
            &format!(
                "OpDecorate %albedo InputAttachmentIndex 0
                 OpDecorate %albedo DescriptorSet 0
                 OpDecorate %albedo Binding 0
                 {depth_index}
                 OpDecorate %depth DescriptorSet 0
                 OpDecorate %depth Binding 1
                 OpDecorate %stencil InputAttachmentIndex 2
                 OpDecorate %stencil DescriptorSet 0
                 OpDecorate %stencil Binding 2
                 OpDecorate %shadow DescriptorSet 0
                 OpDecorate %shadow Binding 3"
            ),
            &declarations,
            "%local = OpVariable %pff Function
             %a = OpLoad %fimage %albedo
             %ar = OpImageRead %v4 %a %origin
             %d = OpLoad %fimage %depth
             %e = OpCopyObject %fimage %d
             %dr = OpImageRead %v4 %e %origin
             %s = OpLoad %uimage %stencil
             %sr = OpImageRead %uv4 %s %origin
             %dx = OpCompositeExtract %float %dr 0
             OpStore %local %dx
             %l = OpLoad %float %local
             %ag = OpCompositeExtract %float %ar 1
             %sx = OpCompositeExtract %uint %sr 0
             %sf = OpConvertUToF %float %sx
             %c = OpCompositeConstruct %v4 %l %ag %sf %dx
             OpStore %out %c",
        );
        to_bytes(&words)
    };
    // A texture declared last, right before a constant of another size than a variable's:
    // a declaration walk that lost count of the skipped variable's words lands inside that
    // constant (and, walking no function, converts nothing: a unit test of `input_depth`
    // checks the reads are converted).
    let misaligned = crate::shader::test_spirv::assemble(
        "OpCapability Shader
        OpCapability InputAttachment
        OpMemoryModel Logical GLSL450
        OpEntryPoint Fragment %main \"main\" %out
        OpExecutionMode %main OriginUpperLeft
        OpDecorate %out Location 0
        OpDecorate %depth InputAttachmentIndex 0
        OpDecorate %depth DescriptorSet 0
        OpDecorate %depth Binding 0
        OpDecorate %shadow DescriptorSet 0
        OpDecorate %shadow Binding 1
        %void = OpTypeVoid
        %fn = OpTypeFunction %void
        %float = OpTypeFloat 32
        %int = OpTypeInt 32 1
        %v4 = OpTypeVector %float 4
        %v2i = OpTypeVector %int 2
        %zero = OpConstant %int 0
        %origin = OpConstantComposite %v2i %zero %zero
        %fimage = OpTypeImage %float SubpassData 0 0 0 2 Unknown
        %pf = OpTypePointer UniformConstant %fimage
        %depth = OpVariable %pf UniformConstant
        %pout = OpTypePointer Output %v4
        %out = OpVariable %pout Output
        %simage = OpTypeImage %float 2D 0 0 0 1 Unknown
        %sampled = OpTypeSampledImage %simage
        %ps = OpTypePointer UniformConstant %sampled
        %shadow = OpVariable %ps UniformConstant
        %half = OpConstant %float 0.5
        %halves = OpConstantComposite %v4 %half %half %half %half
        %main = OpFunction %void None %fn
        %entry = OpLabel
        %d = OpLoad %fimage %depth
        %r = OpImageRead %v4 %d %origin
        %m = OpFMul %v4 %r %halves
        OpStore %out %m
        OpReturn
        OpFunctionEnd",
    );
    let mut seeds = vec![
        to_bytes(&misaligned),
        shape("OpDecorate %depth InputAttachmentIndex 1", false),
        shape("OpDecorate %depth InputAttachmentIndex 1", true),
        shape("", true),
        include_bytes!("../../../shaders/glslang/depth_input.frag.spv").to_vec(),
        include_bytes!("../../../shaders/spvasm/depth_input_undecorated.frag.spv").to_vec(),
    ];
    seeds.dedup();
    seeds
}

pub static INPUT_REWRITTEN: Counter = Counter::new("rewritten");
pub static INPUT_VALIDATED: Counter = Counter::new("rewrites of valid modules validated");
pub static INPUT_REFUSED: Counter = Counter::new("refused");
pub static INPUT_COUNTERS: &[&Counter] = &[&INPUT_REWRITTEN, &INPUT_VALIDATED, &INPUT_REFUSED];

/// The input attachment rewrite never panics, and a module it returns keeps the invariants of
/// [`rewrite_problem`], for every way a pipeline names the depth inputs (a render pass's
/// indices, dynamic rendering's explicit index or its default mapping).
fn check_input(bytes: &[u8]) -> Result<u64, String> {
    use crate::shader::input_depth::{reverse_input_depth, DepthInputs};
    let words = to_words(bytes);
    let _ = crate::shader::input_depth::reads_input_attachments(&words);
    let mut outcomes = Vec::new();
    for inputs in [
        DepthInputs::Indices(vec![0]),
        DepthInputs::Indices(vec![1]),
        DepthInputs::Indices(vec![0, 1, 2]),
        DepthInputs::Undecorated,
    ] {
        let outcome = match reverse_input_depth(&words, &inputs) {
            Ok(None) => "unchanged".to_owned(),
            Err(reason) => {
                INPUT_REFUSED.add();
                reason.0.to_owned()
            }
            Ok(Some(out)) => {
                INPUT_REWRITTEN.add();
                if rewrite_problem(&words, &out)
                    .map_err(|problem| format!("{inputs:?}: {problem}"))?
                    .is_some()
                {
                    INPUT_VALIDATED.add();
                }
                format!("rewritten {}", out.len() - words.len())
            }
        };
        outcomes.push(outcome);
    }
    Ok(hash_of(&outcomes))
}

pub fn input_target() -> Target {
    Target {
        name: "input_rewrite",
        extension: "spv",
        seeds: input_attachment_seeds(),
        mutate: mutate_spirv,
        check: check_input,
        max_len: 64 << 10,
        counters: INPUT_COUNTERS,
    }
}

pub fn run_input() {
    let report = super::run(input_target());
    if report.replay {
        return;
    }
    assert!(report.cases as usize >= input_attachment_seeds().len());
    assert!(
        INPUT_VALIDATED.get() > 0,
        "no rewrite of a valid module was validated (is spirv-val, Debian spirv-tools, installed?)"
    );
}

pub fn run_vertex() {
    let report = super::run(vertex_target());
    if report.replay {
        return;
    }
    assert!(report.cases as usize >= VERTEX_SEEDS.len() + LATER_STAGE_SEEDS.len());
    assert!(VERTEX_PROJECTIONS.get() > 0, "no seed has a projection");
}

pub fn run_fragment() {
    let report = super::run(fragment_target());
    if report.replay {
        return;
    }
    assert!(report.cases as usize >= FRAGMENT_SEEDS.len());
    assert!(
        FRAGMENT_VALIDATED.get() > 0,
        "no rewrite of a valid module was validated (is spirv-val, Debian spirv-tools, installed?)"
    );
}

#[test]
fn the_generated_fragment_shaders_compile() {
    let mut rng = Rng::new(7);
    let compiled = (0..20)
        .filter(|_| compile_glsl(ShaderStage::Fragment, &generate_fragment(&mut rng)).is_some())
        .count();
    assert!(compiled >= 15, "only {compiled} of 20 compile");
}
