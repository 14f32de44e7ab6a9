//! A pixel's samples, summed and written to the film; shared by every integrator.
//!
//! Each camera ray brings a [`CameraSample`]: its radiance, the same radiance split into the
//! terms of the light-path passes ([`Radiance`], [`crate::output::passes`]) and what it found
//! first ([`FirstHit`], for the AOVs). A [`PixelAccumulator`] adds a pixel's samples in sample
//! order (so deterministically) and writes the box filter of them to the film: the mean over
//! the pixel's samples (all `spp`, or fewer where adaptive sampling stopped it,
//! [`super::adaptive`]) for RGB, alpha, the light-path passes, normal and the colours (a
//! sample that hits nothing counting 0), the nearest hit for depth, distance, position and the
//! index passes, the
//! Cryptomatte ranks of the objects and materials hit, and the fraction of samples whose camera
//! ray two backends saw differently (what each channel holds:
//! [`crate::output::film`]).

use super::adaptive::{Adaptive, PixelNoise};
use super::features::Features;
use crate::accel::Hit;
use crate::bsdf::{BsdfEval, PassClass};
use crate::camera::Camera;
use crate::math::Vec3;
use crate::output::cryptomatte;
use crate::output::film::Film;
use crate::output::ids::ObjectIds;
use crate::output::passes::{FAMILIES, LIGHT_PASSES, Pass};
use crate::scene::Scene;
use crate::surface::SurfacePoint;

/// What one camera ray brings to its pixel: its radiance, split into the passes' terms, and
/// its first hit (`None` when it escaped).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CameraSample {
    pub radiance: Vec3,
    pub split: Radiance,
    pub first: Option<FirstHit>,
}

/// The radiance of a camera ray split by what its first hit did with it (the light-path passes,
/// [`crate::output::passes`]); their sum is the beauty to float rounding. Each is in W/(m²·sr)
/// and still carries the first hit's colour (the film divides it out).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Radiance {
    /// Emission `L_e` of the first hit.
    pub emission: Vec3,
    /// Light from lights and emitters scattered once, at the first hit, by lobe family.
    pub direct: BsdfEval,
    /// Light scattered more than once, by the family of the first hit's scattering.
    pub indirect: BsdfEval,
    /// The environment (background) radiance of a camera ray that hits nothing.
    pub background: Vec3,
}

impl Radiance {
    /// The terms in the order of [`LIGHT_PASSES`].
    pub fn terms(&self) -> [Vec3; 8] {
        let (d, i) = (&self.direct, &self.indirect);
        [self.emission, d.diffuse, i.diffuse, d.glossy, i.glossy, d.transmission, i.transmission, self.background]
    }

    /// The sum of the terms.
    pub fn sum(&self) -> Vec3 {
        self.terms().into_iter().sum()
    }
}

/// What a primary ray found at its first hit, for the AOVs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FirstHit {
    /// Distance from the eye (the primary ray's direction has unit length).
    pub t: f32,
    /// World-space unit shading normal, facing the eye.
    pub normal: Vec3,
    /// The colours of the lobe families (`colors.diffuse` is the albedo pass).
    pub colors: BsdfEval,
    /// World-space position.
    pub p: Vec3,
    /// The scene's material index.
    pub material: u32,
    /// The hit itself (which object: [`ObjectIds::object_of`]).
    pub hit: Hit,
}

impl FirstHit {
    /// What the AOVs record of the camera ray's `hit`, shaded as `sp`, whose lobe families
    /// have the colours `colors`.
    pub fn new(sp: &SurfacePoint, hit: &Hit, colors: BsdfEval) -> Self {
        FirstHit { t: sp.t, normal: sp.ns, colors, p: sp.p, material: sp.material, hit: *hit }
    }
}

/// The running sums of one pixel's samples (added in sample order, so deterministically).
#[derive(Clone, Debug, Default)]
pub struct PixelAccumulator {
    radiance: Vec3,
    split: [Vec3; 8],
    hits: u32,
    nearest: Option<FirstHit>,
    normal: Vec3,
    colors: BsdfEval,
    /// (object, samples) and (material, samples), only when a Cryptomatte pass is on.
    objects: Vec<(u32, u32)>,
    materials: Vec<(u32, u32)>,
    /// Samples whose camera ray a second backend saw differently (the `disagreement` pass).
    disagreements: u32,
    /// The sample count and the noise estimates of adaptive sampling and the variance pass.
    noise: PixelNoise,
    /// The sum of the samples' denoising features, when their passes are on.
    features: Features,
}

/// The lobe family whose colour divides a direct or indirect light pass.
fn family(pass: Pass) -> Option<PassClass> {
    let k = FAMILIES.iter().position(|&(d, i, _)| pass == d || pass == i)?;
    Some([PassClass::Diffuse, PassClass::Glossy, PassClass::Transmission][k])
}

/// Adds one sample of `key` to a list of (key, count).
fn count(list: &mut Vec<(u32, u32)>, key: u32) {
    match list.iter_mut().find(|(k, _)| *k == key) {
        Some((_, n)) => *n += 1,
        None => list.push((key, 1)),
    }
}

impl PixelAccumulator {
    /// Adds one sample: its beauty, its split, its first hit and, when Cryptomatte is on
    /// (`object` is `Some`), the object of that hit.
    pub fn add(&mut self, radiance: Vec3, split: &Radiance, first: Option<FirstHit>, object: Option<u32>) {
        self.radiance += radiance;
        self.noise.add(radiance);
        for (sum, term) in self.split.iter_mut().zip(split.terms()) {
            *sum += term;
        }
        if let Some(f) = first {
            self.hits += 1;
            // The nearest sample's hit; the first in sample order among equals.
            if self.nearest.is_none_or(|n| f.t < n.t) {
                self.nearest = Some(f);
            }
            self.normal += f.normal;
            self.colors.diffuse += f.colors.diffuse;
            self.colors.glossy += f.colors.glossy;
            self.colors.transmission += f.colors.transmission;
            if let Some(object) = object {
                count(&mut self.objects, object);
                count(&mut self.materials, f.material);
            }
        }
    }

    /// The colour pass of family `class`: the mean over all the pixel's samples, a miss
    /// counting 0 (coverage-weighted, as Cycles writes DiffCol).
    fn colour(&self, class: PassClass) -> Vec3 {
        self.colors.get(class) / self.noise.samples() as f32
    }

    /// A light pass: the mean of its term over the pixel's `spp` samples, divided by its family's
    /// colour pass for the direct and indirect passes (0 in a channel where that is 0).
    fn light(&self, pass: Pass, spp: u32) -> Vec3 {
        let k = LIGHT_PASSES.iter().position(|&p| p == pass).unwrap_or(0);
        let mean = self.split[k] / spp as f32;
        let Some(class) = family(pass) else { return mean };
        let colour = self.colour(class);
        let div = |l: f32, c: f32| if c != 0.0 { l / c } else { 0.0 };
        Vec3::new(div(mean.x, colour.x), div(mean.y, colour.y), div(mean.z, colour.z))
    }

    /// Adds one sample's denoising features ([`super::features`]); their passes are the mean
    /// over all the pixel's samples, like the beauty (a miss adds 0), so they are filtered as
    /// the beauty is, which OIDN asks.
    pub fn add_features(&mut self, features: Features) {
        self.features += features;
    }

    /// Counts one sample whose camera ray's first hit a second backend finds differently.
    pub fn add_disagreement(&mut self) {
        self.disagreements += 1;
    }

    /// Whether the pixel's samples so far meet the adaptive sampling `rule`.
    pub fn converged(&self, rule: &Adaptive) -> bool {
        rule.converged(self.radiance, &self.noise)
    }

    /// Box filter: the mean over the pixel's samples for RGB, alpha, normal and albedo; the
    /// nearest hit for depth, its view-axis depth through `camera` (see [`crate::output::film`]).
    pub fn write(&self, film: &mut Film, x: u32, y: u32, scene: &Scene, camera: &Camera, ids: &ObjectIds) {
        // `image.spp`, or fewer where adaptive sampling stopped the pixel.
        let spp = self.noise.samples();
        let i = film.index(x, y);
        let rgb = self.radiance / spp as f32;
        let alpha = if scene.output.transparent { self.hits as f32 / spp as f32 } else { 1.0 };
        film.rgba[i] = [rgb.x, rgb.y, rgb.z, alpha];
        if let Some(first) = self.nearest {
            if let Some(depth) = film.depth.get_mut(i) {
                *depth = camera.depth_of(first.p);
            }
            if let Some(normal) = film.normal.get_mut(i) {
                *normal = self.normal / spp as f32;
            }
            if let Some(albedo) = film.albedo.get_mut(i) {
                *albedo = self.colour(PassClass::Diffuse);
            }
        }
        for aov in &mut film.aovs {
            let out = &mut aov.data[i * aov.floats_per_pixel..(i + 1) * aov.floats_per_pixel];
            match aov.pass {
                pass if pass.is_light() => out.copy_from_slice(&self.light(pass, spp).to_array()),
                Pass::GlossyColor => out.copy_from_slice(&self.colour(PassClass::Glossy).to_array()),
                Pass::TransmissionColor => out.copy_from_slice(&self.colour(PassClass::Transmission).to_array()),
                Pass::Distance => out[0] = self.nearest.map_or(f32::INFINITY, |f| f.t),
                Pass::Position => {
                    out.copy_from_slice(&self.nearest.map_or(Vec3::ZERO, |f| f.p).to_array());
                }
                Pass::ObjectIndex => {
                    out[0] = self.nearest.map_or(0.0, |f| (ids.object_of(scene, &f.hit) + 1) as f32);
                }
                Pass::MaterialIndex => out[0] = self.nearest.map_or(0.0, |f| (f.material + 1) as f32),
                Pass::Disagreement => out[0] = self.disagreements as f32 / spp as f32,
                Pass::SampleCount => out[0] = spp as f32 / scene.image.spp as f32,
                Pass::Variance => out.copy_from_slice(&self.noise.variance_of_mean().to_array()),
                Pass::DenoisingAlbedo => out.copy_from_slice(&(self.features.albedo / spp as f32).to_array()),
                Pass::DenoisingNormal => out.copy_from_slice(&(self.features.normal / spp as f32).to_array()),
                Pass::CryptoObject => {
                    let mut counts: Vec<(u32, u32)> =
                        self.objects.iter().map(|&(o, n)| (ids.object_id_bits[o as usize], n)).collect();
                    cryptomatte::write_ranks(&mut counts, spp, out);
                }
                Pass::CryptoMaterial => {
                    let mut counts: Vec<(u32, u32)> =
                        self.materials.iter().map(|&(m, n)| (ids.material_id_bits[m as usize], n)).collect();
                    cryptomatte::write_ranks(&mut counts, spp, out);
                }
                _ => {}
            }
        }
    }
}
