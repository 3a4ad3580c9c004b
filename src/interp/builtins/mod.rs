//! The builtins, grouped by capability. Each group registers its entries in the one registry;
//! adding a capability means adding a group here, nothing else.

mod attributes;
pub mod clouds;
mod colour;
mod core;
mod fields;
mod flames;
pub mod format;
mod frustum;
mod geometry;
pub mod grids;
mod math;
mod modeling;
mod nacelle;
mod particles;
mod rendering;
mod simulation;
pub mod sky;
mod usd;

use super::registry::Registry;

pub fn register_all(r: &mut Registry) {
    core::register(r);
    math::register(r);
    fields::register(r);
    grids::register(r);
    frustum::register(r);
    modeling::register(r);
    rendering::register(r);
    sky::register(r);
    geometry::register(r);
    nacelle::register(r);
    attributes::register(r);
    simulation::register(r);
    particles::register(r);
    clouds::register(r);
    colour::register(r);
    usd::register(r);
}
