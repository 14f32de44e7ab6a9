//! Embree instancing: each prototype mesh is its own committed `RTCScene`, placed in the top
//! scene by `RTC_GEOMETRY_TYPE_INSTANCE` geometries with a 3×4 object-to-world transform
//! (as in Embree's `instanced_geometry` tutorial). Embree transforms each ray into the
//! prototype's space and reports the instance's id in `instID[0]`; strahl's hit then carries
//! that id as its `geom_id` (the scene's numbering, [`crate::scene::Scene::instance_geom_id`])
//! and the prototype's triangle as its `prim_id`. Its `Ng` comes in the prototype's space;
//! [`super::EmbreeAccel`] turns it into world space
//! ([`crate::accel::instance::WorldNormals`]).
//!
//! The API used here (`rtcNewGeometry(INSTANCE)`, `rtcSetGeometryInstancedScene`,
//! `rtcSetGeometryTransform` with `RTC_FORMAT_FLOAT3X4_COLUMN_MAJOR`) is the same in Embree 3
//! and 4.

use glam::Affine3A;

use super::device::take_error;
use super::scene::{Geometry, Scene, SceneBuilder};
use super::{Error, sys};

/// The scene-level geometry id of a hit: the instance's (`instID[0]`) when the hit lies in an
/// instanced scene, else the geometry's own.
#[inline]
pub(super) fn hit_geom_id(geom_id: u32, inst_id: u32) -> u32 {
    if inst_id != sys::RTC_INVALID_GEOMETRY_ID { inst_id } else { geom_id }
}

impl SceneBuilder {
    /// Adds an instance of the committed `prototype` with geometry id `id` (at least
    /// [`SceneBuilder::next_geom_id`]; ids in between stay unused), placed by
    /// `object_to_world`. The instance holds a reference to the prototype's `RTCScene`, so the
    /// prototype may be dropped afterwards.
    pub fn add_instance(&mut self, id: u32, prototype: &Scene, object_to_world: &Affine3A) -> Result<u32, Error> {
        if id < self.next_id {
            return Err(Error::InvalidInput {
                object: format!("instance {id}"),
                problem: format!("geometry id {id} is taken (the next free one is {})", self.next_id),
            });
        }
        let m = object_to_world.to_cols_array();
        if !m.iter().all(|x| x.is_finite()) {
            return Err(Error::InvalidInput {
                object: format!("instance {id}"),
                problem: "the transform is not finite".into(),
            });
        }
        // SAFETY: the device is live; the type is a valid geometry type.
        let geometry = Geometry(unsafe { sys::rtcNewGeometry(self.device.raw(), sys::RTC_GEOMETRY_TYPE_INSTANCE) });
        take_error("rtcNewGeometry")?;
        // SAFETY: `geometry` is a live instance geometry and `prototype.raw` a live committed
        // scene (Embree takes its own reference to it); `m` holds the 12 floats that
        // RTC_FORMAT_FLOAT3X4_COLUMN_MAJOR reads (x, y, z axes, then the translation), and
        // Embree copies them during the call.
        unsafe {
            sys::rtcSetGeometryInstancedScene(geometry.0, prototype.raw);
            sys::rtcSetGeometryTransform(geometry.0, 0, sys::RTC_FORMAT_FLOAT3X4_COLUMN_MAJOR, m.as_ptr().cast());
        }
        take_error("rtcSetGeometryTransform")?;
        self.attach(geometry, id)?;
        self.next_id = id + 1;
        Ok(id)
    }
}
