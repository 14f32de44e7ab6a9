//! Building an Embree scene from triangle meshes and spheres, and querying the committed,
//! immutable result from any number of threads.

use std::cell::Cell;
use std::ptr;
use std::sync::{Arc, Mutex};

use super::device::{Device, take_error};
use super::user_sphere::{self, SphereSet};
use super::{Error, sys};
use crate::accel::Hit;
use crate::geometry::Sphere;
use crate::math::{Ray, Vec3};
use crate::scene::alpha::AlphaTest;
use crate::scene::mesh::triangles_problem;

/// Per-query state handed to Embree as its query context. It begins with Embree's own context
/// (`#[repr(C)]`, first field), so the callbacks can cast the context pointer Embree gives them
/// back to this type and report a caught panic here; the alpha filter also reads the query's
/// rays here, in world space, by the index each Embree ray carries in its `id` ([`rtc_ray`]).
#[repr(C)]
pub(crate) struct QueryContext<'a> {
    #[cfg(embree3)]
    raw: sys::RTCIntersectContext,
    #[cfg(embree4)]
    raw: sys::RTCRayQueryContext,
    panic: Cell<Option<String>>,
    rays: &'a [Ray],
    /// The index of `rays[0]`.
    first: u32,
}

impl<'a> QueryContext<'a> {
    /// The context of a query of `rays` (Embree's ray `i` carrying index `i`).
    #[inline]
    pub(super) fn new(coherent: bool, rays: &'a [Ray]) -> Self {
        Self::with_first(coherent, rays, 0)
    }

    /// The context of a query of `rays`, Embree's ray `i` carrying index `first + i`.
    #[inline]
    pub(super) fn with_first(coherent: bool, rays: &'a [Ray], first: u32) -> Self {
        #[cfg(embree3)]
        let raw = sys::init_intersect_context(if coherent {
            sys::RTC_INTERSECT_CONTEXT_FLAG_COHERENT
        } else {
            sys::RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT
        });
        #[cfg(embree4)]
        let raw = {
            let _ = coherent; // Embree 4 takes the flag in the arguments instead
            sys::init_ray_query_context()
        };
        QueryContext { raw, panic: Cell::new(None), rays, first }
    }

    /// The query's ray with index `index` (the `id` Embree carries for it, [`rtc_ray`]), as
    /// strahl gave it.
    #[inline]
    pub(super) fn ray(&self, index: u32) -> Option<&Ray> {
        self.rays.get(index.checked_sub(self.first)? as usize)
    }

    pub(crate) fn inst_id(&self, level: usize) -> u32 {
        self.raw.instID[level]
    }

    #[cfg(embree_inst_prim_id)]
    pub(crate) fn inst_prim_id(&self, level: usize) -> u32 {
        self.raw.instPrimID[level]
    }

    pub(crate) fn record_panic(&self, message: String) {
        let first = self.panic.take().unwrap_or(message);
        self.panic.set(Some(first));
    }

    /// The query's outcome: a panic caught in a callback, or an error Embree reported.
    #[inline]
    pub(super) fn finish(self, call: &'static str) -> Result<(), Error> {
        match self.panic.take() {
            None => take_error(call),
            Some(message) => Self::panicked(message, call),
        }
    }

    #[cold]
    #[inline(never)]
    fn panicked(message: String, call: &'static str) -> Result<(), Error> {
        let _ = take_error(call); // the panic is the cause; drop any follow-on error
        Err(Error::CallbackPanic(message))
    }
}

/// How Embree should build the BVH.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BuildOptions {
    /// `RTC_BUILD_QUALITY_HIGH` (spatial splits: slower build, faster tracing) instead of
    /// the default medium quality.
    pub high_quality: bool,
    /// `RTC_SCENE_FLAG_ROBUST`: avoid optimisations that reduce arithmetic accuracy. On by
    /// default: without it Embree 3.13.5 lets rays slip through the shared edges of closed
    /// meshes (5.5 % of rays aimed through edge midpoints, about 1 ppm of random rays; light
    /// leaks as speckles), with it none (tests/embree.rs). It costs 10–18 % of Embree's
    /// single-ray speed (full dragon, 1 thread: 9.6 vs 11.2 Mrays/s primary, 4.0 vs 4.4
    /// random).
    pub robust: bool,
}

impl Default for BuildOptions {
    fn default() -> Self {
        BuildOptions { high_quality: false, robust: true }
    }
}

/// Collects geometry for one Embree scene; [`SceneBuilder::commit`] builds the BVH.
///
/// Every input is validated before it reaches Embree: out-of-range indices would make Embree
/// read out of bounds, and non-finite data would corrupt its BVH.
pub struct SceneBuilder {
    pub(super) device: Device,
    pub(super) raw: sys::RTCScene,
    // Boxed: Embree keeps a raw pointer to each set, which must not move when the Vec grows.
    #[allow(clippy::vec_box, reason = "Embree holds pointers to the boxed sets")]
    sphere_sets: Vec<Box<SphereSet>>,
    pub(super) next_id: u32,
    panic_in_callbacks: bool,
    /// The alpha test whose filter the triangle meshes it covers get (`alpha_filter`).
    alpha: Option<Arc<AlphaTest>>,
    /// Whether every triangle mesh gets the filter (a prototype's scene, whose hits the test
    /// decides per instance), not only those the test covers by geometry id.
    alpha_every_mesh: bool,
}

impl SceneBuilder {
    pub fn new(device: &Device, options: BuildOptions) -> Result<Self, Error> {
        // SAFETY: the device is live (the builder keeps a clone of it).
        let raw = unsafe { sys::rtcNewScene(device.raw()) };
        let builder = SceneBuilder {
            device: device.clone(),
            raw,
            sphere_sets: Vec::new(),
            next_id: 0,
            panic_in_callbacks: false,
            alpha: None,
            alpha_every_mesh: false,
        };
        take_error("rtcNewScene")?;
        if raw.is_null() {
            return Err(Error::Api { call: "rtcNewScene", code: sys::RTC_ERROR_UNKNOWN, message: "no scene".into() });
        }
        let flags = if options.robust { sys::RTC_SCENE_FLAG_ROBUST } else { sys::RTC_SCENE_FLAG_NONE };
        let quality = if options.high_quality { sys::RTC_BUILD_QUALITY_HIGH } else { sys::RTC_BUILD_QUALITY_MEDIUM };
        // SAFETY: `raw` is a live, uncommitted scene; flags and quality are valid enum values.
        unsafe {
            sys::rtcSetSceneFlags(raw, flags);
            sys::rtcSetSceneBuildQuality(raw, quality);
        }
        take_error("rtcSetSceneFlags")?;
        Ok(builder)
    }

    /// Gives the triangle meshes added after this call whose ids `test` covers its filter
    /// functions ([`super::alpha_filter`]); the scene keeps `test` alive.
    pub fn set_alpha_test(&mut self, test: Arc<AlphaTest>) {
        self.alpha = Some(test);
    }

    /// Gives every triangle mesh added after this call `test`'s filter functions: the scene is
    /// a prototype some of whose instances the test covers (it decides each instance's hits by
    /// the instance's id, [`super::instance::hit_geom_id`]).
    pub fn set_prototype_alpha_test(&mut self, test: Arc<AlphaTest>) {
        self.alpha = Some(test);
        self.alpha_every_mesh = true;
    }

    /// The id the next geometry added will get.
    pub fn next_geom_id(&self) -> u32 {
        self.next_id
    }

    /// Adds a triangle mesh (`RTC_GEOMETRY_TYPE_TRIANGLE`, f32 vertices, u32 indices) and
    /// returns its geometry id. `name` identifies it in errors. A mesh without triangles takes
    /// an id but adds nothing.
    pub fn add_triangle_mesh(&mut self, name: &str, positions: &[Vec3], indices: &[[u32; 3]]) -> Result<u32, Error> {
        if let Some(problem) = triangles_problem(positions, indices) {
            return Err(Error::InvalidInput { object: format!("mesh '{name}'"), problem });
        }
        let id = self.next_id;
        self.next_id += 1;
        if indices.is_empty() {
            return Ok(id);
        }
        // SAFETY: the device is live; the type is a valid geometry type.
        let geom = unsafe { sys::rtcNewGeometry(self.device.raw(), sys::RTC_GEOMETRY_TYPE_TRIANGLE) };
        take_error("rtcNewGeometry")?;
        let geometry = Geometry(geom);
        const _: () = assert!(std::mem::size_of::<Vec3>() == 12 && std::mem::size_of::<[u32; 3]>() == 12);
        // SAFETY: `rtcSetNewGeometryBuffer` allocates a buffer of `len` items of 12 bytes
        // (padded as Embree needs) that the geometry owns; we copy exactly `len` items into it.
        // `Vec3` is `#[repr(C)]` of three f32, the layout of RTC_FORMAT_FLOAT3.
        unsafe {
            let vb = sys::rtcSetNewGeometryBuffer(
                geometry.0,
                sys::RTC_BUFFER_TYPE_VERTEX,
                0,
                sys::RTC_FORMAT_FLOAT3,
                12,
                positions.len(),
            );
            take_error("rtcSetNewGeometryBuffer")?;
            if vb.is_null() {
                return Err(out_of_memory("vertex buffer"));
            }
            ptr::copy_nonoverlapping(positions.as_ptr() as *const u8, vb as *mut u8, 12 * positions.len());
            let ib = sys::rtcSetNewGeometryBuffer(
                geometry.0,
                sys::RTC_BUFFER_TYPE_INDEX,
                0,
                sys::RTC_FORMAT_UINT3,
                12,
                indices.len(),
            );
            take_error("rtcSetNewGeometryBuffer")?;
            if ib.is_null() {
                return Err(out_of_memory("index buffer"));
            }
            ptr::copy_nonoverlapping(indices.as_ptr() as *const u8, ib as *mut u8, 12 * indices.len());
        }
        if let Some(test) = self.alpha.as_ref().filter(|t| self.alpha_every_mesh || t.covers(id)) {
            // SAFETY: `geometry` is live and not yet committed; the user pointer is the
            // `AlphaTest` in an `Arc` that the builder, then the committed scene, holds for as
            // long as Embree may call the filter; the filter is `extern "C"` and never unwinds.
            unsafe {
                sys::rtcSetGeometryUserData(geometry.0, Arc::as_ptr(test) as *mut _);
                sys::rtcSetGeometryIntersectFilterFunction(geometry.0, Some(super::alpha_filter::filter));
                sys::rtcSetGeometryOccludedFilterFunction(geometry.0, Some(super::alpha_filter::filter));
            }
            take_error("rtcSetGeometryIntersectFilterFunction")?;
        }
        self.attach(geometry, id)?;
        Ok(id)
    }

    /// Adds spheres as one user geometry (primitive `i` is `spheres[i]`) and returns its id.
    pub fn add_spheres(&mut self, name: &str, spheres: &[Sphere]) -> Result<u32, Error> {
        if let Some((i, problem)) = spheres.iter().enumerate().find_map(|(i, s)| s.problem().map(|p| (i, p))) {
            return Err(Error::InvalidInput { object: format!("sphere {i} of '{name}'"), problem });
        }
        let id = self.next_id;
        self.next_id += 1;
        if spheres.is_empty() {
            return Ok(id);
        }
        let set = Box::new(SphereSet {
            spheres: spheres.into(),
            build_panic: Mutex::new(None),
            panic_in_callbacks: self.panic_in_callbacks,
        });
        // SAFETY: the device is live.
        let geom = unsafe { sys::rtcNewGeometry(self.device.raw(), sys::RTC_GEOMETRY_TYPE_USER) };
        take_error("rtcNewGeometry")?;
        let geometry = Geometry(geom);
        // SAFETY: the user pointer is the boxed `SphereSet`, whose heap address stays fixed
        // and which the scene keeps alive for as long as Embree may call back; the callbacks
        // are `extern "C"` and never unwind.
        unsafe {
            sys::rtcSetGeometryUserPrimitiveCount(geometry.0, spheres.len() as u32);
            sys::rtcSetGeometryUserData(geometry.0, &*set as *const SphereSet as *mut _);
            sys::rtcSetGeometryBoundsFunction(geometry.0, Some(user_sphere::bounds), ptr::null_mut());
            sys::rtcSetGeometryIntersectFunction(geometry.0, Some(user_sphere::intersect));
            sys::rtcSetGeometryOccludedFunction(geometry.0, Some(user_sphere::occluded));
        }
        take_error("rtcSetGeometryUserData")?;
        self.sphere_sets.push(set);
        self.attach(geometry, id)?;
        Ok(id)
    }

    /// Test hook: makes every sphere callback of sphere sets added after this call panic, to
    /// show that panics come back as errors instead of unwinding into Embree.
    #[doc(hidden)]
    pub fn panic_in_sphere_callbacks_for_tests(&mut self) {
        self.panic_in_callbacks = true;
    }

    pub(super) fn attach(&mut self, geometry: Geometry, id: u32) -> Result<(), Error> {
        // SAFETY: both handles are live; the scene takes its own reference to the geometry,
        // and `Geometry`'s drop releases ours.
        unsafe {
            sys::rtcCommitGeometry(geometry.0);
            take_error("rtcCommitGeometry")?;
            sys::rtcAttachGeometryByID(self.raw, geometry.0, id);
        }
        take_error("rtcAttachGeometryByID")
    }

    /// Builds the BVH and returns the immutable scene.
    pub fn commit(mut self) -> Result<Scene, Error> {
        // SAFETY: the scene is live and uncommitted; nothing else refers to it yet.
        unsafe { sys::rtcCommitScene(self.raw) };
        take_error("rtcCommitScene")?;
        for set in &self.sphere_sets {
            if let Some(message) = set.build_panic.lock().ok().and_then(|mut p| p.take()) {
                return Err(Error::CallbackPanic(message));
            }
        }
        let raw = std::mem::replace(&mut self.raw, ptr::null_mut());
        Ok(Scene {
            raw,
            sphere_sets: std::mem::take(&mut self.sphere_sets),
            _alpha: self.alpha.take(),
            _device: self.device.clone(),
        })
    }
}

impl Drop for SceneBuilder {
    fn drop(&mut self) {
        if !self.raw.is_null() {
            // SAFETY: an uncommitted scene this builder created and still owns.
            unsafe { sys::rtcReleaseScene(self.raw) };
        }
    }
}

/// A geometry handle released on drop (the scene it is attached to keeps its own reference).
pub(super) struct Geometry(pub(super) sys::RTCGeometry);

impl Drop for Geometry {
    fn drop(&mut self) {
        // SAFETY: a live geometry from `rtcNewGeometry`; this is our one release.
        unsafe { sys::rtcReleaseGeometry(self.0) };
    }
}

impl Device {
    /// Test hook: sets a user-primitive count on a triangle geometry, a call Embree rejects
    /// (`RTC_ERROR_INVALID_OPERATION`), to show that its errors come back as `Err` with
    /// Embree's code.
    #[doc(hidden)]
    pub fn invalid_call_for_tests(&self) -> Result<(), Error> {
        // SAFETY: the device is live; Embree checks the geometry type, reports the error and
        // changes nothing.
        let geometry = Geometry(unsafe { sys::rtcNewGeometry(self.raw(), sys::RTC_GEOMETRY_TYPE_TRIANGLE) });
        take_error("rtcNewGeometry")?;
        // SAFETY: as above.
        unsafe { sys::rtcSetGeometryUserPrimitiveCount(geometry.0, 1) };
        take_error("rtcSetGeometryUserPrimitiveCount")
    }
}

/// A committed, immutable Embree scene, safe to query from many threads at once.
pub struct Scene {
    pub(super) raw: sys::RTCScene,
    // Read by the sphere callbacks through Embree's user pointers: dropped after `raw` is
    // released (see `Drop`), never moved (boxed), never mutated.
    #[expect(dead_code, reason = "read by Embree's callbacks through raw user pointers")]
    #[allow(clippy::vec_box, reason = "Embree holds pointers to the boxed sets")]
    sphere_sets: Vec<Box<SphereSet>>,
    /// Read by the alpha filters through Embree's user pointers; dropped after `raw`.
    _alpha: Option<Arc<AlphaTest>>,
    _device: Device,
}

// SAFETY: a committed scene is never modified again; Embree documents concurrent
// `rtcIntersect*`/`rtcOccluded*` calls on it as thread-safe, and the sphere data the callbacks
// read is immutable (its one Mutex is only used during the build).
unsafe impl Send for Scene {}
// SAFETY: as above: `&Scene` only allows queries.
unsafe impl Sync for Scene {}

impl Drop for Scene {
    fn drop(&mut self) {
        // SAFETY: the committed scene this value owns; its geometries go with it. The sphere
        // sets are dropped after this, when no callback can run any more.
        unsafe { sys::rtcReleaseScene(self.raw) };
    }
}

/// Embree's ray for a strahl ray. Embree accepts hits with `t ≥ tnear`; strahl's interval is
/// open (`t > tnear`, the lecture's `t > 0`), so tnear moves up by one ulp.
///
/// The ray's `id` is its index in the query's rays ([`QueryContext::ray`]), where the alpha
/// filter finds the ray as strahl gave it (origin, direction, camera flag).
///
/// The ray is assembled as three 16-byte words (origin and tnear, direction and time, tfar and
/// the three integers), so that it is stored with vector stores: Embree reads it back with
/// 16-byte loads, and a load that spans several narrower stores cannot be forwarded from the
/// store buffer (a stall on every query; field-by-field stores cost the wrapper about a third
/// of raw Embree's primary-ray speed, see `strahl bench`).
#[inline]
pub(super) fn rtc_ray(r: &Ray, index: u32) -> sys::RTCRay {
    rtc_ray_until(r, r.tfar, index)
}

/// [`rtc_ray`] with `tfar` in place of `r.tfar`.
#[inline(always)]
fn rtc_ray_until(r: &Ray, tfar: f32, index: u32) -> sys::RTCRay {
    let words = RayWords(
        glam::Vec4::new(r.org.x, r.org.y, r.org.z, open_tnear(r.tnear)),
        glam::Vec4::new(r.dir.x, r.dir.y, r.dir.z, 0.0),
        // tfar, then mask (every bit: a NaN pattern, moved, never computed with), id (the
        // index the alpha filter reads, moved too), flags 0
        glam::Vec4::new(tfar, f32::from_bits(u32::MAX), f32::from_bits(index), 0.0),
    );
    // SAFETY: `RayWords` and `RTCRay` are both 48 bytes of 4-byte plain-old-data fields in the
    // same order (org_x, org_y, org_z, tnear; dir_x, dir_y, dir_z, time; tfar, mask, id, flags;
    // sizes checked at compile time below), and every bit pattern is valid for both.
    unsafe { std::mem::transmute::<RayWords, sys::RTCRay>(words) }
}

#[repr(C, align(16))]
struct RayWords(glam::Vec4, glam::Vec4, glam::Vec4);

const _: () = assert!(std::mem::size_of::<RayWords>() == std::mem::size_of::<sys::RTCRay>());

#[inline]
pub(super) fn open_tnear(t: f32) -> f32 {
    // The smallest *normal* float above 0: under flush-to-zero a subnormal would read as 0.
    if t == 0.0 { f32::MIN_POSITIVE } else { t.next_up() }
}

/// Lane `lane` of an 8-wide packet: `r`'s origin and direction, its open interval
/// (`tnear` as [`open_tnear`] makes it), every mask bit set.
#[inline]
fn set_lane(p: &mut sys::RTCRay8, lane: usize, r: &Ray, index: u32) {
    (p.org_x[lane], p.org_y[lane], p.org_z[lane]) = (r.org.x, r.org.y, r.org.z);
    (p.dir_x[lane], p.dir_y[lane], p.dir_z[lane]) = (r.dir.x, r.dir.y, r.dir.z);
    (p.tnear[lane], p.tfar[lane]) = (open_tnear(r.tnear), r.tfar);
    p.mask[lane] = u32::MAX;
    p.id[lane] = index;
}

#[inline]
fn empty_hit() -> sys::RTCHit {
    sys::RTCHit {
        geomID: sys::RTC_INVALID_GEOMETRY_ID,
        primID: sys::RTC_INVALID_GEOMETRY_ID,
        instID: [sys::RTC_INVALID_GEOMETRY_ID; sys::RTC_MAX_INSTANCE_LEVEL_COUNT as usize],
        ..Default::default()
    }
}

/// Most rays in one query: their indices must fit in `id` ([`rtc_ray`]).
pub(super) const MAX_QUERY_RAYS: usize = u32::MAX as usize;

/// Rays per packet query.
pub const PACKET_WIDTH: usize = 8;

#[repr(C, align(32))]
pub(super) struct Valid8(pub(super) [i32; PACKET_WIDTH]);

impl Scene {
    /// Embree's handle, for the raw benchmark loops.
    pub(super) fn raw(&self) -> sys::RTCScene {
        self.raw
    }

    /// The closest hit of `ray` in `(tnear, tfar)` (`rtcIntersect1`).
    #[inline(always)]
    pub fn intersect(&self, ray: &Ray) -> Result<Option<Hit>, Error> {
        self.intersect_until(ray, ray.tfar)
    }

    /// The closest hit of `ray` in `(tnear, tfar)`, `tfar` given apart from the ray:
    /// [`super::EmbreeAccel`] ends rays at the nearest plane, which is not in the Embree
    /// scene, without copying them (a copied ray, reloaded at once in other widths, stalls on
    /// the store buffer: it cost the wrapper about 30 % on the benchmark's primary rays).
    #[inline(always)]
    pub fn intersect_until(&self, ray: &Ray, tfar: f32) -> Result<Option<Hit>, Error> {
        let mut rayhit = sys::RTCRayHit { ray: rtc_ray_until(ray, tfar, 0), hit: empty_hit() };
        let mut ctx = QueryContext::new(false, std::slice::from_ref(ray));
        let ctx_ptr: *mut QueryContext = &mut ctx;
        // SAFETY: the scene is committed; `rayhit` is a valid, initialised RTCRayHit (its
        // size checked against the headers by bindgen's layout asserts); `ctx_ptr` covers the
        // whole QueryContext, whose first field is Embree's context, alive for the call.
        unsafe {
            #[cfg(embree3)]
            sys::rtcIntersect1(self.raw, ctx_ptr.cast(), &mut rayhit);
            #[cfg(embree4)]
            {
                let mut args = sys::init_intersect_arguments(sys::RTC_RAY_QUERY_FLAG_INCOHERENT, ctx_ptr.cast());
                sys::rtcIntersect1(self.raw, &mut rayhit, &mut args);
            }
        }
        ctx.finish("rtcIntersect1")?;
        Ok(to_hit(&rayhit))
    }

    /// Whether anything lies on `ray` within `(tnear, tfar)` (`rtcOccluded1`).
    pub fn occluded(&self, ray: &Ray) -> Result<bool, Error> {
        let mut rtc = rtc_ray(ray, 0);
        let mut ctx = QueryContext::new(false, std::slice::from_ref(ray));
        let ctx_ptr: *mut QueryContext = &mut ctx;
        // SAFETY: as in `intersect`, with an RTCRay.
        unsafe {
            #[cfg(embree3)]
            sys::rtcOccluded1(self.raw, ctx_ptr.cast(), &mut rtc);
            #[cfg(embree4)]
            {
                let mut args = sys::init_occluded_arguments(sys::RTC_RAY_QUERY_FLAG_INCOHERENT, ctx_ptr.cast());
                sys::rtcOccluded1(self.raw, &mut rtc, &mut args);
            }
        }
        ctx.finish("rtcOccluded1")?;
        Ok(rtc.tfar == f32::NEG_INFINITY)
    }

    /// Closest hits of coherent rays, [`PACKET_WIDTH`] at a time through `rtcIntersect8`
    /// (consecutive rays share a packet; the last may be partial), with one query context and
    /// one error check for the whole call. `hits[i]` answers `rays[i]` as `finish(i, hit)`
    /// makes it: the caller's last word on a hit, given before it is stored (a hit stored
    /// and at once reloaded whole to be changed stalls on the store buffer, once per lane).
    #[inline]
    pub fn intersect_packets(
        &self,
        rays: &[Ray],
        hits: &mut [Option<Hit>],
        mut finish: impl FnMut(usize, Option<Hit>) -> Option<Hit>,
    ) -> Result<(), Error> {
        if hits.len() != rays.len() {
            return Err(Error::InvalidInput {
                object: "ray packets".into(),
                problem: format!("{} rays and {} hits", rays.len(), hits.len()),
            });
        }
        if rays.len() > MAX_QUERY_RAYS {
            return Err(Error::InvalidInput {
                object: "ray packets".into(),
                problem: format!("{} rays in one query, more than {MAX_QUERY_RAYS}", rays.len()),
            });
        }
        let mut ctx = QueryContext::new(true, rays);
        let ctx_ptr: *mut QueryContext = &mut ctx;
        #[cfg(embree4)]
        let mut args = sys::init_intersect_arguments(sys::RTC_RAY_QUERY_FLAG_COHERENT, ctx_ptr.cast());
        let mut valid = Valid8([0; PACKET_WIDTH]);
        let mut packet = sys::RTCRayHit8::default();
        for (k, (rays, hits)) in rays.chunks(PACKET_WIDTH).zip(hits.chunks_mut(PACKET_WIDTH)).enumerate() {
            // Every lane's ray and `valid` entry written in a loop of fixed length, as the raw
            // loop does (`raw_bench::set_lanes`); the loop over the chunk's rays alone, which
            // cleared `valid` only for a last partial packet, measured 3–4 % slower on primary
            // rays (`strahl bench`, strahl x8 / raw x8 1.022–1.075 → 0.971–1.030, 6
            // alternations; not on the hits' side: the old loop without the primID reset
            // measured as before). Misses' primID is never read.
            for lane in 0..PACKET_WIDTH {
                let Some(r) = rays.get(lane) else {
                    valid.0[lane] = 0;
                    continue;
                };
                valid.0[lane] = -1;
                set_lane(&mut packet.ray, lane, r, (k * PACKET_WIDTH + lane) as u32);
            }
            for lane in 0..rays.len() {
                let h = &mut packet.hit;
                h.geomID[lane] = sys::RTC_INVALID_GEOMETRY_ID;
                for level in 0..sys::RTC_MAX_INSTANCE_LEVEL_COUNT as usize {
                    h.instID[level][lane] = sys::RTC_INVALID_GEOMETRY_ID;
                }
            }
            // SAFETY: `valid` and `packet` are 32-byte aligned as rtcIntersect8 requires and
            // initialised (zeroed once, active lanes set above, inactive lanes marked 0 in
            // `valid`); the context is as in `intersect` and outlives the loop.
            unsafe {
                #[cfg(embree3)]
                sys::rtcIntersect8(valid.0.as_ptr(), self.raw, ctx_ptr.cast(), &mut packet);
                #[cfg(embree4)]
                sys::rtcIntersect8(valid.0.as_ptr(), self.raw, &mut packet, &mut args);
            }
            for (lane, hit) in hits.iter_mut().enumerate() {
                let h = &packet.hit;
                let found = (h.geomID[lane] != sys::RTC_INVALID_GEOMETRY_ID).then(|| Hit {
                    t: packet.ray.tfar[lane],
                    ng: Vec3::new(h.Ng_x[lane], h.Ng_y[lane], h.Ng_z[lane]),
                    u: h.u[lane],
                    v: h.v[lane],
                    geom_id: super::instance::hit_geom_id(h.geomID[lane], h.instID[0][lane]),
                    prim_id: h.primID[lane],
                });
                *hit = finish(k * PACKET_WIDTH + lane, found);
            }
        }
        ctx.finish("rtcIntersect8")
    }
}

impl Scene {
    /// Any-hit queries for up to [`PACKET_WIDTH`] rays in one `rtcOccluded8`, lanes whose
    /// `skip` is set left out; `occluded[i]` answers `rays[i]` (`true` for skipped lanes).
    pub fn occluded8(&self, rays: &[Ray], skip: &[bool], occluded: &mut [bool]) -> Result<(), Error> {
        let n = rays.len();
        if n > PACKET_WIDTH || occluded.len() != n || skip.len() != n {
            return Err(Error::InvalidInput {
                object: "ray packet".into(),
                problem: format!("{n} rays and {} answers for a packet of {PACKET_WIDTH}", occluded.len()),
            });
        }
        let mut valid = Valid8([0; PACKET_WIDTH]);
        let mut packet = sys::RTCRay8::default();
        for (lane, (r, &skip)) in rays.iter().zip(skip).enumerate() {
            if skip {
                continue;
            }
            valid.0[lane] = -1;
            set_lane(&mut packet, lane, r, lane as u32);
        }
        if valid.0 == [0; PACKET_WIDTH] {
            occluded.fill(true);
            return Ok(());
        }
        let mut ctx = QueryContext::new(true, rays);
        let ctx_ptr: *mut QueryContext = &mut ctx;
        // SAFETY: `valid` and `packet` are 32-byte aligned as rtcOccluded8 requires, fully
        // initialised; inactive lanes are marked 0 in `valid`; the context is as in `intersect`.
        unsafe {
            #[cfg(embree3)]
            sys::rtcOccluded8(valid.0.as_ptr(), self.raw, ctx_ptr.cast(), &mut packet);
            #[cfg(embree4)]
            {
                let mut args = sys::init_occluded_arguments(sys::RTC_RAY_QUERY_FLAG_COHERENT, ctx_ptr.cast());
                sys::rtcOccluded8(valid.0.as_ptr(), self.raw, &mut packet, &mut args);
            }
        }
        ctx.finish("rtcOccluded8")?;
        for (lane, (o, &skip)) in occluded.iter_mut().zip(skip).enumerate() {
            *o = skip || packet.tfar[lane] == f32::NEG_INFINITY;
        }
        Ok(())
    }
}

fn out_of_memory(what: &str) -> Error {
    Error::Api { call: "rtcSetNewGeometryBuffer", code: sys::RTC_ERROR_OUT_OF_MEMORY, message: format!("no {what}") }
}

#[inline]
fn to_hit(rh: &sys::RTCRayHit) -> Option<Hit> {
    (rh.hit.geomID != sys::RTC_INVALID_GEOMETRY_ID).then(|| Hit {
        t: rh.ray.tfar,
        ng: Vec3::new(rh.hit.Ng_x, rh.hit.Ng_y, rh.hit.Ng_z),
        u: rh.hit.u,
        v: rh.hit.v,
        geom_id: super::instance::hit_geom_id(rh.hit.geomID, rh.hit.instID[0]),
        prim_id: rh.hit.primID,
    })
}
