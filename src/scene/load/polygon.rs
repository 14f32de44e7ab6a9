//! Triangulation of one polygonal face (OBJ `f`, PLY `vertex_indices` with more than three
//! corners) in the polygon's own plane: triangles and convex quads directly, everything else by
//! ear clipping (`earcutr`, the Rust port of Mapbox's earcut) after projecting the corners onto
//! the coordinate plane most parallel to the polygon (the one its Newell normal is most
//! perpendicular to). Output triangles keep the face's winding, so their normals point the way
//! the file's polygon does.
//!
//! Ear clipping a simple polygon covers exactly its area. A polygon that crosses or overlaps
//! itself has no such triangulation; it is detected (crossing edges, or the triangles' total
//! area differing from the polygon's shoelace area) and never refused, as Blender, assimp and
//! tobj load such files too:
//! 1. a non-planar polygon whose coordinate-plane projection crosses itself is ear clipped again
//!    in its best-fit plane (perpendicular to the Newell normal);
//! 2. if that is not simple either (a bow tie, a pentagram, an outline traversed twice), it is
//!    split as a fan from its first corner;
//! 3. a polygon of more than [`EAR_CLIP_MAX`] corners is a fan at once (ear clipping a
//!    self-intersecting outline is not bounded in time; a 1,000,000-corner star took > 60 s).
//!
//! Each such face is counted in [`Fallbacks`], which gives the file one warning.

use crate::math::Vec3;

/// How one face was triangulated.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Triangulated {
    /// A simple polygon in its plane: ear clipping (or a convex fan) covers exactly its area.
    Simple,
    /// Non-planar: its coordinate-plane projection crosses itself, its best-fit plane's does not.
    BestFitPlane,
    /// Not simple in any plane (crossing or overlapping itself): a fan from the first corner.
    Fan,
    /// More than [`EAR_CLIP_MAX`] corners: a fan from the first corner, unchecked.
    Huge,
}

/// Polygons of more than this many corners are split as fans without ear clipping. Ear
/// clipping grows faster than linearly (earcutr, release, one core: a 10,000-corner star 18 ms,
/// 10,000 random corners 0.22 s; at 100,000 corners 1.9 s and 21 s), so this bounds the work
/// per corner.
pub const EAR_CLIP_MAX: usize = 10_000;

/// The faces of one file that were not simple polygons, for one warning.
#[derive(Clone, Debug, Default)]
pub struct Fallbacks {
    pub best_fit: usize,
    pub fan: usize,
    pub huge: usize,
    /// Where the first such face is, after the path: `":12"` (a line) or `", face 7"`.
    pub first: Option<String>,
}

impl Fallbacks {
    /// Counts one face's outcome; `place` says where it is (see [`Fallbacks::first`]).
    pub fn count(&mut self, how: Triangulated, place: impl FnOnce() -> String) {
        let slot = match how {
            Triangulated::Simple => return,
            Triangulated::BestFitPlane => &mut self.best_fit,
            Triangulated::Fan => &mut self.fan,
            Triangulated::Huge => &mut self.huge,
        };
        *slot += 1;
        if self.first.is_none() {
            self.first = Some(place());
        }
    }

    /// The file's one warning, if any face needed a fallback.
    pub fn warning(&self, path: &std::path::Path) -> Option<String> {
        let first = self.first.as_ref()?;
        let mut parts = Vec::new();
        if self.best_fit > 0 {
            parts.push(format!("{} non-planar (triangulated in their best-fit plane)", self.best_fit));
        }
        if self.fan > 0 {
            parts.push(format!("{} crossing or overlapping themselves (split as fans)", self.fan));
        }
        if self.huge > 0 {
            parts.push(format!("{} with more than {EAR_CLIP_MAX} corners (split as fans)", self.huge));
        }
        let total = self.best_fit + self.fan + self.huge;
        Some(format!(
            "{}{first}: {total} {}: {}",
            path.display(),
            if total == 1 { "face is not a simple polygon" } else { "faces are not simple polygons" },
            parts.join(", ")
        ))
    }
}

/// Polygons up to this many corners are checked for crossing edges (O(n²)); larger ones only
/// by their area.
const CROSSING_CHECK_MAX: usize = 2048;

/// The first pair of non-adjacent edges that properly cross (each passes strictly through the
/// other's line), if any. Edges that touch at a corner or run along each other do not count:
/// a polygon with a hole joined by a bridge edge traversed both ways is fine.
fn crossing(points: &[[f64; 2]]) -> Option<(usize, usize)> {
    let n = points.len();
    let edge = |i: usize| (points[i], points[(i + 1) % n]);
    for i in 0..n {
        let (p, q) = edge(i);
        let (lo_x, hi_x) = (p[0].min(q[0]), p[0].max(q[0]));
        for j in i + 2..n {
            if i == 0 && j == n - 1 {
                continue;
            }
            let (r, s) = edge(j);
            if r[0].max(s[0]) < lo_x || r[0].min(s[0]) > hi_x {
                continue;
            }
            let (d1, d2) = (cross2(p, q, r), cross2(p, q, s));
            let (d3, d4) = (cross2(r, s, p), cross2(r, s, q));
            if d1 * d2 < 0.0 && d3 * d4 < 0.0 {
                return Some((i, j));
            }
        }
    }
    None
}

/// The polygon's Newell normal: its direction is the face normal by the right-hand rule, its
/// length twice the (vector) area. Exact for planar polygons, a best fit for others.
pub fn newell_normal(corners: &[Vec3]) -> glam::DVec3 {
    let n = corners.len();
    let mut normal = glam::DVec3::ZERO;
    let origin = corners[0].as_dvec3();
    for i in 0..n {
        let a = corners[i].as_dvec3() - origin;
        let b = corners[(i + 1) % n].as_dvec3() - origin;
        normal += a.cross(b);
    }
    normal
}

/// Projects the corners onto the coordinate plane most perpendicular to `normal`, keeping the
/// orientation: a counter-clockwise outline seen from the side `normal` points to stays
/// counter-clockwise (positive signed area).
pub fn project(corners: &[Vec3], normal: glam::DVec3) -> Vec<[f64; 2]> {
    let a = normal.abs();
    let origin = corners[0].as_dvec3();
    let (axis, flip) = if a.z >= a.x && a.z >= a.y {
        (2, normal.z < 0.0)
    } else if a.x >= a.y {
        (0, normal.x < 0.0)
    } else {
        (1, normal.y < 0.0)
    };
    corners
        .iter()
        .map(|c| {
            let p = c.as_dvec3() - origin;
            let (u, v) = match axis {
                2 => (p.x, p.y),
                0 => (p.y, p.z),
                _ => (p.z, p.x),
            };
            if flip { [v, u] } else { [u, v] }
        })
        .collect()
}

/// Twice the signed area of the 2-D triangle `a b c` (positive when counter-clockwise).
fn cross2(a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> f64 {
    (b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1])
}

/// Twice the signed (shoelace) area of a 2-D polygon.
pub fn shoelace(points: &[[f64; 2]]) -> f64 {
    let n = points.len();
    (0..n).map(|i| points[i][0] * points[(i + 1) % n][1] - points[(i + 1) % n][0] * points[i][1]).sum()
}

/// Projects the corners onto the plane perpendicular to `normal` (an orthonormal basis of
/// it), keeping the orientation as [`project`] does. The best-fit plane of a non-planar polygon.
fn project_onto_plane(corners: &[Vec3], normal: glam::DVec3) -> Vec<[f64; 2]> {
    let n = normal.normalize();
    // (u, v, n) right-handed: u × v = n, so counter-clockwise about `normal` stays positive.
    let u = n.any_orthonormal_vector();
    let v = n.cross(u);
    let origin = corners[0].as_dvec3();
    corners
        .iter()
        .map(|c| {
            let p = c.as_dvec3() - origin;
            [p.dot(u), p.dot(v)]
        })
        .collect()
}

/// Ear clips the projected outline `points`, appending triangles with its winding to `out`.
/// `false` (and nothing appended) when the outline is not simple: edges cross, or the ears
/// do not cover exactly the enclosed area.
fn ear_clip(points: &[[f64; 2]], out: &mut Vec<[u32; 3]>) -> bool {
    if points.len() <= CROSSING_CHECK_MAX && crossing(points).is_some() {
        return false;
    }
    if visits_a_point_thrice(points) {
        return false;
    }
    let flat: Vec<f64> = points.iter().flat_map(|p| *p).collect();
    let enclosed = shoelace(points).abs() / 2.0;
    let Ok(ears) = earcutr::earcut(&flat, &[], 2) else {
        return false;
    };
    if ears.len() / 3 > points.len() - 2 {
        // More triangles than a simple polygon has: not simple (never seen, but callers count
        // `n − 2 − emitted` dropped triangles).
        return false;
    }
    let mut covered = 0.0;
    let start = out.len();
    for t in ears.chunks_exact(3) {
        let (a, b, c) = (t[0], t[1], t[2]);
        let area = cross2(points[a], points[b], points[c]);
        covered += area.abs() / 2.0;
        // Keep the polygon's winding (its projection is counter-clockwise).
        out.push(if area < 0.0 { [a as u32, c as u32, b as u32] } else { [a as u32, b as u32, c as u32] });
    }
    let extent = points.iter().fold([f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY], |e, p| {
        [e[0].min(p[0]), e[1].max(p[0]), e[2].min(p[1]), e[3].max(p[1])]
    });
    let box_area = (extent[1] - extent[0]) * (extent[3] - extent[2]);
    let tolerance = 1e-6 * box_area + 1e-9 * covered.max(enclosed);
    if (covered - enclosed).abs() > tolerance || enclosed > box_area + tolerance {
        out.truncate(start);
        return false;
    }
    true
}

/// Whether some point is a corner three times or more: the outline runs through it again and
/// again (assimp's box_longline.obj goes round one square 117 times), which no simple polygon
/// does (a keyhole touches itself at two corners) and on which earcut's degenerate-case passes
/// take cubic time (that file: 2.3 s for 470 corners; found by `make fuzz`).
fn visits_a_point_thrice(points: &[[f64; 2]]) -> bool {
    let mut keys: Vec<[u64; 2]> = points.iter().map(|p| [p[0].to_bits(), p[1].to_bits()]).collect();
    keys.sort_unstable();
    keys.windows(3).any(|w| w[0] == w[2])
}

/// The fan `(0, i, i + 1)` over all corners, appended to `out`.
fn fan(n: usize, out: &mut Vec<[u32; 3]>) {
    out.extend((1..n as u32 - 1).map(|i| [0, i, i + 1]));
}

/// Triangulates the polygon `corners` (at least three), appending index triples into `corners`
/// to `out` with the polygon's winding, and says how (see the module doc: never refused).
/// Emits at most `corners.len() − 2` triangles; fewer when ear clipping removes collinear or
/// repeated corners (the missing triangles have zero area). Triangles of zero area may be among
/// those emitted: the caller drops and counts them.
pub fn triangulate(corners: &[Vec3], out: &mut Vec<[u32; 3]>) -> Triangulated {
    let n = corners.len();
    debug_assert!(n >= 3);
    if n == 3 {
        out.push([0, 1, 2]);
        return Triangulated::Simple;
    }
    if n > EAR_CLIP_MAX {
        fan(n, out);
        return Triangulated::Huge;
    }
    let mut normal = newell_normal(corners);
    if !(normal.length_squared() > 0.0) {
        // Zero net area: a figure eight whose lobes cancel, or all corners on one line. The
        // largest fan triangle's normal gives a plane, if there is one.
        let c0 = corners[0].as_dvec3();
        normal = (1..n - 1)
            .map(|i| (corners[i].as_dvec3() - c0).cross(corners[i + 1].as_dvec3() - c0))
            .max_by(|a, b| a.length_squared().total_cmp(&b.length_squared()))
            .unwrap_or(glam::DVec3::ZERO);
        if !(normal.length_squared() > 0.0) {
            // All corners on one line (or one point): every triangle has zero area.
            fan(n, out);
            return Triangulated::Simple;
        }
    }
    let points = project(corners, normal);
    if n == 4 && (0..4).all(|i| cross2(points[i], points[(i + 1) % 4], points[(i + 2) % 4]) > 0.0) {
        // A convex quad, the common case: a fan is exact.
        fan(4, out);
        return Triangulated::Simple;
    }
    if ear_clip(&points, out) {
        return Triangulated::Simple;
    }
    // A planar polygon is simple in every projection or in none; a non-planar one may be simple
    // in its best-fit plane when the coordinate plane folded it over itself.
    let normal = newell_normal(corners);
    if normal.is_finite() && normal.length_squared() > 0.0 && ear_clip(&project_onto_plane(corners, normal), out) {
        return Triangulated::BestFitPlane;
    }
    fan(n, out);
    Triangulated::Fan
}

#[cfg(test)]
mod tests {
    use super::*;

    fn area3(c: &[Vec3], t: [u32; 3]) -> f64 {
        let [a, b, d] = t.map(|i| c[i as usize].as_dvec3());
        (b - a).cross(d - a).length() / 2.0
    }

    #[test]
    fn convex_quad_is_a_fan_with_the_faces_winding() {
        let c = [Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y];
        let mut out = vec![];
        assert_eq!(triangulate(&c, &mut out), Triangulated::Simple);
        assert_eq!(out, vec![[0, 1, 2], [0, 2, 3]]);
        // The same quad seen from below (clockwise in xy): still the face's own winding.
        let r = [c[0], c[3], c[2], c[1]];
        let mut out = vec![];
        triangulate(&r, &mut out);
        for t in &out {
            let [a, b, d] = t.map(|i| r[i as usize]);
            assert!((b - a).cross(d - a).z < 0.0);
        }
    }

    #[test]
    fn concave_l_shape_covers_its_area_in_any_plane() {
        // An L of area 3 in the xy plane, then the same rotated into a tilted plane.
        let l = [(0.0, 0.0), (2.0, 0.0), (2.0, 1.0), (1.0, 1.0), (1.0, 2.0), (0.0, 2.0)];
        let rot = glam::Quat::from_axis_angle(Vec3::new(1.0, 2.0, 0.5).normalize(), 1.1);
        for q in [glam::Quat::IDENTITY, rot] {
            let c: Vec<Vec3> = l.iter().map(|&(x, y)| q * Vec3::new(x, y, 0.0)).collect();
            let mut out = vec![];
            assert_eq!(triangulate(&c, &mut out), Triangulated::Simple);
            assert_eq!(out.len(), 4);
            let total: f64 = out.iter().map(|&t| area3(&c, t)).sum();
            assert!((total - 3.0).abs() < 1e-5, "{total}");
            let n = q * Vec3::Z;
            for &t in &out {
                let [a, b, d] = t.map(|i| c[i as usize]);
                assert!((b - a).cross(d - a).dot(n) > 0.0, "winding kept");
            }
        }
    }

    #[test]
    fn an_outline_through_one_point_thrice_is_not_ear_clipped() {
        // The unit square traversed 117 times (box_longline.obj's face): a fan, found by the
        // multiplicity check before earcut (which took 2.3 s on it).
        let square = [Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y];
        let c: Vec<Vec3> = square.iter().copied().cycle().take(4 * 117 + 2).collect();
        let mut out = vec![];
        assert_eq!(triangulate(&c, &mut out), Triangulated::Fan);
        assert_eq!(out.len(), c.len() - 2);
        // A keyhole (a square with a square hole, bridged) touches itself at two corners only:
        // still ear clipped, covering the ring's area 16 − 4 = 12.
        let p = |x: f32, y: f32| Vec3::new(x, y, 0.0);
        let keyhole = [
            p(0.0, 0.0),
            p(4.0, 0.0),
            p(4.0, 4.0),
            p(0.0, 4.0),
            p(0.0, 0.0),
            p(1.0, 1.0),
            p(1.0, 3.0),
            p(3.0, 3.0),
            p(3.0, 1.0),
            p(1.0, 1.0),
        ];
        let mut out = vec![];
        assert_eq!(triangulate(&keyhole, &mut out), Triangulated::Simple);
        let total: f64 = out.iter().map(|&t| area3(&keyhole, t)).sum();
        assert!((total - 12.0).abs() < 1e-9, "{total}");
    }

    #[test]
    fn self_crossing_outlines_become_fans() {
        // A square traversed three times (assimp's box_longline.obj does this 234 times).
        let sq = [Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y];
        for k in [2, 3, 234] {
            let c: Vec<Vec3> = sq.iter().cycle().take(4 * k).copied().collect();
            let mut out = vec![];
            assert_eq!(triangulate(&c, &mut out), Triangulated::Fan, "{k}");
            assert_eq!(out.len(), 4 * k - 2);
            assert_eq!(out[1], [0, 2, 3]);
        }
        // A bow tie, and a pentagram: fans from corner 0 with the file's winding.
        let bow = [Vec3::ZERO, Vec3::new(1.0, 1.0, 0.0), Vec3::X, Vec3::Y];
        let mut out = vec![];
        assert_eq!(triangulate(&bow, &mut out), Triangulated::Fan);
        assert_eq!(out, vec![[0, 1, 2], [0, 2, 3]]);
        let star: Vec<Vec3> = (0..5)
            .map(|i| {
                let phi = std::f32::consts::TAU * (2 * i) as f32 / 5.0;
                Vec3::new(phi.cos(), phi.sin(), 0.0)
            })
            .collect();
        let mut out = vec![];
        assert_eq!(triangulate(&star, &mut out), Triangulated::Fan);
        assert_eq!(out, vec![[0, 1, 2], [0, 2, 3], [0, 3, 4]]);
        // A square with a square hole joined by a bridge traversed both ways is fine: area 3.
        let p = |x: f32, y: f32| Vec3::new(x, y, 0.0);
        let bridged = [
            p(0.0, 0.0),
            p(2.0, 0.0),
            p(2.0, 2.0),
            p(0.0, 2.0),
            p(0.0, 0.0),
            p(0.5, 0.5),
            p(0.5, 1.5),
            p(1.5, 1.5),
            p(1.5, 0.5),
            p(0.5, 0.5),
        ];
        let mut out = vec![];
        assert_eq!(triangulate(&bridged, &mut out), Triangulated::Simple);
        let total: f64 = out.iter().map(|&t| area3(&bridged, t)).sum();
        assert!((total - 3.0).abs() < 1e-6, "{total}");
    }

    #[test]
    fn non_planar_quad_folded_by_its_axis_projection_uses_its_best_fit_plane() {
        // Newell normal (-4, -9, -6): projected onto zx, edges 1 and 3 cross; in the plane
        // perpendicular to the normal the quad is convex.
        let c = [
            Vec3::new(-1.0, 2.0, 1.0),
            Vec3::new(2.0, -1.0, -2.0),
            Vec3::new(2.0, 0.0, 2.0),
            Vec3::new(-1.0, -1.0, 0.0),
        ];
        assert_eq!(newell_normal(&c), glam::DVec3::new(-4.0, -9.0, -6.0));
        assert_eq!(crossing(&project(&c, newell_normal(&c))), Some((0, 2)));
        let mut out = vec![];
        assert_eq!(triangulate(&c, &mut out), Triangulated::BestFitPlane);
        assert_eq!(out.len(), 2);
        // Both triangles face the way the polygon's normal does.
        let n = newell_normal(&c);
        for &t in &out {
            let [a, b, d] = t.map(|i| c[i as usize].as_dvec3());
            assert!((b - a).cross(d - a).dot(n) > 0.0, "{t:?}");
        }
    }

    #[test]
    fn huge_polygons_are_fans_without_ear_clipping() {
        // A star of EAR_CLIP_MAX + 2 corners (alternating radii): n − 2 triangles, at once.
        let n = EAR_CLIP_MAX + 2;
        let c: Vec<Vec3> = (0..n)
            .map(|i| {
                let phi = std::f32::consts::TAU * i as f32 / n as f32;
                let r = if i % 2 == 0 { 1.0 } else { 0.5 };
                Vec3::new(r * phi.cos(), r * phi.sin(), 0.0)
            })
            .collect();
        let mut out = vec![];
        assert_eq!(triangulate(&c, &mut out), Triangulated::Huge);
        assert_eq!(out.len(), n - 2);
        assert_eq!(out[n - 3], [0, n as u32 - 2, n as u32 - 1]);
    }

    #[test]
    fn fallbacks_give_one_warning_with_counts() {
        let mut f = Fallbacks::default();
        assert_eq!(f.warning(std::path::Path::new("m.obj")), None);
        f.count(Triangulated::Simple, || unreachable!());
        f.count(Triangulated::Fan, || ":12".into());
        f.count(Triangulated::BestFitPlane, || ":40".into());
        f.count(Triangulated::Fan, || ":41".into());
        assert_eq!(
            f.warning(std::path::Path::new("m.obj")).unwrap(),
            "m.obj:12: 3 faces are not simple polygons: 1 non-planar (triangulated in their best-fit plane), \
             2 crossing or overlapping themselves (split as fans)"
        );
    }

    #[test]
    fn collinear_corners_give_at_most_n_minus_2_triangles() {
        let line: Vec<Vec3> = (0..5).map(|i| Vec3::new(i as f32, 0.0, 0.0)).collect();
        let mut out = vec![];
        triangulate(&line, &mut out);
        assert_eq!(out.len(), 3);
        // A square with a corner repeated and a midpoint on an edge.
        let c = [Vec3::ZERO, Vec3::X, Vec3::X, Vec3::new(1.0, 0.5, 0.0), Vec3::new(1.0, 1.0, 0.0), Vec3::Y];
        let mut out = vec![];
        assert_eq!(triangulate(&c, &mut out), Triangulated::Simple);
        assert!(out.len() <= 4);
        let total: f64 = out.iter().map(|&t| area3(&c, t)).sum();
        assert!((total - 1.0).abs() < 1e-6);
    }

    #[test]
    fn random_star_polygons_never_panic_and_cover_their_area() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(3);
        for _ in 0..2000 {
            let n = rng.random_range(3..40);
            // Star-shaped about the origin: simple, usually concave.
            let c: Vec<Vec3> = (0..n)
                .map(|i| {
                    let phi = std::f32::consts::TAU * (i as f32 + rng.random_range(0.0..0.9)) / n as f32;
                    let r = rng.random_range(0.2..1.0);
                    Vec3::new(r * phi.cos(), r * phi.sin(), 0.0)
                })
                .collect();
            let mut out = vec![];
            assert_eq!(triangulate(&c, &mut out), Triangulated::Simple);
            let pts = project(&c, newell_normal(&c));
            let total: f64 = out.iter().map(|&t| area3(&c, t)).sum();
            assert!((total - shoelace(&pts).abs() / 2.0).abs() < 1e-5);
            // Garbage never panics.
            let g: Vec<Vec3> =
                (0..n).map(|_| Vec3::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0), 0.0)).collect();
            let _ = triangulate(&g, &mut vec![]);
        }
    }
}
