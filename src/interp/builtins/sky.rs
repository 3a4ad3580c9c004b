//! Sky builtins (docs/language.md, Path tracing): `envmap`, `physicalsky` and `sunlight`.
//!
//! A sky is a `light` to the checker, as a distant or point light is: a source of light made
//! once and handed to `render`. The one key decision: a sky goes in `render(..., sky = ...)`
//! and a distant or point light in `lights = {...}`, each refused with a help line in the
//! other's place; the daylight sky's sun is a plain distant light (`sunlight(sky)`), so it can
//! go in `lights` and be named, shadowed and drawn like any other.

use crate::base::failure::{Failure, Outcome};
use crate::interp::registry::Registry;
use crate::interp::value::Value;
use crate::render::sky::Sky;
use crate::render::sky::envmap::EnvMap;
use crate::render::sky::physical::PhysicalSky;
use std::rc::Rc;
use std::sync::Arc;

pub fn register(r: &mut Registry) {
    r.add(
        "rendering",
        &["envmap(string path, float intensity?, float rotate?) -> light"],
        "a sky from a lat-long (equirectangular, 2:1) OpenEXR image of scene-linear radiance, \
         for render's sky: the top row is the zenith (+y), the left edge looks along -z and a \
         quarter across along +x (Mitsuba's layout); intensity scales it, rotate turns it by \
         degrees about +y",
        |interp, a| {
            let name = a.string("path")?;
            let path = interp.files.reading(name)?;
            if !path.is_file() {
                return Err(Failure::new(format!("no environment map '{name}'"))
                    .with_help("a relative path is read beside the script"));
            }
            let intensity = a.opt_float("intensity")?.unwrap_or(1.0);
            let rotate = a.opt_float("rotate")?.unwrap_or(0.0);
            let map = EnvMap::load(&path, name, intensity, rotate)?;
            Ok(Value::Sky(Sky::Environment(Arc::new(map))))
        },
    );
    r.add(
        "rendering",
        &["physicalsky(vector sun, float turbidity?, float intensity?) -> light"],
        "a clear daylight sky (Preetham et al. 1999) for render's sky, with sunlight travelling \
         along sun (as for distantlight; the sun at or above the horizon); turbidity from 2 \
         (very clear) to 10 (hazy), default 3; radiance 1 is 30000 cd/m2 times intensity; \
         sunlight(sky) is its sun",
        |_, a| {
            let turbidity = a.opt_float("turbidity")?.unwrap_or(3.0);
            let intensity = a.opt_float("intensity")?.unwrap_or(1.0);
            let sky = PhysicalSky::new(a.get("sun")?.as_vector()?, turbidity, intensity)?;
            Ok(Value::Sky(Sky::Physical(Arc::new(sky))))
        },
    );
    r.add(
        "rendering",
        &["sunlight(light sky, string name?) -> light"],
        "the sun of a physicalsky: a distant light along its sun direction, of the colour and \
         strength sunlight has at the ground under that sky, for render's lights",
        |_, a| {
            let Value::Sky(Sky::Physical(sky)) = a.get("sky")? else {
                return Err(Failure::new("sunlight takes a physicalsky")
                    .with_help("make the sky with physicalsky(sun, turbidity) and pass it here"));
            };
            let sun = sky.sun().clone();
            let sun = match a.opt("name") {
                Some(name) => sun.named(name.as_str()?)?,
                None => sun,
            };
            Ok(Value::Light(Rc::new(sun)))
        },
    );
}

/// The sky a `render` call's `sky` keyword gives: a vector (uniform radiance) or a sky value.
pub fn sky_setting(value: &Value) -> Outcome<Sky> {
    match value {
        Value::Sky(sky) => Ok(sky.clone()),
        Value::Light(_) => Err(Failure::new(
            "sky takes a vector or a sky, found a distant or point light",
        )
        .with_help(
            "put distant and point lights in lights = {...}; sky takes (r, g, b), \
             envmap(...) or physicalsky(...)",
        )),
        other => Ok(Sky::Uniform(other.as_vector()?)),
    }
}

/// The error for a sky found among `render`'s lights.
pub fn sky_in_lights() -> Failure {
    Failure::new("a sky is not one of render's lights")
        .with_help("pass it as sky = ...; a physicalsky's sun goes in lights as sunlight(sky)")
}
