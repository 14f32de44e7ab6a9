//! `strahl farm slurm SCENE -o OUT.exr --tiles N [--partition P] [--time T] [--cpus C]
//! [--strahl PATH] [--confine DIR] [--submit] [-- RENDER OPTIONS…]`: writes a Slurm job array
//! of `N` tile renders and a merge job into `OUT.exr.farm/` ([`strahl::farm`] writes the
//! scripts and states how every value reaches the jobs unchanged), and with `--submit`
//! submits both, the merge after the array (`--dependency=afterany`).
//!
//! The rule: whatever every task would refuse is refused here, before anything is written
//! (no `OUT.exr.farm/` is left by a refusal). The render options are parsed by `strahl
//! render`'s own parser, and refused when they set what the jobs set (`-o`, `--tile`,
//! `--region`, `--resume`, `--confine`, a second scene), when every tile would write the same
//! file (`--png`), when `--threads` is given (each task runs `--cpus` threads), or when they
//! are invalid. The scene is loaded with them, so that a scene every task would refuse is
//! refused here, `N` is at most the image's height (a tile is at least one row), and a tile
//! must fit an explicit `--max-memory`. Paths are
//! made absolute, since the jobs run wherever Slurm starts them.

use std::ffi::OsString;
use std::path::{Path, PathBuf};
use std::process::Command;

use anyhow::{Context, bail};
use clap::parser::ValueSource;
use clap::{ArgMatches, Args, Subcommand};
use strahl::farm::{MAX_TILES, Scripts, SlurmJob};
use strahl::scene::load::MeshFormat;

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
    /// Number of tiles (array tasks), each `--tile I/N`: at most the image height and 10000.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..=MAX_TILES as i64))]
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
    /// Every task renders with `--confine DIR`: reads no file outside DIR.
    #[arg(long, value_name = "DIR")]
    confine: Option<PathBuf>,
    /// Submit the jobs with sbatch (otherwise only write the scripts and print how to submit).
    #[arg(long)]
    submit: bool,
    /// Denoise the merged frame once with Intel Open Image Denoise (`strahl denoise`, run by the
    /// merge job); the tiles must render the combined, albedo and normal passes, and should
    /// render denoising_albedo and denoising_normal (what `render --denoise` adds, and the
    /// denoiser's better guides; without them it uses albedo and normal).
    #[arg(long)]
    denoise: bool,
    /// Further `strahl render` options for every tile, after `--` (e.g. `-- --spp 16`).
    #[arg(last = true, value_name = "RENDER OPTIONS")]
    render: Vec<OsString>,
}

pub fn run(args: FarmArgs) -> anyhow::Result<()> {
    match args.scheduler {
        Scheduler::Slurm(a) => slurm(a),
    }
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

/// The render options the jobs set themselves (or that no tile may set), and why.
const SET_BY_THE_JOBS: [(&str, &str); 7] = [
    ("scene", "name a scene: farm slurm's SCENE is every task's"),
    ("output", "set -o/--output: each task writes its tile into OUT.exr.farm/"),
    ("tile", "set --tile: each task renders its own"),
    ("region", "set --region: the tasks render tiles"),
    ("resume", "set --resume: every task resumes already"),
    ("confine", "set --confine: give it to farm slurm (--confine DIR)"),
    ("png", "set --png: every tile would write the same PNG"),
];

/// One line of a clap error, without its `error: ` prefix and usage.
fn clap_message(e: &clap::Error) -> String {
    use clap::error::ErrorKind;
    if matches!(e.kind(), ErrorKind::DisplayHelp | ErrorKind::DisplayVersion) {
        return "asks for help or the version".into();
    }
    let rendered = e.render().to_string();
    let first = rendered.split("\n\n").next().unwrap_or_default();
    let words: Vec<&str> = first.split_whitespace().collect();
    words.join(" ").trim_start_matches("error: ").to_string()
}

/// The render options parsed by `strahl render`'s own parser, refused as the module docs say.
fn parse_render_options(a: &SlurmArgs) -> anyhow::Result<ArgMatches> {
    let command = || super::render::RenderArgs::augment_args(clap::Command::new("render").no_binary_name(true));
    let alone = command().mut_arg("scene", |s| s.required(false)).mut_arg("output", |o| o.required(false));
    let m = alone
        .try_get_matches_from(&a.render)
        .map_err(|e| anyhow::anyhow!("the render options after --: {}", clap_message(&e)))?;
    let given = |id: &str| m.ids().any(|i| i == id) && m.value_source(id) == Some(ValueSource::CommandLine);
    for (id, why) in SET_BY_THE_JOBS {
        if given(id) {
            bail!("the render options after -- must not {why}");
        }
    }
    if let Some(&t) = m.get_one::<u32>("threads") {
        match a.cpus {
            Some(c) if c == t => bail!("-- --threads {t}: the tasks already run --cpus {c} threads; leave it out"),
            Some(c) => bail!(
                "-- --threads {t} disagrees with --cpus {c}: each task gets {c} CPUs and runs as many threads; leave --threads out"
            ),
            None => bail!("-- --threads {t}: Slurm gives a task one CPU unless told: give --cpus {t} instead"),
        }
    }
    Ok(m)
}

/// The command line every task runs, parsed by `strahl render`'s parser (tile 1): what the
/// checks above did not foresee fails here rather than in every task.
fn parse_task(a: &SlurmArgs, job: &SlurmJob, scripts: &Scripts) -> anyhow::Result<()> {
    let command = super::render::RenderArgs::augment_args(clap::Command::new("render").no_binary_name(true));
    let mut argv: Vec<OsString> = vec![job.scene.clone().into(), "-o".into(), scripts.folder.join("tile-1.exr").into()];
    argv.extend(["--tile".into(), format!("1/{}", job.tiles).into(), "--resume".into()]);
    if let Some(c) = job.cpus {
        argv.extend(["--threads".into(), c.to_string().into()]);
    }
    if let Some(d) = &job.confine {
        argv.extend(["--confine".into(), d.clone().into()]);
    }
    argv.extend(a.render.iter().cloned());
    command.try_get_matches_from(argv).map_err(|e| anyhow::anyhow!("a task's render command: {}", clap_message(&e)))?;
    Ok(())
}

/// Loads the scene as every task will (camera, image overrides, passes) and checks the tiles
/// against its height and the files it reads against `--confine`.
/// With `--denoise`, the tiles' passes must hold what `strahl denoise` reads.
fn check_denoise_passes(a: &SlurmArgs, scene: &Path, passes: strahl::output::passes::PassSet) -> anyhow::Result<()> {
    use strahl::output::passes::Pass;
    let needed = [Pass::Combined, Pass::Albedo, Pass::Normal];
    if a.denoise && !needed.iter().all(|&p| passes.contains(p)) {
        bail!(
            "{}: --denoise needs the combined, albedo and normal passes in every tile; add them to \
             `-- --passes`",
            scene.display()
        );
    }
    Ok(())
}

fn check_scene(a: &SlurmArgs, scene: &Path, confine: Option<&Path>, m: &ArgMatches) -> anyhow::Result<()> {
    let camera = m.get_one::<String>("camera").map(String::as_str);
    let environment = m.get_one::<String>("environment").is_some();
    let mut loaded = super::load_scene_with_camera(scene, camera, environment)?;
    let get = |id: &str| m.get_one::<u32>(id).copied();
    strahl::job::override_image(
        scene,
        &mut loaded.scene.image,
        [get("width"), get("height"), get("spp"), get("depth")],
    )?;
    let scene_data = &mut loaded.scene;
    if let Some(passes) = m.get_many::<String>("passes") {
        scene_data.output.passes = strahl::job::parse_passes(&passes.cloned().collect::<Vec<_>>())?;
    }
    scene_data.output.transparent |= m.get_flag("transparent");
    if let Some(&levels) = m.get_one::<u32>("cryptomatte_levels") {
        scene_data.output.crypto_levels = levels;
    }
    if let Some(&integrator) = m.get_one::<strahl::scene::IntegratorKind>("integrator") {
        scene_data.render.integrator = integrator;
    }
    if let Some(&clamp) = m.get_one::<f32>("clamp") {
        scene_data.render.clamp = Some(clamp);
    }
    if let Some(&threshold) = m.get_one::<f32>("adaptive_threshold") {
        scene_data.render.set_adaptive_threshold(threshold);
    }
    if let Some(&sampler) = m.get_one::<strahl::light::set::LightSampler>("light_sampler") {
        scene_data.render.light_sampler = sampler;
    }
    if let Some(&seed) = m.get_one::<u32>("seed") {
        scene_data.render.seed = seed;
    }
    super::render::environment_options(
        scene_data,
        m.get_one::<String>("environment").map(String::as_str),
        m.get_one::<f32>("environment_strength").copied(),
        m.get_one::<f32>("environment_rotation").copied(),
    )
    .map_err(|e| anyhow::anyhow!("-- {e}"))?;
    strahl::integrator::check_render(scene_data).map_err(|e| anyhow::anyhow!("{}: {e}", scene.display()))?;
    check_denoise_passes(a, scene, scene_data.output.passes)?;
    if let Some(name) = m.get_one::<String>("layer_name") {
        strahl::output::layer_name::check(name).map_err(|e| anyhow::anyhow!("-- {e}"))?;
    }
    if let Some(&ev) = m.get_one::<f32>("exposure") {
        if !ev.is_finite() {
            bail!("-- --exposure {ev} is not a finite number of stops");
        }
    }
    if let Some(&every) = m.get_one::<f64>("progress_interval") {
        super::progress::interval(every).map_err(|e| anyhow::anyhow!("-- {e}"))?;
    }
    if let Some(&every) = m.get_one::<f64>("checkpoint_every") {
        strahl::job::checkpoint_interval(every).map_err(|e| anyhow::anyhow!("-- {e}"))?;
    }
    let (width, height) = (scene_data.image.width, scene_data.image.height);
    if a.tiles > height {
        bail!(
            "{}: --tiles {} is more than the image's {height} rows (a tile is at least one row)",
            a.scene.display(),
            a.tiles
        );
    }
    // An explicit budget is the same on every node (the default is each node's own memory).
    if let Some(&limit) = m.get_one::<u64>("max_memory") {
        let rows = height.div_ceil(a.tiles) as u64;
        let needs = strahl::job::memory::estimate(scene_data, rows * width as u64);
        if needs.total() > limit {
            bail!(
                "{}: a tile needs about {needs}, more than -- --max-memory {}: use more tiles or raise it",
                a.scene.display(),
                strahl::job::memory::megabytes(limit)
            );
        }
    }
    if let Some(dir) = confine {
        for input in strahl::sys::read::inputs_read() {
            let resolved = input.canonicalize().unwrap_or(input.clone());
            if !resolved.starts_with(dir) {
                bail!("{}: is read by the scene but outside --confine {}", input.display(), dir.display());
            }
        }
    }
    Ok(())
}

fn slurm(a: SlurmArgs) -> anyhow::Result<()> {
    if !a.output.extension().is_some_and(|e| e.eq_ignore_ascii_case("exr")) {
        bail!("{}: the output must have the extension .exr", a.output.display());
    }
    if !a.scene.is_file() {
        bail!("{}: the scene file does not exist", a.scene.display());
    }
    if MeshFormat::of(&a.scene).is_some() {
        bail!(
            "{}: is a mesh file, with no camera or lights to render it by; name it in a scene file \
             (an object of `type = \"mesh\"`, see docs/scene-format.md)",
            a.scene.display()
        );
    }
    let scene = a.scene.canonicalize().with_context(|| format!("{}: cannot resolve", a.scene.display()))?;
    let output = absolute(&a.output, "output")?;
    let strahl = match &a.strahl {
        // A bare name is looked up on the nodes' PATH; a path is made absolute.
        Some(p) if p.components().count() > 1 => {
            std::path::absolute(p).with_context(|| format!("--strahl {}: cannot make it absolute", p.display()))?
        }
        Some(p) => p.clone(),
        None => std::env::current_exe().context("cannot find this strahl's path")?,
    };
    let confine = match &a.confine {
        Some(dir) => {
            let has_confine = super::render::RenderArgs::augment_args(clap::Command::new("render"))
                .get_arguments()
                .any(|arg| arg.get_id() == "confine");
            if !has_confine {
                bail!("--confine: this strahl's render has no --confine to pass to the tasks");
            }
            let d = dir.canonicalize().with_context(|| format!("--confine {}: cannot resolve", dir.display()))?;
            if !d.is_dir() {
                bail!("--confine {}: is not a directory", dir.display());
            }
            if !scene.starts_with(&d) {
                bail!("{}: the scene is outside --confine {}", a.scene.display(), dir.display());
            }
            Some(d)
        }
        None => None,
    };
    let job = SlurmJob {
        strahl,
        scene: scene.clone(),
        output,
        tiles: a.tiles,
        partition: a.partition.clone(),
        time: a.time.clone(),
        cpus: a.cpus,
        confine: confine.clone(),
        render_options: a.render.clone(),
        denoise: a.denoise,
    };
    let scripts = strahl::farm::slurm_scripts(&job)?;
    let options = parse_render_options(&a)?;
    parse_task(&a, &job, &scripts)?;
    check_scene(&a, &scene, confine.as_deref(), &options)?;

    write_scripts(&scripts)?;
    let (render_script, merge_script) = (scripts.render_path(), scripts.merge_path());
    let n = a.tiles;
    println!("wrote {} ({n} tile renders) and {}", render_script.display(), merge_script.display());
    if !a.submit {
        println!("submit with:");
        for line in scripts.submit_commands().lines() {
            println!("  {line}");
        }
        return Ok(());
    }
    let render_id = sbatch(&[render_script.as_os_str()])?;
    let dependency = format!("--dependency=afterany:{render_id}");
    let merge_id = sbatch(&[dependency.as_ref(), merge_script.as_os_str()]).with_context(|| {
        format!("submitted the render array {render_id}, but not the merge (submit it with `sbatch {dependency} …/merge.sbatch`)")
    })?;
    println!("submitted job array {render_id} (tiles 1-{n}) and merge job {merge_id} (after the array ends)");
    println!("{render_id} {merge_id}");
    Ok(())
}

/// Writes both scripts into their folder, creating it; a failure removes a folder it created.
fn write_scripts(scripts: &Scripts) -> anyhow::Result<()> {
    let folder = &scripts.folder;
    let created = match std::fs::create_dir(folder) {
        Ok(()) => true,
        Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists && folder.is_dir() => false,
        Err(e) => return Err(e).with_context(|| format!("{}: cannot create the job folder", folder.display())),
    };
    let written = strahl::sys::atomic::write_atomically(&scripts.render_path(), scripts.render.as_bytes())
        .and_then(|()| strahl::sys::atomic::write_atomically(&scripts.merge_path(), scripts.merge.as_bytes()));
    if let Err(e) = written {
        if created {
            let _ = std::fs::remove_dir_all(folder);
        }
        return Err(e.into());
    }
    Ok(())
}

/// Runs `sbatch --parsable ARGS` and returns the job id it prints.
fn sbatch(args: &[&std::ffi::OsStr]) -> anyhow::Result<String> {
    let out = Command::new("sbatch")
        .arg("--parsable")
        .args(args)
        .output()
        .context("cannot run sbatch (is Slurm's client installed?)")?;
    let stdout = String::from_utf8_lossy(&out.stdout);
    let shown: Vec<String> = args.iter().map(|a| a.to_string_lossy().into_owned()).collect();
    if !out.status.success() {
        let stderr = String::from_utf8_lossy(&out.stderr);
        bail!("sbatch {} failed: {}", shown.join(" "), stderr.trim().replace('\n', "; "));
    }
    let id = stdout.trim().split(';').next().unwrap_or("").to_string();
    if id.is_empty() || !id.chars().all(|c| c.is_ascii_digit()) {
        bail!("sbatch printed no job id: {:?}", stdout.trim());
    }
    Ok(id)
}
