//! Every light of a scene behind one sampling interface, as the path tracer samples them: one
//! light chosen per shading point, a direction towards it, and the density with which that
//! choice would have produced a direction a BSDF sample found (for multiple importance
//! sampling).
//!
//! ```text
//! choice        P(light) = 1/N   (N = point + directional + area lights + emissive meshes + environment)
//! point         wi = (x − p)/|x − p|,  radiance I/d²,  pdf 1 (delta)
//! directional   wi = −direction,       radiance E,     pdf 1 (delta)
//! quad, disk    uniform by area:          pdf_ω = d² / (|cosθ_l|·A)
//! sphere        uniform in its cone:      pdf_ω = 1 / (2π(1 − cosθ_max)),  sin θ_max = r/|c − p|
//!               (by area from inside a two-sided sphere, as for a quad)
//! emissive mesh uniform by area over its emitting triangles: pdf_ω = d² / (|cosθ_l|·A)
//! environment   its own importance sampling (crate::light::environment), distance ∞
//! ```
//!
//! The points are drawn by the lights themselves ([`crate::light::area`],
//! [`crate::light::mesh`], [`crate::light::environment`]); this file adds the densities and
//! the choice. Each sample carries the light's radiance `L` (W/(m²·sr)) and the integrator
//! divides by `P(light)·pdf_ω`. Point and directional lights are delta lights: NEE only.
//!
//! The set is built from plain lights (the scene imports the lights, so the lights cannot
//! import the scene): the integrator maps a hit on an emitter to the [`Emitter`] it is.

use glam::DVec3;

use crate::light::Light;
use crate::light::area::{AreaLight, Shape};
use crate::light::environment::Environment;
use crate::light::mesh::MeshEmitter;
use crate::math::{Vec2, Vec3};

/// One light sample seen from a shading point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightSample {
    /// Unit direction from the shading point towards the light.
    pub wi: Vec3,
    /// Distance to the sampled point (`f32::INFINITY` for a directional light or the
    /// environment).
    pub distance: f32,
    /// Radiance arriving along `−wi` (for a delta light `I/d²` or `E`).
    pub radiance: Vec3,
    /// Solid-angle density of `wi` for this light alone (1 for delta lights).
    pub pdf: f32,
    /// A point or directional light: no BSDF sample can find it.
    pub delta: bool,
}

/// An emitter a BSDF-sampled ray can hit: area light `k`, or emissive mesh `k` of the set.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Emitter {
    Area(u32),
    Mesh(u32),
}

/// What a light of the choice is.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Entry {
    Delta(u32),
    Area(u32),
    Mesh(u32),
    Environment,
}

/// The lights of a scene and how one is chosen (module docs).
#[derive(Clone, Debug)]
pub struct LightSet {
    delta: Vec<Light>,
    area: Vec<AreaLight>,
    meshes: Vec<MeshEmitter>,
    environment: Option<Environment>,
    entries: Vec<Entry>,
}

impl LightSet {
    /// The set of these lights; an environment of zero radiance everywhere is still seen by
    /// escaping rays but never sampled.
    pub fn new(
        delta: &[Light],
        area: &[AreaLight],
        meshes: Vec<MeshEmitter>,
        environment: Option<Environment>,
    ) -> LightSet {
        let mut entries: Vec<Entry> = (0..delta.len() as u32).map(Entry::Delta).collect();
        entries.extend((0..area.len() as u32).map(Entry::Area));
        entries.extend((0..meshes.len() as u32).map(Entry::Mesh));
        if environment.as_ref().is_some_and(|e| e.mean_radiance().max_element() > 0.0) {
            entries.push(Entry::Environment);
        }
        LightSet { delta: delta.to_vec(), area: area.to_vec(), meshes, environment, entries }
    }

    /// Number of lights sampled.
    pub fn len(&self) -> usize {
        self.entries.len()
    }

    /// Whether there is no light to sample.
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }

    /// The probability of choosing entry `k`.
    fn choice(&self, _k: usize) -> f32 {
        1.0 / self.entries.len() as f32
    }

    /// The entry of `e` in the choice.
    fn entry_of(&self, e: Entry) -> Option<usize> {
        self.entries.iter().position(|&x| x == e)
    }

    /// Chooses a light for the shading point `p` (normal `n`) with `u_select`, samples it
    /// with `u`: the sample and the probability of having chosen that light. `None` when the
    /// chosen light cannot reach `p` (behind a one-sided light, `p` on it).
    pub fn sample(&self, p: Vec3, _n: Vec3, u_select: f32, u: Vec2) -> Option<(LightSample, f32)> {
        let n = self.entries.len();
        if n == 0 {
            return None;
        }
        let k = ((u_select * n as f32) as usize).min(n - 1);
        let sample = match self.entries[k] {
            Entry::Delta(i) => {
                let inc = self.delta[i as usize].incidence(p)?;
                LightSample {
                    wi: inc.to_light,
                    distance: inc.distance,
                    radiance: inc.normal_irradiance,
                    pdf: 1.0,
                    delta: true,
                }
            }
            Entry::Area(i) => {
                let light = &self.area[i as usize];
                let inc = light.sample(p, u)?;
                let pdf = area_light_pdf(&light.shape, p, inc.to_light, inc.distance);
                LightSample { wi: inc.to_light, distance: inc.distance, radiance: light.radiance, pdf, delta: false }
            }
            Entry::Mesh(i) => {
                let e = &self.meshes[i as usize];
                let (y, normal, t) = e.sample_point(u);
                let to = y - p.as_dvec3();
                let d2 = to.length_squared();
                let d = d2.sqrt();
                let wi = to / d;
                let cos_l = normal.dot(wi).abs();
                if !(d2 > 0.0 && cos_l > 0.0) {
                    return None;
                }
                let pdf = (d2 / (cos_l * e.area())) as f32;
                LightSample { wi: wi.as_vec3(), distance: d as f32, radiance: e.radiance(t), pdf, delta: false }
            }
            Entry::Environment => {
                let (wi, radiance, pdf) = self.environment.as_ref()?.sample(u)?;
                LightSample { wi, distance: f32::INFINITY, radiance, pdf, delta: false }
            }
        };
        (sample.pdf > 0.0 && sample.pdf.is_finite()).then_some((sample, self.choice(k)))
    }

    /// The density (choice × solid angle) with which [`LightSet::sample`] from `p` (normal
    /// `n`) would have produced the direction `wi` that reached `emitter` at the point `y`
    /// (geometric normal `ng`, either side).
    pub fn pdf_hit(&self, p: Vec3, _n: Vec3, wi: Vec3, emitter: Emitter, y: Vec3, ng: Vec3) -> f32 {
        let d = (y - p).length();
        let (pdf, entry) = match emitter {
            Emitter::Area(k) => {
                let Some(light) = self.area.get(k as usize) else { return 0.0 };
                (area_light_pdf(&light.shape, p, wi, d), Entry::Area(k))
            }
            Emitter::Mesh(k) => {
                let Some(e) = self.meshes.get(k as usize) else { return 0.0 };
                let cos_l = ng.dot(wi).abs() as f64;
                let d2 = (d as f64) * (d as f64);
                let pdf = if cos_l > 0.0 { (d2 / (cos_l * e.area())) as f32 } else { 0.0 };
                (pdf, Entry::Mesh(k))
            }
        };
        match self.entry_of(entry) {
            Some(k) if pdf > 0.0 && pdf.is_finite() => pdf * self.choice(k),
            _ => 0.0,
        }
    }

    /// The density with which [`LightSet::sample`] from `p` (normal `n`) would have produced
    /// the direction `wi` that escaped into the environment.
    pub fn pdf_environment(&self, _p: Vec3, _n: Vec3, wi: Vec3) -> f32 {
        match (self.environment.as_ref(), self.entry_of(Entry::Environment)) {
            (Some(env), Some(k)) => env.pdf(wi) * self.choice(k),
            _ => 0.0,
        }
    }

    /// The radiance of the environment along the escaping direction `wi` (0 without one).
    pub fn environment(&self, wi: Vec3) -> Vec3 {
        self.environment.as_ref().map_or(Vec3::ZERO, |e| e.radiance(wi))
    }
}

/// The solid-angle density with which an area light of `shape` is sampled from `p` in the
/// direction `wi` (unit) that meets it at distance `d` (module docs).
pub fn area_light_pdf(shape: &Shape, p: Vec3, wi: Vec3, d: f32) -> f32 {
    let (w, d) = (wi.as_dvec3(), d as f64);
    let by_area = |normal: DVec3, area: f64| {
        let cos_l = normal.dot(w).abs();
        if cos_l > 0.0 { d * d / (cos_l * area) } else { 0.0 }
    };
    let pdf = match *shape {
        Shape::Quad { edge1, edge2, .. } => {
            let cross = edge1.as_dvec3().cross(edge2.as_dvec3());
            by_area(cross.normalize(), cross.length())
        }
        Shape::Disk { normal, radius, .. } => {
            by_area(normal.as_dvec3().normalize(), std::f64::consts::PI * (radius as f64).powi(2))
        }
        Shape::Sphere { center, radius } => {
            let (c, r) = (center.as_dvec3(), radius as f64);
            let dc2 = (c - p.as_dvec3()).length_squared();
            if dc2 <= r * r {
                let y = p.as_dvec3() + d * w;
                by_area((y - c) / r, 4.0 * std::f64::consts::PI * r * r)
            } else {
                let sin2_max = r * r / dc2;
                let cos_max = (1.0 - sin2_max).max(0.0).sqrt();
                1.0 / (2.0 * std::f64::consts::PI * (sin2_max / (1.0 + cos_max)))
            }
        }
    };
    pdf as f32
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A light's density integrates to 1 over the directions that reach it: the mean of
    /// 1/pdf over its own samples is the solid angle it subtends, which for a sphere is
    /// 2π(1 − cosθ_max) and for a small quad far away A·cosθ/d².
    #[test]
    fn densities_are_those_of_the_samples() {
        let area = [
            AreaLight {
                shape: Shape::Sphere { center: Vec3::new(0.0, 3.0, 0.0), radius: 1.0 },
                radiance: Vec3::ONE,
                two_sided: false,
                samples: 1,
            },
            AreaLight {
                shape: Shape::Quad { corner: Vec3::new(-1.0, 2.0, -1.0), edge1: Vec3::X * 2.0, edge2: Vec3::Z * 2.0 },
                radiance: Vec3::ONE,
                two_sided: true,
                samples: 1,
            },
        ];
        let lights = LightSet::new(&[], &area, Vec::new(), None);
        assert_eq!(lights.len(), 2);
        let n = 256;
        let mut inv = [0.0f64; 2];
        for i in 0..n {
            for j in 0..n {
                let u = Vec2::new((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32);
                for (k, sel) in [0.25f32, 0.75].into_iter().enumerate() {
                    let (s, choice) = lights.sample(Vec3::ZERO, Vec3::Y, sel, u).unwrap();
                    assert_eq!(choice, 0.5);
                    inv[k] += 1.0 / s.pdf as f64 / (n * n) as f64;
                }
            }
        }
        let sphere = 2.0 * std::f64::consts::PI * (1.0 - (1.0f64 - 1.0 / 9.0).sqrt());
        assert!((inv[0] - sphere).abs() < 1e-4 * sphere, "{} vs {sphere}", inv[0]);
        // The 2 × 2 quad at height 2 centred on the axis: 4·asin(a·b/√((a²+h²)(b²+h²))) with
        // half-sides a = b = 1, h = 2.
        let quad = 4.0 * (1.0f64 / 5.0).asin();
        assert!((inv[1] - quad).abs() < 1e-3 * quad, "{} vs {quad}", inv[1]);
    }
}
