//! The benchmark's child roles: each runs in its own process (with or without the layer, as
//! [`crate::variants::Runner`] started it), does one measured piece of work on the device and
//! returns its figures, which `mod.rs` prints as one JSON object on stdout.
//!
//! - [`draw_storm`]: N draws per frame, each with its own pushed MVP, pipelines switched every
//!   [`DRAWS_PER_BIND`] draws, into a D32_SFLOAT attachment that is never read back (so the
//!   layer's default policy reverses it). Per frame: the recording thread's CPU time from the
//!   start of recording to the return of `vkQueueSubmit`, and the wall time until the fence
//!   signals; medians after warm-up. Then the heap and resident size: growth over the measured
//!   frames, and what [`COMMAND_BUFFERS`] recorded command buffers cost.
//! - [`pipeline_storm`]: M graphics pipelines, each from its own vertex module (a copy of
//!   `scene.vert` with one distinct unused constant), module and pipeline created together and
//!   timed; then the heap the pipelines hold.
//! - [`micro`]: the intercepted hot calls in a render pass on the reversed attachment:
//!   `vkCmdPushConstants` of a different perspective MVP each call, `vkCmdDraw` with nothing
//!   changed, `vkCmdBindPipeline` alternating two pipelines; thread CPU time per loop.
//!
//! Files: this one holds the roles and what they measure with; `setup.rs` creates and
//! destroys the objects they share ([`Bench`]: render pass, pipelines, command buffers).

use std::time::Instant;

use anyhow::{anyhow, Context, Result};
use ash::vk;
use glam::{Mat4, Vec3};
use serde::{Deserialize, Serialize};

use crate::gpu::{Gpu, HostBuffer};
use crate::shaders;
use crate::target::{Attachment, DepthFormat, TargetOptions, Targets, COLOR_FORMAT};

/// Draws between pipeline binds in the draw storm (4 pipelines in turn).
pub const DRAWS_PER_BIND: usize = 16;
/// Command buffers recorded for the per-command-buffer memory figure.
pub const COMMAND_BUFFERS: usize = 200;
/// Draws recorded into each of them.
const DRAWS_PER_COMMAND_BUFFER: usize = 64;
/// The push-constant block of `scene.vert` / `scene.frag`: mat4 mvp, vec4 color.
const PUSH_BYTES: u32 = 80;
const PUSH_STAGES: vk::ShaderStageFlags = vk::ShaderStageFlags::from_raw(
    vk::ShaderStageFlags::VERTEX.as_raw() | vk::ShaderStageFlags::FRAGMENT.as_raw(),
);
/// Render size: small, so that the device's raster work does not hide the CPU cost.
const EXTENT: vk::Extent2D = vk::Extent2D {
    width: 64,
    height: 64,
};

/// The recording thread's CPU time in nanoseconds.
pub fn thread_cpu_ns() -> u64 {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `ts` is a valid timespec to write; CLOCK_THREAD_CPUTIME_ID exists on Linux.
    unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) };
    ts.tv_sec as u64 * 1_000_000_000 + ts.tv_nsec as u64
}

/// Bytes of heap in use (glibc `mallinfo2`: small-chunk bytes in use in every arena plus
/// mmapped chunks): what the process, the driver and the layer have allocated and not freed.
pub fn heap_in_use() -> u64 {
    // SAFETY: plain query of the allocator's statistics.
    let info = unsafe { libc::mallinfo2() };
    (info.uordblks + info.hblkhd) as u64
}

/// A `/proc/self/status` size in bytes (`VmHWM`, `VmRSS`), 0 where unreadable.
pub fn proc_status(key: &str) -> u64 {
    let Ok(status) = std::fs::read_to_string("/proc/self/status") else {
        return 0;
    };
    status
        .lines()
        .find_map(|line| {
            let rest = line.strip_prefix(key)?.strip_prefix(':')?;
            let kb: u64 = rest.trim().trim_end_matches("kB").trim().parse().ok()?;
            Some(kb * 1024)
        })
        .unwrap_or(0)
}

/// The median of `values` (0 for none).
pub fn median(values: &[f64]) -> f64 {
    let mut sorted: Vec<f64> = values.iter().copied().filter(|v| v.is_finite()).collect();
    if sorted.is_empty() {
        return 0.0;
    }
    sorted.sort_by(f64::total_cmp);
    let mid = sorted.len() / 2;
    if sorted.len() % 2 == 1 {
        sorted[mid]
    } else {
        (sorted[mid - 1] + sorted[mid]) / 2.0
    }
}

/// An MVP that differs with `i`: the model moves with `i`, the perspective projection (a
/// standard [0, 1] one: near 0, far 1) is the `i % projections`-th of a family with different
/// field of view, near and far planes.
fn mvp(i: usize, projections: usize) -> Mat4 {
    let k = i as f32;
    let p = i % projections.max(1);
    let near = 0.1 + (p % 97) as f32 * 0.001;
    let far = 100.0 + (p % 89) as f32;
    // Right-handed, depth [0, 1] (near 0, far 1), column-major.
    let f = 1.0 / (0.5 + (p % 13) as f32 * 0.005).tan();
    let proj = Mat4::from_cols_array(&[
        f,
        0.0,
        0.0,
        0.0,
        0.0,
        f,
        0.0,
        0.0,
        0.0,
        0.0,
        far / (near - far),
        -1.0,
        0.0,
        0.0,
        near * far / (near - far),
        0.0,
    ]);
    let model = Mat4::from_translation(Vec3::new(
        ((k * 0.37).sin()) * 2.0,
        ((k * 0.61).cos()) * 2.0,
        -5.0 - (i % 50) as f32 * 0.2,
    ));
    proj * model
}

/// The 80 push-constant bytes of draw `i`: its MVP (see [`mvp`]) and a color.
fn push_bytes(i: usize, projections: usize) -> [u8; PUSH_BYTES as usize] {
    let mut out = [0u8; PUSH_BYTES as usize];
    let m = mvp(i, projections).to_cols_array();
    let color = [
        (i % 7) as f32 / 7.0,
        (i % 5) as f32 / 5.0,
        (i % 3) as f32 / 3.0,
        1.0,
    ];
    for (n, v) in m.iter().chain(color.iter()).enumerate() {
        out[n * 4..n * 4 + 4].copy_from_slice(&v.to_ne_bytes());
    }
    out
}

/// SPIR-V word of `OpTypeFloat` (opcode 22) and `OpConstant` (opcode 43).
const OP_TYPE_FLOAT: u32 = 22;
const OP_CONSTANT: u32 = 43;

/// `words` (a SPIR-V module) with one more, unused, 32-bit float constant of value `value`,
/// declared right after the module's `OpTypeFloat 32`: a distinct module that computes the
/// same thing.
pub fn with_unused_constant(words: &[u32], value: f32) -> Result<Vec<u32>> {
    if words.len() < 5 {
        return Err(anyhow!("SPIR-V module too short"));
    }
    let mut at = 5;
    let mut float_type = None;
    while at < words.len() {
        let count = (words[at] >> 16) as usize;
        if count == 0 {
            return Err(anyhow!("malformed SPIR-V instruction at word {at}"));
        }
        if words[at] & 0xffff == OP_TYPE_FLOAT && count == 3 && words.get(at + 2) == Some(&32) {
            float_type = Some((at + count, words[at + 1]));
            break;
        }
        at += count;
    }
    let (insert_at, type_id) = float_type.context("no OpTypeFloat 32 in the module")?;
    let new_id = words[3];
    let mut out = Vec::with_capacity(words.len() + 4);
    out.extend_from_slice(&words[..insert_at]);
    out.extend_from_slice(&[(4 << 16) | OP_CONSTANT, type_id, new_id, value.to_bits()]);
    out.extend_from_slice(&words[insert_at..]);
    out[3] = new_id + 1;
    Ok(out)
}

/// One pipeline's depth state in the draw storm's mix.
#[derive(Clone, Copy, Debug)]
struct PipelineKind {
    compare: vk::CompareOp,
    bias: bool,
}

const MIX: [PipelineKind; 4] = [
    PipelineKind {
        compare: vk::CompareOp::LESS,
        bias: false,
    },
    PipelineKind {
        compare: vk::CompareOp::LESS_OR_EQUAL,
        bias: false,
    },
    PipelineKind {
        compare: vk::CompareOp::LESS,
        bias: true,
    },
    PipelineKind {
        compare: vk::CompareOp::LESS_OR_EQUAL,
        bias: true,
    },
];

/// The objects every role renders with: color + D32 targets, a render pass clearing both
/// (depth to 1.0), its framebuffer, the push-constant layout, `scene.frag`, a one-triangle
/// vertex buffer, a command pool and a fence.
struct Bench<'a> {
    gpu: &'a Gpu,
    render_pass: vk::RenderPass,
    framebuffer: vk::Framebuffer,
    layout: vk::PipelineLayout,
    fragment: vk::ShaderModule,
    pipelines: Vec<vk::Pipeline>,
    pool: vk::CommandPool,
    fence: vk::Fence,
    vertices: HostBuffer<'a>,
    _targets: Targets<'a>,
}

mod setup;

use setup::create_module;

/// What a draw-storm child measured.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct DrawStorm {
    pub draws: usize,
    pub frames: usize,
    pub warmup: usize,
    /// Distinct projections among the draws' MVPs (1: one camera, the model differs).
    pub projections: usize,
    /// Median recording-thread CPU time from the start of recording to the return of
    /// `vkQueueSubmit`, ns.
    pub frame_cpu_ns: f64,
    /// Median wall time from the start of recording to the fence, ns.
    pub frame_wall_ns: f64,
    /// Median wall time of recording and submitting only, ns.
    pub record_wall_ns: f64,
    /// Median over the measured frames of the heap's growth during one frame (bytes): a
    /// steady leak shows as itself, a one-time step of the driver's pools as 0.
    pub heap_growth_per_frame: f64,
    /// Heap growth from the first to the last measured frame, per frame (bytes).
    pub heap_growth_mean_per_frame: f64,
    /// Heap held by [`COMMAND_BUFFERS`] recorded command buffers, per command buffer (bytes).
    pub heap_per_command_buffer: f64,
    /// Resident size growth for the same, per command buffer (bytes, page granularity).
    pub rss_per_command_buffer: f64,
    /// Peak resident size of the process at the end (`VmHWM`, bytes).
    pub vm_hwm: u64,
}

/// The draw storm: `draws` draws a frame, `warmup` frames then `frames` measured.
pub fn draw_storm(
    gpu: &Gpu,
    draws: usize,
    frames: usize,
    warmup: usize,
    projections: usize,
) -> Result<DrawStorm> {
    let storm = Storm::new(gpu, draws, projections)?;
    let mut cpu = Vec::new();
    let mut wall = Vec::new();
    let mut record = Vec::new();
    let mut growth = Vec::new();
    let mut heap_first = 0;
    let mut heap = heap_in_use();
    for frame in 0..warmup + frames {
        let (frame_cpu, frame_record, frame_wall) = storm.frame(frame >= warmup)?;
        let heap_now = heap_in_use();
        if frame >= warmup {
            cpu.push(frame_cpu);
            record.push(frame_record);
            wall.push(frame_wall);
            growth.push(heap_now as f64 - heap as f64);
            if frame == warmup {
                heap_first = heap_now;
            }
        }
        heap = heap_now;
    }
    let heap_growth_mean_per_frame = if frames > 1 {
        (heap as f64 - heap_first as f64) / (frames - 1) as f64
    } else {
        0.0
    };

    // Memory per recorded command buffer: COMMAND_BUFFERS buffers recorded (not submitted),
    // heap and resident size before and after.
    let heap0 = heap_in_use();
    let rss0 = proc_status("VmRSS");
    let cmds = storm.bench.allocate(COMMAND_BUFFERS)?;
    for &c in &cmds {
        storm
            .bench
            .record_storm(c, &storm.pushes, DRAWS_PER_COMMAND_BUFFER.min(draws.max(1)))?;
    }
    let heap1 = heap_in_use();
    let rss1 = proc_status("VmRSS");
    // SAFETY: never submitted; freed back to their pool.
    unsafe { gpu.device.free_command_buffers(storm.bench.pool, &cmds) };
    let per = |a: u64, b: u64| (b as f64 - a as f64) / COMMAND_BUFFERS as f64;
    Ok(DrawStorm {
        draws,
        frames,
        warmup,
        projections,
        frame_cpu_ns: median(&cpu),
        frame_wall_ns: median(&wall),
        record_wall_ns: median(&record),
        heap_growth_per_frame: median(&growth),
        heap_growth_mean_per_frame,
        heap_per_command_buffer: per(heap0, heap1),
        rss_per_command_buffer: per(rss0, rss1),
        vm_hwm: proc_status("VmHWM"),
    })
}

/// A measured frame's CPU work (reset, record, submit) in a function of its own, which the
/// bench's instruction count (callgrind's `--toggle-collect`, [`MEASURED_FRAME_SYMBOL`])
/// counts inside and nowhere else.
#[inline(never)]
fn measured_frame(storm: &Storm) -> Result<()> {
    let done = storm.record_and_submit();
    // Not a tail call: callgrind would take the jump for this function's end.
    std::hint::black_box(&done);
    done
}

/// What callgrind's `--toggle-collect` matches: [`measured_frame`]'s symbol.
pub const MEASURED_FRAME_SYMBOL: &str = "*bench::child::measured_frame*";

/// The draw storm's objects and pushes, recorded and submitted frame by frame.
struct Storm<'a> {
    bench: Bench<'a>,
    pushes: Vec<[u8; 80]>,
    draws: usize,
    cmd: vk::CommandBuffer,
}

impl<'a> Storm<'a> {
    /// Resets, records and submits the frame's command buffer.
    fn record_and_submit(&self) -> Result<()> {
        // SAFETY: the previous submission of `cmd` has completed (fence waited).
        unsafe {
            self.bench
                .gpu
                .device
                .reset_command_buffer(self.cmd, vk::CommandBufferResetFlags::empty())
        }
        .context("vkResetCommandBuffer failed")?;
        self.bench
            .record_storm(self.cmd, &self.pushes, self.draws)?;
        self.bench.submit(self.cmd)
    }

    fn new(gpu: &'a Gpu, draws: usize, projections: usize) -> Result<Self> {
        let mut bench = Bench::new(gpu)?;
        bench.standard_pipelines()?;
        // One distinct MVP per draw, computed before anything is timed.
        let pushes = (0..draws.max(1))
            .map(|i| push_bytes(i, projections))
            .collect();
        let cmd = bench.allocate(1)?[0];
        Ok(Storm {
            bench,
            pushes,
            draws,
            cmd,
        })
    }

    /// Records, submits and waits for one frame: (CPU ns to the return of the submit, wall ns
    /// of the same, wall ns to the fence). A `measured` frame's CPU work goes through
    /// [`measured_frame`], instrumented where callgrind runs the child (only there: the
    /// rest of the child runs at valgrind's plain speed).
    fn frame(&self, measured: bool) -> Result<(f64, f64, f64)> {
        let w0 = Instant::now();
        let c0 = thread_cpu_ns();
        if measured {
            super::callgrind::start_instrumentation();
            let done = measured_frame(self);
            super::callgrind::stop_instrumentation();
            done?;
        } else {
            self.record_and_submit()?;
        }
        let c1 = thread_cpu_ns();
        let w1 = Instant::now();
        self.bench.wait()?;
        let w2 = Instant::now();
        Ok((
            (c1 - c0) as f64,
            (w1 - w0).as_nanos() as f64,
            (w2 - w0).as_nanos() as f64,
        ))
    }
}

/// What a pipeline-storm child measured.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct PipelineStorm {
    pub pipelines: usize,
    pub repeats: usize,
    /// Wall time to create every module and pipeline, ns (the best of the repeats).
    pub create_wall_ns: f64,
    /// The creating thread's CPU time for the same, ns (the best of the repeats).
    pub create_cpu_ns: f64,
    /// Heap held after the first repeat (modules destroyed, pipelines alive), per pipeline
    /// (bytes).
    pub heap_per_pipeline: f64,
    /// Resident size growth for the same, per pipeline (bytes).
    pub rss_per_pipeline: f64,
    /// Peak resident size at the end (`VmHWM`, bytes).
    pub vm_hwm: u64,
}

/// The pipeline storm: `count` pipelines, each from its own vertex module, created `repeats`
/// times (new modules each time; the pipelines are destroyed between repeats). The modules'
/// code differs (an unused constant each), or with `repeated_code` is one code, not that of
/// the first pipeline created before the measurement.
pub fn pipeline_storm(
    gpu: &Gpu,
    count: usize,
    repeats: usize,
    repeated_code: bool,
) -> Result<PipelineStorm> {
    let mut bench = Bench::new(gpu)?;
    let base = shaders::SCENE_VERT.words()?;
    let repeats = repeats.max(1);
    let modules: Vec<Vec<u32>> = (0..count * repeats)
        .map(|i| with_unused_constant(&base, 1000.0 + if repeated_code { 0.0 } else { i as f32 }))
        .collect::<Result<_>>()?;
    // One pipeline first, so that one-time costs (the driver's and the layer's first
    // pipeline) are not counted.
    let warm = create_module(&gpu.device, &base)?;
    let first = bench.pipeline(warm, MIX[0]);
    // SAFETY: only needed while the pipeline was created.
    unsafe { gpu.device.destroy_shader_module(warm, None) };
    bench.pipelines.push(first?);

    let (mut wall, mut cpu) = (f64::MAX, f64::MAX);
    let (mut heap_per_pipeline, mut rss_per_pipeline) = (0.0, 0.0);
    let n = count.max(1) as f64;
    for (rep, chunk) in modules.chunks(count.max(1)).enumerate() {
        let heap0 = heap_in_use();
        let rss0 = proc_status("VmRSS");
        let mut created = Vec::with_capacity(count);
        let w0 = Instant::now();
        let c0 = thread_cpu_ns();
        for (i, words) in chunk.iter().enumerate() {
            let module = create_module(&gpu.device, words)?;
            let pipeline = bench.pipeline(module, MIX[i % MIX.len()]);
            // SAFETY: only needed while the pipeline was created.
            unsafe { gpu.device.destroy_shader_module(module, None) };
            match pipeline {
                Ok(pipeline) => created.push(pipeline),
                Err(e) => {
                    bench.pipelines.extend(created);
                    return Err(e);
                }
            }
        }
        let c1 = thread_cpu_ns();
        let w1 = Instant::now();
        wall = wall.min((w1 - w0).as_nanos() as f64);
        cpu = cpu.min((c1 - c0) as f64);
        if rep == 0 {
            heap_per_pipeline = (heap_in_use() as f64 - heap0 as f64) / n;
            rss_per_pipeline = (proc_status("VmRSS") as f64 - rss0 as f64) / n;
        }
        for pipeline in created {
            // SAFETY: never used in a command buffer.
            unsafe { gpu.device.destroy_pipeline(pipeline, None) };
        }
    }
    Ok(PipelineStorm {
        pipelines: count,
        repeats,
        create_wall_ns: wall,
        create_cpu_ns: cpu,
        heap_per_pipeline,
        rss_per_pipeline,
        vm_hwm: proc_status("VmHWM"),
    })
}

/// The micro-benchmark's loops, in the order [`micro`] runs (and, under callgrind, dumps)
/// them.
pub const MICRO_LOOPS: [&str; 4] = ["push", "push_one_camera", "draw", "bind"];

/// What a micro-benchmark child measured: thread CPU ns per call, each loop's best of
/// `repeats`.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct Micro {
    pub calls: usize,
    pub push_constant_ns: f64,
    /// Pushes of one camera's MVPs (every push its own model matrix: what most applications
    /// push, and what the same-camera shortcut serves).
    pub push_one_camera_ns: f64,
    pub draw_ns: f64,
    pub bind_ns: f64,
}

/// The micro-benchmark: `calls` pushes (a different perspective MVP each), `calls` pushes of
/// one camera's MVPs (a model matrix each), `calls` draws with
/// nothing changed, `calls` binds alternating two pipelines, in a render pass on the reversed
/// attachment with the MVP pipeline bound; each loop timed alone, `repeats` times. Under
/// callgrind (the bench's [`MICRO_LOOPS`] instruction counts) each loop is one dumped part:
/// counters zeroed before it, dumped after it, in this order, every repeat.
pub fn micro(gpu: &Gpu, calls: usize, repeats: usize) -> Result<Micro> {
    let mut bench = Bench::new(gpu)?;
    bench.standard_pipelines()?;
    let device = &gpu.device;
    let mvps: Vec<[u8; 64]> = (0..calls.max(1))
        .map(|i| {
            let mut out = [0u8; 64];
            out.copy_from_slice(&push_bytes(i, i + 1)[..64]);
            out
        })
        .collect();
    let one_camera: Vec<[u8; 64]> = (0..calls.max(1))
        .map(|i| {
            let mut out = [0u8; 64];
            out.copy_from_slice(&push_bytes(i, 1)[..64]);
            out
        })
        .collect();
    let cmd = bench.allocate(1)?[0];
    let (mut push, mut push_one, mut draw, mut bind) = (f64::MAX, f64::MAX, f64::MAX, f64::MAX);
    // Outside valgrind these do nothing.
    super::callgrind::start_instrumentation();
    let counted = |run: &mut dyn FnMut()| {
        super::callgrind::zero_stats();
        run();
        super::callgrind::dump_stats();
    };
    let per_call = |c0: u64, c1: u64| (c1 - c0) as f64 / calls.max(1) as f64;
    for _ in 0..repeats.max(1) {
        // SAFETY: `cmd` is not pending (never submitted).
        unsafe { device.reset_command_buffer(cmd, vk::CommandBufferResetFlags::empty()) }
            .context("vkResetCommandBuffer failed")?;
        bench.begin(cmd)?;
        let [a, b] = [bench.pipelines[0], bench.pipelines[1]];
        // SAFETY: `cmd` is recording inside the render pass; pipelines and layout alive.
        unsafe {
            device.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::GRAPHICS, a);
            counted(&mut || {
                let c0 = thread_cpu_ns();
                for m in &mvps {
                    device.cmd_push_constants(cmd, bench.layout, PUSH_STAGES, 0, m);
                }
                let c1 = thread_cpu_ns();
                push = push.min(per_call(c0, c1));
            });
            counted(&mut || {
                let c0 = thread_cpu_ns();
                for m in &one_camera {
                    device.cmd_push_constants(cmd, bench.layout, PUSH_STAGES, 0, m);
                }
                let c1 = thread_cpu_ns();
                push_one = push_one.min(per_call(c0, c1));
            });
            // The first draw after the pushes settles whatever is pending.
            device.cmd_draw(cmd, 3, 1, 0, 0);
            counted(&mut || {
                let c0 = thread_cpu_ns();
                for _ in 0..calls {
                    device.cmd_draw(cmd, 3, 1, 0, 0);
                }
                let c1 = thread_cpu_ns();
                draw = draw.min(per_call(c0, c1));
            });
            counted(&mut || {
                let c0 = thread_cpu_ns();
                for i in 0..calls {
                    let p = if i % 2 == 0 { b } else { a };
                    device.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::GRAPHICS, p);
                }
                let c1 = thread_cpu_ns();
                bind = bind.min(per_call(c0, c1));
            });
        }
        bench.end(cmd)?;
    }
    Ok(Micro {
        calls,
        push_constant_ns: push,
        push_one_camera_ns: push_one,
        draw_ns: draw,
        bind_ns: bind,
    })
}

/// What [`depth_copy`] measured.
#[derive(Debug, Serialize, Deserialize)]
pub struct DepthCopy {
    pub frames: usize,
    /// Texels copied per frame, in millions.
    pub megapixels: f64,
    /// Median wall time of one frame of D32_SFLOAT: record, submit, wait.
    pub copy_wall_ns: f64,
    /// Median CPU time of the recording thread to record and submit one such frame.
    pub copy_cpu_ns: f64,
    /// The same of D24_UNORM_S8_UINT (its depth aspect copied): the image revz promotes to
    /// D32_SFLOAT_S8_UINT in the precise modes, whose copy it converts back to D24.
    pub copy_d24s8_wall_ns: f64,
    pub copy_d24s8_cpu_ns: f64,
    /// The same D32 image, also SAMPLED, made readable by shaders after the clear (a barrier
    /// into `SHADER_READ_ONLY_OPTIMAL`) instead of copied: revz refreshes its read twin
    /// there (issue #39); without revz the frame is the clear alone.
    pub refresh_wall_ns: f64,
    /// The same refresh of a 4-sample D32 image (a multisampled twin, refreshed per sample by
    /// a compute pass); `None` where the device has no such image.
    #[serde(default)]
    pub refresh_msaa_wall_ns: Option<f64>,
}

/// Samples per pixel of the multisampled image [`depth_copy`] refreshes.
pub const DEPTH_COPY_MSAA_SAMPLES: u32 = 4;

/// Side of the depth image [`depth_copy`] reads back (1024 x 1024: one megapixel).
pub const DEPTH_COPY_SIDE: u32 = 1024;

/// A depth readback per frame, of a D32_SFLOAT and of a D24_UNORM_S8_UINT image
/// ([`depth_copy_of`]).
pub fn depth_copy(gpu: &Gpu, frames: usize, warmup: usize) -> Result<DepthCopy> {
    let single = vk::SampleCountFlags::TYPE_1;
    let d32 = vk::Format::D32_SFLOAT;
    let (wall, cpu) = depth_copy_of(gpu, d32, (false, single), frames, warmup)?;
    let (d24s8_wall, d24s8_cpu) = depth_copy_of(
        gpu,
        vk::Format::D24_UNORM_S8_UINT,
        (false, single),
        frames,
        warmup,
    )?;
    let (refresh_wall, _) = depth_copy_of(gpu, d32, (true, single), frames, warmup)?;
    let msaa = vk::SampleCountFlags::from_raw(DEPTH_COPY_MSAA_SAMPLES);
    // SAFETY: a live physical device.
    let msaa_supported = unsafe {
        gpu.instance().get_physical_device_image_format_properties(
            gpu.physical_device,
            d32,
            vk::ImageType::TYPE_2D,
            vk::ImageTiling::OPTIMAL,
            vk::ImageUsageFlags::TRANSFER_DST
                | vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT
                | vk::ImageUsageFlags::SAMPLED,
            vk::ImageCreateFlags::empty(),
        )
    }
    .is_ok_and(|properties| properties.sample_counts.contains(msaa));
    let refresh_msaa_wall = if msaa_supported {
        Some(depth_copy_of(gpu, d32, (true, msaa), frames, warmup)?.0)
    } else {
        None
    };
    Ok(DepthCopy {
        frames: frames.max(1),
        megapixels: f64::from(DEPTH_COPY_SIDE * DEPTH_COPY_SIDE) / 1e6,
        copy_wall_ns: wall,
        copy_cpu_ns: cpu,
        copy_d24s8_wall_ns: d24s8_wall,
        copy_d24s8_cpu_ns: d24s8_cpu,
        refresh_wall_ns: refresh_wall,
        refresh_msaa_wall_ns: refresh_msaa_wall,
    })
}

/// A depth readback per frame: an image of `format` (`TRANSFER_SRC | TRANSFER_DST |
/// DEPTH_STENCIL_ATTACHMENT`, which revz reverses by default, promotes in the precise modes
/// where it is D24, and whose copies it converts) cleared with `vkCmdClearDepthStencilImage`,
/// then its depth aspect copied into a host buffer with `vkCmdCopyImageToBuffer`; each frame
/// submitted and waited for. The medians of the frames' wall and recording CPU times.
/// `sampled`: the image is SAMPLED too, and the frame ends with a barrier that makes it
/// readable by fragment shaders instead of the copy (a read twin refresh under revz); it has
/// `samples` samples per pixel then (and a view, made before any frame: revz makes what a
/// multisampled twin's refresh binds at the image's first view).
fn depth_copy_of(
    gpu: &Gpu,
    format: vk::Format,
    (sampled, samples): (bool, vk::SampleCountFlags),
    frames: usize,
    warmup: usize,
) -> Result<(f64, f64)> {
    let bench = Bench::new(gpu)?;
    let device = &gpu.device;
    let extent = vk::Extent2D {
        width: DEPTH_COPY_SIDE,
        height: DEPTH_COPY_SIDE,
    };
    let usage = vk::ImageUsageFlags::TRANSFER_SRC
        | vk::ImageUsageFlags::TRANSFER_DST
        | vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT;
    let usage = if sampled {
        usage | vk::ImageUsageFlags::SAMPLED
    } else {
        usage
    };
    let image = if samples == vk::SampleCountFlags::TYPE_1 {
        Attachment::copied(gpu, format, usage, extent)?
    } else {
        Attachment::with_samples(
            gpu,
            format,
            vk::ImageAspectFlags::DEPTH,
            usage,
            extent,
            samples,
        )?
    };
    let pixels = (DEPTH_COPY_SIDE * DEPTH_COPY_SIDE) as usize;
    let host = HostBuffer::new(gpu, pixels * 4, vk::BufferUsageFlags::TRANSFER_DST)?;
    let cmd = bench.allocate(1)?[0];
    let d24s8 = format == vk::Format::D24_UNORM_S8_UINT;
    let range = crate::target::full_range(if d24s8 {
        vk::ImageAspectFlags::DEPTH | vk::ImageAspectFlags::STENCIL
    } else {
        vk::ImageAspectFlags::DEPTH
    });
    let region = vk::BufferImageCopy {
        image_subresource: vk::ImageSubresourceLayers {
            aspect_mask: vk::ImageAspectFlags::DEPTH,
            mip_level: 0,
            base_array_layer: 0,
            layer_count: 1,
        },
        image_extent: vk::Extent3D {
            width: DEPTH_COPY_SIDE,
            height: DEPTH_COPY_SIDE,
            depth: 1,
        },
        ..Default::default()
    };
    let (mut wall, mut cpu) = (Vec::new(), Vec::new());
    for frame in 0..warmup + frames.max(1) {
        let (w0, c0) = (Instant::now(), thread_cpu_ns());
        // SAFETY: `cmd` is not pending (each frame is waited for); the image and buffer are
        // alive and have the usages the commands need.
        unsafe {
            device
                .reset_command_buffer(cmd, vk::CommandBufferResetFlags::empty())
                .context("vkResetCommandBuffer failed")?;
            device
                .begin_command_buffer(
                    cmd,
                    &vk::CommandBufferBeginInfo::default()
                        .flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT),
                )
                .context("vkBeginCommandBuffer failed")?;
            let to_clear = vk::ImageMemoryBarrier::default()
                .src_access_mask(vk::AccessFlags::TRANSFER_READ)
                .dst_access_mask(vk::AccessFlags::TRANSFER_WRITE)
                .old_layout(vk::ImageLayout::UNDEFINED)
                .new_layout(vk::ImageLayout::TRANSFER_DST_OPTIMAL)
                .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
                .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
                .image(image.image)
                .subresource_range(range);
            device.cmd_pipeline_barrier(
                cmd,
                vk::PipelineStageFlags::TRANSFER,
                vk::PipelineStageFlags::TRANSFER,
                vk::DependencyFlags::empty(),
                &[],
                &[],
                &[to_clear],
            );
            let value = vk::ClearDepthStencilValue {
                depth: 0.25,
                stencil: 0,
            };
            device.cmd_clear_depth_stencil_image(
                cmd,
                image.image,
                vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                &value,
                &[range],
            );
            let to_copy = vk::ImageMemoryBarrier {
                src_access_mask: vk::AccessFlags::TRANSFER_WRITE,
                dst_access_mask: vk::AccessFlags::TRANSFER_READ,
                old_layout: vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                new_layout: vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                ..to_clear
            };
            if sampled {
                let to_shaders = vk::ImageMemoryBarrier {
                    dst_access_mask: vk::AccessFlags::SHADER_READ,
                    new_layout: vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
                    ..to_copy
                };
                device.cmd_pipeline_barrier(
                    cmd,
                    vk::PipelineStageFlags::TRANSFER,
                    vk::PipelineStageFlags::FRAGMENT_SHADER,
                    vk::DependencyFlags::empty(),
                    &[],
                    &[],
                    &[to_shaders],
                );
            } else {
                device.cmd_pipeline_barrier(
                    cmd,
                    vk::PipelineStageFlags::TRANSFER,
                    vk::PipelineStageFlags::TRANSFER,
                    vk::DependencyFlags::empty(),
                    &[],
                    &[],
                    &[to_copy],
                );
                device.cmd_copy_image_to_buffer(
                    cmd,
                    image.image,
                    vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                    host.buffer,
                    &[region],
                );
                let to_host = vk::BufferMemoryBarrier::default()
                    .src_access_mask(vk::AccessFlags::TRANSFER_WRITE)
                    .dst_access_mask(vk::AccessFlags::HOST_READ)
                    .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
                    .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
                    .buffer(host.buffer)
                    .size(vk::WHOLE_SIZE);
                device.cmd_pipeline_barrier(
                    cmd,
                    vk::PipelineStageFlags::TRANSFER,
                    vk::PipelineStageFlags::HOST,
                    vk::DependencyFlags::empty(),
                    &[],
                    &[to_host],
                    &[],
                );
            }
            device
                .end_command_buffer(cmd)
                .context("vkEndCommandBuffer failed")?;
        }
        bench.submit(cmd)?;
        let c1 = thread_cpu_ns();
        bench.wait()?;
        if frame >= warmup {
            wall.push(w0.elapsed().as_nanos() as f64);
            cpu.push((c1 - c0) as f64);
        }
    }
    if sampled {
        return Ok((median(&wall), median(&cpu)));
    }
    // The values read back: 0.25 wherever revz reverses and converts (checked so that a
    // timing of a wrong conversion is not reported); D24 within two units of its grid.
    let word = u32::from_ne_bytes(host.contents()[..4].try_into().expect("4 bytes"));
    let (first, tolerance) = if d24s8 {
        let max = 16_777_215.0;
        (f64::from(word & 0x00FF_FFFF) / max, 2.0 / max)
    } else {
        (f64::from(f32::from_bits(word)), 1e-6)
    };
    if (first - 0.25).abs() > tolerance {
        anyhow::bail!(
            "the {format:?} depth copy read back {first}, not the 0.25 it was cleared to"
        );
    }
    Ok((median(&wall), median(&cpu)))
}

/// A short validated run of every role's recording (tiny counts), submitted once: the smoke
/// test's check that what the benchmark records is valid Vulkan.
pub fn smoke(gpu: &Gpu) -> Result<()> {
    draw_storm(gpu, 40, 2, 1, 1)?;
    pipeline_storm(gpu, 3, 2, false)?;
    pipeline_storm(gpu, 3, 2, true)?;
    micro(gpu, 50, 1)?;
    let mut bench = Bench::new(gpu)?;
    bench.standard_pipelines()?;
    let cmd = bench.allocate(1)?[0];
    let pushes: Vec<[u8; 80]> = (0..8).map(|i| push_bytes(i, 3)).collect();
    bench.record_storm(cmd, &pushes, 40)?;
    bench.submit_and_wait(cmd)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_unused_constant_makes_a_distinct_valid_module() {
        let base = shaders::SCENE_VERT.words().unwrap();
        let a = with_unused_constant(&base, 1.0).unwrap();
        let b = with_unused_constant(&base, 2.0).unwrap();
        assert_ne!(a, b);
        assert_eq!(a.len(), base.len() + 4);
        assert_eq!(a[3], base[3] + 1);
        use spirv_tools::val::{self, Validator as _};
        let validator = val::create(Some(spirv_tools::TargetEnv::Vulkan_1_1));
        validator.validate(&a, None).expect("valid SPIR-V");
    }

    #[test]
    fn median_of_odd_and_even_counts() {
        assert_eq!(median(&[3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(&[4.0, 1.0, 2.0, 3.0]), 2.5);
        assert_eq!(median(&[]), 0.0);
    }

    #[test]
    fn status_sizes_are_read() {
        assert!(proc_status("VmRSS") > 0);
        assert!(heap_in_use() > 0);
    }
}
