//! `strahl bench SCENE [--rays N] [--kind primary|random|secondary|shadow|all] [--threads T,...]
//! [--runs R] [--seed S]`: BVH build times and Mrays/s of Embree single rays, Embree 8-wide
//! packets and the native BVH on the same rays, per kind and thread count
//! ([`strahl::verify::bench::run`]), printed as a table. SCENE is a scene file, or a mesh file on its
//! own. The machine's load average is printed before and after: timings on a busy machine are
//! slower and noisier, and the Mrays per CPU-second rows are less affected than the wall clock.

use std::path::PathBuf;

use anyhow::Context;
use clap::Args;
use strahl::verify::bench::{self, Config};
use strahl::verify::workload;

use super::KindArg;

/// Arguments of `strahl bench`.
#[derive(Args, Debug)]
pub struct BenchArgs {
    /// The scene file (TOML), a glTF file (.gltf, .glb), or a mesh file (OBJ, PLY; optionally .gz) on its own.
    scene: PathBuf,
    #[command(flatten)]
    confine: super::ConfineArg,
    /// Rays of each kind (primary rays: the nearest square image, 1000 × 1000 for a million).
    #[arg(long, value_name = "N", default_value_t = workload::DEFAULT_RAYS as u64, value_parser = clap::value_parser!(u64).range(1..=super::MAX_RAYS))]
    rays: u64,
    /// Which rays: primary, random, secondary, shadow, or all four.
    #[arg(long, value_enum, default_value_t = KindArg::All)]
    kind: KindArg,
    /// The thread counts to measure, comma-separated; each builds and traces on that many.
    #[arg(long, value_name = "T,...", value_delimiter = ',', default_values_t = [1, 2], value_parser = clap::value_parser!(u32).range(1..=4096))]
    threads: Vec<u32>,
    /// Runs of each measurement; the table shows their median.
    #[arg(long, value_name = "R", default_value_t = 3, value_parser = clap::value_parser!(u32).range(1..=1000))]
    runs: u32,
    /// Seed of the random rays.
    #[arg(long, value_name = "S", default_value_t = 1)]
    seed: u64,
}

pub fn run(args: BenchArgs) -> anyhow::Result<()> {
    super::set_load_options(&args.confine, None)?;
    let scene = super::load_scene(&args.scene)?.scene;
    super::check_bounded(&args.scene, &scene)?;
    let config = Config {
        rays: args.rays as usize,
        kinds: args.kind.kinds(),
        threads: args.threads.iter().map(|&t| t as usize).collect(),
        runs: args.runs as usize,
        seed: args.seed,
        ..Config::default()
    };
    let kinds: Vec<&str> = config.kinds.iter().map(|k| k.name()).collect();
    let side = workload::primary_side(config.rays);
    println!(
        "{}: {} rays per kind ({}; primary: {side} × {side}), median of {} run{}; load average {}",
        args.scene.display(),
        config.rays,
        kinds.join(", "),
        config.runs,
        if config.runs == 1 { "" } else { "s" },
        load_average()
    );
    println!("{}", strahl::job::embree_device(1)?.describe());
    let report = bench::run(&scene, &config).with_context(|| format!("{}: benchmark failed", args.scene.display()))?;
    println!("{report}");
    println!("load average after: {}", load_average());
    Ok(())
}

/// The 1, 5 and 15-minute load averages (`/proc/loadavg`), or `unknown`.
fn load_average() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .ok()
        .map(|s| s.split_whitespace().take(3).collect::<Vec<_>>().join(" "))
        .filter(|s| !s.is_empty())
        .unwrap_or_else(|| "unknown".into())
}
