//! How fast a tower of nested Laplacians of `perlin()` is built, and how many nodes it makes:
//! `laplacian` (the divergence of the gradient, the diagonal of the Hessian alone) against the
//! nine-term form it replaced (the trace of the full Hessian, `trace(grad(grad(f)))`), which
//! builds the same graph and throws two thirds of the second derivatives away.
//!
//! The node table is process-wide and remembers the ids of nodes it made, so each tower is
//! built in a process of its own (this program run again with `FELT_TOWER` set): a second
//! form built in the same process would find the first one's nodes and make fewer.
//!
//! Run with `cargo bench --bench derivative_tower`. The nine-term form is built up to 10
//! levels only: at 12 it takes minutes and tens of gigabytes. A tower that does not fit in
//! the default memory budget (half of the memory felt may use) is reported as refused.

use felt::field::noise::NoiseKind;
use felt::field::{Field, grad, laplacian, node};
use std::process::Command;
use std::time::Instant;

/// What one build measured: seconds, nodes made, nodes in the result's graph.
struct Build {
    seconds: f64,
    made: u64,
    graph: usize,
}

/// Builds `levels` nested Laplacians of Perlin noise in this process; `None` when the memory
/// budget refuses it.
fn build(levels: usize, nine_terms: bool) -> Option<Build> {
    let mut f = Field::noise(NoiseKind::Perlin, 0);
    let made_before = node::nodes_made();
    let start = Instant::now();
    for _ in 0..levels {
        f = if nine_terms {
            grad(&grad(&f).ok()?).ok()?.trace().ok()?
        } else {
            laplacian(&f).ok()?
        };
    }
    let seconds = start.elapsed().as_secs_f64();
    Some(Build {
        seconds,
        made: node::nodes_made() - made_before,
        graph: node::postorder(f.components()).len(),
    })
}

/// The same build in a child process: a fresh node table.
fn build_apart(levels: usize, nine_terms: bool) -> Option<Build> {
    let form = if nine_terms { "nine" } else { "diagonal" };
    let output = Command::new(std::env::current_exe().unwrap())
        .env("FELT_TOWER", format!("{form}:{levels}"))
        .output()
        .unwrap();
    let line = String::from_utf8_lossy(&output.stdout);
    if line.trim() == "refused" {
        return None;
    }
    let fields: Vec<&str> = line.split_whitespace().collect();
    assert!(
        fields.len() == 3,
        "the child said {line:?}\n{}",
        String::from_utf8_lossy(&output.stderr)
    );
    Some(Build {
        seconds: fields[0].parse().unwrap(),
        made: fields[1].parse().unwrap(),
        graph: fields[2].parse().unwrap(),
    })
}

fn main() {
    if let Ok(job) = std::env::var("FELT_TOWER") {
        let (form, levels) = job.split_once(':').unwrap();
        match build(levels.parse().unwrap(), form == "nine") {
            Some(b) => println!("{} {} {}", b.seconds, b.made, b.graph),
            None => println!("refused"),
        }
        return;
    }
    println!(
        "{:>6} {:>10} {:>12} {:>12} {:>11} {:>12} {:>11}",
        "levels", "seconds", "nodes made", "graph nodes", "9-term s", "9-term made", "made ratio"
    );
    for levels in [8, 10, 12] {
        let Some(diagonal) = build_apart(levels, false) else {
            println!("{levels:>6} refused: over the default memory budget");
            continue;
        };
        let nine = (levels <= 10).then(|| build_apart(levels, true)).flatten();
        let (nine_seconds, nine_made, ratio) = match &nine {
            Some(n) => {
                assert_eq!(
                    n.graph, diagonal.graph,
                    "the two forms built different graphs"
                );
                (
                    format!("{:.2}", n.seconds),
                    n.made.to_string(),
                    format!("{:.2}", n.made as f64 / diagonal.made as f64),
                )
            }
            None => ("-".into(), "-".into(), "-".into()),
        };
        println!(
            "{levels:>6} {:>10.2} {:>12} {:>12} {nine_seconds:>11} {nine_made:>12} {ratio:>11}",
            diagonal.seconds, diagonal.made, diagonal.graph
        );
    }
}
