//! The precise path (`shared/DESIGN.md` sections 1 and 2): the push-constant bytes of one
//! command buffer, and the projection rewrite revz makes in them.
//!
//! A pipeline whose vertex stage multiplies a push-constant matrix into `Position` has a
//! [`ProjectionUse`] (found by [`crate::shader_analysis`] at shader module creation). For its
//! draws into a reversed attachment, the bytes of that matrix must hold the rewritten
//! projection when the draw executes, and every other byte the application's values.
//! [`PushConstants`] keeps the application's values (a shadow copy, so that updates covering
//! part of a matrix can be followed) and what the device holds:
//!
//! - in the common case (bind a pipeline, push its matrix, draw) the rewrite is made in the
//!   bytes `vkCmdPushConstants` passes down ([`PushConstants::push`]) and the draw costs a
//!   flag check;
//! - otherwise (the matrix pushed before its pipeline was bound or before the render pass began,
//!   a partial update, a pipeline without a projection reading bytes rewritten for another) the
//!   draw sends the difference first ([`PushConstants::resolve`]).
//!
//! Pure logic, no Vulkan calls: what must be pushed goes through a [`PushSink`].

use ash::vk;
use revz_math::{
    classify, read_clip_transform, reversed_depth_row, Classification, DepthConvention, Storage,
    Target as RewriteTarget,
};

use crate::shader_analysis::ProjectionSlot;

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
    /// The stage flags a `vkCmdPushConstants` of exactly the matrix's bytes must name: the
    /// stages of every push-constant range of the pipeline layout that overlaps them.
    pub stages: vk::ShaderStageFlags,
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
            stages: vk::ShaderStageFlags::empty(),
        };
        let stages = push_stages(ranges, use_.offset, use_.end()).ok_or(Unusable::Ranges)?;
        Ok(ProjectionUse { stages, ..use_ })
    }

    /// One past the last byte of the matrix.
    pub fn end(&self) -> u32 {
        self.offset + 3 * self.stride + 16
    }

    /// The 16 floats in storage order (vector by vector: one bounds check per vector on this
    /// per-push path; `end() <= PUSH_CONSTANT_BYTES` by construction).
    fn read(&self, bytes: &[u8; PUSH_CONSTANT_BYTES]) -> [f32; 16] {
        let mut values = [0.0; 16];
        for (vector, out) in values.chunks_exact_mut(4).enumerate() {
            let at = self.offset as usize + vector * self.stride as usize;
            let Some(stored) = bytes.get(at..at + 16) else {
                continue;
            };
            for (value, word) in out.iter_mut().zip(stored.chunks_exact(4)) {
                *value = f32::from_ne_bytes([word[0], word[1], word[2], word[3]]);
            }
        }
        values
    }

    /// Byte offset of entry (row 2, `column`) of the matrix: the depth row is all a rewrite
    /// changes.
    fn depth_entry(&self, column: usize) -> usize {
        let (offset, stride) = (self.offset as usize, self.stride as usize);
        match self.storage {
            Storage::ColumnMajor => offset + column * stride + 8,
            Storage::RowMajor => offset + 2 * stride + column * 4,
        }
    }

    /// Writes the depth row `row` into `out`, which holds push-constant bytes starting at byte
    /// `base`; entries outside `out` are skipped.
    fn write_depth_row(&self, row: &[f32; 4], out: &mut [u8], base: usize) {
        for (column, value) in row.iter().enumerate() {
            let Some(at) = self.depth_entry(column).checked_sub(base) else {
                continue;
            };
            if let Some(word) = out.get_mut(at..at + 4) {
                word.copy_from_slice(&value.to_ne_bytes());
            }
        }
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

/// What the current value of a projection slot is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Outcome {
    /// A standard perspective, rewritten: its new depth row (the other rows are unchanged).
    /// `near_over_far` is n / f of its visible range (0 for an infinite far plane).
    Rewritten {
        depth_row: [f32; 4],
        near_over_far: f32,
    },
    /// A projection the application already reversed.
    AlreadyReversed,
    /// Orthographic, or not a projection: the draw takes the flip path (for an affine matrix
    /// that is the exact reversal, `shared/DESIGN.md` section 2).
    Unchanged,
}

/// Classifies and rewrites one pushed matrix (f64 math in [`revz_math`]).
pub fn rewrite_projection(
    values: &[f32; 16],
    storage: Storage,
    convention: DepthConvention,
    target: RewriteTarget,
) -> Outcome {
    let m = read_clip_transform(values, storage);
    let classification = classify(&m, convention);
    match classification {
        Classification::Perspective { range, .. } => {
            // Only the depth row changes: the other twelve floats stay the application's.
            match reversed_depth_row(&m, &classification, target, convention) {
                Some(row) => Outcome::Rewritten {
                    // Each entry rounded once, to nearest.
                    depth_row: row.to_array().map(|entry| entry as f32),
                    near_over_far: (range.near() / range.far()) as f32,
                },
                None => Outcome::Unchanged,
            }
        }
        Classification::Reversed { .. } => Outcome::AlreadyReversed,
        Classification::Orthographic { .. } | Classification::NotProjection(_) => {
            Outcome::Unchanged
        }
    }
}

/// Where [`PushConstants::resolve`] sends push constants (the next layer, in production).
pub trait PushSink {
    fn push_constants(
        &mut self,
        layout: vk::PipelineLayout,
        stages: vk::ShaderStageFlags,
        offset: u32,
        bytes: &[u8],
    );
}

/// What the device holds, compared with the application's values.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Device {
    /// The application's values everywhere.
    Same,
    /// The rewrite of the application's current matrix at this slot; its values elsewhere.
    Rewritten(ProjectionUse),
    /// Something else at this slot's bytes (part of a rewrite, after a partial update); the
    /// application's values elsewhere.
    Stale(ProjectionUse),
}

/// The push-constant state of one command buffer while it records.
#[derive(Clone, Debug)]
pub struct PushConstants {
    /// The application's values.
    bytes: [u8; PUSH_CONSTANT_BYTES],
    /// Which 4-byte words of `bytes` the application has pushed since the recording began.
    written: u64,
    /// The layout of the application's last push (compatible with the bound pipeline's for
    /// push constants, or the application's draws would be invalid).
    layout: vk::PipelineLayout,
    device: Device,
    /// The last classification: its input (bits, storage, convention) and outcome. Consecutive
    /// draws often push the same projection.
    last: Option<([u32; 16], Storage, DepthConvention, Outcome)>,
}

impl Default for PushConstants {
    fn default() -> Self {
        PushConstants {
            bytes: [0; PUSH_CONSTANT_BYTES],
            written: 0,
            layout: vk::PipelineLayout::null(),
            device: Device::Same,
            last: None,
        }
    }
}

/// The 4-byte words `[start, end)` covers (both clamped to [`PUSH_CONSTANT_BYTES`]).
fn word_mask(start: usize, end: usize) -> u64 {
    let (first, last) = (start / 4, end.div_ceil(4).min(64));
    if first >= last {
        return 0;
    }
    let upper = if last == 64 {
        u64::MAX
    } else {
        (1u64 << last) - 1
    };
    upper & !((1u64 << first) - 1)
}

impl PushConstants {
    /// The outcome for `use_` on the current values, or `None` when the application has not
    /// pushed all of its bytes.
    pub fn outcome(&mut self, use_: &ProjectionUse, target: RewriteTarget) -> Option<Outcome> {
        let mask = word_mask(use_.offset as usize, use_.end() as usize);
        if self.written & mask != mask {
            return None;
        }
        let values = use_.read(&self.bytes);
        let bits = values.map(f32::to_bits);
        if let Some((last_bits, storage, convention, outcome)) = &self.last {
            if *last_bits == bits && *storage == use_.storage && *convention == use_.convention {
                return Some(*outcome);
            }
        }
        let outcome = rewrite_projection(&values, use_.storage, use_.convention, target);
        self.last = Some((bits, use_.storage, use_.convention, outcome));
        Some(outcome)
    }

    /// `vkCmdPushConstants` of `data` at `offset` with `layout`. `data` is the copy that goes
    /// down: when `bound` (the projection of the bound pipeline, if its draws would take the
    /// precise path now) lies wholly in it and rewrites, the rewrite is written into `data`.
    /// Returns the outcome applied in place, if any; `None` means the next draw must
    /// [`resolve`](Self::resolve).
    pub fn push(
        &mut self,
        layout: vk::PipelineLayout,
        offset: u32,
        data: &mut [u8],
        bound: Option<(&ProjectionUse, RewriteTarget)>,
    ) -> Option<Outcome> {
        self.layout = layout;
        let start = offset as usize;
        let end = start.saturating_add(data.len());
        if let Some(shadow) = self.bytes.get_mut(start..end.min(PUSH_CONSTANT_BYTES)) {
            shadow.copy_from_slice(&data[..shadow.len()]);
        }
        self.written |= word_mask(start, end);

        let overlaps = |u: &ProjectionUse| start < (u.end() as usize) && (u.offset as usize) < end;
        let covers = |u: &ProjectionUse| start <= (u.offset as usize) && (u.end() as usize) <= end;
        let in_place = bound.filter(|(u, _)| {
            covers(u)
                && match self.device {
                    Device::Same => true,
                    // One slot at most differs from the application's values: the one
                    // rewritten here, or one this push overwrites wholly.
                    Device::Rewritten(other) | Device::Stale(other) => {
                        other == **u || covers(&other)
                    }
                }
        });
        if let Some((use_, target)) = in_place {
            let outcome = self.outcome(use_, target)?;
            self.device = match outcome {
                Outcome::Rewritten { depth_row, .. } => {
                    use_.write_depth_row(&depth_row, data, start);
                    Device::Rewritten(*use_)
                }
                _ => Device::Same,
            };
            return Some(outcome);
        }
        self.device = match self.device {
            // The application's bytes now cover the whole slot.
            Device::Rewritten(u) | Device::Stale(u) if covers(&u) => Device::Same,
            Device::Rewritten(u) | Device::Stale(u) if overlaps(&u) => Device::Stale(u),
            other => other,
        };
        None
    }

    /// Before a draw whose state changed: makes the device hold the rewrite at `wanted` (the
    /// draw's projection, when it takes the precise path) and the application's values
    /// everywhere else. Returns the outcome for `wanted`.
    pub fn resolve(
        &mut self,
        wanted: Option<(&ProjectionUse, RewriteTarget)>,
        sink: &mut impl PushSink,
    ) -> Option<Outcome> {
        let outcome = wanted.and_then(|(use_, target)| Some((use_, self.outcome(use_, target)?)));
        let rewrite = match outcome {
            Some((use_, Outcome::Rewritten { depth_row, .. })) => Some((use_, depth_row)),
            _ => None,
        };
        if self.layout == vk::PipelineLayout::null() {
            return outcome.map(|(_, o)| o);
        }
        match (self.device, rewrite) {
            (Device::Rewritten(held), Some((use_, _))) if held == *use_ => {}
            (Device::Rewritten(held) | Device::Stale(held), rewrite) => {
                // Restore the application's bytes unless the rewrite below covers them.
                if rewrite.is_none_or(|(use_, _)| *use_ != held) {
                    self.send(&held, None, sink);
                }
                self.device = Device::Same;
                if let Some((use_, row)) = rewrite {
                    self.send(use_, Some(&row), sink);
                    self.device = Device::Rewritten(*use_);
                }
            }
            (Device::Same, Some((use_, row))) => {
                self.send(use_, Some(&row), sink);
                self.device = Device::Rewritten(*use_);
            }
            (Device::Same, None) => {}
        }
        outcome.map(|(_, o)| o)
    }

    /// Pushes the bytes of `use_`'s slot: the application's, with `row` as the depth row.
    fn send(&self, use_: &ProjectionUse, row: Option<&[f32; 4]>, sink: &mut impl PushSink) {
        let (start, end) = (use_.offset as usize, use_.end() as usize);
        let mut bytes = [0u8; PUSH_CONSTANT_BYTES];
        let out = &mut bytes[..end - start];
        out.copy_from_slice(&self.bytes[start..end]);
        if let Some(row) = row {
            use_.write_depth_row(row, out, start);
        }
        sink.push_constants(self.layout, use_.stages, use_.offset, out);
    }

    /// After `vkCmdExecuteCommands`, push constants are undefined again.
    pub fn invalidate(&mut self) {
        *self = PushConstants::default();
    }
}

#[cfg(test)]
mod tests {
    use ash::vk::Handle;
    use glam::dcamera::rh::{proj::vulkan, view::look_at_mat4};
    use glam::{DMat4, DVec3};

    use super::*;

    const VERTEX: vk::ShaderStageFlags = vk::ShaderStageFlags::VERTEX;

    fn column_major_at(offset: u32) -> ProjectionUse {
        ProjectionUse {
            offset,
            stride: 16,
            storage: Storage::ColumnMajor,
            convention: DepthConvention::ZeroToOne,
            stages: VERTEX,
        }
    }

    fn perspective() -> [f32; 16] {
        let view = look_at_mat4(DVec3::new(3.0, 2.0, 5.0), DVec3::ZERO, DVec3::Y);
        (vulkan::perspective(1.0, 1.5, 0.1, 100.0) * view)
            .as_mat4()
            .to_cols_array()
    }

    fn bytes_of(values: &[f32]) -> Vec<u8> {
        values.iter().flat_map(|v| v.to_ne_bytes()).collect()
    }

    fn floats_of(bytes: &[u8]) -> Vec<f32> {
        bytes
            .chunks_exact(4)
            .map(|c| f32::from_ne_bytes([c[0], c[1], c[2], c[3]]))
            .collect()
    }

    #[derive(Default)]
    struct Pushes(Vec<(u32, Vec<f32>)>);

    impl PushSink for Pushes {
        fn push_constants(
            &mut self,
            _: vk::PipelineLayout,
            stages: vk::ShaderStageFlags,
            offset: u32,
            bytes: &[u8],
        ) {
            assert_eq!(stages, VERTEX);
            self.0.push((offset, floats_of(bytes)));
        }
    }

    fn layout() -> vk::PipelineLayout {
        vk::PipelineLayout::from_raw(7)
    }

    /// `values` (column-major) with the depth row rewritten to complementary Z.
    fn rewritten(values: &[f32; 16]) -> [f32; 16] {
        match rewrite_projection(
            values,
            Storage::ColumnMajor,
            DepthConvention::ZeroToOne,
            RewriteTarget::Complementary,
        ) {
            Outcome::Rewritten { depth_row, .. } => {
                let mut out = *values;
                for (column, entry) in depth_row.into_iter().enumerate() {
                    out[4 * column + 2] = entry;
                }
                out
            }
            other => panic!("not rewritten: {other:?}"),
        }
    }

    #[test]
    fn a_push_covering_the_bound_projection_is_rewritten_in_place() {
        let use_ = column_major_at(64);
        let matrix = perspective();
        let mut push = PushConstants::default();
        let mut data = bytes_of(&[[1.0; 16], matrix].concat());
        let outcome = push.push(
            layout(),
            0,
            &mut data,
            Some((&use_, RewriteTarget::Complementary)),
        );
        assert!(matches!(outcome, Some(Outcome::Rewritten { .. })));
        let sent = floats_of(&data);
        assert_eq!(
            sent[..16],
            [1.0; 16],
            "bytes outside the slot are the app's"
        );
        assert_eq!(sent[16..], rewritten(&matrix));
        // The draw then has nothing to send.
        let mut sink = Pushes::default();
        push.resolve(Some((&use_, RewriteTarget::Complementary)), &mut sink);
        assert!(sink.0.is_empty());
    }

    #[test]
    fn a_matrix_pushed_before_its_pipeline_is_rewritten_at_the_draw() {
        let use_ = column_major_at(0);
        let matrix = perspective();
        let mut push = PushConstants::default();
        let mut data = bytes_of(&matrix);
        assert_eq!(push.push(layout(), 0, &mut data, None), None);
        assert_eq!(floats_of(&data), matrix, "passed down as the app gave it");
        let mut sink = Pushes::default();
        push.resolve(Some((&use_, RewriteTarget::Complementary)), &mut sink);
        assert_eq!(sink.0, vec![(0, rewritten(&matrix).to_vec())]);
        // A draw of a pipeline without a projection gets the application's bytes back.
        push.resolve(None, &mut sink);
        assert_eq!(sink.0[1], (0, matrix.to_vec()));
        push.resolve(None, &mut sink);
        assert_eq!(sink.0.len(), 2, "nothing more to restore");
    }

    #[test]
    fn partial_updates_are_followed_through_the_shadow_copy() {
        let use_ = column_major_at(0);
        let bound = Some((&use_, RewriteTarget::Complementary));
        let mut push = PushConstants::default();
        let first = perspective();
        push.push(layout(), 0, &mut bytes_of(&first), bound);
        // Only the translation column changes: bytes 48..64.
        let mut second = first;
        second[12..].copy_from_slice(&[0.5, -0.25, 4.0, 6.0]);
        let mut data = bytes_of(&second[12..]);
        assert_eq!(push.push(layout(), 48, &mut data, bound), None);
        assert_eq!(
            floats_of(&data),
            second[12..],
            "a partial push passes as is"
        );
        let mut sink = Pushes::default();
        push.resolve(bound, &mut sink);
        assert_eq!(sink.0, vec![(0, rewritten(&second).to_vec())]);
    }

    #[test]
    fn unpushed_or_unclassifiable_matrices_take_the_flip_path() {
        let use_ = column_major_at(0);
        let bound = Some((&use_, RewriteTarget::Infinite));
        let mut push = PushConstants::default();
        let mut sink = Pushes::default();
        assert_eq!(push.resolve(bound, &mut sink), None, "nothing pushed yet");
        let mut half = bytes_of(&perspective()[..8]);
        assert_eq!(push.push(layout(), 0, &mut half, bound), None);
        assert_eq!(push.resolve(bound, &mut sink), None, "half a matrix");
        let identity = DMat4::IDENTITY.as_mat4().to_cols_array();
        let mut data = bytes_of(&identity);
        assert_eq!(
            push.push(layout(), 0, &mut data, bound),
            Some(Outcome::Unchanged)
        );
        assert_eq!(floats_of(&data), identity);
        assert!(sink.0.is_empty());
    }

    #[test]
    fn already_reversed_projections_are_reported_and_left_alone() {
        let reversed = vulkan::perspective_infinite_reverse(1.0, 1.5, 0.1)
            .as_mat4()
            .to_cols_array();
        let use_ = column_major_at(0);
        let mut push = PushConstants::default();
        let mut data = bytes_of(&reversed);
        let outcome = push.push(
            layout(),
            0,
            &mut data,
            Some((&use_, RewriteTarget::Complementary)),
        );
        assert_eq!(outcome, Some(Outcome::AlreadyReversed));
        assert_eq!(floats_of(&data), reversed);
    }

    #[test]
    fn strided_row_major_slots_are_read_and_written_in_their_layout() {
        // A row-major matrix with 32-byte row stride (std430 would not do this, but a
        // MatrixStride decoration may): rows at 16, 48, 80, 112.
        let use_ = ProjectionUse {
            offset: 16,
            stride: 32,
            storage: Storage::RowMajor,
            ..column_major_at(0)
        };
        assert_eq!(use_.end(), 128);
        let matrix = DMat4::from_cols_array(&perspective().map(f64::from)).transpose();
        let rows = matrix.to_cols_array().map(|v| v as f32);
        let mut block = [9.0f32; 32];
        for row in 0..4 {
            block[4 + row * 8..8 + row * 8].copy_from_slice(&rows[row * 4..row * 4 + 4]);
        }
        let mut data = bytes_of(&block);
        let bound = Some((&use_, RewriteTarget::Complementary));
        let mut push = PushConstants::default();
        assert!(matches!(
            push.push(layout(), 0, &mut data, bound),
            Some(Outcome::Rewritten { .. })
        ));
        let sent = floats_of(&data);
        for (i, value) in sent.iter().enumerate() {
            let in_slot = i >= 4 && (i - 4) % 8 < 4;
            if !in_slot {
                assert_eq!(*value, 9.0, "padding at float {i} untouched");
            }
        }
        // Depth row (row 2) changed, the others did not.
        assert_eq!(sent[4..8], rows[0..4]);
        assert_ne!(sent[20..24], rows[8..12]);
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
    fn only_the_depth_row_is_rewritten_and_exactly_as_the_full_rewrite() {
        for storage in [Storage::ColumnMajor, Storage::RowMajor] {
            let columns = perspective();
            let matrix = match storage {
                Storage::ColumnMajor => columns,
                Storage::RowMajor => glam::Mat4::from_cols_array(&columns)
                    .transpose()
                    .to_cols_array(),
            };
            for target in [RewriteTarget::Complementary, RewriteTarget::Infinite] {
                let m = read_clip_transform(&matrix, storage);
                let classification = classify(&m, DepthConvention::ZeroToOne);
                let full = revz_math::rewrite(&m, &classification, target).expect("a perspective");
                let expected = revz_math::write_clip_transform(&full, storage);
                let Outcome::Rewritten { depth_row, .. } =
                    rewrite_projection(&matrix, storage, DepthConvention::ZeroToOne, target)
                else {
                    panic!("not rewritten");
                };
                let use_ = ProjectionUse {
                    storage,
                    ..column_major_at(0)
                };
                let mut bytes = bytes_of(&matrix);
                use_.write_depth_row(&depth_row, &mut bytes, 0);
                assert_eq!(floats_of(&bytes), expected, "{storage:?} {target:?}");
            }
        }
    }

    #[test]
    fn word_masks() {
        assert_eq!(word_mask(0, 4), 1);
        assert_eq!(word_mask(4, 12), 0b110);
        assert_eq!(word_mask(0, 256), u64::MAX);
        assert_eq!(word_mask(0, 10_000), u64::MAX);
        assert_eq!(word_mask(300, 400), 0);
        assert_eq!(word_mask(2, 5), 0b11);
    }
}
