//! Lights: where illumination comes from and how strong it is where it arrives.
//!
//! Each light answers two questions at a point: in which direction does its light travel there,
//! and what is its unshadowed strength `L` there (the `L` of the course notes' update, eq. 1.3).
//! Shadowing by the volume is not the light's business; the transmissivity `T_L` is computed
//! by `transmittance`. The one key decision: a distant light is given by the direction its
//! light *travels* (the sun high overhead is `(0, -1, 0)`), and a point light's strength falls
//! off as `1/r²` with `color` its strength at distance 1.

use crate::base::failure::{Failure, Outcome};
use glam::DVec3;

/// Parallel light from infinitely far away, like the sun.
#[derive(Clone, Debug, PartialEq)]
pub struct DistantLight {
    /// Unit direction in which the light travels (from the light into the scene).
    pub direction: DVec3,
    /// Strength per channel, the same everywhere.
    pub color: DVec3,
    /// What its AOV channels are called (`key.R`, ...); `None` gives `light0`-style names.
    pub name: Option<String>,
}

/// Light radiating from a point in all directions.
#[derive(Clone, Debug, PartialEq)]
pub struct PointLight {
    pub position: DVec3,
    /// Strength per channel at distance 1; at distance `r` it is `color / r²`.
    pub color: DVec3,
    /// What its AOV channels are called; `None` gives `light0`-style names.
    pub name: Option<String>,
}

/// A light source of the scene.
#[derive(Clone, Debug, PartialEq)]
pub enum Light {
    Distant(DistantLight),
    Point(PointLight),
}

/// Point lights closer than this to a sample are treated as this far away, so a sample on top of
/// the light gets a large but finite strength.
const NEAREST_POINT_LIGHT: f64 = 1e-6;

impl Light {
    /// A distant light whose light travels along `direction` (normalised here).
    pub fn distant(direction: DVec3, color: DVec3) -> Outcome<Light> {
        check_color(color)?;
        if !direction.is_finite() || direction.length() == 0.0 {
            return Err(Failure::new(format!(
                "distant light direction must be a non-zero vector, got {direction}"
            ))
            .with_help(
                "give the direction the light travels, e.g. (0, -1, 0) for light from above",
            ));
        }
        Ok(Light::Distant(DistantLight {
            direction: direction.normalize(),
            color,
            name: None,
        }))
    }

    /// A point light at `position`.
    pub fn point(position: DVec3, color: DVec3) -> Outcome<Light> {
        check_color(color)?;
        if !position.is_finite() {
            return Err(Failure::new(format!(
                "point light position must be finite, got {position}"
            )));
        }
        Ok(Light::Point(PointLight {
            position,
            color,
            name: None,
        }))
    }

    /// The light with a name for its AOV channels: letters, digits, `_` and `-` (a `.` would
    /// split the channel into layers).
    pub fn named(mut self, name: &str) -> Outcome<Light> {
        let valid = !name.is_empty()
            && name
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-');
        if !valid {
            return Err(Failure::new(format!(
                "a light's name must be letters, digits, '_' or '-', found \"{name}\""
            ))
            .with_help("the name becomes the light's AOV channels, NAME.R, NAME.G and NAME.B"));
        }
        let slot = match &mut self {
            Light::Distant(l) => &mut l.name,
            Light::Point(l) => &mut l.name,
        };
        *slot = Some(name.to_string());
        Ok(self)
    }

    /// The layer name of this light's AOV channels, as the `index`-th light of a render.
    pub fn aov_name(&self, index: usize) -> String {
        let name = match self {
            Light::Distant(l) => &l.name,
            Light::Point(l) => &l.name,
        };
        name.clone().unwrap_or_else(|| format!("light{index}"))
    }

    /// The unit direction the light travels at `p`, and its unshadowed strength there.
    pub fn arriving(&self, p: DVec3) -> (DVec3, DVec3) {
        match self {
            Light::Distant(d) => (d.direction, d.color),
            Light::Point(l) => {
                let offset = p - l.position;
                let r = offset.length().max(NEAREST_POINT_LIGHT);
                (offset / r, l.color / (r * r))
            }
        }
    }

    /// The unit direction from `p` towards the light and the distance to it (infinite for a
    /// distant light).
    pub fn towards(&self, p: DVec3) -> (DVec3, f64) {
        match self {
            Light::Distant(d) => (-d.direction, f64::INFINITY),
            Light::Point(l) => {
                let offset = l.position - p;
                let r = offset.length();
                if r == 0.0 {
                    (DVec3::Y, 0.0)
                } else {
                    (offset / r, r)
                }
            }
        }
    }
}

fn check_color(color: DVec3) -> Outcome<()> {
    if !color.is_finite() || color.min_element() < 0.0 {
        return Err(Failure::new(format!(
            "light color must be finite and non-negative, got {color}"
        )));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn point_light_falls_off_with_the_square_of_distance() {
        let light = Light::point(DVec3::new(1.0, 0.0, 0.0), DVec3::splat(8.0)).unwrap();
        let (dir, strength) = light.arriving(DVec3::new(1.0, 0.0, 2.0));
        assert_eq!(dir, DVec3::Z);
        assert_eq!(strength, DVec3::splat(2.0));
        let (to, r) = light.towards(DVec3::new(1.0, 0.0, 2.0));
        assert_eq!((to, r), (-DVec3::Z, 2.0));
        let (_, on_top) = light.arriving(DVec3::new(1.0, 0.0, 0.0));
        assert!(on_top.is_finite());
    }

    #[test]
    fn distant_light_travels_along_its_direction() {
        let light = Light::distant(DVec3::new(0.0, -2.0, 0.0), DVec3::ONE).unwrap();
        assert_eq!(light.arriving(DVec3::splat(7.0)), (-DVec3::Y, DVec3::ONE));
        assert_eq!(light.towards(DVec3::ZERO), (DVec3::Y, f64::INFINITY));
        assert!(Light::distant(DVec3::ZERO, DVec3::ONE).is_err());
        assert!(Light::distant(DVec3::Y, DVec3::new(1.0, -1.0, 0.0)).is_err());
    }
}
