//! The material at a path vertex: what the path tracer asks of a hit's material at every
//! vertex — its BSDF, its emitted radiance and the medium behind it.
//!
//! ```text
//! PBR material (glTF, TOML base_color/metallic/…):
//!   f   = bsdf::gltf(Pbr::params_at(uv, COLOR_0))           in the frame of n_s
//!   L_e = emission · emissiveTexture(uv)                       (emissiveFactor · strength)
//!   σ_a = −ln(attenuationColor) / attenuationDistance         (KHR_materials_volume)
//!   unlit: f = 0, L_e = base colour
//! lecture material (TOML diffuse/specular/mirror/transmission, OBJ):
//!   f   = bsdf::lecture(ρ = SurfacePoint::albedo, k_s, n, k_r, k_t, η)
//!   L_e = material.emission
//! L_e = 0 on the back of a one-sided emitter.
//! ```
//!
//! **Texture filtering** (ray cones, Akenine-Möller et al., "Texture Level of Detail
//! Strategies for Real-Time Ray Tracing", Ray Tracing Gems ch. 20): a ray whose cone is
//! `footprint` wide at the hit covers `footprint/|n_g·wo|` along the surface, which is
//! `width = Δ·footprint/|n_g·wo|` in a texture coordinate set's units, `Δ = √(uv area / world
//! area)` of the hit triangle ([`SurfacePoint::uv_density`]); a texture of `W × H` texels is
//! read at level of detail `λ = log₂(width·√(W·H))` ([`crate::material::TextureSlot::at`],
//! trilinear in its mip pyramid). The path tracer gives camera rays the camera's cone
//! narrowed to one sample's ([`crate::camera::Camera::ray_cone`],
//! [`crate::camera::RayCone::per_sample`]) and every later vertex a point (`footprint` 0: the
//! full-resolution bilinear lookup), as glossy and diffuse bounces average texels anyway.
//! Textures filtered so: base colour, metallic-roughness, emissive, the extensions'
//! ([`crate::material::ExtensionTextures`]), a lecture material's image texture, and the
//! normal maps ([`crate::surface::SurfacePoint::with_footprint`]: a mip level's texel is the
//! mean of the texels it covers, decoded and normalised as one normal).
//!
//! The Whitted integrator does not come here: it shades the lecture fields of every material
//! (a PBR material's closest lecture form, [`crate::material::Pbr::lecture_form`]).

use crate::bsdf::{self, Bsdf, Frame, LectureParams};
use crate::material::{TexCoords, Texture};
use crate::math::Vec3;
use crate::scene::Scene;
use crate::surface::SurfacePoint;

/// The medium behind a transmitting surface (`KHR_materials_volume`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Volume {
    /// Absorption coefficient σ_a per unit of world length: radiance crossing a distance `d`
    /// inside is scaled by `exp(−σ_a d)`.
    pub sigma_a: Vec3,
}

/// What a path vertex needs of its material ([`shade_at`] fills it; `default()`: black).
#[derive(Clone, Debug, Default)]
pub struct Shading {
    pub bsdf: Bsdf,
    /// Radiance emitted back along the ray that found the point.
    pub emission: Vec3,
    /// The medium inside the object, when its material absorbs.
    pub volume: Option<Volume>,
}

/// Sets `out` to the BSDF, emission and volume of `sp` seen along `wo` (towards the viewer);
/// `footprint` is the ray's width at the hit (world units; 0: a point sample). The material
/// must exist: the scene is checked before rendering. `out` is filled in place, the caller's
/// one per path: a BSDF is 632 bytes, and returning a new one would copy it at every vertex.
pub fn shade_at(scene: &Scene, sp: &SurfacePoint, wo: Vec3, footprint: f32, out: &mut Shading) {
    let m = &scene.materials[sp.material as usize];
    let coords = tex_coords(sp, wo, footprint);
    let frame = Frame::from_normal(sp.ns);
    let one_sided_back = m.emission_one_sided && !sp.front_face;
    out.bsdf.reset(frame, sp.ng, sp.front_face);
    out.emission = Vec3::ZERO;
    out.volume = None;
    match m.pbr.as_deref() {
        None => {
            let albedo = match &m.diffuse {
                Texture::Image(_) if footprint > 0.0 => m.diffuse.albedo_at(sp.p, sp.ng_outward, coords) * sp.color,
                _ => sp.albedo(scene),
            };
            let params = LectureParams {
                albedo,
                specular: m.specular,
                shininess: m.shininess,
                mirror: m.mirror,
                transmission: m.transmission,
                ior: m.ior,
            };
            bsdf::lecture(&mut out.bsdf, &params);
            if !one_sided_back {
                out.emission = m.emission;
            }
        }
        Some(pbr) if pbr.unlit => out.emission = pbr.base_color_at(coords, sp.color),
        Some(pbr) => {
            let params = pbr.params_at(coords, sp.color);
            bsdf::gltf(&mut out.bsdf, &params, sp.n_coat);
            if !one_sided_back {
                out.emission = pbr.emission_at(coords);
            }
            out.volume = pbr.sigma_a().map(|sigma_a| Volume { sigma_a });
        }
    }
}

/// Where `sp`'s textures are read for a ray from direction `wo` whose cone is `footprint` wide
/// there (module header): its texture coordinates and the footprint's width in each set's units.
pub fn tex_coords(sp: &SurfacePoint, wo: Vec3, footprint: f32) -> TexCoords {
    TexCoords::through_cone(sp.uv, sp.uv_density, sp.ng, wo, footprint)
}
