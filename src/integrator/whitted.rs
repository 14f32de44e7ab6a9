//! The Whitted integrator: the lecture's ray tracer, in its three steps.
//!
//! 1. **Ray generation** ([`crate::camera`], in the tile loop of [`super`]): for every pixel
//!    and sample, the pinhole ray `e + t·s/|s|` through the sample's position
//!    ([`crate::sampler`]), or with a thin lens the ray from a lens point (stratified across
//!    the pixel's samples, [`SampleDims`]) through the point of the focus plane that pinhole
//!    ray meets.
//! 2. **Intersection** ([`Accel`]): the closest hit with `t > 0`. Primary rays of a tile go
//!    to [`Accel::intersect_batch`] (Embree traces them as 8-wide packets, 2–4× faster on
//!    coherent rays); secondary rays one at a time; shadow rays as any-hit `occluded` queries.
//!    The shadow rays of a tile's camera-ray hits go out light by light (for an area light,
//!    sample by sample) as one [`Accel::occluded_batch`] each ([`super::shadow`]), which
//!    Embree traces as 8-wide `rtcOccluded8` packets: neighbouring pixels' rays towards one
//!    light point are as coherent as their camera rays. Deeper hits trace theirs one by one.
//! 3. **Shading** ([`Whitted::shade`]) at the hit, with the data of [`SurfacePoint`]:
//!
//! ```text
//! L = L_e + ρ·L_a                                      emission + ambient
//!   + Σ_lights V · (ρ/π + k_s·K(n)·(n·h)^n) · E·cosθ   diffuse + normalised Blinn–Phong
//!   + k_r · L(reflected ray)                           mirror (+ Fresnel R of a dielectric)
//!   + k_t · T · L(refracted ray)                       Snell + Fresnel
//! ```
//!
//! with `E = I/d²` for a point light of intensity `I` at distance `d` and `E` itself for a
//! directional light, `cosθ` between the shading normal and the direction to the light, and
//! `V` the shadow ray's verdict. An area light adds `light_samples` such terms, each with a
//! point sampled on the light and `E = L·cosθ_l/(d²·pdf_A)/light_samples`
//! ([`crate::light::area`]): the same shadow ray and BRDF, so its light lands in the direct
//! diffuse and specular passes. Every mesh with an emitting material is such a light too, with
//! one sample per shading point ([`crate::light::mesh`]). The light points are stratified across the pixel's samples
//! ([`SampleDims`]). Emitters are ordinary objects to every ray (their `L_e` is what camera,
//! mirror and glass rays see, from the front only when one-sided); a shadow ray ends just
//! short of its light sample, so a light does not shadow itself. A dielectric (`transmission = k_t ≠ 0`) adds `k_t·R` to the
//! mirror weight `k_r` and refracts `k_t·T`, `R` from the exact unpolarised Fresnel equations
//! and `T = 1 − R` ([`crate::optics`]); beyond the critical angle `R = 1` (total internal
//! reflection). A ray entering or leaving a dielectric is told apart by the geometric normal:
//! entering when it arrives on the side the normal points to (`ior` inside, 1 outside).
//! Rays that escape return the background radiance, or the environment's along their
//! direction when the scene has one (it lights nothing else: no diffuse surface samples it).
//!
//! **Recursion.** The primary ray has depth 0; a hit at depth `k` spawns reflected and
//! refracted rays only while `k < image.max_depth`, so at most `max_depth` secondary rays
//! follow one another. A secondary ray is also skipped when its throughput (the product of
//! the weights along its path) falls below [`THROUGHPUT_CUTOFF`] in every channel.
//! `max_depth` may be at most [`crate::scene::MAX_DEPTH_LIMIT`] (the recursion uses the
//! worker's stack).
//!
//! **Shadow rays and glass.** Every object blocks shadow rays, glass included: a glass ball
//! casts an ordinary hard shadow. A straight shadow ray through a refracting object would be
//! physically wrong either way: the light that really reaches the shadow is focused into
//! caustics, which a Whitted tracer cannot find; letting it through unbent (perhaps
//! tinted) would paint a lit disc where the real image has a dark shadow with a bright
//! caustic somewhere else. The ordinary shadow is the lecture's, and the honest one.
//!
//! **Secondary-ray origins** are moved off the surface with
//! [`crate::math::offset_ray_origin`] (Wächter–Binder), to the side the new ray leaves on;
//! shadow rays towards a point light end just short of it
//! ([`super::lights::SHADOW_TFAR_SCALE`]).
//!
//! **Passes.** Shading the camera ray's hit also splits its radiance into the terms of the
//! light-path passes ([`super::pixel::Radiance`], [`crate::output::passes`]): `L_e` is Emit;
//! the Lambert term is DiffDir and the ambient `ρ·L_a` DiffInd (it stands in for indirect
//! diffuse light); the Blinn–Phong highlight is GlossDir; everything seen in a mirror or by
//! Fresnel reflection is GlossInd and everything seen through refraction TransInd (emitters and
//! background included, where Cycles would count what one bounce reaches as direct); the
//! background of a camera ray that escapes is Env. The family colours are [`colors`]. The beauty
//! is still summed as before, term by term in the same order, so the passes add up to it to
//! float rounding and the beauty does not change.

use super::lights::{Lights, shadow_ray};
use super::pixel::{CameraSample, FirstHit, Radiance};
use super::shadow::ShadowBatch;
use super::{Integrator, PixelSamples, RayCounts};
use crate::accel::{Accel, Hit, TraceError};
use crate::bsdf::BsdfEval;
use crate::camera::Camera;
use crate::light::Incidence;
use crate::material::Material;
use crate::math::{Ray, Vec2, Vec3, offset_ray_origin};
use crate::optics;
use crate::sampler::{PixelSampler, SampleDims};
use crate::scene::Scene;
use crate::surface::SurfacePoint;

/// A secondary ray whose throughput is below this in every channel is not traced: it could
/// change the pixel by at most this fraction of the radiance it would find.
pub const THROUGHPUT_CUTOFF: f32 = 1e-4;

/// The Whitted integrator over one scene, camera and acceleration structure.
pub struct Whitted<'a, A: Accel> {
    pub scene: &'a Scene,
    pub accel: &'a A,
    pub camera: Camera,
    /// The scene's lights, as shading points sample them.
    pub lights: Lights<'a>,
}

/// The working memory of one tile's rounds: each camera ray's shading point and its albedo
/// ([`SurfacePoint::albedo`]), and the shadow rays' batches.
#[derive(Default)]
pub struct WhittedScratch {
    points: Vec<Option<SurfacePoint>>,
    albedos: Vec<Vec3>,
    batch: ShadowBatch,
}

/// A pixel's samples for the Whitted integrator: stratified positions ([`PixelSampler`]) and
/// the stratified light and lens points ([`SampleDims`]), as [`crate::sampler`] describes.
#[derive(Clone, Debug)]
pub struct WhittedSampler {
    pub pixel: PixelSampler,
    pub dims: SampleDims,
}

impl PixelSamples for WhittedSampler {
    fn begin(&mut self, sample: u32) {
        self.dims.begin(sample);
    }

    fn pixel(&mut self) -> Vec2 {
        self.pixel.next_offset()
    }

    fn lens(&mut self) -> Vec2 {
        self.dims.lens()
    }
}

impl AsMut<SampleDims> for WhittedSampler {
    fn as_mut(&mut self) -> &mut SampleDims {
        &mut self.dims
    }
}

impl<A: Accel> Integrator for Whitted<'_, A> {
    type Scratch = WhittedScratch;
    type Sampler = WhittedSampler;

    /// Light sample points are drawn only when the scene has sampled lights, lens points only
    /// with an aperture: a pinhole scene with point lights draws nothing but the positions.
    fn sampler(&self, spp: u32, pixel_index: u64, lens: bool) -> WhittedSampler {
        let lights = self.lights.sampled();
        let dims = if lights || lens { SampleDims::new(spp, pixel_index, lights, lens) } else { SampleDims::unused() };
        WhittedSampler { pixel: PixelSampler::new(spp, pixel_index), dims }
    }

    /// Emission, then the direct light with the shadow rays towards each light (sample) traced
    /// as one batch ([`ShadowBatch`]), then reflection and refraction pixel by pixel; each
    /// pixel's terms are added in the order [`Whitted::shade`] adds them, so the sums are
    /// bit-identical to shading its ray alone.
    fn shade_round(
        &self,
        rays: &[Ray],
        hits: &[Option<Hit>],
        dims: &mut [WhittedSampler],
        counts: &mut RayCounts,
        scratch: &mut WhittedScratch,
        out: &mut [CameraSample],
    ) -> Result<(), TraceError> {
        let WhittedScratch { points, albedos, batch } = scratch;
        points.clear();
        albedos.clear();
        for ((ray, hit), o) in rays.iter().zip(hits).zip(out.iter_mut()) {
            let point = self.shade_emission(ray, hit.as_ref(), o);
            albedos.push(point.map_or(Vec3::ZERO, |(_, albedo)| albedo));
            points.push(point.map(|(sp, _)| sp));
        }
        let materials = &self.scene.materials;
        let casts = |i: usize, sp: &SurfacePoint| is_lit(albedos[i], &materials[sp.material as usize]);
        batch.trace(self.accel, &self.lights, points, casts, dims, counts, |i, sp, inc| {
            let o = &mut out[i];
            let m = &materials[sp.material as usize];
            add_direct(sp, albedos[i], m, -rays[i].dir, inc, &mut o.radiance, Some(&mut o.split));
        })?;
        for (((((ray, hit), d), p), albedo), o) in
            rays.iter().zip(hits).zip(dims.iter_mut()).zip(points.iter()).zip(albedos.iter()).zip(out.iter_mut())
        {
            o.first = match (p, hit) {
                (Some(sp), Some(hit)) => {
                    o.radiance = self.shade_indirect(
                        ray,
                        sp,
                        0,
                        Vec3::ONE,
                        &mut d.dims,
                        counts,
                        o.radiance,
                        Some(&mut o.split),
                    )?;
                    Some(FirstHit::new(sp, hit, colors(*albedo, &self.scene.materials[sp.material as usize])))
                }
                _ => None,
            };
        }
        Ok(())
    }
}

impl<'a, A: Accel> Whitted<'a, A> {
    /// The integrator of `scene` seen by `camera`, tracing through `accel`.
    pub fn new(scene: &'a Scene, accel: &'a A, camera: Camera) -> Self {
        Whitted { scene, accel, camera, lights: Lights::new(scene) }
    }

    /// The radiance of a ray along `dir` that hits nothing: the environment's (which lights
    /// nothing else here), else the background; 0 in a transparent render.
    fn background(&self, dir: Vec3) -> Vec3 {
        match &self.scene.environment {
            _ if self.scene.output.transparent => Vec3::ZERO,
            Some(env) => env.radiance(dir.normalize()),
            None => self.scene.image.background,
        }
    }

    /// The radiance along a primary ray whose closest hit is `hit`, and what the AOVs record
    /// of that hit. `dims` gives the light samples (of the pixel sample being traced).
    pub fn shade_primary(
        &self,
        ray: &Ray,
        hit: Option<&Hit>,
        dims: &mut SampleDims,
        counts: &mut RayCounts,
    ) -> Result<(Vec3, Option<FirstHit>), TraceError> {
        let (radiance, _, first) = self.shade_primary_split(ray, hit, dims, counts)?;
        Ok((radiance, first))
    }

    /// [`Whitted::shade_primary`] with the radiance also split into its terms.
    pub fn shade_primary_split(
        &self,
        ray: &Ray,
        hit: Option<&Hit>,
        dims: &mut SampleDims,
        counts: &mut RayCounts,
    ) -> Result<(Vec3, Radiance, Option<FirstHit>), TraceError> {
        let Some(hit) = hit else {
            let background = self.background(ray.dir);
            return Ok((background, Radiance { background, ..Default::default() }, None));
        };
        let sp = SurfacePoint::new(self.scene, ray, hit);
        let albedo = sp.albedo(self.scene);
        let first = FirstHit::new(&sp, hit, colors(albedo, &self.scene.materials[sp.material as usize]));
        let mut split = Radiance::default();
        let radiance = self.shade_split(ray, &sp, albedo, 0, Vec3::ONE, dims, counts, Some(&mut split))?;
        Ok((radiance, split, Some(first)))
    }

    /// Steps 2 and 3 for a secondary ray at recursion depth `depth` whose path so far weighs
    /// `throughput`: the radiance arriving along it.
    pub fn trace(
        &self,
        ray: &Ray,
        depth: u32,
        throughput: Vec3,
        dims: &mut SampleDims,
        counts: &mut RayCounts,
    ) -> Result<Vec3, TraceError> {
        match self.accel.intersect(ray)? {
            None => Ok(self.background(ray.dir)),
            Some(hit) => {
                let sp = SurfacePoint::new(self.scene, ray, &hit);
                self.shade(ray, &sp, depth, throughput, dims, counts)
            }
        }
    }

    /// Step 3: the radiance leaving `sp` back along `ray` (see the module docs for the
    /// formula), tracing shadow, reflected and refracted rays as needed.
    pub fn shade(
        &self,
        ray: &Ray,
        sp: &SurfacePoint,
        depth: u32,
        throughput: Vec3,
        dims: &mut SampleDims,
        counts: &mut RayCounts,
    ) -> Result<Vec3, TraceError> {
        self.shade_split(ray, sp, sp.albedo(self.scene), depth, throughput, dims, counts, None)
    }

    /// [`Whitted::shade`] of `sp` whose albedo is `albedo`, also adding each term to `split`
    /// when given. The returned radiance is summed exactly as without `split`.
    #[allow(clippy::too_many_arguments)] // the ray, the hit, the path's state, and what it adds to
    fn shade_split(
        &self,
        ray: &Ray,
        sp: &SurfacePoint,
        albedo: Vec3,
        depth: u32,
        throughput: Vec3,
        dims: &mut SampleDims,
        counts: &mut RayCounts,
        mut split: Option<&mut Radiance>,
    ) -> Result<Vec3, TraceError> {
        let m = &self.scene.materials[sp.material as usize];
        let mut l = self.emission(sp, albedo, split.as_deref_mut());

        // Direct light: one shadow ray per point or directional light, `light_samples` per
        // area light (each sample's incidence carries 1/light_samples of the estimate).
        if is_lit(albedo, m) {
            let origin = offset_ray_origin(sp.p, sp.ng);
            for slot in self.lights.slots() {
                let Some(inc) = self.lights.incidence(&slot, sp.p, dims) else { continue };
                let Some(shadow) = shadow_ray(sp, origin, &inc) else { continue };
                counts.shadow += 1;
                if !self.accel.occluded(&shadow)? {
                    add_direct(sp, albedo, m, -ray.dir, &inc, &mut l, split.as_deref_mut());
                }
            }
        }
        self.shade_indirect(ray, sp, depth, throughput, dims, counts, l, split)
    }

    /// Emission (from the front only, for a one-sided emitter) and ambient: a diffuse surface
    /// of albedo `albedo` under uniform radiance `L_a` reflects `ρ·L_a`. Sets `split.emission`
    /// and, the ambient term standing in for indirect diffuse light, `split.indirect.diffuse`.
    fn emission(&self, sp: &SurfacePoint, albedo: Vec3, split: Option<&mut Radiance>) -> Vec3 {
        let m = &self.scene.materials[sp.material as usize];
        let emission = if m.emission_one_sided && !sp.front_face { Vec3::ZERO } else { m.emission };
        let ambient = albedo * self.scene.image.ambient;
        if let Some(split) = split {
            split.emission = emission;
            split.indirect.diffuse = ambient;
        }
        emission + ambient
    }

    /// A camera ray's shading before its direct light: into `out`, the background when it
    /// hits nothing, else [`Whitted::emission`] (and `out.first` cleared); returns its surface
    /// point and albedo.
    fn shade_emission(&self, ray: &Ray, hit: Option<&Hit>, out: &mut CameraSample) -> Option<(SurfacePoint, Vec3)> {
        out.first = None;
        let Some(hit) = hit else {
            let background = self.background(ray.dir);
            out.radiance = background;
            out.split = Radiance { background, ..Default::default() };
            return None;
        };
        let sp = SurfacePoint::new(self.scene, ray, hit);
        let albedo = sp.albedo(self.scene);
        out.split = Radiance::default();
        out.radiance = self.emission(&sp, albedo, Some(&mut out.split));
        Some((sp, albedo))
    }

    /// Reflection and refraction at `sp` (hit by `ray` at recursion depth `depth`), added to
    /// `l`, the radiance of the terms before them: the radiance leaving `sp` along `-ray.dir`.
    #[allow(clippy::too_many_arguments)] // the ray, the hit, the path's state, and what it adds to
    fn shade_indirect(
        &self,
        ray: &Ray,
        sp: &SurfacePoint,
        depth: u32,
        throughput: Vec3,
        dims: &mut SampleDims,
        counts: &mut RayCounts,
        mut l: Vec3,
        mut split: Option<&mut Radiance>,
    ) -> Result<Vec3, TraceError> {
        let scene = self.scene;
        let m = &scene.materials[sp.material as usize];
        let wo = -ray.dir;
        if depth >= scene.image.max_depth {
            return Ok(l);
        }

        // Mirror and dielectric weights.
        let mut reflect_weight = m.mirror;
        let mut refract = None;
        if m.is_dielectric() {
            let (eta_i, eta_t) = if sp.front_face { (1.0, m.ior) } else { (m.ior, 1.0) };
            let r = optics::fresnel_dielectric(wo.dot(sp.ns), eta_i, eta_t);
            reflect_weight += r * m.transmission;
            if r < 1.0 {
                let eta = eta_i / eta_t;
                // Refract about the shading normal unless that sends the ray back out of the
                // surface; then about the geometric one.
                let dir = optics::refract(ray.dir, sp.ns, eta)
                    .filter(|t| t.dot(sp.ng) < 0.0)
                    .or_else(|| optics::refract(ray.dir, sp.ng, eta).filter(|t| t.dot(sp.ng) < 0.0));
                refract = dir.map(|d| (d.normalize(), (1.0 - r) * m.transmission));
            }
        }

        // Reflection.
        if (throughput * reflect_weight).max_element() >= THROUGHPUT_CUTOFF {
            let mut dir = optics::reflect(ray.dir, sp.ns);
            if dir.dot(sp.ng) <= 0.0 {
                dir = optics::reflect(ray.dir, sp.ng); // the shading normal bent it into the surface
            }
            let reflected = Ray::new(offset_ray_origin(sp.p, sp.ng), dir.normalize());
            counts.reflected += 1;
            let reflection =
                reflect_weight * self.trace(&reflected, depth + 1, throughput * reflect_weight, dims, counts)?;
            l += reflection;
            if let Some(split) = split.as_deref_mut() {
                split.indirect.glossy = reflection;
            }
        }

        // Refraction.
        if let Some((dir, weight)) = refract.filter(|(_, w)| (throughput * *w).max_element() >= THROUGHPUT_CUTOFF) {
            let refracted = Ray::new(offset_ray_origin(sp.p, -sp.ng), dir);
            counts.refracted += 1;
            let transmission = weight * self.trace(&refracted, depth + 1, throughput * weight, dims, counts)?;
            l += transmission;
            if let Some(split) = split {
                split.indirect.transmission = transmission;
            }
        }
        Ok(l)
    }
}

/// The colours of the lobe families at a point of albedo `albedo` (the passes' `…Col`): ρ for
/// the diffuse, `k_s + k_r` (`+ k_t` for a dielectric, whose Fresnel reflection is glossy) for
/// the glossy and `k_t` for the transmitting family. Each term of the split is a multiple of
/// its family's colour.
fn colors(albedo: Vec3, m: &Material) -> BsdfEval {
    let kt = if m.is_dielectric() { m.transmission } else { Vec3::ZERO };
    BsdfEval { diffuse: albedo, glossy: m.specular + m.mirror + kt, transmission: kt }
}

/// Whether light reaching a point of albedo `albedo` can be reflected towards the viewer (a
/// diffuse or specular term): only then are shadow rays traced.
#[inline]
fn is_lit(albedo: Vec3, m: &Material) -> bool {
    albedo != Vec3::ZERO || m.specular != Vec3::ZERO
}

/// Adds the light of an unoccluded `inc` reflected at `sp` (of albedo `albedo`) towards `wo` to
/// `l` (and its diffuse and specular terms to `split`): `(ρ/π + k_s·K(n)·(n·h)^n) · E · cosθ`.
#[inline]
fn add_direct(
    sp: &SurfacePoint,
    albedo: Vec3,
    m: &Material,
    wo: Vec3,
    inc: &Incidence,
    l: &mut Vec3,
    split: Option<&mut Radiance>,
) {
    let cos = sp.ns.dot(inc.to_light);
    let lambert = optics::lambert(albedo);
    let mut brdf = lambert;
    let mut highlight = Vec3::ZERO;
    if m.specular != Vec3::ZERO {
        let h = (inc.to_light + wo).normalize_or_zero();
        highlight = m.specular * optics::blinn_phong(sp.ns.dot(h), m.shininess);
        brdf += highlight;
    }
    *l += brdf * inc.normal_irradiance * cos;
    if let Some(split) = split {
        split.direct.diffuse += lambert * inc.normal_irradiance * cos;
        split.direct.glossy += highlight * inc.normal_irradiance * cos;
    }
}
