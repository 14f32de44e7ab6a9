//! Cross-checking two backends: trace the same rays through both and account for every
//! difference. `strahl crosscheck` prints a [`Report`] per kind of ray and fails on any
//! unexplained disagreement.
//!
//! Embree and the native BVH intersect triangles with different f32 algorithms, so they may
//! disagree where rounding decides: a ray that passes within a few ulps of a triangle's edge
//! can hit it in one backend and its neighbour (or nothing, at a silhouette) in the other.
//! Such disagreements are *explained*; anything else is a bug in one of them.
//!
//! # The tolerance
//! Both algorithms decide inside/outside from the corners' positions relative to the ray
//! origin, `p − e`, computed in f32: each coordinate carries a rounding error of the order of
//! `ε·M`, where `ε = 2⁻²⁴` is f32's unit roundoff (half an ulp of 1) and
//! `M = max(|e|∞, |p_i|∞, |p_i − e|∞)` the largest magnitude involved; the edge tests that
//! follow (products and differences of those coordinates) add a few more. Seen along the ray,
//! the backends' pictures of the triangle therefore differ by some `c·ε·M`, and a ray closer
//! than that to an edge may be decided either way. We accept a disagreement on a triangle when
//! the ray passes within [`EDGE_MARGIN`]`·ε·M` of one of its edges, measured in the plane
//! perpendicular to the ray (where both algorithms make the decision), computed in f64 from the
//! scene's vertices. In barycentric terms: the smallest barycentric coordinate of the ray's
//! crossing is below `EDGE_MARGIN·ε·M / h`, `h` being the triangle's height over that edge as
//! seen along the ray. On a sphere, the same margin applies to `|b − r|`, the impact
//! parameter's distance from the silhouette (both backends call the same quadratic, so spheres
//! should never disagree on their own).
//!
//! [`EDGE_MARGIN`] is 16. Rounding analysis gives a few `ε·M` per algorithm: `p − e` rounds
//! once (1), the shear or cross products add a product and a difference (about 3), and the
//! edge function's own products and difference about 4 more relative to its terms; the two
//! algorithms' errors add, so below about 16 together. Measured on a million rays aimed
//! straight at the Stanford bunny's edges (the hardest case, with about 1,900 disagreements
//! and 60,000 ties; `tests/crosscheck.rs`), the worst explained disagreement lies 1.2 `ε·M`
//! from an edge and the worst tie 1.5: 16 is the analytic bound, ten times the measurement,
//! and about 10⁻⁶ of the scene's size, far below anything a rendering bug could hide in.
//!
//! The same rounding decides whether a ray that *starts* on a surface (a random origin that
//! happens to lie within rounding of a triangle; a secondary ray's origin, offset too little)
//! meets that surface just after `tnear` or just before it: each backend computes the
//! origin's side of the plane from `p − e` (and, for an instance, from the origin moved into
//! the prototype's space by its own rounding of `M⁻¹`). So a disagreement is explained as well
//! when the nearer hit's surface passes within [`EDGE_MARGIN`]`·ε·M` of the ray's start
//! `e + tnear·d`, measured perpendicular to the triangle's plane (for a sphere, from its
//! surface). On the scale scene (coordinates up to 56 m) one random ray in a million starts
//! 3.2 µm (0.6 `ε·M`) from a blob that Embree reports at `t = 3.2·10⁻⁶` and the native BVH
//! puts behind the origin.
//!
//! A different primitive at the same `t` (within the same margin along the ray, stretched by
//! the obliquity of the hit) is fine: a ray through a shared edge or vertex, or coincident
//! surfaces (the res2 Stanford dragon has 1,489 duplicated triangles, hit in either copy).

use std::fmt;

use glam::DVec3;
use rayon::prelude::*;

use crate::accel::{Accel, Hit, TraceError};
use crate::integrator::RenderError;
use crate::math::Ray;
use crate::scene::{GeomKind, Scene};
use crate::verify::workload::{self, RayKind};

/// Half an ulp of 1 in f32 (the unit roundoff).
const EPS: f64 = f32::EPSILON as f64 / 2.0;

/// How close to an edge or silhouette, in units of `ε·M` (see the module docs), a ray must pass
/// for a disagreement to count as explained.
pub const EDGE_MARGIN: f64 = 16.0;

/// One ray on which the backends differ, with the measure that explains it (or not).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Disagreement {
    pub index: usize,
    pub ray: Ray,
    pub a: Option<Hit>,
    pub b: Option<Hit>,
    /// The ray's distance from the nearest edge or silhouette of the primitive one backend hit
    /// and the other did not, in units of `ε·M`; `∞` where no edge explains it (planes).
    pub margin: f64,
}

impl Disagreement {
    pub fn explained(&self) -> bool {
        self.margin <= EDGE_MARGIN
    }
}

/// Quantiles of the relative difference `|t_a − t_b| / t_b`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Quantiles {
    pub median: f64,
    pub p999: f64,
    pub max: f64,
}

/// What tracing the same rays through two backends found.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Report {
    pub a: String,
    pub b: String,
    pub rays: usize,
    pub both_hit: usize,
    pub both_miss: usize,
    /// Hit in `a` only / in `b` only.
    pub only_a: usize,
    pub only_b: usize,
    /// Both hit the same `(geom_id, prim_id)`.
    pub same_prim: usize,
    /// Both hit, different primitives at the same `t` (shared edges, coincident surfaces).
    pub other_prim_same_t: usize,
    /// Both hit, different primitives at different `t`: one backend missed the nearer one.
    pub other_prim: usize,
    /// Hit/miss and different-primitive disagreements the tolerance explains, and the rest.
    pub explained: usize,
    pub unexplained: usize,
    /// Of the unexplained ones, the hit/miss disagreements (the rest hit other primitives at
    /// another `t`).
    pub hit_miss_unexplained: usize,
    /// The largest margin among explained disagreements (units of `ε·M`).
    pub worst_margin: f64,
    /// Among hits on different primitives at the same `t`, the largest distance of the ray
    /// from an edge of either (units of `ε·M`): how close to an edge such ties happen (large
    /// only where surfaces coincide).
    pub worst_tie_margin: f64,
    /// `|Δt|/t` over the rays where both hit the same primitive.
    pub dt: Quantiles,
    /// The first unexplained disagreements, for diagnosis.
    pub unexplained_examples: Vec<Disagreement>,
}

impl Report {
    /// Hit/miss disagreements.
    pub fn hit_miss(&self) -> usize {
        self.only_a + self.only_b
    }

    /// Hits on other primitives at another `t` that the tolerance does not explain.
    pub fn other_prim_unexplained(&self) -> usize {
        self.unexplained - self.hit_miss_unexplained
    }
}

/// The tolerance, in words, for reports: see the module docs.
pub fn tolerance() -> String {
    format!(
        "a disagreement is explained when the ray passes within {EDGE_MARGIN} ε·M of an edge (or a sphere's \
         silhouette) of the primitive hit, ε = 2^-24 and M the largest coordinate involved: there rounding in \
         either backend's f32 test may decide either way"
    )
}

impl fmt::Display for Report {
    /// One line per count: `label  count  (detail)`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let pct = |n: usize, of: usize| 100.0 * n as f64 / of.max(1) as f64;
        let (a, b) = (&self.a, &self.b);
        let split =
            |unexplained: usize, all: usize| format!("{} explained, {unexplained} unexplained", all - unexplained);
        writeln!(f, "{a} vs {b}")?;
        writeln!(f, "  rays                {:>10}", self.rays)?;
        writeln!(f, "  both hit            {:>10}  ({:.2} %)", self.both_hit, pct(self.both_hit, self.rays))?;
        writeln!(f, "  both miss           {:>10}  ({:.2} %)", self.both_miss, pct(self.both_miss, self.rays))?;
        writeln!(
            f,
            "  hit/miss            {:>10}  ({} only {a}, {} only {b}; {})",
            self.hit_miss(),
            self.only_a,
            self.only_b,
            split(self.hit_miss_unexplained, self.hit_miss())
        )?;
        writeln!(
            f,
            "  same (geom, prim)   {:>10}  ({:.4} % of both hit)",
            self.same_prim,
            pct(self.same_prim, self.both_hit)
        )?;
        writeln!(
            f,
            "  other prim, same t  {:>10}  (shared edges, coincident surfaces; farthest {:.1} ε·M from an edge)",
            self.other_prim_same_t, self.worst_tie_margin
        )?;
        writeln!(
            f,
            "  other prim, other t {:>10}  ({})",
            self.other_prim,
            split(self.other_prim_unexplained(), self.other_prim)
        )?;
        writeln!(
            f,
            "  |dt|/t              median {:.2e}, p99.9 {:.2e}, max {:.2e} (same prim)",
            self.dt.median, self.dt.p999, self.dt.max
        )?;
        writeln!(
            f,
            "  explained           {:>10}  (within {EDGE_MARGIN} ε·M of an edge or the ray's start; the farthest {:.1})",
            self.explained, self.worst_margin
        )?;
        write!(f, "  unexplained         {:>10}", self.unexplained)
    }
}

/// What happened to one ray.
enum Outcome {
    BothMiss,
    SamePrim(f64),
    OtherPrimSameT(f64),
    Differ(Disagreement),
}

/// Traces `rays` through `a` and `b` (in parallel on the current rayon pool) and compares
/// every hit.
pub fn compare<A: Accel, B: Accel>(scene: &Scene, a: &A, b: &B, rays: &[Ray]) -> Result<Report, TraceError> {
    let outcomes: Vec<Outcome> = rays
        .par_iter()
        .enumerate()
        .map(|(index, ray)| Ok(classify(scene, index, ray, a.intersect(ray)?, b.intersect(ray)?)))
        .collect::<Result<_, TraceError>>()?;
    let mut report = Report { a: a.name().into(), b: b.name().into(), rays: rays.len(), ..Default::default() };
    let mut dts = Vec::with_capacity(rays.len());
    for o in outcomes {
        match o {
            Outcome::BothMiss => report.both_miss += 1,
            Outcome::SamePrim(dt) => {
                report.both_hit += 1;
                report.same_prim += 1;
                dts.push(dt);
            }
            Outcome::OtherPrimSameT(margin) => {
                report.both_hit += 1;
                report.other_prim_same_t += 1;
                report.worst_tie_margin = report.worst_tie_margin.max(margin);
            }
            Outcome::Differ(d) => {
                match (d.a, d.b) {
                    (Some(_), Some(_)) => {
                        report.both_hit += 1;
                        report.other_prim += 1;
                    }
                    (Some(_), None) => report.only_a += 1,
                    _ => report.only_b += 1,
                }
                if d.explained() {
                    report.explained += 1;
                    report.worst_margin = report.worst_margin.max(d.margin);
                } else {
                    report.unexplained += 1;
                    report.hit_miss_unexplained += usize::from(d.a.is_none() || d.b.is_none());
                    if report.unexplained_examples.len() < 10 {
                        report.unexplained_examples.push(d);
                    }
                }
            }
        }
    }
    report.dt = quantiles(&mut dts);
    Ok(report)
}

/// Generates `n` rays of `kind` through `scene` (seeded; secondary rays start from `a`'s
/// primary hits, see [`workload::rays`]) and compares `a` and `b` on them.
pub fn run<A: Accel, B: Accel>(
    scene: &Scene,
    a: &A,
    b: &B,
    kind: RayKind,
    n: usize,
    seed: u64,
) -> Result<Report, RenderError> {
    // The rays are made from the scene's bounds and camera: they must be inside the range
    // both backends trace (a sphere of radius 3e38 has no finite bounds to draw rays in).
    if let Some((object, problem)) = crate::scene::magnitude::problem(scene) {
        return Err(RenderError::InvalidScene(format!("{object}: {problem}")));
    }
    let rays = workload::rays(scene, kind, n, seed, a)?;
    Ok(compare(scene, a, b, &rays)?)
}

fn quantiles(v: &mut [f64]) -> Quantiles {
    if v.is_empty() {
        return Quantiles::default();
    }
    v.sort_unstable_by(f64::total_cmp);
    let at = |q: f64| v[((v.len() - 1) as f64 * q).round() as usize];
    Quantiles { median: at(0.5), p999: at(0.999), max: v[v.len() - 1] }
}

fn classify(scene: &Scene, index: usize, ray: &Ray, a: Option<Hit>, b: Option<Hit>) -> Outcome {
    let differ = |nearer: &Hit| {
        let margin = margin(scene, ray, nearer).min(start_margin(scene, ray, nearer));
        Outcome::Differ(Disagreement { index, ray: *ray, a, b, margin })
    };
    match (&a, &b) {
        (None, None) => Outcome::BothMiss,
        (Some(h), None) | (None, Some(h)) => differ(h),
        (Some(ha), Some(hb)) => {
            let dt = (ha.t as f64 - hb.t as f64).abs();
            if (ha.geom_id, ha.prim_id) == (hb.geom_id, hb.prim_id) {
                Outcome::SamePrim(dt / (hb.t as f64).abs())
            } else if dt <= same_t_tolerance(scene, ray, ha).max(same_t_tolerance(scene, ray, hb)) {
                Outcome::OtherPrimSameT(margin(scene, ray, ha).min(margin(scene, ray, hb)))
            } else {
                differ(if ha.t < hb.t { ha } else { hb })
            }
        }
    }
}

/// The largest coordinate magnitude the backends compute with for this ray and these points.
fn magnitude(org: DVec3, points: &[DVec3]) -> f64 {
    points.iter().fold(org.abs().max_element(), |m, p| m.max(p.abs().max_element()).max((*p - org).abs().max_element()))
}

/// The ray's distance from the nearest edge or silhouette of the primitive `hit` names, in
/// units of `ε·M`.
fn margin(scene: &Scene, ray: &Ray, hit: &Hit) -> f64 {
    let (org, dir) = (ray.org.as_dvec3(), ray.dir.as_dvec3().normalize());
    match scene.geom_kind(hit.geom_id) {
        kind @ (GeomKind::Mesh(_) | GeomKind::Instance(_)) => {
            let p = scene.world_triangle(kind, hit.prim_id as usize).unwrap_or_default().map(|p| p.as_dvec3());
            edge_distance(org, dir, p) / (EPS * magnitude(org, &p))
        }
        GeomKind::Spheres => {
            let s = &scene.spheres[hit.prim_id as usize];
            let c = s.center.as_dvec3();
            let r = s.radius as f64;
            let impact = dir.cross(org - c).length();
            let m = magnitude(org, &[c]).max(c.abs().max_element() + r);
            (impact - r).abs() / (EPS * m)
        }
        GeomKind::Planes => f64::INFINITY,
    }
}

/// The distance of the ray's start `e + tnear·d` from the surface `hit` lies on, in units of
/// `ε·M`: perpendicular to a triangle's plane, or from a sphere's surface; `∞` on planes
/// (both backends call the same plane routine).
fn start_margin(scene: &Scene, ray: &Ray, hit: &Hit) -> f64 {
    let start = ray.org.as_dvec3() + ray.tnear as f64 * ray.dir.as_dvec3();
    match scene.geom_kind(hit.geom_id) {
        kind @ (GeomKind::Mesh(_) | GeomKind::Instance(_)) => {
            let p = scene.world_triangle(kind, hit.prim_id as usize).unwrap_or_default().map(|p| p.as_dvec3());
            let n = (p[1] - p[0]).cross(p[2] - p[0]).normalize_or_zero();
            if n == DVec3::ZERO {
                return f64::INFINITY;
            }
            (start - p[0]).dot(n).abs() / (EPS * magnitude(ray.org.as_dvec3(), &p))
        }
        GeomKind::Spheres => {
            let s = &scene.spheres[hit.prim_id as usize];
            let c = s.center.as_dvec3();
            let m = magnitude(ray.org.as_dvec3(), &[c]).max(c.abs().max_element() + s.radius as f64);
            ((start - c).length() - s.radius as f64).abs() / (EPS * m)
        }
        GeomKind::Planes => f64::INFINITY,
    }
}

/// The distance from the ray (through `org` along unit `dir`) to the nearest of the triangle's
/// edge lines, measured in the plane perpendicular to the ray.
fn edge_distance(org: DVec3, dir: DVec3, p: [DVec3; 3]) -> f64 {
    let (u, v) = dir.any_orthonormal_pair();
    let q = p.map(|p| glam::DVec2::new((p - org).dot(u), (p - org).dot(v)));
    (0..3)
        .map(|i| {
            let (a, b) = (q[(i + 1) % 3], q[(i + 2) % 3]);
            let edge = b - a;
            let len = edge.length();
            // Distance from the origin (the ray) to the line through a and b.
            if len == 0.0 { a.length() } else { edge.perp_dot(-a).abs() / len }
        })
        .fold(f64::INFINITY, f64::min)
}

/// How far apart two hits at "the same t" may be: the edge margin along the ray, stretched by
/// the hit's obliquity `|d|·|n| / |d·n|` (capped at 1000, a ray grazing within 0.06°).
fn same_t_tolerance(scene: &Scene, ray: &Ray, hit: &Hit) -> f64 {
    let org = ray.org.as_dvec3();
    let pts: Vec<DVec3> = match scene.geom_kind(hit.geom_id) {
        kind @ (GeomKind::Mesh(_) | GeomKind::Instance(_)) => {
            scene.world_triangle(kind, hit.prim_id as usize).unwrap_or_default().map(|p| p.as_dvec3()).to_vec()
        }
        GeomKind::Spheres => vec![scene.spheres[hit.prim_id as usize].center.as_dvec3()],
        GeomKind::Planes => vec![ray.at(hit.t).as_dvec3()],
    };
    let n = hit.ng.as_dvec3();
    let d = ray.dir.as_dvec3();
    let obliquity = (d.length() * n.length() / d.dot(n).abs()).min(1000.0);
    EDGE_MARGIN * EPS * magnitude(org, &pts) * obliquity / d.length()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Vec3;
    use crate::scene::Mesh;

    #[test]
    fn edge_distance_is_measured_across_the_ray() {
        // Triangle in z = 0 with an edge along x = 0; a ray straight down at x = 0.25 is 0.25
        // from that edge and farther from the others.
        let p = [DVec3::new(0.0, -1.0, 0.0), DVec3::new(0.0, 1.0, 0.0), DVec3::new(2.0, 0.0, 0.0)];
        let d = edge_distance(DVec3::new(0.25, 0.0, 5.0), DVec3::new(0.0, 0.0, -1.0), p);
        assert!((d - 0.25).abs() < 1e-12, "{d}");
        // Seen at 60° from the normal, across the edge: the projected distance shrinks by cos 60°.
        let dir = DVec3::new(-(60f64.to_radians().sin()), 0.0, -(60f64.to_radians().cos()));
        let d = edge_distance(DVec3::new(0.25, 0.0, 0.0) - 5.0 * dir, dir, p);
        assert!((d - 0.125).abs() < 1e-12, "{d}");
    }

    #[test]
    fn classification_of_hits() {
        let mut scene = Scene::default();
        scene.meshes.push(Mesh {
            name: "quad".into(),
            positions: vec![Vec3::new(0.0, 0.0, 0.0), Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.0, 1.0, 0.0), Vec3::ONE],
            indices: vec![[0, 1, 2], [3, 2, 1]],
            ..Default::default()
        });
        scene.meshes[0].positions[3].z = 0.0;
        let hit = |t: f32, prim: u32| Some(Hit { t, ng: Vec3::Z, u: 0.0, v: 0.0, geom_id: 0, prim_id: prim });
        // On the diagonal: different triangles at the same t.
        let ray = Ray::new(Vec3::new(0.5, 0.5, 1.0), -Vec3::Z);
        assert!(matches!(classify(&scene, 0, &ray, hit(1.0, 0), hit(1.0, 1)), Outcome::OtherPrimSameT(_)));
        assert!(matches!(classify(&scene, 0, &ray, hit(1.0, 0), hit(1.0, 0)), Outcome::SamePrim(0.0)));
        // A miss within a few ulps of the outer edge x = 0: explained.
        let ray = Ray::new(Vec3::new(1e-8, 0.5, 1.0), -Vec3::Z);
        let Outcome::Differ(d) = classify(&scene, 0, &ray, hit(1.0, 0), None) else { panic!() };
        assert!(d.explained(), "margin {}", d.margin);
        // The same far from every edge: unexplained.
        let ray = Ray::new(Vec3::new(0.2, 0.3, 1.0), -Vec3::Z);
        let Outcome::Differ(d) = classify(&scene, 0, &ray, None, hit(1.0, 0)) else { panic!() };
        assert!(!d.explained() && d.margin > 1e5, "margin {}", d.margin);
        // A ray starting on the quad (within rounding: 1e-7 above it, M = 1): explained, one
        // backend may put its start behind the surface. 1e-5 above it is 168 ε·M: not.
        for (z, explained) in [(1e-7, true), (1e-5, false)] {
            let ray = Ray::new(Vec3::new(0.2, 0.3, z), -Vec3::Z);
            let Outcome::Differ(d) = classify(&scene, 0, &ray, None, hit(z, 0)) else { panic!() };
            assert_eq!(d.explained(), explained, "z {z}: margin {}", d.margin);
        }
        // Measured from the ray's start e + tnear·d, not from e.
        let ray = Ray::segment(Vec3::new(0.2, 0.3, 2.0), -Vec3::Z, 2.0 - 1e-7, 10.0);
        let Outcome::Differ(d) = classify(&scene, 0, &ray, hit(2.0, 0), None) else { panic!() };
        assert!(d.explained() && d.margin < 2.0, "margin {}", d.margin);
    }

    #[test]
    fn quantiles_of_a_known_list() {
        let mut v: Vec<f64> = (0..=1000).map(|i| i as f64).collect();
        v.reverse();
        assert_eq!(quantiles(&mut v), Quantiles { median: 500.0, p999: 999.0, max: 1000.0 });
        assert_eq!(quantiles(&mut []), Quantiles::default());
    }
}
