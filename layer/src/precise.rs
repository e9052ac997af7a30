//! The precise path (`shared/DESIGN.md` sections 1 and 2, as changed by issue #14): the
//! push-constant state of one command buffer, the camera each pushed projection belongs to, and
//! the carrier revz pushes for the rewritten vertex stage.
//!
//! A pipeline whose vertex stage multiplies a push-constant matrix into `Position` has a
//! [`ProjectionUse`] (found by [`crate::shader::analysis`] at shader module creation). The
//! pipeline is created with its vertex stage rewritten to store `z' = c_z z + c_w w + c_1` into
//! `Position` ([`crate::shader::position_store`]), with the three values read from a [`Carrier`] revz
//! reserves in the pipeline layout and pushes:
//!
//! - the application's bytes go down unchanged, so every other use of the matrix (lighting,
//!   view vectors, a varying computed from `Position`) sees the application's values; revz
//!   keeps a shadow copy ([`PushConstants`]) to classify the matrix when it is pushed or bound;
//! - the matrix is matched to a camera ([`revz_math::Cameras`]): one camera, one (n, f), taken
//!   from its best-conditioned matrix, so a P * V * M far from the camera, whose own B is lost
//!   to rounding, still stores the camera's `n / w` (infinite) or complementary depth;
//! - the carrier holds `(0, k', B')` of that range for precise draws and `(1, 0, 0)` (the
//!   shader's z exactly: `1 * z + 0 * w + 0` in any order of evaluation, fused or not) for
//!   every other draw, native ones included, so the one pipeline serves both kinds of
//!   attachment and no second pipeline is compiled; it is pushed only when its value or the
//!   layout changes, so a frame of one camera pushes it once per command buffer and target.
//!
//! Why the store and not the matrix bytes (the design before #14): rewriting the depth row in
//! the pushed bytes changed every output computed from the matrix (13 % of the pixels of an
//! application lighting with its MVP), and took n from each matrix's own, rounded depth row.
//!
//! Pure logic, no Vulkan calls: what must be pushed goes through a [`PushSink`].

use std::mem::MaybeUninit;
use std::sync::{Arc, Mutex, PoisonError};

use ash::vk;
use revz_math::{
    read_clip_transform, reversed_coefficients, CameraMatch, Cameras, DepthCoefficients,
    DepthConvention, DepthDirection, DepthLine, Storage, Target as RewriteTarget,
};

use crate::shader::analysis::ProjectionSlot;

/// Push-constant bytes revz follows per command buffer. Vulkan guarantees 128
/// (`maxPushConstantsSize`); current drivers offer 256. A projection beyond them is not
/// rewritten (its pipelines take the flip path), and bytes beyond them pass through untouched.
pub const PUSH_CONSTANT_BYTES: usize = 256;

/// Where a pipeline's projection lies in the push-constant block, and how to push it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ProjectionUse {
    /// Byte offset of the matrix.
    pub offset: u32,
    /// Bytes between consecutive columns (column-major) or rows (row-major).
    pub stride: u32,
    pub storage: Storage,
    /// The pipeline's clip-space depth convention (`negativeOneToOne` or not).
    pub convention: DepthConvention,
}

/// Why a pipeline's projection cannot take the precise path.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Unusable {
    /// Not a 4x4 matrix of 32-bit floats with a stride of at least 16 bytes.
    Shape,
    /// The matrix lies (partly) beyond [`PUSH_CONSTANT_BYTES`].
    TooFar,
    /// The pipeline layout's push-constant ranges do not allow pushing exactly its bytes.
    Ranges,
}

impl std::fmt::Display for Unusable {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Unusable::Shape => "the matrix is not a 4x4 float matrix with a stride >= 16",
            Unusable::TooFar => "the matrix lies beyond the first 256 push-constant bytes",
            Unusable::Ranges => {
                "the pipeline layout's push-constant ranges do not cover the matrix uniformly"
            }
        })
    }
}

impl ProjectionUse {
    /// The use of `slot` by a pipeline with push-constant `ranges` and depth `convention`.
    pub fn new(
        slot: &ProjectionSlot,
        convention: DepthConvention,
        ranges: &[vk::PushConstantRange],
    ) -> Result<ProjectionUse, Unusable> {
        if slot.columns != 4 || slot.rows != 4 || slot.matrix_stride < 16 {
            return Err(Unusable::Shape);
        }
        let end = u64::from(slot.offset) + 3 * u64::from(slot.matrix_stride) + 16;
        if end > PUSH_CONSTANT_BYTES as u64 {
            return Err(Unusable::TooFar);
        }
        let use_ = ProjectionUse {
            offset: slot.offset,
            stride: slot.matrix_stride,
            storage: if slot.row_major {
                Storage::RowMajor
            } else {
                Storage::ColumnMajor
            },
            convention,
        };
        // revz no longer pushes the matrix's bytes (only its carrier), so this check is no
        // longer needed for the pushes to be valid; it is kept so that issue #14 did not change
        // which pipelines take the precise path beyond what it had to (whether to drop it is
        // left open).
        push_stages(ranges, use_.offset, use_.end()).ok_or(Unusable::Ranges)?;
        Ok(use_)
    }

    /// One past the last byte of the matrix.
    pub fn end(&self) -> u32 {
        self.offset + 3 * self.stride + 16
    }

    /// The 4-byte words of push-constant bytes the matrix spans.
    fn words(&self) -> u64 {
        word_mask(self.offset as usize, self.end() as usize)
    }

    /// The 16 floats in storage order (vector by vector: one bounds check per vector on this
    /// per-push path; `end() <= PUSH_CONSTANT_BYTES` by construction, so no vector is ever
    /// missing: one would read as zeros).
    #[inline]
    fn read(&self, bytes: &[u8; PUSH_CONSTANT_BYTES]) -> [f32; 16] {
        let vector = |index: usize| -> [u8; 16] {
            let at = self.offset as usize + index * self.stride as usize;
            bytes
                .get(at..at + 16)
                .and_then(|stored| stored.try_into().ok())
                .unwrap_or([0; 16])
        };
        let vectors = [vector(0), vector(1), vector(2), vector(3)];
        std::array::from_fn(|i| {
            let word = &vectors[i / 4][(i % 4) * 4..(i % 4) * 4 + 4];
            f32::from_ne_bytes([word[0], word[1], word[2], word[3]])
        })
    }
}

/// The stage flags for pushing exactly bytes `[start, end)` of a layout with `ranges`: the
/// union of the stages of every range overlapping them, provided each of those stages has
/// ranges covering every byte (`vkCmdPushConstants`' valid usage). `None` otherwise.
pub fn push_stages(
    ranges: &[vk::PushConstantRange],
    start: u32,
    end: u32,
) -> Option<vk::ShaderStageFlags> {
    let overlaps = |r: &vk::PushConstantRange| {
        u64::from(r.offset) < u64::from(end)
            && u64::from(start) < u64::from(r.offset) + u64::from(r.size)
    };
    let stages = ranges
        .iter()
        .filter(|r| overlaps(r))
        .fold(vk::ShaderStageFlags::empty(), |s, r| s | r.stage_flags);
    if stages.is_empty() {
        return None;
    }
    let covered = |stage: u32| {
        (start..end).step_by(4).all(|byte| {
            ranges.iter().any(|r| {
                r.stage_flags.as_raw() & stage != 0
                    && r.offset <= byte
                    && u64::from(byte) + 4 <= u64::from(r.offset) + u64::from(r.size)
            })
        })
    };
    let all_covered = (0..32)
        .map(|bit| 1u32 << bit)
        .filter(|stage| stages.as_raw() & stage != 0)
        .all(covered);
    all_covered.then_some(stages)
}

/// Bytes of revz's carrier: a `vec4` (`c_z`, `c_w`, `c_1`, unused) that the rewritten vertex
/// stage reads ([`crate::shader::position_store`]).
pub const CARRIER_BYTES: u32 = 16;

/// The carrier values of the flip path: `z' = 1 * z + 0 * w + 0`, the shader's z exactly.
pub const FLIP_CARRIER: [f32; 4] = [1.0, 0.0, 0.0, 0.0];

/// Where revz's carrier lies in a pipeline layout's push constants, and how to push it.
///
/// Every pipeline layout revz sees in a precise mode gets the same 16 bytes reserved at the
/// device's [`carrier_offset`] ([`reserve_carrier`]): the same function of the application's
/// ranges for every layout, so layouts the application made identical stay identical
/// (compatible for push constants and descriptor sets).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Carrier {
    pub offset: u32,
    /// The stages a push of exactly the carrier's bytes must name: those of the range that
    /// holds them.
    pub stages: vk::ShaderStageFlags,
    /// Where a push of the application's with exactly these stages may start to be extended to
    /// the carrier's bytes ([`PushConstants::fold_carrier`]): the start of the range that
    /// holds the carrier, or past the end of every other stage's range inside it (a folded
    /// push must not write another range's bytes without naming its stages). Derived from the
    /// reserved ranges only, so layouts compatible for push constants agree on it.
    pub range_offset: u32,
    /// The stages every push of the application's that reaches bytes `[from, to)` must name
    /// as well, where the vertex stage's range was extended over another stage's range
    /// ([`reserve_carrier`]); `None`: none.
    pub push_patch: Option<PushPatch>,
}

/// Stages added to the application's pushes that reach bytes `[from, to)`: the vertex range
/// revz extended to its carrier covers them now, and a push must name every stage whose range
/// holds a byte it writes (`vkCmdPushConstants`, VUID-01796).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PushPatch {
    pub from: u32,
    pub to: u32,
    pub stages: vk::ShaderStageFlags,
}

impl PushPatch {
    /// No patch: an empty byte range.
    pub const NONE: PushPatch = PushPatch {
        from: 0,
        to: 0,
        stages: vk::ShaderStageFlags::empty(),
    };

    /// The stages a push of `size` bytes at `offset` with `stages` goes down with.
    #[inline]
    pub fn stages_of(
        &self,
        offset: u32,
        size: u32,
        stages: vk::ShaderStageFlags,
    ) -> vk::ShaderStageFlags {
        let end = u64::from(offset) + u64::from(size);
        if u64::from(offset) < u64::from(self.to) && end > u64::from(self.from) {
            stages | self.stages
        } else {
            stages
        }
    }
}

/// The carrier's offset on a device with `max_push_constants_size`: the last 16 bytes of the
/// first 256 (a larger push-constant space costs some drivers on every draw, and revz follows
/// 256 bytes). `None` when the device offers less than the 128 bytes Vulkan guarantees.
pub fn carrier_offset(max_push_constants_size: u32) -> Option<u32> {
    let space = max_push_constants_size.min(PUSH_CONSTANT_BYTES as u32) / 16 * 16;
    (space >= 128).then(|| space - CARRIER_BYTES)
}

/// Why a layout has no carrier (its pipelines get the carrier baked into their reversed
/// variants instead, `crate::shader::position_store::CarrierRead::Baked`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NoRoom {
    /// The application's ranges reach the carrier's bytes.
    Used,
}

impl std::fmt::Display for NoRoom {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            NoRoom::Used => "the application's push constants use the bytes revz reserves",
        })
    }
}

/// The application's push-constant `ranges` with the carrier at `offset` added: the vertex
/// stage's range extended to cover it (a stage may appear in one range only; where no range
/// names the vertex stage, the mesh stage's: a mesh pipeline's layout), or a new range
/// where it had none, of the vertex stage and of those of `later_stages` (the tessellation
/// evaluation, geometry and mesh stages the device enabled) that no range of the application
/// names: a rewritten tessellation evaluation, geometry or mesh stage reads the carrier too. An
/// application's vertex range that names no later stage is extended as it is: adding stages
/// to it would make the application's own pushes to it invalid, and a separate range of the
/// later stages over the carrier would keep revz from folding the carrier into the
/// application's pushes (a driver call per camera); pipelines with a rewritten later stage
/// and such a layout take the flip path.
///
/// Where the vertex range, extended, overlaps another stage's range (a fragment range after
/// it: `VERTEX 0..64, FRAGMENT 64..80`), it is extended anyway: the application's pushes that
/// reach the extension go down naming the vertex range's stages too ([`Carrier::push_patch`]).
/// Every such push was valid on the application's layout, so it writes no byte of the
/// original vertex range (it would have had to name the vertex stage, which has no byte
/// outside that range): it lies inside the extension, which the extended range covers byte
/// for byte (found in review: a range starting below the vertex range is no exception).
pub fn reserve_carrier(
    ranges: &[vk::PushConstantRange],
    offset: u32,
    later_stages: vk::ShaderStageFlags,
) -> Result<(Vec<vk::PushConstantRange>, Carrier), NoRoom> {
    let end = |r: &vk::PushConstantRange| u64::from(r.offset) + u64::from(r.size);
    if ranges.iter().any(|r| end(r) > u64::from(offset)) {
        return Err(NoRoom::Used);
    }
    let carrier_end = offset + CARRIER_BYTES;
    let mut out = ranges.to_vec();
    let vertex = out
        .iter()
        .position(|r| r.stage_flags.contains(vk::ShaderStageFlags::VERTEX))
        .or_else(|| {
            out.iter()
                .position(|r| r.stage_flags.contains(vk::ShaderStageFlags::MESH_EXT))
        });
    let mut push_patch = None;
    let range = match vertex {
        Some(index) => {
            let start = end(&out[index]);
            let overlapped = ranges.iter().enumerate().any(|(other, r)| {
                other != index && u64::from(r.offset) < u64::from(carrier_end) && end(r) > start
            });
            if overlapped {
                push_patch = Some(PushPatch {
                    from: start as u32,
                    to: offset,
                    stages: out[index].stage_flags,
                });
            }
            out[index].size = carrier_end - out[index].offset;
            out[index]
        }
        None => {
            let named = ranges
                .iter()
                .fold(vk::ShaderStageFlags::empty(), |all, r| all | r.stage_flags);
            let later = later_stages
                & (vk::ShaderStageFlags::TESSELLATION_EVALUATION
                    | vk::ShaderStageFlags::GEOMETRY
                    | vk::ShaderStageFlags::MESH_EXT);
            let range = vk::PushConstantRange {
                stage_flags: vk::ShaderStageFlags::VERTEX | (later & !named),
                offset,
                size: CARRIER_BYTES,
            };
            out.push(range);
            range
        }
    };
    // A folded push starts past every other range inside the carrier's range.
    let range_end = u64::from(range.offset) + u64::from(range.size);
    let fold_from = out
        .iter()
        .filter(|r| r.stage_flags != range.stage_flags)
        .filter(|r| u64::from(r.offset) < range_end && end(r) > u64::from(range.offset))
        .map(|r| end(r) as u32)
        .fold(range.offset, u32::max);
    Ok((
        out,
        Carrier {
            offset,
            stages: range.stage_flags,
            range_offset: fold_from,
            push_patch,
        },
    ))
}

impl Carrier {
    /// The carrier's bytes for `values`.
    pub fn bytes(values: &[f32; 4]) -> [u8; CARRIER_BYTES as usize] {
        let mut bytes = [0; CARRIER_BYTES as usize];
        for (out, value) in bytes.chunks_exact_mut(4).zip(values) {
            out.copy_from_slice(&value.to_ne_bytes());
        }
        bytes
    }
}

/// What the current value of a projection slot is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Outcome {
    /// A standard perspective of a known camera: the carrier values that make the rewritten
    /// vertex stage store the camera's reversed depth (`z' = k' w + B'`). `near_over_far` is
    /// n / f of the camera's range (0 for an infinite far plane).
    Rewritten {
        carrier: [f32; 4],
        near_over_far: f32,
    },
    /// A projection the application already reversed.
    AlreadyReversed,
    /// Orthographic, not a projection, or a perspective of no camera revz can trust: the draw
    /// takes the flip path (for an affine matrix that is the exact reversal, `shared/DESIGN.md`
    /// section 2).
    Unchanged,
}

/// Classifies one pushed matrix against the cameras seen so far (f64 math in [`revz_math`]):
/// the range is the camera's, taken from the best-conditioned matrix of that camera, never
/// this matrix's own where its depth row lost B to rounding. Also says which camera changed,
/// if one did (it was made, or its range improved).
pub fn classify_projection(
    values: &[f32; 16],
    storage: Storage,
    convention: DepthConvention,
    target: RewriteTarget,
    cameras: &mut Cameras,
) -> (Outcome, Option<usize>) {
    let m = read_clip_transform(values, storage);
    let (outcome, changed, _) = classify_line(DepthLine::of(&m), convention, target, cameras);
    (outcome, changed)
}

/// [`classify_projection`] of a matrix's depth line (`None`: not a perspective): the outcome,
/// the camera that changed, and the camera the line belongs to, if any.
fn classify_line(
    line: Option<DepthLine>,
    convention: DepthConvention,
    target: RewriteTarget,
    cameras: &mut Cameras,
) -> (Outcome, Option<usize>, Option<usize>) {
    let observed = match line {
        Some(line) => cameras.observe_line(line, convention),
        None => CameraMatch::NotPerspective,
    };
    let camera = match observed {
        CameraMatch::Camera { index, .. } => Some(index),
        _ => None,
    };
    let changed = match observed {
        CameraMatch::Camera {
            index,
            changed: true,
            ..
        } => Some(index),
        _ => None,
    };
    let outcome = match observed {
        CameraMatch::Camera {
            range, direction, ..
        } => match direction {
            DepthDirection::Standard => {
                let DepthCoefficients { k, b } = reversed_coefficients(range, target, convention);
                let carrier = [0.0, k as f32, b as f32, 0.0];
                if carrier.iter().all(|c| c.is_finite()) {
                    Outcome::Rewritten {
                        carrier,
                        near_over_far: (range.near() / range.far()) as f32,
                    }
                } else {
                    Outcome::Unchanged
                }
            }
            DepthDirection::Reversed => Outcome::AlreadyReversed,
        },
        CameraMatch::Untrusted => {
            static UNTRUSTED: crate::logging::LogOnce = crate::logging::LogOnce::new();
            UNTRUSTED.log(|| {
                log::info!(
                    "a pushed perspective matrix matches no camera seen so far, and its depth \
                     row, rounded to float32, gives no near plane revz can trust (B lost to \
                     rounding, or a reversed-looking sign): its draws take the flip path until \
                     a better-conditioned matrix of its camera is pushed"
                )
            });
            Outcome::Unchanged
        }
        CameraMatch::NotPerspective => Outcome::Unchanged,
    };
    (outcome, changed, camera)
}

/// An application's push extended to revz's carrier ([`PushConstants::fold_carrier`]): what
/// goes down in its place, bytes `offset..offset + size` of the block. Small on purpose: it
/// travels through the per-push path, and its bytes are written only where it goes down
/// ([`PushConstants::folded_bytes`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FoldedPush {
    pub offset: u32,
    pub size: u32,
    /// The carrier's values, in its last [`CARRIER_BYTES`].
    carrier: [f32; 4],
}

/// Where [`crate::command_state::CommandState`] sends revz's own push constants (the next
/// layer, in production).
pub trait PushSink {
    fn push_constants(
        &mut self,
        layout: vk::PipelineLayout,
        stages: vk::ShaderStageFlags,
        offset: u32,
        bytes: &[u8],
    );
}

/// The cameras recordings met since the device's last submission that their own tables (the
/// device's cameras at their begin) did not hold, each with the range of the first trusted
/// matrix any recording met of it: recordings of one frame on several threads (a depth
/// pre-pass in one command buffer, the `EQUAL` pass in another) then pin the same range for a
/// camera new in that frame, whichever order each meets its matrices in. Cleared at each
/// submission, when the device's table learns the cameras' best lines (`hooks::cameras`). One
/// lock per camera a recording meets first, for at most [`FIRST_SEEN_LOOKUPS`] cameras per
/// recording.
#[derive(Debug)]
pub struct FirstSeen {
    cameras: Mutex<Cameras>,
}

/// How many cameras a recording looks up in [`FirstSeen`]: a frame's cameras (a main view,
/// shadow and reflection views) are far fewer; a recording meeting more (a new projection per
/// draw) classifies the rest on its own, as before session 39, without a lock per push.
pub const FIRST_SEEN_LOOKUPS: u8 = revz_math::MAX_CAMERAS as u8;

impl Default for FirstSeen {
    fn default() -> Self {
        FirstSeen {
            cameras: Mutex::new(Cameras::default().pinning_ranges()),
        }
    }
}

impl FirstSeen {
    /// `cameras` (a recording's, which has no camera `line` agrees with, or only a provisional
    /// one, in slot `provisional`) meets the trusted `line`: it takes the camera another
    /// recording met first, or this line becomes the one later recordings take (a provisional
    /// range there is replaced by it, as in any table). Whether `cameras` took one.
    fn meet(
        &self,
        cameras: &mut Cameras,
        provisional: Option<usize>,
        line: DepthLine,
        convention: DepthConvention,
    ) -> bool {
        let mut shared = self.cameras.lock().unwrap_or_else(PoisonError::into_inner);
        match shared.observe_line(line, convention) {
            CameraMatch::Camera { index, .. } => {
                cameras.adopt(&shared, index, provisional).is_some()
            }
            _ => false,
        }
    }

    /// A submission: the device's table now holds what recordings met.
    pub fn clear(&self) {
        *self.cameras.lock().unwrap_or_else(PoisonError::into_inner) =
            Cameras::default().pinning_ranges();
    }
}

/// The push-constant state of one command buffer while it records: a shadow copy of the
/// application's values (which go down untouched), and the cameras its projections belong to.
#[derive(Clone, Debug)]
pub struct PushConstants {
    /// The application's values.
    bytes: [u8; PUSH_CONSTANT_BYTES],
    /// Which 4-byte words of `bytes` the application has pushed since the recording began.
    written: u64,
    /// The layout of the application's last push (compatible with the bound pipeline's for
    /// push constants, or the application's draws would be invalid).
    layout: vk::PipelineLayout,
    /// The last search ([`Self::outcome`]): what it depended on besides the matrix's bits,
    /// its outcome and camera. A matrix pushed again (one projection for many draws, the
    /// camera's own best matrix) is not searched again.
    last: Option<(ClassifyInput, Outcome, Option<usize>)>,
    /// The last searched matrix (meaningful where `last` is `Some`; compared by bits).
    last_values: [f32; 16],
    /// The camera the last classified matrix belonged to, for the next matrices of the same
    /// camera (P * V * M of each object: other bits, same line).
    same_camera: Option<SameCamera>,
    /// The cameras seen (seeded from the device's at the recording's begin).
    cameras: Cameras,
    /// Bumped whenever a camera is created or its range improves.
    generation: u64,
    /// A camera was found or improved since [`PushConstants::take_changed`] last asked.
    changed: bool,
    /// Per camera slot of `cameras`, the pushed matrices classified as that camera's in this
    /// recording (the depth profile): a push's matrix counts once, however many binds classify
    /// it again; pushed again, it counts again.
    matches: [u32; revz_math::MAX_CAMERAS],
    /// The words pushed since a classification last counted them ([`Self::count_match`]).
    uncounted: u64,
    /// [`Self::keeps`] found no answer for the current values: the next
    /// [`Self::outcome`] (the full path of the same push) searches at once.
    search_next: bool,
    /// The device's cameras first met since its last submission, where the recording shares
    /// them ([`PushConstants::share_first_seen`]), and how many more it may look up.
    first_seen: Option<(Arc<FirstSeen>, u8)>,
}

impl Default for PushConstants {
    fn default() -> Self {
        PushConstants {
            bytes: [0; PUSH_CONSTANT_BYTES],
            written: 0,
            layout: vk::PipelineLayout::null(),
            last: None,
            last_values: [0.0; 16],
            same_camera: None,
            // A recording's cameras keep their first trusted range ([`Cameras::pinning_ranges`]).
            cameras: Cameras::default().pinning_ranges(),
            generation: 0,
            changed: false,
            matches: [0; revz_math::MAX_CAMERAS],
            search_next: false,
            uncounted: 0,
            first_seen: None,
        }
    }
}

/// The camera of the last classified matrix, and what its matrices classify as: a matrix whose
/// line agrees with the camera's best line and does not improve it gets the same outcome from
/// [`Cameras::observe_line`] (the camera is the most recently used agreeing one, and its
/// range does not change), so the table is not searched again. Valid while the cameras'
/// generation is the one it was made in.
#[derive(Clone, Copy, Debug)]
struct SameCamera {
    index: usize,
    /// The camera's best line.
    line: DepthLine,
    convention: DepthConvention,
    target: RewriteTarget,
    generation: u64,
    outcome: Outcome,
}

/// What a classification of a matrix depends on besides its bits: a matrix of the same bits
/// classifies the same where these are the same.
#[derive(Clone, Copy, Debug, PartialEq)]
struct ClassifyInput {
    storage: Storage,
    convention: DepthConvention,
    target: RewriteTarget,
    /// The cameras' generation.
    generation: u64,
}

/// What the push shortcut (`crate::command_state`) checks a pushed matrix against, prepared
/// where the state settles ([`PushConstants::probe`]) so that a push does only the compares
/// that depend on its bytes ([`PushConstants::keeps`]). Valid until the next search (the
/// full path, which prepares a new one where the state settles again).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShortcutProbe {
    use_: ProjectionUse,
    /// One past the matrix's last byte.
    end: u32,
    /// The 4-byte words of the matrix.
    words: u64,
    /// The outcome the state settled with: the one a push must keep.
    outcome: Outcome,
    same: SameForProbe,
    last: LastForProbe,
}

/// The same-camera answer of [`PushConstants::known`] for a probe.
#[derive(Clone, Copy, Debug, PartialEq)]
enum SameForProbe {
    /// No camera to ask.
    None,
    /// A camera (index, best line) whose matrices keep the probe's outcome.
    Keeps(usize, DepthLine),
    /// A camera whose matrices classify as another outcome.
    Other,
}

/// The last search's answer of [`PushConstants::known`] for a probe (its bits).
#[derive(Clone, Copy, Debug, PartialEq)]
enum LastForProbe {
    /// No search, or one with another input.
    None,
    /// The probe's outcome, of this camera.
    Keeps(Option<usize>),
    /// Another outcome.
    Other,
}

impl ShortcutProbe {
    /// Whether bytes `[offset, offset + size)` touch the matrix.
    #[inline]
    pub fn touched_by(&self, offset: u32, size: usize) -> bool {
        offset < self.end && u64::from(self.use_.offset) < u64::from(offset) + size as u64
    }
}

/// Whether two matrices' bits are equal, compared without a call (`==` on the arrays calls
/// `memcmp`, a tenth of a push's cost in a profile).
#[inline]
fn same_bits(a: &[f32; 16], b: &[f32; 16]) -> bool {
    a.iter()
        .zip(b)
        .fold(0, |differ, (x, y)| differ | (x.to_bits() ^ y.to_bits()))
        == 0
}

/// The 4-byte words `[start, end)` covers (both clamped to [`PUSH_CONSTANT_BYTES`]).
#[inline]
fn word_mask(start: usize, end: usize) -> u64 {
    let (first, last) = (start / 4, end.div_ceil(4).min(64));
    if first >= last {
        return 0;
    }
    // 0 < last <= 64 and first < 64 here: both shifts are in range.
    (u64::MAX >> (64 - last)) & (u64::MAX << first)
}

impl PushConstants {
    /// A recording that starts knowing `cameras`.
    pub fn with_cameras(cameras: Cameras) -> PushConstants {
        PushConstants {
            cameras: cameras.pinning_ranges(),
            ..PushConstants::default()
        }
    }

    /// A camera this recording's table does not hold is looked up in `first_seen` first
    /// ([`FirstSeen`]).
    pub fn share_first_seen(&mut self, first_seen: Arc<FirstSeen>) {
        self.first_seen = Some((first_seen, FIRST_SEEN_LOOKUPS));
    }

    /// The cameras seen so far.
    pub fn cameras(&self) -> &Cameras {
        &self.cameras
    }

    /// Per camera slot of [`Self::cameras`], how many matrices this recording classified as
    /// that camera's.
    pub fn matches(&self) -> &[u32; revz_math::MAX_CAMERAS] {
        &self.matches
    }

    /// The next [`Self::outcome`] searches at once, without asking [`Self::known`]: for a
    /// caller that expects a new camera, which the same-camera test would only decline (the
    /// search gives every answer `known` gives: a matrix that surely holds the camera's line
    /// agrees with it and does not improve it, and the last search's matrix again finds what
    /// it found).
    pub fn search_next(&mut self) {
        self.search_next = true;
    }

    /// Whether a camera was found or improved since last asked.
    pub fn take_changed(&mut self) -> bool {
        std::mem::take(&mut self.changed)
    }

    /// The outcome for `use_` on the current values, or `None` when the application has not
    /// pushed all of its bytes.
    pub fn outcome(&mut self, use_: &ProjectionUse, target: RewriteTarget) -> Option<Outcome> {
        let words = use_.words();
        if self.written & words != words {
            return None;
        }
        let values = use_.read(&self.bytes);
        let input = self.input(use_, target);
        // Where the push shortcut just asked `keeps` of these values, it found no answer.
        let searched = std::mem::take(&mut self.search_next);
        // The camera of the last classified matrix, where this one can be its.
        let same = self.same_camera_for(&input);
        if !searched {
            if let Some((outcome, camera)) = self.known(&values, same, &input) {
                self.count_match(camera, words);
                return Some(outcome);
            }
        }
        let line = DepthLine::of_stored(&values, use_.storage);
        // The same camera's matrix that the sufficient test ([`Self::known`]) did not
        // recognize: its line agrees with the camera's and does not improve it (what the full
        // search would conclude).
        let matched = same
            .filter(|same| {
                line.is_some_and(|line| {
                    same.line.agrees_with(&line)
                        && line.relative_b_error() >= same.line.relative_b_error()
                })
            })
            .map(|same| (same.outcome, Some(same.index)));
        let (outcome, camera) = match matched {
            Some(matched) => matched,
            None => {
                // A trusted line of a camera this recording does not know, or knows only
                // provisionally (untrusted lines pin nothing): the frame's recordings share the
                // range it is first met with.
                if let (Some((first_seen, left)), Some(line)) = (&mut self.first_seen, line) {
                    if *left > 0 && line.is_trusted() {
                        let known = self.cameras.find(&line, use_.convention);
                        let provisional = known.filter(|&index| {
                            self.cameras
                                .camera(index)
                                .is_some_and(|(.., camera_line)| !camera_line.is_trusted())
                        });
                        if (known.is_none() || provisional.is_some())
                            && first_seen.meet(
                                &mut self.cameras,
                                provisional,
                                line,
                                use_.convention,
                            )
                        {
                            *left -= 1;
                            // The device learns it from this recording too.
                            self.generation += 1;
                            self.changed = true;
                        }
                    }
                }
                let (outcome, changed, camera) =
                    classify_line(line, use_.convention, target, &mut self.cameras);
                if changed.is_some() {
                    self.generation += 1;
                    self.changed = true;
                }
                self.same_camera = camera.and_then(|index| {
                    let (.., line) = self.cameras.camera(index)?;
                    Some(SameCamera {
                        index,
                        line,
                        convention: use_.convention,
                        target,
                        generation: self.generation,
                        outcome,
                    })
                });
                (outcome, camera)
            }
        };
        self.count_match(camera, words);
        self.last_values = values;
        self.last = Some((self.input(use_, target), outcome, camera));
        Some(outcome)
    }

    /// What a classification of `use_` for `target` depends on besides the matrix's bits.
    #[inline]
    fn input(&self, use_: &ProjectionUse, target: RewriteTarget) -> ClassifyInput {
        ClassifyInput {
            storage: use_.storage,
            convention: use_.convention,
            target,
            generation: self.generation,
        }
    }

    /// The camera of the last classified matrix, where a matrix classified with `input` can
    /// be its.
    fn same_camera_for(&self, input: &ClassifyInput) -> Option<&SameCamera> {
        self.same_camera.as_ref().filter(|same| {
            same.generation == input.generation
                && same.convention == input.convention
                && same.target == input.target
        })
    }

    /// The outcome the next [`Self::outcome`] gives the current values of `use_` without a
    /// search, where it needs none; nothing is counted.
    pub fn settled_outcome(&self, use_: &ProjectionUse, target: RewriteTarget) -> Option<Outcome> {
        if !self.holds(use_) {
            return None;
        }
        let values = use_.read(&self.bytes);
        let input = self.input(use_, target);
        self.known(&values, self.same_camera_for(&input), &input)
            .map(|(outcome, _)| outcome)
    }

    /// The push shortcut's probe for `use_` rewritten for `target` with the settled
    /// `outcome` ([`ShortcutProbe`], [`Self::keeps`]).
    pub fn probe(
        &self,
        use_: &ProjectionUse,
        target: RewriteTarget,
        outcome: Outcome,
    ) -> ShortcutProbe {
        let input = self.input(use_, target);
        let same = match self.same_camera_for(&input) {
            Some(same) if same.outcome == outcome => SameForProbe::Keeps(same.index, same.line),
            Some(_) => SameForProbe::Other,
            None => SameForProbe::None,
        };
        let last = match &self.last {
            Some((last_input, last, camera)) if *last_input == input => {
                if *last == outcome {
                    LastForProbe::Keeps(*camera)
                } else {
                    LastForProbe::Other
                }
            }
            _ => LastForProbe::None,
        };
        ShortcutProbe {
            use_: *use_,
            end: use_.end(),
            words: use_.words(),
            outcome,
            same,
            last,
        }
    }

    /// Whether the current values of the probe's matrix (just pushed) keep its outcome
    /// without a search: what [`Self::known`] answers, with the compares that do not depend
    /// on the values made in [`Self::probe`] (counted as [`Self::outcome`] counts it).
    /// `false` changes nothing but what the full path of the same push then skips (the
    /// search for an answer this found not to exist).
    #[inline]
    pub fn keeps(&mut self, probe: &ShortcutProbe) -> bool {
        if self.written & probe.words != probe.words {
            return false;
        }
        let values = probe.use_.read(&self.bytes);
        match &probe.same {
            SameForProbe::Keeps(index, line) => {
                if line.surely_holds(&values, probe.use_.storage) {
                    self.count_match(Some(*index), probe.words);
                    return true;
                }
            }
            // `known` may answer another outcome: the full path finds out.
            SameForProbe::Other => return false,
            SameForProbe::None => {}
        }
        match probe.last {
            LastForProbe::Keeps(camera) if same_bits(&self.last_values, &values) => {
                self.count_match(camera, probe.words);
                true
            }
            LastForProbe::Other if same_bits(&self.last_values, &values) => false,
            _ => {
                self.search_next = true;
                false
            }
        }
    }

    /// Whether the application pushed every byte of `use_`.
    #[inline]
    fn holds(&self, use_: &ProjectionUse) -> bool {
        let mask = use_.words();
        self.written & mask == mask
    }

    /// The outcome of `values` (classified with `input`) and its camera where no search is
    /// needed: the camera `same`'s ([`Self::same_camera_for`]) for a matrix that surely
    /// agrees with its line and does not improve it ([`DepthLine::surely_holds`]: about 150
    /// instructions, first because most pushes are such matrices); the last search's, for
    /// its matrix's bits under the same input. The two agree where both answer: a search
    /// leaves `same_camera` as the camera it found, with its outcome.
    #[inline]
    fn known(
        &self,
        values: &[f32; 16],
        same: Option<&SameCamera>,
        input: &ClassifyInput,
    ) -> Option<(Outcome, Option<usize>)> {
        if let Some(same) = same {
            if same.line.surely_holds(values, input.storage) {
                return Some((same.outcome, Some(same.index)));
            }
        }
        let (last_input, outcome, camera) = self.last.as_ref()?;
        (last_input == input && same_bits(&self.last_values, values)).then_some((*outcome, *camera))
    }

    /// The matrix in `words` classified as `camera`'s: where it was pushed since it last
    /// counted, the camera was used now (the table's least recently used camera makes room
    /// for a new one) and counts it (the depth profile). A settle that classifies the same
    /// matrix again (after a bind) changes neither, so a bind that leaves the state settled
    /// without classifying leaves it as that settle would.
    #[inline]
    fn count_match(&mut self, camera: Option<usize>, words: u64) {
        if let Some(index) = camera {
            if self.uncounted & words != 0 {
                self.uncounted &= !words;
                self.cameras.touch(index);
                if let Some(count) = self.matches.get_mut(index) {
                    *count = count.saturating_add(1);
                }
            }
        }
    }

    /// `vkCmdPushConstants` of `data` at `offset` with `layout`: the values go down as they
    /// are; the shadow copy follows them.
    pub fn push(&mut self, layout: vk::PipelineLayout, offset: u32, data: &[u8]) {
        self.layout = layout;
        let start = offset as usize;
        let end = start.saturating_add(data.len());
        if let Some(shadow) = self.bytes.get_mut(start..end.min(PUSH_CONSTANT_BYTES)) {
            shadow.copy_from_slice(&data[..shadow.len()]);
        }
        let words = word_mask(start, end);
        self.written |= words;
        self.uncounted |= words;
    }

    /// The application's push of `stages` at `offset` (already followed by [`Self::push`]),
    /// extended to the carrier's bytes holding `values`: the bytes from `offset` to the
    /// carrier's end (the application's values, then its earlier ones or zeros where it pushed
    /// none, then the carrier). `None` where the push cannot carry it alone: other stages than
    /// the carrier's range's, or bytes before that range. One call down instead of two when a
    /// camera change comes with a push, as it does for a projection per draw.
    pub fn fold_carrier(
        &self,
        carrier: &Carrier,
        stages: vk::ShaderStageFlags,
        offset: u32,
        values: &[f32; 4],
    ) -> Option<FoldedPush> {
        // `range_offset` lies past every other stage's range inside the carrier's: a folded
        // push writes no byte of another range.
        if stages != carrier.stages || offset < carrier.range_offset || offset >= carrier.offset {
            return None;
        }
        let end = carrier.offset + CARRIER_BYTES;
        if end as usize > PUSH_CONSTANT_BYTES {
            return None;
        }
        Some(FoldedPush {
            offset,
            size: end - offset,
            carrier: *values,
        })
    }

    /// The bytes of `folded`, written into `out`: the shadow copy's from its offset to the
    /// carrier (the application's values just pushed, then its earlier ones or zeros where it
    /// pushed none), then the carrier. The shadow must be as it was when `folded` was made.
    pub fn folded_bytes<'a>(
        &self,
        folded: &FoldedPush,
        out: &'a mut [MaybeUninit<u8>; PUSH_CONSTANT_BYTES],
    ) -> &'a [u8] {
        let (start, end) = (
            folded.offset as usize,
            (folded.offset + folded.size) as usize,
        );
        let carrier_at = end - CARRIER_BYTES as usize;
        let (app, carrier) = out[..end - start].split_at_mut(carrier_at - start);
        for (out, byte) in app.iter_mut().zip(&self.bytes[start..carrier_at]) {
            out.write(*byte);
        }
        for (out, byte) in carrier.iter_mut().zip(Carrier::bytes(&folded.carrier)) {
            out.write(byte);
        }
        // SAFETY: both parts of the first `end - start` bytes were written just above.
        unsafe { std::slice::from_raw_parts(out.as_ptr().cast::<u8>(), end - start) }
    }

    /// The layout of the application's last push (null before the first).
    pub fn layout(&self) -> vk::PipelineLayout {
        self.layout
    }

    /// After `vkCmdExecuteCommands`, push constants are undefined again (the cameras stay
    /// known).
    pub fn invalidate(&mut self) {
        *self = PushConstants {
            generation: self.generation,
            changed: self.changed,
            matches: self.matches,
            // Still one of the device's recordings (found in review: a primary that executed a
            // secondary classified the cameras it met after alone).
            first_seen: self.first_seen.take(),
            ..PushConstants::with_cameras(std::mem::take(&mut self.cameras))
        };
    }
}

#[cfg(test)]
mod tests {
    use glam::dcamera::rh::{proj::vulkan, view::look_at_mat4};
    use glam::{DMat4, DVec3};

    use super::*;

    const VERTEX: vk::ShaderStageFlags = vk::ShaderStageFlags::VERTEX;
    const FRAGMENT: vk::ShaderStageFlags = vk::ShaderStageFlags::FRAGMENT;

    fn column_major_at(offset: u32) -> ProjectionUse {
        ProjectionUse {
            offset,
            stride: 16,
            storage: Storage::ColumnMajor,
            convention: DepthConvention::ZeroToOne,
        }
    }

    fn range(stage_flags: vk::ShaderStageFlags, offset: u32, size: u32) -> vk::PushConstantRange {
        vk::PushConstantRange {
            stage_flags,
            offset,
            size,
        }
    }

    /// P * V * M of a camera (n = 0.1, f = 100, eye off the origin) for an object at `at`.
    fn mvp(at: DVec3) -> [f32; 16] {
        let view = look_at_mat4(DVec3::new(30.0, 20.0, 50.0), DVec3::ZERO, DVec3::Y);
        (vulkan::perspective(1.0, 1.5, 0.1, 100.0) * view * DMat4::from_translation(at))
            .as_mat4()
            .to_cols_array()
    }

    fn bytes_of(values: &[f32]) -> Vec<u8> {
        values.iter().flat_map(|v| v.to_ne_bytes()).collect()
    }

    fn layout() -> vk::PipelineLayout {
        use ash::vk::Handle;
        vk::PipelineLayout::from_raw(7)
    }

    /// The same-camera shortcut of [`PushConstants::outcome`] changes nothing: matrices of
    /// three cameras (objects near and far, so that later matrices improve a camera's line),
    /// pushed interleaved in runs, get the outcomes and leave the cameras that classifying
    /// each one from scratch ([`classify_projection`]) gives.
    #[test]
    fn the_same_camera_shortcut_gives_what_the_full_search_gives() {
        let eyes = [
            DVec3::new(30.0, 20.0, 50.0),
            DVec3::new(-4000.0, 15.0, 900.0),
            DVec3::new(0.5, 1.0, 2.0),
        ];
        let planes = [(0.1, 100.0), (0.5, 5.0e4), (0.01, 1.0e7)];
        let mvp = |camera: usize, at: DVec3| -> [f32; 16] {
            let view = look_at_mat4(eyes[camera], DVec3::ZERO, DVec3::Y);
            let (near, far) = planes[camera];
            (vulkan::perspective(1.0, 1.5, near, far) * view * DMat4::from_translation(at))
                .as_mat4()
                .to_cols_array()
        };
        let use_ = column_major_at(0);
        for target in [RewriteTarget::Complementary, RewriteTarget::Infinite] {
            let mut push = PushConstants::default();
            // A recording's table pins its cameras' ranges.
            let mut reference = Cameras::default().pinning_ranges();
            let mut state = 0x2545_f491_4f6c_dd1du64;
            for step in 0..3000 {
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                // Runs of one camera, objects from far to near and back.
                let camera = (step / 50 + (state % 7 == 0) as usize) % 3;
                let distance = [1.0e5, 1.0e3, 10.0, 0.5][(state >> 8) as usize % 4];
                let at = DVec3::new(
                    ((state >> 16) % 100) as f64 / 100.0 - 0.5,
                    ((state >> 24) % 100) as f64 / 100.0 - 0.5,
                    -1.0,
                ) * distance;
                let values = mvp(camera, at);
                push.push(layout(), 0, &bytes_of(&values));
                let got = push.outcome(&use_, target);
                let (want, _) = classify_projection(
                    &values,
                    Storage::ColumnMajor,
                    DepthConvention::ZeroToOne,
                    target,
                    &mut reference,
                );
                assert_eq!(got, Some(want), "step {step}");
                for index in 0..revz_math::MAX_CAMERAS {
                    let ranges = |cameras: &Cameras| cameras.camera(index).map(|c| (c.0, c.3));
                    assert_eq!(ranges(push.cameras()), ranges(&reference), "step {step}");
                }
            }
        }
    }

    /// Two recordings of one frame meet a camera new to the device in opposite orders (a
    /// pre-pass farthest first, a color pass nearest first): sharing [`FirstSeen`], both pin
    /// the range of the first one's first matrix; alone, each pins its own, and they disagree.
    #[test]
    fn recordings_sharing_first_seen_pin_one_range_for_a_new_camera() {
        let mvp = |camera: usize, distance: f64| -> [f32; 16] {
            let view = look_at_mat4(DVec3::new(1.0, 2.0, 3.0), DVec3::ZERO, DVec3::Y);
            let near = [0.1, 0.5][camera];
            (vulkan::perspective(1.0, 1.5, near, 1000.0)
                * view
                * DMat4::from_translation(DVec3::new(0.3, -0.2, -distance)))
            .as_mat4()
            .to_cols_array()
        };
        let use_ = column_major_at(0);
        let far_first = [400.0, 60.0, 3.0, 0.5];
        let near_first = [0.5, 3.0, 60.0, 400.0];
        for target in [RewriteTarget::Complementary, RewriteTarget::Infinite] {
            let run = |matrices: &[[f32; 16]], shared: Option<&Arc<FirstSeen>>| -> Vec<Outcome> {
                let mut push = PushConstants::default();
                if let Some(shared) = shared {
                    push.share_first_seen(Arc::clone(shared));
                }
                matrices
                    .iter()
                    .map(|values| {
                        push.push(layout(), 0, &bytes_of(values));
                        push.outcome(&use_, target).expect("classified")
                    })
                    .collect()
            };
            let of = |distances: &[f64]| -> Vec<[f32; 16]> {
                distances.iter().map(|&d| mvp(0, d)).collect()
            };
            let same = |outcomes: &[Outcome]| outcomes.iter().all(|o| *o == outcomes[0]);
            let alone = (run(&of(&far_first), None), run(&of(&near_first), None));
            assert!(same(&alone.0) && same(&alone.1), "one range per recording");
            assert_ne!(alone.0[0], alone.1[0], "each its own first matrix's");
            let shared = Arc::new(FirstSeen::default());
            let a = run(&of(&far_first), Some(&shared));
            let b = run(&of(&near_first), Some(&shared));
            assert_eq!(a[0], alone.0[0]);
            assert!(a.iter().chain(&b).all(|o| *o == a[0]), "{a:?} {b:?}");
            // After a submission the device's table holds the camera: a recording meeting it
            // afresh pins its own first again.
            shared.clear();
            assert_eq!(run(&of(&near_first), Some(&shared))[0], alone.1[0]);
            // A recording looks up at most FIRST_SEEN_LOOKUPS cameras: one meeting more (a
            // new projection per draw) classifies the rest alone. Here the second camera comes
            // after the lookups are spent, so the later recording does not take its range.
            shared.clear();
            let mut many: Vec<[f32; 16]> = Vec::new();
            for index in 0..FIRST_SEEN_LOOKUPS {
                let near = 0.01 * f64::from(index + 1);
                let view = look_at_mat4(DVec3::new(1.0, 2.0, 3.0), DVec3::ZERO, DVec3::Y);
                many.push(
                    (vulkan::perspective(0.3, 1.0, near, 7.0) * view)
                        .as_mat4()
                        .to_cols_array(),
                );
            }
            many.push(mvp(1, 400.0));
            let spent = run(&many, Some(&shared));
            let later = run(&[mvp(1, 0.5)], Some(&shared));
            assert_eq!(later[0], run(&[mvp(1, 0.5)], None)[0]);
            assert_ne!(later[0], spent[spent.len() - 1]);
        }
    }

    /// A matrix of (near, far), its object at `distance` and `x`.
    fn object_mvp(near: f64, far: f64, distance: f64, x: f64) -> [f32; 16] {
        let view = look_at_mat4(DVec3::new(1.0, 2.0, 3.0), DVec3::ZERO, DVec3::Y);
        (vulkan::perspective(1.0, 1.5, near, far)
            * view
            * DMat4::from_translation(DVec3::new(x, -0.2, -distance)))
        .as_mat4()
        .to_cols_array()
    }

    /// The outcomes of `push` classifying each matrix in turn (complementary).
    fn classified(push: &mut PushConstants, matrices: &[[f32; 16]]) -> Vec<Outcome> {
        matrices
            .iter()
            .map(|values| {
                push.push(layout(), 0, &bytes_of(values));
                push.outcome(&column_major_at(0), RewriteTarget::Complementary)
                    .expect("classified")
            })
            .collect()
    }

    fn sharing(first_seen: &Arc<FirstSeen>) -> PushConstants {
        let mut push = PushConstants::default();
        push.share_first_seen(Arc::clone(first_seen));
        push
    }

    /// Found in review: a camera a recording first met through an untrusted line (B lost to
    /// rounding) kept the first trusted range it met to itself, and the other recordings pinned
    /// their own. Now a trusted line of a camera known only provisionally is shared too.
    #[test]
    fn a_camera_first_met_untrusted_shares_its_first_trusted_range() {
        let (near, far) = (0.01, 1.0e7);
        let provisional = (0..200)
            .map(|i| 4.0e3 * 1.05f64.powi(i))
            .find(|&d| {
                let line =
                    DepthLine::of_stored(&object_mvp(near, far, d, 0.3), Storage::ColumnMajor)
                        .expect("a line");
                !line.is_trusted()
                    && matches!(
                        Cameras::new().observe_line(line, DepthConvention::ZeroToOne),
                        CameraMatch::Camera { .. }
                    )
            })
            .expect("a distance with a provisional line");
        let far_first: Vec<[f32; 16]> = [provisional, 3000.0, 30.0, 0.5]
            .iter()
            .map(|&d| object_mvp(near, far, d, 0.3))
            .collect();
        let near_first: Vec<[f32; 16]> = far_first.iter().rev().copied().collect();
        let shared = Arc::new(FirstSeen::default());
        let a = classified(&mut sharing(&shared), &far_first);
        let b = classified(&mut sharing(&shared), &near_first);
        // The object at 3000: A's first trusted line, which B takes.
        assert_eq!(a[1], b[2], "{a:?} {b:?}");
        assert!(
            a[1..].iter().all(|o| *o == a[1]),
            "one line once trusted: {a:?}"
        );
    }

    /// Found in review: lines that give no range (B lost entirely) spent the lookups, so a
    /// far-to-near pre-pass with eight such objects first classified its camera alone.
    #[test]
    fn untrusted_lines_spend_no_lookups() {
        let (near, far) = (0.001, 1.0e7);
        let lost: Vec<[f32; 16]> = (0..400)
            .map(|i| {
                object_mvp(
                    near,
                    far,
                    100.0 * 1.03f64.powi(i),
                    0.3 + f64::from(i) * 1e-3,
                )
            })
            .filter(|m| {
                let line = DepthLine::of_stored(m, Storage::ColumnMajor).expect("a line");
                matches!(
                    Cameras::new().observe_line(line, DepthConvention::ZeroToOne),
                    CameraMatch::Untrusted
                )
            })
            .take(usize::from(FIRST_SEEN_LOOKUPS))
            .collect();
        assert_eq!(lost.len(), usize::from(FIRST_SEEN_LOOKUPS));
        let shared = Arc::new(FirstSeen::default());
        let mut a = sharing(&shared);
        classified(&mut a, &lost);
        let a = classified(&mut a, &[object_mvp(near, far, 50.0, 0.3)]);
        let b = classified(
            &mut sharing(&shared),
            &[
                object_mvp(near, far, 0.5, 0.3),
                object_mvp(near, far, 50.0, 0.3),
            ],
        );
        assert_eq!(a[0], b[1]);
    }

    /// Found in review: `vkCmdExecuteCommands` (which invalidates the push constants) dropped
    /// the shared table, so a primary classified the cameras it met after it alone.
    #[test]
    fn a_primary_keeps_sharing_after_executing_secondaries() {
        let (near, far) = (0.1, 1000.0);
        let far_first: Vec<[f32; 16]> = [400.0, 60.0, 0.5]
            .iter()
            .map(|&d| object_mvp(near, far, d, 0.3))
            .collect();
        let shared = Arc::new(FirstSeen::default());
        let a = classified(&mut sharing(&shared), &far_first);
        let mut b = sharing(&shared);
        b.invalidate();
        let b = classified(&mut b, &far_first[2..]);
        assert_eq!(a[2], b[0]);
    }

    #[test]
    fn the_carrier_is_the_last_16_of_the_first_256_bytes() {
        assert_eq!(carrier_offset(128), Some(112));
        assert_eq!(carrier_offset(256), Some(240));
        assert_eq!(carrier_offset(4096), Some(240));
        assert_eq!(carrier_offset(200), Some(176));
        assert_eq!(carrier_offset(64), None);
    }

    /// Ranges as comparable triples (ash's ranges have no `PartialEq`).
    fn triples(ranges: &[vk::PushConstantRange]) -> Vec<(u32, u32, u32)> {
        ranges
            .iter()
            .map(|r| (r.stage_flags.as_raw(), r.offset, r.size))
            .collect()
    }

    /// Ranges as triples, and the carrier (or why there is none).
    type Reserved = Result<(Vec<(u32, u32, u32)>, Carrier), NoRoom>;

    fn reserved(ranges: &[vk::PushConstantRange]) -> Reserved {
        reserve_carrier(ranges, 112, vk::ShaderStageFlags::empty())
            .map(|(ranges, carrier)| (triples(&ranges), carrier))
    }

    #[test]
    fn a_carrier_range_of_its_own_names_the_later_stages_the_device_enabled() {
        use vk::ShaderStageFlags as S;
        let later = S::GEOMETRY | S::TESSELLATION_EVALUATION;
        let reserve = |ranges: &[vk::PushConstantRange]| {
            reserve_carrier(ranges, 112, later)
                .map(|(ranges, carrier)| (triples(&ranges), carrier.stages))
        };
        // No push constants (projections in buffers): the carrier reaches every stage that
        // can store Position.
        assert_eq!(
            reserve(&[]),
            Ok((vec![((VERTEX | later).as_raw(), 112, 16)], VERTEX | later))
        );
        // A stage the application's ranges name already is left to its range (a stage may be
        // in one range only).
        let (ranges, stages) = reserve(&[range(S::GEOMETRY | FRAGMENT, 0, 16)]).unwrap();
        assert_eq!(
            ranges[1],
            ((VERTEX | S::TESSELLATION_EVALUATION).as_raw(), 112, 16)
        );
        assert_eq!(stages, VERTEX | S::TESSELLATION_EVALUATION);
        // The application's vertex range is extended with its own stages: a geometry stage
        // it names reads the carrier, one it does not name does not.
        let (_, stages) = reserve(&[range(VERTEX | S::GEOMETRY, 0, 64)]).unwrap();
        assert_eq!(stages, VERTEX | S::GEOMETRY);
        let (_, stages) = reserve(&[range(VERTEX, 0, 64)]).unwrap();
        assert_eq!(stages, VERTEX);
        // Tessellation control and fragment stages are never added.
        let (_, stages) = reserve_carrier(&[], 112, S::ALL_GRAPHICS).unwrap();
        assert_eq!(stages.stages, VERTEX | later);
    }

    #[test]
    fn the_vertex_range_is_extended_to_the_carrier_or_one_is_added() {
        let shared = [range(VERTEX | FRAGMENT, 0, 80)];
        let (ranges, carrier) = reserved(&shared).expect("room");
        assert_eq!(ranges, triples(&[range(VERTEX | FRAGMENT, 0, 128)]));
        assert_eq!(
            carrier,
            Carrier {
                offset: 112,
                stages: VERTEX | FRAGMENT,
                range_offset: 0,
                push_patch: None,
            }
        );
        // The same application ranges give the same layout (compatibility is kept).
        assert_eq!(reserved(&shared).expect("room").0, ranges);
        // A vertex range below a fragment range is extended over it; the fragment stage's
        // pushes that reach the extension name the vertex stage too.
        let split = [range(VERTEX, 0, 64), range(FRAGMENT, 64, 16)];
        let (ranges, carrier) = reserved(&split).expect("room");
        assert_eq!(
            ranges,
            triples(&[range(VERTEX, 0, 128), range(FRAGMENT, 64, 16)])
        );
        let patch = carrier.push_patch.expect("a patch");
        assert_eq!((patch.from, patch.to, patch.stages), (64, 112, VERTEX));
        assert_eq!(patch.stages_of(64, 16, FRAGMENT), VERTEX | FRAGMENT);
        assert_eq!(
            patch.stages_of(0, 64, VERTEX),
            VERTEX,
            "below the extension"
        );
        assert_eq!(patch.stages_of(0, 80, VERTEX | FRAGMENT), VERTEX | FRAGMENT);
        // Folding the carrier into a vertex push would write the fragment range's bytes.
        let shadow = PushConstants::default();
        assert_eq!(
            shadow.fold_carrier(&carrier, VERTEX, 0, &FLIP_CARRIER),
            None
        );
        // A range starting below the vertex range and reaching past it: its valid pushes that
        // reach the extension lie inside it (found in review), so it is extended too.
        let below_vertex = [range(FRAGMENT, 0, 80), range(VERTEX, 16, 48)];
        let (ranges, carrier) = reserved(&below_vertex).expect("room");
        assert_eq!(
            ranges,
            triples(&[range(FRAGMENT, 0, 80), range(VERTEX, 16, 112)])
        );
        let patch = carrier.push_patch.expect("a patch");
        assert_eq!((patch.from, patch.to), (64, 112));
        assert_eq!(
            carrier.range_offset, 80,
            "folds start past the fragment range"
        );
        // A fragment range nested in the vertex range: no patch (its pushes name the vertex
        // stage already), but a push of the vertex stage alone folded from 0 would write the
        // fragment range's bytes without naming it (found in review): folds start past it.
        let nested = [range(VERTEX, 0, 80), range(FRAGMENT, 64, 16)];
        let (ranges, carrier) = reserved(&nested).expect("room");
        assert_eq!(
            ranges,
            triples(&[range(VERTEX, 0, 128), range(FRAGMENT, 64, 16)])
        );
        assert_eq!(carrier.push_patch, None);
        assert_eq!(carrier.range_offset, 80);
        assert_eq!(
            shadow.fold_carrier(&carrier, VERTEX, 0, &FLIP_CARRIER),
            None
        );
        assert!(shadow
            .fold_carrier(&carrier, VERTEX, 96, &FLIP_CARRIER)
            .is_some());
        // The fragment range below the vertex one is fine.
        let below = [range(FRAGMENT, 0, 16), range(VERTEX, 16, 64)];
        let (ranges, carrier) = reserved(&below).expect("room");
        assert_eq!(
            ranges,
            triples(&[range(FRAGMENT, 0, 16), range(VERTEX, 16, 112)])
        );
        assert_eq!(carrier.stages, VERTEX);
        // No vertex range: one of the carrier's own.
        let (ranges, _) = reserved(&[range(FRAGMENT, 0, 16)]).expect("room");
        assert_eq!(ranges[1], (VERTEX.as_raw(), 112, 16));
        assert_eq!(reserved(&[range(VERTEX, 0, 128)]), Err(NoRoom::Used));
        assert_eq!(
            Carrier::bytes(&FLIP_CARRIER)[..4],
            1.0f32.to_ne_bytes(),
            "c_z first"
        );
    }

    #[test]
    fn the_application_bytes_go_down_unchanged_and_matrices_of_one_camera_share_its_range() {
        let use_ = column_major_at(0);
        let target = RewriteTarget::Infinite;
        let mut push = PushConstants::default();
        // An object 1.5 from the eye: its matrix gives n to about 1e-6.
        let near = mvp(DVec3::new(29.0, 19.5, 49.0));
        let data = bytes_of(&near);
        push.push(layout(), 0, &data);
        assert_eq!(
            data,
            bytes_of(&near),
            "nothing is written into the app's bytes"
        );
        let Some(Outcome::Rewritten {
            carrier,
            near_over_far,
        }) = push.outcome(&use_, target)
        else {
            panic!("the near object's projection is rewritten");
        };
        assert_eq!(carrier[0], 0.0, "z does not count");
        assert!(
            (f64::from(carrier[2]) / 0.1 - 1.0).abs() < 4e-6,
            "B' = n: {carrier:?}"
        );
        // Objects far from the camera get its carrier exactly, whatever their own rounding.
        for distance in [10.0, 1e3, 1e5, 1e6] {
            push.push(layout(), 0, &bytes_of(&mvp(DVec3::new(distance, 0.0, 0.0))));
            assert_eq!(
                push.outcome(&use_, target),
                Some(Outcome::Rewritten {
                    carrier,
                    near_over_far
                }),
                "an object {distance} away"
            );
        }
    }

    #[test]
    fn a_far_matrix_before_its_camera_gets_the_better_range_once_it_is_seen_and_kept_across_recordings(
    ) {
        let use_ = column_major_at(0);
        let target = RewriteTarget::Complementary;
        let far = bytes_of(&mvp(DVec3::new(1e6, 0.0, 0.0)));
        let near = bytes_of(&mvp(DVec3::new(29.0, 19.5, 49.0)));
        let mut push = PushConstants::default();
        // Alone, the far matrix is a provisional camera (its B has the standard sign) or the
        // flip path: never a range taken as better than it is.
        push.push(layout(), 0, &far);
        let first = push.outcome(&use_, target);
        assert!(
            matches!(first, Some(Outcome::Unchanged | Outcome::Rewritten { .. })),
            "{first:?}"
        );
        push.push(layout(), 0, &near);
        let Some(Outcome::Rewritten { carrier, .. }) = push.outcome(&use_, target) else {
            panic!("the near matrix is rewritten");
        };
        assert_ne!(
            first,
            push.outcome(&use_, target),
            "the near range replaced it"
        );
        push.push(layout(), 0, &far);
        let far_outcome = push.outcome(&use_, target);
        assert!(
            matches!(far_outcome, Some(Outcome::Rewritten { carrier: c, .. }) if c == carrier),
            "the far matrix gets the near one's range: {far_outcome:?}"
        );
        // The next recording starts with the cameras learned.
        let mut next = PushConstants::with_cameras(push.cameras().clone());
        next.push(layout(), 0, &far);
        assert_eq!(next.outcome(&use_, target), far_outcome);
        next.invalidate();
        next.push(layout(), 0, &far);
        assert_eq!(
            next.outcome(&use_, target),
            far_outcome,
            "invalidation forgets the values, not the cameras"
        );
    }

    #[test]
    fn unpushed_orthographic_and_reversed_matrices_are_not_rewritten() {
        let use_ = column_major_at(64);
        let target = RewriteTarget::Infinite;
        let mut push = PushConstants::default();
        assert_eq!(push.outcome(&use_, target), None, "nothing pushed");
        push.push(layout(), 64, &bytes_of(&mvp(DVec3::ZERO)[..8]));
        assert_eq!(push.outcome(&use_, target), None, "half a matrix pushed");
        let ortho = vulkan::orthographic(-1.0, 1.0, -1.0, 1.0, 0.1, 10.0);
        push.push(layout(), 64, &bytes_of(&ortho.as_mat4().to_cols_array()));
        assert_eq!(push.outcome(&use_, target), Some(Outcome::Unchanged));
        // An application's own reversed projection (near and far swapped).
        let reversed = vulkan::perspective(1.0, 1.5, 100.0, 0.1);
        push.push(layout(), 64, &bytes_of(&reversed.as_mat4().to_cols_array()));
        assert_eq!(push.outcome(&use_, target), Some(Outcome::AlreadyReversed));
    }

    #[test]
    fn push_stages_require_uniform_coverage() {
        let range = |stage_flags, offset, size| vk::PushConstantRange {
            stage_flags,
            offset,
            size,
        };
        let fragment = vk::ShaderStageFlags::FRAGMENT;
        assert_eq!(push_stages(&[range(VERTEX, 0, 128)], 0, 64), Some(VERTEX));
        assert_eq!(
            push_stages(&[range(VERTEX, 0, 64), range(fragment, 64, 16)], 0, 64),
            Some(VERTEX)
        );
        assert_eq!(
            push_stages(&[range(VERTEX | fragment, 0, 80)], 0, 64),
            Some(VERTEX | fragment)
        );
        // A fragment range covering only part of the matrix: no valid stage set.
        assert_eq!(
            push_stages(&[range(VERTEX, 0, 64), range(fragment, 32, 48)], 0, 64),
            None
        );
        assert_eq!(push_stages(&[range(VERTEX, 0, 32)], 0, 64), None);
    }

    #[test]
    fn word_masks() {
        assert_eq!(word_mask(0, 4), 1);
        assert_eq!(word_mask(4, 12), 0b110);
        assert_eq!(word_mask(0, 256), u64::MAX);
        assert_eq!(word_mask(0, 10_000), u64::MAX);
        assert_eq!(word_mask(300, 400), 0);
        assert_eq!(word_mask(2, 5), 0b11);
        // Every byte range up to past the followed bytes, against the words' bits one by one.
        for start in 0..=300usize {
            for end in start..=300 {
                let words = (start / 4..end.div_ceil(4).min(64)).fold(0u64, |m, w| m | 1 << w);
                assert_eq!(word_mask(start, end), words, "[{start}, {end})");
            }
        }
    }
}
