//! Fluids (chapters 6–8): the chapter's simulation scripts run as printed and give the values
//! their physics implies, `fftdivfree` keeps its promises seen from a script, obstacles never
//! leave inflow, memory follows the method (gridless grows, gridded and SELMA stay flat),
//! nothing is solved that no output reads, and bad input is a diagnostic.

mod common;

use common::{lines_of, numbers};
use std::path::Path;

fn chapter(name: &str) -> Vec<Vec<f64>> {
    let outcome = common::run_script(Path::new(&format!("tests/scripts/chapter/{name}")), &[]);
    lines_of(outcome).iter().map(|l| numbers(l)).collect()
}

fn close(a: f64, b: f64, tolerance: f64) -> bool {
    (a - b).abs() <= tolerance
}

#[test]
fn one_navier_stokes_step_conserves_momentum_and_removes_divergence() {
    let out = chapter("ns_step.felt");
    let (density, vx, vy, vz) = (&out[0], &out[1][0..3], &out[1][3..6], &out[1][6..9]);
    // From rest, advection changes nothing: the ball's cells are counted exactly.
    assert_eq!(density[..2], [0.0, 1.0]);
    // The projection keeps the mean flow (the k = 0 mode), which is the buoyant push:
    // mean(v_y) = dt · |g| · mean(density), and nothing sideways.
    assert!(
        close(vy[2], 0.1 * density[2], 1e-15),
        "{vy:?} vs {density:?}"
    );
    assert!(vx[2].abs() < 1e-15 && vz[2].abs() < 1e-15, "{vx:?} {vz:?}");
    // The central-difference divergence is zero inside, to round-off.
    let div = &out[2];
    assert!(div[0].abs() < 1e-13 && div[1].abs() < 1e-13, "{div:?}");
    // The gas rises in the ball and the surroundings sink to make room.
    assert!(out[3][1] > 0.05, "{:?}", out[3]);
    assert!(out[3][4] < 0.0, "{:?}", out[3]);
}

#[test]
fn hot_and_cold_gases_are_mirror_images_gridded_and_gridless() {
    for name in ["hotcold_gridded.felt", "hotcold_gridless.felt"] {
        let out = chapter(name);
        let (hot, cold) = (&out[0][0..3], &out[0][3..6]);
        assert!(hot[1] > 0.5 && hot[2] > 0.01, "{name}: {hot:?}");
        assert!(
            close(hot[2], cold[2], 1e-12 * hot[2]),
            "{name}: {hot:?} {cold:?}"
        );
        // hot(x, y, z) = cold(x, -y, z) everywhere on the cells, and v_y is odd in y.
        assert!(out[1][1] < 1e-5, "{name}: density asymmetry {:?}", out[1]);
        assert!(
            out[2][1] < 1e-5 * out[2][4],
            "{name}: velocity asymmetry {:?}",
            out[2]
        );
        // Hot gas rises where it is injected, cold gas sinks where it is.
        assert!(
            out[3][1] > 0.05 && out[3][4] < -0.05,
            "{name}: {:?}",
            out[3]
        );
    }
    // The two differ only by the densities' gridding: close, not equal.
    let (gridded, gridless) = (
        chapter("hotcold_gridded.felt"),
        chapter("hotcold_gridless.felt"),
    );
    assert!(
        close(gridded[3][1], gridless[3][1], 1e-3),
        "{:?} {:?}",
        gridded[3],
        gridless[3]
    );
    assert_ne!(gridded[0], gridless[0]);
}

#[test]
fn the_printed_boundary_lines_flip_outflow_and_reflect_flips_inflow() {
    let out = chapter("boundary.felt");
    // Printed: the inflow on the -x side passes, the outflow on the +x side is turned in.
    assert_eq!(out[0], [1.0, 0.0, 0.0, -1.0, -0.0, -0.0]);
    // The library: the inflow is turned out, the outflow passes.
    assert_eq!(out[1], [-1.0, 0.0, 0.0, 1.0, -0.0, -0.0]);
    assert_eq!(out[2], [1.0, 0.0, 0.0, 1.0, 0.0, 0.0]);
    // Sticky: alpha = 0.5 returns half the normal speed, alpha = 0 stops it.
    assert_eq!(out[3], [-0.5, 0.0, 0.0, 0.0, 0.0, 0.0]);
}

#[test]
fn gridless_advection_is_the_map_form_exactly() {
    let out = chapter("gridless_advection.felt");
    // Density advected step by step and the initial density composed with the advected map
    // are the same graph: identical values, not merely close.
    assert_eq!(out[0], [0.0, 0.0, 0.0]);
    // Eq. 7.2 written out equals two iterations of eq. 7.4.
    assert_eq!(out[1], [0.0, 0.0, 0.0]);
    // A divergence-free velocity moves the ball without changing its volume much (the
    // velocity is read trilinearly, which is divergence-free only approximately).
    let (before, after) = (out[2][2], out[2][5]);
    assert!(close(after, before, 0.15 * before), "{before} -> {after}");
    assert_ne!(before, after);
}

#[test]
fn selma_moves_the_map_with_the_buoyant_flow() {
    // Its back-traces stay inside the box: no warning about reads outside the map's domain.
    let outcome = common::run_script(Path::new("tests/scripts/chapter/selma.felt"), &[]);
    assert!(outcome.diagnostics.is_empty(), "{}", outcome.rendered);
    let out: Vec<Vec<f64>> = lines_of(outcome).iter().map(|l| numbers(l)).collect();
    // At the ball's start the map points below it: the gas there came from further down.
    assert!(out[0][1] < -0.41 && out[0][0].abs() < 1e-6, "{:?}", out[0]);
    // The density is the initial one moved: same peak, similar amount.
    assert_eq!(out[1][1], 1.0);
    assert!(close(out[1][2], out[1][5], 0.1 * out[1][5]), "{:?}", out[1]);
    // The map differs from the identity by at most a few hundredths after six frames.
    assert!(out[2][1] > 0.01 && out[2][1] < 0.1, "{:?}", out[2]);
}

/// The chapter's SELMA loop as printed, its density then read beyond the map's domain: there
/// the map reads the zero background, every such point maps to the origin (the ball's centre,
/// density 1), and the run says so once, with the count of those reads, at the `cachewrite`
/// line, naming the read that fixes it. With that read the density outside is the ball's: 0.
#[test]
fn a_map_read_outside_its_domain_warns_once_with_the_count() {
    let script = |read: &str| {
        format!(
            r#"param int frames = 10;
domain region((-1, -1, -1), (2, 2, 2), (0, 0, 0), 0.0625);
float dt = 0.1;
vector gravity = (0, 1, 0);
scalarfield initialdensity = mask(0.25 - identity() * identity());
vectorfield Xmap = identity();
vectorfield velocity;
scalarfield density = initialdensity;
for (int frame = 0; frame < frames; frame++) {{
    Xmap = advect(Xmap, velocity, dt);
    // Sample map onto into a grid
    vectorcache XmapCache(region);
    cachewrite( XmapCache, Xmap );
    // Replace Xmap with the gridded version
    Xmap = cacheread({read});
    density = compose(initialdensity, Xmap);
    velocity = advect( velocity, velocity, dt ) + dt*gravity*density ;
    velocity = fftdivfree( velocity, region );
}}
domain wide((-2, -2, -2), (4, 4, 4), (0, 0, 0), 0.125);
print(stats(density, wide));
print(probe(density, (1.2, 1.2, 1.2)));
"#
        )
    };
    let printed = common::run_source("selma.felt", &script("XmapCache"));
    assert!(printed.ok, "{}", printed.rendered);
    let warnings: Vec<_> = printed
        .diagnostics
        .iter()
        .filter(|d| d.message.contains("holds a map"))
        .collect();
    assert_eq!(warnings.len(), 1, "{}", printed.rendered);
    // `wide` has 32³ cell centres, of which the 16³ within (-1, 1)³ are inside the map's
    // domain; the probe is one more point outside: 32³ − 16³ + 1 reads outside.
    let expected = 32u64.pow(3) - 16u64.pow(3) + 1;
    assert!(
        warnings[0]
            .message
            .contains(&format!("{expected} reads of it landed outside")),
        "{}",
        printed.rendered
    );
    assert!(
        printed.rendered.contains("selma.felt:13:5"),
        "{}",
        printed.rendered
    );
    let help = warnings[0].help.as_deref().unwrap_or_default();
    assert!(
        help.contains(r#"cacheread(XmapCache, outside = "extrapolate")"#),
        "{help}"
    );
    // What the warning is about: outside the domain the density reads the ball's centre.
    let lines = lines_of(printed);
    assert_eq!(numbers(&lines[1]), [1.0]);
    // Read as the help says: no warning, and nothing outside the ball.
    let fixed = common::run_source(
        "selma.felt",
        &script(r#"XmapCache, outside = "extrapolate""#),
    );
    assert!(
        fixed.ok && fixed.diagnostics.is_empty(),
        "{}",
        fixed.rendered
    );
    let lines = lines_of(fixed);
    assert_eq!(numbers(&lines[1]), [0.0]);
    assert!(numbers(&lines[0])[2] < 0.01, "{}", lines[0]);
}

/// Seen from a script: the central-difference divergence of `fftdivfree`'s result, written
/// out with `translate`, is a millionth of its input's at every cell centre inside, `div` of
/// the result (which reads with the same differences) agrees, and the central gradient of a
/// periodic potential comes back as zero.
#[test]
fn a_script_sees_a_divergence_free_result() {
    let out = lines_of(common::run_source(
        "divfree.felt",
        r#"
        float h = 0.0625;
        domain d((-1, -1, -1), (2, 2, 2), (0, 0, 0), h);
        domain inside((-0.75, -0.75, -0.75), (1.5, 1.5, 1.5), (0, 0, 0), h);
        func scalarfield centraldiv(vectorfield v, float h) {
            return (translate(v.x, (-h, 0, 0)) - translate(v.x, (h, 0, 0))
                  + translate(v.y, (0, -h, 0)) - translate(v.y, (0, h, 0))
                  + translate(v.z, (0, 0, -h)) - translate(v.z, (0, 0, h))) / (2 * h);
        }
        func vectorfield centralgrad(scalarfield f, float h) {
            return vectorfield(translate(f, (-h, 0, 0)) - translate(f, (h, 0, 0)),
                               translate(f, (0, -h, 0)) - translate(f, (0, h, 0)),
                               translate(f, (0, 0, -h)) - translate(f, (0, 0, h))) / (2 * h);
        }
        vectorfield u = gaussiannoise(d, 0.15, 3, false);
        vectorfield v = fftdivfree(u, d);
        print(stats(abs(centraldiv(u, h)), inside), stats(abs(centraldiv(v, h)), inside));
        print(stats(abs(div(v)), inside));
        scalarfield phi = sin(3.14159265358979 * identity().x) * cos(3.14159265358979 * identity().y) + 0.3 * sin(6.28318530717959 * identity().z);
        vectorfield g = centralgrad(phi, h);
        print(stats(length(fftdivfree(g, d)), d), stats(length(g), d));
        "#,
    ));
    let div = numbers(&out[0]);
    assert!(div[1] > 1.0, "{div:?}");
    assert!(div[4] < 1e-6 * div[1], "{div:?}");
    assert!(numbers(&out[1])[1] < 1e-6 * div[1], "{}", out[1]);
    let gradient = numbers(&out[2]);
    assert!(gradient[1] < 1e-10 * gradient[4], "{gradient:?}");
}

/// Runs the felt binary on a script with `--profile` and extra arguments.
fn felt_cli(script: &Path, args: &[&str]) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_felt"))
        .arg("run")
        .arg(script)
        .arg("--profile")
        .args(args)
        .output()
        .expect("run felt")
}

/// The (grids, filled bricks, live bytes) of the profile row of `kind` in `felt --profile`'s
/// output.
fn profile_row(stderr: &str, kind: &str) -> (u64, u64, f64) {
    let line = stderr
        .lines()
        .find(|l| l.starts_with(kind))
        .unwrap_or_else(|| panic!("no {kind} row in:\n{stderr}"));
    let cells: Vec<&str> = line.split_whitespace().collect();
    let n = cells.len();
    let bytes = |value: &str, unit: &str| {
        let v: f64 = value.parse().unwrap();
        v * match unit {
            "B" => 1.0,
            "KiB" => 1024.0,
            "MiB" => 1024.0 * 1024.0,
            _ => 1024.0 * 1024.0 * 1024.0,
        }
    };
    (
        cells[n - 9].parse().unwrap(),
        cells[n - 7].parse().unwrap(),
        bytes(cells[n - 2], cells[n - 1]),
    )
}

#[test]
fn memory_follows_the_method() {
    let live = |name: &str, frames: &str| {
        let out = felt_cli(
            Path::new(&format!("tests/scripts/chapter/{name}")),
            &["--set", &format!("frames={frames}")],
        );
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        profile_row(&String::from_utf8_lossy(&out.stderr), "fftdivfree").2
    };
    // Gridless densities keep every frame's velocity alive: live memory grows with frames.
    let (short, long) = (
        live("hotcold_gridless.felt", "3"),
        live("hotcold_gridless.felt", "6"),
    );
    assert!(
        close(long, 2.0 * short, 0.05 * long),
        "gridless: {short} then {long}"
    );
    // Gridded densities and SELMA maps let old frames go: flat.
    for name in ["hotcold_gridded.felt", "selma.felt"] {
        let (short, long) = (live(name, "3"), live(name, "6"));
        assert_eq!(short, long, "{name}");
    }
}

#[test]
fn only_what_an_output_reads_is_solved() {
    let dir = tempfile::tempdir().unwrap();
    let script = dir.path().join("lazy.felt");
    let source = |probe_frame: i32| {
        format!(
            r#"
            domain region((-2, -2, -2), (4, 4, 4), (0, 0, 0), 0.25);
            scalarfield hot;
            vectorfield velocity;
            for (int frame = 0; frame < 10; frame++) {{
                hot = advect(hot, velocity, 0.1) + injectball((0, -1, 0), 0.5, 1.0, 0.1);
                scalarcache hotCache(region);
                cachewrite(hotCache, hot);
                hot = cacheread(hotCache);
                velocity = fftdivfree(advect(velocity, velocity, 0.1) + buoyancy(hot, (0, -1, 0), 0.1), region);
                if (frame == {probe_frame}) {{ print(probe(velocity, (0, 0, 0))); }}
            }}
            "#
        )
    };
    // Nothing reads the simulation: nothing is solved.
    std::fs::write(&script, source(-1)).unwrap();
    let out = felt_cli(&script, &[]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    // Ten caches and ten solves, counted as grids, not as the two lines that make them.
    assert!(
        stderr.contains("20 of 20 grids never evaluated: "),
        "{stderr}"
    );
    assert!(
        !stderr.lines().any(|l| l.starts_with("fftdivfree")),
        "{stderr}"
    );
    // A probe of frame 3 solves frames 0 to 3 and nothing after: 4 of 10 grids of 8 bricks.
    std::fs::write(&script, source(3)).unwrap();
    let out = felt_cli(&script, &[]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    let (grids, filled, _) = profile_row(&stderr, "fftdivfree");
    assert_eq!((grids, filled), (10, 4 * 8), "{stderr}");
    // The six solves after the probe never ran, nor the caches of frames 4 to 9 they read.
    assert!(
        stderr.contains("12 of 20 grids never evaluated: "),
        "{stderr}"
    );
    assert!(stderr.contains("(fftdivfree): 6 of 10"), "{stderr}");
    assert!(stderr.contains("(cachewrite): 6 of 10"), "{stderr}");
}

#[test]
fn reflection_leaves_no_inflow_on_or_inside_obstacles() {
    let out = lines_of(common::run_source(
        "obstacles.felt",
        r#"
        domain d((-1, -1, -1), (2, 2, 2), (0, 0, 0), 0.05);
        vectorfield wind = 3.0 * curlnoise(2.0, 4) + vectorfield((0.5, -1, 0.25));
        scalarfield[] objects = {sphere((0.1, 0, 0), 0.6), box((0, 0.1, 0), (0.5, 0.3, 0.7)),
                                 union(sphere((0.4, 0.4, 0), 0.3), box((-0.3, -0.3, 0), (0.3, 0.3, 0.3)))};
        for (int i = 0; i < size(objects); i++) {
            scalarfield o = objects[i];
            vectorfield inward = normalize(grad(o));
            vectorfield r = reflect(wind, o);
            // Inflow left on or inside the object, and the largest speed anywhere.
            print(stats(mask(o) * max(r * inward, 0.0), d), stats(length(r), d), stats(mask(o) * max(wind * inward, 0.0), d));
        }
        "#,
    ));
    for line in &out {
        let v = numbers(line);
        assert_eq!(v[1], 0.0, "inflow left: {line}");
        assert!(v[4].is_finite(), "{line}");
        assert!(
            v[7] > 0.1,
            "the wind flows into the object before reflection: {line}"
        );
    }
}

#[test]
fn bad_simulation_input_is_a_diagnostic_naming_the_line() {
    let error_of = |source: &str| {
        let outcome = common::run_source("bad.felt", source);
        assert!(!outcome.ok, "{source} ran");
        outcome.rendered
    };
    let zero = error_of("domain d((0, 0, 0), (1, 0, 1), (0, 0, 0), 0.1);\n");
    assert!(
        zero.contains("lengths must be positive") && zero.contains("bad.felt:1:"),
        "{zero}"
    );
    let scalar = error_of(
        "domain d((0, 0, 0), (1, 1, 1), (0, 0, 0), 0.1);\nvectorfield v = fftdivfree(identity().x, d);\n",
    );
    assert!(
        scalar.contains("bad.felt:2:") && scalar.contains("scalarfield"),
        "{scalar}"
    );
    let cells = error_of(
        "domain d((0, 0, 0), (1, 1, 1), (0, 0, 0));\nvectorfield v = fftdivfree(identity(), d);\n",
    );
    assert!(
        cells.contains("domain with cells") && cells.contains("bad.felt:2:"),
        "{cells}"
    );
    let dt = error_of("scalarfield f = advect(identity().x, identity(), 0.0 / 0.0);\n");
    assert!(
        dt.contains("time step of advect must be finite") && dt.contains("bad.felt:1:"),
        "{dt}"
    );
    let scheme =
        error_of("scalarfield f = advect(identity().x, identity(), 0.1, scheme = \"upwind\");\n");
    assert!(
        scheme.contains("\"maccormack\"") && scheme.contains("bad.felt:1:"),
        "{scheme}"
    );
    // A NaN velocity surfaces when an output needs the solve, naming the fftdivfree line.
    let nan = error_of(
        "domain d((-1, -1, -1), (2, 2, 2), (0, 0, 0), 0.25);\n\
         vectorfield u = vectorfield(sqrt(identity().x), 0, 0);\n\
         vectorfield v = fftdivfree(u, d);\n\
         print(probe(v, (0, 0, 0)));\n",
    );
    assert!(
        nan.contains("fftdivfree at")
            && nan.contains("bad.felt:3:17")
            && nan.contains("not finite"),
        "{nan}"
    );
    assert!(nan.contains("bad.felt:4:"), "{nan}");
}

#[test]
fn a_solve_over_the_memory_limit_is_refused_before_any_work() {
    let dir = tempfile::tempdir().unwrap();
    let script = dir.path().join("big.felt");
    std::fs::write(
        &script,
        "domain d((0, 0, 0), (1, 1, 1), (0, 0, 0), 1.0 / 256);\nvectorfield v = fftdivfree(identity(), d);\n",
    )
    .unwrap();
    let out = felt_cli(&script, &["--memory-limit", "64"]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains("memory budget") && stderr.contains("big.felt:2:"),
        "{stderr}"
    );
}

#[test]
fn a_graph_that_doubles_every_step_gets_one_warning() {
    // The limit is lowered from its default (a million nodes) so the test builds small graphs.
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("doubling.felt");
    std::fs::write(
        &path,
        r#"
        vectorfield velocity = 0.1 * vectorfield(sin(identity().y), sin(identity().z), sin(identity().x));
        for (int f = 0; f < 14; f++) {
            velocity = advect(velocity, velocity, 0.1);
        }
        "#,
    )
    .unwrap();
    let mut session = felt::session::Session::new(Box::new(std::io::sink()))
        .ok()
        .unwrap();
    session.interp.graph_warning_nodes = 20_000;
    assert!(session.run_file(&path).is_ok());
    let warnings = session.finish();
    let rendered = felt::syntax::diagnostic::render(&warnings, &session.sources.borrow(), false);
    let grown: Vec<_> = warnings
        .iter()
        .filter(|d| d.message.contains("graph has grown"))
        .collect();
    assert_eq!(grown.len(), 1, "{rendered}");
    assert!(rendered.contains("doubling.felt:4:24"), "{rendered}");
    assert!(rendered.contains("cache"), "{rendered}");
}

#[test]
fn simulations_are_bit_identical_for_any_thread_count() {
    let run = |threads: &str, script: &str| {
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_felt"))
            .args(["run", script, "--threads", threads])
            .output()
            .expect("run felt");
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        out.stdout
    };
    for script in [
        "tests/scripts/chapter/hotcold_gridded.felt",
        "tests/scripts/chapter/selma.felt",
    ] {
        assert_eq!(run("1", script), run("2", script), "{script}");
        assert_eq!(run("1", script), run("3", script), "{script}");
    }
}

#[test]
fn held_reads_never_leave_the_range_of_the_samples() {
    let out = lines_of(common::run_source(
        "hold.felt",
        r#"
        domain d((0, 0, 0), (1, 1, 1), (0, 0, 0), 0.25);
        scalarcache c(d);
        cachewrite(c, mask(0.75 - identity().x));
        // In the half cell inside the face at x = 1 the default read extrapolates the step
        // down to below zero; held, it keeps the edge cell's value.
        print(probe(cacheread(c), (0.99, 0.5, 0.5)), probe(cacheread(c, outside = "hold"), (0.99, 0.5, 0.5)));
        print(probe(cacheread(c, outside = "hold"), (0.01, 0.5, 0.5)), probe(cacheread(c, outside = "hold"), (1.01, 0.5, 0.5)));
        // Advected away from the wall it touches, a held density stays within [0, 1].
        domain box((-1, -1, -1), (2, 2, 2), (0, 0, 0), 0.1);
        scalarcache start(box);
        cachewrite(start, mask(0.22 - length(identity() - vectorfield((0.7, 0, 0)))));
        scalarfield rho = cacheread(start, outside = "hold");
        scalarfield plain = cacheread(start);
        for (int f = 0; f < 10; f++) {
            scalarcache a(box);
            cachewrite(a, advect(rho, vectorfield((-0.6, 0.2, 0)), 0.05));
            rho = cacheread(a, outside = "hold");
            scalarcache b(box);
            cachewrite(b, advect(plain, vectorfield((-0.6, 0.2, 0)), 0.05));
            plain = cacheread(b);
        }
        print(stats(rho, box), stats(plain, box));
        "#,
    ));
    let edge = numbers(&out[0]);
    assert!(edge[0] < -0.4, "{}", out[0]);
    assert_eq!(edge[1], 0.0, "{}", out[0]);
    assert_eq!(numbers(&out[1]), [1.0, 0.0]);
    let held = numbers(&out[2]);
    assert!(held[0] >= 0.0 && held[1] <= 1.0, "{}", out[2]);
    assert!(
        held[3] < 0.0,
        "the default read does go below zero here: {}",
        out[2]
    );
}
