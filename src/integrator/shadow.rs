//! The shadow rays of a round of camera-ray hits, traced light by light: for each
//! [`LightSlot`](super::lights::LightSlot) (a light, or one sample of an area light or emissive mesh), the shadow rays
//! of every pixel whose hit casts one towards it go to [`Accel::occluded_batch`] together,
//! which Embree traces as 8-wide `rtcOccluded8` packets: neighbouring pixels' rays towards one
//! light point are as coherent as their camera rays. Shared by every integrator that gathers
//! direct light at its camera hits.
//!
//! **The rule.** Each pixel draws its light samples in slot order and its unoccluded lights
//! are handed back in slot order, exactly as shading that pixel's hit alone, one shadow ray
//! after the other, would: the sums are bit-identical to it. Deeper hits trace their shadow
//! rays one by one.

use super::RayCounts;
use super::lights::{Lights, shadow_ray};
use crate::accel::{Accel, TraceError};
use crate::light::Incidence;
use crate::math::{Ray, Vec3, offset_ray_origin};
use crate::sampler::SampleDims;
use crate::surface::SurfacePoint;

/// The reusable buffers of one tile's shadow-ray batches.
#[derive(Default)]
pub struct ShadowBatch {
    /// Per pixel: the shadow rays' origin, when its hit casts them.
    origins: Vec<Option<Vec3>>,
    rays: Vec<Ray>,
    /// Per ray: the pixel it belongs to and the light's incidence there.
    owners: Vec<(usize, Incidence)>,
    occluded: Vec<bool>,
}

impl ShadowBatch {
    /// Traces the shadow rays from `points` (per pixel, its camera ray's shading point, if
    /// any) that `casts` (whether light reaching pixel `i`'s point can leave it towards the
    /// viewer) towards every light of `lights`, drawing pixel `i`'s light samples from `dims[i]`, and
    /// calls `lit(i, point, incidence)` for every ray that reaches its light: light by light,
    /// and pixel by pixel within a light. Counts the rays in `counts.shadow`.
    #[allow(clippy::too_many_arguments)] // the accel, the lights, the points, and what they add to
    pub fn trace<A: Accel, D: AsMut<SampleDims>>(
        &mut self,
        accel: &A,
        lights: &Lights,
        points: &[Option<SurfacePoint>],
        casts: impl Fn(usize, &SurfacePoint) -> bool,
        dims: &mut [D],
        counts: &mut RayCounts,
        mut lit: impl FnMut(usize, &SurfacePoint, &Incidence),
    ) -> Result<(), TraceError> {
        self.origins.clear();
        self.origins.extend(points.iter().enumerate().map(|(i, p)| match p {
            Some(sp) if casts(i, sp) => Some(offset_ray_origin(sp.p, sp.ng)),
            _ => None,
        }));
        for slot in lights.slots() {
            self.rays.clear();
            self.owners.clear();
            for (i, ((p, d), origin)) in points.iter().zip(dims.iter_mut()).zip(&self.origins).enumerate() {
                let (Some(sp), Some(origin)) = (p, origin) else { continue };
                let Some(inc) = lights.incidence(&slot, sp.p, d.as_mut()) else { continue };
                let Some(shadow) = shadow_ray(sp, *origin, &inc) else { continue };
                self.rays.push(shadow);
                self.owners.push((i, inc));
            }
            if self.rays.is_empty() {
                continue;
            }
            counts.shadow += self.rays.len() as u64;
            self.occluded.clear();
            self.occluded.resize(self.rays.len(), false);
            accel.occluded_batch(&self.rays, &mut self.occluded)?;
            for (&(i, inc), &occluded) in self.owners.iter().zip(&self.occluded) {
                if let (false, Some(sp)) = (occluded, &points[i]) {
                    lit(i, sp, &inc);
                }
            }
        }
        Ok(())
    }
}
