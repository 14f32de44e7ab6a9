//! The path tracer: unidirectional path tracing with next-event estimation and multiple
//! importance sampling (Veach 1997, ch. 9; pbrt-v4's `PathIntegrator`).
//!
//! A camera ray's radiance is the sum over its vertices `x_0, x_1, …` (`x_0` the camera ray's
//! hit) of what reaches each along a path of throughput
//! `β_k = Π_{j<k} f(x_j)·|cosθ_j| / pdf_j` (the BSDF samples that led there):
//!
//! ```text
//! L = Σ_k β_k · ( w_bsdf · L_e(x_k)                                      emission found
//!               + w_light · f(x_k, ω_l)·|cosθ_l|·L_l·V / (P(light)·pdf_l) )   next-event estimation
//!
//! w_light = p_l² / (p_l² + p_b²),  w_bsdf = p_b² / (p_b² + p_l²)      power heuristic (β = 2)
//! ```
//!
//! with `p_l = P(light)·pdf_l(ω)` the light choice's density of a direction and
//! `p_b = pdf_bsdf(ω)` the BSDF's ([`super::path_lights`], [`crate::bsdf`]). Point and
//! directional lights are sampled by NEE only (`w_light = 1`); emission that the camera ray or
//! a ray after a specular bounce finds counts whole (`w_bsdf = 1`), as does emission of an
//! emitter that is not a light (an emissive sphere, or `mesh_lights = false`). Rays that escape
//! bring the environment's radiance ([`crate::light::environment`]; without one the scene's
//! `background`, a constant environment), weighted by MIS against NEE's sampling of it, and
//! camera rays of a `transparent` render see 0 there. There is no ambient term: it is the
//! Whitted integrator's stand-in for the light this integrator follows.
//!
//! **Absorption** (`KHR_materials_volume`). A ray that refracts into an object whose material
//! has a volume travels in it until it next meets a surface, and its throughput is scaled by
//! `exp(−σ_a·t)` over that distance; refracting out ends the medium. Media do not nest (a ray
//! leaving an inner object is taken to be outside every one), and only absorption is modelled.
//!
//! **Depth.** `image.max_depth = d` scatterings at most: NEE and BSDF sampling happen at
//! vertices `x_0 … x_{d−1}`, so `d = 0` shows emitters only and `d = 1` direct light.
//!
//! **Russian roulette.** The continuation from vertex `x_k`, `k ≥ 3` (after three bounces),
//! survives with probability `q = min(1, max_channel(β·η²))` and then carries `β/q`; `η²` undoes
//! the radiance scaling of refraction (pbrt-v4's `etaScale`), so paths inside glass are not cut
//! for that alone. Unbiased: the expectation is unchanged.
//!
//! **Clamp** (`--clamp C`, `[render] clamp`, off by default): each contribution that has
//! scattered at least twice (NEE at `x_k`, `k ≥ 1`; emission or background found at `x_k`,
//! `k ≥ 2`) is scaled so that its largest channel is at most `C`: less variance from rare
//! bright paths (fireflies), at the cost of energy.
//!
//! **Samples.** Every random number comes from the pixel's Owen-scrambled Sobol sequence
//! ([`crate::sampling::sobol`]), with a fixed set of dimensions per vertex, so a pixel's value
//! depends on its index alone. Each vertex's shadow ray and continuation ray are traced one
//! at a time ([`Accel::occluded`], [`Accel::intersect`]); new origins are moved off the
//! surface to the side the ray leaves on ([`offset_ray_origin`]), and shadow rays end just
//! short of their light point ([`SHADOW_TFAR_SCALE`]).
//!
//! **Passes.** The beauty, and the first-hit passes (depth, normal, albedo, position, object
//! and material indices, Cryptomatte) of the camera ray's hit. The light-path passes are the
//! Whitted integrator's and are refused with this one ([`super::check_scene`]).

use super::lights::SHADOW_TFAR_SCALE;
use super::path_lights::PathLights;
use super::pixel::{CameraSample, FirstHit, Radiance};
use super::{Integrator, PixelSamples, RayCounts};
use crate::accel::{Accel, Hit, TraceError};
use crate::bsdf::LobeFlags;
use crate::math::{Ray, Vec2, Vec3, offset_ray_origin};
use crate::sampling::sobol::{CAMERA_DIMS, Sobol};
use crate::scene::Scene;
use crate::shading::shade_at;
use crate::surface::SurfacePoint;

/// Vertices before Russian roulette may end a path (module docs).
pub const ROULETTE_AFTER: u32 = 3;

/// The path tracer over one scene and acceleration structure.
pub struct PathTracer<'a, A: Accel> {
    pub scene: &'a Scene,
    pub accel: &'a A,
    lights: PathLights<'a>,
}

/// A pixel's Sobol sequence, as the tile loop draws the camera ray from it.
impl PixelSamples for Sobol {
    fn begin(&mut self, sample: u32) {
        self.start_sample(sample);
    }

    fn pixel(&mut self) -> Vec2 {
        self.set_dimension(0);
        self.next_2d()
    }

    fn lens(&mut self) -> Vec2 {
        self.set_dimension(CAMERA_DIMS - 2);
        self.next_2d()
    }
}

/// The power heuristic with β = 2 for `a`'s strategy against `b`'s.
#[inline]
fn power_heuristic(a: f32, b: f32) -> f32 {
    let (a2, b2) = (a * a, b * b);
    if a2 + b2 > 0.0 && (a2 + b2).is_finite() {
        a2 / (a2 + b2)
    } else if a > b {
        1.0
    } else {
        0.0
    }
}

impl<A: Accel> Integrator for PathTracer<'_, A> {
    type Scratch = ();
    type Sampler = Sobol;

    fn sampler(&self, _spp: u32, pixel_index: u64, _lens: bool) -> Sobol {
        Sobol::new(pixel_index)
    }

    fn shade_round(
        &self,
        rays: &[Ray],
        hits: &[Option<Hit>],
        samplers: &mut [Sobol],
        counts: &mut RayCounts,
        _scratch: &mut (),
        out: &mut [CameraSample],
    ) -> Result<(), TraceError> {
        for (((ray, hit), s), o) in rays.iter().zip(hits).zip(samplers.iter_mut()).zip(out.iter_mut()) {
            let (radiance, first) = self.radiance(ray, hit.as_ref(), s, counts)?;
            *o = CameraSample { radiance, split: Radiance::default(), first };
        }
        Ok(())
    }
}

impl<'a, A: Accel> PathTracer<'a, A> {
    /// The path tracer of `scene`, tracing through `accel`.
    pub fn new(scene: &'a Scene, accel: &'a A) -> Self {
        PathTracer { scene, accel, lights: PathLights::new(scene) }
    }

    /// `c` added to `l`, clamped when it is indirect light and a clamp is set (module docs).
    #[inline]
    fn add(&self, l: &mut Vec3, c: Vec3, indirect: bool) {
        match self.scene.render.clamp {
            Some(max) if indirect && c.max_element() > max => *l += c * (max / c.max_element()),
            _ => *l += c,
        }
    }

    /// Adds what the ray that escaped after `depth` scatterings (from `prev`, as in
    /// [`Self::radiance`]) sees of the environment, weighted against NEE's sampling of it;
    /// camera rays of a `transparent` render see 0.
    fn add_environment(&self, l: &mut Vec3, beta: Vec3, ray: &Ray, prev: Option<(Vec3, Vec3, f32)>, depth: u32) {
        if depth == 0 && self.scene.output.transparent {
            return;
        }
        let wi = ray.dir.normalize();
        let le = self.lights.environment(wi);
        if le == Vec3::ZERO {
            return;
        }
        let w = match prev {
            None => 1.0,
            Some((p, n, pdf_bsdf)) => power_heuristic(pdf_bsdf, self.lights.pdf_environment(p, n, wi)),
        };
        self.add(l, beta * le * w, depth >= 2);
    }

    /// The radiance along the camera ray `ray` whose closest hit is `hit`, drawing from the
    /// pixel's sampler `s` (begun for this sample), and what the AOVs record of that hit.
    pub fn radiance(
        &self,
        ray: &Ray,
        hit: Option<&Hit>,
        s: &mut Sobol,
        counts: &mut RayCounts,
    ) -> Result<(Vec3, Option<FirstHit>), TraceError> {
        let scene = self.scene;
        let max_depth = scene.image.max_depth;
        let mut l = Vec3::ZERO;
        let mut beta = Vec3::ONE;
        let mut eta_scale = 1.0f32;
        let mut ray = *ray;
        let mut hit = hit.copied();
        let mut first = None;
        // The previous vertex and its BSDF density of the ray's direction; `None` for the
        // camera ray and after a specular bounce (emission counts whole).
        let mut prev: Option<(Vec3, Vec3, f32)> = None;
        // σ_a of the absorbing object the ray travels inside, if any (module docs).
        let mut medium: Option<Vec3> = None;
        let mut depth = 0u32;
        loop {
            if let Some(sigma_a) = medium {
                beta *= transmittance(sigma_a, hit.map_or(f32::INFINITY, |h| h.t));
            }
            let Some(h) = hit else {
                self.add_environment(&mut l, beta, &ray, prev, depth);
                break;
            };
            let sp = SurfacePoint::new(scene, &ray, &h);
            if depth == 0 {
                first = Some(FirstHit::new(&sp, &h));
            }
            let wo = -ray.dir;
            let shading = shade_at(scene, &sp, wo, 0.0);
            if shading.emission != Vec3::ZERO {
                let w = match prev {
                    None => 1.0,
                    Some((p, n, pdf_bsdf)) => power_heuristic(pdf_bsdf, self.lights.pdf_hit(p, n, ray.dir, &h, &sp)),
                };
                self.add(&mut l, beta * shading.emission * w, depth >= 2);
            }
            if depth >= max_depth {
                break;
            }
            s.start_bounce(depth);
            let u_light = s.next_2d();
            let u_select = s.next_1d();
            let u_roulette = s.next_1d();
            let u_bsdf = s.next_2d();
            let u_lobe = s.next_1d();
            let bsdf = &shading.bsdf;

            // Next-event estimation.
            if bsdf.flags().intersects(LobeFlags::DIFFUSE | LobeFlags::GLOSSY) {
                if let Some((ls, choice)) = self.lights.sample(sp.p, sp.ns, u_select, u_light) {
                    let f = bsdf.eval(wo, ls.wi).sum() * ls.wi.dot(sp.ns).abs();
                    if f != Vec3::ZERO && ls.radiance != Vec3::ZERO {
                        counts.shadow += 1;
                        if !self.accel.occluded(&shadow_ray(&sp, &ls))? {
                            let p_light = choice * ls.pdf;
                            let w = if ls.delta { 1.0 } else { power_heuristic(p_light, bsdf.pdf(wo, ls.wi)) };
                            self.add(&mut l, beta * f * ls.radiance * (w / p_light), depth >= 1);
                        }
                    }
                }
            }

            // The BSDF's sample continues the path.
            let Some(bs) = bsdf.sample(wo, u_lobe, u_bsdf) else { break };
            if !(bs.pdf > 0.0) || bs.f == Vec3::ZERO {
                break;
            }
            beta *= bs.f * (bs.wi.dot(sp.ns).abs() / bs.pdf);
            prev = if bs.flags.is_specular() { None } else { Some((sp.p, sp.ns, bs.pdf)) };
            if bs.is_transmission() {
                eta_scale *= bs.eta * bs.eta;
                // Into the object through its surface, or out of it.
                medium = if bs.wi.dot(sp.ng_outward) < 0.0 { shading.volume.map(|v| v.sigma_a) } else { None };
            }
            if depth >= ROULETTE_AFTER {
                let q = (beta * eta_scale).max_element().min(1.0);
                if !(u_roulette < q) {
                    break;
                }
                beta /= q;
            }
            if !beta.is_finite() || beta == Vec3::ZERO {
                break;
            }
            let side = if bs.wi.dot(sp.ng) > 0.0 { sp.ng } else { -sp.ng };
            ray = Ray::new(offset_ray_origin(sp.p, side), bs.wi);
            if bs.is_transmission() {
                counts.refracted += 1;
            } else {
                counts.reflected += 1;
            }
            hit = self.accel.intersect(&ray)?;
            depth += 1;
        }
        Ok((l, first))
    }
}

/// Beer–Lambert: the fraction `exp(−σ_a·t)` of radiance left after a distance `t` in a medium
/// (1 where σ_a is 0, also for `t = ∞`).
fn transmittance(sigma_a: Vec3, t: f32) -> Vec3 {
    let tr = |s: f32| if s > 0.0 { (-s * t).exp() } else { 1.0 };
    Vec3::new(tr(sigma_a.x), tr(sigma_a.y), tr(sigma_a.z))
}

/// The shadow ray from `sp` towards the light sample `ls`: from the point moved off the
/// surface to the side of the light, ending just short of a light point at a finite distance.
fn shadow_ray(sp: &SurfacePoint, ls: &crate::light::set::LightSample) -> Ray {
    let side = if ls.wi.dot(sp.ng) > 0.0 { sp.ng } else { -sp.ng };
    let origin = offset_ray_origin(sp.p, side);
    if ls.distance.is_finite() {
        let to = (sp.p + ls.distance * ls.wi) - origin;
        let d = to.length();
        Ray::segment(origin, to / d, 0.0, d * SHADOW_TFAR_SCALE)
    } else {
        Ray::new(origin, ls.wi)
    }
}
