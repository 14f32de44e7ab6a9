//! Loads every file under a folder and prints what happened: a quick survey tool.
use std::path::Path;
use strahl::io::{MeshFormat, MeshOptions, load_mesh};

fn walk(dir: &Path, out: &mut Vec<std::path::PathBuf>) {
    let mut entries: Vec<_> = std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().path()).collect();
    entries.sort();
    for p in entries {
        if p.is_dir() { walk(&p, out) } else { out.push(p) }
    }
}

fn main() {
    let root = std::env::args().nth(1).unwrap_or("../shared/data/meshes".into());
    let mut files = vec![];
    walk(Path::new(&root), &mut files);
    for f in files {
        let rel = f.strip_prefix(&root).unwrap().display().to_string();
        if MeshFormat::of(&f).is_none() {
            println!("{rel:50} (not a mesh)");
            continue;
        }
        let t = std::time::Instant::now();
        match load_mesh(&f, &MeshOptions::default()) {
            Ok(l) => {
                println!(
                    "{rel:50} ok read {} dropped {} kept {} meshes {} mats {} ({:.1?})",
                    l.triangles_read,
                    l.degenerate_dropped,
                    l.triangle_count(),
                    l.meshes.len(),
                    l.materials.len(),
                    t.elapsed()
                );
                for w in &l.warnings {
                    println!("      warn: {w}");
                }
            }
            Err(e) => println!("{rel:50} ERR {e}"),
        }
    }
}
