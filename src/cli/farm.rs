//! `strahl farm slurm SCENE -o OUT.exr --tiles N [--partition P] [--time T] [--submit]
//! [-- RENDER OPTIONS…]`: writes a Slurm job array of `N` region renders
//! (`strahl render … --tile I/N --resume`, task `I` of the array) and a merge job that runs
//! once every task has succeeded (`--dependency=afterok`), and with `--submit` submits both.
//!
//! The rule: every task renders `--tile $SLURM_ARRAY_TASK_ID/N` into `DIR/tile-I.exr` with
//! `--resume` and `exec` (so a preempted, requeued task receives SIGTERM itself, saves its
//! checkpoint and continues from it), `DIR` being `OUT.exr.farm/`; the merge job runs
//! `strahl merge OUT.exr DIR/tile-1.exr … DIR/tile-N.exr`. Paths are made absolute, since
//! the jobs run wherever Slurm starts them. Other farms drive the same two commands (README,
//! "Rendering on a farm").

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::Command;

use anyhow::{Context, bail};
use clap::{Args, Subcommand};

/// Arguments of `strahl farm`.
#[derive(Args, Debug)]
pub struct FarmArgs {
    #[command(subcommand)]
    scheduler: Scheduler,
}

#[derive(Subcommand, Debug)]
enum Scheduler {
    /// Write (and with --submit, submit) a Slurm job array of tile renders plus a merge job.
    Slurm(SlurmArgs),
}

/// Arguments of `strahl farm slurm`.
#[derive(Args, Debug)]
pub struct SlurmArgs {
    /// The scene file.
    scene: PathBuf,
    /// The merged OpenEXR image the jobs produce.
    #[arg(short, long, value_name = "OUT.exr")]
    output: PathBuf,
    /// Number of tiles (array tasks), each `--tile I/N`.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..=100_000))]
    tiles: u32,
    /// Slurm partition for both jobs.
    #[arg(long, value_name = "P")]
    partition: Option<String>,
    /// Slurm time limit of each job (Slurm's formats, e.g. 30:00 or 1-00:00:00).
    #[arg(long, value_name = "T")]
    time: Option<String>,
    /// CPUs per task (each render uses as many threads).
    #[arg(long, value_name = "C", value_parser = clap::value_parser!(u32).range(1..=4096))]
    cpus: Option<u32>,
    /// The strahl the nodes run [default: this one, by its absolute path].
    #[arg(long, value_name = "PATH")]
    strahl: Option<PathBuf>,
    /// Submit the jobs with sbatch (otherwise only write the scripts and print how to submit).
    #[arg(long)]
    submit: bool,
    /// Further `strahl render` options for every tile, after `--` (e.g. `-- --spp 16`).
    #[arg(last = true, value_name = "RENDER OPTIONS")]
    render: Vec<String>,
}

pub fn run(args: FarmArgs) -> anyhow::Result<()> {
    match args.scheduler {
        Scheduler::Slurm(a) => slurm(a),
    }
}

/// `s` quoted for a POSIX shell.
fn quote(s: &str) -> String {
    format!("'{}'", s.replace('\'', "'\\''"))
}

fn shell_path(p: &Path) -> anyhow::Result<String> {
    p.to_str().map(quote).with_context(|| format!("{}: is not UTF-8, which the job scripts need", p.display()))
}

/// `path` made absolute without requiring it to exist (its directory must).
fn absolute(path: &Path, what: &str) -> anyhow::Result<PathBuf> {
    let dir = strahl::sys::atomic::directory_of(path);
    let dir = dir
        .canonicalize()
        .with_context(|| format!("{}: the directory of the {what} does not exist", path.display()))?;
    let name = path.file_name().with_context(|| format!("{}: the {what} is not a file name", path.display()))?;
    Ok(dir.join(name))
}

fn slurm(a: SlurmArgs) -> anyhow::Result<()> {
    if !a.output.extension().is_some_and(|e| e.eq_ignore_ascii_case("exr")) {
        bail!("{}: the output must have the extension .exr", a.output.display());
    }
    if !a.scene.is_file() {
        bail!("{}: the scene file does not exist", a.scene.display());
    }
    if a.render.iter().any(|o| ["-o", "--output", "--tile", "--region", "--resume"].contains(&o.as_str())) {
        bail!("the render options after -- must not set -o, --tile, --region or --resume: the jobs set them");
    }
    let scene = a.scene.canonicalize().with_context(|| format!("{}: cannot resolve", a.scene.display()))?;
    let output = absolute(&a.output, "output")?;
    let strahl = match &a.strahl {
        Some(p) => p.clone(),
        None => std::env::current_exe().context("cannot find this strahl's path")?,
    };
    let dir = PathBuf::from(format!("{}.farm", output.display()));
    std::fs::create_dir_all(&dir).with_context(|| format!("{}: cannot create the job directory", dir.display()))?;
    let n = a.tiles;
    let tile = |i: &str| dir.join(format!("tile-{i}.exr"));

    let options = |name: &str, log: &str| -> anyhow::Result<String> {
        let mut s = String::from("#!/bin/sh\n");
        writeln!(s, "#SBATCH --job-name={name}")?;
        writeln!(s, "#SBATCH --output={}", dir.join(log).display())?;
        if let Some(p) = &a.partition {
            writeln!(s, "#SBATCH --partition={p}")?;
        }
        if let Some(t) = &a.time {
            writeln!(s, "#SBATCH --time={t}")?;
        }
        if let Some(c) = a.cpus {
            writeln!(s, "#SBATCH --cpus-per-task={c}")?;
        }
        Ok(s)
    };
    let mut render = options("strahl-render", "render-%A_%a.log")?;
    writeln!(render, "#SBATCH --array=1-{n}")?;
    writeln!(render, "#SBATCH --requeue")?;
    writeln!(render, "# Task I renders tile I of {n}; --resume continues a requeued task from its checkpoint.")?;
    let extra: Vec<String> = a.render.iter().map(|o| quote(o)).collect();
    let threads = a.cpus.map(|c| format!(" --threads {c}")).unwrap_or_default();
    let tile_path = shell_path(&dir)?;
    writeln!(
        render,
        "exec {} render {} -o {}/tile-\"$SLURM_ARRAY_TASK_ID\".exr --tile \"$SLURM_ARRAY_TASK_ID\"/{n} --resume{threads}{}",
        shell_path(&strahl)?,
        shell_path(&scene)?,
        tile_path,
        extra.iter().map(|e| format!(" {e}")).collect::<String>()
    )?;
    let mut merge = options("strahl-merge", "merge-%j.log")?;
    let parts: Vec<String> = (1..=n).map(|i| shell_path(&tile(&i.to_string()))).collect::<anyhow::Result<_>>()?;
    writeln!(merge, "exec {} merge {} {}", shell_path(&strahl)?, shell_path(&output)?, parts.join(" "))?;

    let (render_script, merge_script) = (dir.join("render.sbatch"), dir.join("merge.sbatch"));
    strahl::sys::atomic::write_atomically(&render_script, render.as_bytes())?;
    strahl::sys::atomic::write_atomically(&merge_script, merge.as_bytes())?;
    println!("wrote {} ({n} tile renders) and {}", render_script.display(), merge_script.display());
    if !a.submit {
        println!("submit with:");
        println!("  id=$(sbatch --parsable {}) && \\", render_script.display());
        println!("  sbatch --dependency=afterok:\"${{id%%;*}}\" {}", merge_script.display());
        return Ok(());
    }
    let render_id = sbatch(&[render_script.as_os_str().to_str().unwrap_or_default()])?;
    let merge_id = sbatch(&[&format!("--dependency=afterok:{render_id}"), merge_script.to_str().unwrap_or_default()])?;
    println!("submitted job array {render_id} (tiles 1-{n}) and merge job {merge_id} (after it succeeds)");
    println!("{render_id} {merge_id}");
    Ok(())
}

/// Runs `sbatch --parsable ARGS` and returns the job id it prints.
fn sbatch(args: &[&str]) -> anyhow::Result<String> {
    let out = Command::new("sbatch")
        .arg("--parsable")
        .args(args)
        .output()
        .context("cannot run sbatch (is Slurm's client installed?)")?;
    let stdout = String::from_utf8_lossy(&out.stdout);
    if !out.status.success() {
        let stderr = String::from_utf8_lossy(&out.stderr);
        bail!("sbatch {} failed: {}", args.join(" "), stderr.trim().replace('\n', "; "));
    }
    let id = stdout.trim().split(';').next().unwrap_or("").to_string();
    if id.is_empty() || !id.chars().all(|c| c.is_ascii_digit()) {
        bail!("sbatch printed no job id: {:?}", stdout.trim());
    }
    Ok(id)
}
