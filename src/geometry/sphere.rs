//! Ray–sphere intersection: the lecture's quadratic in a numerically stable form.

use crate::math::{Aabb, Vec3};

/// A sphere of `radius` around `center`, with the index of its material.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sphere {
    pub center: Vec3,
    pub radius: f32,
    pub material: u32,
}

impl Sphere {
    pub fn bounds(&self) -> Aabb {
        Aabb::new(self.center - Vec3::splat(self.radius), self.center + Vec3::splat(self.radius))
    }

    /// Why this sphere cannot be traced, if it cannot: a radius ≤ 0 or non-finite data.
    pub fn problem(&self) -> Option<String> {
        if !self.center.is_finite() {
            Some(format!("centre {} is not finite", self.center))
        } else if !self.radius.is_finite() {
            Some(format!("radius {} is not finite", self.radius))
        } else if self.radius <= 0.0 {
            Some(format!("radius {} must be > 0", self.radius))
        } else {
            None
        }
    }
}

/// The ray parameter where `e + t·d` meets the sphere `|p − c| = r` inside `(tnear, tfar)`.
///
/// The lecture's quadratic `a t² + b t + c = 0` with `a = d·d`, `b = 2 d·(e−c)`,
/// `c = (e−c)·(e−c) − r²`. No discriminant → no hit; otherwise the smaller root inside
/// `(tnear, tfar)` wins, else the larger one (a ray starting inside the sphere hits its far side).
///
/// Two rewrites keep it accurate in f32:
/// - The textbook `(−b ± √(b²−4ac)) / 2a` subtracts two nearly equal numbers for one root when
///   `b² ≫ 4ac` (a small sphere far away), losing most of its digits. Instead
///   `q = −(b + sign(b)·√(b²−4ac)) / 2` adds numbers of equal sign, and the roots are `q/a` and
///   `c/q` (their product is `c/a`), both without cancellation.
/// - `b² − 4ac` itself cancels when the ray passes far from a large or distant sphere. By
///   Lagrange's identity it equals `4 (a r² − |d × (e−c)|²)`: the cross product measures the
///   ray's distance from the centre directly (Haines et al., "Precision Improvements for
///   Ray/Sphere Intersection", Ray Tracing Gems, ch. 7).
#[inline]
pub fn intersect(org: Vec3, dir: Vec3, center: Vec3, radius: f32, tnear: f32, tfar: f32) -> Option<f32> {
    let f = org - center; // e − c
    let a = dir.dot(dir);
    let b = 2.0 * dir.dot(f);
    let c = f.dot(f) - radius * radius;
    let quarter_disc = a * radius * radius - dir.cross(f).length_squared(); // (b² − 4ac) / 4
    if !(quarter_disc >= 0.0) {
        return None; // also rejects NaN from a degenerate direction
    }
    let sqrt_disc = 2.0 * quarter_disc.sqrt();
    let q = -0.5 * (b + sqrt_disc.copysign(b));
    let (t0, t1) = if q == 0.0 {
        (0.0, 0.0) // b = 0 and a tangent ray: the double root is t = 0
    } else {
        let (r0, r1) = (q / a, c / q);
        if r0 <= r1 { (r0, r1) } else { (r1, r0) }
    };
    if t0 > tnear && t0 < tfar {
        Some(t0)
    } else if t1 > tnear && t1 < tfar {
        Some(t1)
    } else {
        None
    }
}

/// Spherical coordinates of the unit outward normal `n`, each in [0, 1]:
/// `u` around the y axis from −z, `v` from the south pole (−y) to the north pole (+y).
#[inline]
pub fn uv(n: Vec3) -> (f32, f32) {
    let u = 0.5 + n.x.atan2(-n.z) * (0.5 / std::f32::consts::PI);
    let v = 1.0 - n.y.clamp(-1.0, 1.0).acos() * std::f32::consts::FRAC_1_PI;
    (u, v)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn hit(org: [f32; 3], dir: [f32; 3]) -> Option<f32> {
        intersect(Vec3::from(org), Vec3::from(dir), Vec3::ZERO, 1.0, 0.0, f32::INFINITY)
    }

    #[test]
    fn lecture_cases() {
        assert_eq!(hit([0.0, 0.0, -5.0], [0.0, 0.0, 1.0]), Some(4.0)); // from outside
        assert_eq!(hit([0.0, 0.0, 0.0], [0.0, 0.0, 1.0]), Some(1.0)); // from inside: far side
        assert_eq!(hit([-5.0, 1.0, 0.0], [1.0, 0.0, 0.0]), Some(5.0)); // tangent
        assert_eq!(hit([0.0, 0.0, -5.0], [0.0, 0.0, -1.0]), None); // pointing away
        assert_eq!(hit([0.0, 0.0, 5.0], [0.0, 0.0, 1.0]), None); // sphere behind the origin
        assert_eq!(hit([0.0, 2.0, -5.0], [0.0, 0.0, 1.0]), None); // passes above
        assert_eq!(hit([0.0, 0.0, -5.0], [0.0, 0.0, 2.0]), Some(2.0)); // t in units of |d|
    }

    #[test]
    fn small_far_sphere_keeps_its_digits() {
        // b² ≫ 4ac: the textbook formula loses the near root here.
        let (d, r) = (1.0e4f32, 1.0e-2f32);
        let t = intersect(Vec3::ZERO, Vec3::Z, Vec3::new(0.0, 0.0, d), r, 0.0, f32::INFINITY);
        let expected = (d as f64 - r as f64) as f32;
        assert_eq!(t, Some(expected));
    }

    #[test]
    fn interval_selects_the_far_root() {
        // The near root 4 lies before tnear = 4.5, so the far root 6 is the hit.
        let t = intersect(Vec3::new(0.0, 0.0, -5.0), Vec3::Z, Vec3::ZERO, 1.0, 4.5, 10.0);
        assert_eq!(t, Some(6.0));
        assert_eq!(intersect(Vec3::new(0.0, 0.0, -5.0), Vec3::Z, Vec3::ZERO, 1.0, 0.0, 4.0), None);
    }

    #[test]
    fn uv_of_the_poles_and_equator() {
        assert_eq!(uv(Vec3::Y).1, 1.0);
        assert_eq!(uv(-Vec3::Y).1, 0.0);
        let (u, v) = uv(-Vec3::Z);
        assert_eq!((u, v), (0.5, 0.5));
    }

    #[test]
    fn problems_are_named() {
        let s = |c: Vec3, r: f32| Sphere { center: c, radius: r, material: 0 }.problem();
        assert!(s(Vec3::ZERO, 1.0).is_none());
        assert!(s(Vec3::ZERO, 0.0).unwrap().contains("must be > 0"));
        assert!(s(Vec3::ZERO, -1.0).unwrap().contains("must be > 0"));
        assert!(s(Vec3::ZERO, f32::NAN).unwrap().contains("not finite"));
        assert!(s(Vec3::new(f32::INFINITY, 0.0, 0.0), 1.0).unwrap().contains("centre"));
    }
}
