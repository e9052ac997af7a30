//! The application's depth convention: whether it renders reversed depth itself
//! ([`Convention`], decided once per device by [`ConventionEvidence::decide`]), and what revz
//! observes of it while it records ([`Observed`]: the evidence, the decision, and n / f of the
//! projections it pushes), and where an event commits a reversed image to it
//! ([`Observed::committed`]: the clear it is decided with).

use std::sync::atomic::{AtomicBool, AtomicU32, AtomicU8, Ordering};

use ash::vk;

use crate::command_state::{same_near_over_far, Target};
use crate::config::Mode;
use crate::precise::Outcome;

/// The depth convention an application renders with, as revz decides it for a device.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Convention {
    /// Standard depth (near 0, far 1, LESS): revz reverses it.
    Standard,
    /// The application renders reversed depth itself: revz leaves its depth alone (pitfall 7
    /// of `shared/DESIGN.md`).
    AppReversed,
}

/// What revz has seen of the application before it decides the convention: the compare ops
/// of the depth-testing pipelines it created (static ones, counted) and of
/// `vkCmdSetDepthCompareOp` (seen or not), and whether the projections it pushed were
/// reversed or standard.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ConventionEvidence {
    pub greater_compare_ops: u32,
    pub less_compare_ops: u32,
    pub reversed_projection: bool,
    pub standard_projection: bool,
}

impl ConventionEvidence {
    /// Decides the convention at the first event that commits a reversed attachment to one
    /// (a render pass or rendering begin, an image clear, a secondary's begin); `clear`: the
    /// depth that event clears the attachment to, if it clears it.
    ///
    /// Reversed on a clear to 0 that nothing contradicts (more LESS than GREATER compare ops,
    /// or only standard projections pushed), where what was seen supports it (more GREATER
    /// than LESS, or reversed projections) or nothing was seen at all. One reversed-looking
    /// matrix (rounding in a P*V*M far from the camera) or GREATER compare ops without a clear
    /// to 0, an application that clears to 0 but tests LESS, and a tie of the compare ops
    /// stay standard.
    ///
    /// A clear to 0 before anything else: translation layers that create their pipelines and
    /// set their compare ops at the first draw, after the clear (Zink for OpenGL; DXVK for
    /// Direct3D 11 where its pipeline cache is cold), show nothing else of an application
    /// rendering reversed depth when its first depth image is cleared (`glClipControl` with
    /// `glClearDepth(0)` and `GL_GREATER`: piglit's `arb_clip_control-depth-precision`,
    /// `gl-render --reversed-z`). Taken as standard it would have its depth reversed again,
    /// which in float32 loses what its own reversal gained; taken as reversed, a standard
    /// application that clears to 0 first (rare: nothing passes a LESS test there) is merely
    /// left alone.
    pub fn decide(&self, clear: Option<f32>) -> Convention {
        use std::cmp::Ordering::{Greater, Less};
        let compare = self.greater_compare_ops.cmp(&self.less_compare_ops);
        let camera = match (self.reversed_projection, self.standard_projection) {
            (true, false) => Greater,
            (false, true) => Less,
            _ => std::cmp::Ordering::Equal,
        };
        let nothing_seen = *self == ConventionEvidence::default();
        let supported = compare == Greater || camera == Greater || nothing_seen;
        let contradicted = compare == Less || camera == Less;
        if clear == Some(0.0) && supported && !contradicted {
            Convention::AppReversed
        } else {
            Convention::Standard
        }
    }
}

const UNDECIDED: u8 = 0;
const STANDARD: u8 = 1;
const APP_REVERSED: u8 = 2;

/// What revz learns about a device's application while it records: its depth convention
/// (decided once, [`Observed::settle`]), and (infinite mode) n / f of the projections it
/// pushes. Shared by every recording thread: the evidence is written only until the
/// convention is decided, and then only read (one load).
#[derive(Debug, Default)]
pub struct Observed {
    convention: AtomicU8,
    greater_compare_ops: AtomicU32,
    less_compare_ops: AtomicU32,
    dynamic_greater: AtomicBool,
    dynamic_less: AtomicBool,
    reversed_projection: AtomicBool,
    standard_projection: AtomicBool,
    near_over_far: AtomicU32,
}

/// Sets a flag without writing its cache line when it is already set.
fn raise(flag: &AtomicBool) {
    if !flag.load(Ordering::Relaxed) {
        flag.store(true, Ordering::Relaxed);
    }
}

/// Which way a compare op orders depth: `Some(true)` for GREATER-like, `Some(false)` for
/// LESS-like, `None` for the others (EQUAL, ALWAYS, ...).
fn orders_greater(op: vk::CompareOp) -> Option<bool> {
    match op {
        vk::CompareOp::GREATER | vk::CompareOp::GREATER_OR_EQUAL => Some(true),
        vk::CompareOp::LESS | vk::CompareOp::LESS_OR_EQUAL => Some(false),
        _ => None,
    }
}

impl Observed {
    fn decided(&self) -> u8 {
        self.convention.load(Ordering::Relaxed)
    }

    /// The convention, if decided.
    pub fn convention(&self) -> Option<Convention> {
        match self.decided() {
            STANDARD => Some(Convention::Standard),
            APP_REVERSED => Some(Convention::AppReversed),
            _ => None,
        }
    }

    /// Evidence: a depth-testing pipeline with this static compare op was created.
    pub fn note_pipeline_compare_op(&self, op: vk::CompareOp) {
        if self.decided() != UNDECIDED {
            return;
        }
        match orders_greater(op) {
            Some(true) => self.greater_compare_ops.fetch_add(1, Ordering::Relaxed),
            Some(false) => self.less_compare_ops.fetch_add(1, Ordering::Relaxed),
            None => return,
        };
    }

    /// Evidence: the application set this dynamic compare op.
    pub fn note_dynamic_compare_op(&self, op: vk::CompareOp) {
        if self.decided() != UNDECIDED {
            return;
        }
        match orders_greater(op) {
            Some(true) => raise(&self.dynamic_greater),
            Some(false) => raise(&self.dynamic_less),
            None => {}
        }
    }

    /// What the classification of a pushed projection tells, in a device of `mode`: evidence
    /// of the convention, and (infinite mode only, where clears and flip-path state follow
    /// it) the camera's n / f.
    pub fn note_outcome(&self, mode: Mode, outcome: &Outcome) {
        match outcome {
            Outcome::Rewritten { near_over_far, .. } => {
                self.note_projection(false);
                if mode == Mode::Infinite {
                    self.note_near_over_far(*near_over_far)
                }
            }
            Outcome::AlreadyReversed => self.note_projection(true),
            Outcome::Unchanged => {}
        }
    }

    /// Evidence: the application pushed a projection, reversed or standard.
    pub fn note_projection(&self, reversed: bool) {
        if self.decided() != UNDECIDED {
            return;
        }
        raise(if reversed {
            &self.reversed_projection
        } else {
            &self.standard_projection
        });
    }

    /// What was seen so far.
    pub fn evidence(&self) -> ConventionEvidence {
        let flag = |f: &AtomicBool| u32::from(f.load(Ordering::Relaxed));
        ConventionEvidence {
            greater_compare_ops: self.greater_compare_ops.load(Ordering::Relaxed)
                + flag(&self.dynamic_greater),
            less_compare_ops: self.less_compare_ops.load(Ordering::Relaxed)
                + flag(&self.dynamic_less),
            reversed_projection: self.reversed_projection.load(Ordering::Relaxed),
            standard_projection: self.standard_projection.load(Ordering::Relaxed),
        }
    }

    /// The convention, decided now from the evidence if it is not yet: called where a
    /// reversed attachment is first committed to one (`clear`: the depth it is cleared to
    /// there, if it is). Decided once for the device and never changed, so every command
    /// buffer, recorded before or after, draws into its attachments the same way. Logged
    /// once.
    pub fn settle(&self, clear: Option<f32>) -> Convention {
        if let Some(decided) = self.convention() {
            return decided;
        }
        let evidence = self.evidence();
        let convention = evidence.decide(clear);
        let value = match convention {
            Convention::Standard => STANDARD,
            Convention::AppReversed => APP_REVERSED,
        };
        match self.convention.compare_exchange(
            UNDECIDED,
            value,
            Ordering::Relaxed,
            Ordering::Relaxed,
        ) {
            Ok(_) if convention == Convention::AppReversed => log::info!(
                "the application already uses reversed depth (a depth attachment cleared to 0, \
                 {} GREATER and {} LESS compare ops, {} projections): revz leaves its depth \
                 alone",
                evidence.greater_compare_ops,
                evidence.less_compare_ops,
                match (evidence.reversed_projection, evidence.standard_projection) {
                    (true, false) => "reversed",
                    (false, true) => "standard",
                    (true, true) => "reversed and standard",
                    (false, false) => "no pushed",
                }
            ),
            Ok(_) => log::debug!("the application renders standard depth ({evidence:?})"),
            // Another thread decided first: its decision stands.
            Err(_) => return self.convention().unwrap_or(Convention::Standard),
        }
        convention
    }

    /// The depth target revz acts on for `image`, where an event commits it to a convention:
    /// a pass begin (`image`: reversed where any of its attachments is), or a clear of the
    /// image. Committing a reversed image decides the convention if it is not yet, from
    /// `clear`: the depth the event clears it to (for a pass, the first reversed attachment
    /// it clears), if it clears one. Other images commit nothing.
    pub fn committed(&self, image: Target, clear: Option<f32>) -> Target {
        if image == Target::Reversed {
            self.settle(clear);
        }
        self.effective(image)
    }

    /// The depth target revz acts on for an attachment whose image is `target` (settling
    /// the convention, without a clear, where it is not yet decided).
    pub fn effective(&self, target: Target) -> Target {
        match target {
            Target::Reversed if self.settle(None) == Convention::AppReversed => Target::Native,
            other => other,
        }
    }

    /// n / f of the last projection rewritten (0 before any).
    pub fn near_over_far(&self) -> f32 {
        f32::from_bits(self.near_over_far.load(Ordering::Relaxed))
    }

    pub fn note_near_over_far(&self, near_over_far: f32) {
        // Load first: the common case (the same camera) must not write the shared cache line.
        if !same_near_over_far(self.near_over_far(), near_over_far) {
            self.near_over_far
                .store(near_over_far.to_bits(), Ordering::Relaxed);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_classified_projection_is_evidence_and_gives_n_over_f_only_in_infinite_mode() {
        let rewritten = Outcome::Rewritten {
            carrier: [0.0; 4],
            near_over_far: 0.25,
        };
        for mode in [Mode::Complementary, Mode::Infinite] {
            let observed = Observed::default();
            observed.note_outcome(mode, &rewritten);
            observed.note_outcome(mode, &Outcome::Unchanged);
            let evidence = observed.evidence();
            assert_eq!(
                (evidence.standard_projection, evidence.reversed_projection),
                (true, false)
            );
            let expected = if mode == Mode::Infinite {
                0.25
            } else {
                Observed::default().near_over_far()
            };
            assert_eq!(observed.near_over_far(), expected, "{mode:?}");
            observed.note_outcome(mode, &Outcome::AlreadyReversed);
            assert!(observed.evidence().reversed_projection);
        }
    }

    #[test]
    fn strong_evidence_makes_reversed_targets_native() {
        let observed = Observed::default();
        observed.note_pipeline_compare_op(vk::CompareOp::GREATER);
        observed.note_pipeline_compare_op(vk::CompareOp::EQUAL);
        assert_eq!(observed.settle(Some(0.0)), Convention::AppReversed);
        assert_eq!(observed.effective(Target::Reversed), Target::Native);
        assert_eq!(observed.effective(Target::None), Target::None);
    }

    #[test]
    fn the_convention_is_decided_once_and_later_evidence_changes_nothing() {
        // A standard application's first pass: decided standard.
        let observed = Observed::default();
        observed.note_pipeline_compare_op(vk::CompareOp::LESS);
        assert_eq!(observed.effective(Target::Reversed), Target::Reversed);
        // Later, in the same frame: a matrix that looks reversed, a clear to 0, GREATER
        // pipelines. Command buffers recorded before keep drawing reversed, so new ones must
        // too.
        observed.note_projection(true);
        for _ in 0..10 {
            observed.note_pipeline_compare_op(vk::CompareOp::GREATER_OR_EQUAL);
        }
        observed.note_dynamic_compare_op(vk::CompareOp::GREATER);
        assert_eq!(observed.settle(Some(0.0)), Convention::Standard);
        assert_eq!(observed.effective(Target::Reversed), Target::Reversed);
        // The evidence stopped being gathered once decided.
        assert_eq!(observed.evidence().greater_compare_ops, 0);
    }

    #[test]
    fn one_signal_alone_is_weak_evidence() {
        let decide = |evidence: ConventionEvidence, clear| evidence.decide(clear);
        let none = ConventionEvidence::default();
        let greater = ConventionEvidence {
            greater_compare_ops: 3,
            less_compare_ops: 1,
            ..none
        };
        let camera = ConventionEvidence {
            reversed_projection: true,
            ..none
        };
        // GREATER alone, a reversed camera alone: standard.
        assert_eq!(decide(greater, Some(1.0)), Convention::Standard);
        assert_eq!(decide(greater, None), Convention::Standard);
        assert_eq!(decide(camera, None), Convention::Standard);
        // A clear to 0 with either GREATER or a reversed camera: reversed.
        assert_eq!(decide(greater, Some(0.0)), Convention::AppReversed);
        assert_eq!(decide(camera, Some(0.0)), Convention::AppReversed);
        // Contradicted by more LESS than GREATER, or by standard projections only.
        let less = ConventionEvidence {
            less_compare_ops: 4,
            ..camera
        };
        assert_eq!(decide(less, Some(0.0)), Convention::Standard);
        let standard_camera = ConventionEvidence {
            standard_projection: true,
            ..greater
        };
        assert_eq!(decide(standard_camera, Some(0.0)), Convention::Standard);
        // Both kinds of projection (a reflection, a noisy far matrix) cancel out: the compare
        // ops decide.
        let mixed = ConventionEvidence {
            reversed_projection: true,
            standard_projection: true,
            ..greater
        };
        assert_eq!(decide(mixed, Some(0.0)), Convention::AppReversed);
        // Ties are not evidence.
        let tie = ConventionEvidence {
            greater_compare_ops: 2,
            less_compare_ops: 2,
            ..none
        };
        assert_eq!(decide(tie, Some(0.0)), Convention::Standard);
    }

    #[test]
    fn a_clear_to_0_before_anything_else_is_a_translated_reversed_application() {
        // What Zink (and DXVK with a cold pipeline cache) shows at its first clear: nothing
        // else.
        let none = ConventionEvidence::default();
        assert_eq!(none.decide(Some(0.0)), Convention::AppReversed);
        // Any other clear, or none, stays standard.
        for clear in [Some(1.0), Some(0.5), None] {
            assert_eq!(none.decide(clear), Convention::Standard, "{clear:?}");
        }
        // Anything seen that contradicts it, or that is a tie, keeps it standard.
        for seen in [
            ConventionEvidence {
                less_compare_ops: 1,
                ..none
            },
            ConventionEvidence {
                standard_projection: true,
                ..none
            },
            ConventionEvidence {
                greater_compare_ops: 1,
                less_compare_ops: 1,
                ..none
            },
        ] {
            assert_eq!(seen.decide(Some(0.0)), Convention::Standard, "{seen:?}");
        }
        // Decided so once, the device leaves its reversed images native.
        let observed = Observed::default();
        assert_eq!(
            observed.committed(Target::Reversed, Some(0.0)),
            Target::Native
        );
        assert_eq!(observed.convention(), Some(Convention::AppReversed));
    }

    #[test]
    fn racing_threads_agree_on_the_first_decision() {
        let observed = Observed::default();
        observed.note_pipeline_compare_op(vk::CompareOp::GREATER);
        let results: Vec<Convention> = std::thread::scope(|scope| {
            let handles: Vec<_> = (0..8)
                .map(|i| {
                    let observed = &observed;
                    scope.spawn(move || observed.settle((i % 2 == 0).then_some(0.0)))
                })
                .collect();
            handles
                .into_iter()
                .map(|h| h.join().expect("no panic"))
                .collect()
        });
        let first = observed.convention().expect("decided");
        assert!(results.iter().all(|&r| r == first), "{results:?}");
    }

    #[test]
    fn a_committed_reversed_image_decides_the_convention_with_its_clear() {
        let app_reversed = || {
            let observed = Observed::default();
            observed.note_pipeline_compare_op(vk::CompareOp::GREATER);
            observed
        };
        // Other images commit nothing.
        let observed = app_reversed();
        for image in [Target::None, Target::Native] {
            assert_eq!(observed.committed(image, Some(0.0)), image);
        }
        assert_eq!(observed.convention(), None);
        // A reversed image cleared to 0, with the evidence: the application's own.
        assert_eq!(
            observed.committed(Target::Reversed, Some(0.0)),
            Target::Native
        );
        assert_eq!(observed.convention(), Some(Convention::AppReversed));
        // Without its clear, the same evidence is standard, and stays so.
        let observed = app_reversed();
        assert_eq!(observed.committed(Target::Reversed, None), Target::Reversed);
        assert_eq!(
            observed.committed(Target::Reversed, Some(0.0)),
            Target::Reversed
        );
        assert_eq!(observed.convention(), Some(Convention::Standard));
    }
}
