//! Fuzz targets that run on stable Rust, as ordinary tests, for a bounded time.
//!
//! Each target ([`spirv`]: the vertex-stage analysis and the fragment rewrite; [`chain`]: the
//! `pNext` chain splice; [`config`]: the config sources) is one test that mutates inputs from a
//! small corpus (committed seeds under `layer/fuzz-seeds/`, modules compiled at test time,
//! generated inputs) and checks each result against the target's invariants. There is no
//! coverage instrumentation (that needs nightly): an input joins the corpus when its outcome
//! (a hash the target computes from what the code answered) is new.
//!
//! Environment:
//! - `REVZ_FUZZ_SECONDS`: how long each target runs (default 1; CI runs 30).
//! - `REVZ_FUZZ_SEED`: the run's seed (default 1); a run is deterministic given its seed,
//!   apart from how many cases fit in the time.
//! - `REVZ_FUZZ_CASE_SECONDS`: the time one case may take before it counts as a hang
//!   (default 20).
//! - `REVZ_FUZZ_DIR`: where failing inputs are written (default `target/fuzz`).
//! - `REVZ_FUZZ_REPLAY`: a file written by a failure: only the target it names (its file
//!   name starts with the target's) runs, on that input alone.
//!
//! A failure (an invariant broken, a panic escaping the code under test, a case running past
//! its limit) writes the input to `<dir>/<target>-<hash>.<ext>` and fails the test with that
//! path. An input that kills the process (a stack overflow, an abort) is left in
//! `<dir>/<target>.in-flight`, written before each case.

mod chain;
mod config;
mod spirv;

use std::cell::RefCell;
use std::collections::{BTreeMap, HashSet};
use std::hash::{Hash, Hasher};
use std::io::Write as _;
use std::os::unix::fs::FileExt as _;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::PathBuf;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Once};
use std::time::{Duration, Instant};

/// A small, fast generator (SplitMix64): the fuzzers need speed and reproducibility, not
/// statistical quality.
#[derive(Clone, Debug)]
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Rng {
        Rng(seed)
    }

    pub fn u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    pub fn u32(&mut self) -> u32 {
        (self.u64() >> 32) as u32
    }

    /// A number below `n` (0 when `n` is 0).
    pub fn below(&mut self, n: usize) -> usize {
        if n == 0 {
            0
        } else {
            (self.u64() % n as u64) as usize
        }
    }

    /// True once in `n` times.
    pub fn one_in(&mut self, n: usize) -> bool {
        self.below(n) == 0
    }

    pub fn pick<'a, T>(&mut self, items: &'a [T]) -> &'a T {
        &items[self.below(items.len())]
    }

    pub fn fill(&mut self, bytes: &mut [u8]) {
        for chunk in bytes.chunks_mut(8) {
            let word = self.u64().to_le_bytes();
            chunk.copy_from_slice(&word[..chunk.len()]);
        }
    }
}

/// A 64-bit hash of anything hashable (the outcome features, failure file names).
pub fn hash_of(value: &impl Hash) -> u64 {
    let mut hasher = std::collections::hash_map::DefaultHasher::new();
    value.hash(&mut hasher);
    hasher.finish()
}

/// A named counter a target keeps (how often a check ran), reported and asserted on.
#[derive(Debug)]
pub struct Counter {
    pub name: &'static str,
    value: AtomicU64,
}

impl Counter {
    pub const fn new(name: &'static str) -> Counter {
        Counter {
            name,
            value: AtomicU64::new(0),
        }
    }

    pub fn add(&self) {
        self.value.fetch_add(1, Ordering::Relaxed);
    }

    pub fn get(&self) -> u64 {
        self.value.load(Ordering::Relaxed)
    }
}

/// One fuzz target.
pub struct Target {
    pub name: &'static str,
    /// The extension of the files its failing inputs are written to.
    pub extension: &'static str,
    /// The starting corpus; each seed is checked first.
    pub seeds: Vec<Vec<u8>>,
    /// Turns `input` (a copy of a corpus entry) into the next case; the corpus is there for
    /// splices.
    pub mutate: fn(&mut Rng, &[Vec<u8>], &mut Vec<u8>),
    /// Runs one case: `Ok(outcome)` (a hash of what the code answered: a new one keeps the
    /// input in the corpus), or `Err(which invariant broke)`.
    pub check: fn(&[u8]) -> Result<u64, String>,
    /// Inputs longer than this are cut.
    pub max_len: usize,
    pub counters: &'static [&'static Counter],
}

/// What a run did.
#[derive(Debug)]
pub struct Report {
    /// Whether this was a replay (or a target skipped by one): nothing was fuzzed.
    pub replay: bool,
    pub cases: u64,
    pub seconds: f64,
    pub corpus: usize,
    pub outcomes: usize,
    /// Panics caught inside the code under test (naga's, which `crate::shader::analysis` turns into
    /// `Unreadable`), by location.
    pub caught_panics: BTreeMap<String, u64>,
}

fn env_number<T: std::str::FromStr>(name: &str, default: T) -> T {
    match std::env::var(name) {
        Ok(text) => text
            .trim()
            .parse()
            .unwrap_or_else(|_| panic!("{name}={text} is not a number")),
        Err(_) => default,
    }
}

fn failure_dir() -> PathBuf {
    std::env::var_os("REVZ_FUZZ_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| {
            let target = std::env::var_os("CARGO_TARGET_DIR")
                .map(PathBuf::from)
                .unwrap_or_else(|| {
                    let layer = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
                    layer.parent().unwrap_or(layer).join("target")
                });
            target.join("fuzz")
        })
}

thread_local! {
    /// The last panic on this fuzz thread, and every caught panic's location.
    static PANICS: RefCell<(String, BTreeMap<String, u64>)> = RefCell::default();
}

/// Panics on the fuzz threads are recorded, not printed (naga's, caught by the layer, would
/// flood the output); every other thread keeps the default hook.
fn install_panic_hook() {
    static HOOK: Once = Once::new();
    HOOK.call_once(|| {
        let previous = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            let fuzz_thread = std::thread::current()
                .name()
                .is_some_and(|name| name.starts_with("fuzz-"));
            if !fuzz_thread {
                return previous(info);
            }
            let location = info
                .location()
                .map_or("?".to_owned(), |l| format!("{}:{}", l.file(), l.line()));
            PANICS.with(|panics| {
                let mut panics = panics.borrow_mut();
                panics.0 = info.to_string();
                *panics.1.entry(location).or_default() += 1;
            });
        }));
    });
}

/// Where the input of the case being run is kept, for a process that dies in it.
struct InFlight {
    file: std::fs::File,
    path: PathBuf,
}

impl InFlight {
    fn create(path: PathBuf) -> InFlight {
        let file = std::fs::File::create(&path)
            .unwrap_or_else(|e| panic!("cannot create {}: {e}", path.display()));
        InFlight { file, path }
    }

    fn write(&self, input: &[u8]) {
        // Best effort: a failed write only loses the record of a crash.
        let _ = self.file.set_len(0);
        let _ = self.file.write_all_at(input, 0);
    }
}

/// Writes a failing input and returns its path.
fn write_failure(dir: &std::path::Path, target: &Target, input: &[u8]) -> PathBuf {
    let path = dir.join(format!(
        "{}-{:016x}.{}",
        target.name,
        hash_of(&input),
        target.extension
    ));
    let written = std::fs::File::create(&path).and_then(|mut file| file.write_all(input));
    if let Err(e) = written {
        eprintln!("fuzz {}: cannot write {}: {e}", target.name, path.display());
    }
    path
}

fn fail(dir: &std::path::Path, target: &Target, input: &[u8], why: &str) -> ! {
    let path = write_failure(dir, target, input);
    panic!(
        "fuzz target {name} failed: {why}\ninput ({len} bytes) written to {path}\nreplay: \
         REVZ_FUZZ_REPLAY={path} cargo test -p revz-layer fuzz::{name}",
        name = target.name,
        len = input.len(),
        path = path.display()
    );
}

/// Runs one case, catching a panic that escapes the code under test.
fn run_case(target: &Target, input: &[u8]) -> Result<u64, String> {
    PANICS.with(|panics| panics.borrow_mut().0.clear());
    match catch_unwind(AssertUnwindSafe(|| (target.check)(input))) {
        Ok(result) => result,
        Err(_) => Err(format!(
            "panic: {}",
            PANICS.with(|panics| panics.borrow().0.clone())
        )),
    }
}

/// State the fuzz thread shares with the watchdog.
struct Shared {
    /// Milliseconds since the start at which the current case began; `IDLE` between cases.
    case_started: AtomicU64,
}

const IDLE: u64 = u64::MAX;
/// The most inputs a corpus keeps.
const MAX_CORPUS: usize = 512;

/// How a run goes (from the environment, see the module docs).
#[derive(Clone, Debug)]
struct Settings {
    seconds: f64,
    seed: u64,
    case_limit: Duration,
    dir: PathBuf,
}

/// Runs `target` for `REVZ_FUZZ_SECONDS` (or on `REVZ_FUZZ_REPLAY`) and prints its report;
/// panics on a failure.
pub fn run(target: Target) -> Report {
    let settings = Settings {
        seconds: env_number("REVZ_FUZZ_SECONDS", 1.0),
        seed: env_number("REVZ_FUZZ_SEED", 1),
        case_limit: Duration::from_secs_f64(env_number("REVZ_FUZZ_CASE_SECONDS", 20.0)),
        dir: failure_dir(),
    };
    let name = target.name;

    if let Some(mut replay) = std::env::var_os("REVZ_FUZZ_REPLAY").map(PathBuf::from) {
        if replay.is_relative() && !replay.exists() {
            // Relative to the workspace (tests run in `layer/`).
            replay = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("..")
                .join(replay);
        }
        let file_name = replay.file_name().unwrap_or_default().to_string_lossy();
        if !file_name.starts_with(&format!("{name}-")) {
            eprintln!("fuzz {name}: skipped (replaying {})", replay.display());
            return Report {
                replay: true,
                cases: 0,
                seconds: 0.0,
                corpus: 0,
                outcomes: 0,
                caught_panics: BTreeMap::new(),
            };
        }
        let input = std::fs::read(&replay)
            .unwrap_or_else(|e| panic!("cannot read {}: {e}", replay.display()));
        install_panic_hook();
        let outcome = std::thread::Builder::new()
            .name(format!("fuzz-{name}"))
            .spawn(move || run_case(&target, &input))
            .expect("spawn")
            .join()
            .expect("the case is run under catch_unwind");
        match outcome {
            Ok(_) => {
                eprintln!("fuzz {name}: {} passes", replay.display());
                return Report {
                    replay: true,
                    cases: 1,
                    seconds: 0.0,
                    corpus: 0,
                    outcomes: 1,
                    caught_panics: BTreeMap::new(),
                };
            }
            Err(why) => panic!("fuzz target {name}: {} fails: {why}", replay.display()),
        }
    }

    run_with(target, &settings)
}

fn run_with(target: Target, settings: &Settings) -> Report {
    let Settings {
        seconds,
        seed,
        case_limit,
        ref dir,
    } = *settings;
    let name = target.name;
    install_panic_hook();
    std::fs::create_dir_all(dir).unwrap_or_else(|e| panic!("cannot create {}: {e}", dir.display()));
    let in_flight_path = dir.join(format!("{name}.in-flight"));
    let shared = Arc::new(Shared {
        case_started: AtomicU64::new(IDLE),
    });
    let start = Instant::now();
    let deadline = start + Duration::from_secs_f64(seconds);

    let counters = target.counters;
    let target_extension = target.extension;
    let worker = {
        let shared = Arc::clone(&shared);
        let in_flight = InFlight::create(in_flight_path.clone());
        let dir = dir.clone();
        std::thread::Builder::new()
            .name(format!("fuzz-{name}"))
            // The layer runs on the application's threads: no more stack than a default
            // spawned thread.
            .stack_size(2 << 20)
            .spawn(move || {
                let mut rng = Rng::new(seed ^ hash_of(&name));
                let mut corpus = Vec::new();
                let mut outcomes = HashSet::new();
                let mut cases = 0u64;
                let mut rng_replace = Rng::new(seed);
                let mut case = |input: Vec<u8>, corpus: &mut Vec<Vec<u8>>| {
                    in_flight.write(&input);
                    let at = start.elapsed().as_millis() as u64;
                    shared.case_started.store(at, Ordering::SeqCst);
                    let outcome = run_case(&target, &input);
                    shared.case_started.store(IDLE, Ordering::SeqCst);
                    cases += 1;
                    match outcome {
                        Ok(outcome) => {
                            if outcomes.insert(outcome) {
                                if corpus.len() < MAX_CORPUS {
                                    corpus.push(input);
                                } else {
                                    // Full: a new outcome takes the place of a random mutant.
                                    let seeds = target.seeds.len().min(corpus.len() - 1);
                                    let at = seeds + rng_replace.below(corpus.len() - seeds);
                                    corpus[at] = input;
                                }
                            }
                        }
                        Err(why) => fail(&dir, &target, &input, &why),
                    }
                };
                for seed in target.seeds.clone() {
                    case(seed, &mut corpus);
                }
                if corpus.is_empty() {
                    corpus.push(Vec::new());
                }
                // Half the cases start from a seed: mutants of mutants are mostly rejected
                // early by the code under test.
                let seeds = corpus.len();
                while Instant::now() < deadline {
                    let parent = if rng.one_in(2) {
                        rng.below(seeds)
                    } else {
                        rng.below(corpus.len())
                    };
                    let mut input = corpus[parent].clone();
                    (target.mutate)(&mut rng, &corpus, &mut input);
                    input.truncate(target.max_len);
                    case(input, &mut corpus);
                }
                let caught_panics = PANICS.with(|panics| panics.borrow().1.clone());
                let _ = std::fs::remove_file(&in_flight.path);
                Report {
                    replay: false,
                    cases,
                    seconds: start.elapsed().as_secs_f64(),
                    corpus: corpus.len(),
                    outcomes: outcomes.len(),
                    caught_panics,
                }
            })
            .expect("spawn the fuzz thread")
    };

    // The watchdog: a case running past its limit is a hang (its thread is left behind).
    while !worker.is_finished() {
        std::thread::sleep(Duration::from_millis(20));
        let started = shared.case_started.load(Ordering::SeqCst);
        if started != IDLE {
            let now = start.elapsed().as_millis() as u64;
            if Duration::from_millis(now.saturating_sub(started)) > case_limit {
                let input = std::fs::read(&in_flight_path).unwrap_or_default();
                let path = dir.join(format!(
                    "{name}-hang-{:016x}.{}",
                    hash_of(&input),
                    target_extension
                ));
                let _ = std::fs::write(&path, &input);
                panic!(
                    "fuzz target {name}: a case ran longer than {case_limit:?} (a hang); \
                     input written to {}",
                    path.display()
                );
            }
        }
    }
    let report = match worker.join() {
        Ok(report) => report,
        Err(payload) => {
            let message = payload
                .downcast_ref::<String>()
                .cloned()
                .or_else(|| payload.downcast_ref::<&str>().map(|s| (*s).to_owned()))
                .unwrap_or_default();
            panic!("{message}");
        }
    };
    let counters = counters
        .iter()
        .map(|c| format!(", {} {}", c.name, c.get()))
        .collect::<String>();
    eprintln!(
        "fuzz {name}: {} cases in {:.1} s ({:.0}/s), seed {seed}, corpus {}, {} outcomes{counters}",
        report.cases,
        report.seconds,
        report.cases as f64 / report.seconds.max(1e-9),
        report.corpus,
        report.outcomes,
    );
    for (location, count) in &report.caught_panics {
        eprintln!("fuzz {name}: {count} panics caught inside the layer at {location}");
    }
    report
}

/// Generic byte mutations, for targets whose input is text or a seed.
pub fn mutate_bytes(rng: &mut Rng, corpus: &[Vec<u8>], input: &mut Vec<u8>, dictionary: &[&str]) {
    for _ in 0..1 + rng.below(4) {
        let len = input.len();
        match rng.below(9) {
            0 if len > 0 => {
                let at = rng.below(len);
                input[at] ^= 1 << rng.below(8);
            }
            1 if len > 0 => {
                let at = rng.below(len);
                input[at] = rng.u32() as u8;
            }
            2 if len > 0 => {
                let at = rng.below(len);
                let end = (at + 1 + rng.below(16)).min(len);
                input.drain(at..end);
            }
            3 => {
                let at = rng.below(len + 1);
                let token = rng.pick(dictionary).as_bytes();
                input.splice(at..at, token.iter().copied());
            }
            4 if len > 0 => {
                // Duplicate a run of bytes.
                let at = rng.below(len);
                let end = (at + 1 + rng.below(64)).min(len);
                let run = input[at..end].to_vec();
                let to = rng.below(len + 1);
                input.splice(to..to, run);
            }
            5 => {
                // Splice with another corpus entry.
                let other = rng.pick(corpus);
                let cut = rng.below(len + 1);
                let from = rng.below(other.len() + 1);
                input.truncate(cut);
                input.extend_from_slice(&other[from..]);
            }
            6 => input.truncate(rng.below(len + 1)),
            7 => {
                let at = rng.below(len + 1);
                let mut random = vec![0; 1 + rng.below(8)];
                rng.fill(&mut random);
                input.splice(at..at, random);
            }
            _ => {
                let at = rng.below(len + 1);
                let token = rng.pick(dictionary).as_bytes();
                let end = (at + token.len()).min(len);
                input.splice(at..end, token.iter().copied());
            }
        }
    }
}

#[test]
fn vertex_analysis() {
    spirv::run_vertex();
}

#[test]
fn fragment_rewrite() {
    spirv::run_fragment();
}

#[test]
fn input_rewrite() {
    spirv::run_input();
}

#[test]
fn chain_splice() {
    chain::run();
}

#[test]
fn config() {
    config::run();
}

/// The engine itself: a broken invariant, a panic and a hang each fail the run with the input
/// written where the message says.
mod engine_tests {
    use super::*;

    fn settings(test: &str) -> Settings {
        Settings {
            seconds: 5.0,
            seed: 1,
            case_limit: Duration::from_millis(300),
            dir: std::env::temp_dir().join(format!("revz-fuzz-{test}-{}", std::process::id())),
        }
    }

    fn mutate(rng: &mut Rng, corpus: &[Vec<u8>], input: &mut Vec<u8>) {
        mutate_bytes(rng, corpus, input, &["x", "p", "h"]);
    }

    /// Runs a target whose check fails on inputs holding `trigger`, and returns the input the
    /// failure wrote.
    fn failing_input(test: &str, check: fn(&[u8]) -> Result<u64, String>) -> (String, Vec<u8>) {
        let target = Target {
            name: "engine",
            extension: "bin",
            seeds: vec![b"abcd".to_vec()],
            mutate,
            check,
            max_len: 64,
            counters: &[],
        };
        let settings = settings(test);
        let payload = catch_unwind(AssertUnwindSafe(|| run_with(target, &settings)))
            .expect_err("the run fails");
        let message = payload
            .downcast_ref::<String>()
            .cloned()
            .unwrap_or_default();
        let path = message
            .split("written to ")
            .nth(1)
            .and_then(|rest| rest.lines().next())
            .unwrap_or_else(|| panic!("no path in {message:?}"));
        let input = std::fs::read(path).expect("the failing input was written");
        let _ = std::fs::remove_dir_all(&settings.dir);
        (message, input)
    }

    #[test]
    fn a_broken_invariant_fails_with_its_input() {
        fn check(input: &[u8]) -> Result<u64, String> {
            match input.contains(&b'x') {
                true => Err("holds an x".to_owned()),
                false => Ok(hash_of(&input)),
            }
        }
        let (message, input) = failing_input("invariant", check);
        assert!(message.contains("holds an x"), "{message}");
        assert!(input.contains(&b'x'));
    }

    #[test]
    fn a_panic_fails_with_its_input() {
        fn check(input: &[u8]) -> Result<u64, String> {
            assert!(!input.contains(&b'p'), "a p");
            Ok(hash_of(&input))
        }
        let (message, input) = failing_input("panic", check);
        assert!(
            message.contains("panic: ") && message.contains("a p"),
            "{message}"
        );
        assert!(input.contains(&b'p'));
    }

    #[test]
    fn a_hang_fails_with_its_input() {
        fn check(input: &[u8]) -> Result<u64, String> {
            if input.contains(&b'h') {
                // Left behind by the watchdog; asleep, it costs nothing.
                std::thread::sleep(Duration::from_secs(3600));
            }
            Ok(hash_of(&input))
        }
        let (message, input) = failing_input("hang", check);
        assert!(message.contains("a hang"), "{message}");
        assert!(input.contains(&b'h'));
    }
}
