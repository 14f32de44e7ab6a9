//! The denoising features of a camera ray, the `Denoising Albedo` and `Denoising Normal` passes
//! that OIDN takes as its auxiliary images ([`crate::output::denoise`]), as Cycles makes them:
//! the albedo and shading normal of the first surface that is not mostly specular, seen
//! through mirrors and glass ([`crate::bsdf::DenoisingSplit`] says what each surface does).
//!
//! ```text
//! albedo = Σ_branches T_b · a_b          normal = Σ_b avg(T_b) n_b / Σ_b avg(T_b)
//! ```
//!
//! where a branch `b` is a chain of specular-like bounces from the camera ray, `T_b` the
//! product of what each bounce carries (a mirror's `k_r`, a dielectric's Fresnel `F` or
//! `k_t (1 − F)`), and at its end, `a_b`, `n_b`:
//!
//! * a surface that records its features: its diffuse-like albedo and shading normal (a
//!   black surface: 0 and 0, as Cycles writes for a BSDF of no weight);
//! * emission found on the way (a light seen directly or in a mirror) adds its colour,
//!   `L_e / max(1, max_c L_e)`: Cycles adds the radiance itself, which OIDN's albedo range
//!   [0, 1] does not hold for a light of 18 W/(m²·sr), so strahl keeps its hue and scales it
//!   into the range;
//! * a ray that escapes: the background's radiance, scaled the same way, and normal 0.
//!
//! Cycles follows the one direction its path sampled at each specular bounce, so its
//! features are noisy behind glass (a mean over reflection and refraction samples) and its
//! "Accurate" mode denoises them before use. strahl follows both directions of a dielectric
//! and weights them by Fresnel, which is the mean Cycles' features converge to, with no
//! noise: what OIDN's `cleanAux` asks. The branching stops at [`MAX_RAYS`] traced rays per
//! camera ray, at the scene's `max_depth`, or where a branch carries < [`MIN_CARRIED`]; a
//! branch cut there records the surface it reached with its whole albedo. The result is
//! clamped to [0, 1].
//!
//! These rays take no sample from the pixel's sampler, so the beauty is the same with or
//! without the passes.

use crate::accel::{Accel, Hit, TraceError};
use crate::integrator::RayCounts;
use crate::math::{Ray, Vec3, offset_ray_origin};
use crate::scene::Scene;
use crate::shading::{ConstantBsdfs, Shading, shade_at};
use crate::surface::SurfacePoint;

/// The most rays traced for one camera ray's features, beyond the camera ray.
pub const MAX_RAYS: u32 = 16;
/// A branch carrying less than this (in every channel) is not followed.
pub const MIN_CARRIED: f32 = 1e-3;

/// One camera ray's denoising features (module docs).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Features {
    pub albedo: Vec3,
    pub normal: Vec3,
}

impl std::ops::AddAssign for Features {
    fn add_assign(&mut self, o: Features) {
        self.albedo += o.albedo;
        self.normal += o.normal;
    }
}

/// A radiance as an albedo: its hue, scaled into [0, 1] when brighter (module docs).
fn as_albedo(radiance: Vec3) -> Vec3 {
    radiance / radiance.max_element().max(1.0)
}

/// The radiance of a ray along `dir` that hits nothing, as the integrators see it.
fn background(scene: &Scene, dir: Vec3) -> Vec3 {
    match &scene.environment {
        _ if scene.output.transparent => Vec3::ZERO,
        Some(env) => env.radiance(dir.normalize()),
        None => scene.image.background,
    }
}

/// The features of the camera ray `ray`, whose closest hit is `hit` (module docs).
pub fn denoising_features<A: Accel>(
    scene: &Scene,
    constant: &ConstantBsdfs,
    accel: &A,
    ray: &Ray,
    hit: Option<&Hit>,
    counts: &mut RayCounts,
) -> Result<Features, TraceError> {
    let mut albedo = Vec3::ZERO;
    let (mut normal, mut normal_weight) = (Vec3::ZERO, 0.0f32);
    let mut traced = 0;
    // Depth first, reflection before refraction: the same order, so the same sums, every time.
    let mut stack = vec![(*ray, hit.copied(), Vec3::ONE, 0u32)];
    let mut shading = Shading::default();
    while let Some((ray, hit, carried, depth)) = stack.pop() {
        let weight = carried.element_sum() / 3.0;
        let Some(h) = hit else {
            albedo += carried * as_albedo(background(scene, ray.dir));
            normal_weight += weight;
            continue;
        };
        let sp = SurfacePoint::new(scene, &ray, &h);
        shade_at(scene, constant, &sp, -ray.dir, 0.0, &mut shading);
        albedo += carried * as_albedo(shading.emission);
        let split = shading.bsdf.denoising_split(-ray.dir);
        let branches = [split.reflect, split.transmit];
        let open = branches.iter().flatten().filter(|(_, c)| (carried * *c).max_element() >= MIN_CARRIED).count();
        if split.here || depth >= scene.image.max_depth || traced + open as u32 > MAX_RAYS {
            let whole = if split.here {
                split.diffuse
            } else {
                split.diffuse + branches.iter().flatten().map(|(_, c)| *c).sum::<Vec3>()
            };
            albedo += carried * whole;
            if split.has_lobes {
                normal += weight * sp.ns;
            }
            normal_weight += weight;
            continue;
        }
        for (dir, c) in branches.into_iter().flatten().rev() {
            let carried = carried * c;
            if carried.max_element() < MIN_CARRIED {
                continue;
            }
            let side = if dir.dot(sp.ng) > 0.0 { sp.ng } else { -sp.ng };
            let next = Ray::new(offset_ray_origin(sp.p, side), dir);
            traced += 1;
            if (dir.dot(sp.ng) > 0.0) == ((-ray.dir).dot(sp.ng) > 0.0) {
                counts.reflected += 1;
            } else {
                counts.refracted += 1;
            }
            stack.push((next, accel.intersect(&next)?, carried, depth + 1));
        }
    }
    let normal = if normal_weight > 0.0 { normal / normal_weight } else { Vec3::ZERO };
    Ok(Features { albedo: albedo.clamp(Vec3::ZERO, Vec3::ONE), normal })
}
