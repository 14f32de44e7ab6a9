//! Tangents for normal mapping where a glTF primitive gives none: MikkTSpace, as the glTF 2.0
//! specification asks ("client implementations SHOULD calculate tangents using default
//! MikkTSpace algorithms with the specified vertex positions, normals, and texture coordinates
//! associated with the normal texture"), computed by the `mikktspace` crate (the reference C
//! implementation, translated), not by a port of our own.
//!
//! MikkTSpace is fed strahl's bottom-left texture coordinates of the normal texture's set, so
//! its tangent points along increasing `u` and its bitangent `w·(N × T)` along increasing `v`,
//! up in the image: glTF's convention ([`crate::normal_map`]). Corners without a vertex normal
//! are given their triangle's normal (glTF's flat normals).
//!
//! MikkTSpace gives a tangent per triangle corner. Where the corners of one vertex receive
//! different tangents (a mirrored UV island, a hard edge in tangent space), the vertex is
//! split: a copy of it (position, normal, colour, texture coordinates) is appended for each
//! further distinct tangent and the corners are re-pointed to it, so tangents stay per vertex
//! like glTF's `TANGENT`.

use std::collections::HashMap;
use std::ops::Range;

use super::Mesh;
use crate::math::{Vec2, Vec3, Vec4};

/// The geometry MikkTSpace reads: triangles `range` of `mesh`, their texture coordinates
/// `uvs`, and the tangents it writes per corner.
struct Corners<'a> {
    mesh: &'a Mesh,
    range: Range<usize>,
    uvs: &'a [Vec2],
    out: Vec<Vec4>,
}

impl Corners<'_> {
    fn vertex(&self, face: usize, vert: usize) -> usize {
        self.mesh.indices[self.range.start + face][vert] as usize
    }
}

impl mikktspace::Geometry for Corners<'_> {
    fn num_faces(&self) -> usize {
        self.range.len()
    }

    fn num_vertices_of_face(&self, _face: usize) -> usize {
        3
    }

    fn position(&self, face: usize, vert: usize) -> [f32; 3] {
        self.mesh.positions[self.vertex(face, vert)].to_array()
    }

    fn normal(&self, face: usize, vert: usize) -> [f32; 3] {
        let n = self.mesh.normals.as_ref().map_or(Vec3::ZERO, |n| n[self.vertex(face, vert)]);
        let n = if n.is_finite() && n != Vec3::ZERO {
            n
        } else {
            let [a, b, c] = self.mesh.triangle(self.range.start + face);
            (b - a).cross(c - a).normalize_or_zero()
        };
        n.to_array()
    }

    fn tex_coord(&self, face: usize, vert: usize) -> [f32; 2] {
        let t = self.uvs[self.vertex(face, vert)];
        if t.is_finite() { t.to_array() } else { [0.0; 2] }
    }

    fn set_tangent_encoded(&mut self, tangent: [f32; 4], face: usize, vert: usize) {
        self.out[3 * face + vert] = Vec4::from_array(tangent);
    }
}

/// Computes MikkTSpace tangents for triangles `range` of `mesh` from its texture coordinate set
/// `set` (0 or 1) into `mesh.tangents` (made, zero, if absent), splitting vertices whose corners
/// disagree (module docs). Returns `false`, leaving those tangents zero (no normal mapping
/// there), when the mesh has no such coordinates or MikkTSpace fails.
pub fn mikktspace(mesh: &mut Mesh, range: Range<usize>, set: u32) -> bool {
    let n = mesh.positions.len();
    let tangents = mesh.tangents.get_or_insert_with(|| vec![Vec4::ZERO; n]);
    tangents.resize(n, Vec4::ZERO);
    let uvs = if set == 1 { mesh.uvs1.as_ref().or(mesh.uvs.as_ref()) } else { mesh.uvs.as_ref() };
    let Some(uvs) = uvs else { return false };
    let uvs = uvs.clone();
    let mut corners = Corners { mesh, range: range.clone(), uvs: &uvs, out: vec![Vec4::ZERO; 3 * range.len()] };
    // The crate is a translation of C code: a panic there must not end the load.
    let ok = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| mikktspace::generate_tangents(&mut corners)));
    if !matches!(ok, Ok(true)) {
        return false;
    }
    let out = corners.out;
    // Vertex → the copies made of it, with their tangents (the vertex itself first).
    let mut copies: HashMap<u32, Vec<(Vec4, u32)>> = HashMap::new();
    for (k, tri) in range.clone().enumerate() {
        for vert in 0..3 {
            let tangent = out[3 * k + vert];
            let tangent = if tangent.is_finite() { tangent } else { Vec4::ZERO };
            let i = mesh.indices[tri][vert];
            let known = copies.entry(i).or_default();
            let index = match known.iter().find(|(t, _)| *t == tangent) {
                Some(&(_, index)) => index,
                None if known.is_empty() => {
                    known.push((tangent, i));
                    i
                }
                None => {
                    let index = split(mesh, i as usize);
                    copies.get_mut(&i).expect("inserted above").push((tangent, index));
                    index
                }
            };
            mesh.indices[tri][vert] = index;
            mesh.tangents.as_mut().expect("made above")[index as usize] = tangent;
        }
    }
    true
}

/// Appends a copy of vertex `i` (every per-vertex array) and returns its index.
fn split(mesh: &mut Mesh, i: usize) -> u32 {
    fn copy<T: Copy>(v: &mut Option<Vec<T>>, i: usize) {
        if let Some(v) = v {
            v.push(v[i]);
        }
    }
    mesh.positions.push(mesh.positions[i]);
    copy(&mut mesh.normals, i);
    copy(&mut mesh.colors, i);
    copy(&mut mesh.uvs, i);
    copy(&mut mesh.uvs1, i);
    copy(&mut mesh.tangents, i);
    (mesh.positions.len() - 1) as u32
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A unit quad in the xy plane facing +z, texture coordinates = (x, y), or mirrored in u
    /// on the right half (x > 0.5) when `mirrored`.
    fn quad(mirrored: bool) -> Mesh {
        let xs = [0.0, 0.5, 1.0];
        let mut positions = Vec::new();
        let mut uvs = Vec::new();
        for y in [0.0, 1.0] {
            for x in xs {
                positions.push(Vec3::new(x, y, 0.0));
                uvs.push(Vec2::new(if mirrored && x > 0.5 { 1.0 - x } else { x }, y));
            }
        }
        Mesh {
            name: "quad".into(),
            positions,
            indices: vec![[0, 1, 4], [0, 4, 3], [1, 2, 5], [1, 5, 4]],
            normals: Some(vec![Vec3::Z; 6]),
            uvs: Some(uvs),
            ..Default::default()
        }
    }

    #[test]
    fn tangent_follows_u_and_bitangent_v() {
        let mut m = quad(false);
        assert!(mikktspace(&mut m, 0..4, 0));
        assert_eq!(m.positions.len(), 6, "nothing to split");
        for t in m.tangents.unwrap() {
            assert!((t - Vec4::new(1.0, 0.0, 0.0, 1.0)).abs().max_element() < 1e-6, "{t}");
        }
    }

    #[test]
    fn mirrored_uvs_split_the_seam() {
        let mut m = quad(true);
        assert!(mikktspace(&mut m, 0..4, 0));
        assert_eq!(m.problem(), None);
        let t = m.tangents.as_ref().unwrap();
        for (k, tri) in m.indices.iter().enumerate() {
            // Left half: T = +x; right half (u mirrored): T = −x, and B = w·(N × T) = +y still.
            let want = if k < 2 { Vec4::new(1.0, 0.0, 0.0, 1.0) } else { Vec4::new(-1.0, 0.0, 0.0, -1.0) };
            for &i in tri {
                assert!((t[i as usize] - want).abs().max_element() < 1e-6, "triangle {k}: {}", t[i as usize]);
            }
        }
        // The two seam vertices (x = 0.5) were split.
        assert_eq!(m.positions.len(), 8);
    }

    #[test]
    fn no_texture_coordinates_no_tangents() {
        let mut m = quad(false);
        m.uvs = None;
        assert!(!mikktspace(&mut m, 0..4, 0));
        assert_eq!(m.tangents, Some(vec![Vec4::ZERO; 6]));
    }
}
