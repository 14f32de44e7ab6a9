//! Light sources, in physical units so images compare with other renderers.
//!
//! Point and directional lights ([`Light`]) are delta lights: each lights a point from exactly
//! one direction, tested with one shadow ray, which gives Whitted's hard shadows. Lights with
//! a shape ([`area::AreaLight`]) are sampled, which gives soft shadows. The environment
//! ([`environment::Environment`]) lights from infinitely far away; [`set::LightSet`] is every
//! light behind the path tracer's one sampling interface.

pub mod area;
pub mod environment;
pub mod environment_file;
pub mod mesh;
pub mod set;
pub mod tree;

use crate::math::Vec3;

/// A light that casts hard shadows.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Light {
    /// Radiant intensity `I` (W/sr per channel) from a point: irradiance `I·cosθ/d²` at
    /// distance `d`.
    Point { position: Vec3, intensity: Vec3 },
    /// Irradiance `E` (W/m² per channel, on a surface facing the light) arriving along
    /// `direction` (the way the light travels): irradiance `E·cosθ`.
    Directional { direction: Vec3, irradiance: Vec3 },
}

/// How a light reaches a point: the unit direction towards the light, the distance to it
/// (`∞` for a directional light), and the irradiance on a surface facing it (`I/d²` or `E`),
/// before the cosine factor.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Incidence {
    pub to_light: Vec3,
    pub distance: f32,
    pub normal_irradiance: Vec3,
}

impl Light {
    /// How this light reaches point `p`; `None` when `p` is the light's own position.
    #[inline]
    pub fn incidence(&self, p: Vec3) -> Option<Incidence> {
        match *self {
            Light::Point { position, intensity } => {
                let to = position - p;
                let d2 = to.length_squared();
                (d2 > 0.0).then(|| {
                    let d = d2.sqrt();
                    Incidence { to_light: to / d, distance: d, normal_irradiance: intensity / d2 }
                })
            }
            Light::Directional { direction, irradiance } => Some(Incidence {
                to_light: -direction.normalize(),
                distance: f32::INFINITY,
                normal_irradiance: irradiance,
            }),
        }
    }

    /// Why this light cannot be rendered, if it cannot: non-finite or negative values, or a
    /// directional light without a direction.
    pub fn problem(&self) -> Option<String> {
        let bad = |what: &str, c: Vec3| {
            (!(c.is_finite() && c.min_element() >= 0.0)).then(|| format!("{what} {c} must be finite and ≥ 0"))
        };
        match *self {
            Light::Point { position, intensity } => (!position.is_finite())
                .then(|| format!("position {position} is not finite"))
                .or_else(|| bad("intensity", intensity)),
            Light::Directional { direction, irradiance } => (!(direction.is_finite()
                && direction.length_squared() > 0.0))
                .then(|| format!("direction {direction} must be finite and non-zero"))
                .or_else(|| bad("irradiance", irradiance)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inverse_square_and_directional() {
        let l = Light::Point { position: Vec3::new(0.0, 2.0, 0.0), intensity: Vec3::splat(8.0) };
        let i = l.incidence(Vec3::ZERO).unwrap();
        assert_eq!((i.to_light, i.distance, i.normal_irradiance), (Vec3::Y, 2.0, Vec3::splat(2.0)));
        assert_eq!(l.incidence(Vec3::new(0.0, 2.0, 0.0)), None);
        let l = Light::Directional { direction: Vec3::new(0.0, -3.0, 0.0), irradiance: Vec3::ONE };
        let i = l.incidence(Vec3::ZERO).unwrap();
        assert_eq!((i.to_light, i.distance), (Vec3::Y, f32::INFINITY));
        assert!(Light::Directional { direction: Vec3::ZERO, irradiance: Vec3::ONE }.problem().is_some());
    }
}
