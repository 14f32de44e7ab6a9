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
//! **Russian roulette.** The continuation from vertex `x_k`, `k ≥ 2` (after two bounces),
//! survives with probability `q = min(1, √max_channel(β·η²))` and then carries `β/q`; `η²`
//! undoes the radiance scaling of refraction (pbrt-v4's `etaScale`), so paths inside glass are
//! not cut for that alone. Unbiased: the expectation is unchanged. The square root is Cycles'
//! (`path_state_continuation_probability`, which starts at the first bounce): gentler than `q =
//! β`, it keeps more of the dim paths that a room lit by a small light gets most of its light
//! from. Of the rules measured on the Cornell rooms (docs/performance.md, "Russian roulette,
//! the rule strahl plays"), this one reached a given error in the least time.
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
//! **Passes.** The beauty, the first-hit passes (depth, normal, the lobe families' colours
//! `Bsdf::colors`, position, object and material indices, Cryptomatte) of the camera ray's hit,
//! and the light-path passes as Cycles splits a path ([`crate::output::passes`]): the first
//! hit's emission is Emit and the environment a camera ray sees is Env; light that NEE brings
//! to the first hit is direct, split by the lobe families of `f`; the first hit's BSDF sample
//! gives the path its family (all to the sampled lobe's family for a specular sample, else
//! each family's share of `f` at the sampled direction, per channel), and emission or
//! environment its ray finds is that family's direct light, everything after it (NEE at later
//! vertices, emission and environment found by later rays) that family's indirect light. The
//! split costs one BSDF evaluation per sample, made only when a light-path pass is written.

use super::lights::SHADOW_TFAR_SCALE;
use super::path_lights::PathLights;
use super::pixel::{CameraSample, FirstHit, Radiance};
use super::{Integrator, PixelSamples, RayCounts};
use crate::accel::{Accel, Hit, TraceError};
use crate::bsdf::{BsdfEval, LobeFlags};
use crate::math::{Ray, Vec2, Vec3, offset_ray_origin};
use crate::sampling::sobol::{CAMERA_DIMS, Sobol};
use crate::scene::Scene;
use crate::shading::{ConstantBsdfs, Shading, shade_at};
use crate::surface::SurfacePoint;

/// Vertices before Russian roulette may end a path (module docs).
pub const ROULETTE_AFTER: u32 = 2;

/// The path tracer over one scene and acceleration structure.
pub struct PathTracer<'a, A: Accel> {
    pub scene: &'a Scene,
    pub accel: &'a A,
    lights: PathLights<'a>,
    /// Whether the light-path passes are written (the split costs a BSDF evaluation per sample).
    split: bool,
    /// The camera rays' cone, for texture filtering at the first hit ([`crate::shading`]).
    cone: crate::camera::RayCone,
    /// The untextured materials' lobes, built once ([`crate::shading`]).
    constant: ConstantBsdfs,
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
            let mut split = Radiance::default();
            let want = self.split.then_some(&mut split);
            let (radiance, first) = self.radiance(ray, hit.as_ref(), s, counts, want)?;
            *o = CameraSample { radiance, split, first };
        }
        Ok(())
    }
}

impl<'a, A: Accel> PathTracer<'a, A> {
    /// The path tracer of `scene`, tracing through `accel`.
    pub fn new(scene: &'a Scene, accel: &'a A) -> Self {
        let img = &scene.image;
        let camera = crate::camera::Camera::new(&scene.camera, img.width, img.height);
        let cone = camera.map_or(Default::default(), |c| c.ray_cone().per_sample(img.spp));
        let (lights, constant) = (PathLights::new(scene), ConstantBsdfs::new(scene));
        PathTracer { scene, accel, lights, split: scene.output.passes.any_light(), cone, constant }
    }

    /// `c` added to `l`, clamped when it is indirect light and a clamp is set (module docs);
    /// returns what was added.
    #[inline]
    fn add(&self, l: &mut Vec3, c: Vec3, indirect: bool) -> Vec3 {
        let c = match self.scene.render.clamp {
            Some(max) if indirect && c.max_element() > max => c * (max / c.max_element()),
            _ => c,
        };
        *l += c;
        c
    }

    /// Adds what the ray that escaped after `depth` scatterings (from `prev`, as in
    /// [`Self::radiance`]) sees of the environment, weighted against NEE's sampling of it;
    /// camera rays of a `transparent` render see 0.
    fn add_environment(
        &self,
        l: &mut Vec3,
        beta: Vec3,
        ray: &Ray,
        prev: Option<(Vec3, Vec3, f32)>,
        depth: u32,
    ) -> Vec3 {
        if depth == 0 && self.scene.output.transparent {
            return Vec3::ZERO;
        }
        let wi = ray.dir.normalize();
        let le = self.lights.environment(wi);
        if le == Vec3::ZERO {
            return Vec3::ZERO;
        }
        let w = match prev {
            None => 1.0,
            Some((p, n, pdf_bsdf)) => power_heuristic(pdf_bsdf, self.lights.pdf_environment(p, n, wi)),
        };
        self.add(l, beta * le * w, depth >= 2)
    }

    /// The radiance along the camera ray `ray` whose closest hit is `hit`, drawing from the
    /// pixel's sampler `s` (begun for this sample), and what the AOVs record of that hit; with
    /// `split`, the same radiance split into the light-path passes' terms (module docs).
    pub fn radiance(
        &self,
        ray: &Ray,
        hit: Option<&Hit>,
        s: &mut Sobol,
        counts: &mut RayCounts,
        mut split: Option<&mut Radiance>,
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
        // The lobe families the first hit's scattering went to, per channel (module docs).
        let mut family = BsdfEval::default();
        let mut shading = Shading::default();
        let mut depth = 0u32;
        loop {
            if let Some(sigma_a) = medium {
                beta *= transmittance(sigma_a, hit.map_or(f32::INFINITY, |h| h.t));
            }
            let Some(h) = hit else {
                let c = self.add_environment(&mut l, beta, &ray, prev, depth);
                if let Some(split) = split.as_deref_mut() {
                    split.add_found(c, depth, &family);
                    if depth == 0 {
                        split.background = c;
                    }
                }
                break;
            };
            // Camera rays filter textures by their cone; later vertices read them at a point.
            // Normal maps are read before the hit is re-solved ([`SurfacePoint`]), at the
            // cone's width at the backend's `t`.
            let sp = if depth == 0 {
                SurfacePoint::with_footprint(scene, &ray, &h, self.cone.width_at(h.t * ray.dir.length()))
            } else {
                SurfacePoint::new(scene, &ray, &h)
            };
            let wo = -ray.dir;
            let footprint = if depth == 0 { self.cone.width_at(sp.t * ray.dir.length()) } else { 0.0 };
            shade_at(scene, &self.constant, &sp, wo, footprint, &mut shading);
            if depth == 0 {
                first = Some(FirstHit::new(&sp, &h, shading.bsdf.colors()));
            }
            if shading.emission != Vec3::ZERO {
                let w = match prev {
                    None => 1.0,
                    Some((p, n, pdf_bsdf)) => power_heuristic(pdf_bsdf, self.lights.pdf_hit(p, n, ray.dir, &h, &sp)),
                };
                let c = self.add(&mut l, beta * shading.emission * w, depth >= 2);
                if let Some(split) = split.as_deref_mut() {
                    split.add_found(c, depth, &family);
                    if depth == 0 {
                        split.emission = c;
                    }
                }
            }
            if depth >= max_depth {
                break;
            }
            s.start_bounce(depth);
            let u_light = s.next_2d();
            let u_roulette = s.next_1d();
            let u_bsdf = s.next_2d();
            let u_lobe = s.next_1d();
            let bsdf = &shading.bsdf;

            // Next-event estimation.
            if bsdf.flags().intersects(LobeFlags::DIFFUSE | LobeFlags::GLOSSY) {
                if let Some((ls, choice)) = self.lights.sample(sp.p, sp.ns, u_light) {
                    let eval = bsdf.eval(wo, ls.wi);
                    let cos = ls.wi.dot(sp.ns).abs();
                    let f = eval.sum() * cos;
                    if f != Vec3::ZERO && ls.radiance != Vec3::ZERO {
                        counts.shadow += 1;
                        if !self.accel.occluded(&shadow_ray(&sp, &ls))? {
                            let p_light = choice * ls.pdf;
                            let w = if ls.delta { 1.0 } else { power_heuristic(p_light, bsdf.pdf(wo, ls.wi)) };
                            let c = self.add(&mut l, beta * f * ls.radiance * (w / p_light), depth >= 1);
                            if let Some(split) = split.as_deref_mut() {
                                if depth == 0 {
                                    // β = 1 and nothing is clamped at the first hit.
                                    let weight = ls.radiance * (w / p_light);
                                    split.direct.diffuse += eval.diffuse * cos * weight;
                                    split.direct.glossy += eval.glossy * cos * weight;
                                    split.direct.transmission += eval.transmission * cos * weight;
                                } else {
                                    add_by_family(&mut split.indirect, &family, c);
                                }
                            }
                        }
                    }
                }
            }

            // The BSDF's sample continues the path.
            let Some(bs) = bsdf.sample(wo, u_lobe, u_bsdf) else { break };
            if !(bs.pdf > 0.0) || bs.f == Vec3::ZERO {
                break;
            }
            if depth == 0 && split.is_some() {
                family = families(bsdf, wo, &bs);
            }
            beta *= bs.f * (bs.wi.dot(sp.ns).abs() / bs.pdf);
            prev = if bs.flags.is_specular() { None } else { Some((sp.p, sp.ns, bs.pdf)) };
            if bs.is_transmission() {
                eta_scale *= bs.eta * bs.eta;
                // Into the object through its surface, or out of it.
                medium = if bs.wi.dot(sp.ng_outward) < 0.0 { shading.volume.map(|v| v.sigma_a) } else { None };
            }
            if depth >= ROULETTE_AFTER {
                let q = (beta * eta_scale).max_element().sqrt().min(1.0);
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

impl Radiance {
    /// Adds `c`, emission or environment found by the ray that left vertex `depth − 1`, to the
    /// direct (`depth = 1`) or indirect (`depth ≥ 2`) light of the first hit's `family`;
    /// the camera ray's own (`depth = 0`) is the caller's.
    fn add_found(&mut self, c: Vec3, depth: u32, family: &BsdfEval) {
        match depth {
            0 => {}
            1 => add_by_family(&mut self.direct, family, c),
            _ => add_by_family(&mut self.indirect, family, c),
        }
    }
}

/// `c` shared among the families by the per-channel fractions `family`.
#[inline]
fn add_by_family(out: &mut BsdfEval, family: &BsdfEval, c: Vec3) {
    out.diffuse += c * family.diffuse;
    out.glossy += c * family.glossy;
    out.transmission += c * family.transmission;
}

/// The fractions, per channel, of the BSDF sample `bs` from `wo` that each lobe family
/// scattered: all of it to the sampled lobe's family for a specular sample, else each family's
/// share of `f` at the sampled direction (Cycles' `bsdf_eval_pass_*_weight`).
fn families(bsdf: &crate::bsdf::Bsdf, wo: Vec3, bs: &crate::bsdf::BsdfSample) -> BsdfEval {
    let mut out = BsdfEval::default();
    if bs.flags.is_specular() {
        out.add(bs.class, Vec3::ONE);
        return out;
    }
    let e = bsdf.eval(wo, bs.wi);
    let sum = e.sum();
    let share = |v: Vec3| {
        let div = |a: f32, b: f32| if b != 0.0 { a / b } else { 0.0 };
        Vec3::new(div(v.x, sum.x), div(v.y, sum.y), div(v.z, sum.z))
    };
    if sum == Vec3::ZERO {
        out.add(bs.class, Vec3::ONE);
        return out;
    }
    BsdfEval { diffuse: share(e.diffuse), glossy: share(e.glossy), transmission: share(e.transmission) }
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
