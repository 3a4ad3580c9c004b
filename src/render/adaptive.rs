//! Adaptive stepping: Svea's contribution-driven step control, with one step of backtracking.
//!
//! Each step's contribution to the pixel — the largest change it makes to any colour channel
//! or to alpha, already weighted by the transmittance in front of it — decides the next step:
//! above the tolerance the step is discarded and retried at half the length (down to
//! `min_step`); below a quarter of it the next step is twice as long (up to `max_step`). The
//! one key decision, beyond Svea's published loop: a long step sampled at its midpoint can
//! stride half-way into a dense region and see nothing, so when a step is discarded right after
//! a quiet (low-contribution) step longer than the minimum, the ray is rewound to before that
//! quiet step too, which is retried at half its length. Each rewind halves the step tried at the
//! same place, so the march always advances.

use super::settings::Adaptive;
use glam::DVec3;

/// What to do after a step that contributed `contribution`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum StepRule {
    /// Discard the step; retry this long.
    Retry(f64),
    /// Accept; the next step keeps its length.
    Keep,
    /// Accept; the next step is this long.
    Grow(f64),
}

impl StepRule {
    /// The rule for a step of length `taken` (the planned length was `planned`).
    pub fn after(adaptive: &Adaptive, planned: f64, taken: f64, contribution: f64) -> StepRule {
        if contribution > adaptive.tolerance && taken > adaptive.min_step * (1.0 + 1e-9) {
            StepRule::Retry((0.5 * taken).max(adaptive.min_step))
        } else if contribution < 0.25 * adaptive.tolerance && planned < adaptive.max_step {
            StepRule::Grow((2.0 * planned).min(adaptive.max_step))
        } else {
            StepRule::Keep
        }
    }
}

/// A ray's state before its last accepted step, to rewind to.
#[derive(Clone, Copy, Debug, Default)]
pub struct Snapshot {
    /// Length of that step; 0 when there is nothing to rewind.
    pub length: f64,
    /// Whether that step was quiet (contributed under a quarter of the tolerance).
    pub quiet: bool,
    pub t: f64,
    pub fresh: bool,
    pub transmittance: DVec3,
    pub color: DVec3,
    pub emitted: DVec3,
    pub depth_weighted: f64,
    pub opacity: f64,
    /// The surface AOVs' sums (`render::surface`), where asked for.
    pub surface: [DVec3; 3],
}

impl Snapshot {
    /// Whether a step discarded now should rewind to this snapshot.
    pub fn rewinds(&self, adaptive: &Adaptive) -> bool {
        self.quiet && self.length > adaptive.min_step * (1.0 + 1e-9)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn svea_step_rule() {
        let a = Adaptive {
            min_step: 0.01,
            max_step: 0.08,
            tolerance: 0.1,
        };
        assert_eq!(StepRule::after(&a, 0.04, 0.04, 0.2), StepRule::Retry(0.02));
        // A step cut short by the end of a run is retried at half of what it took.
        assert_eq!(StepRule::after(&a, 0.04, 0.03, 0.2), StepRule::Retry(0.015));
        // At the minimum a large contribution is accepted.
        assert_eq!(StepRule::after(&a, 0.01, 0.01, 0.5), StepRule::Keep);
        assert_eq!(StepRule::after(&a, 0.04, 0.04, 0.01), StepRule::Grow(0.08));
        assert_eq!(StepRule::after(&a, 0.08, 0.08, 0.0), StepRule::Keep);
        // Between a quarter and the whole tolerance the length is kept.
        assert_eq!(StepRule::after(&a, 0.04, 0.04, 0.05), StepRule::Keep);
        let quiet = Snapshot {
            length: 0.04,
            quiet: true,
            ..Snapshot::default()
        };
        assert!(quiet.rewinds(&a));
        assert!(
            !Snapshot {
                length: 0.01,
                ..quiet
            }
            .rewinds(&a)
        );
        assert!(
            !Snapshot {
                quiet: false,
                ..quiet
            }
            .rewinds(&a)
        );
        assert!(!Snapshot::default().rewinds(&a));
    }
}
