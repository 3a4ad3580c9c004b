//! Improved Perlin gradient noise with exact first and second derivatives.
//!
//! Each lattice corner carries one of the twelve cube-edge gradients, picked by an arithmetic
//! hash of the corner and the seed; the noise is the quintic-faded trilinear blend of the
//! corners' linear ramps `g·(p − corner)`. The one key decision: derivatives come from writing
//! the blend as a polynomial in the faded coordinates `(u, v, w)` with coefficients that are
//! themselves linear in `p`, so the gradient and Hessian are short exact expressions of the
//! same corner data, not finite differences.
//!
//! Range: the noise is left unscaled. The largest value any gradient assignment reaches is
//! 1.0364 (at a cell position like (0.5, 0.52, 0.36)), the largest slope 3.75 (along an axis
//! at a cell centre); `bounds.rs` certifies 1.04 and 4.

use super::hash::{PRIME_X, PRIME_Y, PRIME_Z, axis_terms, corner, edge_gradient, edge_ramp};
use super::lattice::{Located, Real, Sample};

/// Quintic fade `s(t) = 6t⁵ − 15t⁴ + 10t³` with its first two derivatives.
#[inline(always)]
pub(crate) fn fade<R: Real>(t: R) -> (R, R, R) {
    let t2 = t * t;
    let s = t2 * t * (t * (t * R::lit(6.0) - R::lit(15.0)) + R::lit(10.0));
    let tm = t - R::ONE;
    let ds = R::lit(30.0) * t2 * tm * tm;
    let dds = R::lit(60.0) * t * tm * (t + t - R::ONE);
    (s, ds, dds)
}

/// The trilinear blend `Σ k·(1, u, v, w, uv, uw, vw, uvw)` of eight corner values (corner
/// index `i + 2j + 4k`), kept as polynomial coefficients so partial derivatives are cheap.
struct Trilinear<R> {
    k: [R; 8],
}

impl<R: Real> Trilinear<R> {
    #[inline(always)]
    fn new(c: [R; 8]) -> Trilinear<R> {
        Trilinear {
            k: [
                c[0],
                c[1] - c[0],
                c[2] - c[0],
                c[4] - c[0],
                c[3] - c[2] - c[1] + c[0],
                c[5] - c[4] - c[1] + c[0],
                c[6] - c[4] - c[2] + c[0],
                c[7] - c[6] - c[5] + c[4] - c[3] + c[2] + c[1] - c[0],
            ],
        }
    }
    #[inline(always)]
    fn value(&self, u: R, v: R, w: R) -> R {
        let k = &self.k;
        k[0] + k[1] * u
            + k[2] * v
            + k[3] * w
            + k[4] * u * v
            + k[5] * u * w
            + k[6] * v * w
            + k[7] * u * v * w
    }
    #[inline(always)]
    fn du(&self, v: R, w: R) -> R {
        let k = &self.k;
        k[1] + k[4] * v + k[5] * w + k[7] * v * w
    }
    #[inline(always)]
    fn dv(&self, u: R, w: R) -> R {
        let k = &self.k;
        k[2] + k[4] * u + k[6] * w + k[7] * u * w
    }
    #[inline(always)]
    fn dw(&self, u: R, v: R) -> R {
        let k = &self.k;
        k[3] + k[5] * u + k[6] * v + k[7] * u * v
    }
    #[inline(always)]
    fn duv(&self, w: R) -> R {
        self.k[4] + self.k[7] * w
    }
    #[inline(always)]
    fn duw(&self, v: R) -> R {
        self.k[5] + self.k[7] * v
    }
    #[inline(always)]
    fn dvw(&self, u: R) -> R {
        self.k[6] + self.k[7] * u
    }
}

#[inline(always)]
fn lerp<R: Real>(a: R, b: R, t: R) -> R {
    a + (b - a) * t
}

/// Perlin noise at a located point. `G`/`H` ask for the gradient / the Hessian too.
#[inline(always)]
pub(crate) fn sample<R: Real, const G: bool, const H: bool>(p: Located<R>, key: u32) -> Sample<R> {
    let [fx, fy, fz] = p.frac;
    let [x0, y0, z0] = axis_terms(p.cell);
    let xs = [x0, x0.wrapping_add(PRIME_X)];
    let ys = [y0, y0.wrapping_add(PRIME_Y)];
    let zs = [z0, z0.wrapping_add(PRIME_Z)];
    let dx = [fx, fx - R::ONE];
    let dy = [fy, fy - R::ONE];
    let dz = [fz, fz - R::ONE];

    // Corner ramps a = g·(p − corner) and, for derivatives, the gradients g themselves. The
    // ramp flips signs of the offsets rather than multiplying by the gradient's ±1 and 0
    // (the same bits, fewer instructions); the gradient becomes numbers only when asked for.
    // Written out corner by corner: a loop here would stay a loop inside the block loop,
    // and LLVM vectorises only innermost loops.
    let mut ramp = [R::ZERO; 8];
    let mut grads = [[R::ZERO; 8]; 3];
    let mut visit = |c: usize| {
        let (i, j, k) = (c & 1, (c >> 1) & 1, c >> 2);
        let h = corner(xs[i], ys[j], zs[k], key);
        ramp[c] = edge_ramp(h, [dx[i], dy[j], dz[k]]);
        if G || H {
            let g: [R; 3] = edge_gradient(h);
            grads[0][c] = g[0];
            grads[1][c] = g[1];
            grads[2][c] = g[2];
        }
    };
    visit(0);
    visit(1);
    visit(2);
    visit(3);
    visit(4);
    visit(5);
    visit(6);
    visit(7);

    let (u, du, ddu) = fade(fx);
    let (v, dv, ddv) = fade(fy);
    let (w, dw, ddw) = fade(fz);
    let mut out = Sample::zero();
    // The value is always blended this way, so it is bit for bit the same whether or not
    // derivatives were asked for.
    let x00 = lerp(ramp[0], ramp[1], u);
    let x10 = lerp(ramp[2], ramp[3], u);
    let x01 = lerp(ramp[4], ramp[5], u);
    let x11 = lerp(ramp[6], ramp[7], u);
    out.value = lerp(lerp(x00, x10, v), lerp(x01, x11, v), w);
    if !G && !H {
        return out;
    }

    // n = L(u,v,w; a(p)) with a linear in p and ∂a/∂x = g_x, so
    // ∂n/∂x = L(u,v,w; g_x) + u'·L_u(a), and the second derivatives follow the same rule.
    let a = Trilinear::new(ramp);
    let gx = Trilinear::new(grads[0]);
    let gy = Trilinear::new(grads[1]);
    let gz = Trilinear::new(grads[2]);
    let a_u = a.du(v, w);
    let a_v = a.dv(u, w);
    let a_w = a.dw(u, v);
    out.gradient = [
        gx.value(u, v, w) + du * a_u,
        gy.value(u, v, w) + dv * a_v,
        gz.value(u, v, w) + dw * a_w,
    ];
    if H {
        let two = R::lit(2.0);
        out.hessian = [
            ddu * a_u + two * du * gx.du(v, w),
            ddv * a_v + two * dv * gy.dv(u, w),
            ddw * a_w + two * dw * gz.dw(u, v),
            du * dv * a.duv(w) + du * gy.du(v, w) + dv * gx.dv(u, w),
            du * dw * a.duw(v) + du * gz.du(v, w) + dw * gx.dw(u, v),
            dv * dw * a.dvw(u) + dv * gz.dv(u, w) + dw * gy.dw(u, v),
        ];
    }
    out
}
