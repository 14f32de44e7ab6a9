//! Instances: a prototype mesh stored once, in its own object space, placed in the world any
//! number of times by an affine transform (a glTF mesh used by many nodes).
//!
//! A point of instance `k` is `p_world = M_k·p_object` ([`Transform`], composed in f64). Both
//! backends trace the ray in object space, `org' = M⁻¹·org`, `dir' = M⁻¹·dir` (not
//! renormalised, so `t` is the same along both), and report the hit with the instance's
//! geometry id ([`crate::scene::Scene::instance_geom_id`]) and the prototype's triangle.
//! Its geometric normal, found in object space, is reported in world space as the flattened
//! triangle's `(p1 − p0) × (p2 − p0)` would be: `|det L|·L⁻ᵀ·n` ([`crate::accel::instance::WorldNormals`],
//! [`Transform::area_normal_f64`]), so that rays leaving the hit (offset along `ng`, mirrored
//! about it) are the same for an instance as for its flattened twin.
//!
//! Shading rebuilds the hit in world space exactly as a flattened copy would hold it: the
//! triangle's corners and vertex normals are transformed one by one with the same f64
//! [`Transform`] that flattening uses (points by `M`, normals by `M⁻ᵀ`, renormalised), then
//! interpolated with the hit's barycentrics; under a mirroring transform (negative
//! determinant) the geometric normal is negated, as a flattened copy swaps two corners. So an
//! instanced scene shades like the same scene with its geometry flattened into world space.

use super::Mesh;
use super::transform::Transform;
use crate::math::{Aabb, Vec3};

/// One placement of a prototype mesh.
#[derive(Clone, Debug, PartialEq)]
pub struct Instance {
    /// Name for messages (`strahl info`): the glTF node or scene object.
    pub name: String,
    /// Index into `Scene::prototypes`.
    pub prototype: u32,
    /// Object to world.
    pub transform: Transform,
    /// Replaces every material of the prototype when given.
    pub material: Option<u32>,
}

impl Instance {
    /// World-space corners of triangle `prim` of `mesh` (this instance's prototype), rounded
    /// to f32 once, as flattening rounds them.
    #[inline]
    pub fn corners(&self, mesh: &Mesh, prim: usize) -> [Vec3; 3] {
        mesh.triangle(prim).map(|p| self.transform.point(p))
    }

    /// The material of triangle `prim` of `mesh`.
    #[inline]
    pub fn material_of(&self, mesh: &Mesh, prim: usize) -> u32 {
        self.material.unwrap_or_else(|| mesh.material_of(prim))
    }

    /// World-space bounds of the prototype's bounds `object` (its eight corners transformed).
    pub fn bounds(&self, object: Aabb) -> Aabb {
        if object.is_empty() {
            return Aabb::EMPTY;
        }
        let (lo, hi) = (object.min, object.max);
        let corners = (0..8).map(|i| {
            let pick = |bit: usize, a: f32, b: f32| if i & bit == 0 { a } else { b };
            let c = Vec3::new(pick(1, lo.x, hi.x), pick(2, lo.y, hi.y), pick(4, lo.z, hi.z));
            self.transform.point_f64(c.as_dvec3())
        });
        // Rounded outwards so that every rounded transformed vertex lies inside.
        let (mut min, mut max) = (glam::DVec3::INFINITY, glam::DVec3::NEG_INFINITY);
        for c in corners {
            (min, max) = (min.min(c), max.max(c));
        }
        let pad = 1e-6 * (max - min).max_element().max(max.abs().max_element());
        Aabb::new((min - pad).as_vec3(), (max + pad).as_vec3())
    }
}

/// The same scene with every instance turned into a world-space mesh (its prototype
/// transformed by [`Transform::apply_to_mesh`]), the prototypes dropped: what an instanced
/// scene must render like.
pub fn flatten(scene: &super::Scene) -> super::Scene {
    let mut flat = super::Scene { prototypes: Vec::new(), instances: Vec::new(), ..scene.clone() };
    for inst in &scene.instances {
        let mut mesh = scene.prototypes[inst.prototype as usize].clone();
        if let Some(m) = inst.material {
            (mesh.material, mesh.triangle_materials) = (m, None);
        }
        mesh.name = inst.name.clone();
        inst.transform.apply_to_mesh(&mut mesh);
        flat.meshes.push(mesh);
    }
    flat
}
