//! `strahl render SCENE -o OUT.exr [--png OUT.png] [--backend embree|native]
//! [--region X0,Y0,X1,Y1 | --tile I/N] [--checkpoint-every S] [--resume]`: loads the scene
//! (its warnings on stderr), applies the command-line overrides, checks the outputs can be
//! written, picks the pixels to render (the whole image, a region, or a farm tile:
//! [`strahl::region`]), builds the backend's BVH (Embree's, or the native one), renders on a pool of
//! `--threads` workers with a progress bar, writes the EXR (and PNG) atomically and prints a
//! summary: resolution, samples, backend, rays by kind, time, Mrays/s, build time. While it
//! renders it saves the finished tiles to `OUT.exr.checkpoint` ([`strahl::checkpoint`]) every
//! `--checkpoint-every` seconds and on SIGINT/SIGTERM; `--resume` continues from it; the
//! finished render removes it.
//!
//! Both backends go through the same [`integrator::render`]; the images differ only where the
//! backends' hits differ (see `strahl crosscheck`).

use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use super::progress::Progress;
use anyhow::{Context, bail};
use clap::{Args, ValueEnum};
use strahl::Accel;
use strahl::bvh::Bvh;
use strahl::checkpoint;
use strahl::embree::{BuildOptions, EmbreeAccel};
use strahl::film::Film;
use strahl::ids::ObjectIds;
use strahl::integrator::{self, RayCounts, TileJob};
use strahl::io::MeshFormat;
use strahl::io::atomic::{directory_of, write_atomically_with};
use strahl::io::exr::{Compression, ExrOptions, Layout};
use strahl::io::exr_stream::BlockStream;
use strahl::io::metadata::RenderInfo;
use strahl::io::same_file::same_file;
use strahl::passes::MAX_CRYPTO_LEVELS;
use strahl::region::Region;
use strahl::scene::Scene;

/// Arguments of `strahl render`.
#[derive(Args, Debug)]
pub struct RenderArgs {
    /// The scene file (TOML; see docs/scene-format.md), or a glTF file (.gltf, .glb).
    scene: PathBuf,
    /// Which camera of a glTF file to render through: its index or name [default: the first].
    #[arg(long, value_name = "NAME|INDEX")]
    camera: Option<String>,
    /// Where to write the OpenEXR image (linear RGBA, Z, N, albedo).
    #[arg(short, long, value_name = "OUT.exr")]
    output: PathBuf,
    /// Also write an 8-bit sRGB PNG preview here.
    #[arg(long, value_name = "OUT.png")]
    png: Option<PathBuf>,
    /// Refuse, before building anything, a render whose estimated memory (as `strahl info`
    /// prints it) exceeds this: bytes or K/M/G/T (e.g. 8G) [default: 3/4 of physical memory].
    #[arg(long, value_name = "SIZE", value_parser = strahl::memory::parse_size)]
    max_memory: Option<u64>,
    /// Image width in pixels (overrides the scene's).
    #[arg(long, value_name = "W", allow_negative_numbers = true, value_parser = clap::value_parser!(u32).range(1..))]
    width: Option<u32>,
    /// Image height in pixels (overrides the scene's).
    #[arg(long, value_name = "H", allow_negative_numbers = true, value_parser = clap::value_parser!(u32).range(1..))]
    height: Option<u32>,
    /// Samples per pixel (overrides the scene's).
    #[arg(long, value_name = "N", allow_negative_numbers = true, value_parser = clap::value_parser!(u32).range(1..))]
    spp: Option<u32>,
    /// Longest chain of reflected/refracted rays (overrides the scene's max_depth).
    #[arg(long, value_name = "D", allow_negative_numbers = true)]
    depth: Option<u32>,
    /// Worker threads for rendering, Embree's BVH build and EXR compression [default: one per core].
    #[arg(long, value_name = "T", allow_negative_numbers = true, value_parser = clap::value_parser!(u32).range(1..=4096))]
    threads: Option<u32>,
    /// Exposure of the PNG preview in stops: its radiance is multiplied by 2^EV.
    #[arg(long, value_name = "EV", default_value_t = 0.0, allow_negative_numbers = true)]
    exposure: f32,
    /// What finds the closest hits: Intel Embree, or strahl's own BVH.
    #[arg(long, value_enum, default_value_t = Backend::Embree)]
    backend: Backend,
    /// The passes to write, comma-separated (overrides the scene's `[output] passes`):
    /// `default`, `all`, or names from combined, depth, normal, albedo, emission, diffuse,
    /// specular, reflection, transmission, background, position, object_index,
    /// material_index, crypto_object, crypto_material.
    #[arg(long, value_name = "LIST", value_delimiter = ',')]
    passes: Option<Vec<String>>,
    /// Render the background transparent: rays that escape give RGBA 0, alpha is coverage.
    #[arg(long)]
    transparent: bool,
    /// Cryptomatte ranks per pixel (overrides the scene's `cryptomatte_levels`).
    #[arg(long, value_name = "N", allow_negative_numbers = true, value_parser = clap::value_parser!(u32).range(1..=MAX_CRYPTO_LEVELS as i64))]
    cryptomatte_levels: Option<u32>,
    /// Channel naming of the EXR: Blender's multilayer names, or Nuke's.
    #[arg(long, value_enum, default_value_t = LayoutArg::Blender)]
    exr_layout: LayoutArg,
    /// Store colour passes as half floats (depth, normals, position, indices and Cryptomatte
    /// stay float32).
    #[arg(long)]
    half: bool,
    /// EXR compression: none, rle, zips, zip, piz, pxr24, b44, b44a.
    #[arg(long, value_name = "C", default_value = "zip", value_parser = parse_compression)]
    compression: Compression,
    /// Render only the pixels X0 ≤ x < X1, Y0 ≤ y < Y1 (half-open pixel bounds, (0,0) the
    /// top-left pixel); the EXR's dataWindow is that region inside the whole displayWindow.
    #[arg(long, value_name = "X0,Y0,X1,Y1", conflicts_with = "tile")]
    region: Option<String>,
    /// Render only tile I of N, I from 1 to N: N bands of whole rows, top to bottom, for
    /// splitting a frame over a farm (`strahl merge` joins the tiles).
    #[arg(long, value_name = "I/N")]
    tile: Option<String>,
    /// Save the finished tiles to OUT.exr.checkpoint every this many seconds (0: after every
    /// tile); SIGINT and SIGTERM save it too before exiting.
    #[arg(long, value_name = "SECONDS", default_value_t = 60.0, allow_negative_numbers = true)]
    checkpoint_every: f64,
    /// Continue from OUT.exr.checkpoint (when it exists): trace only the tiles it lacks. The
    /// result is the same bytes as an uninterrupted render.
    #[arg(long)]
    resume: bool,
}

/// `--exr-layout`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum LayoutArg {
    /// `ViewLayer.Combined.R`, `ViewLayer.Depth.Z`, … (Blender's Image node lists the passes).
    Blender,
    /// `R G B A`, `Z`, `N.X`, … (Nuke's rgba, depth and layer.channel).
    Nuke,
}

fn parse_compression(name: &str) -> Result<Compression, String> {
    Compression::from_name(name).ok_or_else(|| {
        let known: Vec<&str> = Compression::ALL.iter().map(|(_, n)| *n).collect();
        format!("unknown compression '{name}' (known: {})", known.join(", "))
    })
}

/// The ray-tracing backends `strahl render` can use.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Backend {
    /// Intel Embree (triangles in its BVH, spheres as user geometry).
    Embree,
    /// strahl's pure-Rust BVH (`strahl::bvh`).
    Native,
}

/// Refuses outputs that cannot be written, before any time is spent rendering.
fn check_output(path: &Path, extension: &str, what: &str) -> anyhow::Result<()> {
    let shown = path.display();
    if !path.extension().is_some_and(|e| e.eq_ignore_ascii_case(extension)) {
        bail!("{shown}: the {what} must have the extension .{extension}");
    }
    let dir = directory_of(path);
    if !dir.is_dir() {
        bail!("{shown}: the directory {} does not exist", dir.display());
    }
    if path.is_dir() {
        bail!("{shown}: is a directory");
    }
    Ok(())
}

/// Refuses, before rendering, an output (EXR, PNG, checkpoint) that is any file the scene was
/// read from (the scene, its meshes, MTL libraries, textures, glTF buffers and images:
/// [`strahl::io::read::inputs_read`]), through any link or spelling (`strahl::io::same_file`).
fn refuse_inputs_as_outputs(args: &RenderArgs) -> anyhow::Result<()> {
    let checkpoint = checkpoint::path_for(&args.output);
    let outputs = [Some(&args.output), args.png.as_ref(), Some(&checkpoint)];
    let read = strahl::io::read::inputs_read();
    for input in std::iter::once(&args.scene).chain(&read) {
        for output in outputs.iter().flatten() {
            if same_file(input, output) {
                bail!("{}: is an input ({}); writing there would destroy it", output.display(), input.display());
            }
        }
    }
    Ok(())
}

/// Refuses a render whose estimated memory ([`strahl::memory::estimate`]) is over
/// `--max-memory` (default 3/4 of the machine's memory), saying what it needs and what to do.
fn refuse_over_budget(args: &RenderArgs, scene: &Scene, region: Region) -> anyhow::Result<()> {
    use strahl::memory::{default_limit, estimate, megabytes};
    let Some(limit) = args.max_memory.or_else(default_limit) else { return Ok(()) };
    let needs = estimate(scene, region.pixel_count());
    if needs.total() > limit {
        let whose = if args.max_memory.is_some() { "" } else { " (3/4 of this machine's memory)" };
        bail!(
            "{}: this render needs about {needs}, more than --max-memory {}{whose}: render a smaller image \
             (--width/--height), fewer passes (--passes), parts of it (--region or --tile, then strahl merge), \
             or raise --max-memory",
            args.scene.display(),
            megabytes(limit)
        );
    }
    Ok(())
}

pub fn run(args: RenderArgs) -> anyhow::Result<()> {
    check_output(&args.output, "exr", "OpenEXR output (-o)")?;
    if let Some(png) = &args.png {
        check_output(png, "png", "PNG preview (--png)")?;
        if same_file(png, &args.output) {
            bail!("{}: given as both the EXR and the PNG output", png.display());
        }
    }
    if !args.exposure.is_finite() {
        bail!("--exposure {} is not a finite number of stops", args.exposure);
    }
    if MeshFormat::of(&args.scene).is_some() {
        bail!(
            "{}: is a mesh file, with no camera or lights to render it by; name it in a scene file \
             (an object of `type = \"mesh\"`, see docs/scene-format.md)",
            args.scene.display()
        );
    }

    let loaded = super::load_scene_with_camera(&args.scene, args.camera.as_deref())?;
    refuse_inputs_as_outputs(&args)?;
    let mut scene = loaded.scene;
    super::override_image(&args.scene, &mut scene.image, [args.width, args.height, args.spp, args.depth])?;
    let image = scene.image;
    let region = match (&args.region, &args.tile) {
        (Some(text), _) => {
            let r = Region::parse(text).map_err(|m| anyhow::anyhow!("--region {m}"))?;
            if let Some(problem) = r.problem(image.width, image.height) {
                bail!("{}: --region {problem}", args.scene.display());
            }
            r
        }
        (None, Some(text)) => Region::parse_split(text, image.width, image.height)
            .map_err(|m| anyhow::anyhow!("{}: --tile {m}", args.scene.display()))?,
        (None, None) => Region::full(image.width, image.height),
    };
    if let Some(passes) = &args.passes {
        scene.output.passes = super::parse_passes(passes)?;
    }
    scene.output.transparent |= args.transparent;
    scene.output.crypto_levels = args.cryptomatte_levels.unwrap_or(scene.output.crypto_levels);

    refuse_over_budget(&args, &scene, region)?;

    if !(args.checkpoint_every.is_finite() && args.checkpoint_every >= 0.0) {
        bail!("--checkpoint-every {} is not a number of seconds (0 or more)", args.checkpoint_every);
    }
    let checkpointing = Checkpointing {
        path: checkpoint::path_for(&args.output),
        every: Duration::from_secs_f64(args.checkpoint_every),
        resume: args.resume,
        key: checkpoint::key(&scene, region, args.backend.name()),
    };
    // The file's layout, known before rendering so that its blocks can be compressed as the
    // tiles finish (strahl::io::exr_stream); the header attributes are added after.
    let ids = ObjectIds::new(&scene);
    let mut options = ExrOptions {
        layout: match args.exr_layout {
            LayoutArg::Blender => Layout::Blender,
            LayoutArg::Nuke => Layout::Nuke,
        },
        half: args.half,
        compression: args.compression,
        attributes: Vec::new(),
        object_names: ids.object_names.clone(),
        material_names: scene.materials.iter().map(|m| m.name.clone()).collect(),
    };
    // Every string the EXR carries, checked before rendering (strahl::io::exr::check_encodable).
    let info = RenderInfo {
        scene_file: args.scene.display().to_string(),
        backend: args.backend.name().to_string(),
        render_seconds: 0.0,
    };
    options.attributes = strahl::io::metadata::attributes(&scene, &info);
    strahl::io::exr::check_encodable(&scene.output, &options)
        .with_context(|| format!("{}: cannot be written", args.output.display()))?;
    let output = Output { path: &args.output, options: &options };
    let threads = super::thread_count(args.threads.map(|t| t as usize));
    let pool = super::thread_pool(threads)?;
    let (Rendered { film, rays, render_seconds, blocks }, build_seconds) = match args.backend {
        Backend::Embree => {
            let device = super::embree_device(threads)?;
            let build_start = Instant::now();
            let accel = EmbreeAccel::build(&device, &scene, BuildOptions::default())
                .with_context(|| format!("{}: cannot build Embree's BVH", args.scene.display()))?;
            let build_seconds = build_start.elapsed().as_secs_f64();
            (render(&pool, &scene, &accel, region, &args.scene, &checkpointing, &output)?, build_seconds)
        }
        Backend::Native => {
            let build_start = Instant::now();
            let accel = pool
                .install(|| Bvh::build(&scene))
                .with_context(|| format!("{}: cannot build the native BVH", args.scene.display()))?;
            let build_seconds = build_start.elapsed().as_secs_f64();
            (render(&pool, &scene, &accel, region, &args.scene, &checkpointing, &output)?, build_seconds)
        }
    };

    strahl::io::metadata::finish(&mut options.attributes, render_seconds);
    let write_start = Instant::now();
    // Both files whole in their temporaries first, then renamed together: a failure writing
    // either leaves neither (strahl::io::atomic).
    eprintln!("writing {} ...", args.output.display());
    let blocks_seconds = blocks.thread_seconds();
    let mut staged = vec![blocks.stage(&film, &options, &args.output, threads)?];
    if let Some(png) = &args.png {
        eprintln!("writing {} ...", png.display());
        staged.push(strahl::io::png::stage(&film, args.exposure, png)?);
    }
    strahl::io::atomic::commit_all(staged)?;
    // The output is whole: the checkpoint has served.
    if checkpointing.path.exists() {
        std::fs::remove_file(&checkpointing.path).with_context(|| {
            format!("{}: cannot remove the finished render's checkpoint", checkpointing.path.display())
        })?;
    }
    let write_seconds = write_start.elapsed().as_secs_f64();

    let part =
        if region == Region::full(image.width, image.height) { String::new() } else { format!(", region {region}") };
    println!(
        "{}: {} × {} pixels{part}, {} spp, max depth {}, {threads} thread{}",
        args.scene.display(),
        image.width,
        image.height,
        image.spp,
        image.max_depth,
        if threads == 1 { "" } else { "s" }
    );
    println!("  backend: {}, BVH built in {:.1} ms", args.backend.name(), 1e3 * build_seconds);
    println!("  rays: {}", ray_summary(&rays));
    // The rendering threads also compressed the EXR's blocks as tiles finished: the rays'
    // rate is over the rest of the time.
    let compressing = blocks_seconds / threads as f64;
    let share =
        if compressing > 0.0 { format!(", {compressing:.3} s of it compressing the EXR") } else { String::new() };
    println!(
        "  time: {render_seconds:.3} s rendering ({:.2} Mrays/s){share}",
        mrays_per_second(rays.total(), render_seconds - compressing)
    );
    let mut written = vec![sized(&args.output)];
    written.extend(args.png.as_deref().map(sized));
    println!("  wrote {} in {write_seconds:.3} s", written.join(", "));
    Ok(())
}

impl Backend {
    fn name(self) -> &'static str {
        match self {
            Backend::Embree => "embree",
            Backend::Native => "native",
        }
    }
}

/// A rendered image and what it took.
struct Rendered {
    film: Film,
    rays: RayCounts,
    render_seconds: f64,
    /// The EXR's blocks compressed while rendering.
    blocks: BlockStream,
}

/// Where the EXR goes and how it is laid out (its header attributes come after rendering).
struct Output<'a> {
    path: &'a Path,
    options: &'a ExrOptions,
}

/// Where a render keeps its checkpoint and how ([`strahl::checkpoint`]).
struct Checkpointing {
    path: PathBuf,
    /// Time between two checkpoints (zero: after every tile).
    every: Duration,
    resume: bool,
    key: String,
}

/// A test hook: `STRAHL_TEST_TILE_DELAY_MS=N` makes every finished tile wait N ms, so that
/// tests can stop a render at chosen points deterministically (by polling its checkpoint).
fn tile_delay() -> Option<Duration> {
    std::env::var("STRAHL_TEST_TILE_DELAY_MS").ok()?.parse().ok().map(Duration::from_millis)
}

/// Renders `region` of `scene` with `accel` on `pool`,
/// with a progress bar, resuming from and saving to the checkpoint as `ckpt` says. On SIGINT
/// or SIGTERM the tiles under way finish, the checkpoint is saved and this fails saying so
/// (a second SIGINT exits at once).
fn render<A: Accel>(
    pool: &rayon::ThreadPool,
    scene: &Scene,
    accel: &A,
    region: Region,
    path: &Path,
    ckpt: &Checkpointing,
    output: &Output,
) -> anyhow::Result<Rendered> {
    let tiles = region.tiles();
    let mut film = Film::for_region(scene.image.width, scene.image.height, region, &scene.output);
    let shown = ckpt.path.display();
    let mut done = Vec::new();
    if ckpt.path.exists() {
        if ckpt.resume {
            done = checkpoint::read_into(&ckpt.path, &ckpt.key, &tiles, &mut film)?;
            eprintln!("resuming from {shown}: {} of {} tiles done", done.len(), tiles.len());
        } else {
            eprintln!("warning: {shown} exists; rendering from the start and replacing it (--resume continues it)");
        }
    }
    // A mask, not `done.contains`: a 16384² frame has a million tiles.
    let mut is_done = vec![false; tiles.len()];
    for &k in &done {
        is_done[k] = true;
    }
    let todo: Vec<usize> = (0..tiles.len()).filter(|&k| !is_done[k]).collect();
    let todo_tiles: Vec<Region> = todo.iter().map(|&k| tiles[k]).collect();
    let blocks = BlockStream::new(&film, output.options, output.path, &todo_tiles);

    // While the tiles are traced, the first SIGINT/SIGTERM only asks to stop (the checkpoint
    // is saved below); a second one, or any during the writing, exits at once (crate::signals).
    let stop = strahl::signals::stop_requested();
    strahl::signals::graceful(true);
    let finished = Mutex::new(done);
    // When the last save ended and how long it took.
    let last_save = Mutex::new((Instant::now(), Duration::ZERO));
    let save_failed = AtomicBool::new(false);
    let save = |film: &Mutex<Film>| -> anyhow::Result<usize> {
        let mut done = finished.lock().unwrap_or_else(|p| p.into_inner()).clone();
        done.sort_unstable();
        // Streamed from the film, locked a batch at a time (a copy of a large film would
        // double the render's memory).
        write_atomically_with(&ckpt.path, |file| checkpoint::write_to(film, &tiles, &done, &ckpt.key, file))?;
        Ok(done.len())
    };
    let delay = tile_delay();
    let on_tile = |k: usize, film: &Mutex<Film>| {
        finished.lock().unwrap_or_else(|p| p.into_inner()).push(todo[k]);
        blocks.tile_done(&todo_tiles[k], film);
        if let Some(d) = delay {
            std::thread::sleep(d);
        }
        // One thread saves at a time; the others go on tracing.
        let Ok(mut last) = last_save.try_lock() else { return };
        // A save competes with the tiles (for the film's lock, the disk, this thread): the
        // next waits at least nine times as long, so saving costs at most about a tenth
        // (`--checkpoint-every 0` asks for a save after every tile, whatever it costs).
        let (at, took) = *last;
        let wait = if ckpt.every.is_zero() { Duration::ZERO } else { ckpt.every.max(took * 9) };
        if at.elapsed() >= wait {
            let start = Instant::now();
            if let Err(e) = save(film) {
                if !save_failed.swap(true, Ordering::Relaxed) {
                    eprintln!("warning: cannot save the checkpoint: {e:#}");
                }
            }
            *last = (Instant::now(), start.elapsed());
        }
    };
    let bar = Progress::new(region.pixel_count());
    bar.inc(tiles.iter().zip(&is_done).filter(|(_, d)| **d).map(|(t, _)| t.pixel_count()).sum());
    let render_start = Instant::now();
    let progress = |done| bar.inc(done);
    let job = TileJob { tiles: &todo_tiles, stop: Some(stop), progress: &progress, on_tile: &on_tile };
    let rendered = pool.install(|| integrator::render_tiles(scene, accel, film, &job));
    strahl::signals::graceful(false);
    let (film, rays) = rendered.with_context(|| format!("{}: rendering failed", path.display()))?;
    let render_seconds = render_start.elapsed().as_secs_f64();
    bar.finish();
    if stop.load(Ordering::Relaxed) {
        let film = Mutex::new(film);
        let saved = save(&film)?;
        bail!(
            "interrupted: {saved} of {} tiles saved in {shown}; run the same command with --resume to continue",
            tiles.len()
        );
    }
    Ok(Rendered { film, rays, render_seconds, blocks })
}

/// `path (12.3 MB)`: a file written and its size.
fn sized(path: &Path) -> String {
    let bytes = std::fs::metadata(path).map_or(0, |m| m.len());
    format!("{} ({:.1} MB)", path.display(), bytes as f64 / 1e6)
}

fn ray_summary(r: &RayCounts) -> String {
    format!(
        "{} primary, {} shadow, {} reflected, {} refracted, {} in all",
        r.primary,
        r.shadow,
        r.reflected,
        r.refracted,
        r.total()
    )
}

/// Millions of rays per second; 0 when nothing was timed.
fn mrays_per_second(rays: u64, seconds: f64) -> f64 {
    if seconds > 0.0 { rays as f64 / seconds / 1e6 } else { 0.0 }
}
