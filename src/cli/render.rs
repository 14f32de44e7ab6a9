//! `strahl render SCENE -o OUT.exr [--png OUT.png] [--backend embree|native]`: loads the scene
//! (its warnings on stderr), applies the command-line overrides, checks the outputs can be
//! written, builds the backend's BVH (Embree's, or the native one), renders on a pool of
//! `--threads` workers with a progress bar, writes the EXR (and PNG) atomically and prints a
//! summary: resolution, samples, backend, rays by kind, time, Mrays/s, build time.
//!
//! Both backends go through the same [`integrator::render`]; the images differ only where the
//! backends' hits differ (see `strahl crosscheck`).

use std::path::{Path, PathBuf};
use std::time::Instant;

use super::progress::Progress;
use anyhow::{Context, bail};
use clap::{Args, ValueEnum};
use strahl::Accel;
use strahl::bvh::Bvh;
use strahl::embree::{BuildOptions, EmbreeAccel};
use strahl::film::Film;
use strahl::ids::ObjectIds;
use strahl::integrator::{self, RayCounts};
use strahl::io::MeshFormat;
use strahl::io::atomic::directory_of;
use strahl::io::exr::{Compression, ExrOptions, Layout};
use strahl::io::metadata::RenderInfo;
use strahl::passes::{MAX_CRYPTO_LEVELS, PassSet};
use strahl::scene::Scene;
use strahl::scene::file::image_problem;

/// Arguments of `strahl render`.
#[derive(Args, Debug)]
pub struct RenderArgs {
    /// The scene file (TOML; see docs/scene-format.md).
    scene: PathBuf,
    /// Where to write the OpenEXR image (linear RGBA, Z, N, albedo).
    #[arg(short, long, value_name = "OUT.exr")]
    output: PathBuf,
    /// Also write an 8-bit sRGB PNG preview here.
    #[arg(long, value_name = "OUT.png")]
    png: Option<PathBuf>,
    /// Image width in pixels (overrides the scene's).
    #[arg(long, value_name = "W", value_parser = clap::value_parser!(u32).range(1..))]
    width: Option<u32>,
    /// Image height in pixels (overrides the scene's).
    #[arg(long, value_name = "H", value_parser = clap::value_parser!(u32).range(1..))]
    height: Option<u32>,
    /// Samples per pixel (overrides the scene's).
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..))]
    spp: Option<u32>,
    /// Longest chain of reflected/refracted rays (overrides the scene's max_depth).
    #[arg(long, value_name = "D")]
    depth: Option<u32>,
    /// Worker threads for rendering, Embree's BVH build and EXR compression [default: one per core].
    #[arg(long, value_name = "T", value_parser = clap::value_parser!(u32).range(1..=4096))]
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
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..=MAX_CRYPTO_LEVELS as i64))]
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

pub fn run(args: RenderArgs) -> anyhow::Result<()> {
    check_output(&args.output, "exr", "OpenEXR output (-o)")?;
    if let Some(png) = &args.png {
        check_output(png, "png", "PNG preview (--png)")?;
        if png == &args.output {
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

    let mut scene = super::load_scene(&args.scene)?.scene;
    let image = &mut scene.image;
    image.width = args.width.unwrap_or(image.width);
    image.height = args.height.unwrap_or(image.height);
    image.spp = args.spp.unwrap_or(image.spp);
    image.max_depth = args.depth.unwrap_or(image.max_depth);
    if let Some((_, problem)) = image_problem(image) {
        bail!("{}: with the command-line settings: {problem}", args.scene.display());
    }
    let image = scene.image;
    if let Some(passes) = &args.passes {
        scene.output.passes = PassSet::parse(passes).map_err(|m| anyhow::anyhow!("--passes: {m}"))?;
    }
    scene.output.transparent |= args.transparent;
    scene.output.crypto_levels = args.cryptomatte_levels.unwrap_or(scene.output.crypto_levels);

    let threads = super::thread_count(args.threads.map(|t| t as usize));
    let pool = super::thread_pool(threads)?;
    let Rendered { film, rays, build_seconds, render_seconds } = match args.backend {
        Backend::Embree => {
            let device = super::embree_device(threads)?;
            let build_start = Instant::now();
            let accel = EmbreeAccel::build(&device, &scene, BuildOptions::default())
                .with_context(|| format!("{}: cannot build Embree's BVH", args.scene.display()))?;
            render(&pool, &scene, &accel, build_start, &args.scene)?
        }
        Backend::Native => {
            let build_start = Instant::now();
            let accel = pool
                .install(|| Bvh::build(&scene))
                .with_context(|| format!("{}: cannot build the native BVH", args.scene.display()))?;
            render(&pool, &scene, &accel, build_start, &args.scene)?
        }
    };

    let ids = ObjectIds::new(&scene);
    let options = ExrOptions {
        layout: match args.exr_layout {
            LayoutArg::Blender => Layout::Blender,
            LayoutArg::Nuke => Layout::Nuke,
        },
        half: args.half,
        compression: args.compression,
        attributes: strahl::io::metadata::attributes(
            &scene,
            &RenderInfo {
                scene_file: args.scene.display().to_string(),
                backend: args.backend.name().to_string(),
                render_seconds,
            },
        ),
        object_names: ids.object_names.clone(),
        material_names: scene.materials.iter().map(|m| m.name.clone()).collect(),
    };
    let write_start = Instant::now();
    eprintln!("writing {} ...", args.output.display());
    strahl::io::exr::write(&film, &options, &args.output, threads)?;
    if let Some(png) = &args.png {
        eprintln!("writing {} ...", png.display());
        strahl::io::png::write(&film, args.exposure, png)?;
    }
    let write_seconds = write_start.elapsed().as_secs_f64();

    println!(
        "{}: {} × {} pixels, {} spp, max depth {}, {threads} thread{}",
        args.scene.display(),
        image.width,
        image.height,
        image.spp,
        image.max_depth,
        if threads == 1 { "" } else { "s" }
    );
    println!("  backend: {}, BVH built in {:.1} ms", args.backend.name(), 1e3 * build_seconds);
    println!("  rays: {}", ray_summary(&rays));
    println!("  time: {render_seconds:.3} s rendering ({:.2} Mrays/s)", mrays_per_second(rays.total(), render_seconds));
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
    build_seconds: f64,
    render_seconds: f64,
}

/// Renders `scene` with `accel` (whose build began at `build_start`) on `pool`, with a
/// progress bar.
fn render<A: Accel>(
    pool: &rayon::ThreadPool,
    scene: &Scene,
    accel: &A,
    build_start: Instant,
    path: &Path,
) -> anyhow::Result<Rendered> {
    let build_seconds = build_start.elapsed().as_secs_f64();
    let image = &scene.image;
    let bar = Progress::new(image.width as u64 * image.height as u64);
    let render_start = Instant::now();
    let (film, rays) = pool
        .install(|| integrator::render(scene, accel, &|done| bar.inc(done)))
        .with_context(|| format!("{}: rendering failed", path.display()))?;
    let render_seconds = render_start.elapsed().as_secs_f64();
    bar.finish();
    Ok(Rendered { film, rays, build_seconds, render_seconds })
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
