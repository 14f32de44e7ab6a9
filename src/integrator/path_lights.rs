//! The lights as the path tracer samples them: one light chosen per vertex, a direction towards
//! it, and the density with which that choice would have produced a direction a BSDF sample
//! found (for multiple importance sampling).
//!
//! ```text
//! choice        P(light) = 1/N            (N = point + directional + area lights + emissive meshes)
//! point         wi = (x − p)/|x − p|,  radiance I/d²,  pdf 1 (delta)
//! directional   wi = −direction,       radiance E,     pdf 1 (delta)
//! quad, disk    uniform by area:          pdf_ω = d² / (|cosθ_l|·A)
//! sphere        uniform in its cone:      pdf_ω = 1 / (2π(1 − cosθ_max)),  sin θ_max = r/|c − p|
//!               (by area from inside a two-sided sphere, as for a quad)
//! emissive mesh uniform by area over its emitting triangles: pdf_ω = d² / (|cosθ_l|·A)
//! ```
//!
//! The points are drawn by the lights themselves ([`crate::light::area`],
//! [`crate::light::mesh`]); this file only adds the densities. Each sample carries the light's
//! radiance `L` (W/(m²·sr)) and `pdf = P(light)·pdf_ω` is applied by the integrator. A light's
//! `light_samples` and the scene's `mesh_light_samples` are the Whitted integrator's: the path
//! tracer takes one light sample per vertex. Point and directional lights are delta lights:
//! NEE only.
//!
//! [`PathLights::pdf_hit`] maps a hit on an emitter (an area light's geometry, or a triangle of
//! an emissive mesh) back to its light. Emitters that are not lights (emissive instances and
//! spheres, or meshes with `mesh_lights = false`) have density 0 there: BSDF sampling alone
//! finds them, with full weight.
//!
//! This stands in for the `LightSet` (light selection by power, a light tree, the environment)
//! with the same shape of calls.

use glam::DVec3;

use crate::accel::Hit;
use crate::light::area::Shape;
use crate::light::mesh::MeshEmitter;
use crate::math::{Vec2, Vec3};
use crate::scene::{GeomKind, Scene};
use crate::surface::SurfacePoint;

use super::lights::mesh_emitters;

/// One light sample seen from a shading point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightSample {
    /// Unit direction from the shading point towards the light.
    pub wi: Vec3,
    /// Distance to the sampled point (`f32::INFINITY` for a directional light).
    pub distance: f32,
    /// Radiance arriving along `−wi` (for a delta light `I/d²` or `E`).
    pub radiance: Vec3,
    /// Solid-angle density of `wi` for this light alone (1 for delta lights).
    pub pdf: f32,
    /// A point or directional light: no BSDF sample can find it.
    pub delta: bool,
}

/// The scene's lights in the order they are chosen: point and directional, area, emissive
/// meshes.
pub struct PathLights<'a> {
    scene: &'a Scene,
    emitters: Vec<MeshEmitter>,
    /// Per material: the area light whose geometry it is.
    area_of_material: Vec<Option<u32>>,
    /// Per mesh: its emitter.
    emitter_of_mesh: Vec<Option<u32>>,
}

impl<'a> PathLights<'a> {
    /// The lights of `scene`.
    pub fn new(scene: &'a Scene) -> Self {
        let emitters = mesh_emitters(scene);
        // The area lights' materials were added in the lights' order
        // ([`crate::scene::emitters::add_emitters`]).
        let mut next = 0u32;
        let area_of_material = scene
            .materials
            .iter()
            .map(|m| {
                (m.area_light && (next as usize) < scene.area_lights.len()).then(|| {
                    next += 1;
                    next - 1
                })
            })
            .collect();
        let mut emitter_of_mesh = vec![None; scene.meshes.len()];
        for (k, e) in emitters.iter().enumerate() {
            emitter_of_mesh[e.mesh as usize] = Some(k as u32);
        }
        PathLights { scene, emitters, area_of_material, emitter_of_mesh }
    }

    /// Number of lights.
    pub fn len(&self) -> usize {
        self.scene.lights.len() + self.scene.area_lights.len() + self.emitters.len()
    }

    /// Whether the scene has no light to sample.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The probability of choosing any one light.
    fn choice(&self) -> f32 {
        1.0 / self.len() as f32
    }

    /// Chooses a light with `u_select` and samples it from `p` with `u`: the sample and the
    /// probability of having chosen that light. `None` when the chosen light cannot reach `p`
    /// (behind a one-sided light, `p` on it).
    pub fn sample(&self, p: Vec3, u_select: f32, u: Vec2) -> Option<(LightSample, f32)> {
        let n = self.len();
        if n == 0 {
            return None;
        }
        let k = ((u_select * n as f32) as usize).min(n - 1);
        let (n_delta, n_area) = (self.scene.lights.len(), self.scene.area_lights.len());
        let sample = if k < n_delta {
            let inc = self.scene.lights[k].incidence(p)?;
            LightSample {
                wi: inc.to_light,
                distance: inc.distance,
                radiance: inc.normal_irradiance,
                pdf: 1.0,
                delta: true,
            }
        } else if k < n_delta + n_area {
            let light = &self.scene.area_lights[k - n_delta];
            let inc = light.sample(p, u)?;
            let pdf = area_light_pdf(&light.shape, p, inc.to_light, inc.distance);
            LightSample { wi: inc.to_light, distance: inc.distance, radiance: light.radiance, pdf, delta: false }
        } else {
            let e = &self.emitters[k - n_delta - n_area];
            let (y, normal, i) = e.sample_point(u);
            let to = y - p.as_dvec3();
            let d2 = to.length_squared();
            let d = d2.sqrt();
            let wi = to / d;
            let cos_l = normal.dot(wi).abs();
            if !(d2 > 0.0 && cos_l > 0.0) {
                return None;
            }
            let pdf = (d2 / (cos_l * e.area())) as f32;
            LightSample { wi: wi.as_vec3(), distance: d as f32, radiance: e.radiance(i), pdf, delta: false }
        };
        (sample.pdf > 0.0 && sample.pdf.is_finite()).then_some((sample, self.choice()))
    }

    /// The density (choice × solid angle) with which [`PathLights::sample`] from `p` would
    /// have produced the direction `wi` that reached the emitter hit `hit`, shaded as
    /// `sp_light`; 0 when what was hit is not a light.
    pub fn pdf_hit(&self, p: Vec3, wi: Vec3, hit: &Hit, sp_light: &SurfacePoint) -> f32 {
        let d = (sp_light.p - p).length();
        let pdf = if let Some(Some(k)) = self.area_of_material.get(sp_light.material as usize) {
            area_light_pdf(&self.scene.area_lights[*k as usize].shape, p, wi, d)
        } else if let GeomKind::Mesh(m) = self.scene.geom_kind(hit.geom_id) {
            match self.emitter_of_mesh.get(m as usize) {
                Some(Some(e)) => {
                    let cos_l = sp_light.ng_outward.dot(wi).abs() as f64;
                    let d2 = (d as f64) * (d as f64);
                    if cos_l > 0.0 { (d2 / (cos_l * self.emitters[*e as usize].area())) as f32 } else { 0.0 }
                }
                _ => 0.0,
            }
        } else {
            0.0
        };
        if pdf > 0.0 && pdf.is_finite() { pdf * self.choice() } else { 0.0 }
    }
}

/// The solid-angle density with which an area light of `shape` is sampled from `p` in the
/// direction `wi` (unit) that meets it at distance `d` (module docs).
fn area_light_pdf(shape: &Shape, p: Vec3, wi: Vec3, d: f32) -> f32 {
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
    use crate::light::area::AreaLight;

    /// A light's density integrates to 1 over the directions that reach it: the mean of
    /// 1/pdf over its own samples is the solid angle it subtends, which for a sphere is
    /// 2π(1 − cosθ_max) and for a small quad far away A·cosθ/d².
    #[test]
    fn densities_are_those_of_the_samples() {
        let mut scene = Scene::default();
        scene.area_lights.push(AreaLight {
            shape: Shape::Sphere { center: Vec3::new(0.0, 3.0, 0.0), radius: 1.0 },
            radiance: Vec3::ONE,
            two_sided: false,
            samples: 1,
        });
        scene.area_lights.push(AreaLight {
            shape: Shape::Quad { corner: Vec3::new(-1.0, 2.0, -1.0), edge1: Vec3::X * 2.0, edge2: Vec3::Z * 2.0 },
            radiance: Vec3::ONE,
            two_sided: true,
            samples: 1,
        });
        let lights = PathLights::new(&scene);
        assert_eq!(lights.len(), 2);
        let n = 256;
        let mut inv = [0.0f64; 2];
        for i in 0..n {
            for j in 0..n {
                let u = Vec2::new((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32);
                for (k, sel) in [0.25f32, 0.75].into_iter().enumerate() {
                    let (s, choice) = lights.sample(Vec3::ZERO, sel, u).unwrap();
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
