//! Tangent-space normal mapping (glTF 2.0 `normalTexture`): the shading normal read from an
//! image in the frame of the surface's tangent, bitangent and interpolated normal.
//!
//! ```text
//! n_t = normalize((2c − 1) · (scale, scale, 1))       c: the linear texel, scale: normalTexture.scale
//! T   = normalize(t − (t·N) N)                        t: the interpolated tangent (TANGENT.xyz)
//! B   = w · (N × T)                                   w = ±1: TANGENT.w (sign of the interpolated w)
//! n   = normalize(n_t.x T + n_t.y B + n_t.z N)
//! ```
//!
//! `N` is the interpolated vertex normal on the side of the primitive's outward geometric
//! normal; the result is flipped with it towards the viewer ([`crate::surface`]). `T` points
//! along increasing `u` and `B` (for `w = 1`) along increasing `v` of strahl's bottom-left
//! texture coordinates, i.e. up in the image: glTF's "+Y is up" (OpenGL) convention.
//! Tangents come from glTF's `TANGENT` or, when a primitive has none, from MikkTSpace
//! ([`crate::scene::tangents`]); a point whose tangent is zero (no texture coordinates, a
//! degenerate triangle) keeps `N`.
//!
//! **Geometric side.** A mapped normal may tilt so far that the viewer is behind it, or that
//! the mirror direction of `wo` about it points into the surface; the BSDF would then be black
//! there. As Cycles does (`ensure_valid_specular_reflection`), the mapped normal `n` is kept
//! when the reflection `R = 2(n·wo)n − wo` leaves the geometric surface by at least
//! `τ = min(0.9 wo·n_g, 0.01)` (`R·n_g ≥ τ`) and, since strahl's BSDFs see nothing from behind
//! their normal, the viewer is in front of it (`n·wo > 0`); otherwise it is bent towards `n_g`,
//! in the plane of `n_g` and `n`, just far enough that `R·n_g = τ` ([`valid_reflection`];
//! the bent normal has `n·wo = (τ + wo·n_g)/(2 n·n_g) > 0`).
//! Interpolated normals without a normal map keep their own rule (replaced by `n_g` when they
//! face away from the viewer), so scenes without normal maps shade as before.

use crate::math::{Vec3, Vec4};

/// The unit tangent-space normal a texel `c` (linear, each channel in [0, 1]) encodes, its
/// `x` and `y` multiplied by `scale`; `(0, 0, 1)` (unperturbed) if it has no direction.
pub fn tangent_space_normal(c: Vec3, scale: f32) -> Vec3 {
    let n = (2.0 * c - Vec3::ONE) * Vec3::new(scale, scale, 1.0);
    let n = n.normalize_or_zero();
    if n == Vec3::ZERO { Vec3::Z } else { n }
}

/// The world-space normal `n_t` maps to in the frame of the unit normal `n` and the tangent
/// `tangent` (`xyz` not necessarily unit or orthogonal to `n`, `w` the bitangent's sign; see
/// the module header); `None` where the tangent gives no frame (zero, or parallel to `n`).
pub fn perturb(n: Vec3, tangent: Vec4, n_t: Vec3) -> Option<Vec3> {
    let t = tangent.truncate();
    let t = (t - t.dot(n) * n).normalize_or_zero();
    if t == Vec3::ZERO {
        return None;
    }
    let sign = if tangent.w < 0.0 { -1.0 } else { 1.0 };
    let b = sign * n.cross(t);
    let mapped = (n_t.x * t + n_t.y * b + n_t.z * n).normalize_or_zero();
    (mapped != Vec3::ZERO).then_some(mapped)
}

/// `n` bent towards the geometric normal `ng` just far enough that the mirror direction of
/// `wo` about it leaves the surface (module header; Cycles' rule). `ng` and `wo` unit, on the
/// same side (`wo·ng ≥ 0`).
///
/// With `X` the unit part of `n` orthogonal to `ng` and `n' = x X + z ng` (`x² + z² = 1`), the
/// condition `R·ng = 2(n'·wo) z − wo·ng = τ` squared is a quadratic in `z²`:
/// `4a z⁴ − 2b z² + c = 0` with `a = I_x² + I_z²`, `b = 2(a + I_z τ)`, `c = (τ + I_z)²`,
/// `I_x = wo·X`, `I_z = wo·ng`; its root is the larger one when `I_x < 0` (the viewer on the
/// other side of `ng` from the tilt), the smaller one otherwise.
pub fn valid_reflection(ng: Vec3, wo: Vec3, n: Vec3) -> Vec3 {
    let r = 2.0 * n.dot(wo) * n - wo;
    let iz = wo.dot(ng).max(0.0);
    let threshold = (0.9 * iz).min(0.01);
    if r.dot(ng) >= threshold && n.dot(wo) > 0.0 {
        return n;
    }
    let x = (n - n.dot(ng) * ng).normalize_or_zero();
    if x == Vec3::ZERO {
        return ng;
    }
    let ix = wo.dot(x);
    let a = ix * ix + iz * iz;
    if !(a > 0.0) {
        return ng;
    }
    let b = 2.0 * (a + iz * threshold);
    let c = (threshold + iz) * (threshold + iz);
    let root = (b * b - 4.0 * a * c).max(0.0).sqrt();
    let z2 = 0.25 * if ix < 0.0 { b + root } else { b - root } / a;
    let z2 = z2.clamp(0.0, 1.0);
    ((1.0 - z2).sqrt() * x + z2.sqrt() * ng).normalize_or_zero()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: Vec3, b: Vec3) -> bool {
        (a - b).abs().max_element() < 1e-6
    }

    #[test]
    fn flat_texel_keeps_the_normal() {
        let c = Vec3::new(0.5, 0.5, 1.0);
        let n_t = tangent_space_normal(c, 1.0);
        assert!(close(n_t, Vec3::Z));
        assert_eq!(perturb(Vec3::Y, Vec4::new(1.0, 0.0, 0.0, 1.0), n_t), Some(Vec3::Y));
    }

    #[test]
    fn scale_zero_is_unperturbed_and_scale_tilts() {
        let c = Vec3::new(0.75, 0.5, 0.5 + 0.5 * 3f32.sqrt() / 2.0); // 30° towards +x, unit
        assert!(close(tangent_space_normal(c, 0.0), Vec3::Z));
        let n = tangent_space_normal(c, 1.0);
        assert!((n.z - 30f32.to_radians().cos()).abs() < 1e-6, "{n}");
        assert!(tangent_space_normal(c, 2.0).z < n.z);
    }

    #[test]
    fn frame_and_bitangent_sign() {
        // N = z, T = x: n_t = y maps to B = w·(z × x) = w·y.
        let n_t = Vec3::Y;
        assert!(close(perturb(Vec3::Z, Vec4::new(1.0, 0.0, 0.0, 1.0), n_t).unwrap(), Vec3::Y));
        assert!(close(perturb(Vec3::Z, Vec4::new(1.0, 0.0, 0.0, -1.0), n_t).unwrap(), -Vec3::Y));
        // A tangent not orthogonal to N is made so; one along N gives no frame.
        assert!(close(perturb(Vec3::Z, Vec4::new(2.0, 0.0, 5.0, 1.0), Vec3::X).unwrap(), Vec3::X));
        assert_eq!(perturb(Vec3::Z, Vec4::new(0.0, 0.0, 1.0, 1.0), Vec3::X), None);
        assert_eq!(perturb(Vec3::Z, Vec4::ZERO, Vec3::X), None);
    }

    #[test]
    fn reflection_is_kept_above_the_surface() {
        let ng = Vec3::Z;
        // A mild tilt seen from above is kept.
        let n = Vec3::new(0.5, 0.0, 0.75f32.sqrt());
        assert_eq!(valid_reflection(ng, Vec3::Z, n), n);
        // Grazing view against a strong tilt: bent until R·ng = τ.
        let wo = Vec3::new(-0.9, 0.0, 0.19f32.sqrt());
        for n in [Vec3::new(0.9, 0.0, 0.19f32.sqrt()), Vec3::new(0.6, 0.3, -0.2).normalize(), -wo] {
            let bent = valid_reflection(ng, wo, n);
            let r = 2.0 * bent.dot(wo) * bent - wo;
            let tau = (0.9 * wo.z).min(0.01);
            assert!((r.dot(ng) - tau).abs() < 1e-4, "n {n}: bent {bent}, R·ng {}", r.dot(ng));
            assert!((bent.length() - 1.0).abs() < 1e-5 && bent.z > 0.0 && bent.dot(wo) > 0.0);
        }
    }
}
