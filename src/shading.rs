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
//! **Untextured materials** ([`ConstantBsdfs`]): a PBR material without textures, and a lecture
//! material of constant diffuse albedo, has the same lobes at every hit of a mesh without
//! vertex colours, on each side (a glass's relative index is the side's): they are built once
//! per side before rendering and copied into each vertex's BSDF, whose frame and geometric
//! normal are the hit's. The copy holds exactly the values building them at the hit gives.
//!
//! The Whitted integrator does not come here: it shades the lecture fields of every material
//! (a PBR material's closest lecture form, [`crate::material::Pbr::lecture_form`]).

use crate::bsdf::{self, Bsdf, Frame, LectureParams};
use crate::material::{TexCoords, Texture};
use crate::math::{Vec2, Vec3};
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

/// The lobes of the scene's untextured materials, built once for each side (module header), by
/// material index; `None` for the others.
pub struct ConstantBsdfs {
    lobes: Vec<Option<Box<[Bsdf; 2]>>>,
}

impl ConstantBsdfs {
    /// The lobes of `scene`'s untextured materials, `[back, front]`.
    pub fn new(scene: &Scene) -> Self {
        let both = |add: &dyn Fn(&mut Bsdf)| {
            Box::new([false, true].map(|front_face| {
                let mut b = Bsdf::new(Frame::from_normal(Vec3::Z), Vec3::Z, front_face);
                add(&mut b);
                b
            }))
        };
        let lobes = scene
            .materials
            .iter()
            .map(|m| match (m.pbr.as_deref(), &m.diffuse) {
                (Some(pbr), _) if !pbr.unlit && pbr.slots().next().is_none() => {
                    let params = pbr.params_at([Vec2::ZERO; 2], Vec3::ONE);
                    Some(both(&|b| bsdf::gltf(b, &params, Vec3::Z)))
                }
                (None, &Texture::Constant(albedo)) => {
                    // `SurfacePoint::albedo` at a hit without vertex colours: `ρ · 1 = ρ`.
                    let params = lecture_params(m, albedo);
                    Some(both(&|b| bsdf::lecture(b, &params)))
                }
                _ => None,
            })
            .collect();
        ConstantBsdfs { lobes }
    }

    /// The prebuilt lobes of material `m` for a hit on the side `front_face`.
    #[inline]
    fn get(&self, m: u32, front_face: bool) -> Option<&Bsdf> {
        self.lobes.get(m as usize)?.as_deref().map(|b| &b[front_face as usize])
    }

    /// The lobes at `sp`, if its material's are prebuilt and they hold there: no vertex colour
    /// (it tints the albedo) and the coat's normal the shading normal (a normal map moves
    /// neither on an untextured material; the check keeps the rule whole).
    #[inline]
    fn at(&self, sp: &SurfacePoint) -> Option<&Bsdf> {
        self.get(sp.material, sp.front_face).filter(|_| sp.color == Vec3::ONE && sp.n_coat == sp.ns)
    }
}

/// Sets `out` to the BSDF, emission and volume of `sp` seen along `wo` (towards the viewer);
/// `footprint` is the ray's width at the hit (world units; 0: a point sample); `constant` the
/// scene's [`ConstantBsdfs`]. The material must exist: the scene is checked before rendering.
/// `out` is filled in place, the caller's one per path: a BSDF is 632 bytes, and returning a
/// new one would copy it at every vertex.
pub fn shade_at(
    scene: &Scene,
    constant: &ConstantBsdfs,
    sp: &SurfacePoint,
    wo: Vec3,
    footprint: f32,
    out: &mut Shading,
) {
    let m = &scene.materials[sp.material as usize];
    let coords = tex_coords(sp, wo, footprint);
    let frame = Frame::from_normal(sp.ns);
    let one_sided_back = m.emission_one_sided && !sp.front_face;
    out.bsdf.reset(frame, sp.ng, sp.front_face);
    out.emission = Vec3::ZERO;
    out.volume = None;
    match m.pbr.as_deref() {
        None => {
            match constant.at(sp) {
                Some(lobes) => out.bsdf.set_lobes(lobes),
                None => {
                    let albedo = match &m.diffuse {
                        Texture::Image(_) if footprint > 0.0 => {
                            m.diffuse.albedo_at(sp.p, sp.ng_outward, coords) * sp.color
                        }
                        _ => sp.albedo(scene),
                    };
                    bsdf::lecture(&mut out.bsdf, &lecture_params(m, albedo));
                }
            }
            if !one_sided_back {
                out.emission = m.emission;
            }
        }
        Some(pbr) if pbr.unlit => out.emission = pbr.base_color_at(coords, sp.color),
        Some(pbr) => {
            match constant.at(sp) {
                Some(lobes) => out.bsdf.set_lobes(lobes),
                None => bsdf::gltf(&mut out.bsdf, &pbr.params_at(coords, sp.color), sp.n_coat),
            }
            if !one_sided_back {
                out.emission = pbr.emission_at(coords);
            }
            out.volume = pbr.sigma_a().map(|sigma_a| Volume { sigma_a });
        }
    }
}

/// The lecture BSDF's numbers of material `m` at a hit of diffuse albedo `albedo`.
fn lecture_params(m: &crate::material::Material, albedo: Vec3) -> LectureParams {
    LectureParams {
        albedo,
        specular: m.specular,
        shininess: m.shininess,
        mirror: m.mirror,
        transmission: m.transmission,
        ior: m.ior,
    }
}

/// Where `sp`'s textures are read for a ray from direction `wo` whose cone is `footprint` wide
/// there (module header): its texture coordinates and the footprint's width in each set's units.
pub fn tex_coords(sp: &SurfacePoint, wo: Vec3, footprint: f32) -> TexCoords {
    TexCoords::through_cone(sp.uv, sp.uv_density, sp.ng, wo, footprint)
}

#[cfg(test)]
mod tests {
    use rand::{Rng, SeedableRng};
    use rand_pcg::Pcg64Mcg;

    use super::*;
    use crate::bsdf::PbrParams;
    use crate::material::Material;

    /// One material of every lobe kind glTF builds, and mixtures of them.
    fn materials() -> Vec<PbrParams> {
        let d = PbrParams::default();
        vec![
            PbrParams { base_color: Vec3::new(0.8, 0.3, 0.2), metallic: 0.0, roughness: 0.5, ..d },
            PbrParams { base_color: Vec3::new(0.9, 0.7, 0.4), metallic: 1.0, roughness: 0.2, ..d },
            PbrParams { base_color: Vec3::new(0.5, 0.5, 0.9), metallic: 0.4, roughness: 0.7, specular: 0.0, ..d },
            PbrParams { metallic: 0.0, transmission: 1.0, roughness: 0.0, ior: 1.5, ..d },
            PbrParams { metallic: 0.0, transmission: 0.6, roughness: 0.3, ior: 1.33, ..d },
            PbrParams { clearcoat: 1.0, clearcoat_roughness: 0.1, sheen_color: Vec3::new(0.3, 0.2, 0.1), ..d },
        ]
    }

    /// `eval`, `pdf` and `sample` of material `k`'s prebuilt lobes, given 200 random frames,
    /// against the lobes `build` adds at the hit, on both sides; the samples compared.
    fn compare(constant: &ConstantBsdfs, k: usize, build: impl Fn(&mut Bsdf), rng: &mut Pcg64Mcg) -> u32 {
        let unit = |rng: &mut Pcg64Mcg| {
            Vec3::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0)).normalize()
        };
        let mut compared = 0;
        for front_face in [false, true] {
            let template = constant.get(k as u32, front_face).expect("untextured materials are prebuilt");
            for _ in 0..200 {
                let n = unit(rng);
                let frame = Frame::from_normal(n);
                let mut built = Bsdf::new(frame, n, front_face);
                build(&mut built);
                let mut copied = Bsdf::new(frame, n, front_face);
                copied.set_lobes(template);
                let (wo, wi) = (unit(rng), unit(rng));
                let wo = if wo.dot(n) < 0.0 { -wo } else { wo };
                assert_eq!(format!("{:?}", built.eval(wo, wi)), format!("{:?}", copied.eval(wo, wi)));
                assert_eq!(built.pdf(wo, wi).to_bits(), copied.pdf(wo, wi).to_bits());
                let u = (rng.random::<f32>(), Vec2::new(rng.random(), rng.random()));
                let (a, b) = (built.sample(wo, u.0, u.1), copied.sample(wo, u.0, u.1));
                assert_eq!(format!("{a:?}"), format!("{b:?}"), "material {k}, front {front_face}");
                compared += a.is_some() as u32;
            }
        }
        compared
    }

    /// The prebuilt lobes, given the hit's frame, are the lobes built at the hit: `eval`,
    /// `pdf` and `sample` agree bit for bit on both sides, in random frames and directions.
    #[test]
    fn prebuilt_lobes_are_the_lobes_built_at_the_hit() {
        let mut scene = Scene::default();
        for p in materials() {
            let pbr = crate::material::Pbr { factors: p, ..Default::default() };
            scene.materials.push(Material { pbr: Some(Box::new(pbr)), ..Default::default() });
        }
        let constant = ConstantBsdfs::new(&scene);
        let mut rng = Pcg64Mcg::seed_from_u64(3);
        let mut compared = 0;
        for (k, p) in materials().iter().enumerate() {
            compared += compare(&constant, k, |b| bsdf::gltf(b, p, b.frame().n), &mut rng);
        }
        assert!(compared > 1000, "{compared} samples compared");
        // Lecture materials of constant albedo: Lambert, Blinn–Phong, mirror and glass.
        let mut lecture = Scene::default();
        let glassy = Material {
            diffuse: Texture::Constant(Vec3::splat(0.1)),
            transmission: Vec3::splat(0.8),
            ior: 1.5,
            ..Default::default()
        };
        let shiny = Material {
            diffuse: Texture::Constant(Vec3::new(0.6, 0.3, 0.2)),
            specular: Vec3::splat(0.3),
            shininess: 40.0,
            mirror: Vec3::splat(0.2),
            ..Default::default()
        };
        lecture.materials.extend([glassy, shiny]);
        let constant = ConstantBsdfs::new(&lecture);
        for (k, m) in lecture.materials.iter().enumerate() {
            let Texture::Constant(albedo) = m.diffuse else { unreachable!() };
            compare(&constant, k, |b| bsdf::lecture(b, &lecture_params(m, albedo)), &mut rng);
        }
        // A textured material is built at every hit.
        let mut textured = scene.clone();
        let image = crate::texture::Image::from_texels("white.png", 1, 1, vec![Vec3::ONE]).unwrap();
        let w = crate::texture::Wrap::Repeat;
        let texture = crate::texture::ImageTexture {
            image: image.into(),
            wrap_u: w,
            wrap_v: w,
            factor: Vec3::ONE,
            mipmaps: true,
        };
        textured.materials[0].pbr.as_mut().unwrap().base_color_texture =
            Some(crate::material::TextureSlot::plain(texture));
        let constant = ConstantBsdfs::new(&textured);
        assert!(constant.get(0, true).is_none() && constant.get(1, true).is_some());
    }
}
