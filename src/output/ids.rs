//! Which object and material a hit belongs to, for the object and material index passes and
//! Cryptomatte.
//!
//! The objects are the distinct names of the scene's primitives ([`crate::scene::ObjectNames`]),
//! in the order they first appear (meshes, then spheres, then planes, then instances); primitives sharing a
//! name are one object. Object `k` has the index `k + 1` in the `object_index` pass (0 where
//! nothing is hit); material `m` (the scene's `materials[m]`) has `m + 1` in `material_index`.
//! Their Cryptomatte ids are those of their names ([`crate::output::cryptomatte::id`]).

use std::collections::HashMap;

use crate::accel::Hit;
use crate::output::cryptomatte;
use crate::scene::{GeomKind, Scene};

/// The object of every primitive of a scene, and the Cryptomatte ids of objects and materials.
#[derive(Clone, Debug, Default)]
pub struct ObjectIds {
    /// The objects' names, in object-index order.
    pub object_names: Vec<String>,
    /// Cryptomatte id bits of each object.
    pub object_id_bits: Vec<u32>,
    /// Cryptomatte id bits of each material.
    pub material_id_bits: Vec<u32>,
    mesh: Vec<u32>,
    sphere: Vec<u32>,
    plane: Vec<u32>,
    instance: Vec<u32>,
}

impl ObjectIds {
    pub fn new(scene: &Scene) -> ObjectIds {
        let mut ids = ObjectIds::default();
        let mut by_name: HashMap<String, u32> = HashMap::new();
        let mut object = |name: String, ids: &mut ObjectIds| -> u32 {
            *by_name.entry(name).or_insert_with_key(|name| {
                ids.object_names.push(name.clone());
                ids.object_id_bits.push(cryptomatte::id_bits(name));
                ids.object_names.len() as u32 - 1
            })
        };
        for i in 0..scene.meshes.len() {
            let o = object(scene.mesh_name(i).to_string(), &mut ids);
            ids.mesh.push(o);
        }
        for i in 0..scene.spheres.len() {
            let o = object(scene.sphere_name(i), &mut ids);
            ids.sphere.push(o);
        }
        for i in 0..scene.planes.len() {
            let o = object(scene.plane_name(i), &mut ids);
            ids.plane.push(o);
        }
        for inst in &scene.instances {
            let o = object(inst.name.clone(), &mut ids);
            ids.instance.push(o);
        }
        ids.material_id_bits = scene.materials.iter().map(|m| cryptomatte::id_bits(&m.name)).collect();
        ids
    }

    /// The object (index into [`ObjectIds::object_names`]) that `hit` of `scene` lies on.
    pub fn object_of(&self, scene: &Scene, hit: &Hit) -> u32 {
        match scene.geom_kind(hit.geom_id) {
            GeomKind::Mesh(m) => self.mesh[m as usize],
            GeomKind::Spheres => self.sphere[hit.prim_id as usize],
            GeomKind::Planes => self.plane[hit.prim_id as usize],
            GeomKind::Instance(k) => self.instance[k as usize],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Sphere;
    use crate::math::Vec3;

    #[test]
    fn shared_names_are_one_object() {
        let s = Sphere { center: Vec3::ZERO, radius: 1.0, material: 0 };
        let mut scene = Scene { spheres: vec![s; 3], ..Default::default() };
        scene.names.spheres = vec!["a".into(), "b".into(), "a".into()];
        let ids = ObjectIds::new(&scene);
        assert_eq!(ids.object_names, ["a", "b"]);
        let hit = |prim_id| Hit { t: 1.0, ng: Vec3::Z, u: 0.0, v: 0.0, geom_id: scene.spheres_geom_id(), prim_id };
        assert_eq!([0, 1, 2].map(|p| ids.object_of(&scene, &hit(p))), [0, 1, 0]);
        assert_eq!(ids.object_id_bits[1], cryptomatte::id_bits("b"));
    }
}
