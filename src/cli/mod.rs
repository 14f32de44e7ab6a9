//! The `strahl` command's subcommands, one file each (`render.rs`, `info.rs`; `crosscheck` and
//! `bench` are added the same way), and what they share: loading the scene, the thread pool and
//! the Embree device. Errors are `anyhow` with context; `main` prints them as one line.

mod info;
mod render;

use std::path::Path;

use anyhow::Context;
use clap::{Parser, Subcommand};

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
    /// Load a scene and describe it: objects, counts, bounds, load time.
    Info(info::InfoArgs),
}

/// Runs the parsed command.
pub fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        Command::Render(args) => render::run(args),
        Command::Info(args) => info::run(args),
    }
}

/// Loads the scene file at `path` and prints its warnings on stderr, one `warning: …` line each.
fn load_scene(path: &Path) -> anyhow::Result<strahl::scene::Loaded> {
    let loaded = strahl::scene::load(path)?;
    for warning in &loaded.warnings {
        eprintln!("warning: {warning}");
    }
    Ok(loaded)
}

/// The number of threads to use: `requested`, or one per core.
fn thread_count(requested: Option<usize>) -> usize {
    requested.unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()))
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
