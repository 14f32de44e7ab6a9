//! Spheres as one Embree user geometry: bounds, intersect and occluded callbacks that solve the
//! lecture's quadratic ([`crate::geometry::sphere::intersect`]) for packets of any width.
//!
//! Embree calls the ray callbacks with `N` rays in SoA layout (`RTCRayHitN`): measured N = 1
//! from `rtcIntersect1`, 8 from `rtcIntersect8`, 16 from `rtcIntersect1M`. Only lanes with
//! `valid[i] == -1` are active. No callback lets a panic unwind into Embree: it is caught,
//! the ray is left as it was, and the query returns the panic as an error.

use std::any::Any;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::sync::Mutex;

use super::scene::QueryContext;
use super::sys;
use crate::geometry::sphere::{self, Sphere};
use crate::math::Vec3;

/// What the callbacks read: the spheres, owned by the committed scene at a stable address.
pub(crate) struct SphereSet {
    pub spheres: Box<[Sphere]>,
    /// A panic caught in the bounds callback (which runs on Embree's build threads).
    pub build_panic: Mutex<Option<String>>,
    /// Test hook: every ray callback panics, to prove panics are contained.
    pub panic_in_callbacks: bool,
}

pub(crate) fn panic_message(payload: &(dyn Any + Send)) -> String {
    if let Some(s) = payload.downcast_ref::<&str>() {
        (*s).to_string()
    } else if let Some(s) = payload.downcast_ref::<String>() {
        s.clone()
    } else {
        "a panic with a non-string payload".to_string()
    }
}

// Field offsets, in 4-byte words times N, of `RTCRayN` / `RTCHitN` inside `RTCRayHitN`
// (the headers' `RTCRayN_*` and `RTCHitN_*` accessors, which are force-inline C++).
const ORG_X: usize = 0;
const TNEAR: usize = 3;
const DIR_X: usize = 4;
const TFAR: usize = 8;
const HIT: usize = 12; // RTCHitN follows the 12 ray fields
const NG_X: usize = 0;
const U: usize = 3;
const V: usize = 4;
const PRIM_ID: usize = 5;
const GEOM_ID: usize = 6;
const INST_ID: usize = 7;
#[cfg(embree_inst_prim_id)]
const INST_PRIM_ID: usize = INST_ID + sys::RTC_MAX_INSTANCE_LEVEL_COUNT as usize;

/// An `RTCRayN` or `RTCRayHitN` of width `n`: `4·n` bytes per field.
struct SoA {
    words: *mut u32,
    n: usize,
}

impl SoA {
    /// # Safety
    /// `field·n + lane` must lie inside the structure Embree passed.
    #[inline]
    unsafe fn f32(&self, field: usize, lane: usize) -> f32 {
        // SAFETY: in bounds per the caller; Embree's SoA arrays are 4-byte aligned.
        f32::from_bits(unsafe { *self.words.add(field * self.n + lane) })
    }
    #[inline]
    unsafe fn set_f32(&self, field: usize, lane: usize, x: f32) {
        // SAFETY: as for `f32`; Embree lets the callback write the ray and hit.
        unsafe { *self.words.add(field * self.n + lane) = x.to_bits() };
    }
    #[inline]
    unsafe fn set_u32(&self, field: usize, lane: usize, x: u32) {
        // SAFETY: as for `set_f32`.
        unsafe { *self.words.add(field * self.n + lane) = x };
    }
    #[inline]
    unsafe fn vec3(&self, field: usize, lane: usize) -> Vec3 {
        // SAFETY: the three fields from `field` are in bounds per the caller.
        unsafe { Vec3::new(self.f32(field, lane), self.f32(field + 1, lane), self.f32(field + 2, lane)) }
    }
}

pub(crate) unsafe extern "C" fn bounds(args: *const sys::RTCBoundsFunctionArguments) {
    // SAFETY: Embree passes valid arguments for the duration of the call; the user pointer is
    // the `SphereSet` the scene owns, alive until the scene is released.
    let (args, set) = unsafe { (&*args, &*((*args).geometryUserPtr as *const SphereSet)) };
    let result = catch_unwind(AssertUnwindSafe(|| {
        let s = set.spheres[args.primID as usize];
        // Pad by a few ulps so that rounding in the box test can never cull a ray the
        // quadratic would hit.
        let pad = 4.0 * f32::EPSILON * (s.center.abs().max_element() + s.radius);
        let b = s.bounds();
        (b.min - Vec3::splat(pad), b.max + Vec3::splat(pad))
    }));
    // SAFETY: `bounds_o` points to the RTCBounds Embree wants filled.
    let out = unsafe { &mut *args.bounds_o };
    match result {
        Ok((lo, hi)) => {
            (out.lower_x, out.lower_y, out.lower_z) = (lo.x, lo.y, lo.z);
            (out.upper_x, out.upper_y, out.upper_z) = (hi.x, hi.y, hi.z);
        }
        Err(payload) => {
            // An empty box keeps the build sane; the commit then reports the panic.
            (out.lower_x, out.lower_y, out.lower_z) = (0.0, 0.0, 0.0);
            (out.upper_x, out.upper_y, out.upper_z) = (0.0, 0.0, 0.0);
            if let Ok(mut slot) = set.build_panic.lock() {
                slot.get_or_insert_with(|| panic_message(payload.as_ref()));
            }
        }
    }
}

/// Runs `hit(lane, org, dir, tnear, tfar)` for every active lane of a packet, inside a panic
/// guard: a panic is recorded in the query context instead of unwinding into Embree.
///
/// # Safety
/// `valid` must hold `rays.n` entries and `rays` must be the `RTCRayN` (or `RTCRayHitN`) that
/// Embree passed with it.
unsafe fn for_each_active_lane(
    valid: *const i32,
    rays: &SoA,
    ctx: &QueryContext,
    set: &SphereSet,
    callback: &str,
    mut hit: impl FnMut(usize, Vec3, Vec3, f32, f32),
) {
    let result = catch_unwind(AssertUnwindSafe(|| {
        if set.panic_in_callbacks {
            panic!("test hook: sphere {callback} callback");
        }
        for lane in 0..rays.n {
            // SAFETY: `valid` has N entries and the ray fields lie inside the SoA structure,
            // as the caller guarantees.
            if unsafe { *valid.add(lane) } != -1 {
                continue;
            }
            let (org, dir, tnear, tfar) = unsafe {
                (rays.vec3(ORG_X, lane), rays.vec3(DIR_X, lane), rays.f32(TNEAR, lane), rays.f32(TFAR, lane))
            };
            hit(lane, org, dir, tnear, tfar);
        }
    }));
    if let Err(payload) = result {
        ctx.record_panic(panic_message(payload.as_ref()));
    }
}

pub(crate) unsafe extern "C" fn intersect(args: *const sys::RTCIntersectFunctionNArguments) {
    // SAFETY: as in `bounds`; `context` is the `QueryContext` every strahl query passes (it
    // begins with Embree's context, and Embree hands the same pointer to callbacks).
    let (args, set, ctx) = unsafe {
        let a = &*args;
        (a, &*(a.geometryUserPtr as *const SphereSet), &*(a.context as *const QueryContext))
    };
    let rays = SoA { words: args.rayhit as *mut u32, n: args.N as usize };
    let (prim_id, geom_id) = (args.primID, args.geomID);
    let record_hit = |lane: usize, org: Vec3, dir: Vec3, tnear: f32, tfar: f32| {
        let s = set.spheres[prim_id as usize];
        let Some(t) = sphere::intersect(org, dir, s.center, s.radius, tnear, tfar) else {
            return;
        };
        let ng = (org - s.center) + t * dir;
        let (u, v) = sphere::uv(ng / s.radius);
        // SAFETY: writing this active lane's hit, inside RTCRayHitN.
        unsafe {
            rays.set_f32(TFAR, lane, t);
            rays.set_f32(HIT + NG_X, lane, ng.x);
            rays.set_f32(HIT + NG_X + 1, lane, ng.y);
            rays.set_f32(HIT + NG_X + 2, lane, ng.z);
            rays.set_f32(HIT + U, lane, u);
            rays.set_f32(HIT + V, lane, v);
            rays.set_u32(HIT + PRIM_ID, lane, prim_id);
            rays.set_u32(HIT + GEOM_ID, lane, geom_id);
            for level in 0..sys::RTC_MAX_INSTANCE_LEVEL_COUNT as usize {
                rays.set_u32(HIT + INST_ID + level, lane, ctx.inst_id(level));
                #[cfg(embree_inst_prim_id)]
                rays.set_u32(HIT + INST_PRIM_ID + level, lane, ctx.inst_prim_id(level));
            }
        }
    };
    // SAFETY: `valid` and `rayhit` are the N-wide arrays Embree passed together.
    unsafe { for_each_active_lane(args.valid, &rays, ctx, set, "intersect", record_hit) };
}

pub(crate) unsafe extern "C" fn occluded(args: *const sys::RTCOccludedFunctionNArguments) {
    // SAFETY: as in `intersect`, with an `RTCRayN` instead of an `RTCRayHitN`.
    let (args, set, ctx) = unsafe {
        let a = &*args;
        (a, &*(a.geometryUserPtr as *const SphereSet), &*(a.context as *const QueryContext))
    };
    let rays = SoA { words: args.ray as *mut u32, n: args.N as usize };
    let prim_id = args.primID;
    let record_occlusion = |lane: usize, org: Vec3, dir: Vec3, tnear: f32, tfar: f32| {
        let s = set.spheres[prim_id as usize];
        if sphere::intersect(org, dir, s.center, s.radius, tnear, tfar).is_some() {
            // SAFETY: this active lane's tfar, inside RTCRayN; −∞ is how Embree marks
            // an occluded ray.
            unsafe { rays.set_f32(TFAR, lane, f32::NEG_INFINITY) };
        }
    };
    // SAFETY: `valid` and `ray` are the N-wide arrays Embree passed together.
    unsafe { for_each_active_lane(args.valid, &rays, ctx, set, "occluded", record_occlusion) };
}
