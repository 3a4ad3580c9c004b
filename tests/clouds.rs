//! The cloud automaton end to end: the light sweep over a cloud grid against closed forms and
//! the marched light cache, that rendering one frame smooths and lights only that frame, and
//! bad inputs as diagnostics.

mod common;

use felt::cloud::{CloudState, Probabilities, Probability, SmoothedCloud, Smoothing, Wind};
use felt::render::Light;
use felt::render::TransmissivityMethod;
use felt::render::transmittance::light_columns;
use felt::space::domain::Domain;
use felt::space::{Aabb, FnField};
use glam::DVec3;

/// Distance from `p` inside the box `[0, lengths]` to where the ray along `u` leaves it.
fn exit(p: DVec3, u: DVec3, lengths: DVec3) -> f64 {
    (0..3)
        .filter(|&a| u[a] != 0.0)
        .map(|a| {
            if u[a] > 0.0 {
                (lengths[a] - p[a]) / u[a]
            } else {
                -p[a] / u[a]
            }
        })
        .fold(f64::INFINITY, f64::min)
}

#[test]
fn the_sweep_through_a_homogeneous_slab_is_beer_lambert() {
    // A slab of density 1 filling a 2 x 1 x 2 box of 1/16 cells, lit from above at 25° off
    // vertical (the sweep runs along y, the source's first case). Exact: T = exp(−σ·d), d the
    // path from the cell centre to where the line towards the light leaves the box.
    let h = 1.0 / 16.0;
    let lengths = DVec3::new(2.0, 1.0, 2.0);
    let domain = Domain::with_cells(DVec3::ZERO, lengths, DVec3::ZERO, h, h).unwrap();
    let slab = FnField::new(1, |_p: DVec3, out: &mut [f64]| out[0] = 1.0)
        .with_bounds(Aabb::new(DVec3::ZERO, lengths));
    let travel = DVec3::new(0.4, -1.0, 0.25).normalize();
    let light = Light::distant(travel, DVec3::ONE).unwrap();
    let grid = light_columns(
        &slab,
        &light,
        &domain,
        TransmissivityMethod::Sweep,
        f64::INFINITY,
    )
    .unwrap();
    let sigma = 3.0;
    let [nx, ny, nz] = domain.resolution.unwrap();
    let columns = grid.columns();
    let (mut worst_inside, mut worst) = (0f64, 0f64);
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                let p = domain.cell_center(i, j, k);
                let d = exit(p, -travel, lengths);
                let error = ((-sigma * columns[i + nx * (j + ny * k)] as f64).exp()
                    - (-sigma * d).exp())
                .abs();
                worst = worst.max(error);
                // Lines that leave through the top, at least two cells from the side faces all
                // the way: there every upstream read interpolates a column that is linear
                // across the slice, which the sweep's interpolation reproduces exactly, and the
                // trapezoid rule is exact for a constant density.
                let top = p - travel * d;
                let clear = [0, 2].iter().all(|&a| {
                    p[a].min(top[a]) > 2.0 * h && p[a].max(top[a]) < lengths[a] - 2.0 * h
                });
                if clear {
                    worst_inside = worst_inside.max(error);
                }
            }
        }
    }
    // Inside: only the f32 rounding of the stored columns, read back and added to slice after
    // slice (16 slices here): under 1e-5 in transmittance.
    assert!(worst_inside < 1e-5, "inside {worst_inside}");
    // Next to the side faces the column bends within a cell and is read by interpolation: the
    // error is bounded by the optical depth of one cell along the light, σ·h/|u_y|.
    let bound = sigma * h / travel.y.abs();
    assert!(worst < bound, "worst {worst}, bound {bound}");
}

fn grown_cloud(n: [usize; 3], cell: f64) -> (Domain, SmoothedCloud) {
    let lengths = DVec3::new(n[0] as f64, n[1] as f64, n[2] as f64) * cell;
    let domain = Domain::with_cells(DVec3::ZERO, lengths, DVec3::ZERO, cell, cell).unwrap();
    let start = Probabilities {
        hum: Probability::uniform(0.6),
        act: Probability::uniform(0.004),
        ext: Probability::uniform(0.0),
    };
    let mut s = CloudState::initial(domain.clone(), n, 3, &start);
    let p = Probabilities {
        hum: Probability::uniform(0.02),
        act: Probability::uniform(0.0),
        ext: Probability::uniform(0.02),
    };
    for _ in 0..10 {
        s = s.step(&p, &Wind::CALM);
    }
    let density = SmoothedCloud::new(
        domain.clone(),
        s.planes,
        s.cloud_frames(2),
        Smoothing {
            radius: 1,
            window: 1,
        },
    );
    (domain, density)
}

#[test]
fn the_sweep_agrees_with_the_marched_light_cache_on_a_cloud() {
    // A grown automaton cloud, 64 x 16 x 64 cells, κ = 8 per unit length at density 1 (about
    // half an optical depth per cell): the sweep over the cloud's own cells against the light
    // cache filled by marching from every cell, in transmittance.
    let cell = 1.0 / 16.0;
    let (domain, density) = grown_cloud([64, 16, 64], cell);
    let light = Light::distant(DVec3::new(0.5, -1.0, -0.3), DVec3::ONE).unwrap();
    let kappa = 8.0;
    let swept = light_columns(
        &density,
        &light,
        &domain,
        TransmissivityMethod::Sweep,
        f64::INFINITY,
    )
    .unwrap();
    let marched = light_columns(
        &density,
        &light,
        &domain,
        TransmissivityMethod::March,
        f64::INFINITY,
    )
    .unwrap();
    let (mut sum, mut worst) = (0.0, 0f64);
    let (swept, marched) = (swept.columns(), marched.columns());
    for (a, b) in swept.iter().zip(&marched) {
        let d = ((-kappa * *a as f64).exp() - (-kappa * *b as f64).exp()).abs();
        sum += d;
        worst = worst.max(d);
    }
    let mean = sum / swept.len() as f64;
    let lit: f64 = marched
        .iter()
        .map(|c| (-kappa * *c as f64).exp())
        .sum::<f64>()
        / marched.len() as f64;
    eprintln!("sweep vs marched cache: mean |ΔT| {mean:.2e}, worst {worst:.3}, mean T {lit:.3}");
    // The cloud must shadow itself for the comparison to mean anything.
    assert!(lit < 0.9 && lit > 0.1, "mean transmittance {lit}");
    // The sweep interpolates the column slice after slice and so softens shadow edges, where
    // its worst cells lie; over the whole cloud it agrees to a mean |ΔT| under 0.01.
    assert!(mean < 0.01, "mean |ΔT| {mean}, worst {worst}");
    assert!(worst < 0.25, "worst |ΔT| {worst}, mean {mean}");
}

const SKY: &str = r#"
param int frame = 5;
domain d((0, 0, 0), (4, 1, 4), (0, 0, 0), 0.125);
cloudsim s = cloudsim(d, seed = 2, hum = 0.5, act = 0.01);
for (int f = 0; f < frame; f++) {
    s = cloudstep(s, hum = 0.05, act = 0.002, ext = 0.03, wind = (0.5, 0, 0));
}
scalarfield rho = clouddensity(s);
camera cam = camera((2, 0.5, 9), (2, 0.5, 2), (0, 1, 0), 40);
light sun = distantlight((0.3, -1, 0.2));
render("sky.png", density = rho, camera = cam, lights = {sun}, kappa = 5.0, width = 8, height = 6,
       shadows = "sweep", bounds = d);
"#;

#[test]
fn rendering_a_frame_steps_to_it_but_smooths_and_lights_only_it() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("onlyframe.felt");
    std::fs::write(&path, SKY).unwrap();
    std::env::set_current_dir(dir.path()).unwrap();
    let outcome = common::run_script(&path, &[("frame", "12")]);
    assert!(outcome.ok, "{}", outcome.rendered);
    let rows = outcome.profile;
    let row = |kind: &str| {
        rows.iter()
            .filter(|e| e.kind == kind)
            .map(|e| {
                (
                    e.instances,
                    e.bricks_total,
                    e.bricks_filled + e.bricks_skipped,
                )
            })
            .fold((0, 0, 0), |a, b| (a.0 + b.0, a.1 + b.1, a.2 + b.2))
    };
    assert_eq!(row("cloudstep").0, 12, "{rows:?}");
    let (smoothed, bricks, resolved) = row("clouddensity");
    assert_eq!(smoothed, 1, "{rows:?}");
    // 32 x 8 x 32 cells are 4 x 1 x 4 bricks of the one smoothed grid.
    assert_eq!(bricks, 16, "{rows:?}");
    assert!((1..=16).contains(&resolved), "{rows:?}");
    assert_eq!(row("lightgrid").0, 1, "{rows:?}");
}

#[test]
fn bad_cloud_inputs_are_diagnostics() {
    for (source, message) in [
        (
            "domain d((0,0,0), (1,1,1), (0,0,0)); cloudsim s = cloudsim(d);",
            "domain with cells",
        ),
        (
            "domain d((0,0,0), (1,1,1), (0,0,0), 0.25); cloudsim s = cloudsim(d); s = cloudstep(s, wind = (1, 1, 0));",
            "y component must be 0",
        ),
        (
            "domain d((0,0,0), (1,1,1), (0,0,0), 0.25); cloudsim s = cloudsim(d); scalarfield r = clouddensity(s, radius = 4);",
            "radius must be between 0 and 3",
        ),
        (
            "domain d((0,0,0), (1,1,1), (0,0,0), 0.25); cloudsim s = cloudsim(d); s = cloudstep(s, steps = -1);",
            "cloudstep steps must be between 0 and 1000000, found -1",
        ),
        (
            "domain d((0,0,0), (1,1,1), (0,0,0), 0.25); cloudsim s = cloudsim(d); s = cloudstep(s, steps = 1000001);",
            "cloudstep steps must be between 0 and 1000000, found 1000001",
        ),
        (
            // Close to the largest int: refused at once, not left stepping for ages.
            "domain d((0,0,0), (1,1,1), (0,0,0), 0.25); cloudsim s = cloudsim(d); s = cloudstep(s, steps = 9200000000000000000);",
            "cloudstep steps must be between 0 and 1000000, found 9200000000000000000",
        ),
        (
            "scalarfield e = cloudellipsoid((0, 0, 0), (1, 0, 1));",
            "radii must be positive",
        ),
    ] {
        let outcome = common::run_source("bad.felt", source);
        assert!(!outcome.ok, "{source}");
        assert!(
            outcome.rendered.contains(message) && outcome.rendered.contains("bad.felt:1:"),
            "{source}: {}",
            outcome.rendered
        );
    }
}
