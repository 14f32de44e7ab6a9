//! STOP-GAP, to be replaced by `strahl::io` (the PLY/OBJ loaders of another branch) after the
//! merge: a minimal reader of the Stanford ASCII PLY files (optionally gzip'd) that tests and
//! benches use to load the bunny and the dragon until then. It reads `x y z` of each vertex
//! (ignoring further vertex properties) and `vertex_indices` lists, fanning polygons into
//! triangles; nothing else. Not for user input: the library's loader is the one to use.

#![allow(dead_code)]

use std::io::{BufRead, BufReader, Read};
use std::path::{Path, PathBuf};

use strahl::math::Vec3;
use strahl::scene::Mesh;

/// The test-data directory: `STRAHL_TEST_DATA`, else `../shared/data/meshes` from the repo.
pub fn data_dir() -> PathBuf {
    std::env::var_os("STRAHL_TEST_DATA")
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/data/meshes"))
}

/// `stanford/<name>` under [`data_dir`], if it exists.
pub fn stanford(name: &str) -> Option<PathBuf> {
    let p = data_dir().join("stanford").join(name);
    p.exists().then_some(p)
}

/// Reads an ASCII PLY mesh (`.ply` or `.ply.gz`).
pub fn load(path: &Path) -> Result<Mesh, String> {
    let file = std::fs::File::open(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let reader: Box<dyn Read> = if path.extension().is_some_and(|e| e == "gz") {
        Box::new(flate2::read::GzDecoder::new(file))
    } else {
        Box::new(file)
    };
    let mut lines = BufReader::with_capacity(1 << 20, reader).lines();
    let err = |m: &str| format!("{}: {m}", path.display());
    let mut n_vertices = 0usize;
    let mut n_faces = 0usize;
    let mut vertex_props = 0usize;
    let mut in_vertex = false;
    loop {
        let line = lines.next().ok_or_else(|| err("no end_header"))?.map_err(|e| err(&e.to_string()))?;
        let words: Vec<&str> = line.split_whitespace().collect();
        match words.as_slice() {
            ["format", f, ..] if *f != "ascii" => return Err(err("only ASCII PLY")),
            ["element", "vertex", n] => {
                n_vertices = n.parse().map_err(|_| err("bad vertex count"))?;
                in_vertex = true;
            }
            ["element", "face", n] => {
                n_faces = n.parse().map_err(|_| err("bad face count"))?;
                in_vertex = false;
            }
            ["element", ..] => in_vertex = false,
            ["property", ..] if in_vertex => vertex_props += 1,
            ["end_header"] => break,
            _ => {}
        }
    }
    if vertex_props < 3 {
        return Err(err("vertices without x y z"));
    }
    let mut positions = Vec::with_capacity(n_vertices);
    for _ in 0..n_vertices {
        let line = lines.next().ok_or_else(|| err("truncated vertices"))?.map_err(|e| err(&e.to_string()))?;
        let mut it = line.split_whitespace().map(|w| w.parse::<f32>());
        let mut c = [0.0f32; 3];
        for x in &mut c {
            *x = it.next().ok_or_else(|| err("short vertex"))?.map_err(|_| err("bad vertex"))?;
        }
        positions.push(Vec3::from(c));
    }
    let mut indices = Vec::with_capacity(n_faces);
    for _ in 0..n_faces {
        let line = lines.next().ok_or_else(|| err("truncated faces"))?.map_err(|e| err(&e.to_string()))?;
        let v: Vec<u32> =
            line.split_whitespace().map(|w| w.parse::<u32>()).collect::<Result<_, _>>().map_err(|_| err("bad face"))?;
        let (&k, rest) = v.split_first().ok_or_else(|| err("empty face"))?;
        if rest.len() != k as usize || k < 3 {
            return Err(err("bad face"));
        }
        for i in 1..rest.len() - 1 {
            indices.push([rest[0], rest[i], rest[i + 1]]);
        }
    }
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let mesh = Mesh { name, positions, indices, ..Default::default() };
    if let Some(p) = mesh.problem() {
        return Err(err(&p));
    }
    Ok(mesh)
}
