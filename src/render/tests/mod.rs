//! Renders of scenes with closed-form answers (`closed_forms`, `background`, `surface`), the
//! properties every render must have (`properties`), and inputs the march cannot use
//! (`bad_inputs`).

mod background;
mod bad_inputs;
mod closed_forms;
mod properties;
mod surface;

use super::*;
use crate::space::{Aabb, FnField};
use glam::DVec3;

/// Constant `value` (replicated to `width` components) inside the box `[-1,1]² × [z0, z1]`.
fn slab(
    width: usize,
    value: DVec3,
    z0: f64,
    z1: f64,
) -> FnField<impl Fn(DVec3, &mut [f64]) + Send + Sync> {
    FnField::new(width, move |p: DVec3, out: &mut [f64]| {
        let inside = p.z >= z0 && p.z <= z1 && p.x.abs() <= 1.0 && p.y.abs() <= 1.0;
        for (c, o) in out.iter_mut().enumerate() {
            *o = if inside { value[c] } else { 0.0 };
        }
    })
    .with_bounds(Aabb::new(
        DVec3::new(-1.0, -1.0, z0),
        DVec3::new(1.0, 1.0, z1),
    ))
}

/// An orthographic camera on the +z axis looking down -z at a 1 × 1 window.
fn looking_down_z() -> Camera {
    Camera::new(DVec3::new(0.0, 0.0, 5.0), DVec3::ZERO, DVec3::Y, 45.0)
        .unwrap()
        .orthographic(1.0)
        .unwrap()
}

fn scene<'a>(density: &'a dyn FieldSampler, lights: Vec<Light>) -> Scene<'a> {
    Scene {
        density,
        color: None,
        emission: None,
        holdout: None,
        velocity: None,
        camera: looking_down_z(),
        lights,
    }
}

fn small(width: usize, height: usize) -> RenderSettings {
    RenderSettings {
        width,
        height,
        ..RenderSettings::default()
    }
}
