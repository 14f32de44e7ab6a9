//! Surface materials for Whitted shading: a diffuse albedo (constant or Whitted's 1980
//! checkerboard), a normalised Blinn–Phong highlight, an ideal mirror, a dielectric
//! (Snell + Fresnel) and emission. All reflectances are in [0, 1] per channel.

use crate::math::Vec3;

/// How the diffuse albedo varies over a surface.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Texture {
    /// The same albedo everywhere.
    Constant(Vec3),
    /// A world-space 3-D checkerboard of cubes of edge `size`: `even` where
    /// `⌊x/size⌋ + ⌊y/size⌋ + ⌊z/size⌋` is even, `odd` elsewhere.
    Checker { even: Vec3, odd: Vec3, size: f32 },
}

/// A surface material. Energy: `diffuse + specular + mirror` should not exceed 1 per channel,
/// and a dielectric splits what it gets between reflection and refraction by Fresnel.
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    pub name: String,
    /// Diffuse albedo ρ: the surface reflects `ρ/π` (Lambert). Multiplied by the mesh's
    /// per-vertex colour where it has one.
    pub diffuse: Texture,
    /// Weight of the normalised Blinn–Phong lobe `k_s · (n+8)/(8π) · (n·h)^n`.
    pub specular: Vec3,
    /// Blinn–Phong exponent `n`.
    pub shininess: f32,
    /// Reflectance of the ideal mirror direction.
    pub mirror: Vec3,
    /// Filter on light refracted through the surface; zero for an opaque material.
    pub transmission: Vec3,
    /// Index of refraction of the inside (the side the geometric normal points away from).
    pub ior: f32,
    /// Emitted radiance.
    pub emission: Vec3,
}

impl Default for Material {
    /// A mid-grey diffuse surface.
    fn default() -> Self {
        Material {
            name: "default".into(),
            diffuse: Texture::Constant(Vec3::splat(0.5)),
            specular: Vec3::ZERO,
            shininess: 0.0,
            mirror: Vec3::ZERO,
            transmission: Vec3::ZERO,
            ior: 1.5,
            emission: Vec3::ZERO,
        }
    }
}
