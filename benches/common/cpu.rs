//! CPU time for benchmarks that share the machine with other work: the sum over this
//! process's live threads of the scheduler's per-thread run time, which is steadier than wall
//! time under load.

/// CPU seconds used so far by all of this process's live threads, from the per-thread
/// scheduler statistics (nanoseconds); zero where they are not available.
pub fn cpu_seconds() -> f64 {
    let Ok(tasks) = std::fs::read_dir("/proc/self/task") else {
        return 0.0;
    };
    tasks
        .filter_map(|t| std::fs::read_to_string(t.ok()?.path().join("schedstat")).ok())
        .filter_map(|s| s.split_whitespace().next()?.parse::<f64>().ok())
        .sum::<f64>()
        * 1e-9
}
