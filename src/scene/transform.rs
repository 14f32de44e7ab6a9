//! Object transforms of the scene format: scale, then rotate, then translate.
//!
//! A point `p` becomes `p' = T·R·S·p`: first scaled about the origin by `S = diag(scale)`,
//! then rotated by `R = Rz·Ry·Rx` (about the world x axis first, then y, then z, by the angles
//! in degrees), then moved by `T`. Normals are transformed with the inverse transpose of the
//! linear part, `(R·S)⁻ᵀ`, which keeps them perpendicular to the transformed surface under a
//! non-uniform scale. Composed in f64 and rounded to f32 once.

use glam::{DMat3, DVec3};

use super::Mesh;
use crate::geometry::{Plane, Sphere};
use crate::math::Vec3;

/// An affine transform `p ↦ linear·p + translation` built from scale, rotation and translation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Transform {
    scale: DVec3,
    linear: DMat3,
    /// `linear⁻ᵀ`, for normals.
    normal_matrix: DMat3,
    translation: DVec3,
}

impl Default for Transform {
    fn default() -> Self {
        Transform::new(DVec3::ZERO, DVec3::ZERO, DVec3::ONE)
    }
}

impl Transform {
    /// `T·R·S` from a translation, rotation angles about x, y, z in degrees (applied in that
    /// order) and per-axis scale factors. Every scale factor must be non-zero (checked by the
    /// caller: a zero scale flattens the object and has no inverse for normals).
    pub fn new(translate: DVec3, rotate_deg: DVec3, scale: DVec3) -> Self {
        let rotation = DMat3::from_rotation_z(rotate_deg.z.to_radians())
            * DMat3::from_rotation_y(rotate_deg.y.to_radians())
            * DMat3::from_rotation_x(rotate_deg.x.to_radians());
        let linear = rotation * DMat3::from_diagonal(scale);
        Transform { scale, linear, normal_matrix: linear.inverse().transpose(), translation: translate }
    }

    /// Whether this transform changes nothing.
    pub fn is_identity(&self) -> bool {
        self.linear == DMat3::IDENTITY && self.translation == DVec3::ZERO
    }

    /// The transformed point, in f64.
    pub fn point_f64(&self, p: DVec3) -> DVec3 {
        self.linear * p + self.translation
    }

    /// The transformed point.
    pub fn point(&self, p: Vec3) -> Vec3 {
        self.point_f64(p.as_dvec3()).as_vec3()
    }

    /// The transformed normal (inverse transpose), normalised, in f64.
    pub fn normal_f64(&self, n: DVec3) -> DVec3 {
        (self.normal_matrix * n).normalize()
    }

    /// The transformed normal (inverse transpose), normalised.
    pub fn normal(&self, n: Vec3) -> Vec3 {
        self.normal_f64(n.as_dvec3()).as_vec3()
    }

    /// The factor every length is multiplied by, if the scale is the same along every axis
    /// (up to sign: a mirror image of a sphere is a sphere).
    pub fn uniform_scale(&self) -> Option<f64> {
        let a = self.scale.abs();
        let tolerance = 1e-9 * a.max_element();
        ((a.x - a.y).abs() <= tolerance && (a.y - a.z).abs() <= tolerance).then_some(a.x)
    }

    /// Whether the transform mirrors (negative determinant): triangles must then swap two
    /// corners so that their winding still agrees with their normals.
    pub fn flips_orientation(&self) -> bool {
        self.linear.determinant() < 0.0
    }

    /// Transforms a mesh in place: positions as points, normals with the inverse transpose,
    /// and the winding reversed under a mirroring transform.
    pub fn apply_to_mesh(&self, mesh: &mut Mesh) {
        if self.is_identity() {
            return;
        }
        for p in &mut mesh.positions {
            *p = self.point(*p);
        }
        if let Some(normals) = &mut mesh.normals {
            for n in normals {
                *n = self.normal(*n);
            }
        }
        if self.flips_orientation() {
            for tri in &mut mesh.indices {
                tri.swap(1, 2);
            }
        }
    }

    /// The transformed sphere, or why it is not a sphere any more (a non-uniform scale).
    pub fn apply_to_sphere(&self, s: &Sphere) -> Result<Sphere, String> {
        let k = self.uniform_scale().ok_or_else(|| {
            format!(
                "a sphere cannot take the non-uniform scale [{}, {}, {}] (it would become an ellipsoid)",
                self.scale.x, self.scale.y, self.scale.z
            )
        })?;
        Ok(Sphere { center: self.point(s.center), radius: (k * s.radius as f64) as f32, material: s.material })
    }

    /// The transformed plane in Hesse normal form: the normal by the inverse transpose, the
    /// distance from the transformed foot point `n·d`.
    pub fn apply_to_plane(&self, normal: DVec3, dist: f64, material: u32) -> Plane {
        let n = normal.normalize();
        let foot = self.point_f64(n * dist);
        let n2 = self.normal_f64(n);
        Plane { normal: n2.as_vec3(), dist: n2.dot(foot) as f32, material }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scale_then_rotate_then_translate() {
        // (1, 0, 0) scaled by 2 → (2, 0, 0), rotated 90° about z → (0, 2, 0), moved by (1, 1, 1).
        let t = Transform::new(DVec3::ONE, DVec3::new(0.0, 0.0, 90.0), DVec3::splat(2.0));
        let p = t.point_f64(DVec3::X);
        assert!((p - DVec3::new(1.0, 3.0, 1.0)).length() < 1e-12, "{p}");
        // x first, then y: (0, 1, 0) →x90→ (0, 0, 1) →y90→ (1, 0, 0).
        let t = Transform::new(DVec3::ZERO, DVec3::new(90.0, 90.0, 0.0), DVec3::ONE);
        assert!((t.point_f64(DVec3::Y) - DVec3::X).length() < 1e-12);
    }

    #[test]
    fn normals_stay_perpendicular_under_non_uniform_scale() {
        let t = Transform::new(DVec3::ZERO, DVec3::new(10.0, 20.0, 30.0), DVec3::new(1.0, 3.0, 0.5));
        // The plane x + y = 1 has normal (1, 1, 0); its tangent (1, −1, 0) maps to a tangent.
        let n = t.normal_f64(DVec3::new(1.0, 1.0, 0.0));
        let tangent = t.linear * DVec3::new(1.0, -1.0, 0.0);
        assert!(n.dot(tangent).abs() < 1e-12);
        assert!((n.length() - 1.0).abs() < 1e-12);
    }

    #[test]
    fn uniform_scale_and_mirroring() {
        assert_eq!(Transform::new(DVec3::ZERO, DVec3::ZERO, DVec3::splat(3.0)).uniform_scale(), Some(3.0));
        assert_eq!(Transform::new(DVec3::ZERO, DVec3::ZERO, DVec3::new(1.0, 1.0, 2.0)).uniform_scale(), None);
        let mirror = Transform::new(DVec3::ZERO, DVec3::ZERO, DVec3::new(1.0, 1.0, -1.0));
        assert_eq!(mirror.uniform_scale(), Some(1.0));
        assert!(mirror.flips_orientation());
        assert!(!Transform::default().flips_orientation());
    }
}
