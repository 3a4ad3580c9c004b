//! Sessions in one process are isolated: each has its own engine, so memory budgets, profiles
//! and interrupt requests of one never reach another.

mod common;

use felt::engine::Engine;
use felt::session::Session;
use std::path::Path;
use std::sync::Arc;
use std::time::Duration;

/// Keeps a 32³ cache alive in the script's globals, so its memory stays reserved after the run.
const CACHE: &str = r#"
domain d((0, 0, 0), (1, 1, 1), (0, 0, 0), 1.0 / 32);
scalarcache kept(d);
cachewrite(kept, length(identity()));
print(probe(cacheread(kept), (0.5, 0.5, 0.5)));
"#;

fn script(dir: &Path, name: &str, text: &str) -> std::path::PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path
}

fn session(engine: Arc<Engine>) -> Session {
    Session::with_engine(Box::new(std::io::sink()), engine).unwrap_or_else(|_| panic!("stdlib"))
}

#[test]
fn sessions_with_different_memory_limits_do_not_see_each_others_usage() {
    let dir = tempfile::tempdir().unwrap();
    let path = script(dir.path(), "cache.felt", CACHE);
    let mut roomy = session(Engine::with_memory_limit(1 << 30));
    let mut tight = session(Engine::with_memory_limit(64 << 10));

    let warnings = roomy.run_file(&path);
    assert!(warnings.is_ok(), "the roomy session runs the script");
    let held = roomy.engine().budget.used();
    assert!(
        held >= 32 * 32 * 32 * 4,
        "the live cache holds its bytes: {held}"
    );
    assert_eq!(tight.engine().budget.used(), 0);
    assert_eq!(roomy.engine().budget.limit(), 1 << 30);
    assert_eq!(tight.engine().budget.limit(), 64 << 10);

    // The same script does not fit the other session's budget, and the message names that
    // budget, not the roomy one.
    let diags = tight.run_file(&path).unwrap_err();
    let message = diags.iter().map(|d| d.message.clone()).collect::<Vec<_>>();
    assert!(
        message
            .iter()
            .any(|m| m.contains("over the memory budget of 64.0 KiB")),
        "{message:?}"
    );
    assert_eq!(tight.engine().budget.used(), 0);
    assert_eq!(roomy.engine().budget.used(), held);

    // Dropping a session gives its engine's bytes back, and only its own.
    let roomy_engine = roomy.engine().clone();
    drop(roomy);
    assert_eq!(roomy_engine.budget.used(), 0);
}

#[test]
fn a_sessions_profile_lists_only_its_own_grids() {
    let dir = tempfile::tempdir().unwrap();
    let first = script(dir.path(), "first.felt", CACHE);
    let second = script(
        dir.path(),
        "second.felt",
        r#"
        domain d((0, 0, 0), (1, 1, 1), (0, 0, 0), 1.0 / 16);
        scalarcache other(d);
        cachewrite(other, perlin(2.0));
        print(probe(cacheread(other), (0.5, 0.5, 0.5)));
        "#,
    );
    let a = common::run_script(&first, &[]);
    let b = common::run_script(&second, &[]);
    assert!(a.ok && b.ok, "{}{}", a.rendered, b.rendered);
    let labels = |rows: &[felt::engine::profile::ProfileEntry]| {
        rows.iter().map(|r| r.label.clone()).collect::<Vec<_>>()
    };
    let (a_labels, b_labels) = (labels(&a.profile), labels(&b.profile));
    assert_eq!(a_labels.len(), 1, "{a_labels:?}");
    assert!(a_labels[0].contains("first.felt"), "{a_labels:?}");
    assert_eq!(b_labels.len(), 1, "{b_labels:?}");
    assert!(b_labels[0].contains("second.felt"), "{b_labels:?}");
    assert_eq!(b.profile[0].bricks_total, 8, "16³ cells are 8 bricks");
}

#[test]
fn interrupting_one_engine_leaves_another_running() {
    let dir = tempfile::tempdir().unwrap();
    let forever = script(
        dir.path(),
        "forever.felt",
        "int n = 0;\nwhile (true) { n = n + 1; }\n",
    );
    let start = |engine: Arc<Engine>| {
        let path = forever.clone();
        std::thread::spawn(move || common::run_script_on(engine, &path, &[]))
    };
    // A run clears its flag when it starts, so a request is repeated until the run ends (a
    // run that never stops fails after many requests rather than hanging the suite).
    let stop = |engine: &Engine, run: &std::thread::JoinHandle<common::Outcome>| {
        for _ in 0..6000 {
            if run.is_finished() {
                return;
            }
            engine.interrupt();
            std::thread::sleep(Duration::from_millis(10));
        }
        panic!("never stopped");
    };
    let (a, b) = (Engine::new(), Engine::new());
    let (run_a, run_b) = (start(a.clone()), start(b.clone()));
    stop(&a, &run_a);
    let outcome_a = run_a.join().unwrap();
    assert!(!outcome_a.ok);
    assert!(
        outcome_a.rendered.contains("interrupted"),
        "{}",
        outcome_a.rendered
    );
    assert!(!b.interrupted());
    for _ in 0..30 {
        assert!(!run_b.is_finished(), "the other session stopped too");
        std::thread::sleep(Duration::from_millis(10));
    }
    stop(&b, &run_b);
    let outcome_b = run_b.join().unwrap();
    assert!(
        outcome_b.rendered.contains("interrupted"),
        "{}",
        outcome_b.rendered
    );
}
