//! Midpoint subdivision (`subdivide = N` on a `mesh` object): every triangle `p0 p1 p2` is
//! split into four, `N` times over (`4ᴺ` triangles for each one of the file),
//!
//! ```text
//!   m01 = (p0 + p1)/2,  m12 = (p1 + p2)/2,  m20 = (p2 + p0)/2
//!   p0 m01 m20,  m01 p1 m12,  m20 m12 p2,  m01 m12 m20
//! ```
//!
//! keeping the winding. The new vertex of an edge is made once and shared by the triangles on
//! both sides, so a closed mesh stays closed (no cracks) and the vertex count grows like the
//! triangle count's half. Vertex normals (renormalised), colours and texture coordinates are
//! averaged the same way; per-triangle materials pass to the four children.
//!
//! The subdivision is linear: the surface does not move, only its triangles get smaller. It
//! makes large meshes from small shipped files (the scale scene, `scenes/scale/`) and gives
//! vertex normals and colours a finer interpolation. Hand-written (a few lines of index
//! bookkeeping): the mesh crates on crates.io (e.g. `meshopt`) simplify, not refine.

use std::collections::HashMap;

use super::Mesh;
use crate::math::{Vec2, Vec3};

/// Most levels `subdivide` takes (the scene file also bounds the resulting triangle count).
pub const MAX_LEVELS: u32 = 8;

/// `mesh` with every triangle split into four, `levels` times over.
pub fn subdivide(mesh: &Mesh, levels: u32) -> Mesh {
    (0..levels).fold(mesh.clone(), |m, _| once(&m))
}

/// The triangle count after `levels` subdivisions of `triangles`, if it fits in a `u64`.
pub fn triangles_after(triangles: usize, levels: u32) -> Option<u64> {
    4u64.checked_pow(levels)?.checked_mul(triangles as u64)
}

/// One level of subdivision.
fn once(mesh: &Mesh) -> Mesh {
    let mut out = Mesh {
        name: mesh.name.clone(),
        positions: mesh.positions.clone(),
        indices: Vec::with_capacity(mesh.indices.len() * 4),
        normals: mesh.normals.clone(),
        colors: mesh.colors.clone(),
        uvs: mesh.uvs.clone(),
        uvs1: mesh.uvs1.clone(),
        tangents: mesh.tangents.clone(),
        // The alpha test's vertex alphas are not carried through subdivision.
        alphas: None,
        material: mesh.material,
        triangle_materials: mesh.triangle_materials.as_ref().map(|m| m.iter().flat_map(|&x| [x; 4]).collect()),
    };
    // The vertex made for each edge, keyed by its two vertex indices in increasing order.
    let mut midpoints: HashMap<(u32, u32), u32> = HashMap::with_capacity(mesh.indices.len() * 3 / 2);
    let mut midpoint = |out: &mut Mesh, a: u32, b: u32| -> u32 {
        *midpoints.entry((a.min(b), a.max(b))).or_insert_with(|| {
            let (i, j) = (a.min(b) as usize, a.max(b) as usize);
            let mid3 = |v: &[Vec3]| 0.5 * (v[i] + v[j]);
            let m = mid3(&out.positions);
            out.positions.push(m);
            if let Some(n) = &mut out.normals {
                let mid = mid3(n).normalize_or_zero();
                n.push(if mid == Vec3::ZERO { n[i] } else { mid });
            }
            if let Some(c) = &mut out.colors {
                let mid = mid3(c);
                c.push(mid);
            }
            if let Some(t) = &mut out.tangents {
                let mid = (0.5 * (t[i].truncate() + t[j].truncate())).normalize_or_zero();
                t.push(mid.extend(t[i].w));
            }
            for t in [&mut out.uvs, &mut out.uvs1].into_iter().flatten() {
                let mid: Vec2 = 0.5 * (t[i] + t[j]);
                t.push(mid);
            }
            (out.positions.len() - 1) as u32
        })
    };
    for &[a, b, c] in &mesh.indices {
        let (ab, bc, ca) = (midpoint(&mut out, a, b), midpoint(&mut out, b, c), midpoint(&mut out, c, a));
        out.indices.extend([[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tent() -> Mesh {
        // Two triangles sharing the edge 0–1, with normals, colours and uvs.
        Mesh {
            name: "tent".into(),
            positions: vec![Vec3::ZERO, Vec3::X * 2.0, Vec3::new(1.0, 2.0, 0.0), Vec3::new(1.0, -2.0, 2.0)],
            indices: vec![[0, 1, 2], [1, 0, 3]],
            normals: Some(vec![Vec3::Z, Vec3::Z, Vec3::Y, Vec3::X]),
            colors: Some(vec![Vec3::ZERO, Vec3::ONE, Vec3::X, Vec3::Y]),
            uvs: Some(vec![Vec2::ZERO, Vec2::X, Vec2::Y, Vec2::ONE]),
            uvs1: None,
            tangents: None,
            alphas: None,
            material: 3,
            triangle_materials: Some(vec![5, 6]),
        }
    }

    #[test]
    fn one_level_splits_at_shared_midpoints() {
        let s = subdivide(&tent(), 1);
        // 4 + 5 edges' midpoints (the shared edge's made once), 8 triangles.
        assert_eq!((s.positions.len(), s.indices.len()), (9, 8));
        assert_eq!(s.positions[4], Vec3::X); // midpoint of 0–1
        assert_eq!(s.indices[..4], [[0, 4, 6], [4, 1, 5], [6, 5, 2], [4, 5, 6]]);
        // The second triangle reuses vertex 4 for its edge 1–0.
        assert_eq!(s.indices[4], [1, 4, 8]);
        assert_eq!(s.triangle_materials.as_deref(), Some(&[5, 5, 5, 5, 6, 6, 6, 6][..]));
        // Attributes averaged: normal of 1–2 is (Z + Y)/|Z + Y|, colour and uv halves.
        assert_eq!(s.normals.as_ref().unwrap()[5], (Vec3::Z + Vec3::Y).normalize());
        assert_eq!(s.colors.as_ref().unwrap()[4], Vec3::splat(0.5));
        assert_eq!(s.uvs.as_ref().unwrap()[6], Vec2::new(0.0, 0.5));
        // Area and winding kept: the children's normals sum to the parent's.
        let area = |m: &Mesh, range: std::ops::Range<usize>| -> Vec3 {
            range.map(|i| m.triangle(i)).map(|[a, b, c]| (b - a).cross(c - a)).sum()
        };
        let t = tent();
        assert_eq!(area(&s, 0..4), area(&t, 0..1));
        assert_eq!(area(&s, 4..8), area(&t, 1..2));
    }

    #[test]
    fn levels_multiply_triangles_by_four_and_keep_a_closed_mesh_closed() {
        let ico = crate::scene::procedural::icosphere(0);
        let s = subdivide(&ico, 3);
        assert_eq!(s.indices.len(), 20 * 64);
        // Closed: V − E + F = 2 with E = 3F/2 (every edge shared by exactly two triangles).
        let mut edges: HashMap<(u32, u32), u32> = HashMap::new();
        for t in &s.indices {
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                *edges.entry((a.min(b), a.max(b))).or_default() += 1;
            }
        }
        assert!(edges.values().all(|&n| n == 2));
        assert_eq!(s.positions.len() as i64 - edges.len() as i64 + s.indices.len() as i64, 2);
        assert_eq!(triangles_after(20, 3), Some(1280));
        assert_eq!(triangles_after(1, 40), None);
        assert_eq!(subdivide(&ico, 0), ico);
    }
}
