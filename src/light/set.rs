//! Every light of a scene behind one sampling interface, as the path tracer samples them: one
//! light chosen per shading point (by the light tree, or in proportion to its power), a direction towards it, and the
//! density with which that choice would have produced a direction a BSDF sample found (for
//! multiple importance sampling).
//!
//! ```text
//! choice, tree  P(light | p, n) from the light tree (crate::light::tree), over the powers
//!               below and each light's bounds; directional lights and the environment are
//!               its infinite lights
//! choice, power P(light) = Φ_light / Σ Φ     (a CDF over the lights' powers, luminance of RGB)
//!   point         Φ = 4π·I
//!   directional   Φ = π·r²·E                 (r: the radius of the scene's bounding sphere)
//!   quad, disk,   Φ = π·L·A  (2π·L·A two-sided)
//!   sphere
//!   mesh triangle Φ = 2π·L·A                 (each emissive triangle a light; two-sided)
//!   environment   Φ = π·L̄·π·r²              (L̄ its mean radiance: the flux through the
//!                                             scene's bounding disc from one side)
//! point         wi = (x − p)/|x − p|,  radiance I/d²,  pdf 1 (delta)
//! directional   wi = −direction,       radiance E,     pdf 1 (delta)
//! quad          near it (as a triangle below), uniform by solid angle as its two triangles:
//!                                         pdf_ω = 1/(Ω₁ + Ω₂)
//! quad, disk    else uniform by area:     pdf_ω = d² / (|cosθ_l|·A)
//! sphere        uniform in its cone:      pdf_ω = 1 / (2π(1 − cosθ_max)),  sin θ_max = r/|c − p|
//!               (by area from inside a two-sided sphere, as for a quad)
//! triangle      near it (nearer its centroid than its longest edge, Ω ∈ [3·10⁻⁴, 6.22] sr),
//!               uniform by solid angle:   pdf_ω = 1/Ω   (Arvo; crate::sampling::spherical_triangle)
//!               else uniform by area:     pdf_ω = d² / (|cosθ_l|·A_triangle)
//! environment   its own importance sampling (crate::light::environment), distance ∞
//! ```
//!
//! The points are drawn by the lights themselves ([`crate::light::area`],
//! [`crate::light::mesh`], [`crate::light::environment`]), or by solid angle near a quad or a
//! triangle ([`crate::sampling::spherical_triangle`], which has the rule of "near";
//! [`MeshEmitter::seen_from`] and [`Parallelogram::seen_from`] apply it); this file adds the
//! densities and the choice ([`crate::sampling::distribution::Distribution1D`]). Each sample carries the
//! light's radiance `L` (W/(m²·sr)) and the integrator divides by `P(light)·pdf_ω`; `pdf_hit`
//! and `pdf_environment` return the same product for a direction a BSDF sample found, from the
//! same numbers. A light of power 0 is never chosen (and its density is 0). Point and
//! directional lights are delta lights: NEE only.
//!
//! **Which choice.** [`LightSampler::Tree`] is the default, as in pbrt-v4 (`BVHLightSampler`)
//! and Cycles (its light tree): with thousands of emissive triangles, choosing by power alone
//! sends most shadow rays to lights far away or facing elsewhere. [`LightSampler::Power`] (`[render]
//! light_sampler = "power"`, `--light-sampler power`) keeps the choice by power alone, the
//! reference the tree is measured against. With one light the two are the same (that light,
//! probability exactly 1, the same random numbers); the tree gives the environment and
//! directional lights a fixed share (pbrt-v4's rule) where power weighs them by their power.
//!
//! The set is built from plain lights (the scene imports the lights, so the lights cannot
//! import the scene): the integrator maps a hit on an emitter to the [`Emitter`] it is.

use glam::DVec3;

use crate::light::Light;
use crate::light::area::{AreaLight, Shape};
use crate::light::environment::{Environment, luminance};
use crate::light::mesh::MeshEmitter;
use crate::light::tree::{LightBounds, LightExtent, LightTree};
use crate::math::Aabb;
use crate::math::{Vec2, Vec3};
use crate::sampling::distribution::Distribution1D;
use crate::sampling::spherical_triangle::{self, Parallelogram};

/// How [`LightSet::sample`] chooses a light (module docs).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum LightSampler {
    /// By the light tree: importance at the shading point (the default).
    #[default]
    Tree,
    /// In proportion to power, wherever the shading point is.
    Power,
}

impl LightSampler {
    /// Its name in the scene file and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            LightSampler::Tree => "tree",
            LightSampler::Power => "power",
        }
    }

    /// The sampler called `name`, or the one-line reason it is not one.
    pub fn parse(name: &str) -> Result<LightSampler, String> {
        match name {
            "tree" => Ok(LightSampler::Tree),
            "power" => Ok(LightSampler::Power),
            _ => Err(format!("light_sampler {name:?} is not one of \"tree\", \"power\"")),
        }
    }
}

/// The choice among the entries.
#[derive(Clone, Debug)]
enum Selection {
    /// No entries.
    Nothing,
    Power(Distribution1D),
    Tree(LightTree),
}

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
    /// For a point on an emissive mesh: where, so that a radiance that varies over the
    /// surface (an emissive texture, one-sided emission) can be looked up there
    /// ([`crate::integrator::path_lights::PathLights::sample`]); `radiance` is then the
    /// triangle's mean.
    pub on_mesh: Option<MeshPoint>,
}

/// A point of triangle `prim` of the scene's mesh `mesh`, at the barycentric coordinates
/// `(u, v)` as a hit gives them: `(1 − u − v)·p0 + u·p1 + v·p2`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MeshPoint {
    pub mesh: u32,
    pub prim: u32,
    pub u: f32,
    pub v: f32,
}

/// An emitter a BSDF-sampled ray can hit: area light `k`, or triangle `prim` (its index in
/// the scene's mesh) of emissive mesh `mesh` of the set.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Emitter {
    Area(u32),
    Triangle { mesh: u32, prim: u32 },
}

/// What a light of the choice is.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Entry {
    Delta(u32),
    Area(u32),
    /// Kept triangle `tri` of emissive mesh `mesh`.
    Triangle {
        mesh: u32,
        tri: u32,
    },
    Environment,
}

/// The lights of a scene and how one is chosen (module docs).
#[derive(Clone, Debug)]
pub struct LightSet {
    delta: Vec<Light>,
    area: Vec<AreaLight>,
    /// Per area light: for a quad, its parallelogram in f64 (to sample it by solid angle near
    /// it).
    quads: Vec<Option<Parallelogram>>,
    meshes: Vec<MeshEmitter>,
    environment: Option<Environment>,
    entries: Vec<Entry>,
    /// Over the entries.
    selection: Selection,
    /// The entry of area light 0.
    area_base: usize,
    /// Per emissive mesh: the entry of its first triangle.
    mesh_base: Vec<usize>,
    environment_entry: Option<usize>,
}

impl LightSet {
    /// The set of these lights, in a scene whose bounding sphere has radius `scene_radius`
    /// (for the power of directional lights and the environment), choosing by `sampler`.
    pub fn new(
        delta: &[Light],
        area: &[AreaLight],
        meshes: Vec<MeshEmitter>,
        environment: Option<Environment>,
        scene_radius: f32,
        sampler: LightSampler,
    ) -> LightSet {
        use std::f64::consts::PI;
        let r = if scene_radius.is_finite() && scene_radius > 0.0 { scene_radius as f64 } else { 1.0 };
        let lum = |c: Vec3| luminance(c).max(0.0) as f64;
        let mut entries = Vec::new();
        let mut power = Vec::new();
        for (i, l) in delta.iter().enumerate() {
            entries.push(Entry::Delta(i as u32));
            power.push(match *l {
                Light::Point { intensity, .. } => 4.0 * PI * lum(intensity),
                Light::Directional { irradiance, .. } => PI * r * r * lum(irradiance),
            });
        }
        let area_base = entries.len();
        for (i, l) in area.iter().enumerate() {
            entries.push(Entry::Area(i as u32));
            power.push(PI * lum(l.radiance) * l.area() * if l.two_sided { 2.0 } else { 1.0 });
        }
        let mut mesh_base = Vec::with_capacity(meshes.len());
        for (m, e) in meshes.iter().enumerate() {
            mesh_base.push(entries.len());
            for t in 0..e.triangle_count() {
                entries.push(Entry::Triangle { mesh: m as u32, tri: t as u32 });
                power.push(2.0 * PI * lum(e.radiance(t)) * e.triangle_area(t));
            }
        }
        let environment_entry = environment.as_ref().map(|env| {
            entries.push(Entry::Environment);
            power.push(PI * lum(env.mean_radiance()) * PI * r * r);
            entries.len() - 1
        });
        let power: Vec<f32> = power.into_iter().map(|p| p as f32).collect();
        let selection = match sampler {
            _ if entries.is_empty() => Selection::Nothing,
            LightSampler::Power => Selection::Power(Distribution1D::new(&power)),
            LightSampler::Tree => {
                let extents: Vec<LightExtent> =
                    entries.iter().zip(&power).map(|(e, &phi)| extent(e, phi, delta, area, &meshes)).collect();
                Selection::Tree(LightTree::new(&extents))
            }
        };
        let quads = area
            .iter()
            .map(|l| match l.shape {
                Shape::Quad { corner, edge1, edge2 } => {
                    Some(Parallelogram::new(corner.as_dvec3(), edge1.as_dvec3(), edge2.as_dvec3()))
                }
                _ => None,
            })
            .collect();
        LightSet {
            delta: delta.to_vec(),
            area: area.to_vec(),
            quads,
            meshes,
            environment,
            entries,
            selection,
            area_base,
            mesh_base,
            environment_entry,
        }
    }

    /// Number of lights (each emissive triangle one, the environment one).
    pub fn len(&self) -> usize {
        self.entries.len()
    }

    /// Whether there is no light to sample.
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }

    /// The probability of choosing entry `k` at `p` with shading normal `n`.
    fn choice(&self, k: usize, p: Vec3, n: Vec3) -> f32 {
        match &self.selection {
            Selection::Nothing => 0.0,
            Selection::Power(d) => d.probability(k),
            Selection::Tree(t) => t.pmf(p, n, k),
        }
    }

    /// The light tree, when the set chooses by one.
    pub fn tree(&self) -> Option<&LightTree> {
        match &self.selection {
            Selection::Tree(t) => Some(t),
            _ => None,
        }
    }

    /// Chooses a light for the shading point `p` (normal `n`) with `u.x` and samples it with
    /// what is left of `u.x` and `u.y`: the sample and the probability of having chosen that
    /// light. `None` when the chosen light cannot reach `p` (behind a one-sided light, `p` on
    /// it).
    ///
    /// One 2-D point does both, as in Cycles (`light_distribution_sample`: "rescale to reuse
    /// random number"): the points of a pixel's samples that choose a light are those in its
    /// strip of `u.x`, and stretched back to `[0, 1)²` they are still stratified, so each
    /// light's samples are too. Chosen with a separate random number, a light gets a random
    /// subset of the pixel's points, as good as independent ones (on the Cornell room, whose
    /// light is two triangles, 4 × the variance of the direct diffuse light). The price: what
    /// is left of `u.x` keeps only the bits the choice did not use, about `24 − log₂(1/P)` of
    /// the f32's 24 for a light chosen with probability `P` (as in Cycles 3.4), so a light
    /// chosen with `P = 2⁻¹²` gets its points on 4,096 lines across it.
    pub fn sample(&self, p: Vec3, n: Vec3, u: Vec2) -> Option<(LightSample, f32)> {
        let (k, choice, rest) = self.choose(p, n, u.x)?;
        if !(choice > 0.0) {
            return None;
        }
        Some((self.sample_entry(k, p, Vec2::new(rest, u.y))?, choice))
    }

    /// The light `u ∈ [0, 1)` chooses at `p` (normal `n`), the probability of that choice and
    /// what is left of `u` (uniform in `[0, 1)` over the light's share).
    fn choose(&self, p: Vec3, n: Vec3, u: f32) -> Option<(usize, f32, f32)> {
        match &self.selection {
            Selection::Nothing => None,
            Selection::Power(d) => Some(d.sample_discrete(u)),
            Selection::Tree(t) => t.sample(p, n, u),
        }
    }

    /// A sample of light `k` from `p` for `u` (its density for this light alone).
    fn sample_entry(&self, k: usize, p: Vec3, u: Vec2) -> Option<LightSample> {
        let sample = match self.entries[k] {
            Entry::Delta(i) => {
                let inc = self.delta[i as usize].incidence(p)?;
                LightSample {
                    wi: inc.to_light,
                    distance: inc.distance,
                    radiance: inc.normal_irradiance,
                    pdf: 1.0,
                    delta: true,
                    on_mesh: None,
                }
            }
            Entry::Area(i) => {
                let light = &self.area[i as usize];
                if let Some(quad) = &self.quads[i as usize] {
                    // Behind a one-sided quad, or in its plane: no light, however it is sampled.
                    let (pd, normal) = (p.as_dvec3(), quad.normal());
                    if !light.two_sided && normal.dot(pd - quad.corner()) <= 0.0 {
                        return None;
                    }
                    if let Some(q) = quad.seen_from(pd) {
                        let (wi, d) = q.sample(pd, [u.x as f64, u.y as f64])?;
                        if !(d > 0.0 && (light.two_sided || normal.dot(wi) < 0.0)) {
                            return None;
                        }
                        return Some(LightSample {
                            wi: wi.as_vec3(),
                            distance: d as f32,
                            radiance: light.radiance,
                            pdf: (1.0 / q.solid_angle) as f32,
                            delta: false,
                            on_mesh: None,
                        })
                        .filter(|s| s.pdf > 0.0 && s.pdf.is_finite());
                    }
                }
                let inc = light.sample(p, u)?;
                let pdf = pdf_by_area(&light.shape, p, inc.to_light, inc.distance);
                LightSample {
                    wi: inc.to_light,
                    distance: inc.distance,
                    radiance: light.radiance,
                    pdf,
                    delta: false,
                    on_mesh: None,
                }
            }
            Entry::Triangle { mesh, tri } => {
                let e = &self.meshes[mesh as usize];
                let i = tri as usize;
                let corners = e.triangle(i);
                let normal = e.normal(i);
                let p = p.as_dvec3();
                let (wi, d, bu, bv, pdf) = if let Some(st) = e.seen_from(i, p) {
                    let wi = st.sample([u.x as f64, u.y as f64])?;
                    let (d, bu, bv) = spherical_triangle::hit_plane(p, wi, &corners)?;
                    (wi, d, bu as f32, bv as f32, 1.0 / st.solid_angle)
                } else {
                    let y = e.sample_triangle(i, u);
                    let (bu, bv) = MeshEmitter::barycentric_of_sample(u);
                    let to = y - p;
                    let d2 = to.length_squared();
                    let d = d2.sqrt();
                    let wi = to / d;
                    let cos_l = normal.dot(wi).abs();
                    if !(d2 > 0.0 && cos_l > 0.0) {
                        return None;
                    }
                    (wi, d, bu, bv, density_by_area(d2, cos_l, e.triangle_area(i)))
                };
                if !(d > 0.0 && e.emits_along(i, normal, wi)) {
                    return None;
                }
                LightSample {
                    wi: wi.as_vec3(),
                    distance: d as f32,
                    radiance: e.radiance(i),
                    pdf: pdf as f32,
                    delta: false,
                    on_mesh: Some(MeshPoint { mesh: e.mesh, prim: e.prim(i), u: bu, v: bv }),
                }
            }
            Entry::Environment => {
                let (wi, radiance, pdf) = self.environment.as_ref()?.sample(u)?;
                LightSample { wi, distance: f32::INFINITY, radiance, pdf, delta: false, on_mesh: None }
            }
        };
        (sample.pdf > 0.0 && sample.pdf.is_finite()).then_some(sample)
    }

    /// The density (choice × solid angle) with which [`LightSet::sample`] from `p` (normal
    /// `n`) would have produced the direction `wi` that reached `emitter` at the point `y`
    /// (geometric normal `ng`, either side).
    pub fn pdf_hit(&self, p: Vec3, n: Vec3, wi: Vec3, emitter: Emitter, y: Vec3, ng: Vec3) -> f32 {
        let d = (y - p).length();
        let (pdf, entry) = match emitter {
            Emitter::Area(k) => {
                let Some(light) = self.area.get(k as usize) else { return 0.0 };
                let near = self.quads[k as usize].as_ref().and_then(|quad| quad.seen_from(p.as_dvec3()));
                let pdf = match near {
                    Some(q) => (1.0 / q.solid_angle) as f32,
                    None => pdf_by_area(&light.shape, p, wi, d),
                };
                (pdf, self.area_base + k as usize)
            }
            Emitter::Triangle { mesh, prim } => {
                let Some(e) = self.meshes.get(mesh as usize) else { return 0.0 };
                let Some(tri) = e.triangle_of_prim(prim) else { return 0.0 };
                let pdf = if let Some(st) = e.seen_from(tri, p.as_dvec3()) {
                    (1.0 / st.solid_angle) as f32
                } else {
                    let d = d as f64;
                    density_by_area(d * d, ng.dot(wi).abs() as f64, e.triangle_area(tri)) as f32
                };
                (pdf, self.mesh_base[mesh as usize] + tri)
            }
        };
        if pdf > 0.0 && pdf.is_finite() { pdf * self.choice(entry, p, n) } else { 0.0 }
    }

    /// The density with which [`LightSet::sample`] from `p` (normal `n`) would have produced
    /// the direction `wi` that escaped into the environment.
    pub fn pdf_environment(&self, p: Vec3, n: Vec3, wi: Vec3) -> f32 {
        match (self.environment.as_ref(), self.environment_entry) {
            (Some(env), Some(k)) => env.pdf(wi) * self.choice(k, p, n),
            _ => 0.0,
        }
    }

    /// The radiance of the environment along the escaping direction `wi` (0 without one).
    pub fn environment(&self, wi: Vec3) -> Vec3 {
        self.environment.as_ref().map_or(Vec3::ZERO, |e| e.radiance(wi))
    }
}

/// What the light tree knows of entry `e` of power `phi`: its bounds, or that it is infinitely
/// far away.
fn extent(e: &Entry, phi: f32, delta: &[Light], area: &[AreaLight], meshes: &[MeshEmitter]) -> LightExtent {
    match *e {
        Entry::Delta(i) => match delta[i as usize] {
            Light::Point { position, .. } => LightExtent::Bounded(LightBounds::point(position, phi)),
            Light::Directional { .. } => LightExtent::Infinite(phi),
        },
        Entry::Environment => LightExtent::Infinite(phi),
        Entry::Area(i) => {
            let l = &area[i as usize];
            let (bounds, w, cos_o) = match l.shape {
                Shape::Quad { corner, edge1, edge2 } => (
                    Aabb::from_points([corner, corner + edge1, corner + edge2, corner + edge1 + edge2]),
                    edge1.cross(edge2),
                    1.0,
                ),
                Shape::Disk { center, normal, radius } => {
                    let n = normal.normalize();
                    let half = radius * (Vec3::ONE - n * n).max(Vec3::ZERO).powf(0.5);
                    (Aabb::new(center - half, center + half), n, 1.0)
                }
                Shape::Sphere { center, radius } => {
                    (Aabb::new(center - Vec3::splat(radius), center + Vec3::splat(radius)), Vec3::Z, -1.0)
                }
            };
            LightExtent::Bounded(LightBounds::diffuse(bounds, w, phi, cos_o, l.two_sided))
        }
        Entry::Triangle { mesh, tri } => {
            let e = &meshes[mesh as usize];
            let bounds = Aabb::from_points(e.triangle(tri as usize).map(|p| p.as_vec3()));
            LightExtent::Bounded(LightBounds::diffuse(bounds, e.normal(tri as usize).as_vec3(), phi, 1.0, true))
        }
    }
}

/// The solid-angle density `d²/(|cosθ_l|·A)` of a point drawn uniformly on an area `A` seen at
/// distance `d` (`d2` = d²) and angle `θ_l` to its normal; 0 edge-on.
#[inline]
fn density_by_area(d2: f64, cos_l: f64, area: f64) -> f64 {
    if cos_l > 0.0 { d2 / (cos_l * area) } else { 0.0 }
}

/// The solid-angle density of the sampling [`AreaLight::sample`] does (by area, or in a
/// sphere's cone; module docs) from `p`, for the direction `wi` (unit) that meets the light at
/// distance `d`.
pub fn pdf_by_area(shape: &Shape, p: Vec3, wi: Vec3, d: f32) -> f32 {
    let (w, d) = (wi.as_dvec3(), d as f64);
    let by_area = |normal: DVec3, area: f64| density_by_area(d * d, normal.dot(w).abs(), area);
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
    use std::f64::consts::PI;

    use super::*;
    use crate::texture::Image;

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
        let lights = LightSet::new(&[], &area, Vec::new(), None, 1.0, LightSampler::Power);
        assert_eq!(lights.len(), 2);
        // Chosen by power: π·L·4πr² for the sphere, 2π·L·A for the two-sided quad.
        let (sphere_power, quad_power) = (4.0 * PI * PI, 2.0 * PI * 4.0);
        let sphere_choice = (sphere_power / (sphere_power + quad_power)) as f32;
        let n = 256;
        let mut inv = [0.0f64; 2];
        for i in 0..n {
            for j in 0..n {
                let u = Vec2::new((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32);
                // u.x within each light's share of [0, 1): the sphere's first.
                let shares = [(0.0, sphere_choice), (sphere_choice, 1.0 - sphere_choice)];
                for (sum, (start, want)) in inv.iter_mut().zip(shares) {
                    let ux = start + want * u.x;
                    let (s, choice) = lights.sample(Vec3::ZERO, Vec3::Y, Vec2::new(ux, u.y)).unwrap();
                    assert!((choice - want).abs() < 1e-6, "{choice} vs {want}");
                    *sum += 1.0 / s.pdf as f64 / (n * n) as f64;
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

    /// The irradiance an emissive triangle and a quad light give, estimated from their light
    /// samples, is Lambert's closed form for a polygon, `E = L/2 · Σ γ_k n·(r_k × r_k+1)/|r_k ×
    /// r_k+1|` (γ_k the angle between the unit vectors to consecutive corners): near them
    /// (sampled by solid angle) and far from them (by area).
    #[test]
    fn triangle_and_quad_lights_give_lamberts_irradiance() {
        let tri = [Vec3::new(0.0, 1.0, 0.0), Vec3::new(1.0, 1.0, 0.0), Vec3::new(0.0, 1.0, 1.0)];
        let e = MeshEmitter::new(0, 1, [(tri, Vec3::splat(3.0))]).unwrap();
        let mesh = LightSet::new(&[], &[], vec![e], None, 1.0, LightSampler::Power);
        // One-sided, emitting down (edge1 × edge2 = −y).
        let quad = AreaLight {
            shape: Shape::Quad { corner: Vec3::new(0.0, 1.0, 0.0), edge1: Vec3::X, edge2: Vec3::Z * 0.5 },
            radiance: Vec3::splat(3.0),
            two_sided: false,
            samples: 1,
        };
        let quad_set = LightSet::new(&[], &[quad], Vec::new(), None, 1.0, LightSampler::Power);
        let square =
            [Vec3::new(0.0, 1.0, 0.0), Vec3::new(1.0, 1.0, 0.0), Vec3::new(1.0, 1.0, 0.5), Vec3::new(0.0, 1.0, 0.5)];
        // The normal tilted a little, the lights wholly above the horizon of every point.
        let n = Vec3::new(0.02, 1.0, 0.01).normalize();
        let points = [(Vec3::new(0.4, 0.95, 0.1), true), (Vec3::new(0.2, -2.0, 0.3), false)];
        for (name, lights, corners) in [("triangle", &mesh, &tri[..]), ("quad", &quad_set, &square[..])] {
            for (p, near) in points {
                let by_solid_angle = match name {
                    "triangle" => lights.meshes[0].seen_from(0, p.as_dvec3()).is_some(),
                    _ => lights.quads[0].as_ref().unwrap().seen_from(p.as_dvec3()).is_some(),
                };
                assert_eq!(by_solid_angle, near, "{name}");
                let r: Vec<_> = corners.iter().map(|c| (*c - p).as_dvec3().normalize()).collect();
                let closed = (0..r.len())
                    .map(|k| {
                        let (a, b) = (r[k], r[(k + 1) % r.len()]);
                        let g = a.cross(b);
                        a.dot(b).clamp(-1.0, 1.0).acos() * n.as_dvec3().dot(g / g.length())
                    })
                    .sum::<f64>()
                    .abs()
                    * 3.0
                    / 2.0;
                let m = 256;
                let mut sum = 0.0;
                for i in 0..m {
                    for j in 0..m {
                        let u = Vec2::new((i as f32 + 0.5) / m as f32, (j as f32 + 0.5) / m as f32);
                        if let Some((s, choice)) = lights.sample(p, n, u) {
                            sum += (s.radiance.x * s.wi.dot(n).max(0.0) / (s.pdf * choice)) as f64;
                        }
                    }
                }
                let est = sum / (m * m) as f64;
                assert!(
                    (est - closed).abs() < 2e-3 * closed,
                    "{name}, near {near}: estimate {est} vs closed form {closed}"
                );
            }
        }
        // From above, the one-sided quad lights nothing, near or far.
        for p in [Vec3::new(0.4, 1.05, 0.1), Vec3::new(0.2, 4.0, 0.3)] {
            assert!(quad_set.sample(p, -Vec3::Y, Vec2::splat(0.3)).is_none());
        }
    }

    /// One light of every kind: a point and a directional light, a quad, a disk and a sphere,
    /// an emissive mesh of three triangles (one not emitting) and an environment map.
    fn every_kind(sampler: LightSampler) -> LightSet {
        let delta = [
            Light::Point { position: Vec3::new(0.0, 3.0, 0.0), intensity: Vec3::splat(5.0) },
            Light::Directional { direction: Vec3::new(1.0, -1.0, 0.0), irradiance: Vec3::splat(2.0) },
        ];
        let light = |shape, two_sided| AreaLight { shape, radiance: Vec3::new(1.0, 2.0, 3.0), two_sided, samples: 1 };
        let area = [
            light(Shape::Quad { corner: Vec3::new(-1.0, 2.0, -1.0), edge1: Vec3::X * 1.5, edge2: Vec3::Z }, false),
            light(
                Shape::Disk { center: Vec3::new(2.0, 1.0, 0.0), normal: Vec3::new(-1.0, 0.0, 0.0), radius: 0.5 },
                true,
            ),
            light(Shape::Sphere { center: Vec3::new(0.0, 1.0, 3.0), radius: 0.7 }, false),
        ];
        let tri = |a: [f32; 3], b: [f32; 3], c: [f32; 3]| [Vec3::from(a), Vec3::from(b), Vec3::from(c)];
        let mesh = MeshEmitter::new(
            0,
            1,
            [
                (tri([-2.0, 0.5, -2.0], [-1.0, 0.5, -2.0], [-2.0, 1.5, -2.5]), Vec3::splat(4.0)),
                (tri([0.0, 0.0, -3.0], [1.0, 0.0, -3.0], [0.0, 1.0, -3.0]), Vec3::ZERO),
                (tri([1.0, 2.0, -2.0], [2.0, 2.5, -2.0], [1.0, 3.0, -1.0]), Vec3::new(0.5, 1.0, 8.0)),
            ],
        )
        .unwrap();
        let (w, h) = (16, 8);
        let texels = (0..w * h).map(|k| Vec3::splat(0.1 + (k % 7) as f32 * (k / w) as f32)).collect();
        let env =
            Environment { rotation_deg: 20.0, ..Environment::map(Image::from_texels("sky", w, h, texels).unwrap()) };
        LightSet::new(&delta, &area, vec![mesh], Some(env), 4.0, sampler)
    }

    #[test]
    fn pdf_hit_is_the_choice_times_the_density_sample_reported() {
        for sampler in [LightSampler::Power, LightSampler::Tree] {
            pdf_hit_matches(sampler);
        }
    }

    fn pdf_hit_matches(sampler: LightSampler) {
        let lights = every_kind(sampler);
        assert_eq!(lights.len(), 2 + 3 + 2 + 1);
        let p = Vec3::new(-0.9, 1.4, -1.3);
        // From p the first emitting triangle is sampled by solid angle (1.29 m from its centroid,
        // its longest edge 1.5 m), the second by area (2.51 m; 1.5 m): both densities are
        // checked. The quad light too is sampled by solid angle (1.19 m from its centre, its
        // diagonal 1.80 m).
        assert!(lights.meshes[0].seen_from(0, p.as_dvec3()).is_some());
        assert!(lights.meshes[0].seen_from(1, p.as_dvec3()).is_none());
        assert!(lights.quads[0].as_ref().unwrap().seen_from(p.as_dvec3()).is_some());
        let n = 64;
        let mut checked = [0usize; 8];
        for (k, entry) in lights.entries.iter().enumerate() {
            for i in 0..n {
                for j in 0..n {
                    let u = Vec2::new((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32);
                    let Some(s) = lights.sample_entry(k, p, u) else { continue };
                    let want = lights.choice(k, p, Vec3::Y) * s.pdf;
                    let y = p + s.wi * s.distance;
                    let got = match *entry {
                        Entry::Delta(_) => {
                            assert!(s.delta && s.pdf == 1.0);
                            continue;
                        }
                        Entry::Environment => lights.pdf_environment(p, Vec3::Y, s.wi),
                        Entry::Area(a) => {
                            let ng = match lights.area[a as usize].shape {
                                Shape::Quad { edge1, edge2, .. } => edge1.cross(edge2).normalize(),
                                Shape::Disk { normal, .. } => normal,
                                Shape::Sphere { center, .. } => (y - center).normalize(),
                            };
                            lights.pdf_hit(p, Vec3::Y, s.wi, Emitter::Area(a), y, ng)
                        }
                        Entry::Triangle { mesh, tri } => {
                            let e = &lights.meshes[mesh as usize];
                            let [a, b, c] = e.triangle(tri as usize);
                            let ng = (b - a).cross(c - a).normalize().as_vec3();
                            let prim = e.prim(tri as usize);
                            lights.pdf_hit(p, Vec3::Y, s.wi, Emitter::Triangle { mesh, prim }, y, ng)
                        }
                    };
                    assert!((got - want).abs() <= 1e-4 * want, "light {k} {entry:?}: pdf_hit {got} vs {want}");
                    checked[k] += 1;
                }
            }
        }
        // Every light but the delta ones was checked, most samples of each.
        assert!(checked[2..].iter().all(|&c| c > n * n / 3), "{checked:?}");
        // The non-emitting triangle is no light; the choice follows the powers.
        assert_eq!(
            lights.pdf_hit(
                p,
                Vec3::Y,
                Vec3::NEG_Z,
                Emitter::Triangle { mesh: 0, prim: 1 },
                Vec3::new(0.1, 0.2, -3.0),
                Vec3::Z
            ),
            0.0
        );
        let total: f32 = (0..lights.len()).map(|k| lights.choice(k, p, Vec3::Y)).sum();
        assert!((total - 1.0).abs() < 1e-5, "{sampler:?}: Σ choice = {total}");
        if sampler == LightSampler::Tree {
            // pbrt-v4's rule: the two infinite lights (directional, environment) and the tree a
            // third each.
            assert_eq!(lights.choice(1, p, Vec3::Y), 1.0 / 3.0);
            assert_eq!(lights.choice(7, p, Vec3::Y), 1.0 / 3.0);
            return;
        }
        let point = lights.choice(0, p, Vec3::Y) as f64 / (4.0 * PI * 5.0);
        let env = lights.choice(7, p, Vec3::Y) as f64
            / (PI * PI * 16.0 * luminance(lights.environment.as_ref().unwrap().mean_radiance()) as f64);
        assert!((point - env).abs() < 1e-5 * point, "choice per watt: point {point}, environment {env}");
    }

    /// What is left of `u.x` after the choice spreads each light's share of `[0, 1)` evenly
    /// over `[0, 1)` again, so that the stratified points of a pixel's samples that choose a
    /// light stay stratified over it ([`LightSet::sample`]). Evenly spaced `u` give each
    /// light evenly spaced rests, none farther than two spacings from the next or the ends.
    #[test]
    fn the_rest_of_the_choice_is_spread_over_the_lights_share() {
        for sampler in [LightSampler::Power, LightSampler::Tree] {
            let lights = every_kind(sampler);
            let (p, n) = (Vec3::new(0.3, 0.5, -0.2), Vec3::Y);
            let m = 1 << 16;
            let mut rests = vec![Vec::new(); lights.len()];
            for i in 0..m {
                let (k, choice, rest) = lights.choose(p, n, (i as f32 + 0.5) / m as f32).unwrap();
                assert_eq!(choice, lights.choice(k, p, n), "{sampler:?}");
                assert!((0.0..1.0).contains(&rest), "{sampler:?}: rest {rest}");
                rests[k].push(rest);
            }
            for (k, r) in rests.iter_mut().enumerate() {
                if r.is_empty() {
                    continue;
                }
                r.sort_by(f32::total_cmp);
                let spacing = 1.0 / r.len() as f32;
                let gaps = r.windows(2).map(|w| w[1] - w[0]).chain([r[0], 1.0 - r[r.len() - 1]]);
                let widest = gaps.fold(0.0f32, f32::max);
                assert!(widest <= 2.0 * spacing, "{sampler:?}, light {k}: gap {widest}, spacing {spacing}");
            }
        }
    }

    #[test]
    fn the_choice_is_drawn_by_power() {
        // The share of u choosing each light is its probability.
        let lights = every_kind(LightSampler::Power);
        let Selection::Power(selection) = &lights.selection else { unreachable!() };
        let n = 100_000;
        let mut counts = vec![0usize; lights.len()];
        for i in 0..n {
            let (k, p, _) = selection.sample_discrete((i as f32 + 0.5) / n as f32);
            assert_eq!(p, lights.choice(k, Vec3::ZERO, Vec3::Y));
            counts[k] += 1;
        }
        for (k, c) in counts.iter().enumerate() {
            assert!((*c as f32 / n as f32 - lights.choice(k, Vec3::ZERO, Vec3::Y)).abs() < 1e-4, "light {k}");
        }
    }
}
