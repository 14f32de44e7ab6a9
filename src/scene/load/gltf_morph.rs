//! Morph targets at their default weights (glTF 2.0 §3.7.2.2): a primitive's vertex `i` is
//! `pᵢ = p⁰ᵢ + Σₜ wₜ·Δpₜ,ᵢ` and its normal `nᵢ = normalize(n⁰ᵢ + Σₜ wₜ·Δnₜ,ᵢ)`, with the
//! weights of the node (`node.weights`), else of the mesh (`mesh.weights`), else 0 (the base
//! shape). Animations are not read: the default weights are the shape a still image shows.
//!
//! A mesh whose nodes give it other weights than its own is built once per distinct set of
//! weights ([`MeshSlots`]).

use std::collections::HashMap;

use gltf::accessor::{DataType, Dimensions};

use crate::math::Vec3;
use crate::scene::Mesh;

/// The weights `node` gives the targets of `mesh`.
pub fn weights<'a>(node: &gltf::Node<'a>, mesh: &gltf::Mesh<'a>) -> &'a [f32] {
    node.weights().or(mesh.weights()).unwrap_or(&[])
}

/// Which morph target attribute [`displace`] adds.
#[derive(Clone, Copy, Debug)]
pub enum Attribute {
    Position,
    Normal,
}

/// Adds `primitive`'s targets' displacements of `attribute`, weighted by `weights`, to
/// `values` (one per vertex of the primitive). `check` checks an accessor's types and bytes
/// before it is read; a target's accessor must have one element per vertex.
pub fn displace(
    primitive: &gltf::Primitive,
    buffers: &[std::sync::Arc<Vec<u8>>],
    weights: &[f32],
    attribute: Attribute,
    values: &mut [Vec3],
    check: impl Fn(&gltf::Accessor, &[DataType], &[Dimensions], &str) -> Result<(), String>,
) -> Result<(), String> {
    let get = |b: gltf::Buffer| buffers.get(b.index()).map(|d| d.as_slice());
    for (t, target) in primitive.morph_targets().enumerate() {
        let w = weights.get(t).copied().unwrap_or(0.0);
        let a = match attribute {
            Attribute::Position => target.positions(),
            Attribute::Normal => target.normals(),
        };
        let Some(a) = a else { continue };
        if w == 0.0 {
            continue;
        }
        let name = format!("morph target {t} {attribute:?}");
        check(&a, &[DataType::F32], &[Dimensions::Vec3], &name)?;
        if a.count() != values.len() {
            return Err(format!(
                "{name}: accessor {} has {} elements for {} vertices",
                a.index(),
                a.count(),
                values.len()
            ));
        }
        let deltas = gltf::accessor::Iter::<[f32; 3]>::new(a, get).into_iter().flatten();
        values.iter_mut().zip(deltas).for_each(|(v, d)| *v += w * Vec3::from(d));
    }
    Ok(())
}

/// The meshes built so far: one slot per glTF mesh (morphed by its own weights), then one per
/// other set of weights a node gives a mesh.
pub struct MeshSlots {
    pub meshes: Vec<Option<Mesh>>,
    variants: HashMap<(usize, Vec<u32>), usize>,
}

impl MeshSlots {
    pub fn new(gltf_meshes: usize) -> Self {
        MeshSlots { meshes: vec![None; gltf_meshes], variants: HashMap::new() }
    }

    /// The slot of glTF mesh `mesh` morphed by `weights` (the mesh's own slot when they are
    /// the mesh's `own` weights).
    pub fn slot(&mut self, mesh: usize, weights: &[f32], own: &[f32]) -> usize {
        let bits = |w: &[f32]| w.iter().map(|x| x.to_bits()).collect::<Vec<u32>>();
        if bits(weights) == bits(own) {
            return mesh;
        }
        let meshes = &mut self.meshes;
        *self.variants.entry((mesh, bits(weights))).or_insert_with(|| {
            meshes.push(None);
            meshes.len() - 1
        })
    }
}
