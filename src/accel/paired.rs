//! Two backends over the same scene, traced as one: every query goes to the `first` (the
//! render's backend, whose answers make the image), and
//! [`Accel::compare_first_hits`] asks the `second` for the same rays' first hits and reports
//! where they name another primitive ([`super::same_first_hit`]). This is what the
//! `disagreement` pass renders ([`crate::output::passes`]): Embree paired with the native BVH,
//! or the other way round.

use super::{Accel, Hit, TraceError, same_first_hit};
use crate::math::Ray;

/// `first` answers, `second` is compared with it.
pub struct Paired<A, B> {
    pub first: A,
    pub second: B,
}

impl<A: Accel, B: Accel> Accel for Paired<A, B> {
    fn name(&self) -> &'static str {
        self.first.name()
    }

    fn prepare_thread(&self) {
        self.first.prepare_thread();
        self.second.prepare_thread();
    }

    fn intersect(&self, ray: &Ray) -> Result<Option<Hit>, TraceError> {
        self.first.intersect(ray)
    }

    fn occluded(&self, ray: &Ray) -> Result<bool, TraceError> {
        self.first.occluded(ray)
    }

    fn intersect_batch(&self, rays: &[Ray], hits: &mut [Option<Hit>]) -> Result<(), TraceError> {
        self.first.intersect_batch(rays, hits)
    }

    fn occluded_batch(&self, rays: &[Ray], occluded: &mut [bool]) -> Result<(), TraceError> {
        self.first.occluded_batch(rays, occluded)
    }

    fn compare_first_hits(&self, rays: &[Ray], hits: &[Option<Hit>], differ: &mut [bool]) -> Result<(), TraceError> {
        assert!(rays.len() == hits.len() && rays.len() == differ.len(), "compare_first_hits: lengths differ");
        let mut others = vec![None; rays.len()];
        self.second.intersect_batch(rays, &mut others)?;
        for ((d, a), b) in differ.iter_mut().zip(hits).zip(&others) {
            *d = !same_first_hit(a, b);
        }
        Ok(())
    }
}
