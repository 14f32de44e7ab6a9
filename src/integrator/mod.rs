//! The integrators: what turns the scene, seen through the camera and traced through an
//! [`Accel`], into the film's pixels. This file holds the [`Integrator`] interface and what
//! every integrator shares; the shading is each integrator's own file.
//!
//! - The tile loop ([`trace_tiles`]): for each tile and each sample round, the camera rays of
//!   its pixels ([`crate::camera`], through the sample positions of [`crate::sampler`]), their
//!   closest hits as one [`Accel::intersect_batch`], the integrator's shading of them
//!   ([`Integrator::shade_round`]) and the sums of each pixel's samples ([`pixel`]).
//! - [`render`], [`render_region`], [`render_tiles`]: the scene checked ([`check_scene`]), the
//!   camera built, and the tile loop with the scene's integrator (`[render] integrator`):
//!   [`whitted::Whitted`] (the default) or [`path::PathTracer`].
//! - [`lights`]: the lights as a shading point samples them, and the shadow ray towards each;
//!   [`shadow`]: the shadow rays of a round's camera hits, traced light by light as batches.
//!
//! An integrator is a file beside [`whitted`] and [`path`] that implements [`Integrator`],
//! including the pixel sampler it draws from ([`PixelSamples`]: Whitted's stratified positions
//! and light points, the path tracer's Owen-scrambled Sobol sequence); the tile loop, the
//! pixels' sums, the lights and the shadow batches are shared.
//!
//! **Sampling and determinism.** `image.spp` samples per pixel, box-filtered (their mean),
//! drawn from the integrator's pixel sampler seeded from the pixel index alone: stratified
//! ([`crate::sampler`]; `spp = 1` traces exactly the pixel centre) for Whitted, Sobol
//! ([`crate::sampling::sobol`]) for the path tracer. The image (or the [`Region`] of it being rendered) is split
//! into [`TILE_SIZE`](crate::output::region::TILE_SIZE)² tiles of the image's grid ([`Region::tiles`]) rendered in parallel with
//! rayon on the current pool. A tile traces its samples round by round, each
//! round one batch of primary rays ordered in 4×2-pixel blocks (one packet each); a pixel's
//! samples are summed in sample order, ray counts are integers, and tiles are assembled in a
//! fixed order, so the film and the counts are bit-identical for any number of threads. What the film's channels hold is
//! documented in [`crate::output::film`].
//!
//! **Adaptive sampling** ([`adaptive`], `[render] adaptive_threshold`): after the rounds at
//! which Cycles tests pixels, the pixels of a tile that have converged, their neighbours in
//! the tile's grid cell too, leave its batch ([`retire_converged`]); the others go on, in
//! their order, until `spp`. When a pixel stops depends on its cell's samples alone (a tile
//! the region clips traces its whole cell), so this changes nothing of the above.
//!
//! **Streaming.** Each tile's pixels go into the one film as the tile finishes (under a lock
//! held for the tile's copy); no second frame-sized buffer exists. Every pixel is written by
//! exactly one tile, so the order tiles finish in does not matter.

pub mod adaptive;
pub mod features;
pub mod lights;
pub mod path;
pub mod path_lights;
pub mod pixel;
pub mod shadow;
pub mod whitted;

use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, Ordering};

use rayon::prelude::*;

pub use path::PathTracer;
pub use pixel::{CameraSample, FirstHit, Radiance};
pub use whitted::{Whitted, WhittedSampler};

use crate::accel::{Accel, Hit, TraceError};
use crate::camera::Camera;
use crate::math::{Ray, Vec2};
use crate::output::film::Film;
use crate::output::ids::ObjectIds;
use crate::output::passes::Pass;
use crate::output::region::Region;
use crate::sampling::seeded_pixel;
use crate::scene::{IntegratorKind, MAX_DEPTH_LIMIT, Scene};
use crate::shading::ConstantBsdfs;
use pixel::PixelAccumulator;

/// Rays traced, by kind, for the summary the command prints.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RayCounts {
    pub primary: u64,
    pub shadow: u64,
    pub reflected: u64,
    pub refracted: u64,
}

impl RayCounts {
    /// All rays of every kind.
    pub fn total(&self) -> u64 {
        self.primary + self.shadow + self.reflected + self.refracted
    }
}

impl std::ops::AddAssign for RayCounts {
    fn add_assign(&mut self, o: RayCounts) {
        self.primary += o.primary;
        self.shadow += o.shadow;
        self.reflected += o.reflected;
        self.refracted += o.refracted;
    }
}

/// Why a render failed: the camera or the scene cannot be rendered (found before anything is
/// traced), or the backend failed while tracing.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    /// The backend failed while tracing.
    #[error(transparent)]
    Trace(#[from] TraceError),
    /// The camera cannot be built (its message starts with `camera:`).
    #[error(transparent)]
    Camera(#[from] crate::camera::CameraError),
    /// An object of the scene cannot be rendered: `sphere 3: material 7 does not exist ...`.
    #[error("{0}")]
    InvalidScene(String),
}

/// The random numbers of one pixel's samples, as the tile loop draws the camera rays from
/// them; the integrator draws the rest from the same sampler in [`Integrator::shade_round`].
pub trait PixelSamples {
    /// Starts the pixel's sample `sample` (they come in order `0..spp`).
    fn begin(&mut self, sample: u32);
    /// The sample's position in the pixel, in `[0, 1)²`.
    fn pixel(&mut self) -> Vec2;
    /// The sample's lens point in `[0, 1)²` (drawn after [`PixelSamples::pixel`], only with an
    /// aperture).
    fn lens(&mut self) -> Vec2;
}

/// What shades the camera rays of a sample round: [`Whitted`], [`PathTracer`].
/// The tile loop ([`trace_tiles`]) makes the rays, finds their closest hits and sums what
/// this returns into the pixels; an integrator turns each ray and hit into a
/// [`CameraSample`], tracing whatever further rays it needs.
pub trait Integrator: Sync {
    /// Working memory of one tile, reused from round to round (shadow-ray batches, ...).
    type Scratch: Default;

    /// One pixel's sampler.
    type Sampler: PixelSamples;

    /// The sampler of the pixel with index `pixel_index` (`y·W + x`, the render's seed folded
    /// in: [`seeded_pixel`]) for `spp` samples; `lens` when the camera has an aperture. It may
    /// depend on nothing else.
    fn sampler(&self, spp: u32, pixel_index: u64, lens: bool) -> Self::Sampler;

    /// Shades one round: `out[i]` for the camera ray `rays[i]`, whose closest hit is `hits[i]`
    /// and whose pixel's sampler is `samplers[i]` (begun for the round's sample, the camera's
    /// numbers drawn). Adds the rays it traces to `counts`. Each pixel's sample must depend on
    /// nothing but that pixel's ray, hit and sampler, so that a render is the same for any
    /// split into tiles.
    fn shade_round(
        &self,
        rays: &[Ray],
        hits: &[Option<Hit>],
        samplers: &mut [Self::Sampler],
        counts: &mut RayCounts,
        scratch: &mut Self::Scratch,
        out: &mut [CameraSample],
    ) -> Result<(), TraceError>;
}

/// Renders `scene` (its `image` settings: size, spp, depth, background) with `accel`, in
/// parallel over tiles on the current rayon pool. `progress` is called with the number of
/// pixels finished since its last call. Deterministic: the same bytes for any thread count.
///
/// Fails before tracing anything if the camera or the scene cannot be rendered (a material
/// index out of range, a bad light or material, `spp = 0`, `max_depth` above
/// [`MAX_DEPTH_LIMIT`]), and with the backend's error if
/// tracing fails.
pub fn render<A: Accel>(
    scene: &Scene,
    accel: &A,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<(Film, RayCounts), RenderError> {
    let region = Region::full(scene.image.width, scene.image.height);
    render_region(scene, accel, region, progress)
}

/// [`render`] of the pixels of `region` only (which must lie inside the image): a film of
/// that region, every pixel bit-identical to the same pixel of a full render.
pub fn render_region<A: Accel>(
    scene: &Scene,
    accel: &A,
    region: Region,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<(Film, RayCounts), RenderError> {
    let film = Film::for_region(scene.image.width, scene.image.height, region, &scene.output);
    let tiles = region.tiles();
    let on_tile = |_: usize, _: &Mutex<Film>| {};
    let job = TileJob { tiles: &tiles, stop: None, progress, on_tile: &on_tile };
    render_tiles(scene, accel, film, &job)
}

/// What [`render_tiles`] traces and whom it tells.
pub struct TileJob<'a> {
    /// The tiles to trace (inside the film's region; [`Region::tiles`] or some of them).
    pub tiles: &'a [Region],
    /// When set (by a signal handler, say), tiles not yet begun are skipped; those under way
    /// finish. The caller can tell by the flag that the film is incomplete.
    pub stop: Option<&'a AtomicBool>,
    /// Called with the number of pixels finished since its last call.
    pub progress: &'a (dyn Fn(u64) + Sync),
    /// Called with the index (into `tiles`) of each tile once its pixels are in the film, and
    /// the film (not locked: lock it to read).
    pub on_tile: &'a (dyn Fn(usize, &Mutex<Film>) + Sync),
}

/// Traces `job.tiles` of `scene` into `film` (a film of the image or of a region of it,
/// perhaps holding finished tiles already), in parallel on the current rayon pool, and
/// returns it with the rays traced. Each pixel is written by exactly one tile and depends on
/// nothing but its own index, so which tiles run, in what order and on how many threads
/// changes no value.
pub fn render_tiles<A: Accel>(
    scene: &Scene,
    accel: &A,
    film: Film,
    job: &TileJob,
) -> Result<(Film, RayCounts), RenderError> {
    check_scene(scene)?;
    let img = &scene.image;
    let camera = Camera::new(&scene.camera, img.width, img.height)?;
    match scene.render.integrator {
        IntegratorKind::Whitted => trace_tiles(scene, accel, &camera, &Whitted::new(scene, accel, camera), film, job),
        IntegratorKind::Path => trace_tiles(scene, accel, &camera, &PathTracer::new(scene, accel), film, job),
    }
}

/// The tile loop: [`render_tiles`] with `integrator` shading the camera rays of `camera`
/// (the scene checked by the caller, [`check_scene`]).
pub fn trace_tiles<A: Accel, I: Integrator>(
    scene: &Scene,
    accel: &A,
    camera: &Camera,
    integrator: &I,
    film: Film,
    job: &TileJob,
) -> Result<(Film, RayCounts), RenderError> {
    let ids = ObjectIds::new(scene);
    // The denoising features, when their passes are asked for, with the untextured materials'
    // lobes they shade with (the path tracer keeps its own).
    let passes = scene.output.passes;
    let features = (passes.contains(Pass::DenoisingAlbedo) || passes.contains(Pass::DenoisingNormal))
        .then(|| ConstantBsdfs::new(scene));
    let inside = film.region();
    if let Some(t) = job.tiles.iter().find(|t| t.intersection(&inside) != Some(**t)) {
        return Err(RenderError::InvalidScene(format!("tile {t} lies outside the film's region {inside}")));
    }
    let film = Mutex::new(film);
    let counts = job
        .tiles
        .par_iter()
        .enumerate()
        .map(|(k, tile)| {
            if job.stop.is_some_and(|s| s.load(Ordering::Relaxed)) {
                return Ok(RayCounts::default());
            }
            let (pixels, accumulators, counts) =
                render_tile(scene, accel, camera, integrator, tile, &ids, features.as_ref())?;
            {
                let mut film = film.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
                for (&(x, y), acc) in pixels.iter().zip(&accumulators) {
                    acc.write(&mut film, x, y, scene, camera, &ids);
                }
            }
            (job.progress)(tile.pixel_count());
            (job.on_tile)(k, &film);
            Ok::<_, RenderError>(counts)
        })
        .try_reduce(RayCounts::default, |mut a, b| {
            a += b;
            Ok(a)
        })?;
    Ok((film.into_inner().unwrap_or_else(|poisoned| poisoned.into_inner()), counts))
}

/// Renders one tile: all its pixels' samples, round by round, each round one batch of camera
/// rays. Returns the pixels (in packet order), their accumulated samples and the rays traced.
#[allow(clippy::type_complexity)]
fn render_tile<A: Accel, I: Integrator>(
    scene: &Scene,
    accel: &A,
    camera: &Camera,
    integrator: &I,
    tile: &Region,
    ids: &ObjectIds,
    features: Option<&ConstantBsdfs>,
) -> Result<(Vec<(u32, u32)>, Vec<PixelAccumulator>, RayCounts), TraceError> {
    // The backend's float mode (flush-to-zero, which Embree asks of every thread that
    // traces); setting it here (two instructions) also makes shading arithmetic identical
    // on every worker, whatever the pool's start handler did.
    accel.prepare_thread();
    let width = scene.image.width as u64;
    let passes = scene.output.passes;
    let crypto = passes.contains(Pass::CryptoObject) || passes.contains(Pass::CryptoMaterial);
    let compare = passes.contains(Pass::Disagreement);
    let adaptive = scene.render.adaptive.as_ref().map(adaptive::Adaptive::new);
    // Adaptive sampling decides over the tile's whole grid cell (its neighbour dilation,
    // [`adaptive::dilate`]): a tile the region clips traces the rest of its cell as well, for
    // the noise estimates, and returns only its own pixels.
    let traced = if adaptive.is_some() { tile.grid_cell(scene.image.width, scene.image.height) } else { *tile };
    let mut pixels = traced.pixels_in_packet_order();
    let spp = scene.image.spp;
    let lens = camera.has_lens();
    let seed = scene.render.seed;
    let mut samplers: Vec<I::Sampler> = pixels
        .iter()
        .map(|&(x, y)| integrator.sampler(spp, seeded_pixel(y as u64 * width + x as u64, seed), lens))
        .collect();
    let mut accumulators = vec![PixelAccumulator::default(); pixels.len()];
    let mut counts = RayCounts::default();
    let mut rays = Vec::with_capacity(pixels.len());
    let mut hits = vec![None; pixels.len()];
    let mut differ = vec![false; if compare { pixels.len() } else { 0 }];
    // Written in place every round (a 160-byte value returned per pixel cost a memcpy call).
    let mut samples = vec![CameraSample::default(); pixels.len()];
    let mut scratch = I::Scratch::default();
    // The pixels still sampling are the first `n` of `pixels`, `samplers` and `accumulators`.
    let mut n = pixels.len();
    for sample in 0..spp {
        if n == 0 {
            break;
        }
        camera_rays(camera, &pixels[..n], &mut samplers[..n], sample, &mut rays);
        counts.primary += rays.len() as u64;
        let hits = &mut hits[..n];
        accel.intersect_batch(&rays, hits)?;
        if compare {
            accel.compare_first_hits(&rays, hits, &mut differ[..n])?;
            for (acc, _) in accumulators.iter_mut().zip(&differ[..n]).filter(|(_, d)| **d) {
                acc.add_disagreement();
            }
        }
        let samples = &mut samples[..n];
        integrator.shade_round(&rays, hits, &mut samplers[..n], &mut counts, &mut scratch, samples)?;
        for (acc, s) in accumulators.iter_mut().zip(samples.iter()) {
            let object = s.first.filter(|_| crypto).map(|f| ids.object_of(scene, &f.hit));
            acc.add(s.radiance, &s.split, s.first, object);
        }
        if let Some(constant) = features {
            for ((acc, ray), hit) in accumulators.iter_mut().zip(&rays).zip(hits.iter()) {
                acc.add_features(features::denoising_features(scene, constant, accel, ray, hit.as_ref(), &mut counts)?);
            }
        }
        if let Some(rule) = adaptive.as_ref().filter(|rule| rule.tests_after(sample)) {
            n = retire_converged(rule, &traced, n, &mut pixels, &mut samplers, &mut accumulators);
        }
    }
    if traced != *tile {
        let inside = |&(x, y): &(u32, u32)| (tile.x0..tile.x1).contains(&x) && (tile.y0..tile.y1).contains(&y);
        let (mine, accumulators): (Vec<_>, Vec<_>) =
            pixels.into_iter().zip(accumulators).filter(|(p, _)| inside(p)).unzip();
        return Ok((mine, accumulators, counts));
    }
    Ok((pixels, accumulators, counts))
}

/// Moves the pixels among the first `n` that stop after this test (they and their neighbours
/// in `cell` meet `rule`, [`adaptive::dilate`]) behind those that go on, keeping the order of
/// the latter (their packets stay as coherent as they can), and returns how many go on. The
/// three lists are permuted alike; `pixels` are `cell`'s.
fn retire_converged<S>(
    rule: &adaptive::Adaptive,
    cell: &Region,
    n: usize,
    pixels: &mut [(u32, u32)],
    samplers: &mut [S],
    accumulators: &mut [PixelAccumulator],
) -> usize {
    let width = cell.width() as usize;
    let at = |(x, y): (u32, u32)| (y - cell.y0) as usize * width + (x - cell.x0) as usize;
    let mut unconverged = vec![false; cell.pixel_count() as usize];
    for (&p, acc) in pixels[..n].iter().zip(&accumulators[..n]) {
        unconverged[at(p)] = !acc.converged(rule);
    }
    let going_on = adaptive::dilate(&unconverged, width);
    let mut kept = 0;
    for i in 0..n {
        if going_on[at(pixels[i])] {
            pixels.swap(kept, i);
            samplers.swap(kept, i);
            accumulators.swap(kept, i);
            kept += 1;
        }
    }
    kept
}

/// The camera rays of round `sample` into `rays`, one per pixel: the pinhole ray through the
/// pixel's sample position, or with a thin lens the ray from the sample's lens point
/// ([`PixelSamples::begin`] starts the round's numbers).
fn camera_rays<S: PixelSamples>(
    camera: &Camera,
    pixels: &[(u32, u32)],
    samplers: &mut [S],
    sample: u32,
    rays: &mut Vec<Ray>,
) {
    let lens = camera.has_lens();
    rays.clear();
    rays.extend(pixels.iter().zip(samplers).map(|(&(x, y), s)| {
        s.begin(sample);
        let offset = s.pixel();
        if lens { camera.lens_ray(x, y, offset, s.lens()) } else { camera.ray(x, y, offset) }
    }));
}

/// Checks the `[render]` settings against the rest of the scene: the clamp, adaptive sampling
/// (the path tracer's only), and for the path tracer the samples its Sobol sequence holds. Part of
/// [`check_scene`]; also called by a job before anything is loaded or built.
pub fn check_render(scene: &Scene) -> Result<(), RenderError> {
    if let Some(problem) = scene.render.problem() {
        return Err(RenderError::InvalidScene(format!("render: {problem}")));
    }
    if scene.render.integrator == IntegratorKind::Whitted && scene.render.adaptive.is_some() {
        let problem = "adaptive sampling is the path tracer's (--integrator path): Whitted's stratified \
                       samples are spread for exactly spp samples, so a pixel cannot stop early";
        return Err(RenderError::InvalidScene(format!("render: {problem}")));
    }
    if scene.render.integrator == IntegratorKind::Path {
        if let Err(problem) = crate::sampling::sobol::check_spp(scene.image.spp) {
            return Err(RenderError::InvalidScene(format!("image: {problem}")));
        }
    }
    Ok(())
}

/// Checks everything the integrator indexes or divides by, so that rendering cannot panic or
/// produce NaN from bad input. Errors name the object: `sphere 3: material 7 does not exist`.
pub fn check_scene(scene: &Scene) -> Result<(), RenderError> {
    let bad = |object: String, problem: String| Err(RenderError::InvalidScene(format!("{object}: {problem}")));
    if scene.image.spp == 0 {
        return bad("image".into(), "spp 0 must be at least 1".into());
    }
    check_render(scene)?;
    if scene.image.max_depth > MAX_DEPTH_LIMIT {
        return bad("image".into(), format!("max_depth {} exceeds {MAX_DEPTH_LIMIT}", scene.image.max_depth));
    }
    for (name, c) in [("background", scene.image.background), ("ambient", scene.image.ambient)] {
        if !(c.is_finite() && c.min_element() >= 0.0) {
            return bad("image".into(), format!("{name} {c} must be finite and ≥ 0"));
        }
    }
    if let Some(problem) = scene.environment.as_ref().and_then(|e| e.problem()) {
        return bad("environment".into(), problem);
    }
    for (i, m) in scene.materials.iter().enumerate() {
        if let Some(problem) = m.problem() {
            return bad(format!("material {i} '{}'", m.name), problem);
        }
    }
    for (i, l) in scene.lights.iter().enumerate() {
        if let Some(problem) = l.problem() {
            return bad(format!("light {i}"), problem);
        }
    }
    for (i, l) in scene.area_lights.iter().enumerate() {
        if let Some(problem) = l.problem() {
            return bad(format!("area light {i}"), problem);
        }
    }
    let n = scene.materials.len();
    let missing = |m: u32| (m as usize >= n).then(|| format!("material {m} does not exist (the scene has {n})"));
    for (i, mesh) in scene.meshes.iter().enumerate() {
        let object = format!("mesh {i} '{}'", mesh.name);
        if let Some(problem) = mesh.problem() {
            return bad(object, problem);
        }
        let per_triangle = mesh.triangle_materials.iter().flatten().copied();
        if let Some(problem) = std::iter::once(mesh.material).chain(per_triangle).find_map(missing) {
            return bad(object, problem);
        }
    }
    if let Some((object, problem)) = scene.instances_problem() {
        return bad(object, problem);
    }
    for (i, mesh) in scene.prototypes.iter().enumerate() {
        let per_triangle = mesh.triangle_materials.iter().flatten().copied();
        if let Some(problem) = std::iter::once(mesh.material).chain(per_triangle).find_map(missing) {
            return bad(format!("prototype {i} '{}'", mesh.name), problem);
        }
    }
    for (i, s) in scene.spheres.iter().enumerate() {
        if let Some(problem) = s.problem().or_else(|| missing(s.material)) {
            return bad(format!("sphere {i}"), problem);
        }
    }
    for (i, p) in scene.planes.iter().enumerate() {
        if let Some(problem) = p.problem().or_else(|| missing(p.material)) {
            return bad(format!("plane {i}"), problem);
        }
    }
    if let Some((object, problem)) = crate::scene::magnitude::problem(scene) {
        return bad(object, problem);
    }
    Ok(())
}
