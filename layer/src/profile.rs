//! The depth profile (issue #19): what revz did in one process and device, as a JSON document
//! a person or a script reads to tell whether revz helped, written where the `report` setting
//! says (`REVZ_REPORT=<file or directory>`).
//!
//! This module owns the document and its file: what is recorded (the application, the
//! settings in force and where each came from, every depth image and the policy's decision,
//! every depth-testing pipeline and the path its draws take, the cameras, the draws per path
//! per frame), and when it is written: at every frame boundary at most every
//! [`WRITE_INTERVAL`], and when the device is destroyed, each time to a temporary file renamed
//! over the report, so a killed application leaves the last complete one.
//!
//! Cost: images and pipelines are recorded where revz already decides about them (creation),
//! draws are counted per command buffer ([`DrawTally`]: one add per draw; the count is filed
//! under its depth image and pipeline where either changes, at binds and pass begins) and
//! folded into the frame at `vkQueueSubmit`, under this module's one lock, taken per
//! submission, per object creation and per converted copy, never per draw. Cameras count the
//! matrices each recording classified as theirs (`crate::precise::PushConstants::matches`),
//! mapped to the device's camera slots at the submission. Draws are only seen at all where a
//! profile is kept: otherwise `vkCmdDraw*` are the next layer's own.

use std::collections::{HashMap, VecDeque};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU32, Ordering};
use std::sync::{Mutex, PoisonError};
use std::time::{Duration, Instant};

use ash::vk;
use serde_json::{json, Value};

use crate::config::{Settings, SETTINGS};

/// How often a running application's report is rewritten, at most.
pub const WRITE_INTERVAL: Duration = Duration::from_secs(2);
/// Frames kept in the document's `frames` list (the totals count all).
pub const FRAMES_KEPT: usize = 64;
/// Images and pipelines kept (an application creating more has its first ones listed, and the
/// counts of all).
pub const OBJECTS_KEPT: usize = 4096;

/// Draw commands recorded per path (`crate::command_state::DrawPath`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DrawCounts {
    /// Into native attachments, or outside a depth attachment.
    pub native: u64,
    pub flip: u64,
    pub precise: u64,
}

impl DrawCounts {
    pub fn add(&mut self, other: &DrawCounts) {
        self.native += other.native;
        self.flip += other.flip;
        self.precise += other.precise;
    }

    pub fn total(&self) -> u64 {
        self.native + self.flip + self.precise
    }

    fn json(&self) -> Value {
        json!({"native": self.native, "flip": self.flip, "precise": self.precise})
    }
}

/// The path of one draw command (`crate::command_state::DrawPath` names them for the state
/// machine; the profile only counts).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DrawnPath {
    Native,
    Flip,
    Precise,
}

impl DrawCounts {
    #[inline]
    pub fn count(&mut self, path: DrawnPath) {
        let counter = match path {
            DrawnPath::Native => &mut self.native,
            DrawnPath::Flip => &mut self.flip,
            DrawnPath::Precise => &mut self.precise,
        };
        *counter += 1;
    }
}

/// Draws of one command buffer with the depth image and the pipeline they were recorded with
/// (raw handles; 0: none, or not known where recorded, as in a secondary without a
/// framebuffer).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Segment {
    pub image: u64,
    pub pipeline: u64,
    pub draws: DrawCounts,
}

/// Distinct (image, pipeline) pairs one command buffer keeps apart; draws of further pairs go
/// to the pair (0, 0), so a recording never grows without bound.
const SEGMENTS_KEPT: usize = 256;

/// The draws of one command buffer, in total and per (depth image, pipeline): one add per
/// draw; the keys change at binds and pass begins, where the open count is filed (a search
/// of the few pairs this recording has).
#[derive(Clone, Debug, Default)]
pub struct DrawTally {
    totals: DrawCounts,
    open: DrawCounts,
    image: u64,
    pipeline: u64,
    segments: Vec<Segment>,
}

impl DrawTally {
    #[inline]
    pub fn count(&mut self, path: DrawnPath) {
        self.totals.count(path);
        self.open.count(path);
    }

    pub fn totals(&self) -> DrawCounts {
        self.totals
    }

    /// The depth image draws go to from now on.
    pub fn set_image(&mut self, image: u64) {
        if image != self.image {
            self.file();
            self.image = image;
        }
    }

    /// The pipeline (or vertex shader object) draws use from now on.
    pub fn set_pipeline(&mut self, pipeline: u64) {
        if pipeline != self.pipeline {
            self.file();
            self.pipeline = pipeline;
        }
    }

    fn file(&mut self) {
        if self.open.total() == 0 {
            return;
        }
        let open = std::mem::take(&mut self.open);
        self.add_segment(self.image, self.pipeline, &open);
    }

    fn add_segment(&mut self, image: u64, pipeline: u64, draws: &DrawCounts) {
        let at = |segments: &[Segment], key: (u64, u64)| {
            segments.iter().position(|s| (s.image, s.pipeline) == key)
        };
        let mut key = (image, pipeline);
        if at(&self.segments, key).is_none() && self.segments.len() >= SEGMENTS_KEPT {
            key = (0, 0);
        }
        match at(&self.segments, key) {
            Some(index) => self.segments[index].draws.add(draws),
            None => self.segments.push(Segment {
                image: key.0,
                pipeline: key.1,
                draws: *draws,
            }),
        }
    }

    /// Every (image, pipeline) pair with its draws, the open one included.
    pub fn segments(&self) -> impl Iterator<Item = Segment> + '_ {
        let open = (self.open.total() > 0).then_some(Segment {
            image: self.image,
            pipeline: self.pipeline,
            draws: self.open,
        });
        self.segments.iter().copied().chain(open)
    }

    /// `vkCmdExecuteCommands` of a secondary that recorded `executed`: its draws are this
    /// command buffer's, into the image this one renders to where the secondary did not know
    /// its own.
    pub fn add_executed(&mut self, executed: &DrawTally) {
        self.file();
        self.totals.add(&executed.totals);
        for segment in executed.segments() {
            let image = if segment.image == 0 {
                self.image
            } else {
                segment.image
            };
            self.add_segment(image, segment.pipeline, &segment.draws);
        }
    }
}

/// One depth image as the policy decided it.
#[derive(Clone, Debug)]
pub struct ImageRecord {
    pub format: vk::Format,
    pub promoted: Option<vk::Format>,
    pub extent: vk::Extent3D,
    pub samples: vk::SampleCountFlags,
    pub usage: vk::ImageUsageFlags,
    /// `None`: reversed; else why it stays native.
    pub native_because: Option<String>,
    /// The frame in which a reversed image became native (a resolve from or into a native
    /// image), if it did.
    pub demoted_in_frame: Option<u64>,
    /// Shaders read it through a read twin (issue #39).
    pub read_twin: bool,
}

/// One depth-testing pipeline and its path.
#[derive(Clone, Debug)]
pub struct PipelineRecord {
    /// `pipeline`, or `vertex shader object` (`tessellation evaluation`, `geometry`, `mesh`:
    /// `VK_EXT_shader_object`, whose draws are counted under the last pre-rasterization
    /// stage's shader bound).
    pub kind: &'static str,
    /// `precise`, `flip` (reversed draws), with why; `none` for a pipeline that renders no
    /// depth, listed for the depth it reads through input attachments.
    pub path: &'static str,
    /// Where its projection comes from: push-constant bytes, a buffer the stage fits from, or
    /// why neither.
    pub projection: String,
    pub reversed_variant: bool,
    pub promoted_variant: bool,
    /// Its fragment shader reads depth through input attachments, and its variants convert
    /// what it reads (`crate::shader::input_depth`).
    pub converts_depth_inputs: bool,
}

#[derive(Debug, Default)]
struct Inner {
    images: Vec<(u64, ImageRecord)>,
    image_count: u64,
    pipelines: Vec<(u64, PipelineRecord)>,
    pipeline_count: u64,
    /// The open frame's draws; frames close at `vkQueuePresentKHR`, or at each submission of
    /// an application that never presents.
    current: DrawCounts,
    /// The open frame's draws per depth image (raw handle; 0: none).
    current_by_image: Vec<(u64, DrawCounts)>,
    frames: VecDeque<Frame>,
    frame_index: u64,
    totals: DrawCounts,
    /// All draws per depth image and per pipeline (or vertex shader object).
    by_image: HashMap<u64, DrawCounts>,
    by_pipeline: HashMap<u64, DrawCounts>,
    submissions: u64,
    presents: bool,
    last_write: Option<Instant>,
    /// The device's cameras as last asked, each with its slot.
    cameras: Vec<(usize, Value)>,
    /// Matrices matched per camera slot.
    camera_matches: [u64; revz_math::MAX_CAMERAS],
    /// Copy commands between a reversed and a standard end recorded, converted and sent
    /// down unconverted (why: in `warnings`).
    copies_converted: u64,
    copies_unconverted: u64,
    /// Read twin refreshes recorded per image (raw handle): how many, and the bytes each
    /// copied (texels of the stored format over the refreshed subresources); and those that
    /// could not be recorded.
    refreshes: HashMap<u64, (u64, u64)>,
    refreshes_failed: u64,
    /// The device found the application already renders reversed depth: revz leaves every
    /// attachment alone (`crate::policy::Observed`).
    application_reversed: bool,
}

/// Why an image the policy would reverse is native once the application is found to render
/// reversed depth itself.
const APPLICATION_REVERSED: &str =
    "the application already renders reversed depth (cleared to 0, GREATER): revz leaves it alone";

/// What one `vkQueueSubmit` recorded, for [`Profile::submit`].
#[derive(Debug, Default)]
pub struct Submission {
    /// Per (depth image, pipeline), from every command buffer.
    pub segments: Vec<Segment>,
    /// (the device's camera slot, matrices matched) from every command buffer.
    pub camera_matches: Vec<(usize, u64)>,
}

/// One closed frame.
#[derive(Debug)]
struct Frame {
    index: u64,
    draws: DrawCounts,
    by_image: Vec<(u64, DrawCounts)>,
}

/// The profile of one device.
#[derive(Debug)]
pub struct Profile {
    path: PathBuf,
    header: Value,
    inner: Mutex<Inner>,
}

/// Devices of this process with a profile, to name their files apart.
static DEVICES: AtomicU32 = AtomicU32::new(0);

impl Profile {
    /// The profile of a device created with `settings` by the application `application`
    /// (`VkApplicationInfo` names, API version), written to `report` (a directory: a file
    /// named after the executable, the process and the device in it).
    pub fn new(
        report: &Path,
        application: Value,
        settings: &Settings,
        origins: &[(crate::config::Key, String)],
    ) -> Profile {
        let device = DEVICES.fetch_add(1, Ordering::Relaxed);
        let is_dir = report.is_dir() || report.as_os_str().to_string_lossy().ends_with('/');
        let path = if is_dir {
            let executable = std::env::current_exe()
                .ok()
                .and_then(|p| p.file_stem().map(|s| s.to_string_lossy().into_owned()))
                .unwrap_or_else(|| "application".to_owned());
            report.join(format!(
                "revz-{executable}-{}-{device}.json",
                std::process::id()
            ))
        } else if device == 0 {
            report.to_path_buf()
        } else {
            let mut name = report.as_os_str().to_owned();
            name.push(format!(".{device}"));
            PathBuf::from(name)
        };
        let settings: Vec<Value> = SETTINGS
            .iter()
            .map(|spec| {
                let value = settings.describe(spec.key);
                let origin = origins
                    .iter()
                    .find(|(key, _)| *key == spec.key)
                    .map_or("default", |(_, origin)| origin);
                json!({"name": spec.name, "value": value, "from": origin})
            })
            .collect();
        Profile {
            path,
            header: json!({
                "revz": env!("CARGO_PKG_VERSION"),
                "process": std::process::id(),
                "application": application,
                "settings": settings,
            }),
            inner: Mutex::new(Inner::default()),
        }
    }

    /// Where the report is written.
    pub fn path(&self) -> &Path {
        &self.path
    }

    fn inner(&self) -> std::sync::MutexGuard<'_, Inner> {
        self.inner.lock().unwrap_or_else(PoisonError::into_inner)
    }

    pub fn image(&self, image: vk::Image, record: ImageRecord) {
        let mut inner = self.inner();
        inner.image_count += 1;
        if inner.images.len() < OBJECTS_KEPT {
            inner.images.push((vk::Handle::as_raw(image), record));
        }
    }

    /// A depth-testing pipeline, or a vertex shader object (raw handle).
    pub fn pipeline(&self, pipeline: u64, record: PipelineRecord) {
        let mut inner = self.inner();
        inner.pipeline_count += 1;
        if inner.pipelines.len() < OBJECTS_KEPT {
            inner.pipelines.push((pipeline, record));
        }
    }

    /// A reversed image became native (`because`), in the frame open now.
    pub fn demote(&self, image: vk::Image, because: String) {
        let mut inner = self.inner();
        let frame = inner.frame_index;
        let raw = vk::Handle::as_raw(image);
        if let Some((_, record)) = inner.images.iter_mut().rev().find(|(h, _)| *h == raw) {
            record.native_because = Some(because);
            record.demoted_in_frame = Some(frame);
        }
    }

    /// A submission of command buffers that recorded `draws`, with the device's cameras as
    /// they are now; writes the report if it is due.
    pub fn submit(&self, submission: &Submission, cameras: impl FnOnce() -> Vec<(usize, Value)>) {
        let due = {
            let mut inner = self.inner();
            // Every draw of a recording is in one of its segments.
            let mut draws = DrawCounts::default();
            for segment in &submission.segments {
                draws.add(&segment.draws);
            }
            inner.current.add(&draws);
            inner.totals.add(&draws);
            for &(slot, count) in &submission.camera_matches {
                if let Some(total) = inner.camera_matches.get_mut(slot) {
                    *total += count;
                }
            }
            for segment in &submission.segments {
                inner
                    .by_image
                    .entry(segment.image)
                    .or_default()
                    .add(&segment.draws);
                inner
                    .by_pipeline
                    .entry(segment.pipeline)
                    .or_default()
                    .add(&segment.draws);
                match inner
                    .current_by_image
                    .iter_mut()
                    .find(|(image, _)| *image == segment.image)
                {
                    Some((_, counts)) => counts.add(&segment.draws),
                    None => inner.current_by_image.push((segment.image, segment.draws)),
                }
            }
            inner.submissions += 1;
            if !inner.presents {
                inner.close_frame();
            }
            let due = inner
                .last_write
                .is_none_or(|at| at.elapsed() >= WRITE_INTERVAL);
            if due {
                inner.cameras = cameras();
            }
            due
        };
        if due {
            self.write();
        }
    }

    /// A copy command between a reversed and a standard end was recorded, converted or not
    /// (`crate::depth_copy`).
    pub fn copy(&self, converted: bool) {
        let mut inner = self.inner();
        if converted {
            inner.copies_converted += 1;
        } else {
            inner.copies_unconverted += 1;
        }
    }

    /// A read twin refresh of `image` was recorded (`bytes` copied), or could not be
    /// (`None`).
    pub fn refresh(&self, image: vk::Image, bytes: Option<u64>) {
        let mut inner = self.inner();
        match bytes {
            Some(bytes) => {
                let entry = inner
                    .refreshes
                    .entry(vk::Handle::as_raw(image))
                    .or_default();
                entry.0 += 1;
                entry.1 += bytes;
            }
            None => inner.refreshes_failed += 1,
        }
    }

    /// The application was found to render reversed depth itself.
    pub fn set_application_reversed(&self) {
        self.inner().application_reversed = true;
    }

    /// The device's cameras, for the next write.
    pub fn set_cameras(&self, cameras: Vec<(usize, Value)>) {
        self.inner().cameras = cameras;
    }

    /// `vkQueuePresentKHR`: the frame ends.
    pub fn present(&self) {
        let mut inner = self.inner();
        inner.presents = true;
        inner.close_frame();
    }

    /// The document as it stands.
    pub fn document(&self) -> Value {
        let inner = self.inner();
        let images: Vec<Value> = inner
            .images
            .iter()
            .map(|(handle, r)| {
                let native_because = inner.native_because(r);
                json!({
                    "handle": handle_name(*handle),
                    "format": format!("{:?}", r.format),
                    "promoted_format": r.promoted.map(|f| format!("{f:?}")),
                    "width": r.extent.width,
                    "height": r.extent.height,
                    "samples": r.samples.as_raw(),
                    "usage": format!("{:?}", r.usage),
                    "depth": if native_because.is_none() { "reversed" } else { "native" },
                    "reason": native_because,
                    "demoted_in_frame": r.demoted_in_frame,
                    "read_twin": r.read_twin,
                    "refreshes_recorded": inner.refreshes.get(handle).map_or(0, |r| r.0),
                    "bytes_refreshed": inner.refreshes.get(handle).map_or(0, |r| r.1),
                    "draws": inner.by_image.get(handle).copied().unwrap_or_default().json(),
                })
            })
            .collect();
        let pipelines: Vec<Value> = inner
            .pipelines
            .iter()
            .map(|(handle, r)| {
                json!({
                    "handle": handle_name(*handle),
                    "kind": r.kind,
                    "path": r.path,
                    "projection": r.projection,
                    "reversed_variant": r.reversed_variant,
                    "promoted_variant": r.promoted_variant,
                    "converts_depth_inputs": r.converts_depth_inputs,
                    "draws": inner.by_pipeline.get(handle).copied().unwrap_or_default().json(),
                })
            })
            .collect();
        let mut by_path: HashMap<&str, usize> = HashMap::new();
        for (_, r) in &inner.pipelines {
            *by_path.entry(r.path).or_default() += 1;
        }
        let frames: Vec<Value> = inner
            .frames
            .iter()
            .map(|frame| {
                let by_image: Vec<Value> = frame
                    .by_image
                    .iter()
                    .map(|(image, d)| json!({"image": handle_name(*image), "draws": d.json()}))
                    .collect();
                json!({
                    "frame": frame.index,
                    "draws": frame.draws.json(),
                    "precise_fraction_of_reversed": precise_fraction(&frame.draws),
                    "by_image": by_image,
                })
            })
            .collect();
        let outside_images = inner.by_image.get(&0).copied().unwrap_or_default();
        let mut document = self.header.clone();
        let object = document.as_object_mut().expect("the header is an object");
        object.insert("images".into(), Value::Array(images));
        object.insert("image_count".into(), json!(inner.image_count));
        object.insert("pipelines".into(), Value::Array(pipelines));
        object.insert("pipeline_count".into(), json!(inner.pipeline_count));
        let cameras: Vec<Value> = inner
            .cameras
            .iter()
            .map(|(slot, camera)| {
                let mut camera = camera.clone();
                if let Some(fields) = camera.as_object_mut() {
                    let matched = inner.camera_matches.get(*slot).copied().unwrap_or(0);
                    fields.insert("matrices_matched".into(), json!(matched));
                }
                camera
            })
            .collect();
        object.insert("cameras".into(), Value::Array(cameras));
        object.insert("frames".into(), Value::Array(frames));
        object.insert(
            "totals".into(),
            json!({
                "frames": inner.frame_index,
                "submissions": inner.submissions,
                "draws": inner.totals.json(),
                "draws_without_depth_image": outside_images.json(),
                "copies_recorded": {
                    "converted": inner.copies_converted,
                    "unconverted": inner.copies_unconverted,
                },
                "read_twin_refreshes_recorded": {
                    "recorded": inner.refreshes.values().map(|r| r.0).sum::<u64>(),
                    "bytes": inner.refreshes.values().map(|r| r.1).sum::<u64>(),
                    "failed": inner.refreshes_failed,
                },
                "precise_fraction_of_reversed": precise_fraction(&inner.totals),
                "flip_reasons": flip_reasons(&inner)
                    .iter()
                    .map(|r| json!({
                        "reason": r.reason,
                        "pipelines": r.pipelines,
                        "draws": r.draws,
                        "fraction_of_draws": r.draws as f64 / inner.totals.total().max(1) as f64,
                    }))
                    .collect::<Vec<Value>>(),
            }),
        );
        let mode = self.header["settings"]
            .as_array()
            .and_then(|settings| settings.iter().find(|s| s["name"] == "mode"))
            .and_then(|s| s["value"].as_str())
            .unwrap_or("?")
            .to_owned();
        object.insert("summary".into(), json!(summary(&inner, &mode)));
        let warnings: Vec<Value> = crate::logging::warnings()
            .into_iter()
            .map(|(message, count)| json!({"message": message, "count": count}))
            .collect();
        object.insert("warnings".into(), Value::Array(warnings));
        document
    }

    /// Writes the report now (atomically: a temporary file renamed over it). A failure is
    /// logged once and never reaches the application.
    pub fn write(&self) {
        let text = match serde_json::to_string_pretty(&self.document()) {
            Ok(text) => text,
            Err(_) => return,
        };
        self.inner().last_write = Some(Instant::now());
        let mut temporary = self.path.as_os_str().to_owned();
        temporary.push(".tmp");
        let temporary = PathBuf::from(temporary);
        let written =
            std::fs::write(&temporary, text).and_then(|()| std::fs::rename(&temporary, &self.path));
        if let Err(err) = written {
            static FAILED: crate::logging::LogOnce = crate::logging::LogOnce::new();
            FAILED.log(|| {
                log::warn!(
                    "report {}: cannot be written ({err}); no profile is kept",
                    self.path.display()
                )
            });
        }
    }
}

impl Inner {
    /// Why `image` is native as revz treats it now (`None`: reversed).
    fn native_because<'a>(&self, image: &'a ImageRecord) -> Option<&'a str> {
        match &image.native_because {
            Some(reason) => Some(reason),
            None if self.application_reversed => Some(APPLICATION_REVERSED),
            None => None,
        }
    }

    fn close_frame(&mut self) {
        let draws = std::mem::take(&mut self.current);
        let by_image = std::mem::take(&mut self.current_by_image);
        self.frames.push_back(Frame {
            index: self.frame_index,
            draws,
            by_image,
        });
        self.frame_index += 1;
        while self.frames.len() > FRAMES_KEPT {
            self.frames.pop_front();
        }
    }
}

/// A raw handle as the document names it (`none` for 0).
fn handle_name(handle: u64) -> String {
    if handle == 0 {
        "none".to_owned()
    } else {
        format!("{handle:#x}")
    }
}

/// The fraction of draws into reversed attachments that took the precise path (`None`: no such
/// draw).
fn precise_fraction(d: &DrawCounts) -> Option<f64> {
    let reversed = d.flip + d.precise;
    (reversed > 0).then(|| d.precise as f64 / reversed as f64)
}

/// `value` to 3 significant digits, without trailing zeros (0.1, 0.00125, 2.5e-7 as 0).
fn significant(value: f64) -> String {
    let digits = (3 - value.abs().log10().ceil() as i32).clamp(0, 12) as usize;
    let text = format!("{value:.digits$}");
    if text.contains('.') {
        text.trim_end_matches('0').trim_end_matches('.').to_owned()
    } else {
        text
    }
}

/// Why draws into reversed attachments took the flip path: one reason of the flip pipelines,
/// or the draws of precise pipelines sent to the flip path one by one.
#[derive(Debug, PartialEq)]
struct FlipReason<'a> {
    reason: &'a str,
    /// Pipelines (or vertex shader objects) that take the flip path for this reason.
    pipelines: usize,
    /// Their draws into reversed attachments.
    draws: u64,
}

/// What precise pipelines' draws that took the flip path have in common.
const PER_DRAW_FLIPS: &str = "draws of precise pipelines sent to the flip path (a matrix \
    revz cannot trust, a depth clamp enabled, viewports a secondary inherits, a shader object \
    projecting gl_in bound after one whose w = 1 is not shown)";

/// The flip path's draws by reason, most draws first (the profile's `flip_reasons` and the
/// summary's shares: what would help most). A reason whose pipelines drew nothing is kept,
/// with 0 draws.
fn flip_reasons(inner: &Inner) -> Vec<FlipReason<'_>> {
    let mut reasons: Vec<FlipReason<'_>> = Vec::new();
    let mut by_flip_pipelines = 0;
    for (handle, record) in &inner.pipelines {
        if record.path != "flip" {
            continue;
        }
        let draws = inner.by_pipeline.get(handle).map_or(0, |d| d.flip);
        by_flip_pipelines += draws;
        match reasons.iter_mut().find(|r| r.reason == record.projection) {
            Some(reason) => {
                reason.pipelines += 1;
                reason.draws += draws;
            }
            None => reasons.push(FlipReason {
                reason: &record.projection,
                pipelines: 1,
                draws,
            }),
        }
    }
    let per_draw = inner.totals.flip.saturating_sub(by_flip_pipelines);
    if per_draw > 0 {
        reasons.push(FlipReason {
            reason: PER_DRAW_FLIPS,
            pipelines: 0,
            draws: per_draw,
        });
    }
    reasons.sort_by(|a, b| b.draws.cmp(&a.draws).then(a.reason.cmp(b.reason)));
    reasons
}

/// The line a person reads (the README's "did it work?"), such as `precise 87% of draws
/// (infinite; camera n=0.1), flip 13% (2 pipelines: <reason> 10%; <reason> 3%), native 0%
/// (...); depth images: 1 reversed D32_SFLOAT, 1 native D32_SFLOAT (shaders read it ...)`: the
/// flip path's share of all draws per reason.
fn summary(inner: &Inner, mode: &str) -> String {
    // The shares are of the draws into depth images: a pass without one (post processing,
    // UI) has no depth to reverse, and is counted apart.
    let outside = inner.by_image.get(&0).copied().unwrap_or_default();
    let d = &DrawCounts {
        native: inner.totals.native.saturating_sub(outside.native),
        flip: inner.totals.flip.saturating_sub(outside.flip),
        precise: inner.totals.precise.saturating_sub(outside.precise),
    };
    let total = d.total().max(1) as f64;
    let percent = |n: u64| 100.0 * n as f64 / total;
    let nears: Vec<String> = inner
        .cameras
        .iter()
        .filter_map(|(_, c)| c["near"].as_f64())
        .map(significant)
        .collect();
    let fitted = inner
        .pipelines
        .iter()
        .any(|(_, r)| r.path == "precise" && r.projection.contains("fitted"));
    let mut precise_how = vec![mode.to_owned()];
    match nears.len() {
        0 => {}
        1 => precise_how.push(format!("camera n={}", nears[0])),
        n => precise_how.push(format!("{n} cameras n={}", nears.join(", "))),
    }
    if fitted && mode == "infinite" && nears.is_empty() {
        // `command_state::Reversing::derived_target`: with no n / f on the CPU, what the
        // copies and twins map back with, deriving stages store 1 - D.
        precise_how.push(
            "ranges fitted by vertex stages, complementary depth: no camera pushed".to_owned(),
        );
    } else if fitted {
        precise_how.push("ranges fitted by vertex stages".to_owned());
    }
    let reasons = flip_reasons(inner);
    let flip_pipelines: usize = reasons.iter().map(|r| r.pipelines).sum();
    let shares: Vec<String> = reasons
        .iter()
        .map(|r| format!("{} {:.0}%", r.reason, percent(r.draws)))
        .collect();
    let flip_how = match flip_pipelines {
        0 if shares.is_empty() => String::new(),
        0 => format!(" ({})", shares.join("; ")),
        1 => format!(" (1 pipeline: {})", shares.join("; ")),
        n => format!(" ({n} pipelines: {})", shares.join("; ")),
    };
    // Images grouped by what happened to them and their format.
    let mut groups: Vec<(bool, String, usize, Option<&str>)> = Vec::new();
    for (_, image) in &inner.images {
        let because = inner.native_because(image);
        let format = format!("{:?}", image.promoted.unwrap_or(image.format));
        match groups
            .iter_mut()
            .find(|g| (g.0, &g.1, g.3) == (because.is_none(), &format, because))
        {
            Some(group) => group.2 += 1,
            None => groups.push((because.is_none(), format, 1, because)),
        }
    }
    let images: Vec<String> = groups
        .iter()
        .map(|(reversed, format, count, because)| match because {
            None if *reversed => format!("{count} reversed {format}"),
            _ => format!("{count} native {format} ({})", because.unwrap_or("")),
        })
        .collect();
    let frames = inner.frame_index;
    let without = match outside.total() {
        0 => String::new(),
        n => format!(", {n} more without a depth image"),
    };
    format!(
        "precise {:.0}% of draws ({}), flip {:.0}%{flip_how}, native {:.0}% ({} draws{without}, \
         {frames} frame{}); depth images: {}",
        percent(d.precise),
        precise_how.join("; "),
        percent(d.flip),
        percent(d.native),
        d.total(),
        if frames == 1 { "" } else { "s" },
        if images.is_empty() {
            "none".to_owned()
        } else {
            images.join(", ")
        }
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use ash::vk::Handle as _;

    fn record(native_because: Option<&str>) -> ImageRecord {
        ImageRecord {
            format: vk::Format::D32_SFLOAT,
            promoted: None,
            extent: vk::Extent3D {
                width: 4,
                height: 4,
                depth: 1,
            },
            samples: vk::SampleCountFlags::TYPE_1,
            usage: vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT,
            native_because: native_because.map(str::to_owned),
            demoted_in_frame: None,
            read_twin: false,
        }
    }

    #[test]
    fn frames_close_at_submissions_until_the_application_presents_and_the_file_is_replaced() {
        let dir = std::env::temp_dir().join(format!("revz-profile-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let file = dir.join("report.json");
        let origins = [(crate::config::Key::Mode, "environment REVZ_MODE".to_owned())];
        let profile = Profile::new(
            &file,
            json!({"name": "test"}),
            &Settings::default(),
            &origins,
        );
        // Another test's device may have been this process's first profile: then the file
        // is named apart.
        let file = profile.path.clone();
        profile.image(vk::Image::from_raw(1), record(None));
        profile.image(vk::Image::from_raw(2), record(Some("shaders read it")));
        profile.pipeline(
            3,
            PipelineRecord {
                kind: "pipeline",
                path: "precise",
                projection: "push-constant bytes 0..64".into(),
                reversed_variant: false,
                promoted_variant: false,
                converts_depth_inputs: false,
            },
        );
        // Draws per submission: native 1, flip 1, precise 2.
        let submission = Submission {
            segments: vec![
                Segment {
                    image: 1,
                    pipeline: 3,
                    draws: DrawCounts {
                        precise: 2,
                        flip: 1,
                        native: 0,
                    },
                },
                Segment {
                    image: 2,
                    pipeline: 3,
                    draws: DrawCounts {
                        native: 1,
                        ..DrawCounts::default()
                    },
                },
            ],
            camera_matches: vec![(1, 5)],
        };
        let camera = || vec![(1, json!({"near": 0.1}))];
        profile.submit(&submission, camera);
        profile.submit(&submission, camera);
        let written: Value =
            serde_json::from_str(&std::fs::read_to_string(&file).unwrap()).unwrap();
        // Written at the first submission; the second was within the interval.
        assert_eq!(written["totals"]["submissions"], 1);
        let document = profile.document();
        assert_eq!(document["totals"]["frames"], 2);
        assert_eq!(document["totals"]["draws"]["precise"], 4);
        assert_eq!(
            document["totals"]["precise_fraction_of_reversed"],
            2.0 / 3.0
        );
        profile.present();
        profile.submit(&submission, camera);
        profile.present();
        assert_eq!(profile.document()["totals"]["frames"], 4);
        assert_eq!(profile.document()["frames"][3]["draws"]["native"], 1);
        // Per image and per pipeline, over every submission.
        let document = profile.document();
        assert_eq!(document["images"][0]["draws"]["precise"], 6);
        assert_eq!(document["images"][1]["draws"]["native"], 3);
        assert_eq!(document["pipelines"][0]["draws"]["flip"], 3);
        assert_eq!(document["frames"][3]["by_image"][1]["image"], "0x2");
        assert_eq!(document["frames"][3]["by_image"][1]["draws"]["native"], 1);
        assert_eq!(document["cameras"][0]["matrices_matched"], 15);
        let summary = profile.document()["summary"].as_str().unwrap().to_owned();
        assert_eq!(
            summary,
            format!(
                "precise 50% of draws (complementary; camera n=0.1), flip 25% \
                 ({PER_DRAW_FLIPS} 25%), native 25% (12 draws, 4 frames); depth images: 1 \
                 reversed D32_SFLOAT, 1 native D32_SFLOAT (shaders read it)"
            )
        );
        assert_eq!(significant(0.00125), "0.00125");
        assert_eq!(significant(1234.7), "1235");
        profile.write();
        assert!(!dir.join("report.json.tmp").exists());
        let again: Value = serde_json::from_str(&std::fs::read_to_string(&file).unwrap()).unwrap();
        assert_eq!(again["images"][1]["reason"], "shaders read it");
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn flip_draws_are_shared_out_by_reason_most_first() {
        let mut inner = Inner::default();
        let flip = |reason: &str| PipelineRecord {
            kind: "pipeline",
            path: "flip",
            projection: reason.into(),
            reversed_variant: false,
            promoted_variant: false,
            converts_depth_inputs: false,
        };
        let geometry = "revz's push constants do not reach its geometry stage";
        let ortho = "Position does not come from a push-constant matrix";
        inner.pipelines = vec![
            (1, flip(ortho)),
            (2, flip(geometry)),
            (3, flip(geometry)),
            (
                4,
                PipelineRecord {
                    path: "precise",
                    ..flip("push-constant bytes 0..64")
                },
            ),
            (5, flip("its code is not given")),
        ];
        let draws = |flip, precise| DrawCounts {
            native: 0,
            flip,
            precise,
        };
        inner.by_pipeline = [
            (1, draws(2, 0)),
            (2, draws(3, 0)),
            (3, draws(4, 0)),
            (4, draws(1, 10)),
        ]
        .into_iter()
        .collect();
        inner.totals = draws(10, 10);
        let reasons = flip_reasons(&inner);
        assert_eq!(
            reasons,
            [
                FlipReason {
                    reason: geometry,
                    pipelines: 2,
                    draws: 7
                },
                FlipReason {
                    reason: ortho,
                    pipelines: 1,
                    draws: 2
                },
                FlipReason {
                    reason: PER_DRAW_FLIPS,
                    pipelines: 0,
                    draws: 1
                },
                FlipReason {
                    reason: "its code is not given",
                    pipelines: 1,
                    draws: 0
                },
            ]
        );
        let line = summary(&inner, "infinite");
        assert!(
            line.contains(&format!(
                "flip 50% (4 pipelines: {geometry} 35%; {ortho} 10%; {PER_DRAW_FLIPS} 5%; its \
                 code is not given 0%)"
            )),
            "{line}"
        );
    }

    #[test]
    fn fitted_ranges_in_infinite_mode_without_a_camera_are_said_to_store_complementary_depth() {
        let inner = Inner {
            pipelines: vec![(
                1,
                PipelineRecord {
                    kind: "pipeline",
                    path: "precise",
                    projection: "a uniform buffer, fitted by the shader".into(),
                    reversed_variant: false,
                    promoted_variant: false,
                    converts_depth_inputs: false,
                },
            )],
            totals: DrawCounts {
                native: 0,
                flip: 0,
                precise: 4,
            },
            ..Default::default()
        };
        let line = summary(&inner, "infinite");
        assert!(
            line.contains(
                "(infinite; ranges fitted by vertex stages, complementary depth: no camera pushed)"
            ),
            "{line}"
        );
        let line = summary(&inner, "complementary");
        assert!(
            line.contains("(complementary; ranges fitted by vertex stages)"),
            "{line}"
        );
    }

    #[test]
    fn a_tally_files_draws_under_the_image_and_pipeline_they_were_recorded_with() {
        let mut primary = DrawTally::default();
        primary.set_image(7);
        primary.set_pipeline(1);
        primary.count(DrawnPath::Precise);
        primary.count(DrawnPath::Precise);
        primary.set_pipeline(2);
        primary.count(DrawnPath::Flip);
        // Back to the first pipeline: the same pair again.
        primary.set_pipeline(1);
        primary.count(DrawnPath::Precise);
        // A secondary that did not know its image draws into the primary's.
        let mut secondary = DrawTally::default();
        secondary.set_pipeline(1);
        secondary.count(DrawnPath::Precise);
        secondary.set_image(9);
        secondary.count(DrawnPath::Native);
        primary.add_executed(&secondary);
        let mut segments: Vec<(u64, u64, DrawCounts)> = primary
            .segments()
            .map(|s| (s.image, s.pipeline, s.draws))
            .collect();
        segments.sort_by_key(|s| (s.0, s.1));
        let counts = |native, flip, precise| DrawCounts {
            native,
            flip,
            precise,
        };
        assert_eq!(
            segments,
            vec![
                (7, 1, counts(0, 0, 4)),
                (7, 2, counts(0, 1, 0)),
                (9, 1, counts(1, 0, 0)),
            ]
        );
        assert_eq!(primary.totals(), counts(1, 1, 4));
        // Beyond the pairs kept, draws go to (0, 0): nothing grows without bound.
        let mut many = DrawTally::default();
        for pipeline in 1..=(SEGMENTS_KEPT as u64 + 10) {
            many.set_pipeline(pipeline);
            many.count(DrawnPath::Flip);
        }
        many.set_pipeline(0);
        assert_eq!(many.segments().count(), SEGMENTS_KEPT + 1);
        assert_eq!(
            many.segments().map(|s| s.draws.flip).sum::<u64>(),
            SEGMENTS_KEPT as u64 + 10
        );
    }
}
