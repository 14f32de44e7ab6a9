//! The one tracing interface: closest hit, any hit and a batch form for coherent rays.
//!
//! Implemented by the Embree backend ([`crate::accel::embree::EmbreeAccel`]) and the native BVH
//! ([`crate::accel::bvh::Bvh`]); the integrator and `crosscheck` never know which one they hold.

pub mod bvh;
pub mod embree;
pub mod instance;
pub mod paired;

use crate::math::{Ray, Vec3};

/// The closest intersection of a ray.
///
/// Ids follow the scene's numbering (see [`crate::scene::Scene::geom_kind`]): `geom_id` is a
/// mesh index, or the id of the scene's one sphere set or plane set, and `prim_id` is the
/// triangle, sphere or plane within it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Ray parameter of the hit, in `(tnear, tfar)`.
    pub t: f32,
    /// Geometric normal in world space, not normalised. Triangles: `(p1 − p0) × (p2 − p0)`
    /// (on an instance, that of the triangle flattened into world space, see
    /// [`crate::scene::instance`]); spheres: the outward `p − c`; planes: the plane's `n`.
    pub ng: Vec3,
    /// Barycentric coordinates on triangles (`p = (1−u−v)·p0 + u·p1 + v·p2`); spherical
    /// coordinates in [0, 1] on spheres; 0 on planes.
    pub u: f32,
    pub v: f32,
    pub geom_id: u32,
    pub prim_id: u32,
}

/// A failure while tracing. Only the Embree backend can fail (an Embree error, or a panic
/// caught in one of its callbacks), and it converts its own error into this one; the native
/// backend never does. Errors that are not tracing errors (a camera or scene the integrator
/// cannot render) are the integrator's ([`crate::integrator::RenderError`]).
#[derive(Debug, thiserror::Error)]
pub enum TraceError {
    /// The backend's error, shown as its own message (`Embree error RTC_ERROR_… in
    /// rtcIntersect1: …`); downcast it to the backend's error type to read more.
    #[error("{0}")]
    Backend(Box<dyn std::error::Error + Send + Sync>),
}

/// A ray-tracing acceleration structure over a committed, immutable scene.
pub trait Accel: Sync {
    /// A short name for reports: `"embree"` or `"native"`.
    fn name(&self) -> &'static str;

    /// Makes the calling thread ready to trace; the tile loop calls it in every thread before
    /// it traces a tile. Both backends switch the thread's SSE unit to flush denormals to
    /// zero, as Embree asks of every thread that traces, so that a pixel's arithmetic is the
    /// same whichever backend, thread or pool traced it.
    fn prepare_thread(&self);

    /// The closest hit with `ray.tnear < t < ray.tfar`, if any.
    fn intersect(&self, ray: &Ray) -> Result<Option<Hit>, TraceError>;

    /// Whether anything lies on the ray within `(tnear, tfar)` (shadow rays).
    fn occluded(&self, ray: &Ray) -> Result<bool, TraceError>;

    /// Closest hits for many rays at once; `hits[i]` answers `rays[i]`. Backends that trace
    /// packets override this; coherent rays (neighbouring pixels) gain the most.
    fn intersect_batch(&self, rays: &[Ray], hits: &mut [Option<Hit>]) -> Result<(), TraceError> {
        assert_eq!(rays.len(), hits.len(), "intersect_batch: rays and hits differ in length");
        for (ray, hit) in rays.iter().zip(hits.iter_mut()) {
            *hit = self.intersect(ray)?;
        }
        Ok(())
    }

    /// Any-hit queries for many rays at once; `occluded[i]` answers `rays[i]`. Backends that
    /// trace packets override this (the shadow rays of neighbouring pixels towards one light
    /// are as coherent as their primary rays).
    fn occluded_batch(&self, rays: &[Ray], occluded: &mut [bool]) -> Result<(), TraceError> {
        assert_eq!(rays.len(), occluded.len(), "occluded_batch: rays and answers differ in length");
        for (ray, o) in rays.iter().zip(occluded.iter_mut()) {
            *o = self.occluded(ray)?;
        }
        Ok(())
    }

    /// For the `disagreement` pass: `differ[i]` says whether a second backend finds another
    /// first hit for `rays[i]` than `hits[i]`, this backend's ([`same_first_hit`]). Only
    /// [`paired::Paired`] has a second backend; alone, a backend agrees with itself and sets
    /// every `differ[i]` to false.
    fn compare_first_hits(&self, rays: &[Ray], hits: &[Option<Hit>], differ: &mut [bool]) -> Result<(), TraceError> {
        let _ = (rays, hits);
        differ.fill(false);
        Ok(())
    }
}

/// Whether two backends' answers for one ray name the same first hit: both none, or the same
/// primitive (`geom_id`, `prim_id`). Their `t`, normal and barycentrics may differ by
/// rounding.
pub fn same_first_hit(a: &Option<Hit>, b: &Option<Hit>) -> bool {
    match (a, b) {
        (None, None) => true,
        (Some(a), Some(b)) => (a.geom_id, a.prim_id) == (b.geom_id, b.prim_id),
        _ => false,
    }
}
