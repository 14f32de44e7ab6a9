//! Writes the meshes strahl makes itself for the shipped scenes into scenes/meshes/:
//! `cargo run --example gen_meshes`. tests/meshes.rs checks the committed files are current.

use std::path::Path;

fn main() -> std::io::Result<()> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/meshes");
    std::fs::create_dir_all(&dir)?;
    for (name, mesh, comment) in strahl::scene::procedural::shipped_meshes() {
        let path = dir.join(name);
        let mut out = Vec::new();
        strahl::scene::load::ply::write_ascii(&mesh, &mut out, comment)?;
        std::fs::write(&path, out)?;
        println!("wrote {} ({} triangles, {} vertices)", path.display(), mesh.indices.len(), mesh.positions.len());
    }
    Ok(())
}
