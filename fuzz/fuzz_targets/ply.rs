//! A PLY file's bytes (ASCII or binary; gzip is the bounded reader's, tested in the suite).
#![no_main]
use libfuzzer_sys::fuzz_target;
use strahl::scene::load::mesh::MeshOptions;

fuzz_target!(|data: &[u8]| {
    let path = std::path::Path::new("/nonexistent/strahl-fuzz/f.ply");
    let _ = strahl::scene::load::ply::parse(path, data, &MeshOptions { smooth_normals: true });
});
