//! The Whitted integrator: the lecture's ray tracer, in its three steps.
//!
//! 1. **Ray generation** ([`crate::camera`]): for every pixel and sample, the pinhole ray
//!    `e + t·s/|s|` through the sample's position ([`crate::sampler`]), or with a thin lens
//!    the ray from a lens point (stratified across the pixel's samples, [`SampleDims`])
//!    through the point of the focus plane that pinhole ray meets.
//! 2. **Intersection** ([`Accel`]): the closest hit with `t > 0`. Primary rays of a tile go
//!    to [`Accel::intersect_batch`] (Embree traces them as 8-wide packets, 2–4× faster on
//!    coherent rays); secondary rays one at a time; shadow rays as any-hit `occluded` queries.
//!    The shadow rays of a tile's camera-ray hits go out light by light (for an area light,
//!    sample by sample) as one [`Accel::occluded_batch`] each, which Embree traces as 8-wide
//!    `rtcOccluded8` packets: neighbouring pixels' rays towards one light point are as coherent
//!    as their camera rays. Deeper hits trace theirs one by one.
//! 3. **Shading** ([`Whitted::shade`]) at the hit, with the data of [`SurfacePoint`]:
//!
//! ```text
//! L = L_e + ρ·L_a                                      emission + ambient
//!   + Σ_lights V · (ρ/π + k_s·K(n)·(n·h)^n) · E·cosθ   diffuse + normalised Blinn–Phong
//!   + k_r · L(reflected ray)                           mirror (+ Fresnel R of a dielectric)
//!   + k_t · T · L(refracted ray)                       Snell + Fresnel
//! ```
//!
//! with `E = I/d²` for a point light of intensity `I` at distance `d` and `E` itself for a
//! directional light, `cosθ` between the shading normal and the direction to the light, and
//! `V` the shadow ray's verdict. An area light adds `light_samples` such terms, each with a
//! point sampled on the light and `E = L·cosθ_l/(d²·pdf_A)/light_samples`
//! ([`crate::light::area`]): the same shadow ray and BRDF, so its light lands in the direct
//! diffuse and specular passes. Every mesh with an emitting material is such a light too, with
//! one sample per shading point ([`crate::light::mesh`]). The light points are stratified across the pixel's samples
//! ([`SampleDims`]). Emitters are ordinary objects to every ray (their `L_e` is what camera,
//! mirror and glass rays see, from the front only when one-sided); a shadow ray ends just
//! short of its light sample, so a light does not shadow itself. A dielectric (`transmission = k_t ≠ 0`) adds `k_t·R` to the
//! mirror weight `k_r` and refracts `k_t·T`, `R` from the exact unpolarised Fresnel equations
//! and `T = 1 − R` ([`crate::optics`]); beyond the critical angle `R = 1` (total internal
//! reflection). A ray entering or leaving a dielectric is told apart by the geometric normal:
//! entering when it arrives on the side the normal points to (`ior` inside, 1 outside).
//! Rays that escape return the background radiance.
//!
//! **Recursion.** The primary ray has depth 0; a hit at depth `k` spawns reflected and
//! refracted rays only while `k < image.max_depth`, so at most `max_depth` secondary rays
//! follow one another. A secondary ray is also skipped when its throughput (the product of
//! the weights along its path) falls below [`THROUGHPUT_CUTOFF`] in every channel.
//! `max_depth` may be at most [`MAX_DEPTH_LIMIT`] (the recursion uses the worker's stack).
//!
//! **Shadow rays and glass.** Every object blocks shadow rays, glass included: a glass ball
//! casts an ordinary hard shadow. A straight shadow ray through a refracting object would be
//! physically wrong either way: the light that really reaches the shadow is focused into
//! caustics, which a Whitted tracer cannot find; letting it through unbent (perhaps
//! tinted) would paint a lit disc where the real image has a dark shadow with a bright
//! caustic somewhere else. The ordinary shadow is the lecture's, and the honest one.
//!
//! **Secondary-ray origins** are moved off the surface with
//! [`crate::math::offset_ray_origin`] (Wächter–Binder), to the side the new ray leaves on;
//! shadow rays towards a point light end just short of it ([`SHADOW_TFAR_SCALE`]).
//!
//! **Sampling and determinism.** `image.spp` stratified samples per pixel
//! ([`crate::sampler`], seeded from the pixel index), box-filtered (their mean); `spp = 1`
//! traces exactly the pixel centre. The image (or the [`Region`] of it being rendered) is split
//! into [`TILE_SIZE`]² tiles of the image's grid ([`Region::tiles`]) rendered in parallel with
//! rayon on the current pool. A tile traces its samples round by round, each
//! round one batch of primary rays ordered in 4×2-pixel blocks (one packet each); a pixel's
//! samples are summed in sample order, ray counts are integers, and tiles are assembled in a
//! fixed order, so the film and the counts are bit-identical for any number of threads. What the film's channels hold is
//! documented in [`crate::film`].
//!
//! **Passes.** Shading the camera ray's hit also splits its radiance into the six terms of
//! the formula ([`Radiance`]: emission + ambient, direct diffuse, direct specular, reflection,
//! transmission, and the background of a camera ray that escapes), the light-path passes of
//! [`crate::passes`]. The beauty is still summed as before, term by term in the same order, so
//! the passes add up to it to float rounding and the beauty does not change.
//!
//! **Streaming.** Each tile's pixels go into the one film as the tile finishes (under a lock
//! held for the tile's copy); no second frame-sized buffer exists. Every pixel is written by
//! exactly one tile, so the order tiles finish in does not matter.

use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, Ordering};

use rayon::prelude::*;

use crate::accel::{Accel, Hit, TraceError};
use crate::camera::Camera;
use crate::cryptomatte;
use crate::film::Film;
use crate::ids::ObjectIds;
use crate::light::Incidence;
use crate::light::mesh::MeshEmitter;
use crate::material::Material;
use crate::math::{Ray, Vec3, offset_ray_origin};
use crate::optics;
use crate::passes::{LIGHT_PASSES, Pass};
use crate::region::Region;
use crate::sampler::{PixelSampler, SampleDims, strata};
use crate::scene::Scene;
use crate::surface::SurfacePoint;

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

pub use crate::region::TILE_SIZE;

/// A secondary ray whose throughput is below this in every channel is not traced: it could
/// change the pixel by at most this fraction of the radiance it would find.
pub const THROUGHPUT_CUTOFF: f32 = 1e-4;

/// The largest `image.max_depth` accepted. Reflection and refraction recurse once per
/// bounce; this bounds the stack a worker thread needs (well inside rayon's default), and
/// no image changes visibly beyond it (even between perfect mirrors the `max_depth`-th image
/// is a speck).
pub const MAX_DEPTH_LIMIT: u32 = 256;

/// A shadow ray towards a point light at distance `d` ends at `d·SHADOW_TFAR_SCALE`, just short
/// of the light, so that a surface the light sits on does not shadow it.
pub const SHADOW_TFAR_SCALE: f32 = 1.0 - 1e-4;

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
) -> Result<(Film, RayCounts), TraceError> {
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
) -> Result<(Film, RayCounts), TraceError> {
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
) -> Result<(Film, RayCounts), TraceError> {
    check_scene(scene)?;
    let img = &scene.image;
    let camera = Camera::new(&scene.camera, img.width, img.height)?;
    let whitted = Whitted::new(scene, accel, camera);
    let ids = ObjectIds::new(scene);
    let inside = film.region();
    if let Some(t) = job.tiles.iter().find(|t| t.intersection(&inside) != Some(**t)) {
        return Err(TraceError::InvalidScene(format!("tile {t} lies outside the film's region {inside}")));
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
            let (pixels, accumulators, counts) = whitted.render_tile(tile, &ids)?;
            {
                let mut film = film.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
                for (&(x, y), acc) in pixels.iter().zip(&accumulators) {
                    acc.write(&mut film, x, y, scene, &ids);
                }
            }
            (job.progress)(tile.pixel_count());
            (job.on_tile)(k, &film);
            Ok::<_, TraceError>(counts)
        })
        .try_reduce(RayCounts::default, |mut a, b| {
            a += b;
            Ok(a)
        })?;
    Ok((film.into_inner().unwrap_or_else(|poisoned| poisoned.into_inner()), counts))
}

/// Checks everything the integrator indexes or divides by, so that rendering cannot panic or
/// produce NaN from bad input. Errors name the object: `sphere 3: material 7 does not exist`.
pub fn check_scene(scene: &Scene) -> Result<(), TraceError> {
    let bad = |object: String, problem: String| Err(TraceError::InvalidScene(format!("{object}: {problem}")));
    if scene.image.spp == 0 {
        return bad("image".into(), "spp 0 must be at least 1".into());
    }
    if scene.image.max_depth > MAX_DEPTH_LIMIT {
        return bad("image".into(), format!("max_depth {} exceeds {MAX_DEPTH_LIMIT}", scene.image.max_depth));
    }
    for (name, c) in [("background", scene.image.background), ("ambient", scene.image.ambient)] {
        if !(c.is_finite() && c.min_element() >= 0.0) {
            return bad("image".into(), format!("{name} {c} must be finite and ≥ 0"));
        }
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

/// The radiance of a camera ray split into the terms of the shading formula (the module
/// docs); their sum is the beauty to float rounding. Each is in W/(m²·sr).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Radiance {
    /// Emission `L_e` plus ambient `ρ·L_a` of the first hit.
    pub emission: Vec3,
    /// Direct light reflected by the Lambert lobe at the first hit.
    pub diffuse: Vec3,
    /// Direct light reflected by the Blinn–Phong highlight at the first hit.
    pub specular: Vec3,
    /// What the mirror and Fresnel reflection at the first hit bring, weighted.
    pub reflection: Vec3,
    /// What the refraction at the first hit brings, weighted.
    pub transmission: Vec3,
    /// The background radiance of a camera ray that hits nothing.
    pub background: Vec3,
}

impl Radiance {
    /// The terms in the order of [`LIGHT_PASSES`].
    pub fn terms(&self) -> [Vec3; 6] {
        [self.emission, self.diffuse, self.specular, self.reflection, self.transmission, self.background]
    }

    /// The sum of the terms.
    pub fn sum(&self) -> Vec3 {
        self.terms().into_iter().sum()
    }
}

/// What a primary ray found at its first hit, for the AOVs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FirstHit {
    /// Distance from the eye (the primary ray's direction has unit length).
    pub t: f32,
    /// World-space unit shading normal, facing the eye.
    pub normal: Vec3,
    /// Diffuse albedo.
    pub albedo: Vec3,
    /// World-space position.
    pub p: Vec3,
    /// The scene's material index.
    pub material: u32,
    /// The hit itself (which object: [`ObjectIds::object_of`]).
    pub hit: Hit,
}

impl FirstHit {
    /// What the AOVs record of the camera ray's `hit`, shaded as `sp`.
    fn new(sp: &SurfacePoint, hit: &Hit) -> Self {
        FirstHit { t: sp.t, normal: sp.ns, albedo: sp.albedo, p: sp.p, material: sp.material, hit: *hit }
    }
}

/// The running sums of one pixel's samples (added in sample order, so deterministically).
#[derive(Clone, Debug, Default)]
struct PixelAccumulator {
    radiance: Vec3,
    split: [Vec3; 6],
    hits: u32,
    nearest: Option<FirstHit>,
    normal: Vec3,
    albedo: Vec3,
    /// (object, samples) and (material, samples), only when a Cryptomatte pass is on.
    objects: Vec<(u32, u32)>,
    materials: Vec<(u32, u32)>,
}

/// Adds one sample of `key` to a list of (key, count).
fn count(list: &mut Vec<(u32, u32)>, key: u32) {
    match list.iter_mut().find(|(k, _)| *k == key) {
        Some((_, n)) => *n += 1,
        None => list.push((key, 1)),
    }
}

impl PixelAccumulator {
    /// Adds one sample: its beauty, its split, its first hit and, when Cryptomatte is on
    /// (`object` is `Some`), the object of that hit.
    fn add(&mut self, radiance: Vec3, split: &Radiance, first: Option<FirstHit>, object: Option<u32>) {
        self.radiance += radiance;
        for (sum, term) in self.split.iter_mut().zip(split.terms()) {
            *sum += term;
        }
        if let Some(f) = first {
            self.hits += 1;
            // The nearest sample's hit; the first in sample order among equals.
            if self.nearest.is_none_or(|n| f.t < n.t) {
                self.nearest = Some(f);
            }
            self.normal += f.normal;
            self.albedo += f.albedo;
            if let Some(object) = object {
                count(&mut self.objects, object);
                count(&mut self.materials, f.material);
            }
        }
    }

    /// Box filter: the mean over all `spp` samples for RGB and alpha, over the hit samples for
    /// normal and albedo; the nearest hit for depth (see [`crate::film`]).
    fn write(&self, film: &mut Film, x: u32, y: u32, scene: &Scene, ids: &ObjectIds) {
        let spp = scene.image.spp;
        let i = film.index(x, y);
        let rgb = self.radiance / spp as f32;
        let alpha = if scene.output.transparent { self.hits as f32 / spp as f32 } else { 1.0 };
        film.rgba[i] = [rgb.x, rgb.y, rgb.z, alpha];
        if let Some(first) = self.nearest {
            if let Some(depth) = film.depth.get_mut(i) {
                *depth = first.t;
            }
            if let Some(normal) = film.normal.get_mut(i) {
                // One unit normal needs no renormalising (which could move it by an ulp).
                *normal = if self.hits == 1 { self.normal } else { self.normal.normalize_or_zero() };
            }
            if let Some(albedo) = film.albedo.get_mut(i) {
                *albedo = self.albedo / self.hits as f32;
            }
        }
        for aov in &mut film.aovs {
            let out = &mut aov.data[i * aov.floats_per_pixel..(i + 1) * aov.floats_per_pixel];
            match aov.pass {
                pass if pass.is_light() => {
                    let k = LIGHT_PASSES.iter().position(|&p| p == pass).unwrap_or(0);
                    out.copy_from_slice(&(self.split[k] / spp as f32).to_array());
                }
                Pass::Position => {
                    out.copy_from_slice(&self.nearest.map_or(Vec3::ZERO, |f| f.p).to_array());
                }
                Pass::ObjectIndex => {
                    out[0] = self.nearest.map_or(0.0, |f| (ids.object_of(scene, &f.hit) + 1) as f32);
                }
                Pass::MaterialIndex => out[0] = self.nearest.map_or(0.0, |f| (f.material + 1) as f32),
                Pass::CryptoObject => {
                    let mut counts: Vec<(u32, u32)> =
                        self.objects.iter().map(|&(o, n)| (ids.object_id_bits[o as usize], n)).collect();
                    cryptomatte::write_ranks(&mut counts, spp, out);
                }
                Pass::CryptoMaterial => {
                    let mut counts: Vec<(u32, u32)> =
                        self.materials.iter().map(|&(m, n)| (ids.material_id_bits[m as usize], n)).collect();
                    cryptomatte::write_ranks(&mut counts, spp, out);
                }
                _ => {}
            }
        }
    }
}

/// The Whitted integrator over one scene, camera and acceleration structure.
pub struct Whitted<'a, A: Accel> {
    pub scene: &'a Scene,
    pub accel: &'a A,
    pub camera: Camera,
    /// The scene's emissive meshes, lighting it ([`MeshEmitter::of_scene`]).
    pub emitters: Vec<MeshEmitter>,
}

/// One shadow ray a shading point may cast: towards a point or directional light, or sample
/// `j` (of the stratum grid `grid`) of an area light or an emissive mesh.
#[derive(Clone, Copy, Debug)]
enum LightSlot {
    Delta(usize),
    Area { light: usize, j: u32, grid: (u32, u32) },
    Emitter { emitter: usize, j: u32, grid: (u32, u32) },
}

/// What the camera ray of one pixel found, while a tile's direct light is gathered light by
/// light: its hit, its radiance and split so far.
struct PrimaryShading {
    sp: Option<SurfacePoint>,
    radiance: Vec3,
    split: Radiance,
}

impl<'a, A: Accel> Whitted<'a, A> {
    /// The integrator of `scene` seen by `camera`, tracing through `accel`.
    pub fn new(scene: &'a Scene, accel: &'a A, camera: Camera) -> Self {
        Whitted { scene, accel, camera, emitters: MeshEmitter::of_scene(scene) }
    }

    /// Renders one tile: all its pixels' samples, sample by sample, each round as one batch
    /// of primary rays. Returns the pixels (in packet order), their accumulated samples and the
    /// rays traced.
    #[allow(clippy::type_complexity)]
    fn render_tile(
        &self,
        tile: &Region,
        ids: &ObjectIds,
    ) -> Result<(Vec<(u32, u32)>, Vec<PixelAccumulator>, RayCounts), TraceError> {
        // Embree asks for flush-to-zero in every thread that traces; setting it here (two
        // instructions) also makes shading arithmetic identical on every worker, whatever
        // the pool's start handler did.
        crate::embree::enable_flush_to_zero();
        let width = self.scene.image.width as u64;
        let passes = self.scene.output.passes;
        let crypto = passes.contains(Pass::CryptoObject) || passes.contains(Pass::CryptoMaterial);
        let pixels = tile.pixels_in_packet_order();
        let spp = self.scene.image.spp;
        let mut samplers: Vec<PixelSampler> =
            pixels.iter().map(|&(x, y)| PixelSampler::new(spp, y as u64 * width + x as u64)).collect();
        let lights = !(self.scene.area_lights.is_empty() && self.emitters.is_empty());
        let lens = self.camera.has_lens();
        let mut dims: Vec<SampleDims> = pixels
            .iter()
            .map(|&(x, y)| {
                if lights || lens {
                    SampleDims::new(spp, y as u64 * width + x as u64, lights, lens)
                } else {
                    SampleDims::unused()
                }
            })
            .collect();
        let mut accumulators = vec![PixelAccumulator::default(); pixels.len()];
        let mut counts = RayCounts::default();
        let mut rays = Vec::with_capacity(pixels.len());
        let mut hits = vec![None; pixels.len()];
        // Written in place every round (a 160-byte value returned per pixel cost a memcpy call).
        let mut primary: Vec<PrimaryShading> = (0..pixels.len())
            .map(|_| PrimaryShading { sp: None, radiance: Vec3::ZERO, split: Radiance::default() })
            .collect();
        let mut batch = ShadowBatch::default();
        for sample in 0..spp {
            // 1. Ray generation.
            rays.clear();
            rays.extend(pixels.iter().zip(&mut samplers).zip(&mut dims).map(|((&(x, y), s), d)| {
                d.begin(sample);
                let offset = s.next_offset();
                if lens { self.camera.lens_ray(x, y, offset, d.lens()) } else { self.camera.ray(x, y, offset) }
            }));
            counts.primary += rays.len() as u64;
            // 2. Intersection, as packets.
            self.accel.intersect_batch(&rays, &mut hits)?;
            // 3. Shading: emission, then direct light with the shadow rays towards each light
            // (sample) traced as one batch, then reflection and refraction pixel by pixel.
            for ((ray, hit), p) in rays.iter().zip(&hits).zip(&mut primary) {
                self.shade_emission(ray, hit.as_ref(), p);
            }
            self.direct_batch(&rays, &mut primary, &mut dims, &mut counts, &mut batch)?;
            for ((((ray, hit), acc), d), p) in
                rays.iter().zip(&hits).zip(&mut accumulators).zip(&mut dims).zip(&mut primary)
            {
                let first = match (&p.sp, hit) {
                    (Some(sp), Some(hit)) => {
                        p.radiance =
                            self.shade_indirect(ray, sp, 0, Vec3::ONE, d, &mut counts, p.radiance, Some(&mut p.split))?;
                        Some(FirstHit::new(sp, hit))
                    }
                    _ => None,
                };
                let object = first.filter(|_| crypto).map(|f| ids.object_of(self.scene, &f.hit));
                acc.add(p.radiance, &p.split, first, object);
            }
        }
        Ok((pixels, accumulators, counts))
    }

    /// The radiance of rays that hit nothing: the background, or 0 in a transparent render.
    fn background(&self) -> Vec3 {
        if self.scene.output.transparent { Vec3::ZERO } else { self.scene.image.background }
    }

    /// The radiance along a primary ray whose closest hit is `hit`, and what the AOVs record
    /// of that hit. `dims` gives the light samples (of the pixel sample being traced).
    pub fn shade_primary(
        &self,
        ray: &Ray,
        hit: Option<&Hit>,
        dims: &mut SampleDims,
        counts: &mut RayCounts,
    ) -> Result<(Vec3, Option<FirstHit>), TraceError> {
        let (radiance, _, first) = self.shade_primary_split(ray, hit, dims, counts)?;
        Ok((radiance, first))
    }

    /// [`Whitted::shade_primary`] with the radiance also split into its terms.
    pub fn shade_primary_split(
        &self,
        ray: &Ray,
        hit: Option<&Hit>,
        dims: &mut SampleDims,
        counts: &mut RayCounts,
    ) -> Result<(Vec3, Radiance, Option<FirstHit>), TraceError> {
        let Some(hit) = hit else {
            let background = self.background();
            return Ok((background, Radiance { background, ..Default::default() }, None));
        };
        let sp = SurfacePoint::new(self.scene, ray, hit);
        let first = FirstHit::new(&sp, hit);
        let mut split = Radiance::default();
        let radiance = self.shade_split(ray, &sp, 0, Vec3::ONE, dims, counts, Some(&mut split))?;
        Ok((radiance, split, Some(first)))
    }

    /// Steps 2 and 3 for a secondary ray at recursion depth `depth` whose path so far weighs
    /// `throughput`: the radiance arriving along it.
    pub fn trace(
        &self,
        ray: &Ray,
        depth: u32,
        throughput: Vec3,
        dims: &mut SampleDims,
        counts: &mut RayCounts,
    ) -> Result<Vec3, TraceError> {
        match self.accel.intersect(ray)? {
            None => Ok(self.background()),
            Some(hit) => {
                let sp = SurfacePoint::new(self.scene, ray, &hit);
                self.shade(ray, &sp, depth, throughput, dims, counts)
            }
        }
    }

    /// Step 3: the radiance leaving `sp` back along `ray` (see the module docs for the
    /// formula), tracing shadow, reflected and refracted rays as needed.
    pub fn shade(
        &self,
        ray: &Ray,
        sp: &SurfacePoint,
        depth: u32,
        throughput: Vec3,
        dims: &mut SampleDims,
        counts: &mut RayCounts,
    ) -> Result<Vec3, TraceError> {
        self.shade_split(ray, sp, depth, throughput, dims, counts, None)
    }

    /// [`Whitted::shade`], also adding each term to `split` when given. The returned radiance
    /// is summed exactly as without `split`.
    #[allow(clippy::too_many_arguments)] // the ray, the hit, the path's state, and what it adds to
    fn shade_split(
        &self,
        ray: &Ray,
        sp: &SurfacePoint,
        depth: u32,
        throughput: Vec3,
        dims: &mut SampleDims,
        counts: &mut RayCounts,
        mut split: Option<&mut Radiance>,
    ) -> Result<Vec3, TraceError> {
        let m = &self.scene.materials[sp.material as usize];
        let mut l = self.emission(sp, split.as_deref_mut());

        // Direct light: one shadow ray per point or directional light, `light_samples` per
        // area light (each sample's incidence carries 1/light_samples of the estimate).
        if is_lit(sp, m) {
            let origin = offset_ray_origin(sp.p, sp.ng);
            for slot in self.slots() {
                let Some(inc) = self.incidence(&slot, sp.p, dims) else { continue };
                let Some(shadow) = shadow_ray(sp, origin, &inc) else { continue };
                counts.shadow += 1;
                if !self.accel.occluded(&shadow)? {
                    add_direct(sp, m, -ray.dir, &inc, &mut l, split.as_deref_mut());
                }
            }
        }
        self.shade_indirect(ray, sp, depth, throughput, dims, counts, l, split)
    }

    /// Emission (from the front only, for a one-sided emitter) and ambient: a diffuse surface
    /// under uniform radiance `L_a` reflects `ρ·L_a`. Sets `split.emission`.
    fn emission(&self, sp: &SurfacePoint, split: Option<&mut Radiance>) -> Vec3 {
        let m = &self.scene.materials[sp.material as usize];
        let emission = if m.emission_one_sided && !sp.front_face { Vec3::ZERO } else { m.emission };
        let l = emission + sp.albedo * self.scene.image.ambient;
        if let Some(split) = split {
            split.emission = l;
        }
        l
    }

    /// A camera ray's shading before its direct light, into `out` (every field): the
    /// background when it hits nothing, else its surface point and [`Whitted::emission`].
    fn shade_emission(&self, ray: &Ray, hit: Option<&Hit>, out: &mut PrimaryShading) {
        let Some(hit) = hit else {
            let background = self.background();
            out.sp = None;
            out.radiance = background;
            out.split = Radiance { background, ..Default::default() };
            return;
        };
        let sp = SurfacePoint::new(self.scene, ray, hit);
        out.split = Radiance::default();
        out.radiance = self.emission(&sp, Some(&mut out.split));
        out.sp = Some(sp);
    }

    /// The direct light at the camera rays' hits, light (sample) by light: the shadow rays of
    /// all pixels towards one light sample go to [`Accel::occluded_batch`] together (Embree
    /// traces them as 8-wide packets). Each pixel draws its light samples and adds its terms
    /// in the order [`Whitted::shade_split`] does, so the sums are bit-identical to it.
    fn direct_batch(
        &self,
        rays: &[Ray],
        primary: &mut [PrimaryShading],
        dims: &mut [SampleDims],
        counts: &mut RayCounts,
        batch: &mut ShadowBatch,
    ) -> Result<(), TraceError> {
        let materials = &self.scene.materials;
        batch.origins.clear();
        batch.origins.extend(primary.iter().map(|p| match &p.sp {
            Some(sp) if is_lit(sp, &materials[sp.material as usize]) => Some(offset_ray_origin(sp.p, sp.ng)),
            _ => None,
        }));
        for slot in self.slots() {
            batch.rays.clear();
            batch.owners.clear();
            for (i, ((p, d), origin)) in primary.iter().zip(dims.iter_mut()).zip(&batch.origins).enumerate() {
                let (Some(sp), Some(origin)) = (&p.sp, origin) else { continue };
                let Some(inc) = self.incidence(&slot, sp.p, d) else { continue };
                let Some(shadow) = shadow_ray(sp, *origin, &inc) else { continue };
                batch.rays.push(shadow);
                batch.owners.push((i, inc));
            }
            if batch.rays.is_empty() {
                continue;
            }
            counts.shadow += batch.rays.len() as u64;
            batch.occluded.clear();
            batch.occluded.resize(batch.rays.len(), false);
            self.accel.occluded_batch(&batch.rays, &mut batch.occluded)?;
            for (&(i, inc), &occluded) in batch.owners.iter().zip(&batch.occluded) {
                let p = &mut primary[i];
                if let (false, Some(sp)) = (occluded, &p.sp) {
                    let m = &materials[sp.material as usize];
                    add_direct(sp, m, -rays[i].dir, &inc, &mut p.radiance, Some(&mut p.split));
                }
            }
        }
        Ok(())
    }

    /// Every shadow ray a shading point may cast, in the order their light is added: the point
    /// and directional lights, then each area light's samples, then each emissive mesh's.
    fn slots(&self) -> impl Iterator<Item = LightSlot> + '_ {
        let delta = (0..self.scene.lights.len()).map(LightSlot::Delta);
        let area = self.scene.area_lights.iter().enumerate().flat_map(|(light, l)| {
            let grid = strata(l.samples);
            (0..l.samples).map(move |j| LightSlot::Area { light, j, grid })
        });
        let emitters = self.emitters.iter().enumerate().flat_map(|(emitter, e)| {
            let grid = strata(e.samples);
            (0..e.samples).map(move |j| LightSlot::Emitter { emitter, j, grid })
        });
        delta.chain(area).chain(emitters)
    }

    /// How the light of `slot` reaches `p`, drawing its sample point from `dims`.
    #[inline]
    fn incidence(&self, slot: &LightSlot, p: Vec3, dims: &mut SampleDims) -> Option<Incidence> {
        match *slot {
            LightSlot::Delta(i) => self.scene.lights[i].incidence(p),
            LightSlot::Area { light, j, grid } => self.scene.area_lights[light].sample(p, dims.light(j, grid)),
            LightSlot::Emitter { emitter, j, grid } => self.emitters[emitter].sample(p, dims.light(j, grid)),
        }
    }

    /// Reflection and refraction at `sp` (hit by `ray` at recursion depth `depth`), added to
    /// `l`, the radiance of the terms before them: the radiance leaving `sp` along `-ray.dir`.
    #[allow(clippy::too_many_arguments)] // the ray, the hit, the path's state, and what it adds to
    fn shade_indirect(
        &self,
        ray: &Ray,
        sp: &SurfacePoint,
        depth: u32,
        throughput: Vec3,
        dims: &mut SampleDims,
        counts: &mut RayCounts,
        mut l: Vec3,
        mut split: Option<&mut Radiance>,
    ) -> Result<Vec3, TraceError> {
        let scene = self.scene;
        let m = &scene.materials[sp.material as usize];
        let wo = -ray.dir;
        if depth >= scene.image.max_depth {
            return Ok(l);
        }

        // Mirror and dielectric weights.
        let mut reflect_weight = m.mirror;
        let mut refract = None;
        if m.is_dielectric() {
            let (eta_i, eta_t) = if sp.front_face { (1.0, m.ior) } else { (m.ior, 1.0) };
            let r = optics::fresnel_dielectric(wo.dot(sp.ns), eta_i, eta_t);
            reflect_weight += r * m.transmission;
            if r < 1.0 {
                let eta = eta_i / eta_t;
                // Refract about the shading normal unless that sends the ray back out of the
                // surface; then about the geometric one.
                let dir = optics::refract(ray.dir, sp.ns, eta)
                    .filter(|t| t.dot(sp.ng) < 0.0)
                    .or_else(|| optics::refract(ray.dir, sp.ng, eta).filter(|t| t.dot(sp.ng) < 0.0));
                refract = dir.map(|d| (d.normalize(), (1.0 - r) * m.transmission));
            }
        }

        // Reflection.
        if (throughput * reflect_weight).max_element() >= THROUGHPUT_CUTOFF {
            let mut dir = optics::reflect(ray.dir, sp.ns);
            if dir.dot(sp.ng) <= 0.0 {
                dir = optics::reflect(ray.dir, sp.ng); // the shading normal bent it into the surface
            }
            let reflected = Ray::new(offset_ray_origin(sp.p, sp.ng), dir.normalize());
            counts.reflected += 1;
            let reflection =
                reflect_weight * self.trace(&reflected, depth + 1, throughput * reflect_weight, dims, counts)?;
            l += reflection;
            if let Some(split) = split.as_deref_mut() {
                split.reflection = reflection;
            }
        }

        // Refraction.
        if let Some((dir, weight)) = refract.filter(|(_, w)| (throughput * *w).max_element() >= THROUGHPUT_CUTOFF) {
            let refracted = Ray::new(offset_ray_origin(sp.p, -sp.ng), dir);
            counts.refracted += 1;
            let transmission = weight * self.trace(&refracted, depth + 1, throughput * weight, dims, counts)?;
            l += transmission;
            if let Some(split) = split {
                split.transmission = transmission;
            }
        }
        Ok(l)
    }
}

/// Whether light reaching `sp` can be reflected towards the viewer (a diffuse or specular
/// term): only then are shadow rays traced.
#[inline]
fn is_lit(sp: &SurfacePoint, m: &Material) -> bool {
    sp.albedo != Vec3::ZERO || m.specular != Vec3::ZERO
}

/// The shadow ray from `origin` (the hit point moved off the surface) towards the light of
/// `inc`, ending just short of a light at a finite distance; `None` when the light is behind
/// the surface (self-shadowed without a ray).
#[inline]
fn shadow_ray(sp: &SurfacePoint, origin: Vec3, inc: &Incidence) -> Option<Ray> {
    let cos = sp.ns.dot(inc.to_light);
    if cos <= 0.0 || sp.ng.dot(inc.to_light) <= 0.0 {
        return None;
    }
    Some(if inc.distance.is_finite() {
        let to = (sp.p + inc.distance * inc.to_light) - origin;
        let d = to.length();
        Ray::segment(origin, to / d, 0.0, d * SHADOW_TFAR_SCALE)
    } else {
        Ray::new(origin, inc.to_light)
    })
}

/// Adds the light of an unoccluded `inc` reflected at `sp` towards `wo` to `l` (and its
/// diffuse and specular terms to `split`): `(ρ/π + k_s·K(n)·(n·h)^n) · E · cosθ`.
#[inline]
fn add_direct(sp: &SurfacePoint, m: &Material, wo: Vec3, inc: &Incidence, l: &mut Vec3, split: Option<&mut Radiance>) {
    let cos = sp.ns.dot(inc.to_light);
    let lambert = optics::lambert(sp.albedo);
    let mut brdf = lambert;
    let mut highlight = Vec3::ZERO;
    if m.specular != Vec3::ZERO {
        let h = (inc.to_light + wo).normalize_or_zero();
        highlight = m.specular * optics::blinn_phong(sp.ns.dot(h), m.shininess);
        brdf += highlight;
    }
    *l += brdf * inc.normal_irradiance * cos;
    if let Some(split) = split {
        split.diffuse += lambert * inc.normal_irradiance * cos;
        split.specular += highlight * inc.normal_irradiance * cos;
    }
}

/// The reusable buffers of one tile's shadow-ray batches.
#[derive(Default)]
struct ShadowBatch {
    /// Per pixel: the shadow rays' origin, when its hit is lit.
    origins: Vec<Option<Vec3>>,
    rays: Vec<Ray>,
    /// Per ray: the pixel it belongs to and the light's incidence there.
    owners: Vec<(usize, Incidence)>,
    occluded: Vec<bool>,
}
