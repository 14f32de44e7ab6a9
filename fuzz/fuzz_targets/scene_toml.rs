//! A scene file's text: any result but a panic, hang or memory bomb. Mesh files it names are
//! looked for under a folder that does not exist.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(text) = std::str::from_utf8(data) {
        let _ = strahl::scene::from_toml_str(text, std::path::Path::new("/nonexistent/strahl-fuzz/scene.toml"));
    }
});
