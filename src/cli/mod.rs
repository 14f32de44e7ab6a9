//! The `strahl` command's subcommands, one file each (`render.rs`, `merge.rs`, `farm.rs`, `info.rs`,
//! `crosscheck.rs`, `bench.rs`), and what they share: loading the scene, the thread pool and the Embree device.
//! Errors are `anyhow` with context; `main` prints them as one line.

mod bench;
mod crosscheck;
mod farm;
mod info;
mod merge;
mod progress;
mod render;

use std::path::Path;

use anyhow::Context;
use clap::{Parser, Subcommand};
use strahl::io::MeshFormat;
use strahl::workload::RayKind;

/// strahl: an offline Whitted-style ray tracer over Intel Embree.
#[derive(Parser, Debug)]
#[command(name = "strahl", version, about, propagate_version = true)]
pub struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Render a scene file to OpenEXR (and optionally a PNG preview).
    Render(render::RenderArgs),
    /// Join the EXRs of regions of one render (`render --region`/`--tile`) into the whole image.
    Merge(merge::MergeArgs),
    /// Split a render over a farm's scheduler: `strahl farm slurm` writes (and submits) a Slurm
    /// job array of tile renders and a merge job.
    Farm(farm::FarmArgs),
    /// Load a scene and describe it: objects, counts, bounds, load time.
    Info(info::InfoArgs),
    /// Trace the same rays through Embree and the native BVH and account for every difference.
    Crosscheck(crosscheck::CrosscheckArgs),
    /// Measure BVH build times and Mrays/s of Embree (single rays, packets) and the native BVH.
    Bench(bench::BenchArgs),
}

/// What `strahl --version` prints: strahl's version, then the Embree library it loaded (version,
/// headers when they differ, ISA), or why no Embree device could be created.
pub fn version_report() -> String {
    let embree = match strahl::embree::Device::new() {
        Ok(device) => device.describe(),
        Err(e) => format!("Embree unavailable: {e}"),
    };
    format!("strahl {}\n{embree}", env!("CARGO_PKG_VERSION"))
}

/// Runs the parsed command.
pub fn run(cli: Cli) -> anyhow::Result<()> {
    // SIGINT/SIGTERM remove the temporary files of outputs being written (strahl::signals).
    strahl::signals::install().context("cannot install the signal handlers")?;
    match cli.command {
        Command::Render(args) => render::run(args),
        Command::Merge(args) => merge::run(args),
        Command::Farm(args) => farm::run(args),
        Command::Info(args) => info::run(args),
        Command::Crosscheck(args) => crosscheck::run(args),
        Command::Bench(args) => bench::run(args),
    }
}

/// Loads the scene at `path` and prints its warnings on stderr, one `warning: …` line each: a
/// scene file (TOML), a glTF file (`.gltf`, `.glb`) with its own camera and lights
/// ([`strahl::scene::from_gltf_file`], with `camera` choosing among its cameras), or a mesh
/// file (OBJ, PLY) as a scene of that mesh alone ([`strahl::scene::from_mesh_file`]), told
/// apart by the file's extension.
fn load_scene_with_camera(path: &Path, camera: Option<&str>) -> anyhow::Result<strahl::scene::Loaded> {
    let loaded = if strahl::io::gltf::is_gltf(path) {
        strahl::scene::from_gltf_file(path, camera)?
    } else if camera.is_some() {
        anyhow::bail!("{}: --camera chooses among the cameras of a glTF file; this is not one", path.display());
    } else {
        match MeshFormat::of(path) {
            Some(_) => strahl::scene::from_mesh_file(path)?,
            None => strahl::scene::load(path)?,
        }
    };
    for warning in &loaded.warnings {
        eprintln!("warning: {warning}");
    }
    Ok(loaded)
}

/// [`load_scene_with_camera`] with a glTF file's first camera.
fn load_scene(path: &Path) -> anyhow::Result<strahl::scene::Loaded> {
    load_scene_with_camera(path, None)
}

/// The image settings of the command line (`--width`, `--height`, `--spp`, `--depth`; `None`
/// keeps the scene's) applied to `image` of the scene at `path`, checked as the scene file's
/// own are ([`strahl::scene::file::image_problem`]).
fn override_image(
    path: &Path,
    image: &mut strahl::scene::ImageSpec,
    [width, height, spp, depth]: [Option<u32>; 4],
) -> anyhow::Result<()> {
    image.width = width.unwrap_or(image.width);
    image.height = height.unwrap_or(image.height);
    image.spp = spp.unwrap_or(image.spp);
    image.max_depth = depth.unwrap_or(image.max_depth);
    if let Some((_, problem)) = strahl::scene::file::image_problem(image) {
        anyhow::bail!("{}: with the command-line settings: {problem}", path.display());
    }
    Ok(())
}

/// The passes of `--passes LIST`.
fn parse_passes(list: &[String]) -> anyhow::Result<strahl::passes::PassSet> {
    strahl::passes::PassSet::parse(list).map_err(|m| anyhow::anyhow!("--passes: {m}"))
}

/// Most rays of each kind `crosscheck` and `bench` trace (a million take 30–150 MB).
const MAX_RAYS: u64 = 20_000_000;

/// Which kinds of rays `bench` traces (`crosscheck` takes [`CrosscheckKind`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
enum KindArg {
    Primary,
    Random,
    Secondary,
    Shadow,
    All,
}

impl KindArg {
    fn kinds(self) -> Vec<RayKind> {
        match self {
            KindArg::Primary => vec![RayKind::Primary],
            KindArg::Random => vec![RayKind::Random],
            KindArg::Secondary => vec![RayKind::Secondary],
            KindArg::Shadow => vec![RayKind::Shadow],
            KindArg::All => RayKind::ALL.to_vec(),
        }
    }
}

/// Which kinds of rays `crosscheck` compares: the closest-hit kinds (shadow rays are any-hit
/// queries, with no hit to compare).
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
enum CrosscheckKind {
    Primary,
    Random,
    Secondary,
    All,
}

impl CrosscheckKind {
    fn kinds(self) -> Vec<RayKind> {
        match self {
            CrosscheckKind::Primary => vec![RayKind::Primary],
            CrosscheckKind::Random => vec![RayKind::Random],
            CrosscheckKind::Secondary => vec![RayKind::Secondary],
            CrosscheckKind::All => RayKind::CLOSEST_HIT.to_vec(),
        }
    }
}

/// The number of threads to use: one per core this process may run on (its affinity and
/// cgroup quota, as [`std::thread::available_parallelism`] reads them), or `requested` if that
/// is fewer. More would only wait for each other: an idle rayon worker tries to steal from
/// every other one, so the waiting grows with the square of the count (`--threads 4096` took
/// 50 s on 2 cores for an 8 × 8 image); a note says so.
fn thread_count(requested: Option<usize>) -> usize {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    match requested {
        Some(t) if t > cores => {
            eprintln!("note: --threads {t} is more than the {cores} cores this process may use: using {cores}");
            cores
        }
        Some(t) => t,
        None => cores,
    }
}

/// A rayon pool of `threads` workers, each with flush-to-zero on as Embree asks.
fn thread_pool(threads: usize) -> anyhow::Result<rayon::ThreadPool> {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .thread_name(|i| format!("strahl-{i}"))
        .start_handler(|_| strahl::embree::enable_flush_to_zero())
        .build()
        .with_context(|| format!("cannot start {threads} threads"))
}

/// An Embree device that builds BVHs on `threads` threads.
fn embree_device(threads: usize) -> anyhow::Result<strahl::embree::Device> {
    strahl::embree::Device::with_options(strahl::embree::DeviceOptions { threads: Some(threads) })
        .context("cannot start Embree")
}

/// Refuses a scene with no meshes or spheres, naming its file: planes are tested outside both
/// BVHs, so a scene of planes alone gives the backends nothing to differ on or to be timed on.
fn check_bounded(path: &Path, scene: &strahl::Scene) -> anyhow::Result<()> {
    if scene.bounds().is_empty() {
        anyhow::bail!("{}: has no meshes or spheres to trace (planes are tested outside both BVHs)", path.display());
    }
    Ok(())
}
