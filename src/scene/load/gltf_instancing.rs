//! `EXT_mesh_gpu_instancing`: a node that places its mesh once per element of its
//! `TRANSLATION` (VEC3), `ROTATION` (VEC4 unit quaternion `x y z w`) and `SCALE` (VEC3)
//! accessors, instance `k` at `node_to_world · T(tₖ) · R(qₖ) · S(sₖ)` (the instance's TRS
//! applied before the node's transform; a missing attribute is the identity). Each becomes one
//! of strahl's placements, as a mesh placed by several nodes does (one prototype, an Embree
//! instance each).
//!
//! The attributes are floats (normalized integers need `KHR_mesh_quantization`, refused) with
//! one count between them. An instance whose transform is singular (a zero scale, used to
//! hide instances) is skipped, all of them named in one warning.

use glam::{DMat4, DQuat, DVec3};
use gltf::accessor::{DataType, Dimensions};

use super::gltf_extensions::Instancing;
use crate::scene::transform::Transform;

/// An accessor by index, or the error naming who asked for it.
pub fn accessor<'a>(doc: &'a gltf::Document, index: usize, what: &str) -> Result<gltf::Accessor<'a>, String> {
    doc.accessors()
        .nth(index)
        .ok_or_else(|| format!("{what} names accessor {index}, but the file has {}", doc.accessors().len()))
}

/// The placements `inst` declares on node `node`, in object-to-node terms (to be followed by
/// the node's transform): `(instance index, transform)` for every non-singular one, and how
/// many were skipped. `check` checks an accessor's types and bytes before it is read.
pub fn instance_transforms(
    doc: &gltf::Document,
    buffers: &[std::sync::Arc<Vec<u8>>],
    node: usize,
    inst: &Instancing,
    check: impl Fn(&gltf::Accessor, &[DataType], &[Dimensions], &str) -> Result<(), String>,
) -> Result<(Vec<(usize, Transform)>, usize), String> {
    let what = format!("node {node}: EXT_mesh_gpu_instancing");
    let get = |b: gltf::Buffer| buffers.get(b.index()).map(|d| d.as_slice());
    let mut count: Option<usize> = None;
    let mut read = |index: Option<usize>, key: &str, dims: Dimensions| -> Result<Option<Vec<Vec<f64>>>, String> {
        let Some(index) = index else { return Ok(None) };
        let name = format!("{what} {key}");
        let a = accessor(doc, index, &name)?;
        check(&a, &[DataType::F32], &[dims], &name)?;
        if let Some(c) = count.filter(|&c| c != a.count()) {
            return Err(format!("{name}: accessor {index} has {} elements, the other attributes {c}", a.count()));
        }
        count = Some(a.count());
        let values: Vec<Vec<f64>> = match dims {
            Dimensions::Vec4 => gltf::accessor::Iter::<[f32; 4]>::new(a, get)
                .into_iter()
                .flatten()
                .map(|v| v.map(f64::from).to_vec())
                .collect(),
            _ => gltf::accessor::Iter::<[f32; 3]>::new(a, get)
                .into_iter()
                .flatten()
                .map(|v| v.map(f64::from).to_vec())
                .collect(),
        };
        if values.len() != count.unwrap_or(0) {
            return Err(format!("{name}: accessor {index} could not be read"));
        }
        Ok(Some(values))
    };
    let t = read(inst.translation, "TRANSLATION", Dimensions::Vec3)?;
    let r = read(inst.rotation, "ROTATION", Dimensions::Vec4)?;
    let s = read(inst.scale, "SCALE", Dimensions::Vec3)?;
    let n = count.unwrap_or(0);
    let (mut out, mut skipped) = (Vec::with_capacity(n), 0);
    for k in 0..n {
        let translation = t.as_ref().map_or(DVec3::ZERO, |t| DVec3::from_slice(&t[k]));
        let q = r.as_ref().map_or(DQuat::IDENTITY, |r| DQuat::from_slice(&r[k]));
        let q = if q.length() > 0.0 { q.normalize() } else { q };
        let scale = s.as_ref().map_or(DVec3::ONE, |s| DVec3::from_slice(&s[k]));
        match Transform::from_matrix(DMat4::from_scale_rotation_translation(scale, q, translation)) {
            Ok(transform) => out.push((k, transform)),
            Err(_) => skipped += 1,
        }
    }
    Ok((out, skipped))
}

/// Placements the instancing of every node of `nodes` (node, mesh or not) may add, from the
/// accessors' declared counts: for the memory budget, before anything is read.
pub fn declared_placements(
    doc: &gltf::Document,
    instancing: &std::collections::HashMap<usize, Instancing>,
) -> Result<u64, String> {
    let mut total = 0u64;
    for (&node, inst) in instancing {
        let what = format!("node {node}: EXT_mesh_gpu_instancing");
        let mut most = 0;
        for index in [inst.translation, inst.rotation, inst.scale].into_iter().flatten() {
            most = most.max(accessor(doc, index, &what)?.count() as u64);
        }
        total = total.saturating_add(most);
    }
    Ok(total)
}
