//! A render as one job, as `strahl render` runs it and any other caller (a farm's worker, a
//! test, a program using strahl as a library) can:
//!
//! 1. [`Output::check`]: the outputs can be written (their extensions; no directory in the
//!    place of the EXR, the PNG or the checkpoint; a file can be made in their folders; the
//!    PNG is not the EXR; the exposure is a number), before the scene is even loaded.
//! 2. [`RenderJob::new`]: the loaded scene with the [`Settings`] applied, each checked: no
//!    output is a file the scene was read from, through any link or spelling; the image
//!    overrides, the pixels to render (the whole image, `--region` or `--tile`,
//!    [`crate::output::region`]), the passes; the estimated memory against the budget
//!    ([`memory`]); the checkpoint interval.
//! 3. [`RenderJob::render`]: the thread pool, the backend's BVH (Embree's or the native one)
//!    and the tile loop ([`crate::integrator::render_tiles`]). A job with an [`Output`]
//!    resumes from and saves to its checkpoint ([`crate::output::checkpoint`]) every
//!    [`Output::checkpoint_every`] and on SIGINT/SIGTERM, and compresses the EXR's blocks as
//!    the tiles finish ([`crate::output::exr_stream`]); a job without one renders to memory.
//! 4. [`RenderJob::write`]: the EXR (with its header attributes, [`crate::output::metadata`])
//!    and the PNG, renamed into place together ([`crate::sys::atomic`]), and the checkpoint,
//!    which has served, removed.
//!
//! Errors are one line each, naming the scene file or the option at fault.

pub mod memory;

use std::fmt;
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use anyhow::{Context, bail};

use crate::accel::Accel;
use crate::accel::bvh::Bvh;
use crate::accel::embree::{self, BuildOptions, Device, DeviceOptions, EmbreeAccel};
use crate::accel::paired::Paired;
use crate::integrator::{self, RayCounts, TileJob};
use crate::math::Vec3;
use crate::output::checkpoint;
use crate::output::exr::{Attribute, Compression, ExrOptions, Layout};
use crate::output::exr_stream::BlockStream;
use crate::output::film::Film;
use crate::output::ids::ObjectIds;
use crate::output::metadata::{RENDER_KEY, RenderInfo};
use crate::output::passes::{Pass, PassSet};
use crate::output::region::Region;
use crate::scene::{ImageSpec, IntegratorKind, Scene};
use crate::sys::atomic::{directory_of, write_atomically_with};
use crate::sys::same_file::same_file;

/// What finds the closest hits.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Backend {
    /// Intel Embree (triangles in its BVH, spheres as user geometry).
    #[default]
    Embree,
    /// strahl's pure-Rust BVH ([`crate::accel::bvh`]).
    Native,
}

impl Backend {
    /// `"embree"` or `"native"`, as reports and the checkpoint's key name it.
    pub fn name(self) -> &'static str {
        match self {
            Backend::Embree => "embree",
            Backend::Native => "native",
        }
    }
}

/// Where a render's image goes and how it is written.
#[derive(Clone, Debug)]
pub struct Output {
    /// The OpenEXR image.
    pub exr: PathBuf,
    /// An 8-bit sRGB PNG preview.
    pub png: Option<PathBuf>,
    /// Exposure of the PNG preview in stops.
    pub exposure: f32,
    /// Channel naming, sample type and compression of the EXR.
    pub layout: Layout,
    /// The view layer name of the `blender` layout (`--layer-name`); `None`: `ViewLayer`.
    pub layer_name: Option<String>,
    pub half: bool,
    pub compression: Compression,
    /// Seconds between two checkpoints (0: after every tile).
    pub checkpoint_every: f64,
    /// Continue from the checkpoint when it exists.
    pub resume: bool,
    /// The frame number and frames per second the header names (`Frame`, `Time`;
    /// [`crate::output::metadata`]); no pixel depends on them.
    pub frame: u32,
    pub fps: u32,
}

impl Output {
    /// Refuses outputs that cannot be written, before any time is spent loading or rendering.
    pub fn check(&self) -> anyhow::Result<()> {
        check_output(&self.exr, "exr", "OpenEXR output (-o)")?;
        if let Some(png) = &self.png {
            check_output(png, "png", "PNG preview (--png)")?;
            if same_file(png, &self.exr) {
                bail!("{}: given as both the EXR and the PNG output", png.display());
            }
        }
        if !self.exposure.is_finite() {
            bail!("--exposure {} is not a finite number of stops", self.exposure);
        }
        self.check_layer_name()?;
        let checkpoint = self.checkpoint();
        if checkpoint.is_dir() {
            bail!("{}: is a directory, where the render keeps its checkpoint", checkpoint.display());
        }
        // A file can be made where the outputs' temporaries go (the checkpoint's is the EXR's
        // folder): a folder without write permission, or a read-only file system, is found now,
        // not after rendering.
        for path in std::iter::once(&self.exr).chain(&self.png) {
            drop(crate::sys::atomic::Scratch::beside(path)?);
        }
        Ok(())
    }

    /// `--layer-name`: a name Blender can give a view layer ([`crate::output::layer_name`]),
    /// for the layout that has layers.
    fn check_layer_name(&self) -> anyhow::Result<()> {
        let Some(name) = &self.layer_name else { return Ok(()) };
        crate::output::layer_name::check(name).map_err(anyhow::Error::msg)?;
        if self.layout != Layout::Blender {
            bail!("--layer-name {name:?}: names the view layer of --exr-layout blender; the other layout has none");
        }
        Ok(())
    }

    /// Removes the temporaries that killed runs of this host left in the folders this output
    /// writes to ([`crate::sys::temporary::remove_stale`]), saying so.
    fn remove_stale_temporaries(&self, observer: &Observer) {
        let mut dirs = vec![directory_of(&self.exr)];
        dirs.extend(self.png.as_deref().map(directory_of).filter(|d| !same_file(d, directory_of(&self.exr))));
        for dir in dirs {
            if let Some(line) = crate::sys::temporary::remove_stale_saying(dir) {
                (observer.note)(&line);
            }
        }
    }

    /// Where the render keeps its checkpoint.
    fn checkpoint(&self) -> PathBuf {
        checkpoint::path_for(&self.exr)
    }
}

/// Everything a render takes besides its scene, as a user gives it (`strahl render`'s
/// options); `None` keeps the scene's own.
#[derive(Clone, Debug, Default)]
pub struct Settings {
    pub width: Option<u32>,
    pub height: Option<u32>,
    pub spp: Option<u32>,
    pub depth: Option<u32>,
    /// Pass names, as `--passes` lists them.
    pub passes: Option<Vec<String>>,
    pub transparent: bool,
    pub crypto_levels: Option<u32>,
    /// `X0,Y0,X1,Y1`: the pixels to render.
    pub region: Option<String>,
    /// `I/N`: tile I of N bands of whole rows (when `region` is not given).
    pub tile: Option<String>,
    pub backend: Backend,
    /// Worker threads [default: one per core].
    pub threads: Option<usize>,
    /// The memory budget in bytes [default: 3/4 of physical memory].
    pub max_memory: Option<u64>,
    /// The files to write; `None` renders to memory.
    pub output: Option<Output>,
    /// The integrator (overrides the scene's `[render] integrator`).
    pub integrator: Option<crate::scene::IntegratorKind>,
    /// The path tracer's clamp of indirect light (overrides `[render] clamp`).
    pub clamp: Option<f32>,
    /// How the path tracer chooses lights (overrides `[render] light_sampler`).
    pub light_sampler: Option<crate::light::set::LightSampler>,
    /// Adaptive sampling's noise threshold (overrides `[render] adaptive_threshold`; 0 turns
    /// it off).
    pub adaptive_threshold: Option<f32>,
    /// The seed of the sample sequences (overrides `[render] seed`).
    pub seed: Option<u32>,
}

/// A render ready to run: its scene with the settings applied, and everything checked.
pub struct RenderJob {
    /// The scene file (named in messages and in the EXR's metadata).
    pub path: PathBuf,
    pub scene: Scene,
    /// The pixels to render.
    pub region: Region,
    pub backend: Backend,
    pub threads: usize,
    pub output: Option<Output>,
}

/// Whom a job tells how it goes.
pub struct Observer<'a> {
    /// Called with the number of pixels finished since its last call (first those a
    /// checkpoint restored).
    pub progress: &'a (dyn Fn(u64) + Sync),
    /// Called with one line for the user: resuming, a checkpoint replaced or not saved, a file
    /// being written.
    pub note: &'a (dyn Fn(&str) + Sync),
}

impl Observer<'_> {
    /// An observer that is told nothing.
    pub fn quiet() -> Observer<'static> {
        Observer { progress: &|_| {}, note: &|_| {} }
    }
}

/// A rendered image and what it took.
pub struct Rendered {
    pub film: Film,
    pub rays: RayCounts,
    /// Seconds building the BVH, and tracing the tiles (compressing the EXR's blocks too).
    pub build_seconds: f64,
    pub render_seconds: f64,
    /// CPU seconds the rendering threads spent compressing the EXR's blocks as tiles finished.
    pub compress_seconds: f64,
    /// The EXR's blocks compressed while rendering (a job with an output, until it is written).
    blocks: Option<BlockStream>,
}

impl RenderJob {
    /// The job of rendering `scene` (loaded from `path`) as `settings` say, each setting
    /// checked against the scene.
    pub fn new(path: &Path, mut scene: Scene, settings: Settings) -> anyhow::Result<RenderJob> {
        if let Some(output) = &settings.output {
            refuse_inputs_as_outputs(path, output)?;
        }
        let [width, height, spp, depth] = [settings.width, settings.height, settings.spp, settings.depth];
        override_image(path, &mut scene.image, [width, height, spp, depth])?;
        let region = region_of(path, &scene.image, &settings)?;
        if let Some(passes) = &settings.passes {
            scene.output.passes = parse_passes(passes)?;
        }
        scene.output.transparent |= settings.transparent;
        scene.output.crypto_levels = settings.crypto_levels.unwrap_or(scene.output.crypto_levels);
        scene.render.integrator = settings.integrator.unwrap_or(scene.render.integrator);
        scene.render.clamp = settings.clamp.or(scene.render.clamp);
        scene.render.light_sampler = settings.light_sampler.unwrap_or(scene.render.light_sampler);
        scene.render.seed = settings.seed.unwrap_or(scene.render.seed);
        if let Some(threshold) = settings.adaptive_threshold {
            scene.render.set_adaptive_threshold(threshold);
        }
        crate::integrator::check_render(&scene).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
        refuse_over_budget(path, settings.max_memory, &scene, region)?;
        if let Some(every) = settings.output.as_ref().map(|o| o.checkpoint_every) {
            checkpoint_interval(every)?;
        }
        let threads = thread_count(settings.threads);
        let (backend, output) = (settings.backend, settings.output);
        let job = RenderJob { path: path.to_path_buf(), scene, region, backend, threads, output };
        // Every string the EXR will carry, checked before rendering, so that no scene path or
        // name can make a finished render unwritable.
        if let Some(output) = &job.output {
            crate::output::exr::check_encodable(&job.scene.output, &job.exr_options(output))
                .with_context(|| format!("{}: cannot be written", output.exr.display()))?;
        }
        Ok(job)
    }

    /// Builds the backend's BVH and renders on a pool of the job's threads. With an output,
    /// resumes from and saves to the checkpoint as it says; on SIGINT or SIGTERM the tiles
    /// under way finish, the checkpoint is saved and this fails saying so (a second SIGINT
    /// exits at once).
    pub fn render(&self, observer: &Observer) -> anyhow::Result<Rendered> {
        let pool = thread_pool(self.threads)?;
        let shown = self.path.display();
        if self.scene.render.integrator == IntegratorKind::Path && self.scene.image.ambient != Vec3::ZERO {
            (observer.note)(&format!(
                "warning: {shown}: ambient is the Whitted integrator's stand-in for indirect light; the path \
                 tracer computes that light and ignores it (`[render] integrator = \"whitted\"` renders the \
                 lecture's image)"
            ));
        }
        if let Some(output) = &self.output {
            if let Some(warning) = output.compression.for_output(&self.scene.output, output.half).1 {
                (observer.note)(&format!("{}: {warning}", output.exr.display()));
            }
        }
        let build_start = Instant::now();
        let build_native = || {
            pool.install(|| Bvh::build(&self.scene)).with_context(|| format!("{shown}: cannot build the native BVH"))
        };
        let device = match self.backend {
            Backend::Embree => Some(embree_device(self.threads)?),
            Backend::Native if self.compares_backends() => Some(embree_device(self.threads)?),
            Backend::Native => None,
        };
        let build_embree = || {
            let device = device.as_ref().expect("an Embree device");
            EmbreeAccel::build(device, &self.scene, BuildOptions::default())
                .with_context(|| format!("{shown}: cannot build Embree's BVH"))
        };
        // The disagreement pass traces the camera rays through the other backend as well.
        match (self.backend, self.compares_backends()) {
            (Backend::Embree, false) => {
                let accel = build_embree()?;
                self.trace(&pool, &accel, build_start.elapsed().as_secs_f64(), observer)
            }
            (Backend::Native, false) => {
                let accel = build_native()?;
                self.trace(&pool, &accel, build_start.elapsed().as_secs_f64(), observer)
            }
            (Backend::Embree, true) => {
                let accel = Paired { first: build_embree()?, second: build_native()? };
                self.trace(&pool, &accel, build_start.elapsed().as_secs_f64(), observer)
            }
            (Backend::Native, true) => {
                let accel = Paired { first: build_native()?, second: build_embree()? };
                self.trace(&pool, &accel, build_start.elapsed().as_secs_f64(), observer)
            }
        }
    }

    /// Whether the render writes the `disagreement` pass, for which it builds both backends.
    fn compares_backends(&self) -> bool {
        self.scene.output.passes.contains(Pass::Disagreement)
    }

    /// Writes `rendered` to the job's output: both files whole in their temporaries first, then
    /// renamed together, so that a failure writing either leaves neither; then removes the
    /// checkpoint. Returns the seconds it took.
    pub fn write(&self, rendered: &mut Rendered, observer: &Observer) -> anyhow::Result<f64> {
        let (Some(output), Some(blocks)) = (&self.output, rendered.blocks.take()) else {
            bail!("{}: this render has no output to write, or it is written", self.path.display());
        };
        let mut options = self.exr_options(output);
        crate::output::metadata::finish(&mut options.attributes, rendered.render_seconds);
        let write_start = Instant::now();
        (observer.note)(&format!("writing {} ...", output.exr.display()));
        let mut staged = vec![blocks.stage(&rendered.film, &options, &output.exr, self.threads)?];
        if let Some(png) = &output.png {
            (observer.note)(&format!("writing {} ...", png.display()));
            staged.push(crate::output::png::stage(&rendered.film, output.exposure, png)?);
        }
        crate::sys::atomic::commit_all(staged)?;
        // The output is whole: the checkpoint has served.
        let checkpoint = output.checkpoint();
        if checkpoint.exists() {
            std::fs::remove_file(&checkpoint)
                .with_context(|| format!("{}: cannot remove the finished render's checkpoint", checkpoint.display()))?;
        }
        Ok(write_start.elapsed().as_secs_f64())
    }

    /// With `--resume`, whether the job's outputs exist and are of this render already (the
    /// EXR's [`RENDER_KEY`] is this job's and its data window this job's region; the PNG, if
    /// asked for, exists): then the line to print, and the checkpoint, if a kill left it after
    /// the outputs were renamed, is removed, as are the stale temporaries
    /// ([`Output::remove_stale_temporaries`]). A farm's requeued task that had finished ends at
    /// once. Any other output (another scene or settings, not a strahl EXR, damaged) is
    /// rendered again and replaced. The PNG's exposure is not compared: `--exposure` alone
    /// does not render again.
    pub fn complete(&self, observer: &Observer) -> anyhow::Result<Option<String>> {
        let Some(output) = self.output.as_ref().filter(|o| o.resume) else { return Ok(None) };
        if output.png.as_ref().is_some_and(|png| !png.is_file()) {
            return Ok(None);
        }
        let theirs = crate::output::metadata::read_text_attribute(&output.exr, RENDER_KEY);
        if theirs != Some((self.render_key(output), self.region)) {
            return Ok(None);
        }
        let checkpoint = output.checkpoint();
        if checkpoint.is_file() {
            std::fs::remove_file(&checkpoint)
                .with_context(|| format!("{}: cannot remove the finished render's checkpoint", checkpoint.display()))?;
        }
        output.remove_stale_temporaries(observer);
        Ok(Some(format!(
            "{}: complete, a render of this scene with these settings; nothing to do (render without --resume \
             to render it again)",
            output.exr.display()
        )))
    }

    /// The [`RENDER_KEY`] of this job's EXR (see there).
    fn render_key(&self, output: &Output) -> String {
        format!(
            "strahl {} scene {} tile {} backend {} exr {:?} {} {}",
            env!("CARGO_PKG_VERSION"),
            crate::scene::hash::scene_hash_hex(&self.scene),
            crate::output::region::TILE_SIZE,
            self.backend.name(),
            output.layout,
            output.compression.for_output(&self.scene.output, output.half).0.name(),
            if output.half { "half" } else { "float" },
        )
    }

    /// What the job did, for the summary a command prints ([`Summary`]'s lines).
    pub fn summary<'a>(&'a self, rendered: &'a Rendered, write_seconds: f64) -> Summary<'a> {
        Summary { job: self, rendered, write_seconds }
    }

    /// The EXR's layout, known before rendering so that its blocks can be compressed as the
    /// tiles finish, and its header attributes (their date and render time are put in when it
    /// is written, [`crate::output::metadata::finish`]).
    fn exr_options(&self, output: &Output) -> ExrOptions {
        let info = RenderInfo {
            scene_file: self.path.display().to_string(),
            backend: self.backend.name().to_string(),
            render_seconds: 0.0,
            frame: output.frame,
            fps: output.fps,
            layer: output.layer_name.clone(),
        };
        let mut attributes = crate::output::metadata::attributes(&self.scene, &info);
        if output.layout == Layout::Blender {
            attributes.push(("BlenderMultiChannel".to_string(), Attribute::Text("Blender V2.55.1 and newer".into())));
        }
        attributes.push((RENDER_KEY.to_string(), Attribute::Text(self.render_key(output))));
        ExrOptions {
            layout: output.layout,
            view_layer: output.layer_name.clone(),
            half: output.half,
            compression: output.compression.for_output(&self.scene.output, output.half).0,
            attributes,
            object_names: ObjectIds::new(&self.scene).object_names,
            material_names: self.scene.materials.iter().map(|m| m.name.clone()).collect(),
        }
    }

    /// Renders with `accel` on `pool`: to memory, or with the checkpoint and the EXR's
    /// streamed blocks of the job's output ([`RenderJob::render`]).
    fn trace<A: Accel>(
        &self,
        pool: &rayon::ThreadPool,
        accel: &A,
        build_seconds: f64,
        observer: &Observer,
    ) -> anyhow::Result<Rendered> {
        let scene = &self.scene;
        let film = Film::for_region(scene.image.width, scene.image.height, self.region, &scene.output);
        let Some(output) = &self.output else {
            let tiles = self.region.tiles();
            let job = TileJob { tiles: &tiles, stop: None, progress: observer.progress, on_tile: &|_, _| {} };
            let render_start = Instant::now();
            let (film, rays) = pool
                .install(|| integrator::render_tiles(scene, accel, film, &job))
                .with_context(|| format!("{}: rendering failed", self.path.display()))?;
            let render_seconds = render_start.elapsed().as_secs_f64();
            return Ok(Rendered { film, rays, build_seconds, render_seconds, compress_seconds: 0.0, blocks: None });
        };
        output.remove_stale_temporaries(observer);
        let checkpointing = Checkpointing {
            path: output.checkpoint(),
            every: checkpoint_interval(output.checkpoint_every)?,
            resume: output.resume,
            key: checkpoint::key(scene, self.region, self.backend.name()),
        };
        let options = self.exr_options(output);
        let streamed = Streamed { path: &output.exr, options: &options, checkpointing: &checkpointing };
        let mut rendered = self.trace_to_files(pool, accel, film, &streamed, observer)?;
        rendered.build_seconds = build_seconds;
        Ok(rendered)
    }

    /// [`RenderJob::trace`] with an output: resuming from and saving to the checkpoint, the
    /// EXR's blocks compressed as the tiles finish.
    fn trace_to_files<A: Accel>(
        &self,
        pool: &rayon::ThreadPool,
        accel: &A,
        mut film: Film,
        out: &Streamed,
        observer: &Observer,
    ) -> anyhow::Result<Rendered> {
        let (scene, ckpt) = (&self.scene, out.checkpointing);
        let tiles = self.region.tiles();
        let shown = ckpt.path.display();
        let fresh = || Film::for_region(scene.image.width, scene.image.height, self.region, &scene.output);
        let done = ckpt.restore(&tiles, &mut film, fresh, observer)?;
        // A mask, not `done.contains`: a 16384² frame has a million tiles.
        let mut is_done = vec![false; tiles.len()];
        for &k in &done {
            is_done[k] = true;
        }
        let todo: Vec<usize> = (0..tiles.len()).filter(|&k| !is_done[k]).collect();
        let todo_tiles: Vec<Region> = todo.iter().map(|&k| tiles[k]).collect();
        let blocks = BlockStream::new(&film, out.options, out.path, &todo_tiles);

        // While the tiles are traced, the first SIGINT/SIGTERM only asks to stop (the
        // checkpoint is saved below); a second one, or any during the writing, exits at once
        // (crate::sys::signals).
        let stop = crate::sys::signals::stop_requested();
        crate::sys::signals::graceful(true);
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
                        (observer.note)(&format!("warning: cannot save the checkpoint: {e:#}"));
                    }
                }
                *last = (Instant::now(), start.elapsed());
            }
        };
        (observer.progress)(tiles.iter().zip(&is_done).filter(|(_, d)| **d).map(|(t, _)| t.pixel_count()).sum());
        let render_start = Instant::now();
        let job = TileJob { tiles: &todo_tiles, stop: Some(stop), progress: observer.progress, on_tile: &on_tile };
        let rendered = pool.install(|| integrator::render_tiles(scene, accel, film, &job));
        crate::sys::signals::graceful(false);
        let (film, rays) = rendered.with_context(|| format!("{}: rendering failed", self.path.display()))?;
        let render_seconds = render_start.elapsed().as_secs_f64();
        if stop.load(Ordering::Relaxed) {
            let film = Mutex::new(film);
            let saved = save(&film)?;
            bail!(
                "interrupted: {saved} of {} tiles saved in {shown}; run the same command with --resume to continue",
                tiles.len()
            );
        }
        let compress_seconds = blocks.thread_seconds();
        Ok(Rendered { film, rays, build_seconds: 0.0, render_seconds, compress_seconds, blocks: Some(blocks) })
    }
}

/// What a finished job prints:
///
/// ```text
/// scene.toml: 960 × 540 pixels, 4 spp, max depth 8, 2 threads
///   backend: embree, BVH built in 1.2 ms
///   rays: 2073600 primary, … in all
///   time: 1.234 s rendering (4.56 Mrays/s), 0.012 s of it compressing the EXR
///   wrote out.exr (12.3 MB), out.png (1.0 MB) in 0.045 s
/// ```
pub struct Summary<'a> {
    job: &'a RenderJob,
    rendered: &'a Rendered,
    write_seconds: f64,
}

impl fmt::Display for Summary<'_> {
    fn fmt(&self, f: &mut fmt::Formatter) -> fmt::Result {
        let Summary { job, rendered, write_seconds } = self;
        let (image, region, threads) = (job.scene.image, job.region, job.threads);
        let part = if region == Region::full(image.width, image.height) {
            String::new()
        } else {
            format!(", region {region}")
        };
        writeln!(
            f,
            "{}: {} × {} pixels{part}, {} spp, max depth {}, {threads} thread{}",
            job.path.display(),
            image.width,
            image.height,
            image.spp,
            image.max_depth,
            if threads == 1 { "" } else { "s" }
        )?;
        let other = match job.backend {
            Backend::Embree => "native",
            Backend::Native => "embree",
        };
        let compared =
            if job.compares_backends() { format!(" (camera rays compared with {other})") } else { String::new() };
        writeln!(
            f,
            "  backend: {}{compared}, BVH built in {:.1} ms",
            job.backend.name(),
            1e3 * rendered.build_seconds
        )?;
        writeln!(f, "  rays: {}", ray_summary(&rendered.rays))?;
        // The rendering threads also compressed the EXR's blocks as tiles finished: the rays'
        // rate is over the rest of the time.
        let compressing = rendered.compress_seconds / threads as f64;
        let share =
            if compressing > 0.0 { format!(", {compressing:.3} s of it compressing the EXR") } else { String::new() };
        let render_seconds = rendered.render_seconds;
        writeln!(
            f,
            "  time: {render_seconds:.3} s rendering ({:.2} Mrays/s){share}",
            mrays_per_second(rendered.rays.total(), render_seconds - compressing)
        )?;
        if let Some(output) = &job.output {
            let mut written = vec![sized(&output.exr)];
            written.extend(output.png.as_deref().map(sized));
            writeln!(f, "  wrote {} in {write_seconds:.3} s", written.join(", "))?;
        }
        Ok(())
    }
}

/// The image settings `[width, height, spp, depth]` (`None` keeps the scene's) applied to
/// `image` of the scene at `path`, checked as the scene file's own are
/// ([`crate::scene::load::file::image_problem`]). A width without a height keeps the scene's
/// aspect ratio (a glTF camera's `aspectRatio`): `height = round(width · H / W)`, at least 1.
pub fn override_image(
    path: &Path,
    image: &mut ImageSpec,
    [width, height, spp, depth]: [Option<u32>; 4],
) -> anyhow::Result<()> {
    if let (Some(w), None) = (width, height) {
        if image.width > 0 {
            let h = (w as f64 * image.height as f64 / image.width as f64).round();
            image.height = h.clamp(1.0, u32::MAX as f64) as u32;
        }
    }
    image.width = width.unwrap_or(image.width);
    image.height = height.unwrap_or(image.height);
    image.spp = spp.unwrap_or(image.spp);
    image.max_depth = depth.unwrap_or(image.max_depth);
    if let Some((_, problem)) = crate::scene::load::file::image_problem(image) {
        bail!("{}: with the command-line settings: {problem}", path.display());
    }
    Ok(())
}

/// The passes of `--passes LIST`.
pub fn parse_passes(list: &[String]) -> anyhow::Result<PassSet> {
    PassSet::parse(list).map_err(|m| anyhow::anyhow!("--passes: {m}"))
}

/// The EXR compression named `name` (`--compression`), or a message listing the names.
pub fn parse_compression(name: &str) -> Result<Compression, String> {
    Compression::from_name(name).ok_or_else(|| {
        let known: Vec<&str> = Compression::ALL.iter().map(|(_, n)| *n).collect();
        format!("unknown compression '{name}' (known: {})", known.join(", "))
    })
}

/// The number of threads to use: `requested`, or one per core.
///
/// At most one per core this process may run on (its affinity and cgroup quota, as
/// [`std::thread::available_parallelism`] reads them): more would only wait for each other (an
/// idle rayon worker tries to steal from every other one, so the waiting grows with the square
/// of the count: `--threads 4096` took 112 s on 2 cores for an 8 × 8 image, 0.04 s capped);
/// a note on stderr says so.
pub fn thread_count(requested: Option<usize>) -> usize {
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

/// The time between two checkpoints, `--checkpoint-every SECONDS`: 0 to 1e9 s (about 32
/// years; a larger float has no `Duration`, and `from_secs_f64` panics on it).
pub fn checkpoint_interval(seconds: f64) -> anyhow::Result<Duration> {
    Duration::try_from_secs_f64(seconds).ok().filter(|d| d.as_secs_f64() <= 1e9).with_context(|| {
        let shown = if seconds.abs() < 1e9 { seconds.to_string() } else { format!("{seconds:e}") };
        format!("--checkpoint-every {shown} is not a number of seconds from 0 to 1e9")
    })
}

/// A rayon pool of `threads` workers, each with flush-to-zero on as Embree asks.
pub fn thread_pool(threads: usize) -> anyhow::Result<rayon::ThreadPool> {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .thread_name(|i| format!("strahl-{i}"))
        .start_handler(|_| embree::enable_flush_to_zero())
        .build()
        .with_context(|| format!("cannot start {threads} threads"))
}

/// An Embree device that builds BVHs on `threads` threads.
pub fn embree_device(threads: usize) -> anyhow::Result<Device> {
    Device::with_options(DeviceOptions { threads: Some(threads) }).context("cannot start Embree")
}

/// The pixels `settings` ask for in `image` of the scene at `path`: `--region`, else
/// `--tile`, else the whole image.
fn region_of(path: &Path, image: &ImageSpec, settings: &Settings) -> anyhow::Result<Region> {
    Ok(match (&settings.region, &settings.tile) {
        (Some(text), _) => {
            let r = Region::parse(text).map_err(|m| anyhow::anyhow!("--region {m}"))?;
            if let Some(problem) = r.problem(image.width, image.height) {
                bail!("{}: --region {problem}", path.display());
            }
            r
        }
        (None, Some(text)) => Region::parse_split(text, image.width, image.height)
            .map_err(|m| anyhow::anyhow!("{}: --tile {m}", path.display()))?,
        (None, None) => Region::full(image.width, image.height),
    })
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
/// read from (the scene at `path`, its meshes, MTL libraries, textures, glTF buffers and
/// images: [`crate::sys::read::inputs_read`]), through any link or spelling
/// ([`crate::sys::same_file`]).
fn refuse_inputs_as_outputs(path: &Path, output: &Output) -> anyhow::Result<()> {
    let checkpoint = output.checkpoint();
    let outputs = [Some(&output.exr), output.png.as_ref(), Some(&checkpoint)];
    let read = crate::sys::read::inputs_read();
    for input in std::iter::once(path).chain(read.iter().map(PathBuf::as_path)) {
        for output in outputs.iter().flatten() {
            if same_file(input, output) {
                bail!("{}: is an input ({}); writing there would destroy it", output.display(), input.display());
            }
        }
    }
    Ok(())
}

/// Refuses a render whose estimated memory ([`memory::estimate`]) is over `max_memory`
/// (default: the smallest limit this process runs under, [`memory::default_limit`]), saying
/// what it needs, which limit refused it and what to do.
fn refuse_over_budget(path: &Path, max_memory: Option<u64>, scene: &Scene, region: Region) -> anyhow::Result<()> {
    use memory::{default_limit, estimate, megabytes};
    let default = if max_memory.is_some() { None } else { default_limit() };
    let Some(limit) = max_memory.or(default.as_ref().map(|d| d.bytes)) else { return Ok(()) };
    let needs = estimate(scene, region.pixel_count());
    if needs.total() > limit {
        let whose = default.map_or(String::new(), |d| format!(" (the default: {})", d.source));
        bail!(
            "{}: this render needs about {needs}, more than --max-memory {}{whose}: render a smaller image \
             (--width/--height), fewer passes (--passes), parts of it (--region or --tile, then strahl merge), \
             or raise --max-memory",
            path.display(),
            megabytes(limit)
        );
    }
    Ok(())
}

/// Where the EXR goes, how it is laid out (its header attributes come after rendering) and
/// how the render is checkpointed.
struct Streamed<'a> {
    path: &'a Path,
    options: &'a ExrOptions,
    checkpointing: &'a Checkpointing,
}

/// Where a render keeps its checkpoint and how ([`crate::output::checkpoint`]).
struct Checkpointing {
    path: PathBuf,
    /// Time between two checkpoints (zero: after every tile).
    every: Duration,
    resume: bool,
    key: String,
}

impl Checkpointing {
    /// The tiles (indices into `tiles`) the checkpoint holds, copied into `film`, when there is
    /// one and the render resumes; none otherwise (a checkpoint that is not resumed is
    /// replaced, with a warning). A damaged checkpoint, or one of another render, is moved
    /// aside with a warning ([`checkpoint::aside`]) and `film` made `fresh` again (the reading
    /// may have filled part of it).
    fn restore(
        &self,
        tiles: &[Region],
        film: &mut Film,
        fresh: impl Fn() -> Film,
        observer: &Observer,
    ) -> anyhow::Result<Vec<usize>> {
        let shown = self.path.display();
        if !self.path.exists() {
            return Ok(Vec::new());
        }
        if !self.resume {
            (observer.note)(&format!(
                "warning: {shown} exists; rendering from the start and replacing it (--resume continues it)"
            ));
            return Ok(Vec::new());
        }
        match checkpoint::read_into(&self.path, &self.key, tiles, film) {
            Ok(done) => {
                (observer.note)(&format!("resuming from {shown}: {} of {} tiles done", done.len(), tiles.len()));
                Ok(done)
            }
            Err(e) if e.kind == checkpoint::Problem::Unreadable => Err(e.into()),
            Err(e) => {
                let aside = checkpoint::aside(&self.path, e.kind);
                std::fs::rename(&self.path, &aside)
                    .with_context(|| format!("{e}; cannot move it aside to {}", aside.display()))?;
                (observer.note)(&format!("warning: {e}; moved it to {}, rendering from the start", aside.display()));
                *film = fresh();
                Ok(Vec::new())
            }
        }
    }
}

/// A test hook: `STRAHL_TEST_TILE_DELAY_MS=N` makes every finished tile wait N ms, so that
/// tests can stop a render at chosen points deterministically (by polling its checkpoint).
fn tile_delay() -> Option<Duration> {
    std::env::var("STRAHL_TEST_TILE_DELAY_MS").ok()?.parse().ok().map(Duration::from_millis)
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
