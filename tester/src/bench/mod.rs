//! The benchmark (issue #7): the layer's cost measured in every mode against no layer, in one
//! run.
//!
//! The parent process runs each measurement in a child process of this same executable (the
//! hidden `--child ROLE` argument), once per [`Variant`] (no layer, and revz in `off`, `flip`,
//! `complementary`, `infinite`), round after round with the variants' order rotated each
//! round, and compares every variant with no layer *of the same round*: ratios and differences
//! are the median over rounds of the per-round figures. The children print what they measured
//! as one JSON object on stdout (`child/` has the roles). Timing runs have validation off;
//! `--validation` turns it on in every child (for smoke tests, not for figures).
//!
//! Outputs: `<out>/bench.json` (every child's figures and the summary), the `speed` table of
//! `<out>/report.json` and `<out>/report.md` (after the `<!-- speed -->` marker; the rest of
//! both files belongs to `revz-tester report`), and `<out>/overhead-vs-error.png`.

mod callgrind;
mod child;
mod report;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{bail, Context, Result};
use serde::{Deserialize, Serialize};
use serde_json::{json, Value};

use crate::gpu::{Features, Gpu, GpuOptions};
use crate::variants::{Runner, Variant};

/// A child process's role (hidden `--child`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Role {
    DrawStorm,
    PipelineStorm,
    Micro,
    /// A one-megapixel depth readback per frame (revz converts the copy).
    DepthCopy,
    /// Every role with tiny counts and one submitted storm (for validated smoke runs).
    Smoke,
}

/// revz's `compare_op` setting, as the benchmark runs it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum CompareOp {
    Dynamic,
    Variants,
}

impl CompareOp {
    /// The setting's value (`REVZ_COMPARE_OP`).
    fn setting(self) -> &'static str {
        match self {
            CompareOp::Dynamic => "dynamic",
            CompareOp::Variants => "variants",
        }
    }
}

/// `revz-tester bench`.
#[derive(Debug, clap::Args)]
pub struct BenchArgs {
    /// Output directory (created if missing): bench.json, and the speed table merged into
    /// report.json and report.md, overhead-vs-error.png.
    #[arg(long, value_name = "DIR", required_unless_present = "child")]
    pub out: Option<PathBuf>,

    /// Run on the first device whose name contains NAME (case-insensitive). Default: lavapipe
    /// when present, else the first device.
    #[arg(long, value_name = "NAME")]
    pub device: Option<String>,

    /// Draws per frame in the draw storm, one measurement each (comma-separated).
    #[arg(long, value_delimiter = ',', default_values_t = [1000usize, 10000])]
    pub draws: Vec<usize>,

    /// Distinct projections among a draw-storm frame's MVPs (1: one camera, every draw its
    /// own model matrix, as most applications draw; more: the projection changes between
    /// draws too).
    #[arg(long, default_value_t = 1)]
    pub projections: usize,

    /// Measured frames per draw-storm child (after the warm-up frames).
    #[arg(long, default_value_t = 20)]
    pub frames: usize,

    /// Warm-up frames per draw-storm child (not measured).
    #[arg(long, default_value_t = 3)]
    pub warmup: usize,

    /// Rounds: each round runs every variant once per measurement, order rotated.
    #[arg(long, default_value_t = 5)]
    pub rounds: usize,

    /// Pipelines in the pipeline storm (each from its own vertex module).
    #[arg(long, default_value_t = 200)]
    pub pipelines: usize,

    /// A pipeline-storm child (hidden): every vertex module of the same code, as applications
    /// that create a module per pipeline from one blob do.
    #[arg(long, hide = true)]
    pub repeated_code: bool,

    /// Calls per loop in the micro-benchmark.
    #[arg(long, default_value_t = 100_000)]
    pub calls: usize,

    /// Repeats of each micro-benchmark loop and of the pipeline storm in one child (the best
    /// is kept).
    #[arg(long, default_value_t = 3)]
    pub repeats: usize,

    /// The layer's manifest directory (default: `manifests/explicit` next to this executable,
    /// as `cargo xtask build` writes it).
    #[arg(long, value_name = "DIR")]
    pub layer_dir: Option<PathBuf>,

    /// How revz gives draws into reversed attachments the flipped compare op (its
    /// `compare_op` setting, `REVZ_COMPARE_OP`): dynamic state, or a pipeline variant per
    /// depth-testing pipeline (what devices without extended dynamic state get).
    #[arg(long, value_enum, default_value_t = CompareOp::Dynamic)]
    pub compare_op: CompareOp,

    /// Tiny counts (a smoke run; the figures mean nothing; no instruction counts).
    #[arg(long)]
    pub quick: bool,

    /// Skip the instruction count of the largest storms under callgrind (about 10 s per
    /// child, 50 children: five per storm and variant; done by default where `valgrind` is
    /// installed).
    #[arg(long)]
    pub no_instructions: bool,

    /// Enable the Khronos validation layer in every child (fails on any message; the timings
    /// are then meaningless).
    #[arg(long)]
    pub validation: bool,

    /// Internal: run one measurement and print it as JSON (what the parent starts).
    #[arg(long, value_enum, hide = true)]
    pub child: Option<Role>,
}

/// The counts one run uses (`--quick` overrides the arguments).
#[derive(Clone, Debug, Serialize)]
struct Config {
    draws: Vec<usize>,
    frames: usize,
    warmup: usize,
    projections: usize,
    rounds: usize,
    pipelines: usize,
    calls: usize,
    repeats: usize,
    compare_op: CompareOp,
    validation: bool,
    instructions: bool,
}

impl Config {
    fn of(args: &BenchArgs) -> Config {
        if args.quick {
            Config {
                draws: vec![50, 200],
                frames: 3,
                warmup: 1,
                projections: args.projections.max(1),
                rounds: 1,
                pipelines: 4,
                calls: 2000,
                repeats: 1,
                compare_op: args.compare_op,
                validation: args.validation,
                instructions: false,
            }
        } else {
            Config {
                draws: args.draws.clone(),
                frames: args.frames.max(1),
                warmup: args.warmup,
                projections: args.projections.max(1),
                rounds: args.rounds.max(1),
                pipelines: args.pipelines.max(1),
                calls: args.calls.max(1),
                repeats: args.repeats.max(1),
                compare_op: args.compare_op,
                validation: args.validation,
                instructions: !args.no_instructions && !args.validation,
            }
        }
    }
}

pub fn run(args: &BenchArgs) -> Result<ExitCode> {
    match args.child {
        Some(role) => run_child(args, role),
        None => run_parent(args),
    }
}

/// A child: one measurement, printed as JSON on stdout.
fn run_child(args: &BenchArgs, role: Role) -> Result<ExitCode> {
    let config = Config::of(args);
    let gpu = Gpu::new(&GpuOptions {
        device: args.device.clone(),
        validation: args.validation,
        sync_validation: false,
        features: Features::default(),
        max_api_version: None,
    })?;
    let draws = config.draws.first().copied().unwrap_or(1000);
    let result = match role {
        Role::DrawStorm => serde_json::to_value(child::draw_storm(
            &gpu,
            draws,
            config.frames,
            config.warmup,
            config.projections,
        )?)?,
        Role::PipelineStorm => serde_json::to_value(child::pipeline_storm(
            &gpu,
            config.pipelines,
            config.repeats,
            args.repeated_code,
        )?)?,
        Role::Micro => serde_json::to_value(child::micro(&gpu, config.calls, config.repeats)?)?,
        Role::DepthCopy => {
            serde_json::to_value(child::depth_copy(&gpu, config.frames, config.warmup)?)?
        }
        Role::Smoke => {
            child::smoke(&gpu)?;
            json!({})
        }
    };
    let device = gpu.info.name.clone();
    let driver = gpu.info.driver();
    let log = gpu.validation_log();
    drop(gpu);
    let messages = log.count();
    let out = json!({
        "role": role,
        "device": device,
        "driver": driver,
        "validation_messages": messages,
        "result": result,
    });
    println!("{out}");
    Ok(if messages > 0 {
        ExitCode::from(2)
    } else {
        ExitCode::SUCCESS
    })
}

/// The allocator settings every child runs with (unless the caller set `GLIBC_TUNABLES`): heap
/// memory is neither trimmed nor mmapped below 256 MiB.
pub const MALLOC_TUNABLES: &str =
    "glibc.malloc.trim_threshold=268435456:glibc.malloc.mmap_threshold=268435456";

/// One measurement the parent runs in every variant.
#[derive(Clone, Debug, PartialEq)]
enum Job {
    /// Draws per frame, distinct projections among them.
    DrawStorm(usize, usize),
    /// The draw storm with revz's depth profile on (`REVZ_REPORT`: draws counted per command
    /// buffer, folded at submit, the file rewritten every 2 s).
    DrawStormProfiled(usize, usize),
    /// The draw storm with the counting layer (`tester/count-layer`) below revz, or alone for
    /// no layer: the commands that reach the driver per frame. Counts do not vary, so it runs
    /// in the first round only, and its timings are not used.
    DrawStormCounted(usize, usize),
    /// The draw storm under callgrind (valgrind's instruction counter), counting the
    /// recording thread's instructions in the measured frames only: a figure that varies far
    /// less than the frame times of a shared machine. A child's count is often a few percent
    /// high (docs/bench.md), so the child runs in the first [`INSTRUCTION_RUNS`] rounds and
    /// the smallest count is kept; with few frames, where `valgrind` is installed.
    DrawStormInstructions(usize, usize),
    Micro,
    /// The micro-benchmark under callgrind: each loop's instructions per call (every loop a
    /// part the child dumps), in the first [`MICRO_INSTRUCTION_RUNS`] rounds, with
    /// [`MICRO_INSTRUCTION_CALLS`] calls a loop.
    MicroInstructions,
    PipelineStorm,
    /// The pipeline storm with every vertex module of one code (revz analyzes it once).
    PipelineStormRepeated,
    DepthCopy,
    Smoke,
}

impl Job {
    fn name(&self) -> String {
        match self {
            Job::DrawStorm(n, p) => format!("draw-storm-{n}-p{p}"),
            Job::DrawStormProfiled(n, p) => format!("draw-storm-{n}-p{p}-report"),
            Job::DrawStormCounted(n, p) => format!("draw-storm-{n}-p{p}-counted"),
            Job::DrawStormInstructions(n, p) => format!("draw-storm-{n}-p{p}-instructions"),
            Job::Micro => "micro".into(),
            Job::MicroInstructions => "micro-instructions".into(),
            Job::PipelineStorm => "pipeline-storm".into(),
            Job::PipelineStormRepeated => "pipeline-storm-repeated-code".into(),
            Job::DepthCopy => "depth-copy".into(),
            Job::Smoke => "smoke".into(),
        }
    }
}

/// One child's figures.
#[derive(Clone, Debug, Serialize)]
struct Sample {
    job: String,
    variant: &'static str,
    round: usize,
    result: Value,
}

fn run_parent(args: &BenchArgs) -> Result<ExitCode> {
    let out = args.out.as_deref().context("--out is required")?;
    std::fs::create_dir_all(out)
        .with_context(|| format!("cannot create output directory {}", out.display()))?;
    let config = Config::of(args);
    let runner = Runner::locate(args.layer_dir.as_deref())?;
    let mut jobs: Vec<Job> = config
        .draws
        .iter()
        .map(|&n| Job::DrawStorm(n, config.projections))
        .collect();
    // The worst case for the precise path: the projection changes with every draw.
    let largest = config.draws.iter().copied().max().unwrap_or(0);
    if largest > 0 && config.projections < largest {
        jobs.push(Job::DrawStorm(largest, largest));
    }
    if largest > 0 {
        jobs.push(Job::DrawStormProfiled(largest, config.projections));
        jobs.push(Job::DrawStormCounted(largest, config.projections));
        if config.instructions && callgrind::has_valgrind() {
            jobs.push(Job::DrawStormInstructions(largest, config.projections));
            if config.projections < largest {
                jobs.push(Job::DrawStormInstructions(largest, largest));
            }
        } else if config.instructions {
            eprintln!("bench: valgrind not found: no instruction counts");
        }
    }
    jobs.push(Job::Micro);
    if config.instructions && callgrind::has_valgrind() {
        jobs.push(Job::MicroInstructions);
    }
    jobs.push(Job::PipelineStorm);
    jobs.push(Job::PipelineStormRepeated);
    jobs.push(Job::DepthCopy);
    if config.validation {
        jobs.push(Job::Smoke);
    }
    eprintln!(
        "bench: {} round(s) x {} variants x {} measurements{}",
        config.rounds,
        Variant::ALL.len(),
        jobs.len(),
        if config.validation {
            " (validation on: timings are not meaningful)"
        } else {
            ""
        }
    );
    let started = std::time::Instant::now();
    let mut samples = Vec::new();
    let mut device = String::new();
    let mut driver = String::new();
    for round in 0..config.rounds {
        for (j, job) in jobs.iter().enumerate() {
            let runs = match job {
                Job::DrawStormCounted(..) => 1,
                Job::DrawStormInstructions(..) => INSTRUCTION_RUNS,
                Job::MicroInstructions => MICRO_INSTRUCTION_RUNS,
                _ => config.rounds,
            };
            if round >= runs {
                continue;
            }
            let mut order = Variant::ALL.to_vec();
            let len = order.len();
            order.rotate_left((round + j) % len);
            for variant in order {
                let line = run_one(&runner, args.device.as_deref(), &config, job, variant)?;
                if device.is_empty() {
                    device = line["device"].as_str().unwrap_or("").to_owned();
                    driver = line["driver"].as_str().unwrap_or("").to_owned();
                }
                samples.push(Sample {
                    job: job.name(),
                    variant: variant.name(),
                    round,
                    result: line["result"].clone(),
                });
            }
        }
        eprintln!(
            "bench: round {}/{} done ({:.0} s)",
            round + 1,
            config.rounds,
            started.elapsed().as_secs_f64()
        );
    }
    let summary = summarize(&samples, &config, &device, &driver);
    let bench = json!({
        "device": device,
        "driver": driver,
        "config": config,
        // The children's allocator settings (see MALLOC_TUNABLES).
        "glibc_tunables": std::env::var("GLIBC_TUNABLES").unwrap_or_else(|_| MALLOC_TUNABLES.into()),
        "elapsed_s": started.elapsed().as_secs_f64(),
        "speed": summary,
        "samples": samples,
    });
    let bench_path = out.join("bench.json");
    std::fs::write(&bench_path, serde_json::to_string_pretty(&bench)? + "\n")
        .with_context(|| format!("cannot write {}", bench_path.display()))?;
    println!("wrote: {}", bench_path.display());
    let table = report::integrate(
        out,
        &device,
        &driver,
        config.compare_op.setting(),
        &summary,
        &config.draws,
    )?;
    println!("{table}");
    Ok(ExitCode::SUCCESS)
}

/// The demo's cost figure (`revz-tester demo`): the recording thread's instructions per frame
/// of a `draws`-draw storm (one camera) under callgrind, `runs` children per variant (no
/// layer, flip, complementary, infinite), two at a time, each variant's smallest count as a
/// ratio against no layer's. A child can read a few percent high (see [`INSTRUCTION_RUNS`]):
/// the bench keeps the smallest of five. `None`: valgrind is not installed.
pub fn quick_instruction_ratios(
    layer_dir: Option<&Path>,
    device: Option<&str>,
    draws: usize,
    runs: usize,
) -> Result<Option<Vec<(Variant, f64)>>> {
    if !callgrind::has_valgrind() {
        return Ok(None);
    }
    let runner = Runner::locate(layer_dir)?;
    let config = Config {
        draws: vec![draws],
        frames: INSTRUCTION_FRAMES,
        warmup: 1,
        projections: 1,
        rounds: 1,
        pipelines: 1,
        calls: 1,
        repeats: 1,
        compare_op: CompareOp::Dynamic,
        validation: false,
        instructions: true,
    };
    let job = Job::DrawStormInstructions(draws, 1);
    const VARIANTS: [Variant; 4] = [
        Variant::NoLayer,
        Variant::Flip,
        Variant::Complementary,
        Variant::Infinite,
    ];
    let children: Vec<Variant> = (0..runs.max(1)).flat_map(|_| VARIANTS).collect();
    // Two children at a time: the machines this runs on have two cores, and callgrind runs
    // its client on one.
    let counts: Vec<Result<f64>> = std::thread::scope(|scope| {
        children
            .chunks(2)
            .flat_map(|pair| {
                let handles: Vec<_> = pair
                    .iter()
                    .map(|&variant| {
                        let (runner, config, job) = (&runner, &config, &job);
                        scope.spawn(move || {
                            let line = run_one(runner, device, config, job, variant)?;
                            line["result"]["frame_instructions"]
                                .as_f64()
                                .context("no instruction count")
                        })
                    })
                    .collect();
                handles
                    .into_iter()
                    .map(|h| {
                        h.join()
                            .unwrap_or_else(|_| Err(anyhow::anyhow!("a child panicked")))
                    })
                    .collect::<Vec<_>>()
            })
            .collect()
    });
    let counts = counts.into_iter().collect::<Result<Vec<f64>>>()?;
    let smallest = |variant: Variant| {
        children
            .iter()
            .zip(&counts)
            .filter(|(&v, _)| v == variant)
            .map(|(_, &count)| count)
            .fold(f64::INFINITY, f64::min)
    };
    let without = smallest(Variant::NoLayer);
    Ok(Some(
        VARIANTS
            .iter()
            .map(|&variant| (variant, smallest(variant) / without))
            .collect(),
    ))
}

/// Runs one child and returns its JSON line.
fn run_one(
    runner: &Runner,
    device: Option<&str>,
    config: &Config,
    job: &Job,
    variant: Variant,
) -> Result<Value> {
    let role = match job {
        Job::DrawStorm(..)
        | Job::DrawStormProfiled(..)
        | Job::DrawStormCounted(..)
        | Job::DrawStormInstructions(..) => "draw-storm",
        Job::Micro | Job::MicroInstructions => "micro",
        Job::PipelineStorm | Job::PipelineStormRepeated => "pipeline-storm",
        Job::DepthCopy => "depth-copy",
        Job::Smoke => "smoke",
    };
    let (draws, projections) = match job {
        Job::DrawStorm(n, p)
        | Job::DrawStormProfiled(n, p)
        | Job::DrawStormCounted(n, p)
        | Job::DrawStormInstructions(n, p) => (*n, *p),
        _ => (1, 1),
    };
    // Under callgrind a frame takes some fifty times as long; a few frames give the count.
    let (frames, warmup) = match job {
        Job::DrawStormInstructions(..) => (INSTRUCTION_FRAMES, 1),
        _ => (config.frames, config.warmup),
    };
    // Under callgrind, fewer calls a loop and two repeats (each loop's smaller count kept).
    let (calls, repeats) = match job {
        Job::MicroInstructions => (MICRO_INSTRUCTION_CALLS, MICRO_INSTRUCTION_REPEATS),
        _ => (config.calls, config.repeats),
    };
    let mut owned: Vec<String> = vec![
        "bench".into(),
        "--child".into(),
        role.into(),
        "--draws".into(),
        draws.to_string(),
        "--frames".into(),
        frames.to_string(),
        "--warmup".into(),
        warmup.to_string(),
        "--projections".into(),
        projections.to_string(),
        "--pipelines".into(),
        config.pipelines.to_string(),
        "--calls".into(),
        calls.to_string(),
        "--repeats".into(),
        repeats.to_string(),
    ];
    if let Some(device) = device {
        owned.push("--device".into());
        owned.push(device.to_owned());
    }
    if config.validation {
        owned.push("--validation".into());
    }
    if let Job::PipelineStormRepeated = job {
        owned.push("--repeated-code".into());
    }
    let argv: Vec<&str> = owned.iter().map(String::as_str).collect();
    let profile_dir =
        std::env::temp_dir().join(format!("revz-bench-profile-{}", std::process::id()));
    let mut settings = vec![("REVZ_COMPARE_OP", config.compare_op.setting().to_owned())];
    if let Job::DrawStormProfiled(..) = job {
        std::fs::create_dir_all(&profile_dir).ok();
        settings.push(("REVZ_REPORT", profile_dir.display().to_string()));
    }
    let settings: Vec<(&str, &str)> = settings.iter().map(|(k, v)| (*k, v.as_str())).collect();
    let mut command = runner.command(variant, &argv, &settings);
    // Pipelines are created from scratch in every variant: no shader cache on disk.
    command.env("MESA_SHADER_CACHE_DISABLE", "true");
    if std::env::var_os("GLIBC_TUNABLES").is_none() {
        // glibc's adaptive heap trimming and mmap threshold return lavapipe's per-frame command
        // memory to the kernel and fault it back in, at a rate that depends on the heap's
        // layout (and so on whatever else is loaded): measured, a million page faults in a
        // 10k-draw child without any layer, and 1.4x between runs of the same binary. Fixed
        // thresholds make every variant's allocator behave alike; a GLIBC_TUNABLES of the
        // caller's is kept.
        command.env("GLIBC_TUNABLES", MALLOC_TUNABLES);
    }
    let counts = std::env::temp_dir().join(format!(
        "revz-bench-counts-{}-{}.txt",
        std::process::id(),
        variant.name()
    ));
    if let Job::DrawStormCounted(..) = job {
        // Below revz (the first layer named is the application's side), or alone.
        let layers = match variant.mode() {
            Some(_) => format!("{}:{COUNT_LAYER}", crate::variants::LAYER_NAME),
            None => COUNT_LAYER.to_owned(),
        };
        // The loader stacks explicit layers in the order it finds their manifests: revz's
        // directory first puts the counting layer below it.
        let count_dir = runner.layer_dir().join("../count");
        let mut path = std::ffi::OsString::from(runner.layer_dir());
        path.push(":");
        path.push(&count_dir);
        command
            .env("VK_ADD_LAYER_PATH", path)
            .env("VK_INSTANCE_LAYERS", layers)
            .env("REVZ_COUNT_OUT", &counts);
    }
    let instructions_out = std::env::temp_dir().join(format!(
        "revz-bench-callgrind-{}-{}.out",
        std::process::id(),
        variant.name()
    ));
    if let Job::DrawStormInstructions(..) = job {
        command = callgrind::under_callgrind(&command, &instructions_out);
    }
    if let Job::MicroInstructions = job {
        command = callgrind::under_callgrind_dumps(&command, &instructions_out);
    }
    if std::env::var_os("REVZ_BENCH_ASLR").is_none() {
        // The same addresses in every child: caches and TLBs see the same layout in every
        // variant, so rounds differ by what the variants do, not by where each run's heap and
        // libraries landed. Set on the command that runs, after the callgrind wrap above (a
        // `pre_exec` is not copied; the personality is inherited across valgrind's exec).
        use std::os::unix::process::CommandExt;
        // SAFETY: `personality` is async-signal-safe and touches no memory of this process.
        unsafe {
            command.pre_exec(|| {
                libc::personality(libc::ADDR_NO_RANDOMIZE as libc::c_ulong);
                Ok(())
            });
        }
    }
    let output = command
        .output()
        .with_context(|| format!("cannot start the {} child", job.name()))?;
    let stdout = String::from_utf8_lossy(&output.stdout);
    if !output.status.success() {
        bail!(
            "the {} child ({}) failed ({}):\n{}{}",
            job.name(),
            variant.name(),
            output.status,
            String::from_utf8_lossy(&output.stderr),
            stdout
        );
    }
    let line = stdout
        .lines()
        .rev()
        .find(|l| l.starts_with('{'))
        .with_context(|| format!("the {} child printed no JSON: {stdout}", job.name()))?;
    let mut value: Value =
        serde_json::from_str(line).with_context(|| format!("the {} child's JSON", job.name()))?;
    if let Job::DrawStormCounted(..) = job {
        let text = std::fs::read_to_string(&counts).with_context(|| {
            format!(
                "the counting layer wrote no {} (is {COUNT_LAYER} built? `cargo xtask build`)",
                counts.display()
            )
        })?;
        let _ = std::fs::remove_file(&counts);
        value["result"]["driver_calls"] = last_frame_calls(&text)?;
    }
    if let Job::DrawStormInstructions(..) = job {
        let text = std::fs::read_to_string(&instructions_out)
            .with_context(|| format!("callgrind wrote no {}", instructions_out.display()))?;
        let _ = std::fs::remove_file(&instructions_out);
        let total = callgrind::callgrind_total(&text)?;
        value["result"]["frame_instructions"] = json!(total as f64 / frames as f64);
    }
    if let Job::MicroInstructions = job {
        let loops = child::MICRO_LOOPS.len();
        let totals = callgrind::dumped_totals(&instructions_out, loops * repeats)?;
        for (index, name) in child::MICRO_LOOPS.iter().enumerate() {
            let smallest = totals
                .iter()
                .skip(index)
                .step_by(loops)
                .copied()
                .min()
                .unwrap_or(0);
            value["result"][format!("{name}_instructions")] =
                json!(smallest as f64 / calls.max(1) as f64);
        }
    }
    Ok(value)
}

/// Children of [`Job::MicroInstructions`] per variant (the first rounds'); each loop's
/// smallest count per call is kept.
const MICRO_INSTRUCTION_RUNS: usize = 3;

/// Calls per loop of [`Job::MicroInstructions`] (callgrind runs some fifty times slower).
const MICRO_INSTRUCTION_CALLS: usize = 10_000;

/// Repeats of each loop in one [`Job::MicroInstructions`] child.
const MICRO_INSTRUCTION_REPEATS: usize = 2;

/// Measured frames of [`Job::DrawStormInstructions`] (after one warm-up frame).
const INSTRUCTION_FRAMES: usize = 3;

/// Children of [`Job::DrawStormInstructions`] per variant (the first rounds'), of which the
/// smallest count is kept. Measured (lavapipe, release build, the bench of 2026-12-04): 9 of
/// 30 children read 2.5-6.2% above their variant's smallest (58-86 more instructions per
/// draw, in no layer's children as in revz's: work in the driver or the allocator that some
/// processes do, whatever the layer), the others within 0.05% of it, and each variant's
/// smallest gave the previous day's lower ratios to 3-4 places. With a high child in three,
/// five children leave about 1 chance in 400 that a variant's smallest is high.
const INSTRUCTION_RUNS: usize = 5;

/// The benchmark's counting layer (`tester/count-layer`).
const COUNT_LAYER: &str = "VK_LAYER_REVZ_count";

/// The commands the last submission's frame sent to the driver, from the counting layer's
/// file (a line of cumulative `name=count` pairs per submission), with their `total`.
fn last_frame_calls(text: &str) -> Result<Value> {
    let parse = |line: &str| -> Result<Vec<(String, u64)>> {
        line.split_whitespace()
            .map(|pair| {
                let (name, count) = pair.split_once('=').context("a name=count pair")?;
                Ok((name.to_owned(), count.parse()?))
            })
            .collect()
    };
    let lines: Vec<&str> = text.lines().filter(|l| !l.trim().is_empty()).collect();
    let [.., before, last] = lines.as_slice() else {
        bail!("the counting layer saw fewer than two submissions");
    };
    let (before, last) = (parse(before)?, parse(last)?);
    let mut calls = serde_json::Map::new();
    let mut total = 0;
    for ((name, was), (_, is)) in before.iter().zip(&last) {
        let frame = is - was;
        total += frame;
        calls.insert(name.clone(), json!(frame));
    }
    calls.insert("total".into(), json!(total));
    Ok(Value::Object(calls))
}

/// The figures of `job` in `variant`, round by round (`None` where missing).
fn per_round<'a>(
    samples: &'a [Sample],
    job: &str,
    variant: &str,
    rounds: usize,
) -> Vec<Option<&'a Value>> {
    (0..rounds)
        .map(|r| {
            samples
                .iter()
                .find(|s| s.job == job && s.variant == variant && s.round == r)
                .map(|s| &s.result)
        })
        .collect()
}

/// The per-round values of `f(variant's figure, no layer's figure)`, for the rounds that have
/// both.
fn paired_rounds(
    samples: &[Sample],
    job: &str,
    variant: &str,
    rounds: usize,
    key: &str,
    f: impl Fn(f64, f64) -> f64,
) -> Vec<f64> {
    let with = per_round(samples, job, variant, rounds);
    let without = per_round(samples, job, Variant::NoLayer.name(), rounds);
    with.iter()
        .zip(&without)
        .filter_map(|(w, n)| Some(f((*w)?.get(key)?.as_f64()?, (*n)?.get(key)?.as_f64()?)))
        .collect()
}

/// The median over rounds of what a read twin refresh adds to the frame (`key`, a refresh
/// frame's wall time, against no layer's) in units of a native copy of the same bytes: `copies`
/// times no layer's copy of one single-sample megapixel (its copy frame less its refresh frame,
/// which is the clear alone). `None` without data.
fn refresh_in_native_copies(
    samples: &[Sample],
    job: &str,
    variant: &str,
    rounds: usize,
    key: &str,
    copies: f64,
) -> Option<f64> {
    let with = per_round(samples, job, variant, rounds);
    let without = per_round(samples, job, Variant::NoLayer.name(), rounds);
    let values: Vec<f64> = with
        .iter()
        .zip(&without)
        .filter_map(|(w, n)| {
            let figure = |sample: &Option<&Value>, key: &str| sample.as_ref()?.get(key)?.as_f64();
            let added = figure(w, key)? - figure(n, key)?;
            let copy = copies * (figure(n, "copy_wall_ns")? - figure(n, "refresh_wall_ns")?);
            (copy > 0.0).then(|| added / copy)
        })
        .collect();
    (!values.is_empty()).then(|| child::median(&values))
}

/// The median over rounds of `f(variant's figure, no layer's figure)`, `None` without data.
fn paired(
    samples: &[Sample],
    job: &str,
    variant: &str,
    rounds: usize,
    key: &str,
    f: impl Fn(f64, f64) -> f64,
) -> Option<f64> {
    let values = paired_rounds(samples, job, variant, rounds, key, f);
    (!values.is_empty()).then(|| child::median(&values))
}

/// The smallest and largest per-round value of `f(variant's figure, no layer's figure)`:
/// the spread beside [`paired`]'s median. `None` without data.
fn paired_spread(
    samples: &[Sample],
    job: &str,
    variant: &str,
    rounds: usize,
    key: &str,
    f: impl Fn(f64, f64) -> f64,
) -> Option<[f64; 2]> {
    spread(&paired_rounds(samples, job, variant, rounds, key, f))
}

/// `[min, max]` of finite values, `None` when there is none.
fn spread(values: &[f64]) -> Option<[f64; 2]> {
    let finite = values.iter().copied().filter(|v| v.is_finite());
    let min = finite.clone().reduce(f64::min)?;
    let max = finite.reduce(f64::max)?;
    Some([min, max])
}

/// The median over rounds of a variant's own figure.
fn own(samples: &[Sample], job: &str, variant: &str, rounds: usize, key: &str) -> Option<f64> {
    let values: Vec<f64> = per_round(samples, job, variant, rounds)
        .into_iter()
        .filter_map(|v| v?.get(key)?.as_f64())
        .collect();
    (!values.is_empty()).then(|| child::median(&values))
}

/// The smallest and largest instruction count of `variant`'s children of `job` (separate
/// children, not paired by round), `None` without data.
fn instruction_spread(
    samples: &[Sample],
    job: &str,
    variant: &str,
    rounds: usize,
) -> Option<[f64; 2]> {
    let values: Vec<f64> = per_round(samples, job, variant, rounds)
        .into_iter()
        .filter_map(|r| r?.get("frame_instructions")?.as_f64())
        .collect();
    spread(&values)
}

/// `variant`'s smallest instruction count of `job` against no layer's smallest
/// ([`INSTRUCTION_RUNS`]: a child's count is never below its variant's, often above).
fn instruction_ratio(samples: &[Sample], job: &str, variant: &str, rounds: usize) -> Option<f64> {
    let smallest =
        |variant: &str| instruction_spread(samples, job, variant, rounds).map(|[min, _]| min);
    let without = smallest(Variant::NoLayer.name())?;
    (without > 0.0).then_some(smallest(variant)? / without)
}

/// `variant`'s smallest `field` over the children of `job` less no layer's smallest (a count
/// per call: a child's count is never below its variant's, sometimes above).
fn smallest_difference(samples: &[Sample], job: &str, variant: &str, field: &str) -> Option<f64> {
    let smallest = |variant: &str| {
        samples
            .iter()
            .filter(|s| s.job == job && s.variant == variant)
            .filter_map(|s| s.result.get(field)?.as_f64())
            .reduce(f64::min)
    };
    Some(smallest(variant)? - smallest(Variant::NoLayer.name())?)
}

/// One speed row per variant (mode), in `report.json`'s `speed` schema.
fn summarize(samples: &[Sample], config: &Config, device: &str, driver: &str) -> Vec<Value> {
    let rounds = config.rounds;
    let largest = config.draws.iter().copied().max().unwrap_or(0);
    let storm = |n: usize| Job::DrawStorm(n, config.projections).name();
    let varying = Job::DrawStorm(largest, largest).name();
    let profiled = Job::DrawStormProfiled(largest, config.projections).name();
    let ratio = |a: f64, b: f64| if b > 0.0 { a / b } else { f64::NAN };
    let diff = |a: f64, b: f64| a - b;
    let pipe = Job::PipelineStorm.name();
    let pipe_repeated = Job::PipelineStormRepeated.name();
    let micro = Job::Micro.name();
    let micro_counted = Job::MicroInstructions.name();
    let copy = Job::DepthCopy.name();
    let counted_storm = Job::DrawStormInstructions(largest, config.projections).name();
    let counted_varying = Job::DrawStormInstructions(largest, largest).name();
    let megapixels = f64::from(child::DEPTH_COPY_SIDE * child::DEPTH_COPY_SIDE) / 1e6;
    Variant::ALL
        .iter()
        .map(|variant| {
            let v = variant.name();
            let own_spread = |job: &str| instruction_spread(samples, job, v, rounds);
            let smallest = |job: &str| own_spread(job).map(|[min, _]| min);
            let smallest_ratio = |job: &str| instruction_ratio(samples, job, v, rounds);
            let mut by_draws = BTreeMap::new();
            let mut cpu_ns = BTreeMap::new();
            let mut wall_ns = BTreeMap::new();
            for &n in &config.draws {
                let job = storm(n);
                by_draws.insert(
                    n.to_string(),
                    json!({
                        "frame_cpu_ratio": paired(samples, &job, v, rounds, "frame_cpu_ns", ratio),
                        "frame_wall_ratio": paired(samples, &job, v, rounds, "frame_wall_ns", ratio),
                    }),
                );
                cpu_ns.insert(n.to_string(), own(samples, &job, v, rounds, "frame_cpu_ns"));
                wall_ns.insert(n.to_string(), own(samples, &job, v, rounds, "frame_wall_ns"));
            }
            let big = storm(largest);
            let counted = Job::DrawStormCounted(largest, config.projections).name();
            let calls = samples
                .iter()
                .find(|s| s.job == counted && s.variant == v)
                .map(|s| s.result["driver_calls"].clone())
                .unwrap_or(Value::Null);
            json!({
                "device": device,
                "driver": driver,
                "mode": v,
                "draws": largest,
                "frame_cpu_ratio": paired(samples, &big, v, rounds, "frame_cpu_ns", ratio),
                "projections": config.projections,
                "frame_cpu_ratio_projection_per_draw": paired(samples, &varying, v, rounds, "frame_cpu_ns", ratio),
                "frame_cpu_ratio_with_report": paired(samples, &profiled, v, rounds, "frame_cpu_ns", ratio),
                "frame_wall_ratio": paired(samples, &big, v, rounds, "frame_wall_ns", ratio),
                // The recording thread's instructions per measured frame (callgrind, the
                // smallest of the first rounds' children, and their spread), against no
                // layer's.
                "frame_instructions_ratio": smallest_ratio(&counted_storm),
                "frame_instructions_ratio_projection_per_draw": smallest_ratio(&counted_varying),
                "frame_instructions": smallest(&counted_storm),
                "frame_instructions_spread": own_spread(&counted_storm),
                "frame_instructions_projection_per_draw": smallest(&counted_varying),
                "frame_instructions_projection_per_draw_spread": own_spread(&counted_varying),
                "frame_instructions_runs": per_round(samples, &counted_storm, v, rounds).iter().flatten().count(),
                "pipeline_creation_ratio": paired(samples, &pipe, v, rounds, "create_wall_ns", ratio),
                "pipeline_creation_cpu_ratio": paired(samples, &pipe, v, rounds, "create_cpu_ns", ratio),
                "pipeline_creation_ratio_repeated_code": paired(samples, &pipe_repeated, v, rounds, "create_wall_ns", ratio),
                "ns_per_push_constant": paired(samples, &micro, v, rounds, "push_constant_ns", diff),
                "ns_per_push_one_camera": paired(samples, &micro, v, rounds, "push_one_camera_ns", diff),
                "ns_per_draw": paired(samples, &micro, v, rounds, "draw_ns", diff),
                "ns_per_bind": paired(samples, &micro, v, rounds, "bind_ns", diff),
                // The micro-benchmark's calls under callgrind: instructions per call more than
                // no layer's (each variant's smallest count per loop).
                "instructions_per_push_one_camera": smallest_difference(samples, &micro_counted, v, "push_one_camera_instructions"),
                "instructions_per_push_new_camera": smallest_difference(samples, &micro_counted, v, "push_instructions"),
                "instructions_per_draw": smallest_difference(samples, &micro_counted, v, "draw_instructions"),
                "instructions_per_bind": smallest_difference(samples, &micro_counted, v, "bind_instructions"),
                // A converted depth copy: the frame's wall time against no layer, and what it
                // adds per copy and per megapixel.
                "depth_copy_wall_ratio": paired(samples, &copy, v, rounds, "copy_wall_ns", ratio),
                "depth_copy_extra_ms": paired(samples, &copy, v, rounds, "copy_wall_ns", |a, b| (a - b) / 1e6),
                "depth_copy_extra_ms_per_megapixel": paired(samples, &copy, v, rounds, "copy_wall_ns", |a, b| (a - b) / 1e6 / megapixels),
                "depth_copy_wall_ns": own(samples, &copy, v, rounds, "copy_wall_ns"),
                // The same of a D24S8 image (promoted in the precise modes: its copy converts
                // float32 storage back to the application's D24).
                "depth_copy_d24s8_wall_ratio": paired(samples, &copy, v, rounds, "copy_d24s8_wall_ns", ratio),
                "depth_copy_d24s8_extra_ms_per_megapixel": paired(samples, &copy, v, rounds, "copy_d24s8_wall_ns", |a, b| (a - b) / 1e6 / megapixels),
                "depth_copy_d24s8_wall_ns": own(samples, &copy, v, rounds, "copy_d24s8_wall_ns"),
                // A read twin refresh of the same megapixel (issue #39): what it adds to the
                // frame, and that in units of a native copy of the same bytes (no layer's copy
                // frame less its frame without the copy, in the same round).
                "depth_refresh_extra_ms_per_megapixel": paired(samples, &copy, v, rounds, "refresh_wall_ns", |a, b| (a - b) / 1e6 / megapixels),
                "depth_refresh_in_native_copies": refresh_in_native_copies(samples, &copy, v, rounds, "refresh_wall_ns", 1.0),
                // The same of a 4-sample image (a multisampled twin, refreshed per sample by a
                // compute pass): per megapixel of pixels, and in native copies of its bytes
                // (four single-sample megapixels).
                "depth_refresh_msaa_extra_ms_per_megapixel": paired(samples, &copy, v, rounds, "refresh_msaa_wall_ns", |a, b| (a - b) / 1e6 / megapixels),
                "depth_refresh_msaa_in_native_copies": refresh_in_native_copies(samples, &copy, v, rounds, "refresh_msaa_wall_ns", f64::from(child::DEPTH_COPY_MSAA_SAMPLES)),
                "bytes_per_pipeline": paired(samples, &pipe, v, rounds, "heap_per_pipeline", diff),
                "bytes_per_command_buffer": paired(samples, &big, v, rounds, "heap_per_command_buffer", diff),
                "heap_growth_per_frame": paired(samples, &big, v, rounds, "heap_growth_per_frame", diff),
                "heap_growth_per_frame_own": own(samples, &big, v, rounds, "heap_growth_per_frame"),
                "peak_rss_draw_storm": own(samples, &big, v, rounds, "vm_hwm"),
                "peak_rss_delta_draw_storm": paired(samples, &big, v, rounds, "vm_hwm", diff),
                "peak_rss_pipeline_storm": own(samples, &pipe, v, rounds, "vm_hwm"),
                "peak_rss_delta_pipeline_storm": paired(samples, &pipe, v, rounds, "vm_hwm", diff),
                "frame_cpu_ns": cpu_ns,
                "frame_wall_ns": wall_ns,
                "pipeline_creation_ns": own(samples, &pipe, v, rounds, "create_wall_ns"),
                "pipelines": config.pipelines,
                "push_constant_ns": own(samples, &micro, v, rounds, "push_constant_ns"),
                "push_one_camera_ns": own(samples, &micro, v, rounds, "push_one_camera_ns"),
                "draw_ns": own(samples, &micro, v, rounds, "draw_ns"),
                "bind_ns": own(samples, &micro, v, rounds, "bind_ns"),
                "by_draws": by_draws,
                "rounds": rounds,
                // What reached the driver in the last frame of the largest storm (the
                // counting layer below revz): per command, and in total.
                "driver_calls_per_frame": calls["total"].clone(),
                "driver_calls_by_command": calls,
                // [min, max] over rounds of the per-round figures whose median is above.
                "spread": {
                    "frame_cpu_ratio": paired_spread(samples, &big, v, rounds, "frame_cpu_ns", ratio),
                    "frame_cpu_ratio_projection_per_draw": paired_spread(samples, &varying, v, rounds, "frame_cpu_ns", ratio),
                    "pipeline_creation_ratio": paired_spread(samples, &pipe, v, rounds, "create_wall_ns", ratio),
                    "pipeline_creation_ratio_repeated_code": paired_spread(samples, &pipe_repeated, v, rounds, "create_wall_ns", ratio),
                    "ns_per_push_constant": paired_spread(samples, &micro, v, rounds, "push_constant_ns", diff),
                    "ns_per_push_one_camera": paired_spread(samples, &micro, v, rounds, "push_one_camera_ns", diff),
                    "ns_per_draw": paired_spread(samples, &micro, v, rounds, "draw_ns", diff),
                    "ns_per_bind": paired_spread(samples, &micro, v, rounds, "bind_ns", diff),
                    "depth_copy_wall_ratio": paired_spread(samples, &copy, v, rounds, "copy_wall_ns", ratio),
                    "depth_copy_d24s8_wall_ratio": paired_spread(samples, &copy, v, rounds, "copy_d24s8_wall_ns", ratio),
                },
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_last_frames_calls_are_the_difference_of_the_last_two_submissions() {
        let text = "vkCmdDraw=0 vkCmdBindPipeline=1\nvkCmdDraw=10 vkCmdBindPipeline=4\n\
                    vkCmdDraw=20 vkCmdBindPipeline=6\n";
        let calls = last_frame_calls(text).unwrap();
        assert_eq!(calls["vkCmdDraw"], 10);
        assert_eq!(calls["vkCmdBindPipeline"], 2);
        assert_eq!(calls["total"], 12);
        assert!(last_frame_calls("vkCmdDraw=1\n").is_err());
        assert!(last_frame_calls("vkCmdDraw=1\nvkCmdDraw\n").is_err());
    }

    #[test]
    fn a_micro_loops_instructions_are_each_variants_smallest_less_no_layers() {
        let sample = |variant, round, push: f64| Sample {
            job: "micro-instructions".into(),
            variant,
            round,
            result: json!({ "push_instructions": push }),
        };
        let samples = [
            sample("none", 0, 500.0),
            sample("none", 1, 480.0),
            sample("flip", 0, 530.0),
            sample("flip", 1, 560.0),
        ];
        let difference =
            smallest_difference(&samples, "micro-instructions", "flip", "push_instructions");
        assert_eq!(difference, Some(50.0));
        assert_eq!(
            smallest_difference(
                &samples,
                "micro-instructions",
                "infinite",
                "push_instructions"
            ),
            None
        );
    }

    #[test]
    fn the_instruction_ratio_is_of_each_variants_smallest_count() {
        let sample = |variant, round, count: f64| Sample {
            job: "storm".into(),
            variant,
            round,
            result: json!({ "frame_instructions": count }),
        };
        // No layer's second child and flip's first read high.
        let samples = [
            sample("none", 0, 100.0),
            sample("none", 1, 104.0),
            sample("none", 2, 100.0),
            sample("flip", 0, 112.0),
            sample("flip", 1, 106.0),
            sample("flip", 2, 106.0),
        ];
        assert_eq!(
            instruction_spread(&samples, "storm", "flip", 3),
            Some([106.0, 112.0])
        );
        let ratio = instruction_ratio(&samples, "storm", "flip", 3).unwrap();
        assert!((ratio - 1.06).abs() < 1e-12, "{ratio}");
        assert_eq!(instruction_ratio(&samples, "storm", "none", 3), Some(1.0));
        assert_eq!(instruction_ratio(&samples, "other", "flip", 3), None);
    }

    #[test]
    fn the_spread_is_the_finite_extremes() {
        assert_eq!(spread(&[1.2, f64::NAN, 0.9, 1.5]), Some([0.9, 1.5]));
        assert_eq!(spread(&[f64::NAN]), None);
        assert_eq!(spread(&[]), None);
    }
}
