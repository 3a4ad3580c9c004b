//! Ctrl-C: a flag of the current engine (`crate::engine`) that a signal handler sets and that
//! long-running work polls (the interpreter at every loop iteration and call, the engine
//! between blocks), so an interrupted evaluation unwinds as an ordinary error and the session
//! keeps its state. The flag belongs to the engine, not the process, so interrupting one
//! session leaves another running; a signal handler holds the engine it interrupts
//! (`Engine::interrupt`).
//!
//! A command that runs other felt processes (`felt study`, `felt run --frames` over a range)
//! starts each child in a process group of its own (`spawn_child`) and, when it is
//! interrupted, stops that whole group and waits for it to be gone before it exits 130
//! (`stop_children`): a child killed with its parent would otherwise keep running under
//! init, holding CPUs on a shared machine. The child's own group keeps a terminal's Ctrl-C
//! from reaching it twice; the parent passes it on as SIGTERM, which a felt run answers by
//! removing its temporary files and exiting 130.

use std::process::{Child, Command};
use std::sync::{Mutex, MutexGuard};
use std::time::Duration;

/// Asks the evaluation running on the current engine to stop.
pub fn request() {
    crate::engine::with(|e| e.interrupt());
}

/// Has a stop been asked for since the last `clear`?
pub fn requested() -> bool {
    crate::engine::with(|e| e.interrupted())
}

/// Forgets an earlier request (at the start of each evaluation).
pub fn clear() {
    crate::engine::with(|e| e.clear_interrupt());
}

/// The process group of the child running now (0 for none), and whether this process is
/// stopping: once it is, no new child starts.
struct Children {
    group: u32,
    stopping: bool,
}

static CHILDREN: Mutex<Children> = Mutex::new(Children {
    group: 0,
    stopping: false,
});

/// How often a stopped child's group is polled, and how many polls it has to remove its
/// temporaries and exit before it is killed (2,000 polls 10 ms apart: about 20 s).
const POLL: Duration = Duration::from_millis(10);
const GRACE_POLLS: u32 = 2_000;

fn children() -> MutexGuard<'static, Children> {
    CHILDREN.lock().unwrap_or_else(|e| e.into_inner())
}

/// Waits for the process to end, once `stop_children` has begun to end it: work on this
/// thread must not go on (start another child, write a report) behind a stop.
fn wait_for_the_stop() -> ! {
    loop {
        std::thread::park();
    }
}

/// Starts `command` as a child in a process group of its own, recorded so that
/// `stop_children` can stop it and everything it started. Call `child_done` once it has been
/// reaped. When the process is already stopping, this waits for the end instead.
pub fn spawn_child(command: &mut Command) -> std::io::Result<Child> {
    #[cfg(unix)]
    {
        use std::os::unix::process::CommandExt;
        command.process_group(0);
    }
    let mut record = children();
    if record.stopping {
        drop(record);
        wait_for_the_stop();
    }
    let child = command.spawn()?;
    record.group = child.id();
    Ok(child)
}

/// Forgets the child `spawn_child` started, once it has been reaped. When the process is
/// stopping (the child ended because it was stopped), this waits for the end instead.
pub fn child_done() {
    let mut record = children();
    record.group = 0;
    if record.stopping {
        drop(record);
        wait_for_the_stop();
    }
}

/// Stops the child started by `spawn_child` and its whole process group (from a Ctrl-C or
/// SIGTERM handler, before the process exits): SIGTERM first, SIGKILL for what is left after
/// `GRACE_POLLS` polls; returns once no process of the group is left. No child starts after
/// this.
pub fn stop_children() {
    let group = {
        let mut record = children();
        record.stopping = true;
        record.group
    };
    #[cfg(unix)]
    if group != 0 {
        let group = group as libc::pid_t;
        signal_group(group, libc::SIGTERM);
        if !wait_for_group(group, GRACE_POLLS) {
            signal_group(group, libc::SIGKILL);
            wait_for_group(group, GRACE_POLLS);
        }
    }
}

#[cfg(unix)]
fn signal_group(group: libc::pid_t, signal: libc::c_int) {
    // SAFETY: kill has no memory effects. The group is our child's own (it cannot be reused
    // while the child is unreaped, and our own thread reaps it only after this returns or the
    // group is empty); a group that is gone is signalled to nothing (ESRCH).
    unsafe {
        libc::kill(-group, signal);
    }
}

/// Whether the process group became empty within `polls` polls. The child leader leaves it
/// when the thread that started it reaps it; its own children when they exit.
#[cfg(unix)]
fn wait_for_group(group: libc::pid_t, polls: u32) -> bool {
    for _ in 0..polls {
        // SAFETY: signal 0 only asks whether the group has a member; no memory effects.
        let alive = unsafe { libc::kill(-group, 0) } == 0;
        if !alive {
            return true;
        }
        std::thread::sleep(POLL);
    }
    false
}
