//! The project's throughput table: `cargo bench --bench table -- [SCENE ...] [--rays N]
//! [--runs K] [--threads 1,2] [--kinds primary,random,secondary]
//! [--engines embree1,embree8,native]`. Prints, per scene, build
//! times and Mrays/s of Embree single rays, Embree packets and the native BVH on the same rays
//! (`strahl::bench`). Scenes: see `benches/scenes.rs` (default: bunny and dragon).

mod scenes;

use strahl::bench::{self, Config};

fn main() {
    let mut config = Config::default();
    let mut names = Vec::new();
    let mut args = std::env::args().skip(1);
    while let Some(arg) = args.next() {
        let mut value = || args.next().unwrap_or_else(|| panic!("{arg} needs a value"));
        match arg.as_str() {
            "--bench" => {}
            "--rays" => config.rays = value().parse().expect("--rays N"),
            "--runs" => config.runs = value().parse().expect("--runs K"),
            "--threads" => config.threads = value().split(',').map(|t| t.parse().expect("--threads 1,2")).collect(),
            "--engines" => config.engines = value().split(',').map(|e| e.parse().unwrap()).collect(),
            "--kinds" => config.kinds = value().split(',').map(|k| k.parse().unwrap()).collect(),
            name => names.push(name.to_string()),
        }
    }
    if names.is_empty() {
        names = vec!["bunny".into(), "dragon".into()];
    }
    for name in names {
        let Some(scene) = scenes::load(&name) else {
            println!("{name}: skipped (file not found)");
            continue;
        };
        let report = bench::run(&scene, &config).unwrap_or_else(|e| panic!("{name}: {e}"));
        println!("== {name}: {} rays per kind, median of {} runs\n{report}\n", config.rays, config.runs);
    }
}
