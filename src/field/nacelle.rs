//! The nacelle warp (FELT chapter 4): a vectorfield `X` with `Lo(x) = Lr(X(x))`, so that `X`
//! carries the object level set `Lo` onto the reference level set `Lr` and attributes can be
//! read back from the reference.
//!
//! Each iteration moves `Xn` along `B = ∇Lr(Xn)` by the root `A` of the quadratic Taylor model
//! `Δ = A + ½ΓA²` (eqs. 4.6–4.10). The one key decision: the root is taken in the stable form
//! `A = 2Δ / (1 + √(1 + 2ΔΓ))`, algebraically the printed `(−1 + √(1 + 2ΔΓ))/Γ` but without
//! its 0/0 as `Γ → 0` — on an exact sphere distance `Γ` is round-off (−2e-16) and the printed
//! form returns no step at all. Where `1 + 2ΔΓ < 0` the model has no real root and the step
//! goes to the parabola's vertex `A = −1/Γ`, the point where the model comes closest; where
//! `|B|²` vanishes (the centre of a sphere, the axis of a torus) there is no direction and the
//! step is zero. The steps are ordinary field graphs, so the result is exactly
//! differentiable and compiles into one program.

use super::{Field, compose, grad};
use crate::base::failure::Outcome;

/// Below this `|∇Lr|²` a point has no usable direction and does not move (a unit-gradient
/// distance field is far above it everywhere but at its singular points).
pub const FLAT_GRADIENT: f64 = 1e-20;

/// One nacelle iteration: the next warp and where its root had to be clamped.
pub struct Step {
    /// `X_{n+1} = X_n + A·B` (eq. 4.10).
    pub warp: Field,
    /// `1 + 2ΔΓ`: negative where the quadratic model has no real root and `A` is the vertex.
    pub discriminant: Field,
}

/// How `B·B` and `B·M·B` are formed: exactly, or through a cache the caller provides (the
/// chapter's faster variant samples both onto a grid every iteration).
pub type Sampling<'a> = Option<&'a dyn Fn(&Field) -> Outcome<Field>>;

/// One step from `xn`. `hessian` is `grad(grad(Lr))`, passed in so that iterations share it.
pub fn step(
    lo: &Field,
    lr: &Field,
    gradient: &Field,
    hessian: &Field,
    xn: &Field,
    sampling: Sampling,
) -> Outcome<Step> {
    let b = compose(gradient, xn)?;
    let m = compose(hessian, xn)?;
    let mut bb = b.mul(&b)?;
    let mut bmb = b.mul(&m.mul(&b)?)?;
    if let Some(sample) = sampling {
        bb = sample(&bb)?;
        bmb = sample(&bmb)?;
    }
    let constant = Field::constant_scalar;
    // Where |B|² is below the floor the divisions are replaced by 0: no step, not Inf/NaN.
    let steep = bb.sub(&constant(FLAT_GRADIENT))?;
    let safe_bb = Field::max(&bb, &constant(FLAT_GRADIENT))?;
    // Eq. 4.8 and 4.9.
    let delta = lo.sub(&compose(lr, xn)?)?.div(&safe_bb)?;
    let gamma = bmb.div(&safe_bb)?;
    let discriminant = constant(1.0).add(&constant(2.0).mul(&delta)?.mul(&gamma)?)?;
    // Eq. 4.7 in its stable form; √ of the clamped discriminant keeps NaN out of the unused
    // branch of the select below.
    let root = Field::max(&discriminant, &constant(0.0))?.math(super::MathFn::Sqrt)?;
    let stable = constant(2.0).mul(&delta)?.div(&constant(1.0).add(&root)?)?;
    // No real root: the vertex of Δ = A + ½ΓA², where dΔ/dA = 1 + ΓA = 0. There |2ΔΓ| > 1, so
    // Γ is not zero and the guarded division only protects the branch that is not taken.
    let vertex = constant(-1.0).guarded_div(&gamma)?;
    let a = Field::select(&discriminant, &stable, &vertex)?;
    let a = Field::select(&steep, &a, &constant(0.0))?;
    Ok(Step {
        warp: xn.add(&a.mul(&b)?)?,
        discriminant,
    })
}

/// `iterations` steps from the identity; element `n` is the step that produced `X_{n+1}`.
pub fn iterate(
    lo: &Field,
    lr: &Field,
    iterations: usize,
    sampling: Sampling,
) -> Outcome<Vec<Step>> {
    let gradient = grad(lr)?;
    let hessian = grad(&gradient)?;
    let mut steps: Vec<Step> = Vec::with_capacity(iterations);
    let mut xn = Field::identity();
    for _ in 0..iterations {
        let next = step(lo, lr, &gradient, &hessian, &xn, sampling)?;
        xn = next.warp.clone();
        steps.push(next);
    }
    Ok(steps)
}
