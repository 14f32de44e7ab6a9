//! The alpha and back-face test ([`crate::scene::alpha`]) as Embree filter functions: one
//! function set as both the intersection and the occlusion filter of every triangle geometry
//! whose mesh has a material with a coverage (`rtcSetGeometryIntersectFilterFunction`,
//! `rtcSetGeometryOccludedFilterFunction`), its user pointer the scene's [`AlphaTest`]. Other
//! geometries get no filter and pay nothing.
//!
//! Embree calls it with `N` candidate hits in SoA layout (`RTCRayN`, `RTCHitN`); for every
//! active lane (`valid[i] == -1`) it calls [`AlphaTest::passes`] with the hit's scene-level
//! geometry id (the instance's, `instID[0]`, for a hit in a prototype) and the ray as strahl
//! gave it, in world space with its camera flag: the query's ray that the lane's `id` indexes
//! in the [`QueryContext`] (see [`super::scene`]; Embree's own copy of an instance's ray is in
//! the prototype's space). It rejects the hit by setting `valid[i] = 0`: Embree
//! then goes on looking, for the closest hit and for any hit alike. The native BVH calls the
//! same function on the same values, so both backends accept the same hits.
//!
//! The filter is set on the meshes of the top scene the test covers and on every mesh of a
//! prototype that one of its instances' materials covers ([`AlphaTest::covers_prototype`]).
//!
//! A panic cannot unwind into Embree: it is caught, every lane of the call is rejected, and
//! the query returns it as an error (through the [`QueryContext`] every strahl query passes).

use std::panic::{AssertUnwindSafe, catch_unwind};

use super::instance::hit_geom_id;
use super::scene::QueryContext;
use super::sys;
use super::user_sphere::panic_message;
use crate::scene::alpha::AlphaTest;

// Field offsets, in 4-byte words times N: `RTCRayN` (org, tnear, dir, time, tfar, mask, id,
// flags) and `RTCHitN` (Ng, u, v, primID, geomID, instID[0], ...), the headers' force-inline
// `RTCRayN_*` / `RTCHitN_*` accessors.
const ID: usize = 10;
const PRIM_ID: usize = 5;
const GEOM_ID: usize = 6;
const INST_ID: usize = 7;

/// The filter (module docs).
///
/// # Safety
/// Embree calls it with valid arguments: `valid` holds `N` entries, `ray` and `hit` are
/// `N`-wide SoA structures, `geometryUserPtr` is the [`AlphaTest`] the scene owns and
/// `context` a strahl [`QueryContext`].
pub(super) unsafe extern "C" fn filter(args: *const sys::RTCFilterFunctionNArguments) {
    // SAFETY: Embree passes valid arguments for the duration of the call; the user pointer is
    // the `AlphaTest` the committed scene keeps alive (boxed in an `Arc`, never moved) until it
    // is released; every strahl query passes a `QueryContext`, which begins with Embree's.
    let (args, test, ctx) = unsafe {
        let a = &*args;
        (a, &*(a.geometryUserPtr as *const AlphaTest), &*(a.context as *const QueryContext))
    };
    let n = args.N as usize;
    let (valid, ray, hit) = (args.valid, args.ray as *const u32, args.hit as *const u32);
    // SAFETY: `field·n + lane` with `lane < n` lies inside the SoA structure (a field index
    // below its field count), 4-byte aligned, as Embree lays it out.
    let word = |base: *const u32, field: usize, lane: usize| unsafe { *base.add(field * n + lane) };
    let result = catch_unwind(AssertUnwindSafe(|| {
        for lane in 0..n {
            // SAFETY: `valid` holds `n` entries.
            if unsafe { *valid.add(lane) } != -1 {
                continue;
            }
            let r = ctx.ray(word(ray, ID, lane)).expect("every query passes its rays in its context");
            let geom = hit_geom_id(word(hit, GEOM_ID, lane), word(hit, INST_ID, lane));
            if !test.passes(geom, word(hit, PRIM_ID, lane), r) {
                // SAFETY: `valid` holds `n` entries and Embree lets the filter clear them.
                unsafe { *valid.add(lane) = 0 };
            }
        }
    }));
    if let Err(payload) = result {
        for lane in 0..n {
            // SAFETY: as above.
            unsafe { *valid.add(lane) = 0 };
        }
        ctx.record_panic(panic_message(payload.as_ref()));
    }
}
