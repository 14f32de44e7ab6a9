//! Directions towards a triangle, uniform in the solid angle it subtends (Arvo, "Stratified
//! Sampling of Spherical Triangles", SIGGRAPH 1995), as Cycles and pbrt-v4 sample emissive
//! triangles near a shading point.
//!
//! ```text
//! Ω = 2·atan2(|a·(b × c)|, 1 + a·b + b·c + c·a)      (a, b, c: unit vectors from p to the corners;
//!                                                     Van Oosterom and Strackee)
//! p(ω) = 1/Ω                                         for every ω that meets the triangle
//! ```
//!
//! A sample cuts the spherical triangle `abc` at the point `c'` of the arc `ac` for which the
//! sub-triangle `abc'` has area `u₁·Ω`, then picks `ω` on the arc `bc'` so that
//! `1 − ω·b = u₂·(1 − c'·b)`. The map is area-preserving, so strata of the unit square stay
//! strata of the solid angle and a Sobol sequence keeps its stratification.
//!
//! Beside a light, a triangle sampled uniformly by area gives the estimate
//! `L·cosθ_s·cosθ_l·A/d²`, which grows without bound as the shading point nears the light (the
//! bright spikes on a surface beside a lamp); sampled by solid angle it is `L·cosθ_s·Ω`. Far
//! away the two agree, and area sampling is cheaper (no trigonometry) and better conditioned.
//! So a triangle is sampled by solid angle only where the shading point is nearer its centroid
//! than its longest edge is long ([`is_near`]: `|p − c| < ℓ_max`; Cycles' rule, nearer the
//! triangle's plane than that, also takes points far off to the side, and cost 4–6 % more
//! instructions on the scenes of docs/performance.md for no less noise), and then only for
//! `Ω ∈ [3·10⁻⁴, 6.22]` sr (pbrt-v4's `MinSphericalSampleArea` and `MaxSphericalSampleArea`:
//! below, the spherical triangle is too thin for the arithmetic; near 2π the point almost lies
//! on the triangle). All the arithmetic is f64.
//!
//! A parallelogram (a quad light) is its two triangles ([`Parallelogram`], [`SphericalQuad`]):
//! `u₁·Ω` picks the triangle whose share of `Ω = Ω₁ + Ω₂` it falls in and is rescaled within it
//! (strata stay strata), and the density is `1/Ω` over the whole quad.

use std::f64::consts::PI;

use glam::DVec3;

/// Below this solid angle (sr) a triangle is sampled by area (module docs).
pub const MIN_SOLID_ANGLE: f64 = 3e-4;
/// Above this solid angle (sr) a triangle is sampled by area (module docs).
pub const MAX_SOLID_ANGLE: f64 = 6.22;

/// Whether `p` is near enough to a light of centroid `centroid` and longest edge (or diagonal)
/// `ℓ`, given as `ℓ²`, to be sampled by solid angle: nearer its centroid than `ℓ`.
#[inline]
pub fn is_near(p: DVec3, centroid: DVec3, longest_edge2: f64) -> bool {
    (p - centroid).length_squared() < longest_edge2
}

/// A triangle as seen from a point: the unit vectors towards its corners and the solid angle it
/// subtends.
#[derive(Clone, Copy, Debug)]
pub struct SphericalTriangle {
    corners: [DVec3; 3],
    /// Ω, sr.
    pub solid_angle: f64,
}

impl SphericalTriangle {
    /// The triangle `tri` seen from `p` (its solid angle 0 when `p` lies in its plane or on a
    /// corner).
    pub fn new(p: DVec3, tri: &[DVec3; 3]) -> SphericalTriangle {
        let corners = tri.map(|v| (v - p).normalize_or_zero());
        SphericalTriangle { corners, solid_angle: solid_angle_of(&corners) }
    }

    /// Whether its solid angle is one the sampling handles (module docs).
    #[inline]
    pub fn usable(&self) -> bool {
        usable(self.solid_angle)
    }

    /// The unit direction for `u ∈ [0, 1)²`, uniform in the solid angle; `None` when the
    /// arithmetic degenerates.
    pub fn sample(&self, u: [f64; 2]) -> Option<DVec3> {
        let ([a, b, c], omega) = (self.corners, self.solid_angle);
        let n_ab = a.cross(b).normalize_or_zero();
        let n_ca = c.cross(a).normalize_or_zero();
        // The spherical triangle's angle at `a`: between the great circles `ab` and `ac`.
        let cos_alpha = (-n_ab.dot(n_ca)).clamp(-1.0, 1.0);
        let sin_alpha = (1.0 - cos_alpha * cos_alpha).max(0.0).sqrt();
        if !(sin_alpha > 0.0) {
            return None;
        }
        // The sub-triangle abc' of area u₁·Ω: its angle sum is π + u₁·Ω.
        let (sin_s, cos_s) = (PI + u[0] * omega).sin_cos();
        let sin_phi = sin_s * cos_alpha - cos_s * sin_alpha;
        let cos_phi = cos_s * cos_alpha + sin_s * sin_alpha;
        let k1 = cos_phi + cos_alpha;
        let k2 = sin_phi - sin_alpha * a.dot(b);
        let cos_b = ((k2 + (k2 * cos_phi - k1 * sin_phi) * cos_alpha) / ((k2 * sin_phi + k1 * cos_phi) * sin_alpha))
            .clamp(-1.0, 1.0);
        let sin_b = (1.0 - cos_b * cos_b).max(0.0).sqrt();
        let c_prime = cos_b * a + sin_b * (c - c.dot(a) * a).normalize_or_zero();
        // ω on the arc from b to c'.
        let cos_theta = 1.0 - u[1] * (1.0 - c_prime.dot(b));
        let sin_theta = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
        let w = cos_theta * b + sin_theta * (c_prime - c_prime.dot(b) * b).normalize_or_zero();
        (w.is_finite() && w != DVec3::ZERO).then(|| w.normalize())
    }
}

/// A parallelogram `corner + a·e1 + b·e2` (`a, b ∈ [0, 1]`): its two triangles
/// `(c, c + e1, c + e1 + e2)` and `(c, c + e1 + e2, c + e2)`, and what [`is_near`] asks of it.
#[derive(Clone, Copy, Debug)]
pub struct Parallelogram {
    triangles: [[DVec3; 3]; 2],
    /// `e1 × e2`, normalised.
    normal: DVec3,
    centroid: DVec3,
    /// The longest of its sides and the diagonal its triangles share, squared.
    longest2: f64,
}

impl Parallelogram {
    pub fn new(corner: DVec3, e1: DVec3, e2: DVec3) -> Parallelogram {
        let far = corner + e1 + e2;
        Parallelogram {
            triangles: [[corner, corner + e1, far], [corner, far, corner + e2]],
            normal: e1.cross(e2).normalize(),
            centroid: corner + 0.5 * (e1 + e2),
            longest2: e1.length_squared().max(e2.length_squared()).max((e1 + e2).length_squared()),
        }
    }

    /// Its first corner.
    pub fn corner(&self) -> DVec3 {
        self.triangles[0][0]
    }

    /// Its unit normal, `e1 × e2` normalised.
    pub fn normal(&self) -> DVec3 {
        self.normal
    }

    /// The parallelogram seen from `p`, when `p` is near it ([`is_near`]) and its solid angle
    /// is [`usable`]; else `None`.
    pub fn seen_from(&self, p: DVec3) -> Option<SphericalQuad> {
        if !is_near(p, self.centroid, self.longest2) {
            return None;
        }
        let halves = self.triangles.map(|t| SphericalTriangle::new(p, &t));
        let solid_angle = halves[0].solid_angle + halves[1].solid_angle;
        usable(solid_angle).then_some(SphericalQuad { halves, triangles: self.triangles, solid_angle })
    }
}

/// A [`Parallelogram`] seen from a point, as its two spherical triangles.
#[derive(Clone, Copy, Debug)]
pub struct SphericalQuad {
    halves: [SphericalTriangle; 2],
    triangles: [[DVec3; 3]; 2],
    /// Ω = Ω₁ + Ω₂, sr.
    pub solid_angle: f64,
}

impl SphericalQuad {
    /// The unit direction from `p` (the point it was seen from) for `u ∈ [0, 1)²`, uniform in
    /// the solid angle, and the distance along it to the parallelogram.
    pub fn sample(&self, p: DVec3, u: [f64; 2]) -> Option<(DVec3, f64)> {
        let t = u[0] * self.solid_angle;
        let first = self.halves[0].solid_angle;
        let (k, u1) = if t < first { (0, t / first) } else { (1, (t - first) / self.halves[1].solid_angle) };
        let w = self.halves[k].sample([u1.clamp(0.0, 1.0), u[1]])?;
        let (d, _, _) = hit_plane(p, w, &self.triangles[k])?;
        Some((w, d))
    }
}

/// Whether a solid angle `omega` (sr) of a triangle, or of a quad's two, is one the sampling
/// handles: in `[MIN_SOLID_ANGLE, MAX_SOLID_ANGLE]`.
#[inline]
pub fn usable(omega: f64) -> bool {
    (MIN_SOLID_ANGLE..=MAX_SOLID_ANGLE).contains(&omega)
}

/// Van Oosterom and Strackee's formula for unit vectors `a, b, c`.
fn solid_angle_of([a, b, c]: &[DVec3; 3]) -> f64 {
    let triple = a.dot(b.cross(*c)).abs();
    let omega = 2.0 * triple.atan2(1.0 + a.dot(*b) + b.dot(*c) + c.dot(*a));
    if omega.is_finite() { omega } else { 0.0 }
}

/// Where the ray `p + t·w` (`w` unit) meets the plane of `tri`: the distance `t` and the
/// barycentric coordinates `(u, v)` of the second and third corners, clamped to the triangle
/// (a direction [`SphericalTriangle::sample`] gives can fall outside by rounding); `None` when
/// the ray runs parallel to the plane or away from it.
pub fn hit_plane(p: DVec3, w: DVec3, tri: &[DVec3; 3]) -> Option<(f64, f64, f64)> {
    // Möller and Trumbore's solution, without its inside test.
    let [a, b, c] = *tri;
    let (e1, e2) = (b - a, c - a);
    let s = w.cross(e2);
    let det = e1.dot(s);
    let o = p - a;
    let q = o.cross(e1);
    let inv = 1.0 / det;
    let (mut u, mut v, t) = ((o.dot(s) * inv).max(0.0), (w.dot(q) * inv).max(0.0), e2.dot(q) * inv);
    if !(t > 0.0 && t.is_finite() && u.is_finite() && v.is_finite()) {
        return None;
    }
    if u + v > 1.0 {
        let sum = u + v;
        (u, v) = (u / sum, v / sum);
    }
    Some((t, u, v))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Vec3;
    use crate::sampling::chi2::{Chi2Test, sidak};

    /// Möller–Trumbore: whether the ray from `p` along `w` meets `tri`.
    fn hits(p: DVec3, w: DVec3, tri: &[DVec3; 3]) -> bool {
        let [a, b, c] = *tri;
        let (e1, e2) = (b - a, c - a);
        let s = w.cross(e2);
        let det = e1.dot(s);
        if det.abs() < 1e-300 {
            return false;
        }
        let o = p - a;
        let u = o.dot(s) / det;
        let q = o.cross(e1);
        let v = w.dot(q) / det;
        let t = e2.dot(q) / det;
        u >= 0.0 && v >= 0.0 && u + v <= 1.0 && t > 0.0
    }

    /// The solid angle of `tri` from `p`.
    fn solid_angle(p: DVec3, tri: &[DVec3; 3]) -> f64 {
        SphericalTriangle::new(p, tri).solid_angle
    }

    /// The solid angle by Girard's theorem, independently of Van Oosterom and Strackee: the
    /// spherical triangle's angle sum less π, each angle between the planes through `p` and two
    /// corners.
    fn girard(p: DVec3, tri: &[DVec3; 3]) -> f64 {
        let v = tri.map(|c| (c - p).normalize());
        (0..3)
            .map(|k| {
                let (a, b, c) = (v[k], v[(k + 1) % 3], v[(k + 2) % 3]);
                a.cross(b).normalize().angle_between(a.cross(c).normalize())
            })
            .sum::<f64>()
            - PI
    }

    fn triangles() -> Vec<(DVec3, [DVec3; 3])> {
        vec![
            // Large and near: the Cornell room's wall point beside its ceiling light.
            (DVec3::ZERO, [DVec3::new(-0.5, 0.2, -0.5), DVec3::new(0.5, 0.2, -0.5), DVec3::new(0.0, 0.3, 0.7)]),
            // Seen obliquely, close to its plane.
            (
                DVec3::new(0.6, 0.2, 0.6),
                [DVec3::new(0.0, 0.0, 1.0), DVec3::new(1.0, 0.5, 1.0), DVec3::new(0.2, 1.0, 1.5)],
            ),
            // Small and far, thin.
            (DVec3::ZERO, [DVec3::new(-0.1, 0.0, 2.0), DVec3::new(0.1, 0.02, 2.0), DVec3::new(0.05, -0.05, 2.1)]),
        ]
    }

    #[test]
    fn the_solid_angle_of_an_octant_and_of_a_square_seen_from_its_axis() {
        // The triangle of the three unit axes bounds one octant of the sphere: 4π/8.
        let octant = solid_angle(DVec3::ZERO, &[DVec3::X, DVec3::Y, DVec3::Z]);
        assert!((octant - PI / 2.0).abs() < 1e-14, "{octant}");
        // A 2 × 2 square at height 2 on its axis, as two triangles: 4·asin(1/5).
        let [p0, p1, p2, p3] = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)].map(|(x, y)| DVec3::new(x, y, 2.0));
        let square = solid_angle(DVec3::ZERO, &[p0, p1, p2]) + solid_angle(DVec3::ZERO, &[p0, p2, p3]);
        assert!((square - 4.0 * (0.2f64).asin()).abs() < 1e-14, "{square}");
        // In the plane: nothing.
        assert_eq!(solid_angle(DVec3::new(5.0, 0.0, 2.0), &[p0, p1, p2]), 0.0);
    }

    #[test]
    fn near_means_nearer_the_centroid_than_the_longest_edge_and_a_usable_solid_angle() {
        let tri = [DVec3::new(0.0, 0.0, 1.0), DVec3::new(1.0, 0.0, 1.0), DVec3::new(0.0, 2.0, 1.0)];
        let (c, edge2) = (DVec3::new(1.0 / 3.0, 2.0 / 3.0, 1.0), 5.0); // longest edge √5
        assert!(is_near(c + DVec3::new(0.0, 0.0, -2.23), c, edge2));
        assert!(!is_near(c + DVec3::new(0.0, 0.0, -2.24), c, edge2));
        assert!(!is_near(DVec3::new(9.0, 9.0, 1.0), c, edge2), "in its plane, far off to the side");
        assert!(is_near(c + DVec3::new(1.5, 0.0, 1.5), c, edge2), "either side, off its axis");
        // Seen from its plane, or too small to sample: none.
        assert!(!SphericalTriangle::new(DVec3::new(5.0, 5.0, 1.0), &tri).usable());
        assert!(!SphericalTriangle::new(DVec3::new(0.3, 0.3, -200.0), &tri).usable());
        let st = SphericalTriangle::new(DVec3::new(0.3, 0.3, 0.0), &tri);
        assert!(st.usable());
        assert!((st.solid_angle - girard(DVec3::new(0.3, 0.3, 0.0), &tri)).abs() < 1e-12);
    }

    #[test]
    fn samples_meet_the_triangle_and_are_uniform_in_solid_angle() {
        // Every sample meets the triangle, and the samples' directions pass Pearson's χ²
        // against the density 1/Ω inside the triangle's solid angle and 0 outside. (The χ²
        // harness integrates the density per bin by adaptive Simpson quadrature, which cannot
        // see a sliver of a small triangle in a bin: the small triangle's uniformity is checked
        // by the Jacobian in `the_map_is_area_preserving` instead.)
        let cases = triangles();
        let chi2_cases = cases.iter().filter(|(p, tri)| solid_angle(*p, tri) > 0.5).count();
        assert_eq!(chi2_cases, 2);
        for (k, (p, tri)) in cases.iter().enumerate() {
            let st = SphericalTriangle::new(*p, tri);
            let omega = st.solid_angle;
            assert!((omega - girard(*p, tri)).abs() < 1e-12 * omega.max(1.0), "triangle {k}: Ω {omega}");
            let n = 64;
            for i in 0..n {
                for j in 0..n {
                    let u = [(i as f64 + 0.5) / n as f64, (j as f64 + 0.5) / n as f64];
                    let w = st.sample(u).unwrap();
                    let (t, bu, bv) = hit_plane(*p, w, tri).unwrap();
                    let y = p + t * w;
                    let back = (1.0 - bu - bv) * tri[0] + bu * tri[1] + bv * tri[2];
                    assert!((y - back).length() < 1e-9, "triangle {k}, u {u:?}: {y} is not on it ({back})");
                    assert!(bu > 0.0 && bv > 0.0 && bu + bv < 1.0, "triangle {k}, u {u:?}: ({bu}, {bv})");
                }
            }
            if omega <= 0.5 {
                continue;
            }
            let r = Chi2Test { cos_bins: 51, phi_bins: 100, ..Default::default() }.run(
                |_, u| st.sample([u.x as f64, u.y as f64]).map(|w| w.as_vec3()),
                |w: Vec3| if hits(*p, w.as_dvec3(), tri) { 1.0 / omega } else { 0.0 },
            );
            assert!(r.passes(sidak(0.01, chi2_cases)), "triangle {k} (Ω = {omega}): {r}");
        }
    }

    #[test]
    fn random_and_degenerate_triangles_give_finite_samples_on_the_triangle() {
        // Triangles of random corners seen from random points, among them slivers, points
        // almost in the plane and points almost on a corner: whenever a triangle is usable its
        // samples are unit directions that meet the plane at a finite distance, at barycentric
        // coordinates inside the triangle, within 1e-6 of the triangle's size; from a point 1e-9
        // from a corner, which sees the triangle almost edge-on, the plane hit is ill-conditioned
        // and the point is within 1e-3 (the worst of these cases: 8e-5).
        use rand::{Rng, SeedableRng};
        let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(43);
        let mut v = |scale: f64| {
            DVec3::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0)) * scale
        };
        let mut usable_cases = 0;
        for case in 0..20_000 {
            let (a, b) = (v(1.0), v(1.0));
            let c = match case % 4 {
                0 => v(1.0),
                1 => a + (b - a) * 0.5 + v(1e-7), // a sliver
                _ => v(1.0),
            };
            let tri = [a, b, c];
            let n = (b - a).cross(c - a);
            let p = match case % 4 {
                2 => a + v(1e-9),                                                // on a corner
                3 => (a + b + c) / 3.0 + n.normalize_or_zero() * 1e-9 + v(1e-3), // almost in the plane
                _ => v(2.0),
            };
            let st = SphericalTriangle::new(p, &tri);
            assert!(st.solid_angle.is_finite() && st.solid_angle >= 0.0, "case {case}: Ω {}", st.solid_angle);
            if !st.usable() {
                continue;
            }
            usable_cases += 1;
            let size = (b - a).length().max((c - a).length());
            for u in [[0.0, 0.0], [0.5, 0.5], [0.999_999, 0.999_999], [0.25, 0.999_999], [0.999_999, 0.0]] {
                let Some(w) = st.sample(u) else { continue };
                assert!(w.is_finite() && (w.length() - 1.0).abs() < 1e-12, "case {case}, u {u:?}: {w}");
                let Some((t, bu, bv)) = hit_plane(p, w, &tri) else { continue };
                let on = (1.0 - bu - bv) * a + bu * b + bv * c;
                assert!(t.is_finite() && bu >= 0.0 && bv >= 0.0 && bu + bv <= 1.0 + 1e-12, "case {case}: ({bu}, {bv})");
                let tol = if case % 4 == 2 { 1e-3 } else { 1e-6 };
                let off = (p + t * w - on).length();
                assert!(
                    off < tol * size.max(t),
                    "case {case}, u {u:?}: off the triangle by {off} (Ω {})",
                    st.solid_angle
                );
            }
        }
        assert!(usable_cases > 10_000, "{usable_cases}");
    }

    #[test]
    fn a_quad_is_sampled_uniformly_in_its_solid_angle() {
        // A parallelogram seen from nearby: every sample meets it, and the directions pass χ²
        // against 1/(Ω₁ + Ω₂) over either triangle.
        let (p, corner, e1, e2) = (
            DVec3::new(0.2, 0.1, 0.0),
            DVec3::new(-0.5, -0.3, 0.4),
            DVec3::new(1.2, 0.1, 0.0),
            DVec3::new(0.3, 0.9, 0.2),
        );
        let quad = Parallelogram::new(corner, e1, e2);
        let q = quad.seen_from(p).unwrap();
        let tris = [[corner, corner + e1, corner + e1 + e2], [corner, corner + e1 + e2, corner + e2]];
        assert!((q.solid_angle - solid_angle(p, &tris[0]) - solid_angle(p, &tris[1])).abs() < 1e-12);
        for i in 0..64 {
            for j in 0..64 {
                let (w, d) = q.sample(p, [(i as f64 + 0.5) / 64.0, (j as f64 + 0.5) / 64.0]).unwrap();
                assert!(tris.iter().any(|t| hits(p, w, t)), "{w} misses the quad");
                assert!((e1.cross(e2).normalize().dot(p + d * w - corner)).abs() < 1e-12, "not on its plane");
            }
        }
        let r = Chi2Test { cos_bins: 51, phi_bins: 100, ..Default::default() }.run(
            |_, u| q.sample(p, [u.x as f64, u.y as f64]).map(|(w, _)| w.as_vec3()),
            |w: Vec3| if tris.iter().any(|t| hits(p, w.as_dvec3(), t)) { 1.0 / q.solid_angle } else { 0.0 },
        );
        assert!(r.passes(0.01), "Ω = {}: {r}", q.solid_angle);
        // Far from it: area sampling.
        assert!(quad.seen_from(p + DVec3::Z * 5.0).is_none());
    }

    #[test]
    fn a_wrong_density_fails_chi2() {
        // The samples of the first triangle against the density of area sampling: rejected.
        let (p, tri) = triangles()[0];
        let st = SphericalTriangle::new(p, &tri);
        let n = (tri[1] - tri[0]).cross(tri[2] - tri[0]);
        let area = 0.5 * n.length();
        let r = Chi2Test { cos_bins: 51, phi_bins: 100, ..Default::default() }.run(
            |_, u| st.sample([u.x as f64, u.y as f64]).map(|w| w.as_vec3()),
            |w: Vec3| {
                let w = w.as_dvec3();
                match (hits(p, w, &tri), hit_plane(p, w, &tri)) {
                    (true, Some((t, _, _))) => t * t / (n.normalize().dot(w).abs() * area),
                    _ => 0.0,
                }
            },
        );
        assert!(!r.passes(0.01), "{r}");
    }

    #[test]
    fn the_map_is_area_preserving() {
        // The Jacobian of u ↦ ω is Ω everywhere: a small square of side δ in u maps to a patch
        // of solid angle Ω·δ² (its two sides' cross product), so the density is 1/Ω at every
        // point and neighbouring strata stay neighbours.
        let d = 1e-5;
        for (k, (p, tri)) in triangles().iter().enumerate() {
            let omega = solid_angle(*p, tri);
            for u in [[0.1, 0.1], [0.5, 0.5], [0.9, 0.2], [0.3, 0.95], [0.99, 0.99]] {
                let st = SphericalTriangle::new(*p, tri);
                let w = |du: f64, dv: f64| st.sample([u[0] + du, u[1] + dv]).unwrap();
                let (w0, wu, wv) = (w(0.0, 0.0), w(d, 0.0), w(0.0, d));
                let patch = (wu - w0).cross(wv - w0).length() / (d * d);
                assert!((patch / omega - 1.0).abs() < 1e-3, "triangle {k}, u {u:?}: Jacobian {patch} vs Ω {omega}");
            }
        }
    }
}
