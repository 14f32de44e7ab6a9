//! Triangle meshes in world space, with the optional per-vertex data shading (and the alpha
//! test) interpolates.

use crate::math::{Aabb, Vec2, Vec3, Vec4};

/// A triangle mesh: f32 positions, u32 index triples, and optional per-vertex normals,
/// colours and texture coordinates (each, when present, as long as `positions`).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Mesh {
    /// Name for messages and `strahl info` (file name, OBJ group, scene object name).
    pub name: String,
    pub positions: Vec<Vec3>,
    pub indices: Vec<[u32; 3]>,
    pub normals: Option<Vec<Vec3>>,
    pub colors: Option<Vec<Vec3>>,
    /// Per-vertex alpha (glTF's `COLOR_0.a`), read only by a material's alpha test
    /// ([`crate::scene::alpha`]).
    pub alphas: Option<Vec<f32>>,
    pub uvs: Option<Vec<Vec2>>,
    /// A second set of texture coordinates (glTF's `TEXCOORD_1`), read by the textures that
    /// ask for it ([`crate::material::TextureSlot::tex_coord`]).
    pub uvs1: Option<Vec<Vec2>>,
    /// Tangents for normal mapping (glTF's `TANGENT`, or MikkTSpace's): `xyz` the unit
    /// tangent along increasing `u`, `w` = ±1 the bitangent's sign, `B = w·(N × T)`. Kept only
    /// for meshes whose material has a normal map ([`crate::normal_map`]).
    pub tangents: Option<Vec<Vec4>>,
    /// Material of every triangle, unless `triangle_materials` says otherwise.
    pub material: u32,
    /// Material per triangle (OBJ `usemtl`), as long as `indices` when present.
    pub triangle_materials: Option<Vec<u32>>,
}

impl Mesh {
    pub fn bounds(&self) -> Aabb {
        Aabb::from_points(self.positions.iter().copied())
    }

    /// The three corners of triangle `i`.
    #[inline]
    pub fn triangle(&self, i: usize) -> [Vec3; 3] {
        let [a, b, c] = self.indices[i];
        [self.positions[a as usize], self.positions[b as usize], self.positions[c as usize]]
    }

    /// The material of triangle `i`.
    #[inline]
    pub fn material_of(&self, i: usize) -> u32 {
        self.triangle_materials.as_ref().map_or(self.material, |m| m[i])
    }

    /// Why this mesh cannot be traced, if it cannot: an index out of range, a non-finite
    /// vertex, or per-vertex/per-triangle arrays of the wrong length. Checked before anything
    /// reaches a backend (an index out of range would make Embree read out of bounds).
    pub fn problem(&self) -> Option<String> {
        let n = self.positions.len();
        if let Some(problem) = triangles_problem(&self.positions, &self.indices) {
            return Some(problem);
        }
        let per_vertex = [
            ("normals", self.normals.as_ref().map(Vec::len)),
            ("colours", self.colors.as_ref().map(Vec::len)),
            ("vertex alphas", self.alphas.as_ref().map(Vec::len)),
            ("texture coordinates", self.uvs.as_ref().map(Vec::len)),
            ("second texture coordinates", self.uvs1.as_ref().map(Vec::len)),
            ("tangents", self.tangents.as_ref().map(Vec::len)),
        ];
        for (what, len) in per_vertex {
            if let Some(len) = len.filter(|&l| l != n) {
                return Some(format!("{len} {what} for {n} vertices"));
            }
        }
        if let Some(len) = self.triangle_materials.as_ref().map(Vec::len).filter(|&l| l != self.indices.len()) {
            return Some(format!("{len} triangle materials for {} triangles", self.indices.len()));
        }
        None
    }
}

/// Why `positions` and `indices` do not form a traceable triangle mesh, if they do not: a
/// non-finite vertex or an index out of range.
pub fn triangles_problem(positions: &[Vec3], indices: &[[u32; 3]]) -> Option<String> {
    let n = positions.len();
    if let Some(i) = positions.iter().position(|p| !p.is_finite()) {
        return Some(format!("vertex {i} {} is not finite", positions[i]));
    }
    if n > u32::MAX as usize {
        return Some(format!("{n} vertices are more than 32-bit indices can address"));
    }
    indices
        .iter()
        .enumerate()
        .find(|(_, tri)| tri.iter().any(|&v| v as usize >= n))
        .map(|(t, idx)| format!("triangle {t} has index {idx:?} out of range (the mesh has {n} vertices)"))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tri() -> Mesh {
        Mesh {
            name: "t".into(),
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y],
            indices: vec![[0, 1, 2]],
            ..Default::default()
        }
    }

    #[test]
    fn problems_name_the_element() {
        assert_eq!(tri().problem(), None);
        let mut m = tri();
        m.indices.push([0, 1, 3]);
        assert!(m.problem().unwrap().starts_with("triangle 1 has index [0, 1, 3] out of range"));
        let mut m = tri();
        m.positions[2].y = f32::NAN;
        assert!(m.problem().unwrap().starts_with("vertex 2"));
        let mut m = tri();
        m.normals = Some(vec![Vec3::Z]);
        assert_eq!(m.problem().unwrap(), "1 normals for 3 vertices");
    }
}
