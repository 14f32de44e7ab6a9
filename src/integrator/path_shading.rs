//! The material at a path vertex: the BSDF and the emitted radiance of a hit, as the path
//! tracer asks for them at every vertex.
//!
//! ```text
//! f   = bsdf::lecture(ρ = SurfacePoint::albedo, k_s, n, k_r, k_t, η)   in the frame of n_s
//! L_e = material.emission, 0 on the back of a one-sided emitter
//! ```
//!
//! Only strahl's Whitted materials exist here ([`bsdf::lecture`]); the glTF
//! metallic-roughness materials ([`bsdf::gltf`]) replace this file with a `shade_at` that
//! knows textures, normal maps and the ray's footprint.

use crate::bsdf::{self, Bsdf, Frame, LectureParams};
use crate::math::Vec3;
use crate::scene::Scene;
use crate::surface::SurfacePoint;

/// What a path vertex needs of its material.
#[derive(Clone, Copy, Debug)]
pub struct Shading {
    pub bsdf: Bsdf,
    /// Radiance emitted back along the ray that found the point.
    pub emission: Vec3,
}

/// The BSDF and emission of `sp` (its material must exist: the scene is checked).
pub fn shade_at(scene: &Scene, sp: &SurfacePoint) -> Shading {
    let m = &scene.materials[sp.material as usize];
    let params = LectureParams {
        albedo: sp.albedo,
        specular: m.specular,
        shininess: m.shininess,
        mirror: m.mirror,
        transmission: m.transmission,
        ior: m.ior,
    };
    let bsdf = bsdf::lecture(&params, Frame::from_normal(sp.ns), sp.ng, sp.front_face);
    let emission = if m.emission_one_sided && !sp.front_face { Vec3::ZERO } else { m.emission };
    Shading { bsdf, emission }
}
