//! Loading triangle meshes from the files other tools write: [`load_mesh`] reads Wavefront OBJ
//! (with its MTL materials) and PLY (ASCII and both binary byte orders), either of them
//! gzip-compressed (`.obj.gz`, `.ply.gz`), into world-independent [`Mesh`]es.
//!
//! What every loaded mesh satisfies, whatever the format:
//! - polygons are triangulated in their own plane (see [`super::polygon`]), keeping the file's
//!   winding; a non-planar polygon, one that crosses or overlaps itself, or a huge one is
//!   still triangulated (best-fit plane, else a fan), with one warning per file counting them;
//! - triangles of zero area are dropped and counted ([`LoadedMesh::degenerate_dropped`], and a
//!   warning), never passed on;
//! - vertices no remaining triangle uses are left out; the others keep their order;
//! - per-vertex normals from the file are kept (normalised); without them,
//!   [`MeshOptions::smooth_normals`] computes area-weighted ones;
//! - non-finite coordinates and face indices out of range are errors naming the file and line.
//!
//! A file with no faces at all (a point cloud, an OBJ of lines) or whose faces all have zero
//! area is an **error**, not an empty mesh: a renderer given a mesh that draws nothing almost
//! certainly got the wrong file, and saying so at load time beats a silently empty image.

use std::path::{Path, PathBuf};

use crate::material::Material;
use crate::math::{Vec2, Vec3};
use crate::scene::Mesh;
use crate::sys::read::{self, ReadError};

/// How to load a mesh.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MeshOptions {
    /// Compute area-weighted per-vertex normals for meshes whose file has none (otherwise such
    /// meshes shade flat, with the geometric normal).
    pub smooth_normals: bool,
}

/// What a mesh file holds, ready for a [`crate::Scene`].
#[derive(Clone, Debug, Default)]
pub struct LoadedMesh {
    /// One mesh per OBJ group/object with faces (one for a PLY file), in file order.
    pub meshes: Vec<Mesh>,
    /// The materials the file defines (OBJ: its MTL files, plus a default material when some
    /// faces name none or an unknown one; PLY: one default material). **The material indices
    /// in [`Self::meshes`] (`Mesh::material`, `Mesh::triangle_materials`) index this list**: a
    /// scene that appends these materials to its own must add its material count to them.
    pub materials: Vec<Material>,
    /// Things the caller should tell the user, one line each, naming the file (and line).
    pub warnings: Vec<String>,
    /// Triangles the file's faces make (a polygon of n corners makes n − 2).
    pub triangles_read: usize,
    /// Of those, the ones of zero area, dropped.
    pub degenerate_dropped: usize,
}

impl LoadedMesh {
    /// Triangles in the meshes: `triangles_read − degenerate_dropped`.
    pub fn triangle_count(&self) -> usize {
        self.meshes.iter().map(|m| m.indices.len()).sum()
    }

    /// Vertices in the meshes.
    pub fn vertex_count(&self) -> usize {
        self.meshes.iter().map(|m| m.positions.len()).sum()
    }
}

/// Why a mesh file could not be loaded. Displays as one line: `path:LINE: problem` or
/// `path: problem`.
#[derive(Debug, thiserror::Error)]
pub enum MeshError {
    /// The file could not be read: missing, not a regular file, over the size limit, or
    /// corrupt or oversized gzip (see [`crate::sys::read`]). The OS error is part of the message,
    /// not a separate source, so that it is printed once.
    #[error("{}: {problem}", path.display())]
    Io { path: PathBuf, problem: ReadError },
    /// A problem at a line of a text file (OBJ, MTL, ASCII PLY and any PLY header).
    #[error("{}:{line}: {problem}", path.display())]
    AtLine { path: PathBuf, line: usize, problem: String },
    /// A problem of the file as a whole, or of binary data.
    #[error("{}: {problem}", path.display())]
    Invalid { path: PathBuf, problem: String },
}

impl MeshError {
    pub(crate) fn at(path: &Path, line: usize, problem: impl Into<String>) -> MeshError {
        MeshError::AtLine { path: path.to_owned(), line, problem: problem.into() }
    }

    pub(crate) fn invalid(path: &Path, problem: impl Into<String>) -> MeshError {
        MeshError::Invalid { path: path.to_owned(), problem: problem.into() }
    }

    /// The line the problem is at, if there is one.
    pub fn line(&self) -> Option<usize> {
        match self {
            MeshError::AtLine { line, .. } => Some(*line),
            _ => None,
        }
    }
}

/// The mesh formats [`load_mesh`] reads, chosen by file extension (`.gz` looked through).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MeshFormat {
    Obj,
    Ply,
}

impl MeshFormat {
    /// The format a path's extension names: `.obj`, `.ply`, either followed by `.gz`; any case.
    pub fn of(path: &Path) -> Option<MeshFormat> {
        let name = path.file_name()?.to_string_lossy().to_ascii_lowercase();
        let name = name.strip_suffix(".gz").unwrap_or(&name);
        match Path::new(name).extension()?.to_str()? {
            "obj" => Some(MeshFormat::Obj),
            "ply" => Some(MeshFormat::Ply),
            _ => None,
        }
    }
}

/// Loads the OBJ or PLY file at `path` (the format from its extension; gzip-compressed files
/// are recognised by their content and decompressed).
pub fn load_mesh(path: &Path, options: &MeshOptions) -> Result<LoadedMesh, MeshError> {
    let format = MeshFormat::of(path).ok_or_else(|| {
        MeshError::invalid(path, "unknown mesh format: expected a .obj or .ply file (optionally .gz)")
    })?;
    let data = read_file(path)?;
    match format {
        MeshFormat::Obj => super::obj::parse(path, &data, options),
        MeshFormat::Ply => super::ply::parse(path, &data, options),
    }
}

/// The bytes of the mesh (or MTL) file at `path`, decompressed when they start with the gzip
/// magic number; only a regular file, and at most [`read::max_mesh_bytes`] bytes before and
/// after decompression (see [`crate::sys::read`]).
pub fn read_file(path: &Path) -> Result<Vec<u8>, MeshError> {
    let io = |problem| MeshError::Io { path: path.to_owned(), problem };
    let cap = read::max_mesh_bytes().map_err(io)?;
    let raw = read::read_regular(path, cap, read::MESH_LIMIT_HINT).map_err(io)?;
    if read::is_gzip(&raw) {
        read::inflate(&raw, cap).map_err(io)
    } else if path.extension().is_some_and(|e| e.eq_ignore_ascii_case("gz")) {
        Err(MeshError::invalid(path, "named .gz but not gzip-compressed"))
    } else {
        Ok(raw)
    }
}

/// One mesh as a reader produces it: triangles over per-vertex arrays, before degenerate
/// triangles and unused vertices are dropped.
#[derive(Debug, Default)]
pub(crate) struct RawMesh {
    pub name: String,
    pub positions: Vec<Vec3>,
    pub normals: Option<Vec<Vec3>>,
    pub uvs: Option<Vec<Vec2>>,
    pub colors: Option<Vec<Vec3>>,
    pub triangles: Vec<[u32; 3]>,
    /// Material of each triangle.
    pub triangle_materials: Vec<u32>,
}

/// What a reader hands to [`finish`].
#[derive(Debug, Default)]
pub(crate) struct Parsed {
    pub meshes: Vec<RawMesh>,
    pub materials: Vec<Material>,
    pub warnings: Vec<String>,
    /// Σ (corners − 2) over the faces.
    pub triangles_read: usize,
    /// Triangles the triangulation did not emit because they had zero area.
    pub degenerate: usize,
    /// Vertices in the file (for the "no faces" message).
    pub vertices_in_file: usize,
}

/// Drops degenerate triangles and unused vertices, normalises or computes normals, and checks
/// the result: the last step of every reader.
pub(crate) fn finish(path: &Path, parsed: Parsed, options: &MeshOptions) -> Result<LoadedMesh, MeshError> {
    let Parsed { meshes: raws, materials, mut warnings, triangles_read, mut degenerate, vertices_in_file } = parsed;
    if triangles_read == 0 {
        return Err(MeshError::invalid(
            path,
            format!("no faces to render ({vertices_in_file} vertices and no polygons: a point cloud or lines?)"),
        ));
    }
    let mut meshes = Vec::with_capacity(raws.len());
    for raw in raws {
        let (mesh, dropped) = finish_one(path, raw, options, &mut warnings);
        degenerate += dropped;
        if !mesh.indices.is_empty() {
            meshes.push(mesh);
        }
    }
    if degenerate == triangles_read {
        return Err(MeshError::invalid(path, format!("all {triangles_read} triangles have zero area")));
    }
    if degenerate > 0 {
        warnings.push(format!(
            "{}: dropped {degenerate} degenerate (zero-area) triangles of {triangles_read}",
            path.display()
        ));
    }
    for m in &meshes {
        if let Some(problem) = m.problem() {
            // The readers check indices and coordinates with line numbers; this is a backstop.
            return Err(MeshError::invalid(path, format!("mesh '{}': {problem}", m.name)));
        }
    }
    Ok(LoadedMesh { meshes, materials, warnings, triangles_read, degenerate_dropped: degenerate })
}

fn finish_one(path: &Path, raw: RawMesh, options: &MeshOptions, warnings: &mut Vec<String>) -> (Mesh, usize) {
    let RawMesh { name, positions, normals, uvs, colors, triangles, triangle_materials } = raw;
    let n_read = triangles.len();
    // Zero-area triangles: exactly zero cross product in f32.
    let mut kept = Vec::with_capacity(n_read);
    let mut kept_materials = Vec::with_capacity(triangle_materials.len());
    for (i, &[a, b, c]) in triangles.iter().enumerate() {
        let (pa, pb, pc) = (positions[a as usize], positions[b as usize], positions[c as usize]);
        if (pb - pa).cross(pc - pa) != Vec3::ZERO {
            kept.push([a, b, c]);
            if let Some(&m) = triangle_materials.get(i) {
                kept_materials.push(m);
            }
        }
    }
    let dropped = n_read - kept.len();

    // Unused vertices out, order kept.
    let mut remap = vec![u32::MAX; positions.len()];
    for t in &kept {
        for &v in t {
            remap[v as usize] = 0;
        }
    }
    let mut next = 0u32;
    for r in remap.iter_mut().filter(|r| **r == 0) {
        *r = next;
        next += 1;
    }
    let all_used = next as usize == positions.len();
    fn compact<T>(v: Vec<T>, remap: &[u32], all_used: bool) -> Vec<T> {
        if all_used { v } else { v.into_iter().zip(remap).filter(|(_, r)| **r != u32::MAX).map(|(x, _)| x).collect() }
    }
    let positions = compact(positions, &remap, all_used);
    let indices: Vec<[u32; 3]> =
        if all_used { kept } else { kept.into_iter().map(|t| t.map(|v| remap[v as usize])).collect() };
    let mut normals = normals.map(|v| compact(v, &remap, all_used));
    let uvs = uvs.map(|v| compact(v, &remap, all_used));
    let colors = colors.map(|v| compact(v, &remap, all_used));

    if let Some(ns) = &mut normals {
        if let Some(i) = ns.iter().position(|n| !(n.length_squared() > 0.0)) {
            warnings.push(format!(
                "{}: mesh '{name}': vertex {i} has a zero normal; the file's normals are ignored{}",
                path.display(),
                if options.smooth_normals { " and smooth ones computed" } else { "" }
            ));
            normals = None;
        } else {
            ns.iter_mut().for_each(|n| *n = n.normalize());
        }
    }
    if normals.is_none() && options.smooth_normals {
        normals = Some(smooth_normals(&positions, &indices));
    }

    let (material, triangle_materials) = match kept_materials.first() {
        Some(&first) if kept_materials.iter().any(|&m| m != first) => (first, Some(kept_materials)),
        Some(&first) => (first, None),
        None => (0, None),
    };
    (
        Mesh {
            name,
            positions,
            indices,
            normals,
            colors,
            uvs,
            uvs1: None,
            tangents: None,
            alphas: None,
            material,
            triangle_materials,
        },
        dropped,
    )
}

/// Area-weighted vertex normals: the sum of the (unnormalised, so area-weighted) normals of the
/// triangles around each vertex, normalised. Every triangle here has a non-zero area; a vertex
/// whose neighbours' normals cancel exactly takes the normal of its first triangle.
pub fn smooth_normals(positions: &[Vec3], indices: &[[u32; 3]]) -> Vec<Vec3> {
    let mut sums = vec![Vec3::ZERO; positions.len()];
    let mut first = vec![Vec3::ZERO; positions.len()];
    for &[a, b, c] in indices {
        let (pa, pb, pc) = (positions[a as usize], positions[b as usize], positions[c as usize]);
        let n = (pb - pa).cross(pc - pa);
        for v in [a, b, c] {
            sums[v as usize] += n;
            if first[v as usize] == Vec3::ZERO {
                first[v as usize] = n;
            }
        }
    }
    sums.iter().zip(&first).map(|(s, f)| s.try_normalize().or_else(|| f.try_normalize()).unwrap_or(Vec3::Z)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn format_from_extension() {
        assert_eq!(MeshFormat::of(Path::new("a/b.OBJ")), Some(MeshFormat::Obj));
        assert_eq!(MeshFormat::of(Path::new("dragon.ply.gz")), Some(MeshFormat::Ply));
        assert_eq!(MeshFormat::of(Path::new("x.stl")), None);
        assert_eq!(MeshFormat::of(Path::new("gz")), None);
    }

    #[test]
    fn smooth_normals_of_a_tent_bisect_its_two_faces() {
        // Two faces meeting at the ridge y = 1 at 45°: the ridge normal is +y, the eaves keep
        // their own face's normal.
        let p =
            [Vec3::new(0.0, 1.0, 0.0), Vec3::new(0.0, 1.0, 1.0), Vec3::new(1.0, 0.0, 0.0), Vec3::new(-1.0, 0.0, 0.0)];
        let n = smooth_normals(&p, &[[0, 1, 2], [0, 3, 1]]);
        assert!((n[0] - Vec3::Y).length() < 1e-6, "{}", n[0]);
        assert!((n[2] - Vec3::new(1.0, 1.0, 0.0).normalize()).length() < 1e-6);
        assert!((n[3] - Vec3::new(-1.0, 1.0, 0.0).normalize()).length() < 1e-6);
    }

    #[test]
    fn finishing_drops_degenerates_and_unused_vertices_in_order() {
        let raw = RawMesh {
            name: "m".into(),
            positions: vec![Vec3::ZERO, Vec3::splat(9.0), Vec3::X, Vec3::Y, Vec3::X * 2.0],
            uvs: Some((0..5).map(|i| Vec2::splat(i as f32)).collect()),
            triangles: vec![[0, 2, 3], [0, 2, 4]],
            triangle_materials: vec![1, 2],
            ..Default::default()
        };
        let parsed = Parsed { meshes: vec![raw], triangles_read: 2, ..Default::default() };
        let l = finish(Path::new("t.obj"), parsed, &MeshOptions { smooth_normals: true }).unwrap();
        let m = &l.meshes[0];
        assert_eq!(m.positions, vec![Vec3::ZERO, Vec3::X, Vec3::Y]);
        assert_eq!(m.uvs.as_ref().unwrap(), &vec![Vec2::splat(0.0), Vec2::splat(2.0), Vec2::splat(3.0)]);
        assert_eq!(m.indices, vec![[0, 1, 2]]);
        assert_eq!((m.material, m.triangle_materials.clone()), (1, None));
        assert_eq!(m.normals.as_ref().unwrap(), &vec![Vec3::Z; 3]);
        assert_eq!((l.triangles_read, l.degenerate_dropped), (2, 1));
        assert_eq!(l.warnings, vec!["t.obj: dropped 1 degenerate (zero-area) triangles of 2"]);
    }
}
