//! Ray–plane intersection in the lecture's Hesse normal form `n·p = d`.
//!
//! Planes are unbounded, so they sit outside both BVHs: each backend tests the scene's (few)
//! planes itself, with the same function. They end at
//! [`PLANE_EXTENT`] from the origin along each axis:
//! a grazing ray would otherwise meet one arbitrarily far away, and a ray leaving such a hit
//! would start outside the range Embree traces ([`crate::scene::magnitude`]).

use crate::math::Vec3;

/// Planes end this far from the origin along each axis: a plane hit beyond it is a miss
/// ([`intersect`]); four times the largest coordinate a scene may hold
/// ([`crate::scene::magnitude::MAX_COORDINATE`]).
pub const PLANE_EXTENT: f32 = 4e9;

/// The plane of points `p` with `normal·p = dist`, `normal` of unit length; the normal is
/// the side the plane faces (its geometric normal).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Plane {
    pub normal: Vec3,
    pub dist: f32,
    pub material: u32,
}

impl Plane {
    /// The plane through `point` facing `normal` (normalised here).
    pub fn through(point: Vec3, normal: Vec3, material: u32) -> Self {
        let n = normal.normalize();
        Plane { normal: n, dist: n.dot(point), material }
    }

    /// Why this plane cannot be traced, if it cannot.
    pub fn problem(&self) -> Option<String> {
        if !self.normal.is_finite() || !self.dist.is_finite() {
            Some(format!("normal {} / distance {} is not finite", self.normal, self.dist))
        } else if (self.normal.length() - 1.0).abs() > 1e-4 {
            Some(format!("normal {} is not of unit length", self.normal))
        } else {
            None
        }
    }
}

/// `t = (d − e·n) / (d⃗·n)` for the ray `e + t·d⃗` inside `(tnear, tfar)`, if the hit lies within
/// [`PLANE_EXTENT`] of the origin along each axis; a ray
/// parallel to the plane (`d⃗·n = 0`) never hits it.
#[inline]
pub fn intersect(org: Vec3, dir: Vec3, plane: &Plane, tnear: f32, tfar: f32) -> Option<f32> {
    let denom = dir.dot(plane.normal);
    if denom == 0.0 {
        return None;
    }
    let t = (plane.dist - org.dot(plane.normal)) / denom;
    let inside = |t: f32| (org + t * dir).abs().max_element() <= PLANE_EXTENT;
    (t > tnear && t < tfar && inside(t)).then_some(t)
}

/// The closest of `planes` along the ray inside `(tnear, tfar)`: `(t, plane index)`.
#[inline]
pub fn closest(planes: &[Plane], org: Vec3, dir: Vec3, tnear: f32, tfar: f32) -> Option<(f32, u32)> {
    let mut best = None;
    let mut tmax = tfar;
    for (i, p) in planes.iter().enumerate() {
        if let Some(t) = intersect(org, dir, p, tnear, tmax) {
            tmax = t;
            best = Some((t, i as u32));
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    const FLOOR: Plane = Plane { normal: Vec3::Y, dist: -1.0, material: 0 };

    #[test]
    fn hesse_form_distance() {
        let t = intersect(Vec3::new(0.0, 2.0, 0.0), Vec3::new(0.0, -1.0, 0.0), &FLOOR, 0.0, f32::INFINITY);
        assert_eq!(t, Some(3.0));
        // Oblique: 45° down, travels √2 per unit of height.
        let d = Vec3::new(1.0, -1.0, 0.0).normalize();
        let t = intersect(Vec3::new(0.0, 2.0, 0.0), d, &FLOOR, 0.0, f32::INFINITY).unwrap();
        assert!((t - 3.0 * 2f32.sqrt()).abs() <= 1e-6 * t);
    }

    #[test]
    fn parallel_and_behind_miss() {
        assert_eq!(intersect(Vec3::ZERO, Vec3::X, &FLOOR, 0.0, f32::INFINITY), None);
        assert_eq!(intersect(Vec3::ZERO, Vec3::Y, &FLOOR, 0.0, f32::INFINITY), None);
        // Grazing at 10⁻³ rad, one unit above the floor: t = 1 / sin(10⁻³) ≈ 1000.
        let (s, c) = 1e-3f64.sin_cos();
        let t = intersect(Vec3::ZERO, Vec3::new(c as f32, -s as f32, 0.0), &FLOOR, 0.0, f32::INFINITY).unwrap();
        assert!((t as f64 - 1.0 / s).abs() <= 1e-6 / s, "{t}");
        // From below, facing away from the normal, still hits (planes are two-sided).
        assert_eq!(intersect(Vec3::new(0.0, -3.0, 0.0), Vec3::Y, &FLOOR, 0.0, f32::INFINITY), Some(2.0));
    }

    #[test]
    fn planes_end_at_the_extent() {
        // Direction y = −10⁻²⁰: y = −1 lies 10²⁰ away, beyond what a ray may start from.
        let grazing = Vec3::new(1.0, -1e-20, 0.0);
        assert_eq!(intersect(Vec3::ZERO, grazing, &FLOOR, 0.0, f32::INFINITY), None);
        let extent = PLANE_EXTENT;
        // Just inside: 0.9 of the extent along x.
        let d = Vec3::new(0.9 * extent, -1.0, 0.0).normalize();
        let t = intersect(Vec3::ZERO, d, &FLOOR, 0.0, f32::INFINITY).unwrap();
        assert!(((t * d).x / extent - 0.9).abs() < 1e-3, "{t}");
    }

    #[test]
    fn closest_of_several() {
        let ceiling = Plane { normal: -Vec3::Y, dist: -4.0, material: 1 };
        let hit = closest(&[ceiling, FLOOR], Vec3::ZERO, Vec3::Y, 0.0, f32::INFINITY);
        assert_eq!(hit, Some((4.0, 0)));
        let hit = closest(&[ceiling, FLOOR], Vec3::ZERO, -Vec3::Y, 0.0, f32::INFINITY);
        assert_eq!(hit, Some((1.0, 1)));
    }
}
