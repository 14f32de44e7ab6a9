//! An OBJ file's bytes, and the same bytes as an MTL library.
#![no_main]
use libfuzzer_sys::fuzz_target;
use std::path::Path;
use strahl::scene::load::mesh::MeshOptions;

fuzz_target!(|data: &[u8]| {
    let dir = Path::new("/nonexistent/strahl-fuzz");
    let _ = strahl::scene::load::obj::parse(&dir.join("f.obj"), data, &MeshOptions { smooth_normals: true });
    let _ = strahl::scene::load::obj::parse_mtl(&dir.join("f.mtl"), data, &mut Vec::new());
});
