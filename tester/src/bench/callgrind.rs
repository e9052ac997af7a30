//! Valgrind's client requests for callgrind, so that the bench's instruction count runs its
//! child at full speed until the measured frames: callgrind started with
//! `--instr-atstart=no` instruments nothing until [`start_instrumentation`].
//!
//! A client request is a no-op instruction sequence that valgrind's JIT recognizes (the
//! rotations of `rdi` add up to 128 bits; see `valgrind.h`, `__SPECIAL_INSTRUCTION_PREAMBLE`):
//! outside valgrind it does nothing. Implemented on x86_64 only; elsewhere both calls do
//! nothing and the count covers whatever callgrind instruments from the start.

/// `VG_USERREQ_TOOL_BASE('C', 'T')`: callgrind's requests (`callgrind.h`).
const CALLGRIND_BASE: usize = ((b'C' as usize) << 24) | ((b'T' as usize) << 16);
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
    #[test]
    fn requests_do_nothing_outside_valgrind() {
        super::start_instrumentation();
        super::stop_instrumentation();
    }
}
