//! Frustum caches (docs/language.md, "Frustum caches"): `frustumcache` and
//! `frustumvectorcache`, and what the cache builtins do differently for them.
//!
//! The one key decision: a frustum cache is an ordinary cache variable over the frustum's
//! index domain, with the frustum beside it. `cachewrite` composes the field with the
//! index-to-world map, `cacheread` reads through the world-to-index map, and `splat` moves the
//! particles into index space; the cache itself (bricks, budget, fills) never knows.

use crate::base::failure::{Failure, Outcome};
use crate::check::types::Shape;
use crate::field::Field;
use crate::grid::frustum::{Frustum, FrustumRead};
use crate::interp::registry::{Args, Registry};
use crate::interp::value::{CacheVar, Value};
use crate::particles::Particles;
use crate::space::GridSource;
use glam::DVec3;
use std::cell::RefCell;
use std::rc::Rc;
use std::sync::Arc;

pub fn register(r: &mut Registry) {
    r.add(
        "caches",
        &[
            "frustumcache(camera cam, float near, float far, int width, int height, int depth, \
           float background?, int padding?) -> scalarcache",
        ],
        "a scalarcache whose cell (i, j, k) is pixel (i, j) of cam's width x height image at \
         depth slice k of depth slices between near and far (uniform in depth); padding adds \
         cells beyond the image's edges",
        |_, a| {
            let background = a.opt_float("background")?.unwrap_or(0.0);
            new_frustum_cache(&a, Shape::Scalar, vec![background])
        },
    );
    r.add(
        "caches",
        &[
            "frustumvectorcache(camera cam, float near, float far, int width, int height, \
           int depth, vector background?, int padding?) -> vectorcache",
        ],
        "a vectorcache over the cells of a camera's frustum, as frustumcache",
        |_, a| {
            let background = match a.opt("background") {
                Some(v) => v.as_vector()?,
                None => DVec3::ZERO,
            };
            new_frustum_cache(&a, Shape::Vector, background.to_array().to_vec())
        },
    );
}

fn new_frustum_cache(a: &Args, shape: Shape, background: Vec<f64>) -> Outcome<Value> {
    let Value::Camera(camera) = a.get("cam")? else {
        return Err(Failure::new("a frustum cache needs a camera"));
    };
    if background.iter().any(|b| !b.is_finite()) {
        return Err(Failure::new("a cache's background must be finite"));
    }
    let pixels = [
        a.positive_int("width")?,
        a.positive_int("height")?,
        a.positive_int("depth")?,
    ];
    let padding = match a.opt_int("padding")? {
        None => 0,
        Some(n) => usize::try_from(n)
            .map_err(|_| Failure::new(format!("padding must be zero or more pixels, found {n}")))?,
    };
    let view = camera.frustum_view(pixels[0], pixels[1]);
    let frustum = Frustum::new(
        view,
        a.float("near")?,
        a.float("far")?,
        pixels,
        padding,
        background.len(),
    )?;
    let domain = frustum.index_domain()?;
    Ok(Value::Cache(Rc::new(CacheVar {
        shape,
        domain: Rc::new(domain),
        frustum: Some(Arc::new(frustum)),
        background,
        state: RefCell::new(None),
    })))
}

/// The field a cache fill samples at its cells' centres: `field` itself, or for a frustum
/// cache `field` at the world points of the index domain's cell centres.
pub fn field_in_cells(var: &CacheVar, field: &Field) -> Outcome<Field> {
    match &var.frustum {
        None => Ok(field.clone()),
        Some(frustum) => field.compose(&crate::field::shapes::frustum_cell_to_world(
            &frustum.index_map(),
        )?),
    }
}

/// The grid a read of a cache samples at world points: through `frustum` for a frustum's cache
/// (a frustum cache's, or a loaded grid's with OpenVDB's frustum map).
pub fn read_at_world(
    frustum: Option<&Arc<Frustum>>,
    grid: Arc<dyn GridSource>,
) -> Arc<dyn GridSource> {
    match frustum {
        None => grid,
        Some(frustum) => Arc::new(FrustumRead::new(frustum.clone(), grid)),
    }
}

/// Refuses what a frustum cache cannot do, naming the call.
pub fn refuse(var: &CacheVar, what: &str, help: &str) -> Outcome<()> {
    match var.frustum {
        None => Ok(()),
        Some(_) => Err(refusal(what, help)),
    }
}

/// The message refusing `what` for a frustum cache.
pub fn refusal(what: &str, help: &str) -> Failure {
    Failure::new(format!("{what} cannot take a frustum cache")).with_help(help)
}

/// The particles at their index coordinates, for a splat into a frustum cache (the set itself
/// for any other cache). Attributes stay with the set the caller holds: a splat reads only the
/// positions from the set it is given.
pub fn particles_in_cells<'a>(
    var: &CacheVar,
    set: &'a Particles,
) -> Outcome<std::borrow::Cow<'a, Particles>> {
    let Some(frustum) = &var.frustum else {
        return Ok(std::borrow::Cow::Borrowed(set));
    };
    crate::particles::check_memory(set.len(), &[], "the particles moved into a frustum")?;
    let positions = set
        .positions
        .iter()
        .map(|p| {
            let world = DVec3::new(f64::from(p[0]), f64::from(p[1]), f64::from(p[2]));
            let q = frustum.world_to_index(world);
            [q.x as f32, q.y as f32, q.z as f32]
        })
        .collect();
    Ok(std::borrow::Cow::Owned(Particles::new(positions)))
}
