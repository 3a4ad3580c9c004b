//! Advection's hard cases: Zalesak's slotted disk turned once, LeVeque's single vortex
//! undone, a CFL-20 step, long gridless chains and long SELMA map sequences. Each method's
//! error is asserted, and their ordering, since the ordering is why each method exists.

mod common;

use common::{lines_of, numbers};
use std::path::Path;

/// (area before, area after, symmetric difference, ...) printed by an advection script.
fn run(script: &str, method: u32, extra: &[(&str, &str)]) -> Vec<f64> {
    let method = method.to_string();
    let mut overrides = vec![("method", method.as_str())];
    overrides.extend_from_slice(extra);
    let path = format!("tests/scripts/advection/{script}");
    let out = lines_of(common::run_script(Path::new(&path), &overrides));
    out.iter().flat_map(|l| numbers(l)).collect()
}

#[test]
fn zalesak_disk_after_one_turn() {
    let zalesak = |method| run("zalesak.felt", method, &[]);
    let [sl, maccormack, bfecc, gridless, selma, naive, exact] = [0, 1, 2, 3, 4, 5, 6].map(zalesak);
    let area = sl[0];
    let loss = |r: &[f64]| (area - r[1]).abs() / area;
    // Gridded: first order loses a sixth of the disk; the corrected schemes keep most of it.
    assert!(loss(&sl) > 0.1, "{sl:?}");
    assert!(
        loss(&maccormack) < 0.5 * loss(&sl),
        "{maccormack:?} vs {sl:?}"
    );
    assert!(loss(&bfecc) < 0.5 * loss(&sl), "{bfecc:?} vs {sl:?}");
    assert!(bfecc[2] < 0.5 * sl[2], "shape: {bfecc:?} vs {sl:?}");
    // Gridless and SELMA maps of a rigid rotation are exact where it matters: an affine map
    // is reproduced by trilinear reads, extrapolated beyond the border.
    assert_eq!(gridless[1..3], [area, 0.0]);
    assert_eq!(selma[1..3], [area, 0.0]);
    // A map read with a zero background outside its domain is wrong near the corners.
    assert!(loss(&naive) > 0.1, "{naive:?}");
    // With the exact rotation as back trace the map comes back to the identity to round-off
    // of its f32 samples.
    assert_eq!(exact[1..3], [area, 0.0]);
    assert!(exact[3] < 2e-5, "map moved {}", exact[3]);
}

#[test]
fn single_vortex_comes_back_in_the_order_of_the_methods() {
    let vortex = |method| run("vortex.felt", method, &[]);
    let [
        sl,
        maccormack,
        bfecc,
        gridless,
        map_sl,
        map_maccormack,
        map_bfecc,
    ] = [0, 1, 2, 3, 4, 5, 6].map(vortex);
    let area = sl[0];
    // Gridded first order smears the filament away: nothing stays above one half.
    assert_eq!(sl[1], 0.0, "{sl:?}");
    assert!(sl[3] < 0.5, "{sl:?}");
    // The corrected schemes keep a peak and part of the shape.
    for r in [&maccormack, &bfecc] {
        assert!(r[2] < 0.75 * sl[2] && r[3] > 0.5, "{r:?} vs {sl:?}");
    }
    // Gridless follows the exact trajectories: the circle returns exactly.
    assert_eq!(gridless[1..4], [area, 0.0, 1.0]);
    // SELMA keeps the density sharp (its peak is the initial one); under this shear a
    // first-order map falls apart and a MacCormack map does not, BFECC in between.
    for r in [&map_sl, &map_maccormack, &map_bfecc] {
        assert_eq!(r[3], 1.0, "{r:?}");
    }
    assert!(
        map_maccormack[2] < 0.2 * map_sl[2],
        "{map_maccormack:?} vs {map_sl:?}"
    );
    assert!(
        map_maccormack[2] < map_bfecc[2],
        "{map_maccormack:?} vs {map_bfecc:?}"
    );
    assert!(map_bfecc[2] < 0.5 * bfecc[2], "{map_bfecc:?} vs {bfecc:?}");
}

#[test]
fn a_cfl_20_step_stays_within_the_initial_values() {
    let out = lines_of(common::run_source(
        "cfl.felt",
        r#"
        domain d((-1, -1, -1), (2, 2, 2), (0, 0, 0), 0.05);
        scalarfield blob = exp(-8 * (identity() - vectorfield((0.3, 0, 0))) * (identity() - vectorfield((0.3, 0, 0))))
                         * (0.5 + 0.5 * sin(9 * identity().y));
        scalarcache c(d);
        cachewrite(c, blob);
        scalarfield rho = cacheread(c);
        // A rotation about z fast enough to cross 20 cells per step at radius 0.5.
        vectorfield spin = 2.0 * vectorfield(-identity().y, identity().x, scalarfield(0));
        float dt = 1.0;
        string[] schemes = {"semilagrangian", "maccormack", "bfecc"};
        print(stats(rho, d));
        for (int i = 0; i < 3; i++) {
            scalarcache after(d);
            cachewrite(after, advect(rho, spin, dt, 1, schemes[i]));
            print(stats(cacheread(after), d));
        }
        "#,
    ));
    let initial = numbers(&out[0]);
    for line in &out[1..] {
        let after = numbers(line);
        // Points traced out of the domain read the background, 0.
        assert!(
            after[1] <= initial[1] && after[0] >= 0.0,
            "{line} vs {:?}",
            initial
        );
        assert!(after[1] > 0.2 * initial[1], "{line}");
    }
}

#[test]
fn sixty_gridless_steps_and_two_hundred_selma_steps_stay_finite() {
    let out = lines_of(common::run_source(
        "long.felt",
        r#"
        domain region((-1, -1, -1), (2, 2, 2), (0, 0, 0), 0.125);
        domain mapregion((-1, -1, -1), (2, 2, 2), (0, 0, 0), 1.0 / 12);
        // An unrelated buoyant flow: a fixed warm ball drives it.
        scalarfield warm = mask(0.1 - (identity() - vectorfield((0, -0.5, 0))) * (identity() - vectorfield((0, -0.5, 0))));
        vectorfield velocity;
        scalarfield density = mask(0.2 - identity() * identity());
        for (int f = 0; f < 60; f++) {
            velocity = fftdivfree(advect(velocity, velocity, 0.05) + buoyancy(warm, (0, -4, 0), 0.05), region);
            density = advect(density, velocity, 0.05);
        }
        print(stats(density, region));
        // Two hundred SELMA steps through a steady swirl.
        vectorfield swirl = vectorfield(-identity().y, identity().x, 0.3 * sin(3 * identity().x));
        vectorfield map = identity();
        for (int s = 0; s < 200; s++) {
            map = selmastep(map, swirl, 0.05, mapregion);
        }
        print(stats(map.x, mapregion), stats(map.y, mapregion), stats(map.z, mapregion));
        "#,
    ));
    let density = numbers(&out[0]);
    assert!(density.iter().all(|v| v.is_finite()), "{}", out[0]);
    assert!(density[1] > 0.5 && density[0] >= 0.0, "{}", out[0]);
    // The map's values are points: finite and within the domain padded by its own size.
    let map = numbers(&out[1]);
    assert!(
        map.iter().all(|v| v.is_finite() && v.abs() < 3.0),
        "{}",
        out[1]
    );
}

#[test]
fn corrected_schemes_let_density_leave_the_domain() {
    // A blob carried out through a face: where the traces leave the grid the schemes fall
    // back to the plain back trace, so no density is put back from outside.
    let out = lines_of(common::run_source(
        "outflow.felt",
        r#"
        domain region((-1, -1, -1), (2, 2, 2), (0, 0, 0), 2.0 / 32);
        vectorfield velocity = vectorfield((1, 0.3, 0));
        string[] schemes = {"semilagrangian", "maccormack", "bfecc"};
        for (int s = 0; s < 3; s++) {
            scalarcache c0(region);
            cachewrite(c0, lsdensitysmooth(sphere((0.3, 0, 0), 0.25), 0.05));
            scalarfield rho = cacheread(c0);
            float before = stats(rho, region).z;
            for (int f = 0; f < 30; f++) {
                scalarcache c(region);
                cachewrite(c, advect(rho, velocity, 0.05, 1, schemes[s]));
                rho = cacheread(c);
            }
            print(before, stats(rho, region).z);
        }
        "#,
    ));
    for line in &out {
        let v = numbers(line);
        assert!(v[1].abs() < 1e-4 * v[0], "{line}");
    }
}
