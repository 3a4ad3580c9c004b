//! Nacelle warps: the time to evaluate an exact three-iteration warp against the chapter's
//! cached variant (B·B and B·M·B sampled onto a grid every iteration, the fills included), on
//! the surface vertices of the cone-and-tori object and over a grid around it, with the
//! residual |Lo − Lr(X)| each leaves on the surface. The timing is done by the script's own
//! `clock()`, best of three runs, so it measures felt as a user runs it.

use felt::session::Session;
use std::io::Write;

const SCRIPT: &str = r#"
scalarfield ringA = torus((0, 0, 0), 0.55, 0.16);
scalarfield ringB = translate(rotate(torus((0, 0, 0), 0.55, 0.16), (1, 0, 0), 1.5707963267948966), (0.55, 0, 0));
scalarfield spike = cone((-0.3, 0.9, 0), (0, -1, 0), 0.35, 1.3);
scalarfield Lo = union(spike, union(ringA, ringB));
scalarfield Lr = sin(1.0 - length(identity()));
domain d((-1.0, -0.9, -0.8), (2.4, 1.9, 1.6), (0, 0, 0), 0.02);
domain cells((-1.0, -0.9, -0.8), (2.4, 1.9, 1.6), (0, 0, 0), 0.04);
shape obj = ls2shape(Lo, d);

func float worst(float[] r) {
    float w = 0;
    for (int i = 0; i < size(r); i++) { w = max(w, r[i]); }
    return w;
}
float[] best = {1e9, 1e9, 1e9, 1e9};
float[] residual = {0, 0};
for (int run = 0; run < 3; run++) {
    for (int cached = 0; cached < 2; cached++) {
        float start = clock();
        vectorfield X = nacelle(Lo, Lr, 3);
        if (cached == 1) { X = nacelle(Lo, Lr, 3, d); }
        shape s = setpointattr(obj, "r", abs(Lo - compose(Lr, X)));
        best[2 * cached] = min(best[2 * cached], clock() - start);
        residual[cached] = worst(pointattrfloat(s, "r"));
        start = clock();
        vector m = stats(length(X), cells);
        best[2 * cached + 1] = min(best[2 * cached + 1], clock() - start);
    }
}
print(vertices(obj), best[0], best[2], best[1], best[3], residual[0], residual[1]);
"#;

#[derive(Clone, Default)]
struct Captured(std::rc::Rc<std::cell::RefCell<Vec<u8>>>);

impl Write for Captured {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.0.borrow_mut().extend_from_slice(buf);
        Ok(buf.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

fn main() {
    let dir = tempfile::tempdir().expect("a scratch directory");
    let path = dir.path().join("nacelle_bench.felt");
    std::fs::write(&path, SCRIPT).expect("the script is written");
    let out = Captured::default();
    let mut session = Session::new(Box::new(out.clone())).unwrap_or_else(|_| panic!("a session"));
    if let Err(diagnostics) = session.run_file(&path) {
        panic!(
            "{}",
            felt::syntax::diagnostic::render(&diagnostics, &session.sources.borrow(), false)
        );
    }
    let text = String::from_utf8_lossy(&out.0.borrow()).into_owned();
    let v: Vec<f64> = text
        .split_whitespace()
        .filter_map(|t| t.parse().ok())
        .collect();
    let [
        vertices,
        exact_v,
        cached_v,
        exact_g,
        cached_g,
        exact_r,
        cached_r,
    ] = v[..]
    else {
        panic!("unexpected output: {text}");
    };
    println!("nacelle, 3 iterations, cone and tori onto sin(1 - |x|), cache cell 0.02");
    println!("| where | exact | cached (fills included) | cached / exact |");
    println!("|---|---|---|---|");
    println!(
        "| {vertices} surface vertices | {exact_v:.3} s | {cached_v:.3} s | {:.2} |",
        cached_v / exact_v
    );
    println!(
        "| 60 x 48 x 40 grid | {exact_g:.3} s | {cached_g:.3} s | {:.2} |",
        cached_g / exact_g
    );
    println!("residual on the surface: exact {exact_r:.2e}, cached {cached_r:.2e}");
}
