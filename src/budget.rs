//! One memory budget per run: every large allocation — caches, FFT and projection buffers,
//! framebuffers, light caches, strings and arrays — is checked against what is left of it
//! *before* it is made, so running out of memory is a diagnostic at the line that asked, never
//! an abort.
//!
//! Long-lived storage takes a `Reservation` that gives its bytes back when dropped (a cache
//! holds one for as long as it lives); short-lived values are only checked against what is
//! left. The budget is `--memory-limit` when given, else half of the memory this process may
//! use: the smallest of physical memory, the cgroup's `memory.max` and the address-space and
//! data-segment limits (`ulimit -v`, `ulimit -d`). Half, because the budget counts the large
//! buffers only; the interpreter, field graphs and per-thread scratch live beside them.

use crate::failure::{Failure, Outcome};
use std::sync::atomic::{AtomicU64, Ordering};

/// The budget in bytes; 0 until set (the default is then worked out on first use).
static LIMIT: AtomicU64 = AtomicU64::new(0);
/// Bytes held by live reservations.
static USED: AtomicU64 = AtomicU64::new(0);

/// Sets the budget, in bytes.
pub fn set_limit(bytes: u64) {
    LIMIT.store(bytes.max(1), Ordering::Relaxed);
}

/// The budget, in bytes.
pub fn limit() -> u64 {
    match LIMIT.load(Ordering::Relaxed) {
        0 => {
            let default = available_memory().map(|m| m / 2).unwrap_or(4 << 30);
            LIMIT.store(default, Ordering::Relaxed);
            default
        }
        limit => limit,
    }
}

/// Bytes held by live reservations now.
pub fn used() -> u64 {
    USED.load(Ordering::Relaxed)
}

/// The most memory this process may use, if known.
fn available_memory() -> Option<u64> {
    let mut smallest = physical_memory();
    let mut consider = |bytes: Option<u64>| {
        if let Some(b) = bytes {
            smallest = Some(smallest.map_or(b, |s| s.min(b)));
        }
    };
    consider(cgroup_limit());
    #[cfg(unix)]
    {
        consider(rlimit(libc::RLIMIT_AS));
        consider(rlimit(libc::RLIMIT_DATA));
    }
    smallest
}

fn physical_memory() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemTotal:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024)
}

/// A cgroup v2 `memory.max` (or v1 `memory.limit_in_bytes`) below "max".
fn cgroup_limit() -> Option<u64> {
    [
        "/sys/fs/cgroup/memory.max",
        "/sys/fs/cgroup/memory/memory.limit_in_bytes",
    ]
    .iter()
    .find_map(|path| {
        std::fs::read_to_string(path)
            .ok()?
            .trim()
            .parse::<u64>()
            .ok()
    })
    // v1 reports "no limit" as a number near 2^63.
    .filter(|&b| b < 1 << 60)
}

#[cfg(unix)]
fn rlimit(resource: libc::__rlimit_resource_t) -> Option<u64> {
    // SAFETY: getrlimit only writes the struct it is given.
    let mut limit: libc::rlimit = unsafe { std::mem::zeroed() };
    let ok = unsafe { libc::getrlimit(resource, &mut limit) } == 0;
    (ok && limit.rlim_cur != libc::RLIM_INFINITY).then_some(limit.rlim_cur as u64)
}

/// `bytes` of the budget, held until dropped.
#[derive(Debug)]
pub struct Reservation {
    bytes: u64,
}

impl Drop for Reservation {
    fn drop(&mut self) {
        USED.fetch_sub(self.bytes, Ordering::Relaxed);
    }
}

/// "1.5 GiB".
pub fn human(bytes: f64) -> String {
    const UNITS: [&str; 5] = ["B", "KiB", "MiB", "GiB", "TiB"];
    let mut value = bytes;
    let mut unit = 0;
    while value >= 1024.0 && unit + 1 < UNITS.len() {
        value /= 1024.0;
        unit += 1;
    }
    format!("{value:.1} {}", UNITS[unit])
}

fn over(what: &str, bytes: f64) -> Failure {
    let (limit, used) = (limit() as f64, used() as f64);
    let held = if used > 0.0 {
        format!(
            " ({} of it already held by this run's caches and buffers)",
            human(used)
        )
    } else {
        String::new()
    };
    Failure::new(format!(
        "{what} would take {}, over the memory budget of {}{held}",
        human(bytes),
        human(limit)
    ))
    .with_help(
        "use a coarser cell, a smaller domain or image, free earlier caches, or raise the \
         budget with --memory-limit MB",
    )
}

/// Takes `bytes` of the budget for storage that lives on (a cache, a buffer).
pub fn reserve(bytes: f64, what: &str) -> Outcome<Reservation> {
    if !(bytes.is_finite() && bytes >= 0.0) || bytes > u64::MAX as f64 {
        return Err(over(what, bytes));
    }
    let wanted = bytes as u64;
    let limit = limit();
    let mut current = USED.load(Ordering::Relaxed);
    loop {
        if current.saturating_add(wanted) > limit {
            return Err(over(what, bytes));
        }
        match USED.compare_exchange_weak(
            current,
            current + wanted,
            Ordering::Relaxed,
            Ordering::Relaxed,
        ) {
            Ok(_) => return Ok(Reservation { bytes: wanted }),
            Err(actual) => current = actual,
        }
    }
}

/// Checks that `bytes` fit in what is left of the budget, without holding them (a string, an
/// array: values that come and go with the statements that make them).
pub fn check(bytes: f64, what: &str) -> Outcome<()> {
    if !(bytes.is_finite() && bytes >= 0.0) || bytes + used() as f64 > limit() as f64 {
        return Err(over(what, bytes));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reservations_hold_their_bytes_and_refuse_what_cannot_fit() {
        // The budget is process-wide and other tests hold parts of it, so only what holds
        // whatever they do is asserted here; adding up and giving back across a whole run is
        // tested by `felt run` in tests/cli.rs.
        let held = reserve(1000.0, "a").unwrap();
        assert_eq!(held.bytes, 1000);
        let err = reserve(limit() as f64 + 1.0, "more than the budget").unwrap_err();
        assert!(
            err.message.contains("over the memory budget"),
            "{}",
            err.message
        );
        assert!(reserve(f64::NAN, "a NaN-sized thing").is_err());
        assert!(reserve(-1.0, "a negative size").is_err());
        assert!(check(1e30, "a huge string").is_err());
    }
}
