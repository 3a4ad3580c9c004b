//! The projection's promises, checked on the periodic grid itself: the central-difference
//! divergence vanishes, projecting twice changes nothing, discrete gradients are removed and
//! discrete curls kept, in axis-aligned and rotated domains.

use super::DivergenceFree;
use crate::space::domain::Domain;
use crate::space::{FieldSampler, FnField};
use glam::DVec3;
use std::sync::Arc;

/// A reproducible number in [-1, 1] for (seed, cell).
fn noise(seed: u64, cell: usize) -> f64 {
    let mut z = seed.wrapping_mul(0x9e37_79b9_7f4a_7c15)
        ^ (cell as u64).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 30)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^= z >> 31;
    (z >> 11) as f64 / (1u64 << 52) as f64 - 1.0
}

/// Cells of a small periodic grid with index arithmetic that wraps.
struct Periodic {
    domain: Domain,
    n: [usize; 3],
}

impl Periodic {
    fn new(orientation: DVec3) -> Periodic {
        let domain = Domain::with_cells(
            DVec3::new(-0.3, 0.2, 0.1),
            DVec3::new(1.1, 1.0, 0.7),
            orientation,
            0.1,
            0.1,
        )
        .unwrap();
        let n = domain.resolution.unwrap();
        Periodic { domain, n }
    }

    fn index(&self, c: [isize; 3]) -> usize {
        let w = |a: usize| c[a].rem_euclid(self.n[a] as isize) as usize;
        w(0) + self.n[0] * (w(1) + self.n[1] * w(2))
    }

    fn cells(&self) -> impl Iterator<Item = [isize; 3]> + '_ {
        let [nx, ny, nz] = self.n;
        (0..nx * ny * nz).map(move |c| {
            [
                (c % nx) as isize,
                (c / nx % ny) as isize,
                (c / (nx * ny)) as isize,
            ]
        })
    }

    /// Central differences of a per-cell scalar along grid axis `a`, wrapping around.
    fn central(&self, f: &[f64], c: [isize; 3], a: usize) -> f64 {
        let mut up = c;
        let mut down = c;
        up[a] += 1;
        down[a] -= 1;
        (f[self.index(up)] - f[self.index(down)]) / (2.0 * self.domain.cell[a])
    }

    /// A field that reads per-cell vectors given in the grid's frame, turned to world axes.
    fn field(&self, local: Vec<DVec3>) -> Arc<dyn FieldSampler> {
        let rotation = self.domain.rotation;
        let domain = self.domain.clone();
        let n = self.n;
        Arc::new(FnField::new(3, move |p, out: &mut [f64]| {
            let u = domain.world_to_index(p);
            let c = [
                u.x.round() as usize,
                u.y.round() as usize,
                u.z.round() as usize,
            ];
            let v = rotation * local[c[0] + n[0] * (c[1] + n[1] * c[2])];
            out.copy_from_slice(&v.to_array());
        }))
    }

    fn project(&self, local: Vec<DVec3>) -> Vec<DVec3> {
        let solve =
            DivergenceFree::new(self.domain.clone(), self.field(local), "test".into()).unwrap();
        let to_local = self.domain.rotation.transpose();
        self.cells()
            .map(|c| {
                to_local
                    * solve
                        .cell_value(c[0] as usize, c[1] as usize, c[2] as usize)
                        .unwrap()
            })
            .collect()
    }

    /// The largest |central divergence| over all cells (periodic).
    fn divergence(&self, v: &[DVec3]) -> f64 {
        let comp = |a: usize| v.iter().map(|v| v[a]).collect::<Vec<f64>>();
        let parts = [comp(0), comp(1), comp(2)];
        self.cells()
            .map(|c| {
                (0..3)
                    .map(|a| self.central(&parts[a], c, a))
                    .sum::<f64>()
                    .abs()
            })
            .fold(0.0, f64::max)
    }
}

fn largest(v: &[DVec3]) -> f64 {
    v.iter().map(|v| v.abs().max_element()).fold(0.0, f64::max)
}

fn random_vectors(grid: &Periodic, seed: u64) -> Vec<DVec3> {
    grid.cells()
        .map(|c| {
            let i = grid.index(c);
            DVec3::new(
                noise(seed, 3 * i),
                noise(seed, 3 * i + 1),
                noise(seed, 3 * i + 2),
            )
        })
        .collect()
}

#[test]
fn the_central_divergence_vanishes_and_a_second_projection_changes_nothing() {
    for orientation in [DVec3::ZERO, DVec3::new(0.4, -0.7, 0.25)] {
        let grid = Periodic::new(orientation);
        let u = random_vectors(&grid, 3);
        let before = grid.divergence(&u);
        let once = grid.project(u);
        let after = grid.divergence(&once);
        assert!(before > 1.0, "{before}");
        assert!(
            after < 1e-12 * before,
            "divergence {after} of {before} ({orientation})"
        );
        let twice = grid.project(once.clone());
        let change = once
            .iter()
            .zip(&twice)
            .map(|(a, b)| (*a - *b).abs().max_element())
            .fold(0.0, f64::max);
        assert!(
            change < 1e-12 * largest(&once),
            "second projection moved values by {change}"
        );
    }
}

#[test]
fn gradients_vanish_and_curls_are_kept() {
    for orientation in [DVec3::ZERO, DVec3::new(-0.2, 0.9, 0.5)] {
        let grid = Periodic::new(orientation);
        let cells: Vec<[isize; 3]> = grid.cells().collect();
        // The discrete gradient of a random periodic potential.
        let phi: Vec<f64> = (0..cells.len()).map(|i| noise(11, i)).collect();
        let gradient: Vec<DVec3> = cells
            .iter()
            .map(|&c| {
                DVec3::new(
                    grid.central(&phi, c, 0),
                    grid.central(&phi, c, 1),
                    grid.central(&phi, c, 2),
                )
            })
            .collect();
        let projected = grid.project(gradient.clone());
        assert!(
            largest(&projected) < 1e-10 * largest(&gradient),
            "{}",
            largest(&projected)
        );
        // The discrete curl of a random periodic vector potential.
        let a = random_vectors(&grid, 17);
        let part = |k: usize| a.iter().map(|v| v[k]).collect::<Vec<f64>>();
        let (ax, ay, az) = (part(0), part(1), part(2));
        let curl: Vec<DVec3> = cells
            .iter()
            .map(|&c| {
                DVec3::new(
                    grid.central(&az, c, 1) - grid.central(&ay, c, 2),
                    grid.central(&ax, c, 2) - grid.central(&az, c, 0),
                    grid.central(&ay, c, 0) - grid.central(&ax, c, 1),
                )
            })
            .collect();
        let kept = grid.project(curl.clone());
        let change = kept
            .iter()
            .zip(&curl)
            .map(|(a, b)| (*a - *b).abs().max_element())
            .fold(0.0, f64::max);
        assert!(change < 1e-10 * largest(&curl), "curl changed by {change}");
    }
}

#[test]
fn a_constant_flow_is_kept_and_nothing_is_solved_before_it_is_read() {
    let grid = Periodic::new(DVec3::ZERO);
    let flow = DVec3::new(0.5, -1.0, 2.0);
    let solve = DivergenceFree::new(
        grid.domain.clone(),
        Arc::new(FnField::new(3, move |_, out: &mut [f64]| {
            out.copy_from_slice(&flow.to_array())
        })),
        "constant".into(),
    )
    .unwrap();
    assert!(!solve.is_solved());
    let v = solve.cell_value(3, 2, 1).unwrap();
    assert!(solve.is_solved());
    assert!((v - flow).length() < 1e-14, "{v}");
}

#[test]
fn a_non_finite_velocity_is_an_error_naming_the_cell() {
    let grid = Periodic::new(DVec3::ZERO);
    let solve = DivergenceFree::new(
        grid.domain.clone(),
        Arc::new(FnField::new(3, |p, out: &mut [f64]| {
            out.copy_from_slice(&[0.0, if p.x > 0.5 { f64::NAN } else { 1.0 }, 0.0])
        })),
        "fftdivfree at scene.felt:3:5".into(),
    )
    .unwrap();
    let failure = crate::space::GridSource::solve(&solve).unwrap_err();
    assert!(
        failure.message.contains("fftdivfree at scene.felt:3:5"),
        "{}",
        failure.message
    );
    assert!(
        failure
            .message
            .contains("not finite (NaN) at cell (8, 0, 0)"),
        "{}",
        failure.message
    );
}
