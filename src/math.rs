//! Rays, bounding boxes and the robust offset of secondary-ray origins, over `glam`.

pub use glam::{Vec2, Vec3, Vec4};

/// A ray `r(t) = org + t·dir`, valid for `tnear < t < tfar`.
///
/// `dir` need not be unit length; `t` is then measured in units of `|dir|`. Every ray strahl
/// traces for an image has a unit `dir`, so `t` is a distance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    pub org: Vec3,
    pub dir: Vec3,
    pub tnear: f32,
    pub tfar: f32,
    /// Whether the camera made this ray: its hits on the back of a one-sided surface (glTF
    /// `doubleSided: false`) do not exist ([`crate::scene::alpha`]); secondary and shadow rays
    /// see both sides.
    pub camera: bool,
}

impl Ray {
    /// A ray from `org` along `dir` over `(0, ∞)`.
    pub fn new(org: Vec3, dir: Vec3) -> Self {
        Ray { org, dir, tnear: 0.0, tfar: f32::INFINITY, camera: false }
    }

    /// The same ray restricted to `(tnear, tfar)`.
    pub fn segment(org: Vec3, dir: Vec3, tnear: f32, tfar: f32) -> Self {
        Ray { org, dir, tnear, tfar, camera: false }
    }

    /// The same ray, marked as a camera ray.
    #[inline]
    pub fn from_camera(self) -> Self {
        Ray { camera: true, ..self }
    }

    /// The point at parameter `t`.
    #[inline]
    pub fn at(&self, t: f32) -> Vec3 {
        self.org + t * self.dir
    }
}

/// An axis-aligned bounding box; `Aabb::EMPTY` contains nothing and is the identity of `union`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    pub min: Vec3,
    pub max: Vec3,
}

impl Aabb {
    pub const EMPTY: Aabb = Aabb { min: Vec3::splat(f32::INFINITY), max: Vec3::splat(f32::NEG_INFINITY) };

    pub fn new(min: Vec3, max: Vec3) -> Self {
        Aabb { min, max }
    }

    pub fn from_points(points: impl IntoIterator<Item = Vec3>) -> Self {
        points.into_iter().fold(Aabb::EMPTY, |b, p| b.grow(p))
    }

    #[inline]
    pub fn grow(self, p: Vec3) -> Self {
        Aabb { min: self.min.min(p), max: self.max.max(p) }
    }

    #[inline]
    pub fn union(self, o: Aabb) -> Self {
        Aabb { min: self.min.min(o.min), max: self.max.max(o.max) }
    }

    pub fn is_empty(&self) -> bool {
        self.min.cmpgt(self.max).any()
    }

    /// The box's size per axis; 0 for an empty box (`min > max`, as [`Aabb::EMPTY`] is: its
    /// `max − min` is −∞). Branch-free.
    pub fn extent(&self) -> Vec3 {
        (self.max - self.min).max(Vec3::ZERO)
    }

    pub fn centroid(&self) -> Vec3 {
        0.5 * (self.min + self.max)
    }

    /// Surface area; 0 for an empty box.
    pub fn area(&self) -> f32 {
        let e = self.extent();
        2.0 * (e.x * e.y + e.y * e.z + e.z * e.x)
    }
}

/// Moves a hit point off its surface along the geometric normal `ng` so that a ray leaving it
/// does not hit the same surface again, by an amount that scales with the point's magnitude.
///
/// A fixed epsilon is wrong at every scale but one: too small far from the origin (where one
/// float ulp exceeds it), too large for small objects near it. This is Wächter and Binder's
/// method ("A Fast and Robust Method for Avoiding Self-Intersection", Ray Tracing Gems, ch. 6):
/// the offset is a fixed number of ulps of each coordinate, plus a tiny absolute offset for
/// coordinates near zero where ulps vanish. Pass `ng` facing the side the new ray leaves on
/// (flip it for refracted rays).
pub fn offset_ray_origin(p: Vec3, ng: Vec3) -> Vec3 {
    const ORIGIN: f32 = 1.0 / 32.0;
    const FLOAT_SCALE: f32 = 1.0 / 65536.0;
    const INT_SCALE: f32 = 256.0;
    let n = ng.normalize_or_zero();
    let of_i = [(INT_SCALE * n.x) as i32, (INT_SCALE * n.y) as i32, (INT_SCALE * n.z) as i32];
    let shift = |x: f32, o: i32| -> f32 {
        // Adding the integer to the bit pattern moves by `o` ulps away from zero for positive
        // x; negate the step for negative x so the move is always along +n.
        let step = if x < 0.0 { -o } else { o };
        f32::from_bits((x.to_bits() as i32).wrapping_add(step) as u32)
    };
    let p_i = Vec3::new(shift(p.x, of_i[0]), shift(p.y, of_i[1]), shift(p.z, of_i[2]));
    Vec3::new(
        if p.x.abs() < ORIGIN { p.x + FLOAT_SCALE * n.x } else { p_i.x },
        if p.y.abs() < ORIGIN { p.y + FLOAT_SCALE * n.y } else { p_i.y },
        if p.z.abs() < ORIGIN { p.z + FLOAT_SCALE * n.z } else { p_i.z },
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn offset_moves_along_the_normal_at_every_scale() {
        for scale in [1e-3f32, 1.0, 1e3, 1e6] {
            let p = Vec3::new(0.3, -0.7, 0.2) * scale;
            let n = Vec3::new(0.0, 1.0, 0.0);
            let q = offset_ray_origin(p, n);
            assert!(q.y > p.y, "scale {scale}: {q} not above {p}");
            // x and z barely move: the offset is a few ulps, not a fixed epsilon.
            assert!((q.x - p.x).abs() <= 2.0 * f32::EPSILON * p.x.abs().max(1.0));
            let rel = (q.y - p.y) / p.y.abs().max(ORIGIN_FOR_TEST);
            assert!(rel < 1e-3, "scale {scale}: moved {rel} relative");
        }
    }

    const ORIGIN_FOR_TEST: f32 = 1.0 / 32.0;

    #[test]
    fn empty_box_is_the_union_identity() {
        let b = Aabb::new(Vec3::ZERO, Vec3::ONE);
        assert_eq!(Aabb::EMPTY.union(b), b);
        assert!(Aabb::EMPTY.is_empty());
        assert_eq!(Aabb::EMPTY.area(), 0.0);
        assert_eq!(b.area(), 6.0);
    }
}
