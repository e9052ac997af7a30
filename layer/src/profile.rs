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
//! draws are counted per command buffer (one add per draw, `crate::command_state`) and folded
//! into the frame at `vkQueueSubmit`, under this module's one lock, taken per submission and
//! per object creation, never per draw.

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
}

/// One depth-testing pipeline and its path.
#[derive(Clone, Debug)]
pub struct PipelineRecord {
    /// `precise`, `flip` (reversed draws), with why.
    pub path: &'static str,
    /// Where its projection comes from: push-constant bytes, a buffer the stage fits from, or
    /// why neither.
    pub projection: String,
    pub reversed_variant: bool,
    pub promoted_variant: bool,
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
    frames: VecDeque<(u64, DrawCounts)>,
    frame_index: u64,
    totals: DrawCounts,
    submissions: u64,
    presents: bool,
    last_write: Option<Instant>,
    cameras: Vec<Value>,
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
    pub fn new(report: &Path, application: Value, settings: &Settings) -> Profile {
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
                let origin = match std::env::var(spec.env) {
                    Ok(v) if !v.trim().is_empty() => format!("environment {}", spec.env),
                    _ if value == spec.default
                        || (spec.default.is_empty() && (value == "stderr" || value == "none")) =>
                    {
                        "default".to_owned()
                    }
                    _ => "config file or VK_EXT_layer_settings".to_owned(),
                };
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

    pub fn pipeline(&self, pipeline: vk::Pipeline, record: PipelineRecord) {
        let mut inner = self.inner();
        inner.pipeline_count += 1;
        if inner.pipelines.len() < OBJECTS_KEPT {
            inner.pipelines.push((vk::Handle::as_raw(pipeline), record));
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
    pub fn submit(&self, draws: &DrawCounts, cameras: impl FnOnce() -> Vec<Value>) {
        let due = {
            let mut inner = self.inner();
            inner.current.add(draws);
            inner.totals.add(draws);
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

    /// The device's cameras, for the next write.
    pub fn set_cameras(&self, cameras: Vec<Value>) {
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
                json!({
                    "handle": format!("{handle:#x}"),
                    "format": format!("{:?}", r.format),
                    "promoted_format": r.promoted.map(|f| format!("{f:?}")),
                    "width": r.extent.width,
                    "height": r.extent.height,
                    "samples": r.samples.as_raw(),
                    "usage": format!("{:?}", r.usage),
                    "depth": if r.native_because.is_none() { "reversed" } else { "native" },
                    "reason": r.native_because,
                    "demoted_in_frame": r.demoted_in_frame,
                })
            })
            .collect();
        let pipelines: Vec<Value> = inner
            .pipelines
            .iter()
            .map(|(handle, r)| {
                json!({
                    "handle": format!("{handle:#x}"),
                    "path": r.path,
                    "projection": r.projection,
                    "reversed_variant": r.reversed_variant,
                    "promoted_variant": r.promoted_variant,
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
            .map(|(index, d)| json!({"frame": index, "draws": d.json()}))
            .collect();
        let mut document = self.header.clone();
        let object = document.as_object_mut().expect("the header is an object");
        object.insert("images".into(), Value::Array(images));
        object.insert("image_count".into(), json!(inner.image_count));
        object.insert("pipelines".into(), Value::Array(pipelines));
        object.insert("pipeline_count".into(), json!(inner.pipeline_count));
        object.insert("cameras".into(), Value::Array(inner.cameras.clone()));
        object.insert("frames".into(), Value::Array(frames));
        object.insert(
            "totals".into(),
            json!({
                "frames": inner.frame_index,
                "submissions": inner.submissions,
                "draws": inner.totals.json(),
                "precise_fraction_of_reversed": precise_fraction(&inner.totals),
            }),
        );
        object.insert("summary".into(), json!(summary(&inner)));
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
            static FAILED: std::sync::Once = std::sync::Once::new();
            FAILED.call_once(|| {
                log::warn!(
                    "report {}: cannot be written ({err}); no profile is kept",
                    self.path.display()
                )
            });
        }
    }
}

impl Inner {
    fn close_frame(&mut self) {
        let counts = std::mem::take(&mut self.current);
        self.frames.push_back((self.frame_index, counts));
        self.frame_index += 1;
        while self.frames.len() > FRAMES_KEPT {
            self.frames.pop_front();
        }
    }
}

/// The fraction of draws into reversed attachments that took the precise path (`None`: no such
/// draw).
fn precise_fraction(d: &DrawCounts) -> Option<f64> {
    let reversed = d.flip + d.precise;
    (reversed > 0).then(|| d.precise as f64 / reversed as f64)
}

/// The few lines a person reads (the README's "did it work?").
fn summary(inner: &Inner) -> String {
    let d = &inner.totals;
    let total = d.total().max(1) as f64;
    let percent = |n: u64| 100.0 * n as f64 / total;
    let reversed = inner
        .images
        .iter()
        .filter(|(_, r)| r.native_because.is_none())
        .count();
    let native = inner.images.len() - reversed;
    let mut reasons: Vec<&str> = inner
        .images
        .iter()
        .filter_map(|(_, r)| r.native_because.as_deref())
        .collect();
    reasons.sort_unstable();
    reasons.dedup();
    let flip_pipelines = inner
        .pipelines
        .iter()
        .filter(|(_, r)| r.path == "flip")
        .count();
    format!(
        "precise {:.0}% of draws, flip {:.0}%, native {:.0}% ({} draws, {} frames); pipelines: \
         {} precise, {} flip; depth images: {} reversed, {} native{}",
        percent(d.precise),
        percent(d.flip),
        percent(d.native),
        d.total(),
        inner.frame_index,
        inner.pipelines.len() - flip_pipelines,
        flip_pipelines,
        reversed,
        native,
        if reasons.is_empty() {
            String::new()
        } else {
            format!(" ({})", reasons.join("; "))
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
        }
    }

    #[test]
    fn frames_close_at_submissions_until_the_application_presents_and_the_file_is_replaced() {
        let dir = std::env::temp_dir().join(format!("revz-profile-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let file = dir.join("report.json");
        let profile = Profile::new(&file, json!({"name": "test"}), &Settings::default());
        // Another test's device may have been this process's first profile: then the file
        // is named apart.
        let file = profile.path.clone();
        profile.image(vk::Image::from_raw(1), record(None));
        profile.image(vk::Image::from_raw(2), record(Some("shaders read it")));
        profile.pipeline(
            vk::Pipeline::from_raw(3),
            PipelineRecord {
                path: "precise",
                projection: "push-constant bytes 0..64".into(),
                reversed_variant: false,
                promoted_variant: false,
            },
        );
        let draws = DrawCounts {
            native: 1,
            flip: 1,
            precise: 2,
        };
        profile.submit(&draws, Vec::new);
        profile.submit(&draws, Vec::new);
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
        profile.submit(&draws, Vec::new);
        profile.present();
        assert_eq!(profile.document()["totals"]["frames"], 4);
        assert_eq!(profile.document()["frames"][3]["draws"]["native"], 1);
        let summary = profile.document()["summary"].as_str().unwrap().to_owned();
        assert!(
            summary.starts_with("precise 50% of draws, flip 25%, native 25% (12 draws, 4 frames)"),
            "{summary}"
        );
        assert!(
            summary.contains("1 reversed, 1 native (shaders read it)"),
            "{summary}"
        );
        profile.write();
        assert!(!dir.join("report.json.tmp").exists());
        let again: Value = serde_json::from_str(&std::fs::read_to_string(&file).unwrap()).unwrap();
        assert_eq!(again["images"][1]["reason"], "shaders read it");
        std::fs::remove_dir_all(&dir).ok();
    }
}
