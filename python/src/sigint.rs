//! Ctrl-C during a run. While felt runs, the GIL is released and Python's own SIGINT handler
//! only records the signal for the interpreter loop that is not running, so for the length of
//! a run on the main thread a handler of ours takes SIGINT: it sets the session engine's
//! interrupt flag (an atomic store, safe in a signal handler), felt unwinds as it does at the
//! CLI, and the run raises `KeyboardInterrupt`. Python's handler is put back when the run
//! ends. Off the main thread Python never delivers KeyboardInterrupt, and neither does felt.

use felt::engine::Engine;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicPtr, Ordering};

/// The engine of the run in progress on the main thread (null when none).
static RUNNING: AtomicPtr<Engine> = AtomicPtr::new(std::ptr::null_mut());
/// Whether SIGINT arrived during the run in progress.
static SEEN: AtomicBool = AtomicBool::new(false);

extern "C" fn on_sigint(_signal: libc::c_int) {
    SEEN.store(true, Ordering::SeqCst);
    let engine = RUNNING.load(Ordering::SeqCst);
    if !engine.is_null() {
        // SAFETY: `RUNNING` is non-null only while a `Hook` lives, and the hook holds an `Arc`
        // of that engine, so the pointer is valid; `interrupt` is one atomic store.
        unsafe { (*engine).interrupt() };
    }
}

/// Our SIGINT handler, installed for one run; dropping it restores the handler before it.
pub struct Hook {
    previous: Option<libc::sigaction>,
    _engine: Arc<Engine>,
}

impl Hook {
    /// Installs the handler when `main_thread` (elsewhere it does nothing).
    pub fn install(engine: &Arc<Engine>, main_thread: bool) -> Hook {
        let mut hook = Hook {
            previous: None,
            _engine: engine.clone(),
        };
        if !main_thread {
            return hook;
        }
        SEEN.store(false, Ordering::SeqCst);
        RUNNING.store(Arc::as_ptr(engine).cast_mut(), Ordering::SeqCst);
        // SAFETY: both `sigaction` structs are fully initialised (zeroed, then the handler and
        // an empty mask set) and live across the calls; `on_sigint` only does atomic operations.
        unsafe {
            let mut action: libc::sigaction = std::mem::zeroed();
            action.sa_sigaction = on_sigint as *const () as libc::sighandler_t;
            libc::sigemptyset(&mut action.sa_mask);
            action.sa_flags = libc::SA_RESTART;
            let mut previous: libc::sigaction = std::mem::zeroed();
            if libc::sigaction(libc::SIGINT, &action, &mut previous) == 0 {
                hook.previous = Some(previous);
            }
        }
        hook
    }

    /// Whether SIGINT arrived while the hook was installed.
    pub fn interrupted(&self) -> bool {
        self.previous.is_some() && SEEN.load(Ordering::SeqCst)
    }
}

impl Drop for Hook {
    fn drop(&mut self) {
        if let Some(previous) = self.previous.take() {
            // SAFETY: `previous` is the action `sigaction` reported for SIGINT when the hook
            // was installed; putting it back is what Python expects to find.
            unsafe {
                libc::sigaction(libc::SIGINT, &previous, std::ptr::null_mut());
            }
            RUNNING.store(std::ptr::null_mut(), Ordering::SeqCst);
        }
    }
}
