//! 3×3 matrix algebra on scalar nodes (row-major, nine nodes per matrix) and the per-point
//! pseudo-inverse kernel.
//!
//! The one key decision: `inverse` of a matrixfield is the Moore–Penrose pseudo-inverse at
//! points where the matrix is singular, rather than infinities. At a well-conditioned point it is
//! the ordinary inverse (by the adjugate, exact to rounding); where the determinant is negligible
//! against the scale of the rows, it is `V Σ⁺ Vᵀ Aᵀ` from the eigen-decomposition of `AᵀA`,
//! dropping singular values below 1e-7 of the largest. A field that is singular on a set of
//! measure zero (a Jacobian at a fold) therefore stays finite and continuous where it can be.

use crate::field::node::{self, NodeRef};

pub type Mat = [NodeRef; 9];
pub type Vec3 = [NodeRef; 3];

pub fn mat_vec(m: &[NodeRef], v: &[NodeRef]) -> Vec3 {
    std::array::from_fn(|r| dot(&m[r * 3..r * 3 + 3], v))
}

pub fn mat_mul(a: &[NodeRef], b: &[NodeRef]) -> Mat {
    std::array::from_fn(|i| {
        let (r, c) = (i / 3, i % 3);
        node::sum((0..3).map(|k| node::mul(a[r * 3 + k].clone(), b[k * 3 + c].clone())))
    })
}

pub fn transpose(m: &[NodeRef]) -> Mat {
    std::array::from_fn(|i| m[(i % 3) * 3 + i / 3].clone())
}

pub fn dot(a: &[NodeRef], b: &[NodeRef]) -> NodeRef {
    node::sum(
        a.iter()
            .zip(b)
            .map(|(x, y)| node::mul(x.clone(), y.clone())),
    )
}

pub fn cross(a: &[NodeRef], b: &[NodeRef]) -> Vec3 {
    let term = |i: usize, j: usize| {
        node::sub(
            node::mul(a[i].clone(), b[j].clone()),
            node::mul(a[j].clone(), b[i].clone()),
        )
    };
    [term(1, 2), term(2, 0), term(0, 1)]
}

pub fn det(m: &[NodeRef]) -> NodeRef {
    let rows: [&[NodeRef]; 3] = [&m[0..3], &m[3..6], &m[6..9]];
    dot(rows[0], &cross(rows[1], rows[2]))
}

pub fn trace(m: &[NodeRef]) -> NodeRef {
    node::sum([m[0].clone(), m[4].clone(), m[8].clone()])
}

/// The inverse, or where singular the pseudo-inverse, of a row-major 3×3 matrix.
pub fn pseudo_inverse(m: [f64; 9]) -> [f64; 9] {
    let row = |r: usize| glam::DVec3::new(m[r * 3], m[r * 3 + 1], m[r * 3 + 2]);
    let (r0, r1, r2) = (row(0), row(1), row(2));
    let c0 = r1.cross(r2);
    let det = r0.dot(c0);
    let scale = r0.length() * r1.length() * r2.length();
    if det.is_finite() && scale > 0.0 && det.abs() > 1e-10 * scale {
        // Columns of the inverse are the cross products of rows over the determinant.
        let (c1, c2) = (r2.cross(r0), r0.cross(r1));
        return [
            c0.x / det,
            c1.x / det,
            c2.x / det,
            c0.y / det,
            c1.y / det,
            c2.y / det,
            c0.z / det,
            c1.z / det,
            c2.z / det,
        ];
    }
    if !m.iter().all(|v| v.is_finite()) {
        return [f64::NAN; 9];
    }
    // AᵀA = V diag(σ²) Vᵀ; A⁺ = V diag(1/σ²) Vᵀ Aᵀ over the significant σ.
    let mut ata = [[0.0; 3]; 3];
    for (i, row_i) in ata.iter_mut().enumerate() {
        for (j, entry) in row_i.iter_mut().enumerate() {
            *entry = (0..3).map(|k| m[k * 3 + i] * m[k * 3 + j]).sum();
        }
    }
    let (values, vectors) = symmetric_eigen(ata);
    let largest = values.iter().cloned().fold(0.0, f64::max);
    let mut out = [0.0; 9];
    if largest <= 0.0 {
        return out;
    }
    for (e, &lambda) in values.iter().enumerate() {
        // σ below 1e-7 σ_max: σ² below 1e-14 σ_max².
        if lambda <= 1e-14 * largest {
            continue;
        }
        let v = [vectors[0][e], vectors[1][e], vectors[2][e]];
        // (v vᵀ Aᵀ) / λ: row r, column c gets v_r (A v)_c / λ.
        let av: [f64; 3] = std::array::from_fn(|c| (0..3).map(|k| m[c * 3 + k] * v[k]).sum());
        for r in 0..3 {
            for c in 0..3 {
                out[r * 3 + c] += v[r] * av[c] / lambda;
            }
        }
    }
    out
}

/// Eigenvalues and eigenvectors (as columns) of a symmetric 3×3 matrix, by cyclic Jacobi sweeps.
fn symmetric_eigen(mut a: [[f64; 3]; 3]) -> ([f64; 3], [[f64; 3]; 3]) {
    let mut v = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    for _sweep in 0..32 {
        let off = a[0][1].abs() + a[0][2].abs() + a[1][2].abs();
        let diag = a[0][0].abs() + a[1][1].abs() + a[2][2].abs();
        if off <= 1e-300 || off <= 1e-17 * diag {
            break;
        }
        for (p, q) in [(0, 1), (0, 2), (1, 2)] {
            if a[p][q] == 0.0 {
                continue;
            }
            let theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q]);
            let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
            let t = if theta == 0.0 { 1.0 } else { t };
            let c = 1.0 / (t * t + 1.0).sqrt();
            let s = t * c;
            for k in 0..3 {
                let (akp, akq) = (a[k][p], a[k][q]);
                a[k][p] = c * akp - s * akq;
                a[k][q] = s * akp + c * akq;
            }
            for k in 0..3 {
                let (apk, aqk) = (a[p][k], a[q][k]);
                a[p][k] = c * apk - s * aqk;
                a[q][k] = s * apk + c * aqk;
            }
            for row in v.iter_mut() {
                let (vp, vq) = (row[p], row[q]);
                row[p] = c * vp - s * vq;
                row[q] = s * vp + c * vq;
            }
        }
    }
    ([a[0][0], a[1][1], a[2][2]], v)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn mul(a: &[f64; 9], b: &[f64; 9]) -> [f64; 9] {
        std::array::from_fn(|i| (0..3).map(|k| a[(i / 3) * 3 + k] * b[k * 3 + i % 3]).sum())
    }

    #[test]
    fn regular_matrix_inverts_exactly() {
        let m = [2.0, 1.0, 0.0, 0.0, 3.0, 1.0, 1.0, 0.0, 4.0];
        let p = mul(&m, &pseudo_inverse(m));
        for (i, v) in p.iter().enumerate() {
            let expected = if i % 4 == 0 { 1.0 } else { 0.0 };
            assert!((v - expected).abs() < 1e-14, "{p:?}");
        }
    }

    #[test]
    fn singular_matrix_satisfies_the_penrose_conditions() {
        // Rank two: the third row is the sum of the first two.
        let m = [1.0, 2.0, 3.0, 0.0, 1.0, 4.0, 1.0, 3.0, 7.0];
        let p = pseudo_inverse(m);
        // A A⁺ A = A and A⁺ A A⁺ = A⁺.
        let apa = mul(&mul(&m, &p), &m);
        let pap = mul(&mul(&p, &m), &p);
        for i in 0..9 {
            assert!((apa[i] - m[i]).abs() < 1e-9, "{apa:?}");
            assert!((pap[i] - p[i]).abs() < 1e-9, "{pap:?}");
        }
        // The zero matrix's pseudo-inverse is zero.
        assert_eq!(pseudo_inverse([0.0; 9]), [0.0; 9]);
        // diag(2, 0, 0) → diag(0.5, 0, 0).
        let d = pseudo_inverse([2.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
        assert!((d[0] - 0.5).abs() < 1e-15 && d[1..].iter().all(|v| v.abs() < 1e-15));
    }
}
