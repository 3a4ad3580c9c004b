//! Worker threads under an address-space limit (`ulimit -v`, common on farms): each thread
//! takes its stack from the same address space the memory budget draws on, and a thread that
//! cannot get one is an abort deep inside the thread library, not a diagnostic. So the thread
//! count is fitted before any pool starts.
//!
//! The key decision is what a thread is charged: its stack (`WORKER_STACK_BYTES`, set on every
//! pool felt starts) with its guard and signal stacks, twice over, because an `fftdivfree`
//! solve runs on a second pool of the same size while the first waits. Threads may take half
//! of the address space left when the pool starts; the other half is the heap's (the default
//! memory budget is half of the limit). glibc also reserves 64 MiB of address space per malloc
//! arena, up to eight per core; under a limit felt caps the arenas at `ARENAS` so the heap is
//! not spent on reservations.

/// The stack of each worker thread felt starts.
pub const WORKER_STACK_BYTES: usize = 2 << 20;

/// Address space one worker takes: its stack, guard page and signal stack, rounded up.
const THREAD_BYTES: u64 = WORKER_STACK_BYTES as u64 + (128 << 10);

/// malloc arenas allowed under an address-space limit.
const ARENAS: u64 = 4;

/// Address space glibc reserves for each arena past the first (64-bit `HEAP_MAX_SIZE`).
const ARENA_BYTES: u64 = 64 << 20;

/// How many of `wanted` worker threads this process can give stacks to: `wanted` when the
/// address space is not limited, else what half of the unused address space holds (at least
/// one).
pub fn threads_that_fit(wanted: usize) -> usize {
    #[cfg(unix)]
    {
        let Some(limit) = super::rlimit(libc::RLIMIT_AS) else {
            return wanted;
        };
        cap_malloc_arenas();
        let mapped = mapped_bytes().unwrap_or(0);
        fit(wanted, limit, mapped)
    }
    #[cfg(not(unix))]
    wanted
}

/// The thread count `threads_that_fit` allows with `limit` bytes of address space, `mapped`
/// of them in use.
fn fit(wanted: usize, limit: u64, mapped: u64) -> usize {
    let room = limit
        .saturating_sub(mapped)
        .saturating_sub(ARENAS * ARENA_BYTES)
        / 2;
    // A pool, and a second one of the same size while a solve runs.
    let fits = (room / (2 * THREAD_BYTES)) as usize;
    wanted.min(fits.max(1))
}

/// Address space this process has mapped now (`VmSize`), if known.
fn mapped_bytes() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmSize:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024)
}

/// Caps glibc's malloc arenas at `ARENAS` (see the module's note).
fn cap_malloc_arenas() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: mallopt only changes a malloc tunable; it is called before the worker threads
    // that would create arenas start.
    unsafe {
        libc::mallopt(libc::M_ARENA_MAX, ARENAS as libc::c_int);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn threads_fit_half_the_address_space_left_twice_over() {
        const MIB: u64 = 1 << 20;
        // 2000 MB of address space (`ulimit -v 2000000`), 700 MiB mapped: (1953 − 700 − 256) / 2
        // = 498 MiB for threads, 2 × 2.125 MiB each: 117.
        let limit = 2_000_000 * 1024;
        assert_eq!(fit(250, limit, 700 * MIB), 117);
        assert_eq!(fit(8, limit, 700 * MIB), 8, "a count that fits is kept");
        assert_eq!(fit(250, limit, limit), 1, "at least one thread");
    }
}
