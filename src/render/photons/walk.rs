//! One photon's walk through the medium: the path tracer's delta tracking, a score at every
//! scattering, and a weight window that splits photons where the camera sees and plays
//! Russian roulette where it does not. The one key decision: copies are walked from a stack,
//! each from its own numbered stream, so a walk is the same on any thread.

use super::super::camera::Ray;
use super::super::path::sampling::{PathRandom, scatter};
use super::super::path::tracking::{Flight, Medium};
use super::super::space::clip_to_box;
use super::{Cells, IMPORTANCE_FLOOR, Importance, PhotonInputs, Sums};
use glam::DVec3;
use std::f64::consts::PI;

/// One photon and what its walk reads.
pub(super) struct Photon<'a> {
    pub(super) inputs: &'a PhotonInputs<'a>,
    pub(super) cells: &'a Cells,
    pub(super) importance: &'a Importance,
    pub(super) power: DVec3,
    /// Its light and number, which key the streams of the copies it splits into.
    pub(super) key: u64,
}

/// The most copies one scattering splits a photon into.
const MOST_COPIES: u32 = 32;

/// The most copies one photon's walk follows.
const MOST_WALKED: u64 = 1 << 17;

/// A photon copy still to walk: where it scattered, the way it had travelled, its weight and
/// the scatterings behind it.
struct Pending {
    at: DVec3,
    travelled: DVec3,
    weight: DVec3,
    order: u32,
    random: PathRandom,
}

impl Photon<'_> {
    /// Follows the photon and every copy it splits into; scores `Φ·β·p(ω·v)` at each
    /// scattering after the first.
    pub(super) fn walk(
        &self,
        medium: &mut Medium,
        ray: Ray,
        mut random: PathRandom,
        sums: &mut Sums,
    ) {
        let mut copies = 0u64;
        let mut stack = Vec::new();
        let mut spawned = 0u64;
        let walk = &mut Walk {
            sums,
            stack: &mut stack,
            spawned: &mut spawned,
        };
        self.fly(medium, ray, DVec3::ONE, 0, &mut random, walk);
        while let Some(pending) = stack.pop() {
            let Pending {
                at,
                travelled,
                weight,
                order,
                mut random,
            } = pending;
            let ray = Ray {
                origin: at,
                direction: scatter(&self.inputs.phase, travelled, &mut random),
            };
            let walk = &mut Walk {
                sums,
                stack: &mut stack,
                spawned: &mut spawned,
            };
            self.fly(medium, ray, weight, order, &mut random, walk);
            copies += 1;
            // A bound on one walk's work: the weight window keeps copies near the camera's
            // importance, so only a walk that keeps returning from deep inside a vast dense
            // medium comes near it; the copies left then are dropped (a loss of light no
            // test scene reaches), not walked without end.
            if copies > MOST_WALKED {
                return;
            }
        }
    }

    /// Flies from `ray` until this copy of the walk ends; the copies it splits into go on
    /// the walk's stack.
    fn fly(
        &self,
        medium: &mut Medium,
        mut ray: Ray,
        mut weight: DVec3,
        mut order: u32,
        random: &mut PathRandom,
        walk: &mut Walk,
    ) {
        let inputs = self.inputs;
        // Photons carry no emission; the grid's gathered part has it.
        let mut emitted = DVec3::ZERO;
        loop {
            random.start_bounce(order);
            let flight = match clip_to_box(&ray, &self.cells.bounds) {
                Some((t0, t1)) => medium.fly(&ray, t0, t1, &mut weight, &mut emitted, random),
                None => Flight::Escaped,
            };
            let Flight::Scattered(t) = flight else {
                return;
            };
            order += 1;
            // The light arriving at this scattering has scattered `order − 1` times; the
            // march scatters it once more, and paths stop at `bounces` scatterings.
            if order > inputs.bounces {
                return;
            }
            let p = ray.at(t);
            {
                let to_camera = if inputs.camera.is_orthographic() {
                    -inputs.camera.forward()
                } else {
                    (inputs.camera.eye - p)
                        .try_normalize()
                        .unwrap_or(-inputs.camera.forward())
                };
                let phase = inputs.phase.relative(ray.direction.dot(to_camera)) / (4.0 * PI);
                // Odd keys hold the first scatterings: the lights' own light, which the march
                // computes exactly; it is tallied only to say how much the rest matters.
                let key = 2 * self.cells.index(p) + usize::from(order == 1);
                *walk.sums.entry(key).or_insert(DVec3::ZERO) += self.power * weight * phase;
            }
            // The weight window: keep the weight near 1/importance.
            let target = 1.0 / self.importance.at(p).max(IMPORTANCE_FLOOR);
            let w = weight.max_element();
            if w.is_nan() || w <= 0.0 {
                return;
            }
            if w < 0.5 * target {
                let survival = w / target;
                if random.uniform() >= survival {
                    return;
                }
                weight /= survival;
            } else if w > 2.0 * target {
                let copies = ((w / target) as u32).clamp(2, MOST_COPIES);
                weight /= f64::from(copies);
                for _ in 1..copies {
                    *walk.spawned += 1;
                    walk.stack.push(Pending {
                        at: p,
                        travelled: ray.direction,
                        weight,
                        order,
                        random: PathRandom::new(
                            inputs.seed ^ SPLIT_STREAM,
                            self.key,
                            *walk.spawned,
                        ),
                    });
                }
            }
            ray = Ray {
                origin: p,
                direction: scatter(&inputs.phase, ray.direction, random),
            };
        }
    }
}

/// What a photon's walk adds to: the chunk's sums, the copies still to walk and how many
/// copies it has made (each copy's stream is numbered by it).
struct Walk<'a> {
    sums: &'a mut Sums,
    stack: &'a mut Vec<Pending>,
    spawned: &'a mut u64,
}

/// The streams of split copies.
const SPLIT_STREAM: u64 = 0x5b11_7c0f_1e50_0000;
