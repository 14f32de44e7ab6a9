//! Object transforms of the scene format: scale, then rotate, then translate.
//!
//! A point `p` becomes `p' = T·R·S·p`: first scaled about the origin by `S = diag(scale)`,
//! then rotated by `R = Rz·Ry·Rx` (about the world x axis first, then y, then z, by the angles
//! in degrees), then moved by `T`. Normals are transformed with the inverse transpose of the
//! linear part, `(R·S)⁻ᵀ`, which keeps them perpendicular to the transformed surface under a
//! non-uniform scale. Composed in f64 and rounded to f32 once.
//!
//! glTF nodes give their transform as a general affine matrix ([`Transform::from_matrix`]),
//! and nested nodes and glTF objects placed in a TOML scene compose transforms
//! ([`Transform::then`]).

use glam::{DAffine3, DMat3, DMat4, DVec3};

use super::Mesh;
use crate::geometry::{Plane, Sphere};
use crate::math::{Vec3, Vec4};

/// An affine transform `p ↦ linear·p + translation` built from scale, rotation and translation
/// (or from a matrix).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Transform {
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
        Transform { linear, normal_matrix: linear.inverse().transpose(), translation: translate }
    }

    /// The affine transform of a 4×4 matrix (column vectors, `p' = M·(p, 1)`), or why it is
    /// not one: a bottom row other than `(0, 0, 0, 1)`, a non-finite entry, or a singular
    /// linear part (it would flatten the object and has no inverse for normals).
    pub fn from_matrix(m: DMat4) -> Result<Self, String> {
        if !m.is_finite() {
            return Err("the matrix has a non-finite entry".into());
        }
        if m.row(3) != glam::DVec4::W {
            return Err(format!("the matrix's bottom row {} is not (0, 0, 0, 1)", m.row(3)));
        }
        let linear = DMat3::from_mat4(m);
        let det = linear.determinant();
        let size = linear.x_axis.length() * linear.y_axis.length() * linear.z_axis.length();
        if !(det.abs() > 1e-12 * size) || size == 0.0 {
            return Err("the matrix is singular (a zero scale)".into());
        }
        Ok(Transform { linear, normal_matrix: linear.inverse().transpose(), translation: m.w_axis.truncate() })
    }

    /// `outer ∘ self`: first this transform, then `outer` (a child node's transform, then its
    /// parent's).
    pub fn then(&self, outer: &Transform) -> Transform {
        let linear = outer.linear * self.linear;
        Transform {
            linear,
            normal_matrix: linear.inverse().transpose(),
            translation: outer.linear * self.translation + outer.translation,
        }
    }

    /// The transform as an f64 affine map (object to world).
    pub fn affine(&self) -> DAffine3 {
        DAffine3 { matrix3: self.linear, translation: self.translation }
    }

    /// The transformed direction (linear part only), not normalised, in f64.
    pub fn vector_f64(&self, v: DVec3) -> DVec3 {
        self.linear * v
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

    /// The transformed tangent of normal mapping (`xyz` a direction, transformed by the linear
    /// part and normalised, in f64; `w` the bitangent's sign, negated under a mirroring
    /// transform, since for a similarity `L` the bitangent `L·(n × t)` is
    /// `sign(det L)·(L⁻ᵀ·n × L·t)` up to length).
    pub fn tangent(&self, t: Vec4) -> Vec4 {
        let xyz = self.vector_f64(t.truncate().as_dvec3()).normalize_or_zero().as_vec3();
        xyz.extend(if self.flips_orientation() { -t.w } else { t.w })
    }

    /// The factor every length is multiplied by, if the transform scales every direction by
    /// the same factor (`Lᵀ·L = k²·I`, up to sign: a mirror image of a sphere is a sphere).
    pub fn uniform_scale(&self) -> Option<f64> {
        let g = self.linear.transpose() * self.linear;
        let k2 = g.x_axis.x.max(g.y_axis.y).max(g.z_axis.z);
        let tolerance = 2e-9 * k2;
        let expected = DMat3::from_diagonal(DVec3::splat(k2));
        let off = (g - expected).to_cols_array().iter().fold(0.0f64, |m, x| m.max(x.abs()));
        (off <= tolerance).then(|| k2.sqrt())
    }

    /// The world-space geometric normal `(p1 − p0) × (p2 − p0)` of a triangle as flattening
    /// places it, from its object-space one `n`: `|det L|·L⁻ᵀ·n` in f64. (`L·a × L·b =
    /// det L·L⁻ᵀ·(a × b)`, and under a mirroring `L` flattening swaps two corners, which
    /// negates it once more.) Not normalised, like a triangle's own.
    pub fn area_normal_f64(&self, n: DVec3) -> DVec3 {
        self.linear.determinant().abs() * (self.normal_matrix * n)
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
        if let Some(tangents) = &mut mesh.tangents {
            for t in tangents {
                *t = self.tangent(*t);
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
            let l = &self.linear;
            format!(
                "a sphere cannot take the non-uniform scale [{}, {}, {}] (it would become an ellipsoid)",
                l.x_axis.length(),
                l.y_axis.length(),
                l.z_axis.length()
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
