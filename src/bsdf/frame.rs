//! An orthonormal shading frame `(s, t, n)`: `to_local(v) = (v·s, v·t, v·n)`, `to_world(v) =
//! v.x s + v.y t + v.z n`. Local `z` is the shading normal, so `cos θ = v.z`.
//!
//! Built from the normal alone by Duff et al.'s branchless construction ("Building an
//! Orthonormal Basis, Revisited", JCGT 2017), or from a normal and a tangent by Gram–Schmidt
//! (the tangent's component along `n` removed), falling back to the former when the tangent is
//! parallel to `n` or not finite.

use crate::math::Vec3;

/// An orthonormal frame; `n` is the shading normal.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frame {
    pub s: Vec3,
    pub t: Vec3,
    pub n: Vec3,
}

impl Frame {
    /// A frame around the unit normal `n`, with an arbitrary but continuous tangent.
    #[inline]
    pub fn from_normal(n: Vec3) -> Frame {
        let sign = 1.0f32.copysign(n.z);
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        let s = Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
        let t = Vec3::new(b, sign + n.y * n.y * a, -n.y);
        Frame { s, t, n }
    }

    /// A frame around the unit normal `n` whose `s` lies along `tangent` (made orthogonal to
    /// `n`); [`Frame::from_normal`] when the tangent gives no direction.
    #[inline]
    pub fn from_normal_tangent(n: Vec3, tangent: Vec3) -> Frame {
        let s = (tangent - n * n.dot(tangent)).normalize_or_zero();
        if s == Vec3::ZERO || !s.is_finite() {
            return Frame::from_normal(n);
        }
        Frame { s, t: n.cross(s), n }
    }

    /// `v` in local coordinates.
    #[inline]
    pub fn to_local(&self, v: Vec3) -> Vec3 {
        Vec3::new(v.dot(self.s), v.dot(self.t), v.dot(self.n))
    }

    /// Local `v` in world coordinates.
    #[inline]
    pub fn to_world(&self, v: Vec3) -> Vec3 {
        v.x * self.s + v.y * self.t + v.z * self.n
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frames_are_orthonormal_and_round_trip() {
        let normals = [Vec3::Z, -Vec3::Z, Vec3::X, Vec3::new(0.3, -0.5, 0.8).normalize(), Vec3::new(1e-8, 0.0, -1.0)];
        for n in normals {
            let n = n.normalize();
            for f in [Frame::from_normal(n), Frame::from_normal_tangent(n, Vec3::new(0.2, 0.9, 0.1))] {
                assert!((f.s.length() - 1.0).abs() < 1e-5 && (f.t.length() - 1.0).abs() < 1e-5, "{f:?}");
                assert!(f.s.dot(f.t).abs() < 1e-5 && f.s.dot(f.n).abs() < 1e-5 && f.t.dot(f.n).abs() < 1e-5);
                assert!((f.s.cross(f.t) - f.n).length() < 1e-5, "right-handed: {f:?}");
                let v = Vec3::new(0.6, -0.64, 0.48);
                assert!((f.to_world(f.to_local(v)) - v).length() < 1e-5);
                assert!((f.to_local(n) - Vec3::Z).length() < 1e-5);
            }
        }
        // A tangent along the normal falls back to the normal-only frame.
        assert_eq!(Frame::from_normal_tangent(Vec3::Z, Vec3::Z), Frame::from_normal(Vec3::Z));
    }
}
