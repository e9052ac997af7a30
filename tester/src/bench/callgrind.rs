//! The bench's instruction count under callgrind: in the parent, the child's command wrapped
//! in `valgrind --tool=callgrind` ([`under_callgrind`]) and the count read back
//! ([`callgrind_total`]); in the child, valgrind's client requests, so that it runs at full
//! speed until the measured frames: callgrind started with `--instr-atstart=no` instruments
//! nothing until [`start_instrumentation`].
//!
//! A client request is a no-op instruction sequence that valgrind's JIT recognizes (the
//! rotations of `rdi` add up to 128 bits; see `valgrind.h`, `__SPECIAL_INSTRUCTION_PREAMBLE`):
//! outside valgrind it does nothing. Implemented on x86_64 only; elsewhere both calls do
//! nothing and the count covers whatever callgrind instruments from the start.

use std::path::Path;

use anyhow::{Context, Result};

/// `VG_USERREQ_TOOL_BASE('C', 'T')`: callgrind's requests (`callgrind.h`).
const CALLGRIND_BASE: usize = ((b'C' as usize) << 24) | ((b'T' as usize) << 16);
const DUMP_STATS: usize = CALLGRIND_BASE;
const ZERO_STATS: usize = CALLGRIND_BASE + 1;
const START_INSTRUMENTATION: usize = CALLGRIND_BASE + 4;
const STOP_INSTRUMENTATION: usize = CALLGRIND_BASE + 5;

/// Callgrind instruments from here on (nothing outside valgrind).
pub fn start_instrumentation() {
    client_request(START_INSTRUMENTATION);
}

/// Callgrind stops instrumenting (nothing outside valgrind).
pub fn stop_instrumentation() {
    client_request(STOP_INSTRUMENTATION);
}

/// Callgrind's counters start again from zero (nothing outside valgrind).
pub fn zero_stats() {
    client_request(ZERO_STATS);
}

/// Callgrind writes what it counted since the last dump or zeroing as the next part of its
/// output (`<out>.1`, `<out>.2`, ...; nothing outside valgrind).
pub fn dump_stats() {
    client_request(DUMP_STATS);
}

/// `command` run under callgrind with instrumentation off until the child starts it, every
/// part it dumps ([`dump_stats`]) written beside `out` ([`dumped_totals`]).
pub(super) fn under_callgrind_dumps(
    command: &std::process::Command,
    out: &Path,
) -> std::process::Command {
    callgrind_wrapping(command, out, None)
}

/// The totals of the parts a child dumped under [`under_callgrind_dumps`], in order (each
/// part file removed once read; the part written at the child's exit is not one of them: it
/// follows the last dump).
pub(super) fn dumped_totals(out: &Path, parts: usize) -> Result<Vec<u64>> {
    let mut totals = Vec::with_capacity(parts);
    for part in 1..=parts {
        let path = std::path::PathBuf::from(format!("{}.{part}", out.display()));
        let text = std::fs::read_to_string(&path)
            .with_context(|| format!("callgrind wrote no {}", path.display()))?;
        totals.push(callgrind_total(&text)?);
    }
    // Every part, the exit's included.
    for part in 1.. {
        let path = std::path::PathBuf::from(format!("{}.{part}", out.display()));
        if std::fs::remove_file(&path).is_err() {
            break;
        }
    }
    let _ = std::fs::remove_file(out);
    Ok(totals)
}

/// Whether `valgrind` can be run (the instruction count is skipped without it).
pub(super) fn has_valgrind() -> bool {
    std::process::Command::new("valgrind")
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success())
}

/// `command` run under callgrind, counting instructions only inside the storm's measured
/// frames (`super::child::MEASURED_FRAME_SYMBOL`), the count written to `out`.
pub(super) fn under_callgrind(
    command: &std::process::Command,
    out: &Path,
) -> std::process::Command {
    let toggle = format!("--toggle-collect={}", super::child::MEASURED_FRAME_SYMBOL);
    callgrind_wrapping(command, out, Some(&toggle))
}

/// `valgrind --tool=callgrind` running `command` (its program, arguments and environment),
/// instrumenting only from the child's [`start_instrumentation`] on (its set-up runs at
/// valgrind's plain speed), writing to `out`, with `toggle` (collecting only inside a
/// function) where given.
fn callgrind_wrapping(
    command: &std::process::Command,
    out: &Path,
    toggle: Option<&str>,
) -> std::process::Command {
    let mut wrapped = std::process::Command::new("valgrind");
    wrapped.arg("--tool=callgrind").arg("--instr-atstart=no");
    if let Some(toggle) = toggle {
        wrapped.arg(toggle);
    }
    wrapped
        .arg(format!("--callgrind-out-file={}", out.display()))
        .arg(command.get_program())
        .args(command.get_args());
    for (name, value) in command.get_envs() {
        match value {
            Some(value) => wrapped.env(name, value),
            None => wrapped.env_remove(name),
        };
    }
    wrapped
}

/// The event total of a callgrind output file (its `totals:` line, else `summary:`).
pub(super) fn callgrind_total(text: &str) -> Result<u64> {
    let field = |key: &str| {
        text.lines()
            .find_map(|l| l.strip_prefix(key))
            .and_then(|v| v.split_whitespace().next()?.parse::<u64>().ok())
    };
    field("totals:")
        .or_else(|| field("summary:"))
        .context("no totals: line in callgrind's output")
}

#[cfg(target_arch = "x86_64")]
fn client_request(request: usize) {
    let args: [usize; 6] = [request, 0, 0, 0, 0, 0];
    // SAFETY: the preamble's rotations leave `rdi` as it was and `xchg rbx, rbx` changes
    // nothing; under valgrind the request reads the six words at `rax` (alive for the call)
    // and writes its result to `rdx`, declared clobbered (the rotations change the flags).
    unsafe {
        std::arch::asm!(
            "rol rdi, 3",
            "rol rdi, 13",
            "rol rdi, 61",
            "rol rdi, 51",
            "xchg rbx, rbx",
            in("rax") args.as_ptr(),
            inout("rdx") 0usize => _,
            inout("rdi") 0usize => _,
            options(nostack),
        );
    }
}

#[cfg(not(target_arch = "x86_64"))]
fn client_request(_request: usize) {}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn requests_do_nothing_outside_valgrind() {
        super::start_instrumentation();
        super::zero_stats();
        super::dump_stats();
        super::stop_instrumentation();
    }

    #[test]
    fn dumped_parts_are_read_in_order_and_every_part_is_removed() {
        let dir = std::env::temp_dir().join(format!("revz-callgrind-parts-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let out = dir.join("micro.out");
        for (part, total) in [(1, 30), (2, 10), (3, 99)] {
            std::fs::write(
                format!("{}.{part}", out.display()),
                format!("summary: {total}\n"),
            )
            .unwrap();
        }
        std::fs::write(&out, "summary: 5\n").unwrap();
        assert_eq!(dumped_totals(&out, 2).unwrap(), vec![30, 10]);
        assert!(
            std::fs::read_dir(&dir).unwrap().next().is_none(),
            "parts left"
        );
        assert!(dumped_totals(&out, 1).is_err());
        std::fs::remove_dir(&dir).unwrap();
    }

    #[test]
    fn callgrinds_total_is_its_totals_line_else_its_summary() {
        let file = "version: 1\nevents: Ir\nsummary: 2800000\nfn=x\n1 5\ntotals: 2800001\n";
        assert_eq!(callgrind_total(file).unwrap(), 2_800_001);
        assert_eq!(callgrind_total("events: Ir\nsummary: 7\n").unwrap(), 7);
        assert!(callgrind_total("events: Ir\n").is_err());
        assert!(callgrind_total("totals: many\n").is_err());
    }
}
