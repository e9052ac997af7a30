//! What recordings teach each other about cameras (the precise path, `crate::precise`): each
//! recording classifies its projections against a copy of the device's cameras taken when it
//! begins; what it found or improved goes into the device's *pending* cameras when it ends, and
//! a queue submission makes the pending ones the cameras later recordings begin with.
//!
//! Why at a submission, not at the end of each recording: recordings of one frame (on several
//! threads, or one after the other) then all start from what the frames before taught, so a
//! frame's depths do not depend on which thread finished first, and every frame after the
//! first of a camera gets its best-conditioned matrix from the first draw on. One lock per
//! recording that found something, one per submission after such a recording: none per draw.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Mutex, PoisonError};

use ash::vk;
use revz_math::Cameras;

use super::command::with_entry;
use crate::boundary::{guarded, EntryPoint};
use crate::state::{DispatchKey, DEVICES};

/// A device's cameras: those recordings begin with, and those learned since the last
/// submission.
#[derive(Debug, Default)]
pub struct DeviceCameras {
    learned: Mutex<Cameras>,
    pending: Mutex<Cameras>,
    has_pending: AtomicBool,
    /// The cameras recordings met since the last submission that `learned` lacks, with the
    /// range each was first met with (`crate::precise::FirstSeen`).
    first_seen: std::sync::Arc<crate::precise::FirstSeen>,
}

impl DeviceCameras {
    /// The cameras a recording begins with.
    pub fn learned(&self) -> Cameras {
        self.learned
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .clone()
    }

    /// What recordings share of the cameras they meet before the next submission.
    pub fn first_seen(&self) -> std::sync::Arc<crate::precise::FirstSeen> {
        std::sync::Arc::clone(&self.first_seen)
    }

    /// A recording ended having found or improved `cameras`.
    pub fn end_recording(&self, cameras: &Cameras) {
        self.pending
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .merge(cameras);
        self.has_pending.store(true, Ordering::Release);
    }

    /// A submission: what recordings found becomes what the next ones begin with.
    pub fn submit(&self) {
        if !self.has_pending.swap(false, Ordering::AcqRel) {
            return;
        }
        let pending =
            std::mem::take(&mut *self.pending.lock().unwrap_or_else(PoisonError::into_inner));
        self.learned
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .merge(&pending);
        // The recordings begun from now on find those cameras in `learned`, with their best
        // lines' ranges.
        self.first_seen.clear();
    }
}

/// `vkEndCommandBuffer`.
pub unsafe extern "system" fn end_command_buffer(buffer: vk::CommandBuffer) -> vk::Result {
    static ENTRY: EntryPoint = EntryPoint::new("vkEndCommandBuffer");
    let device = with_entry(buffer, &ENTRY, |entry| {
        let cameras = entry.state().take_changed_cameras();
        if let Some(cameras) = cameras {
            entry.device.cameras.end_recording(&cameras);
        }
    });
    match device {
        // SAFETY: calling down with the application's arguments.
        Some(device) => unsafe { (device.next.fp_v1_0().end_command_buffer)(buffer) },
        None => vk::Result::ERROR_INITIALIZATION_FAILED,
    }
}

static QUEUE_SUBMIT: EntryPoint = EntryPoint::new("vkQueueSubmit");

/// The device of `queue` (a queue shares its device's dispatch key), with its cameras
/// promoted.
///
/// # Safety
/// `queue` is a live queue.
unsafe fn submitting(queue: vk::Queue) -> Option<std::sync::Arc<crate::state::DeviceState>> {
    // SAFETY: the caller's contract.
    let device = DEVICES.get(unsafe { DispatchKey::of(queue) })?;
    guarded(&QUEUE_SUBMIT, || device.cameras.submit(), || ());
    Some(device)
}

/// `vkQueueSubmit`.
pub unsafe extern "system" fn queue_submit(
    queue: vk::Queue,
    count: u32,
    p_submits: *const vk::SubmitInfo<'_>,
    fence: vk::Fence,
) -> vk::Result {
    // SAFETY: a live queue (the application's contract).
    match unsafe { submitting(queue) } {
        Some(device) => {
            profile_submit(&device, || {
                // SAFETY: `count` valid submit infos, each with its command buffers.
                let submits = unsafe { super::resources::slice(p_submits, count) };
                // SAFETY: each submit info's `commandBufferCount` command buffers.
                submits.iter().flat_map(|submit| unsafe {
                    super::resources::slice(submit.p_command_buffers, submit.command_buffer_count)
                        .iter()
                        .copied()
                })
            });
            // SAFETY: calling down with the application's arguments.
            unsafe { (device.next.fp_v1_0().queue_submit)(queue, count, p_submits, fence) }
        }
        None => vk::Result::ERROR_INITIALIZATION_FAILED,
    }
}

/// `vkQueuePresentKHR` (handed out only with a depth profile): the frame ends.
pub unsafe extern "system" fn queue_present(
    queue: vk::Queue,
    p_present_info: *const vk::PresentInfoKHR<'_>,
) -> vk::Result {
    static ENTRY: EntryPoint = EntryPoint::new("vkQueuePresentKHR");
    // SAFETY: a live queue shares its device's dispatch key.
    let Some(device) = DEVICES.get(unsafe { DispatchKey::of(queue) }) else {
        return vk::Result::ERROR_INITIALIZATION_FAILED;
    };
    if let Some(profile) = &device.profile {
        guarded(&ENTRY, || profile.present(), || ());
    }
    match device.commands.queue_present {
        // SAFETY: calling down with the application's arguments.
        Some(next) => unsafe { next(queue, p_present_info) },
        None => vk::Result::ERROR_INITIALIZATION_FAILED,
    }
}

/// Folds the draws of the submitted command buffers (`buffers` lists them: only read where
/// the device has a depth profile) into the profile, with the demotions since the last
/// submission.
fn profile_submit<I: Iterator<Item = vk::CommandBuffer>>(
    device: &crate::state::DeviceState,
    buffers: impl FnOnce() -> I,
) {
    let Some(profile) = &device.profile else {
        return;
    };
    guarded(
        &QUEUE_SUBMIT,
        || {
            for (image, reason) in device.objects.take_demotions() {
                profile.demote(image, reason.to_string());
            }
            if device.observed.convention() == Some(crate::policy::Convention::AppReversed) {
                profile.set_application_reversed();
            }
            let mut submission = crate::profile::Submission::default();
            let mut learned = None;
            for buffer in buffers() {
                if let Some(entry) = crate::objects::command_buffer(buffer) {
                    let state = entry.state();
                    submission.segments.extend(state.tally().segments());
                    // The recording's cameras are the device's by now (merged at its end or
                    // known at its begin): its counts go to the device's slot of each.
                    for (line, convention, count) in state.camera_matches() {
                        let learned = learned.get_or_insert_with(|| device.cameras.learned());
                        if let Some(slot) = learned.find(&line, convention) {
                            submission.camera_matches.push((slot, u64::from(count)));
                        }
                    }
                }
            }
            profile.submit(&submission, || camera_list(&device.cameras.learned()));
        },
        || (),
    );
}

/// The cameras for the profile: near, far, convention, direction, in the device's slots
/// (the profile adds how many matrices matched each slot). Only matrices revz reads on the
/// CPU (push constants) make cameras: a projection in a buffer is fitted per draw by the
/// vertex stage, and shows in the pipeline's `projection`.
pub(crate) fn camera_list(cameras: &Cameras) -> Vec<(usize, serde_json::Value)> {
    (0..revz_math::MAX_CAMERAS)
        .filter_map(|index| Some((index, cameras.camera(index)?)))
        .map(|(index, (range, direction, convention, _))| {
            (
                index,
                serde_json::json!({
                    "delivered": "push constants",
                    "near": range.near(),
                    "far": if range.is_infinite() { None } else { Some(range.far()) },
                    "convention": format!("{convention:?}"),
                    "direction": format!("{direction:?}"),
                }),
            )
        })
        .collect()
}

/// `vkQueueSubmit2` and `vkQueueSubmit2KHR`.
pub unsafe extern "system" fn queue_submit2(
    queue: vk::Queue,
    count: u32,
    p_submits: *const vk::SubmitInfo2<'_>,
    fence: vk::Fence,
) -> vk::Result {
    // SAFETY: a live queue (the application's contract).
    let device = unsafe { submitting(queue) };
    if let Some(device) = &device {
        profile_submit(device, || {
            // SAFETY: `count` valid submit infos, each with its command buffer infos.
            let submits = unsafe { super::resources::slice(p_submits, count) };
            // SAFETY: each submit info's `commandBufferInfoCount` infos.
            submits.iter().flat_map(|submit| unsafe {
                super::resources::slice(
                    submit.p_command_buffer_infos,
                    submit.command_buffer_info_count,
                )
                .iter()
                .map(|info| info.command_buffer)
            })
        });
    }
    let next = device.and_then(|device| device.commands.queue_submit2);
    match next {
        // SAFETY: calling down with the application's arguments.
        Some(next) => unsafe { next(queue, count, p_submits, fence) },
        None => vk::Result::ERROR_INITIALIZATION_FAILED,
    }
}

#[cfg(test)]
mod tests {
    use glam::dcamera::rh::proj::vulkan;
    use glam::{DMat4, DVec3};
    use revz_math::{CameraMatch, DepthConvention};

    use super::*;

    #[test]
    fn what_a_recording_found_is_seen_by_recordings_begun_after_the_next_submission() {
        let device = DeviceCameras::default();
        let mut recording = device.learned();
        let near = vulkan::perspective(1.0, 1.5, 0.1, 100.0)
            * DMat4::from_translation(DVec3::new(0.0, 0.0, -2.0));
        let found = recording.observe(&near, DepthConvention::ZeroToOne);
        assert!(matches!(found, CameraMatch::Camera { changed: true, .. }));
        device.end_recording(&recording);
        assert!(device.learned().is_empty(), "not before a submission");
        device.submit();
        assert_eq!(device.learned().len(), 1);
        // Nothing pending: a submission changes nothing.
        device.submit();
        assert_eq!(device.learned().len(), 1);
    }
}
