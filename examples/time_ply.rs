//! Times the PLY reader on the dragon in CPU time of this thread (wall time is unreliable on
//! a shared machine): `cargo run --release --example time_ply [file]`.
use std::path::Path;

fn cpu_ns() -> u64 {
    let s = std::fs::read_to_string("/proc/thread-self/schedstat").unwrap_or_default();
    s.split_whitespace().next().and_then(|v| v.parse().ok()).unwrap_or(0)
}

fn main() {
    let arg = std::env::args().nth(1).unwrap_or("../shared/data/meshes/stanford/dragon_vrip.ply.gz".into());
    let p = Path::new(&arg);
    let (t, c) = (std::time::Instant::now(), cpu_ns());
    let data = strahl::io::mesh::read_file(p).unwrap();
    println!("read+gunzip: wall {:?}, cpu {:.1} ms", t.elapsed(), (cpu_ns() - c) as f64 / 1e6);
    for _ in 0..3 {
        let (t, c) = (std::time::Instant::now(), cpu_ns());
        let l = strahl::io::ply::parse(p, &data, &Default::default()).unwrap();
        println!(
            "parse: wall {:?}, cpu {:.1} ms, {} triangles",
            t.elapsed(),
            (cpu_ns() - c) as f64 / 1e6,
            l.triangle_count()
        );
    }
}
