//! `strahl render SCENE -o OUT.exr [--png OUT.png] [--backend embree|native]
//! [--region X0,Y0,X1,Y1 | --tile I/N] [--checkpoint-every S] [--resume]`: checks the outputs
//! can be written, loads the scene (its warnings on stderr), runs it as a
//! [`strahl::job::RenderJob`] (the overrides and the budget checked, the backend's BVH, the
//! tiles on `--threads` workers with a progress bar, the checkpoint `OUT.exr.checkpoint` saved
//! every `--checkpoint-every` seconds and on SIGINT/SIGTERM, the EXR and PNG written
//! atomically) and prints its summary: resolution, samples, backend, rays by kind, time,
//! Mrays/s, build time.

use std::path::PathBuf;

use super::Backend;
use super::output_args::OutputArgs;
use super::progress::Progress;
use anyhow::bail;
use clap::Args;
use strahl::job::{Observer, RenderJob, Settings};
use strahl::light::set::LightSampler;
use strahl::output::passes::{MAX_CRYPTO_LEVELS, Pass, PassSet};
use strahl::scene::IntegratorKind;
use strahl::scene::load::MeshFormat;

/// Arguments of `strahl render`.
#[derive(Args, Debug)]
pub struct RenderArgs {
    /// The scene file (TOML; see docs/scene-format.md), or a glTF file (.gltf, .glb).
    scene: PathBuf,
    /// Which camera of a glTF file to render through: its index, its name or its node's name [default: the first].
    #[arg(long, value_name = "NAME|INDEX")]
    camera: Option<String>,
    /// Refuse, before building anything, a render whose estimated memory (as `strahl info`
    /// prints it) exceeds this: bytes or K/M/G/T (e.g. 8G) [default: the smallest of 3/4 of
    /// physical memory, the cgroup's memory limit and RLIMIT_AS less a reserve; `strahl info`
    /// prints it].
    #[arg(long, value_name = "SIZE", value_parser = strahl::job::memory::parse_size)]
    max_memory: Option<u64>,
    #[command(flatten)]
    confine: super::ConfineArg,
    #[command(flatten)]
    output: OutputArgs,
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
    /// What computes the light: the lecture's ray tracer (`whitted`), or the path tracer
    /// (`path`: indirect light, next-event estimation with MIS) [default: the scene's
    /// `[render] integrator`, else whitted].
    #[arg(long, value_name = "NAME", value_parser = IntegratorKind::parse)]
    integrator: Option<IntegratorKind>,
    /// The path tracer's clamp: every contribution of light that scattered twice or more is
    /// scaled so its largest channel is at most C (less fireflies, less energy) [default: off].
    #[arg(long, value_name = "C", allow_negative_numbers = true)]
    clamp: Option<f32>,
    /// How the path tracer chooses a light per shading point: by the light tree over the
    /// emitters (`tree`: importance by power, distance and orientation, as pbrt-v4 and Cycles
    /// do) or in proportion to power alone (`power`) [default: the scene's `[render]
    /// light_sampler`, else tree].
    #[arg(long, value_name = "NAME", value_parser = LightSampler::parse)]
    light_sampler: Option<LightSampler>,
    /// Adaptive sampling, Cycles' noise threshold (0.01 is Cycles' usual value; lower: less
    /// noise, more samples): the path tracer stops sampling a pixel once its own noise estimate
    /// is below T, testing every 16 samples after a minimum of max(4, ceil(16/T^0.3)) samples
    /// (Cycles' rule: 64 at T = 0.01, first test after 80), so `--spp` is the most samples a
    /// pixel takes. The minimum can exceed `--spp`: then no pixel is ever tested and every
    /// pixel takes all `--spp` samples, as without adaptive sampling (at T = 0.01, any `--spp`
    /// up to 80). 0 turns it off (overrides `[render] adaptive_threshold`; see
    /// docs/rendering.md) [default: off].
    #[arg(long, value_name = "T", allow_negative_numbers = true)]
    adaptive_threshold: Option<f32>,
    /// The seed of every pixel's sample sequence, 0 to 2147483647: renders of one scene with
    /// different seeds have independent noise (an animation: the frame number, as Cycles'
    /// animated seed) [default: the scene's `[render] seed`, else 0].
    #[arg(long, value_name = "N", allow_negative_numbers = true,
          value_parser = clap::value_parser!(u32).range(0..=strahl::scene::MAX_SEED as i64))]
    seed: Option<u32>,
    /// The radiance from far away along rays that leave the scene (overrides the scene's
    /// `[environment]`): an equirectangular map (OpenEXR or Radiance .hdr, Blender's
    /// orientation; see docs/lights.md), or a constant colour R,G,B.
    #[arg(long, value_name = "FILE|R,G,B")]
    environment: Option<String>,
    /// Scales the environment's radiance (overrides `[environment] strength`; needs an
    /// environment, from the scene or `--environment`) [default: 1].
    #[arg(long, value_name = "S", allow_negative_numbers = true)]
    environment_strength: Option<f32>,
    /// Turns the environment about the up axis by this many degrees, right-handed (overrides
    /// `[environment] rotation`; needs an environment) [default: 0].
    #[arg(long, value_name = "DEGREES", allow_negative_numbers = true)]
    environment_rotation: Option<f32>,
    /// What finds the closest hits: Intel Embree, or strahl's own BVH.
    #[arg(long, value_enum, default_value_t = Backend::Embree)]
    backend: Backend,
    /// The passes to write, comma-separated (overrides the scene's `[output] passes`):
    /// `default`, `all`, `light`, `diffuse`, `glossy`, `transmission` (a family's direct,
    /// indirect and colour passes), or names from combined, depth, normal, albedo, emission,
    /// diffuse_direct, diffuse_indirect, glossy_direct, glossy_indirect, glossy_color,
    /// transmission_direct, transmission_indirect, transmission_color, background, position,
    /// distance, object_index, material_index, crypto_object, crypto_material, disagreement (the
    /// camera rays traced through both backends; not in `all`), sample_count, variance,
    /// denoising_albedo, denoising_normal (OIDN's guides, seen through mirrors and glass; not in
    /// `all`, added by --denoise).
    #[arg(long, value_name = "LIST", value_delimiter = ',')]
    passes: Option<Vec<String>>,
    /// Render the background transparent: rays that escape give RGBA 0, alpha is coverage.
    #[arg(long)]
    transparent: bool,
    /// Cryptomatte ranks per pixel (overrides the scene's `cryptomatte_levels`).
    #[arg(long, value_name = "N", allow_negative_numbers = true, value_parser = clap::value_parser!(u32).range(1..=MAX_CRYPTO_LEVELS as i64))]
    cryptomatte_levels: Option<u32>,
    /// Render only the pixels X0 ≤ x < X1, Y0 ≤ y < Y1 (half-open pixel bounds, (0,0) the
    /// top-left pixel); the EXR's dataWindow is that region inside the whole displayWindow.
    #[arg(long, value_name = "X0,Y0,X1,Y1", conflicts_with = "tile")]
    region: Option<String>,
    /// Render only tile I of N, I from 1 to N: N bands of whole rows, top to bottom, for
    /// splitting a frame over a farm (`strahl merge` joins the tiles).
    #[arg(long, value_name = "I/N")]
    tile: Option<String>,
    /// Denoise the frame with Intel Open Image Denoise once it is written (as `strahl denoise`
    /// does; adds the combined, albedo, normal, depth, denoising_albedo and denoising_normal
    /// passes); the --png preview shows the denoised frame. Not with --region/--tile: denoise
    /// the merged frame (`strahl denoise`), or tiles show seams.
    #[arg(long, conflicts_with_all = ["region", "tile"])]
    denoise: bool,
    /// Seconds between two progress lines when stderr is not a terminal (a log, a program
    /// following the render, such as the Blender add-on, which asks for 0.5); 0: a line per
    /// finished tile.
    #[arg(long, value_name = "SECONDS", default_value_t = super::progress::LOG_INTERVAL_SECONDS, allow_negative_numbers = true)]
    progress_interval: f64,
}

/// The passes `--denoise` needs, added to those asked for.
const DENOISE_PASSES: [Pass; 6] =
    [Pass::Combined, Pass::Albedo, Pass::Normal, Pass::Depth, Pass::DenoisingAlbedo, Pass::DenoisingNormal];

/// `--passes` with what denoising needs added (the scene's passes when `--passes` is absent).
fn passes_with_denoising(asked: Option<Vec<String>>, scene: PassSet) -> Vec<String> {
    let mut names = asked.unwrap_or_else(|| scene.iter().map(|p| p.name().to_string()).collect());
    for pass in DENOISE_PASSES {
        if !names.iter().any(|n| n == pass.name()) {
            names.push(pass.name().to_string());
        }
    }
    names
}

/// `--environment` (a map read as the scene's inputs are, or a colour), then
/// `--environment-strength` and `--environment-rotation` applied to the scene's environment;
/// either of the last two without an environment is an error, as is a value the environment
/// refuses (a negative or non-finite strength, a non-finite rotation). `farm slurm` checks its
/// tiles' options with the same function.
pub(super) fn environment_options(
    scene: &mut strahl::scene::Scene,
    environment: Option<&str>,
    strength: Option<f32>,
    rotation: Option<f32>,
) -> anyhow::Result<()> {
    if let Some(arg) = environment {
        scene.environment =
            Some(strahl::light::environment_file::environment_argument(arg).map_err(anyhow::Error::msg)?);
    }
    if strength.is_none() && rotation.is_none() {
        return Ok(());
    }
    let flag = if strength.is_some() { "--environment-strength" } else { "--environment-rotation" };
    let Some(env) = scene.environment.as_mut() else {
        bail!("{flag}: the scene has no environment to change (give one with --environment or [environment])");
    };
    if let Some(s) = strength {
        env.strength = s;
        if let Some(problem) = env.problem() {
            bail!("--environment-strength {s}: {problem}");
        }
    }
    if let Some(r) = rotation {
        env.rotation_deg = r;
        if let Some(problem) = env.problem() {
            bail!("--environment-rotation {r}: {problem}");
        }
    }
    Ok(())
}

pub fn run(args: RenderArgs) -> anyhow::Result<()> {
    let progress_every = super::progress::interval(args.progress_interval)?;
    let output = args.output.into_output();
    output.check()?;
    if args.denoise {
        strahl::output::denoise::check_available()?;
    }
    let (exr_path, png, exposure) = (output.exr.clone(), output.png.clone(), output.exposure);
    if MeshFormat::of(&args.scene).is_some() {
        bail!(
            "{}: is a mesh file, with no camera or lights to render it by; name it in a scene file \
             (an object of `type = \"mesh\"`, see docs/scene-format.md)",
            args.scene.display()
        );
    }
    super::set_load_options(&args.confine, args.max_memory)?;
    let mut loaded = super::load_scene_with_camera(&args.scene, args.camera.as_deref(), args.environment.is_some())?;
    environment_options(
        &mut loaded.scene,
        args.environment.as_deref(),
        args.environment_strength,
        args.environment_rotation,
    )?;
    let settings = Settings {
        width: args.width,
        height: args.height,
        spp: args.spp,
        depth: args.depth,
        passes: if args.denoise {
            Some(passes_with_denoising(args.passes, loaded.scene.output.passes))
        } else {
            args.passes
        },
        transparent: args.transparent,
        crypto_levels: args.cryptomatte_levels,
        region: args.region,
        tile: args.tile,
        backend: args.backend.into(),
        threads: args.threads.map(|t| t as usize),
        max_memory: args.max_memory,
        output: Some(output),
        integrator: args.integrator,
        clamp: args.clamp,
        light_sampler: args.light_sampler,
        adaptive_threshold: args.adaptive_threshold,
        seed: args.seed,
    };
    let job = RenderJob::new(&args.scene, loaded.scene, settings)?;
    if let Some(line) = job.complete(&Observer { progress: &|_| {}, note: &|line| eprintln!("{line}") })? {
        println!("{line}");
        return Ok(());
    }
    let bar = Progress::new(job.region.pixel_count(), progress_every);
    let observer = Observer { progress: &|pixels| bar.inc(pixels), note: &|line| eprintln!("{line}") };
    let rendered = job.render(&observer);
    bar.finish();
    let mut rendered = rendered?;
    let write_seconds = job.write(&mut rendered, &observer)?;
    print!("{}", job.summary(&rendered, write_seconds));
    if args.denoise {
        let beauty = strahl::output::denoise::denoise_in_place(&exr_path)
            .map_err(|e| anyhow::anyhow!("{e} (it holds the frame as rendered, not denoised)"))?;
        println!("denoised {}", exr_path.display());
        if let Some(png) = &png {
            strahl::output::png::write_rgb(beauty.width, beauty.height, &beauty.rgb, exposure, png)
                .map_err(|e| anyhow::anyhow!("{e} (it holds the frame as rendered, not denoised)"))?;
            println!("wrote the denoised preview {}", png.display());
        }
    }
    Ok(())
}
