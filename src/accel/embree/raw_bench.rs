//! The benchmark's yardstick: Embree's own query calls on prepared rays, with nothing of
//! strahl's in the loop, as a C program would trace them.
//!
//! `strahl bench` times these loops beside strahl's wrapper ([`super::EmbreeAccel`]) on exactly
//! the same rays and the same committed scene (same flags, same BVH), so the wrapper's cost is
//! `wrapper time / raw time − 1`. The rays are converted to Embree's structs before the clock
//! starts ([`RawRays::new`]); each loop then copies a ray into the query struct, resets the
//! hit, calls Embree and keeps its answer per ray, as any caller must: a closest hit as the
//! 32 bytes Embree reports ([`RawHit`]: distance, geometric normal, barycentrics, ids, what
//! strahl's wrapper keeps too), an any-hit answer as one byte (strahl keeps a `bool`). One query context serves a whole chunk, and errors are read once per chunk.
//! Planes are not in the Embree scene (strahl tests them in Rust), so these rows measure the
//! BVH alone: compare them with scenes without planes, such as a bare mesh.

use super::scene::{MAX_QUERY_RAYS, PACKET_WIDTH, QueryContext, Scene, Valid8};
use super::{Error, sys};
use crate::math::Ray;

/// A closest hit as Embree reports it (`tfar` and the `RTCHit` fields a caller reads), which
/// the raw loops keep per ray as any caller keeps its answers: 32 bytes. `geom_id` is
/// `RTC_INVALID_GEOMETRY_ID` for a miss.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[repr(C)]
pub struct RawHit {
    pub t: f32,
    pub ng: [f32; 3],
    pub u: f32,
    pub v: f32,
    pub prim_id: u32,
    pub geom_id: u32,
}

impl RawHit {
    pub fn is_hit(&self) -> bool {
        self.geom_id != sys::RTC_INVALID_GEOMETRY_ID
    }
}

/// Rays in Embree's layout, ready for the raw loops (`tnear` already moved up one ulp, as
/// the wrapper does for strahl's open interval).
/// The strahl rays are kept beside them: an alpha filter on an instance reads the world-space
/// ray that an Embree ray's `id` indexes (`super::alpha_filter`).
pub struct RawRays {
    rtc: Vec<sys::RTCRay>,
    rays: Vec<Ray>,
}

impl RawRays {
    pub fn new(rays: &[Ray]) -> Result<Self, Error> {
        if rays.len() > MAX_QUERY_RAYS {
            return Err(Error::InvalidInput {
                object: "benchmark rays".into(),
                problem: format!("{} rays, more than {MAX_QUERY_RAYS}", rays.len()),
            });
        }
        let rtc = rays.iter().enumerate().map(|(i, r)| super::scene::rtc_ray(r, i as u32)).collect();
        Ok(RawRays { rtc, rays: rays.to_vec() })
    }

    pub fn len(&self) -> usize {
        self.rtc.len()
    }

    pub fn is_empty(&self) -> bool {
        self.rtc.is_empty()
    }

    /// The rays in chunks of `size`, for handing to a thread pool.
    pub fn chunks(&self, size: usize) -> impl Iterator<Item = RawChunk<'_>> + '_ {
        let size = size.max(1);
        let chunks = self.rtc.chunks(size).zip(self.rays.chunks(size));
        chunks.enumerate().map(move |(k, (rtc, rays))| RawChunk { rtc, rays, first: (k * size) as u32 })
    }
}

/// A run of [`RawRays`]: the Embree rays, the strahl rays, and the index of the first.
#[derive(Clone, Copy)]
pub struct RawChunk<'a> {
    rtc: &'a [sys::RTCRay],
    rays: &'a [Ray],
    first: u32,
}

impl RawChunk<'_> {
    pub fn len(&self) -> usize {
        self.rtc.len()
    }

    pub fn is_empty(&self) -> bool {
        self.rtc.is_empty()
    }
}

/// Closest-hit queries for `rays` on `scene` (`rtcIntersect1`, or `rtcIntersect8` on
/// consecutive rays with `packets`, the last packet of a chunk partial); `hits[i]` answers
/// `rays[i]`. Call from a thread with flush-to-zero on.
pub fn intersect(scene: &Scene, packets: bool, rays: RawChunk<'_>, hits: &mut [RawHit]) -> Result<(), Error> {
    let RawChunk { rtc: rays, rays: world, first } = rays;
    assert_eq!(rays.len(), hits.len(), "raw_bench::intersect: rays and hits differ in length");
    let raw = scene.raw();
    let mut ctx = QueryContext::with_first(packets, world, first);
    let ctx_ptr: *mut QueryContext = &mut ctx;
    #[cfg(embree4)]
    let flags = if packets { sys::RTC_RAY_QUERY_FLAG_COHERENT } else { sys::RTC_RAY_QUERY_FLAG_INCOHERENT };
    #[cfg(embree4)]
    let mut args = sys::init_intersect_arguments(flags, ctx_ptr.cast());
    if !packets {
        let mut rayhit = sys::RTCRayHit::default();
        for (ray, out) in rays.iter().zip(hits.iter_mut()) {
            rayhit.ray = *ray;
            rayhit.hit.geomID = sys::RTC_INVALID_GEOMETRY_ID;
            rayhit.hit.instID[0] = sys::RTC_INVALID_GEOMETRY_ID;
            // SAFETY: a committed scene; `rayhit` a valid RTCRayHit; the context, alive for
            // the loop, begins with Embree's own context.
            unsafe {
                #[cfg(embree3)]
                sys::rtcIntersect1(raw, ctx_ptr.cast(), &mut rayhit);
                #[cfg(embree4)]
                sys::rtcIntersect1(raw, &mut rayhit, &mut args);
            }
            let h = &rayhit.hit;
            *out = RawHit {
                t: rayhit.ray.tfar,
                ng: [h.Ng_x, h.Ng_y, h.Ng_z],
                u: h.u,
                v: h.v,
                prim_id: h.primID,
                geom_id: h.geomID,
            };
        }
        return ctx.finish("rtcIntersect1");
    }
    let mut packet = sys::RTCRayHit8::default();
    let mut valid = Valid8([0; PACKET_WIDTH]);
    for (rays, hits) in rays.chunks(PACKET_WIDTH).zip(hits.chunks_mut(PACKET_WIDTH)) {
        set_lanes(&mut packet.ray, &mut valid, rays);
        for lane in 0..rays.len() {
            packet.hit.geomID[lane] = sys::RTC_INVALID_GEOMETRY_ID;
            packet.hit.instID[0][lane] = sys::RTC_INVALID_GEOMETRY_ID;
        }
        // SAFETY: `valid` and `packet` are 32-byte aligned as rtcIntersect8 requires and
        // initialised (inactive lanes are marked 0); the context as above.
        unsafe {
            #[cfg(embree3)]
            sys::rtcIntersect8(valid.0.as_ptr(), raw, ctx_ptr.cast(), &mut packet);
            #[cfg(embree4)]
            sys::rtcIntersect8(valid.0.as_ptr(), raw, &mut packet, &mut args);
        }
        let h = &packet.hit;
        for (lane, out) in hits.iter_mut().enumerate() {
            *out = RawHit {
                t: packet.ray.tfar[lane],
                ng: [h.Ng_x[lane], h.Ng_y[lane], h.Ng_z[lane]],
                u: h.u[lane],
                v: h.v[lane],
                prim_id: h.primID[lane],
                geom_id: h.geomID[lane],
            };
        }
    }
    ctx.finish("rtcIntersect8")
}

/// Any-hit queries for `rays` on `scene` (`rtcOccluded1`, or `rtcOccluded8` with `packets`);
/// `occluded[i]` becomes 1 if `rays[i]` is blocked, else 0. Call from a thread with
/// flush-to-zero on.
pub fn occluded(scene: &Scene, packets: bool, rays: RawChunk<'_>, occluded: &mut [u8]) -> Result<(), Error> {
    let RawChunk { rtc: rays, rays: world, first } = rays;
    assert_eq!(rays.len(), occluded.len(), "raw_bench::occluded: rays and answers differ in length");
    let raw = scene.raw();
    let mut ctx = QueryContext::with_first(packets, world, first);
    let ctx_ptr: *mut QueryContext = &mut ctx;
    #[cfg(embree4)]
    let flags = if packets { sys::RTC_RAY_QUERY_FLAG_COHERENT } else { sys::RTC_RAY_QUERY_FLAG_INCOHERENT };
    #[cfg(embree4)]
    let mut args = sys::init_occluded_arguments(flags, ctx_ptr.cast());
    if !packets {
        for (r, out) in rays.iter().zip(occluded.iter_mut()) {
            let mut ray = *r;
            // SAFETY: as in `intersect`, with an RTCRay.
            unsafe {
                #[cfg(embree3)]
                sys::rtcOccluded1(raw, ctx_ptr.cast(), &mut ray);
                #[cfg(embree4)]
                sys::rtcOccluded1(raw, &mut ray, &mut args);
            }
            *out = (ray.tfar == f32::NEG_INFINITY) as u8;
        }
        return ctx.finish("rtcOccluded1");
    }
    let mut packet = sys::RTCRay8::default();
    let mut valid = Valid8([0; PACKET_WIDTH]);
    for (rays, occluded) in rays.chunks(PACKET_WIDTH).zip(occluded.chunks_mut(PACKET_WIDTH)) {
        set_lanes(&mut packet, &mut valid, rays);
        // SAFETY: `valid` and `packet` are 32-byte aligned as rtcOccluded8 requires and
        // initialised (inactive lanes are marked 0); the context as above.
        unsafe {
            #[cfg(embree3)]
            sys::rtcOccluded8(valid.0.as_ptr(), raw, ctx_ptr.cast(), &mut packet);
            #[cfg(embree4)]
            sys::rtcOccluded8(valid.0.as_ptr(), raw, &mut packet, &mut args);
        }
        for (lane, out) in occluded.iter_mut().enumerate() {
            *out = (packet.tfar[lane] == f32::NEG_INFINITY) as u8;
        }
    }
    ctx.finish("rtcOccluded8")
}

/// Copies up to eight rays into the lanes of `packet`, marking the others inactive.
fn set_lanes(packet: &mut sys::RTCRay8, valid: &mut Valid8, rays: &[sys::RTCRay]) {
    for lane in 0..PACKET_WIDTH {
        let Some(r) = rays.get(lane) else {
            valid.0[lane] = 0;
            continue;
        };
        valid.0[lane] = -1;
        (packet.org_x[lane], packet.org_y[lane], packet.org_z[lane], packet.tnear[lane]) =
            (r.org_x, r.org_y, r.org_z, r.tnear);
        (packet.dir_x[lane], packet.dir_y[lane], packet.dir_z[lane], packet.tfar[lane]) =
            (r.dir_x, r.dir_y, r.dir_z, r.tfar);
        packet.mask[lane] = u32::MAX;
        packet.id[lane] = r.id;
    }
}
