//! Instance hits in world space, for both backends. A backend traces an instance's ray in
//! object space and finds the prototype triangle's geometric normal `n` there; the hit reports
//! it in world space as the flattened triangle's `(p1 − p0) × (p2 − p0)` would be,
//! `|det L|·L⁻ᵀ·n` ([`Transform::area_normal_f64`], in f64), so that rays leaving the hit are
//! the same for an instance as for its flattened twin (see [`crate::scene::instance`]).

use crate::accel::Hit;
use crate::scene::Scene;
use crate::scene::transform::Transform;

/// Turns instance hits' object-space geometric normals into world space (see the module
/// docs); both backends report every hit through it.
#[derive(Clone, Debug, Default)]
pub struct WorldNormals {
    /// The geometry id of instance 0.
    first: u32,
    transforms: Vec<Transform>,
}

impl WorldNormals {
    /// The instances of `scene`.
    pub fn of_scene(scene: &Scene) -> WorldNormals {
        WorldNormals {
            first: scene.instance_geom_id(0),
            transforms: scene.instances.iter().map(|i| i.transform).collect(),
        }
    }

    /// `hit` with its `ng` in world space if it lies on an instance (unchanged otherwise).
    #[inline]
    pub fn to_world(&self, hit: Hit) -> Hit {
        match hit.geom_id.checked_sub(self.first).and_then(|k| self.transforms.get(k as usize)) {
            Some(t) => Hit { ng: t.area_normal_f64(hit.ng.as_dvec3()).as_vec3(), ..hit },
            None => hit,
        }
    }
}
