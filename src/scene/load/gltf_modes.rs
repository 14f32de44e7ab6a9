//! Triangle strips and fans as triangles (glTF 2.0 §3.7.2.1, for vertices `p₀ … p₋₁`):
//! - `TRIANGLE_STRIP`: triangle `i` is `(pᵢ, pᵢ₊₁₊ᵢ﹪₂, pᵢ₊₂₋ᵢ﹪₂)` for `i` in `0 … n−3`, every other
//!   triangle turned round so all keep the strip's winding;
//! - `TRIANGLE_FAN`: triangle `i` is `(pᵢ₊₁, pᵢ₊₂, p₀)`.
//!
//! Fewer than three vertices make no triangle.

use gltf::mesh::Mode;

/// Triangles of `corners` (a primitive's vertex indices, in order) drawn in `mode`; `None` for
/// modes that are not triangles, and for `TRIANGLES` with a count that is not a multiple of 3.
pub fn triangles(mode: Mode, corners: &[u32]) -> Option<Vec<[u32; 3]>> {
    let n = corners.len();
    match mode {
        Mode::Triangles if n % 3 == 0 => Some(corners.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect()),
        Mode::TriangleStrip => Some(
            (0..n.saturating_sub(2)).map(|i| [corners[i], corners[i + 1 + i % 2], corners[i + 2 - i % 2]]).collect(),
        ),
        Mode::TriangleFan => {
            Some((0..n.saturating_sub(2)).map(|i| [corners[i + 1], corners[i + 2], corners[0]]).collect())
        }
        _ => None,
    }
}

/// Triangles a primitive of `corners` vertex indices in `mode` makes (0 for other modes).
pub fn triangle_count(mode: Mode, corners: u64) -> u64 {
    match mode {
        Mode::Triangles => corners / 3,
        Mode::TriangleStrip | Mode::TriangleFan => corners.saturating_sub(2),
        _ => 0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn strips_keep_their_winding_and_fans_turn_about_the_first_vertex() {
        let c = [0, 1, 2, 3, 4];
        assert_eq!(triangles(Mode::TriangleStrip, &c).unwrap(), [[0, 1, 2], [1, 3, 2], [2, 3, 4]]);
        assert_eq!(triangles(Mode::TriangleFan, &c).unwrap(), [[1, 2, 0], [2, 3, 0], [3, 4, 0]]);
        assert_eq!(triangles(Mode::Triangles, &c), None);
        assert_eq!(triangles(Mode::TriangleStrip, &c[..2]).unwrap(), Vec::<[u32; 3]>::new());
        assert_eq!(triangles(Mode::Lines, &c), None);
        assert_eq!(triangle_count(Mode::TriangleFan, 5), 3);
    }
}
