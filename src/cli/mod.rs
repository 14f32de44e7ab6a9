//! The `strahl` command: argument parsing and printing only. Each subcommand (one file each:
//! `render.rs`, `merge.rs`, `farm.rs`, `info.rs`, `crosscheck.rs`, `bench.rs`) turns its
//! arguments into a call of the library (`render` a [`strahl::job::RenderJob`], `merge`
//! [`strahl::output::merge`], `crosscheck` and `bench` [`strahl::verify`]) and prints what it
//! returns; this file holds what they share: loading the scene and the argument enums.
//! Errors are `anyhow` with context; `main` prints them as one line.

mod bench;
mod crosscheck;
mod denoise;
mod farm;
mod info;
mod merge;
mod output_args;
mod progress;
mod render;

use std::path::Path;

use anyhow::Context;
use clap::{Parser, Subcommand};
use strahl::scene::load::MeshFormat;
use strahl::verify::workload::RayKind;

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
    /// Denoise a strahl EXR (e.g. a merged farm frame) with Intel Open Image Denoise.
    Denoise(denoise::DenoiseArgs),
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
    let embree = match strahl::accel::embree::Device::new() {
        Ok(device) => device.describe(),
        Err(e) => format!("Embree unavailable: {e}"),
    };
    format!("strahl {}\n{embree}", env!("CARGO_PKG_VERSION"))
}

/// Runs the parsed command.
pub fn run(cli: Cli) -> anyhow::Result<()> {
    // SIGINT/SIGTERM remove the temporary files of outputs being written (strahl::sys::signals).
    strahl::sys::signals::install().context("cannot install the signal handlers")?;
    match cli.command {
        Command::Render(args) => render::run(args),
        Command::Merge(args) => merge::run(args),
        Command::Denoise(args) => denoise::run(args),
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
/// apart by the file's extension. `lit_by_environment`: the command gives the scene an
/// environment, so a glTF file without lights gets no default light.
fn load_scene_with_camera(
    path: &Path,
    camera: Option<&str>,
    lit_by_environment: bool,
) -> anyhow::Result<strahl::scene::Loaded> {
    let loaded = if strahl::scene::load::gltf::is_gltf(path) {
        strahl::scene::from_gltf_file_lit(path, camera, lit_by_environment)?
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

/// `--confine DIR`, for the commands that load a scene.
#[derive(clap::Args, Debug)]
struct ConfineArg {
    /// Read the scene's files (the scene, meshes, MTL libraries, textures, glTF buffers and
    /// images) only from inside DIR, after following symlinks: any other is refused, naming it.
    #[arg(long, value_name = "DIR")]
    confine: Option<std::path::PathBuf>,
}

/// Sets what the scene load may read and allocate ([`strahl::sys::read::LoadOptions`]):
/// `--confine` and the memory budget (`--max-memory`; `None`: the default budget).
fn set_load_options(confine: &ConfineArg, max_memory: Option<u64>) -> anyhow::Result<()> {
    let options = strahl::sys::read::LoadOptions { max_memory, confine: confine.confine.clone() };
    strahl::sys::read::set_load_options(options).map_err(anyhow::Error::msg)
}

/// [`load_scene_with_camera`] with a glTF file's first camera and no environment given.
fn load_scene(path: &Path) -> anyhow::Result<strahl::scene::Loaded> {
    load_scene_with_camera(path, None, false)
}

/// Most rays of each kind `crosscheck` and `bench` trace (a million take 30–150 MB).
const MAX_RAYS: u64 = 20_000_000;

/// `--exr-layout`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum LayoutArg {
    /// `ViewLayer.Combined.R`, `ViewLayer.Depth.Z`, … (Blender's Image node lists the passes).
    Blender,
    /// `R G B A`, `Z`, `N.X`, … (Nuke's rgba, depth and layer.channel).
    Nuke,
}

/// `--backend`: the ray-tracing backends `strahl render` can use.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Backend {
    /// Intel Embree (triangles in its BVH, spheres as user geometry).
    Embree,
    /// strahl's pure-Rust BVH (`strahl::accel::bvh`).
    Native,
}

impl From<LayoutArg> for strahl::output::exr::Layout {
    fn from(layout: LayoutArg) -> Self {
        match layout {
            LayoutArg::Blender => strahl::output::exr::Layout::Blender,
            LayoutArg::Nuke => strahl::output::exr::Layout::Nuke,
        }
    }
}

impl From<Backend> for strahl::job::Backend {
    fn from(backend: Backend) -> Self {
        match backend {
            Backend::Embree => strahl::job::Backend::Embree,
            Backend::Native => strahl::job::Backend::Native,
        }
    }
}

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

/// Refuses a scene with no meshes or spheres, naming its file: planes are tested outside both
/// BVHs, so a scene of planes alone gives the backends nothing to differ on or to be timed on.
fn check_bounded(path: &Path, scene: &strahl::Scene) -> anyhow::Result<()> {
    if scene.bounds().is_empty() {
        anyhow::bail!("{}: has no meshes or spheres to trace (planes are tested outside both BVHs)", path.display());
    }
    Ok(())
}
