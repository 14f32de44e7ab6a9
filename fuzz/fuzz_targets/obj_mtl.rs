//! An OBJ file's bytes, and the same bytes as an MTL library.
#![no_main]
use libfuzzer_sys::fuzz_target;
use std::path::Path;
use strahl::io::mesh::MeshOptions;

fuzz_target!(|data: &[u8]| {
    let dir = Path::new("/nonexistent/strahl-fuzz");
    let _ = strahl::io::obj::parse(&dir.join("f.obj"), data, &MeshOptions { smooth_normals: true });
    let _ = strahl::io::obj::parse_mtl(&dir.join("f.mtl"), data, &mut Vec::new());
});
