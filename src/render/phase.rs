//! Phase functions: how much of the light arriving at a point scatters towards the camera.
//!
//! `cos_theta` is the cosine of the scattering angle, between the direction the light travels
//! and the direction from the sample to the camera: 1 means the camera looks straight into the
//! light (forward scattering, the silver lining of clouds), -1 means the light comes from behind
//! the camera. The one key decision: phase functions are reported *relative to isotropic*, i.e.
//! `4π·p(θ)`, so the isotropic phase is exactly 1 and the march reduces to the course notes'
//! update (eq. 1.3) unchanged; every phase here averages to 1 over the sphere, so switching
//! phase redistributes light without changing its total.

use crate::base::failure::{Failure, Outcome};

/// A phase function.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub enum Phase {
    /// Scatters equally in all directions.
    #[default]
    Isotropic,
    /// Henyey–Greenstein with eccentricity `g` in (-1, 1): `g > 0` scatters forward.
    HenyeyGreenstein { g: f64 },
    /// `weight · HG(g1) + (1 - weight) · HG(g2)`: a forward and a back lobe together.
    TwoLobe { g1: f64, g2: f64, weight: f64 },
}

/// Henyey–Greenstein relative to isotropic: `(1 - g²) / (1 + g² - 2g·cosθ)^{3/2}`.
fn henyey_greenstein(g: f64, cos_theta: f64) -> f64 {
    let g2 = g * g;
    let denom = 1.0 + g2 - 2.0 * g * cos_theta;
    (1.0 - g2) / (denom * denom.sqrt())
}

impl Phase {
    /// Checks the parameters: eccentricities in (-1, 1), weight in [0, 1].
    pub fn validate(&self) -> Outcome<()> {
        let eccentric = |g: f64| {
            if g.is_finite() && g > -1.0 && g < 1.0 {
                Ok(())
            } else {
                Err(Failure::new(format!(
                    "phase eccentricity g must be between -1 and 1 (exclusive), got {g}"
                ))
                .with_help("0 scatters evenly, 0.8 strongly forward, -0.3 somewhat backward"))
            }
        };
        match *self {
            Phase::Isotropic => Ok(()),
            Phase::HenyeyGreenstein { g } => eccentric(g),
            Phase::TwoLobe { g1, g2, weight } => {
                eccentric(g1)?;
                eccentric(g2)?;
                if !(0.0..=1.0).contains(&weight) {
                    return Err(Failure::new(format!(
                        "two-lobe phase weight must be between 0 and 1, got {weight}"
                    )));
                }
                Ok(())
            }
        }
    }

    /// `4π·p(θ)`: the phase relative to isotropic scattering.
    pub fn relative(&self, cos_theta: f64) -> f64 {
        match *self {
            Phase::Isotropic => 1.0,
            Phase::HenyeyGreenstein { g } => henyey_greenstein(g, cos_theta),
            Phase::TwoLobe { g1, g2, weight } => {
                weight * henyey_greenstein(g1, cos_theta)
                    + (1.0 - weight) * henyey_greenstein(g2, cos_theta)
            }
        }
    }

    /// The same phase with every eccentricity multiplied by `factor` (multiple-scattering
    /// octaves widen the lobes this way).
    pub fn scaled(&self, factor: f64) -> Phase {
        match *self {
            Phase::Isotropic => Phase::Isotropic,
            Phase::HenyeyGreenstein { g } => Phase::HenyeyGreenstein { g: g * factor },
            Phase::TwoLobe { g1, g2, weight } => Phase::TwoLobe {
                g1: g1 * factor,
                g2: g2 * factor,
                weight,
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Average of `f(cosθ)` over the sphere: ½∫₋₁¹ f(μ) dμ by the midpoint rule.
    fn sphere_mean(f: impl Fn(f64) -> f64) -> f64 {
        let n = 200_000;
        let h = 2.0 / n as f64;
        (0..n).map(|i| f(-1.0 + (i as f64 + 0.5) * h)).sum::<f64>() * h * 0.5
    }

    #[test]
    fn phases_average_to_one_and_hg_mean_cosine_is_g() {
        for phase in [
            Phase::Isotropic,
            Phase::HenyeyGreenstein { g: 0.6 },
            Phase::HenyeyGreenstein { g: -0.3 },
            Phase::TwoLobe {
                g1: 0.8,
                g2: -0.4,
                weight: 0.7,
            },
        ] {
            phase.validate().unwrap();
            let mean = sphere_mean(|mu| phase.relative(mu));
            assert!((mean - 1.0).abs() < 1e-6, "{phase:?}: {mean}");
        }
        // The defining property of Henyey–Greenstein: the mean cosine equals g.
        for g in [0.6, -0.3] {
            let hg = Phase::HenyeyGreenstein { g };
            let mean_cos = sphere_mean(|mu| mu * hg.relative(mu));
            assert!((mean_cos - g).abs() < 1e-6, "g {g}: {mean_cos}");
        }
        let two = Phase::TwoLobe {
            g1: 0.8,
            g2: -0.4,
            weight: 0.7,
        };
        let mean_cos = sphere_mean(|mu| mu * two.relative(mu));
        assert!((mean_cos - (0.7 * 0.8 - 0.3 * 0.4)).abs() < 1e-6);
    }

    #[test]
    fn forward_peak_value_and_bad_parameters() {
        // At θ = 0: (1 - g²)/(1 - g)³ = (1 + g)/(1 - g)².
        let g = 0.5;
        let peak = Phase::HenyeyGreenstein { g }.relative(1.0);
        assert!((peak - (1.0 + g) / ((1.0 - g) * (1.0 - g))).abs() < 1e-12);
        assert_eq!(
            Phase::HenyeyGreenstein { g: 0.5 }.scaled(0.5),
            Phase::HenyeyGreenstein { g: 0.25 }
        );
        assert!(Phase::HenyeyGreenstein { g: 1.0 }.validate().is_err());
        assert!(
            Phase::TwoLobe {
                g1: 0.2,
                g2: 0.1,
                weight: 1.5
            }
            .validate()
            .is_err()
        );
    }
}
