//! Light sources, in physical units so images compare with other renderers.

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
