//! A glTF (JSON) or GLB file's bytes; external buffers and images are looked for under a
//! folder that does not exist.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let path = std::path::Path::new("/nonexistent/strahl-fuzz/f.gltf");
    let _ = strahl::scene::load::gltf::parse_gltf(path, data.to_vec());
});
