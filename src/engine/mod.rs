//! The engine context: the state one run of felt owns — its memory budget, its `--profile`
//! rows, its interrupt flag, its output settings and the band it renders — kept in one value
//! instead of in process-wide statics, so two sessions in one process (tests, a host
//! application embedding felt) never see each other's usage, profiles or Ctrl-C.
//!
//! The key decision is how deep code finds its engine without every function taking one: a
//! session *enters* its engine on the thread it runs on (a guard sets a thread-local "current
//! engine"), and that thread is made worker 0 of a rayon pool of its own (`use_current_thread`),
//! so the parallel loops it starts run on that pool, whose workers read the engine the home
//! thread has entered through a shared slot. `crate::engine::budget::reserve`, `crate::engine::interrupt::
//! requested` and `crate::engine::profile::register` therefore reach the right engine from the
//! interpreter and from any worker alike. The pool belongs to the thread, not to a session,
//! because rayon lets a thread join one pool only; sessions on one thread run one at a time
//! (a session is not `Send`), so the slot is never ambiguous. Code that runs with no engine
//! entered (benches, plain library calls, a thread that is already another pool's worker)
//! uses one default process engine.

pub mod band;
pub mod budget;
pub mod interrupt;
pub mod output;
pub mod profile;
pub mod spare;

use crate::engine::budget::Budget;
use crate::engine::profile::Profile;
use band::Band;
use output::OutputSettings;
use std::cell::{OnceCell, RefCell};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, LazyLock, OnceLock, RwLock};

/// What one run owns. Shared (`Arc`) between the session, its worker threads and whatever
/// outlives a statement (a cache's memory reservation, a signal handler).
#[derive(Debug, Default)]
pub struct Engine {
    /// The memory budget (`--memory-limit`).
    pub budget: Arc<Budget>,
    /// The `--profile` rows.
    pub profile: Profile,
    /// Where outputs go and which frame this is (`--output-dir`, `--frames`).
    pub output: OutputSettings,
    /// The one band of every image to render (`--tile`).
    pub band: OnceLock<Band>,
    interrupted: AtomicBool,
}

impl Engine {
    /// An engine with the default budget (half the memory this process may use).
    pub fn new() -> Arc<Engine> {
        Arc::new(Engine::default())
    }

    /// An engine whose memory budget is `bytes`.
    pub fn with_memory_limit(bytes: u64) -> Arc<Engine> {
        let engine = Engine::default();
        engine.budget.set_limit(bytes);
        Arc::new(engine)
    }

    /// Asks the evaluation running on this engine to stop (Ctrl-C); safe from a signal
    /// handler's thread.
    pub fn interrupt(&self) {
        self.interrupted.store(true, Ordering::Relaxed);
    }

    /// Has a stop been asked for since the last `clear_interrupt`?
    pub fn interrupted(&self) -> bool {
        self.interrupted.load(Ordering::Relaxed)
    }

    /// Forgets an earlier request (at the start of each evaluation).
    pub fn clear_interrupt(&self) {
        self.interrupted.store(false, Ordering::Relaxed);
    }

    /// Makes this the current engine of this thread and of its worker pool until the guard is
    /// dropped; the engine entered before comes back then.
    pub fn enter(self: &Arc<Self>) -> Entered {
        attach_pool(None).ok();
        let previous_home = HOME.with(|home| home.borrow_mut().replace(self.clone()));
        let previous_slot = POOL.with(|pool| {
            pool.get().map(|pool| {
                let mut slot = pool.slot.write().unwrap_or_else(|e| e.into_inner());
                slot.replace(self.clone())
            })
        });
        Entered {
            previous_home,
            previous_slot,
            _not_send: std::marker::PhantomData,
        }
    }
}

/// While alive, an engine is the current one (see `Engine::enter`).
#[must_use = "the engine is current only while the guard lives"]
pub struct Entered {
    previous_home: Option<Arc<Engine>>,
    previous_slot: Option<Option<Arc<Engine>>>,
    // Restores the thread it was made on.
    _not_send: std::marker::PhantomData<*const ()>,
}

impl Drop for Entered {
    fn drop(&mut self) {
        let previous = self.previous_home.take();
        HOME.with(|home| *home.borrow_mut() = previous);
        if let Some(previous) = self.previous_slot.take() {
            POOL.with(|pool| {
                if let Some(pool) = pool.get() {
                    *pool.slot.write().unwrap_or_else(|e| e.into_inner()) = previous;
                }
            });
        }
    }
}

/// The engine a pool's workers use: the one their home thread has entered now.
type Slot = RwLock<Option<Arc<Engine>>>;

/// A home thread's pool and the slot its workers read.
struct HomePool {
    _pool: rayon::ThreadPool,
    slot: Arc<Slot>,
}

thread_local! {
    /// The engine entered on this thread.
    static HOME: RefCell<Option<Arc<Engine>>> = const { RefCell::new(None) };
    /// On a worker thread: its pool's slot.
    static WORKER: OnceCell<Arc<Slot>> = const { OnceCell::new() };
    /// On a home thread: the pool it is worker 0 of.
    static POOL: OnceCell<HomePool> = const { OnceCell::new() };
}

/// The engine of code that runs outside any session.
static DEFAULT: LazyLock<Arc<Engine>> = LazyLock::new(Engine::new);

/// Runs `f` with the current engine: the one entered on this thread, else the one this
/// worker's home thread has entered, else the default engine.
pub fn with<R>(f: impl FnOnce(&Engine) -> R) -> R {
    f(&current())
}

/// The current engine (see `with`).
pub fn current() -> Arc<Engine> {
    if let Some(engine) = HOME.with(|home| home.borrow().clone()) {
        return engine;
    }
    let from_pool = WORKER.with(|worker| {
        worker
            .get()
            .and_then(|slot| slot.read().unwrap_or_else(|e| e.into_inner()).clone())
    });
    from_pool.unwrap_or_else(|| DEFAULT.clone())
}

/// Makes this thread worker 0 of a pool of `threads` workers (all cores when `None`), so the
/// parallel loops it starts run there and find its engine. Does nothing if it already has one;
/// fails if the pool cannot start or this thread already works for a pool that is not its
/// own (its loops then run on that pool, with the default engine).
pub fn attach_pool(threads: Option<usize>) -> Result<(), rayon::ThreadPoolBuildError> {
    if POOL.with(|pool| pool.get().is_some()) {
        return Ok(());
    }
    let slot: Arc<Slot> = Arc::new(RwLock::new(None));
    let pool = pool_builder(slot.clone(), threads)
        .use_current_thread()
        .build()?;
    POOL.with(|cell| {
        let _ = cell.set(HomePool { _pool: pool, slot });
    });
    Ok(())
}

/// A separate pool whose workers use the current engine, for work that must not run on the
/// pool it was started from (a solve that others wait for).
pub fn worker_pool(threads: usize) -> Result<rayon::ThreadPool, rayon::ThreadPoolBuildError> {
    let slot = Arc::new(RwLock::new(Some(current())));
    pool_builder(slot, Some(threads)).build()
}

fn pool_builder(slot: Arc<Slot>, threads: Option<usize>) -> rayon::ThreadPoolBuilder {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads.unwrap_or(0))
        .stack_size(crate::engine::budget::WORKER_STACK_BYTES)
        .start_handler(move |_| {
            WORKER.with(|worker| {
                let _ = worker.set(slot.clone());
            });
        })
}

#[cfg(test)]
mod tests {
    use super::*;
    use rayon::prelude::*;

    #[test]
    fn workers_see_the_engine_their_home_thread_entered() {
        std::thread::spawn(|| {
            attach_pool(Some(3)).unwrap();
            let a = Engine::with_memory_limit(1 << 20);
            let b = Engine::with_memory_limit(2 << 20);
            let limits = |engine: &Arc<Engine>| {
                let _entered = engine.enter();
                (0..64)
                    .into_par_iter()
                    .map(|_| with(|e| e.budget.limit()))
                    .collect::<Vec<_>>()
            };
            assert!(limits(&a).iter().all(|&l| l == 1 << 20));
            assert!(limits(&b).iter().all(|&l| l == 2 << 20));
            // Nested entries restore the outer engine.
            let _outer = a.enter();
            {
                let _inner = b.enter();
                assert_eq!(current().budget.limit(), 2 << 20);
            }
            assert_eq!(current().budget.limit(), 1 << 20);
            let pool = worker_pool(2).unwrap();
            assert_eq!(pool.install(|| current().budget.limit()), 1 << 20);
        })
        .join()
        .unwrap();
    }

    #[test]
    fn with_nothing_entered_the_default_engine_is_used() {
        std::thread::spawn(|| assert!(Arc::ptr_eq(&current(), &DEFAULT)))
            .join()
            .unwrap();
    }
}
