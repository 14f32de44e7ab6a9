//! The native backend's second level: one [`Bvh`] per prototype mesh, in its own object
//! space, and a top-level binary tree over the instances' world-space boxes.
//!
//! A ray reaching an instance's box is transformed into the prototype's space,
//! `org' = M⁻¹·org`, `dir' = M⁻¹·dir` (`M⁻¹` computed in f64 and rounded once; the direction
//! is not renormalised, so `t` is the same in both spaces), and traced through the
//! prototype's tree with `tfar` clipped to the closest hit so far. Hits carry the instance's
//! geometry id ([`crate::scene::Scene::instance_geom_id`]) and the prototype's triangle, like
//! Embree's; their `ng`, found in the prototype's space, is reported in world space
//! ([`WorldNormals`]).
//!
//! An instance whose hits the alpha test decides ([`crate::scene::alpha`]) is traced through
//! its prototype's tree with the test, given the instance's id and the world-space ray, so it
//! decides as for the flattened twin and as Embree's filter does.
//!
//! The top tree splits the instances at the median of their box centres along the widest
//! axis, down to leaves of `TOP_LEAF`; it is small (a node per two instances) and its build
//! is deterministic.

use glam::Affine3A;
use std::sync::Arc;

use super::{Bvh, Error};
use crate::accel::instance::WorldNormals;
use crate::accel::{Accel, Hit};
use crate::math::{Aabb, Ray, Vec3};
use crate::scene::Scene;
use crate::scene::alpha::AlphaTest;

/// Most instances in a top-level leaf.
const TOP_LEAF: usize = 2;

/// An instance as the traversal sees it.
struct Entry {
    world_to_object: Affine3A,
    prototype: u32,
    geom_id: u32,
}

/// A node of the top tree: children `left`, `left + 1`... as indices, or a leaf's range of
/// entries.
struct TopNode {
    bounds: Aabb,
    /// Leaf: `count > 0`, entries `first .. first + count`; inner: children `first` and
    /// `first + 1`.
    first: u32,
    count: u32,
}

/// The prototypes' trees and the top tree over the instances.
pub struct Instances {
    prototypes: Vec<Bvh>,
    entries: Vec<Entry>,
    nodes: Vec<TopNode>,
    normals: WorldNormals,
    /// The scene's alpha test, when it covers some instance.
    alpha: Option<Arc<AlphaTest>>,
}

impl Instances {
    /// The second level of `scene`, or `None` when it has no instances; `alpha` is the
    /// scene's alpha test.
    pub fn build(scene: &Scene, alpha: Option<Arc<AlphaTest>>) -> Result<Option<Instances>, Error> {
        if scene.instances.is_empty() {
            return Ok(None);
        }
        if let Some((object, problem)) = scene.instances_problem() {
            return Err(Error::InvalidInput { object, problem });
        }
        let prototypes = scene
            .prototypes
            .iter()
            .map(|mesh| Bvh::build(&Scene { meshes: vec![mesh.clone()], ..Default::default() }))
            .collect::<Result<Vec<_>, _>>()?;
        let mut items: Vec<(Aabb, Entry)> = scene
            .instances
            .iter()
            .enumerate()
            .map(|(k, inst)| {
                let inverse = inst.transform.affine().inverse();
                let world_to_object =
                    Affine3A::from_mat3_translation(inverse.matrix3.as_mat3(), inverse.translation.as_vec3());
                let bounds = inst.bounds(prototypes[inst.prototype as usize].bounds());
                (bounds, Entry { world_to_object, prototype: inst.prototype, geom_id: scene.instance_geom_id(k) })
            })
            .collect();
        let mut nodes = vec![TopNode { bounds: Aabb::EMPTY, first: 0, count: 0 }];
        split(&mut items, 0, 0, &mut nodes);
        let entries = items.into_iter().map(|(_, e)| e).collect();
        let alpha = alpha.filter(|a| (0..scene.instances.len()).any(|k| a.covers(scene.instance_geom_id(k))));
        Ok(Some(Instances { prototypes, entries, nodes, normals: WorldNormals::of_scene(scene), alpha }))
    }

    /// The closest instance hit within `(ray.tnear, ray.tfar)`.
    pub fn intersect(&self, ray: &Ray) -> Option<Hit> {
        let mut closest: Option<Hit> = None;
        let mut tfar = ray.tfar;
        self.visit(ray, |entry| {
            let local = self.local_ray(entry, ray, tfar);
            let prototype = &self.prototypes[entry.prototype as usize];
            let found = match self.tested(entry) {
                Some(alpha) => prototype.intersect_instance(&local, alpha, ray, entry.geom_id),
                None => prototype.intersect(&local).ok().flatten(),
            };
            if let Some(hit) = found {
                if hit.t < tfar {
                    tfar = hit.t;
                    closest = Some(Hit { geom_id: entry.geom_id, ..hit });
                }
            }
            true
        });
        closest.map(|h| self.normals.to_world(h))
    }

    /// Whether any instance lies on the ray within `(tnear, tfar)`.
    pub fn occluded(&self, ray: &Ray) -> bool {
        let mut hit = false;
        self.visit(ray, |entry| {
            let local = self.local_ray(entry, ray, ray.tfar);
            let prototype = &self.prototypes[entry.prototype as usize];
            hit = match self.tested(entry) {
                Some(alpha) => prototype.occluded_instance(&local, alpha, ray, entry.geom_id),
                None => prototype.occluded(&local).unwrap_or(false),
            };
            !hit
        });
        hit
    }

    /// The alpha test, if it decides `entry`'s hits.
    #[inline]
    fn tested(&self, entry: &Entry) -> Option<&AlphaTest> {
        self.alpha.as_deref().filter(|a| a.covers(entry.geom_id))
    }

    #[inline]
    fn local_ray(&self, entry: &Entry, ray: &Ray, tfar: f32) -> Ray {
        let m = &entry.world_to_object;
        Ray { org: m.transform_point3(ray.org), dir: m.transform_vector3(ray.dir), tfar, ..*ray }
    }

    /// Calls `f` on every entry whose box the ray enters, until `f` returns false.
    fn visit(&self, ray: &Ray, mut f: impl FnMut(&Entry) -> bool) {
        let inv = ray.dir.recip();
        let mut stack = vec![0u32];
        while let Some(i) = stack.pop() {
            let node = &self.nodes[i as usize];
            if !enters(&node.bounds, ray, inv) {
                continue;
            }
            if node.count > 0 {
                for e in &self.entries[node.first as usize..(node.first + node.count) as usize] {
                    if !f(e) {
                        return;
                    }
                }
            } else {
                stack.push(node.first);
                stack.push(node.first + 1);
            }
        }
    }

    /// Bytes the second level takes besides the prototypes' trees.
    pub fn top_bytes(&self) -> usize {
        self.entries.len() * size_of::<Entry>() + self.nodes.len() * size_of::<TopNode>()
    }
}

/// Whether the ray's interval `(tnear, tfar)` overlaps the box (slab test; a NaN from a ray on
/// a slab's plane counts as inside; the interval widened by a few ulps so rounding never
/// culls a box the ray touches).
#[inline]
fn enters(b: &Aabb, ray: &Ray, inv: Vec3) -> bool {
    let t0 = (b.min - ray.org) * inv;
    let t1 = (b.max - ray.org) * inv;
    let near = t0.min(t1).max_element().max(ray.tnear);
    let far = t0.max(t1).min_element().min(ray.tfar);
    near <= far * (1.0 + 4.0 * f32::EPSILON)
}

/// Fills node `index` with `items` (which start at entry `offset`), splitting at the median
/// of the box centres along their widest axis.
fn split(items: &mut [(Aabb, Entry)], offset: usize, index: usize, nodes: &mut Vec<TopNode>) {
    let bounds = items.iter().fold(Aabb::EMPTY, |b, (x, _)| b.union(*x));
    if items.len() <= TOP_LEAF {
        nodes[index] = TopNode { bounds, first: offset as u32, count: items.len() as u32 };
        return;
    }
    let centres = items.iter().fold(Aabb::EMPTY, |b, (x, _)| b.grow(x.centroid()));
    let extent = centres.extent();
    let axis = if extent.x >= extent.y && extent.x >= extent.z {
        0
    } else if extent.y >= extent.z {
        1
    } else {
        2
    };
    let mid = items.len() / 2;
    items.select_nth_unstable_by(mid, |a, b| a.0.centroid()[axis].total_cmp(&b.0.centroid()[axis]));
    let first = nodes.len();
    nodes.push(TopNode { bounds: Aabb::EMPTY, first: 0, count: 0 });
    nodes.push(TopNode { bounds: Aabb::EMPTY, first: 0, count: 0 });
    nodes[index] = TopNode { bounds, first: first as u32, count: 0 };
    let (left, right) = items.split_at_mut(mid);
    split(left, offset, first, nodes);
    split(right, offset + mid, first + 1, nodes);
}
