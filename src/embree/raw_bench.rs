//! The benchmark's yardstick: Embree's own query calls on prepared rays, with nothing of
//! strahl's in the loop, as a C program would trace them.
//!
//! `strahl bench` times these loops beside strahl's wrapper ([`super::EmbreeAccel`]) on exactly
//! the same rays and the same committed scene (same flags, same BVH), so the wrapper's cost is
//! `wrapper time / raw time − 1`. The rays are converted to Embree's structs before the clock
//! starts ([`RawRays::new`]); each loop then copies a ray into the query struct, resets the
//! hit, calls Embree and stores one word per ray (the hit's geometry id, or whether the ray is
//! occluded). One query context serves a whole chunk, and errors are read once per chunk.
//! Planes are not in the Embree scene (strahl tests them in Rust), so these rows measure the
//! BVH alone: compare them with scenes without planes, such as a bare mesh.

use super::scene::{PACKET_WIDTH, QueryContext, Scene, Valid8};
use super::{Error, sys};
use crate::math::Ray;

/// Which Embree call to measure.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RawQuery {
    /// `rtcIntersect1`, one ray at a time.
    Intersect1,
    /// `rtcOccluded1`, one ray at a time.
    Occluded1,
    /// `rtcIntersect8` on consecutive rays (the last packet of a chunk may be partial).
    Intersect8,
    /// `rtcOccluded8` on consecutive rays.
    Occluded8,
}

/// Rays in Embree's layout, ready for the raw loops (`tnear` already moved up one ulp, as
/// the wrapper does for strahl's open interval).
pub struct RawRays(Vec<sys::RTCRay>);

impl RawRays {
    pub fn new(rays: &[Ray]) -> Self {
        RawRays(rays.iter().map(super::scene::rtc_ray).collect())
    }

    pub fn len(&self) -> usize {
        self.0.len()
    }

    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }

    /// The rays in chunks of `size`, for handing to a thread pool.
    pub fn chunks(&self, size: usize) -> impl Iterator<Item = RawChunk<'_>> + '_ {
        self.0.chunks(size).map(RawChunk)
    }
}

/// A run of [`RawRays`].
#[derive(Clone, Copy)]
pub struct RawChunk<'a>(&'a [sys::RTCRay]);

impl RawChunk<'_> {
    pub fn len(&self) -> usize {
        self.0.len()
    }

    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }
}

/// Traces `rays` with `query` on `scene`; `found[i]` becomes 1 if ray `i` hit (or is occluded),
/// else 0. Call from a thread with flush-to-zero on.
pub fn trace(scene: &Scene, query: RawQuery, rays: RawChunk<'_>, found: &mut [u8]) -> Result<(), Error> {
    let rays = rays.0;
    assert_eq!(rays.len(), found.len(), "raw_bench::trace: rays and results differ in length");
    let raw = scene.raw();
    let coherent = matches!(query, RawQuery::Intersect8 | RawQuery::Occluded8);
    let mut ctx = QueryContext::new(coherent);
    let ctx_ptr: *mut QueryContext = &mut ctx;
    #[cfg(embree4)]
    let flags = if coherent { sys::RTC_RAY_QUERY_FLAG_COHERENT } else { sys::RTC_RAY_QUERY_FLAG_INCOHERENT };
    #[cfg(embree4)]
    let mut iargs = sys::init_intersect_arguments(flags, ctx_ptr.cast());
    #[cfg(embree4)]
    let mut oargs = sys::init_occluded_arguments(flags, ctx_ptr.cast());
    match query {
        RawQuery::Intersect1 => {
            let mut rayhit = sys::RTCRayHit::default();
            for (ray, found) in rays.iter().zip(found.iter_mut()) {
                rayhit.ray = *ray;
                rayhit.hit.geomID = sys::RTC_INVALID_GEOMETRY_ID;
                rayhit.hit.instID[0] = sys::RTC_INVALID_GEOMETRY_ID;
                // SAFETY: a committed scene; `rayhit` a valid RTCRayHit; the context, alive for
                // the loop, begins with Embree's own context.
                unsafe {
                    #[cfg(embree3)]
                    sys::rtcIntersect1(raw, ctx_ptr.cast(), &mut rayhit);
                    #[cfg(embree4)]
                    sys::rtcIntersect1(raw, &mut rayhit, &mut iargs);
                }
                *found = (rayhit.hit.geomID != sys::RTC_INVALID_GEOMETRY_ID) as u8;
            }
        }
        RawQuery::Occluded1 => {
            for (r, found) in rays.iter().zip(found.iter_mut()) {
                let mut ray = *r;
                // SAFETY: as above, with an RTCRay.
                unsafe {
                    #[cfg(embree3)]
                    sys::rtcOccluded1(raw, ctx_ptr.cast(), &mut ray);
                    #[cfg(embree4)]
                    sys::rtcOccluded1(raw, &mut ray, &mut oargs);
                }
                *found = (ray.tfar == f32::NEG_INFINITY) as u8;
            }
        }
        RawQuery::Intersect8 | RawQuery::Occluded8 => {
            let mut packet = sys::RTCRayHit8::default();
            let mut valid = Valid8([0; PACKET_WIDTH]);
            for (rays, found) in rays.chunks(PACKET_WIDTH).zip(found.chunks_mut(PACKET_WIDTH)) {
                for lane in 0..PACKET_WIDTH {
                    let active = lane < rays.len();
                    valid.0[lane] = if active { -1 } else { 0 };
                    if !active {
                        continue;
                    }
                    let (r, p) = (&rays[lane], &mut packet.ray);
                    (p.org_x[lane], p.org_y[lane], p.org_z[lane], p.tnear[lane]) = (r.org_x, r.org_y, r.org_z, r.tnear);
                    (p.dir_x[lane], p.dir_y[lane], p.dir_z[lane], p.tfar[lane]) = (r.dir_x, r.dir_y, r.dir_z, r.tfar);
                    p.mask[lane] = u32::MAX;
                    packet.hit.geomID[lane] = sys::RTC_INVALID_GEOMETRY_ID;
                    packet.hit.instID[0][lane] = sys::RTC_INVALID_GEOMETRY_ID;
                }
                // SAFETY: `valid` and `packet` are 32-byte aligned as the 8-wide calls require
                // and initialised (inactive lanes are marked 0); the context as above. The
                // occluded call reads the ray part of the packet, which comes first.
                unsafe {
                    match query {
                        #[cfg(embree3)]
                        RawQuery::Intersect8 => sys::rtcIntersect8(valid.0.as_ptr(), raw, ctx_ptr.cast(), &mut packet),
                        #[cfg(embree4)]
                        RawQuery::Intersect8 => sys::rtcIntersect8(valid.0.as_ptr(), raw, &mut packet, &mut iargs),
                        #[cfg(embree3)]
                        _ => sys::rtcOccluded8(valid.0.as_ptr(), raw, ctx_ptr.cast(), &mut packet.ray),
                        #[cfg(embree4)]
                        _ => sys::rtcOccluded8(valid.0.as_ptr(), raw, &mut packet.ray, &mut oargs),
                    }
                }
                for (lane, found) in found.iter_mut().enumerate() {
                    *found = match query {
                        RawQuery::Intersect8 => packet.hit.geomID[lane] != sys::RTC_INVALID_GEOMETRY_ID,
                        _ => packet.ray.tfar[lane] == f32::NEG_INFINITY,
                    } as u8;
                }
            }
        }
    }
    ctx.finish(match query {
        RawQuery::Intersect1 => "rtcIntersect1",
        RawQuery::Occluded1 => "rtcOccluded1",
        RawQuery::Intersect8 => "rtcIntersect8",
        RawQuery::Occluded8 => "rtcOccluded8",
    })
}
