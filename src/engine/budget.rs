//! One memory budget per run: every large allocation — caches, FFT and projection buffers,
//! framebuffers, light caches, strings and arrays — is checked against what is left of it
//! *before* it is made, so running out of memory is a diagnostic at the line that asked, never
//! an abort.
//!
//! Long-lived storage takes a `Reservation` that gives its bytes back when dropped (a cache
//! holds one for as long as it lives, an array for its elements); short-lived values are only
//! checked against what is left. Each engine (`crate::engine`) has its own budget; the free functions here use the
//! current one. The budget is `--memory-limit` when given, else half of the memory this process may
//! use: the smallest of physical memory, the cgroup's `memory.max` and the address-space and
//! data-segment limits (`ulimit -v`, `ulimit -d`). Half, because the budget counts the large
//! buffers only; the interpreter, field graphs and per-thread scratch live beside them.

mod threads;

pub use threads::{WORKER_STACK_BYTES, threads_that_fit};

use crate::base::failure::{Failure, Outcome};
use crate::base::text::human_bytes;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};

/// One engine's budget (see `crate::engine`): its limit and what live reservations hold.
#[derive(Debug, Default)]
pub struct Budget {
    /// The budget in bytes; 0 until set (the default is then worked out on first use).
    limit: AtomicU64,
    /// Bytes held by live reservations.
    used: AtomicU64,
    /// The most `used` has been.
    peak: AtomicU64,
}

impl Budget {
    /// Sets the budget, in bytes.
    pub fn set_limit(&self, bytes: u64) {
        self.limit.store(bytes.max(1), Ordering::Relaxed);
    }

    /// The budget, in bytes.
    pub fn limit(&self) -> u64 {
        match self.limit.load(Ordering::Relaxed) {
            0 => {
                let default = default_limit();
                self.limit.store(default, Ordering::Relaxed);
                default
            }
            limit => limit,
        }
    }

    /// Bytes held by live reservations now.
    pub fn used(&self) -> u64 {
        self.used.load(Ordering::Relaxed)
    }

    /// Takes `bytes` of the budget for storage that lives on (a cache, a buffer). Kept spare
    /// buffers (`crate::engine::spare`) are freed first when it would not fit otherwise.
    pub fn reserve(self: &Arc<Self>, bytes: f64, what: &str) -> Outcome<Reservation> {
        self.reserve_unshed(bytes, what).or_else(|_| {
            crate::engine::spare::shed_all();
            self.reserve_unshed(bytes, what)
        })
    }

    /// `reserve` without freeing kept spare buffers: for keeping another one.
    pub fn reserve_unshed(self: &Arc<Self>, bytes: f64, what: &str) -> Outcome<Reservation> {
        if !(bytes.is_finite() && bytes >= 0.0) || bytes > u64::MAX as f64 {
            return Err(self.over(what, bytes));
        }
        let wanted = bytes as u64;
        let limit = self.limit();
        let mut current = self.used.load(Ordering::Relaxed);
        loop {
            if current.saturating_add(wanted) > limit {
                return Err(self.over(what, bytes));
            }
            match self.used.compare_exchange_weak(
                current,
                current + wanted,
                Ordering::Relaxed,
                Ordering::Relaxed,
            ) {
                Ok(_) => {
                    self.peak.fetch_max(current + wanted, Ordering::Relaxed);
                    return Ok(Reservation {
                        bytes: wanted,
                        budget: self.clone(),
                    });
                }
                Err(actual) => current = actual,
            }
        }
    }

    /// Takes `bytes` of the budget for storage that already exists (an array built by a
    /// builtin, a copy made on write), without refusing: what is made is counted while it
    /// lives, so later requests see it; the request that made it was checked beforehand.
    pub fn hold(self: &Arc<Self>, bytes: u64) -> Reservation {
        let now = self.used.fetch_add(bytes, Ordering::Relaxed) + bytes;
        self.peak.fetch_max(now, Ordering::Relaxed);
        Reservation {
            bytes,
            budget: self.clone(),
        }
    }

    /// Checks that `bytes` fit in what is left of the budget, without holding them; kept
    /// spare buffers are freed first when they would not fit otherwise.
    pub fn check(&self, bytes: f64, what: &str) -> Outcome<()> {
        let fits = |budget: &Budget| {
            bytes.is_finite()
                && bytes >= 0.0
                && bytes + budget.used() as f64 <= budget.limit() as f64
        };
        if !fits(self) {
            crate::engine::spare::shed_all();
            if !fits(self) {
                return Err(self.over(what, bytes));
            }
        }
        Ok(())
    }

    /// The most bytes live reservations have held at once.
    pub fn peak(&self) -> u64 {
        self.peak.load(Ordering::Relaxed)
    }

    fn over(&self, what: &str, bytes: f64) -> Failure {
        let (limit, used) = (self.limit() as f64, self.used() as f64);
        let held = if used > 0.0 {
            format!(
                " ({} of it already held by this run's caches, buffers and arrays)",
                human_bytes(used)
            )
        } else {
            String::new()
        };
        Failure::new(format!(
            "{what} would take {}, over the memory budget of {}{held}",
            human_bytes(bytes),
            human_bytes(limit)
        ))
        .with_help(
            "use a coarser cell, a smaller domain or image, free earlier caches, or raise the \
             budget with --memory-limit MB",
        )
    }
}

/// Sets the current engine's budget, in bytes.
pub fn set_limit(bytes: u64) {
    crate::engine::with(|e| e.budget.set_limit(bytes));
}

/// The current engine's budget, in bytes.
pub fn limit() -> u64 {
    crate::engine::with(|e| e.budget.limit())
}

/// Bytes held by the current engine's live reservations now.
pub fn used() -> u64 {
    crate::engine::with(|e| e.budget.used())
}

/// Half of what this process may use, worked out once: it is a fact of the machine.
fn default_limit() -> u64 {
    static DEFAULT: std::sync::OnceLock<u64> = std::sync::OnceLock::new();
    *DEFAULT.get_or_init(|| available_memory().map(|m| m / 2).unwrap_or(4 << 30))
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
    /// The budget it came from, which may not be current when it is dropped.
    budget: Arc<Budget>,
}

impl Reservation {
    /// Holds `bytes` instead, for storage that grew or shrank (growth is checked by the
    /// caller before the storage is made).
    pub fn resize(&mut self, bytes: u64) {
        if bytes >= self.bytes {
            let now = self
                .budget
                .used
                .fetch_add(bytes - self.bytes, Ordering::Relaxed);
            self.budget
                .peak
                .fetch_max(now + bytes - self.bytes, Ordering::Relaxed);
        } else {
            self.budget
                .used
                .fetch_sub(self.bytes - bytes, Ordering::Relaxed);
        }
        self.bytes = bytes;
    }

    /// The bytes held.
    pub fn bytes(&self) -> u64 {
        self.bytes
    }
}

impl Drop for Reservation {
    fn drop(&mut self) {
        self.budget.used.fetch_sub(self.bytes, Ordering::Relaxed);
    }
}

/// Takes `bytes` of the current engine's budget for storage that lives on (a cache, a
/// buffer).
pub fn reserve(bytes: f64, what: &str) -> Outcome<Reservation> {
    crate::engine::current().budget.reserve(bytes, what)
}

/// Takes `bytes` of the current engine's budget for storage that already exists (see
/// `Budget::hold`).
pub fn hold(bytes: u64) -> Reservation {
    crate::engine::current().budget.hold(bytes)
}

/// Checks that `bytes` fit in what is left of the current engine's budget, without holding
/// them (a string, an array: values that come and go with the statements that make them).
pub fn check(bytes: f64, what: &str) -> Outcome<()> {
    crate::engine::with(|e| e.budget.check(bytes, what))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reservations_hold_their_bytes_and_refuse_what_cannot_fit() {
        let budget = Arc::new(Budget::default());
        budget.set_limit(10_000);
        let held = budget.reserve(1000.0, "a").unwrap();
        assert_eq!(held.bytes, 1000);
        assert_eq!(budget.used(), 1000);
        let err = budget.reserve(9001.0, "more than the budget").unwrap_err();
        assert!(
            err.message.contains("over the memory budget"),
            "{}",
            err.message
        );
        assert!(
            err.message.contains("1000.0 B of it already held"),
            "{}",
            err.message
        );
        assert!(budget.reserve(9000.0, "the rest").is_ok());
        assert_eq!(
            budget.used(),
            1000,
            "a dropped reservation gives its bytes back"
        );
        drop(held);
        assert_eq!(budget.used(), 0);
        // Storage that exists is held without refusal, and follows its storage's size.
        let mut made = budget.hold(12_000);
        assert_eq!((budget.used(), budget.peak()), (12_000, 12_000));
        assert!(budget.check(1.0, "anything more").is_err());
        made.resize(3000);
        assert_eq!((budget.used(), made.bytes()), (3000, 3000));
        made.resize(5000);
        assert_eq!(budget.used(), 5000);
        drop(made);
        assert_eq!(budget.used(), 0);
        assert!(budget.reserve(f64::NAN, "a NaN-sized thing").is_err());
        assert!(budget.reserve(-1.0, "a negative size").is_err());
        assert!(budget.check(1e30, "a huge string").is_err());
        assert!(budget.check(10_000.0, "all of it").is_ok());
    }
}
