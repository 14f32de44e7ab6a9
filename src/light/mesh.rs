//! Emissive triangle meshes as area lights: every mesh whose material (or per-triangle
//! material) has an `emission` `L ≠ 0` — a TOML material, an OBJ `Ke`, a glTF emissive —
//! lights the scene like a quad light made of those triangles, two-sided (as the camera sees
//! such a surface, from both sides), or from the front only (the side the winding's normal
//! points to) for triangles whose material is a one-sided emitter (`emission_one_sided`: a
//! glTF `doubleSided: false` material), as the camera sees those. `L` here is the triangle's
//! mean radiance (an emission texture's mean texel): what chooses lights and triangles. The
//! path tracer then looks the radiance up where the sampled point lies
//! ([`crate::integrator::path_lights::PathLights::sample`]), so light sampling and BSDF
//! sampling estimate the same light.
//!
//! `mesh_light_samples` (in `[image]`, default 1) samples per shading point per mesh, each
//! carrying `1/mesh_light_samples` of the estimate and stratified as an area light's: a triangle is chosen with probability proportional
//! to its area and a point on it uniformly, so the points are uniform over the mesh's
//! emitting area `A` (`pdf_A = 1/A`) and the estimate is, as for every area light,
//!
//! ```text
//! Ê = L_i · cosθ_s · |cosθ_l| / d² · A          (L_i the chosen triangle's radiance)
//! ```
//!
//! The triangle is picked by inverting the cumulative areas with the sample's first
//! coordinate, and that coordinate is then rescaled inside the triangle's interval, so strata
//! of the unit square stay strata of the mesh. A triangle point is `(1 − √u₁)·a +
//! √u₁(1 − u₂)·b + √u₁·u₂·c` (uniform by area). Instances are not emitters (their emission
//! shows but does not light). `mesh_lights = false` in `[image]` turns emitting meshes back
//! into glowing surfaces that light nothing (as a point light placed by hand in a lamp's
//! shade needs).

use glam::DVec3;

use crate::light::Incidence;
use crate::math::{Vec2, Vec3};
use crate::sampling::spherical_triangle::{self, SphericalTriangle};

/// The emitting triangles of one mesh.
#[derive(Clone, Debug, PartialEq)]
pub struct MeshEmitter {
    /// Index into the scene's meshes.
    pub mesh: u32,
    /// Per kept triangle: its position in the triangles given to [`MeshEmitter::new`] (the
    /// mesh's triangle index when every triangle is given), increasing.
    prims: Vec<u32>,
    corners: Vec<[DVec3; 3]>,
    radiance: Vec<Vec3>,
    /// `cdf[i]` = area of triangles `0..=i`; the last is the total.
    cdf: Vec<f64>,
    /// Samples per shading point (the scene's `image.mesh_light_samples`).
    pub samples: u32,
    /// Per kept triangle, whether it emits from its front only; empty: none does.
    front_only: Vec<bool>,
    /// Per kept triangle: its unit normal (by the winding), its centroid and its longest edge,
    /// squared.
    normals: Vec<DVec3>,
    centroids: Vec<DVec3>,
    longest_edge2: Vec<f64>,
}

impl MeshEmitter {
    /// The emitter of mesh `mesh` (an index into the scene's meshes) made of `triangles`
    /// (corners and radiance), cast `samples` times per shading point; triangles of zero or
    /// non-finite area, or of radiance 0, are left out, and with them all, so is the emitter
    /// (`None`).
    pub fn new(mesh: u32, samples: u32, triangles: impl IntoIterator<Item = ([Vec3; 3], Vec3)>) -> Option<MeshEmitter> {
        let mut e = MeshEmitter {
            mesh,
            prims: Vec::new(),
            corners: Vec::new(),
            radiance: Vec::new(),
            cdf: Vec::new(),
            samples,
            front_only: Vec::new(),
            normals: Vec::new(),
            centroids: Vec::new(),
            longest_edge2: Vec::new(),
        };
        let mut total = 0.0;
        for (prim, (corners, l)) in triangles.into_iter().enumerate() {
            if l == Vec3::ZERO {
                continue;
            }
            let [a, b, c] = corners.map(|p| p.as_dvec3());
            let area = 0.5 * (b - a).cross(c - a).length();
            if area > 0.0 && area.is_finite() {
                total += area;
                e.prims.push(prim as u32);
                e.corners.push([a, b, c]);
                e.radiance.push(l);
                e.cdf.push(total);
                e.normals.push((b - a).cross(c - a).normalize());
                e.centroids.push((a + b + c) / 3.0);
                e.longest_edge2
                    .push((b - a).length_squared().max((c - b).length_squared()).max((a - c).length_squared()));
            }
        }
        (!e.corners.is_empty()).then_some(e)
    }

    /// The same emitter, its triangles whose `front_only(prim)` holds (`prim` as given to
    /// [`MeshEmitter::new`]) emitting from their front only.
    pub fn with_front_only(mut self, front_only: impl Fn(u32) -> bool) -> MeshEmitter {
        let flags: Vec<bool> = self.prims.iter().map(|&p| front_only(p)).collect();
        self.front_only = if flags.contains(&true) { flags } else { Vec::new() };
        self
    }

    /// Whether triangle `i`, of unit normal `normal`, sends light along `wi` (the direction
    /// from the lit point to the light): always for a two-sided triangle, else when the point
    /// lies in front of it (`normal · wi < 0`).
    #[inline]
    pub fn emits_along(&self, i: usize, normal: DVec3, wi: DVec3) -> bool {
        !self.front_only.get(i).copied().unwrap_or(false) || normal.dot(wi) < 0.0
    }

    /// The emitting area `A`, m².
    pub fn area(&self) -> f64 {
        self.cdf.last().copied().unwrap_or(0.0)
    }

    /// The point of the mesh for `u ∈ [0, 1)²` (uniform by area), the unit normal of its
    /// triangle (by the winding) and the triangle's index.
    pub fn sample_point(&self, u: Vec2) -> (DVec3, DVec3, usize) {
        let total = self.area();
        let target = u.x as f64 * total;
        let i = self.cdf.partition_point(|&c| c <= target).min(self.cdf.len() - 1);
        let start = if i == 0 { 0.0 } else { self.cdf[i - 1] };
        let u1 = ((target - start) / (self.cdf[i] - start)).clamp(0.0, 1.0);
        (self.point_on(i, u1, u.y as f64), self.normals[i], i)
    }

    /// The point `(1 − √u₁)·a + √u₁(1 − u₂)·b + √u₁·u₂·c` of triangle `i` (uniform by area for
    /// uniform `u₁, u₂`).
    #[inline]
    fn point_on(&self, i: usize, u1: f64, u2: f64) -> DVec3 {
        let [a, b, c] = self.corners[i];
        let s = u1.sqrt();
        (1.0 - s) * a + s * (1.0 - u2) * b + s * u2 * c
    }

    /// The radiance of triangle `i` (an index [`MeshEmitter::sample_point`] returns).
    pub fn radiance(&self, i: usize) -> Vec3 {
        self.radiance[i]
    }

    /// Number of emitting triangles kept.
    pub fn triangle_count(&self) -> usize {
        self.corners.len()
    }

    /// The kept triangle that was triangle `prim` of those given to [`MeshEmitter::new`].
    pub fn triangle_of_prim(&self, prim: u32) -> Option<usize> {
        self.prims.binary_search(&prim).ok()
    }

    /// The position of triangle `i` among those given to [`MeshEmitter::new`].
    pub fn prim(&self, i: usize) -> u32 {
        self.prims[i]
    }

    /// The area of triangle `i`, m².
    pub fn triangle_area(&self, i: usize) -> f64 {
        self.cdf[i] - if i == 0 { 0.0 } else { self.cdf[i - 1] }
    }

    /// The corners of triangle `i`.
    pub fn triangle(&self, i: usize) -> [DVec3; 3] {
        self.corners[i]
    }

    /// The unit normal of triangle `i` (by the winding).
    pub fn normal(&self, i: usize) -> DVec3 {
        self.normals[i]
    }

    /// Triangle `i` as seen from `p`, when it is sampled by solid angle from there (near it,
    /// and of a solid angle the sampling handles: [`crate::sampling::spherical_triangle`]).
    pub fn seen_from(&self, i: usize, p: DVec3) -> Option<SphericalTriangle> {
        spherical_triangle::is_near(p, self.centroids[i], self.longest_edge2[i])
            .then(|| SphericalTriangle::new(p, &self.corners[i]))
            .filter(SphericalTriangle::usable)
    }

    /// A point of triangle `i` for `u ∈ [0, 1)²`, uniform by area.
    pub fn sample_triangle(&self, i: usize, u: Vec2) -> DVec3 {
        self.point_on(i, u.x as f64, u.y as f64)
    }

    /// The barycentric coordinates `(u, v)` (of the second and third corners) of the point
    /// [`MeshEmitter::sample_triangle`] gives for `u`: `(√u₁(1 − u₂), √u₁·u₂)`.
    pub fn barycentric_of_sample(u: Vec2) -> (f32, f32) {
        let s = (u.x as f64).sqrt();
        ((s * (1.0 - u.y as f64)) as f32, (s * u.y as f64) as f32)
    }

    /// One sample of the mesh seen from `p` for the point `u ∈ [0, 1)²`, as
    /// [`crate::light::area::AreaLight::sample`]; `None` when the point is `p` itself or seen
    /// edge-on.
    pub fn sample(&self, p: Vec3, u: Vec2) -> Option<Incidence> {
        let total = self.area();
        let (y, normal, i) = self.sample_point(u);
        let to = y - p.as_dvec3();
        let d2 = to.length_squared();
        let w = to / d2.sqrt();
        if !self.emits_along(i, normal, w) {
            return None;
        }
        let cos_l = normal.dot(w).abs();
        (d2 > 0.0 && cos_l > 0.0).then(|| Incidence {
            to_light: w.as_vec3(),
            distance: d2.sqrt() as f32,
            normal_irradiance: (self.radiance[i].as_dvec3() * (cos_l * total / d2 / self.samples as f64)).as_vec3(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::light::area::{AreaLight, Shape};

    #[test]
    fn a_two_triangle_square_lights_like_the_same_quad_light() {
        // The unit square at height 1 as an emissive mesh and as a two-sided quad light: the
        // same estimate for the same sample points (the mesh splits u.x between its two
        // triangles, so compare the means over a fine grid).
        let [p0, p1, p2, p3] = [(-0.5, -0.5), (0.5, -0.5), (0.5, 0.5), (-0.5, 0.5)].map(|(x, z)| Vec3::new(x, 1.0, z));
        let l = Vec3::splat(2.0);
        let e = MeshEmitter::new(0, 1, [([p0, p1, p2], l), ([p0, p2, p3], l)]).unwrap();
        assert!((e.area() - 1.0).abs() < 1e-12);
        let quad = AreaLight {
            shape: Shape::Quad { corner: Vec3::new(-0.5, 1.0, -0.5), edge1: Vec3::X, edge2: Vec3::Z },
            radiance: Vec3::splat(2.0),
            two_sided: true,
            samples: 1,
        };
        let mean = |f: &dyn Fn(Vec2) -> f64| {
            let n = 200;
            let mut sum = 0.0;
            for i in 0..n {
                for j in 0..n {
                    sum += f(Vec2::new((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32));
                }
            }
            sum / (n * n) as f64
        };
        let e_of = |inc: Option<Incidence>| inc.map_or(0.0, |i| (i.normal_irradiance.x * i.to_light.y.max(0.0)) as f64);
        let m = mean(&|u| e_of(e.sample(Vec3::ZERO, u)));
        let q = mean(&|u| e_of(quad.sample(Vec3::ZERO, u)));
        assert!((m - q).abs() < 2e-4 * q, "mesh {m} vs quad {q}");
        // Every sample lies on the square.
        for u in [Vec2::ZERO, Vec2::new(0.49, 0.9), Vec2::new(0.999, 0.001)] {
            let i = e.sample(Vec3::ZERO, u).unwrap();
            let y = i.to_light * i.distance;
            assert!((y.y - 1.0).abs() < 1e-6 && y.x.abs() <= 0.5 + 1e-6 && y.z.abs() <= 0.5 + 1e-6, "{y}");
        }
    }
}
