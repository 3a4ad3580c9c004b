//! The Rust side of `bench/bench.py`'s first figure: a fresh session on one engine running a
//! one-line script, as `felt.Session.run` does from Python, timed the same way (the mean of
//! many runs after a warm-up). `cargo run --release --example one_line`.

use felt::engine::Engine;
use felt::session::Session;
use std::time::Instant;

const SCRIPT: &str = "float a = 1.0 + 2.0;";
const RUNS: u32 = 200;

fn run_once(engine: &std::sync::Arc<Engine>) {
    let mut session = match Session::with_engine(Box::new(std::io::sink()), engine.clone()) {
        Ok(session) => session,
        Err(_) => {
            eprintln!("the standard library failed to load");
            std::process::exit(70);
        }
    };
    if session.run_source("<bench>", SCRIPT).is_err() {
        eprintln!("the one-line script failed");
        std::process::exit(70);
    }
    session.finish();
}

fn main() {
    let engine = Engine::new();
    for _ in 0..10 {
        run_once(&engine);
    }
    let start = Instant::now();
    for _ in 0..RUNS {
        run_once(&engine);
    }
    let mean = start.elapsed().as_secs_f64() / f64::from(RUNS);
    println!("rust one-line run: {:.3} ms", mean * 1e3);
}
