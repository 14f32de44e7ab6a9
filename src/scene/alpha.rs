//! Which hits on a surface exist: glTF's `alphaMode`, `alphaCutoff` and `doubleSided`, decided
//! by one function that both backends call ([`AlphaTest::passes`]), so they agree bit for bit.
//!
//! At a hit on triangle `prim` of mesh `geom` whose material has a [`Coverage`] (its
//! `alphaMode`, alpha and `doubleSided`, a material property in [`crate::material`]):
//!
//! ```text
//! α = baseColorFactor.a · baseColorTexture.a(uv) · COLOR_0.a(u, v)
//! MASK:   the hit exists  ⇔  α ≥ alphaCutoff                      (default 0.5)
//! BLEND:  the hit exists  ⇔  ξ < α,  ξ = hash(ray.org, ray.dir, geom, prim) ∈ [0, 1)
//! doubleSided false: a camera ray's hit on the back (dir · ((p1 − p0) × (p2 − p0)) > 0)
//!                    does not exist
//! ```
//!
//! - The texture's alpha is its alpha plane ([`crate::texture::Encoding::Alpha`]: linear, read
//!   bilinearly with the colour's wrap modes, through the colour texture's `texCoord` and
//!   `KHR_texture_transform`), the vertex alpha interpolated barycentrically.
//! - `u, v` (and so `uv`) are re-solved in f64 from the ray and the triangle's corners
//!   ([`triangle::resolve_f64`], as shading does), never taken from the backend: Embree's and
//!   the native BVH's own barycentrics differ in their last bits, the decision must not.
//! - BLEND is stochastic transparency: the surface is there for a fraction α of the rays that
//!   reach it, decided by a hash of the ray's bits and the primitive (SplitMix64's finaliser
//!   over the eight words, the top 24 bits as ξ), so the same ray meets the same surfaces
//!   whatever the thread, tile, backend or resume; shadow rays follow the same rule, so a
//!   sheet of α = 0.25 passes 75 % of the light in expectation, and a pixel converges to
//!   `α·L_surface + (1 − α)·L_behind`.
//! - Back faces are culled for camera rays only (the glTF specification's rule for what is
//!   drawn); secondary and shadow rays see both sides, as Cycles does, so a one-sided quad
//!   seen from behind shows what is behind it and still casts its shadow.
//!
//! - An instance's hit (geometry id [`Scene::instance_geom_id`]) is tested as its flattened
//!   twin would be ([`crate::scene::instance::flatten`]): the prototype's triangle moved to
//!   world space corner by corner ([`Instance::corners`], rounded to f32 as flattening rounds
//!   them), two corners swapped under a mirroring transform (as flattening swaps them), the
//!   instance's material if it replaces the prototype's, and the ray in world space as the
//!   caller gave it, never the backend's object-space copy. So an instanced mesh keeps its
//!   cut-outs and its culled back faces, and both backends decide its hits alike; only
//!   BLEND's `ξ` differs from the flattened twin's, since it hashes the instance's own id.
//!
//! A mesh or prototype without such a material costs nothing: Embree attaches the filter only
//! to the geometries that have one, and the native BVH tests only their hits.

use crate::geometry::triangle;
use crate::material::{AlphaMode, Coverage, Material};
use crate::math::{Ray, Vec2};
use crate::scene::{Instance, Mesh, Scene};

/// `ξ ∈ [0, 1)` of a ray meeting triangle `prim` of geometry `geom` (module docs).
#[inline]
pub fn blend_xi(ray: &Ray, geom: u32, prim: u32) -> f32 {
    let words = [
        ray.org.x.to_bits(),
        ray.org.y.to_bits(),
        ray.org.z.to_bits(),
        ray.dir.x.to_bits(),
        ray.dir.y.to_bits(),
        ray.dir.z.to_bits(),
        geom,
        prim,
    ];
    let h = words.iter().fold(0x243f_6a88_85a3_08d3_u64, |h, &w| splitmix64(h ^ w as u64));
    (h >> 40) as f32 * (1.0 / (1u64 << 24) as f32)
}

/// SplitMix64's step and finaliser (Steele, Lea & Flood 2014).
#[inline]
fn splitmix64(x: u64) -> u64 {
    let mut z = x.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// What the test reads of a mesh: its corners, texture coordinates, vertex alphas and
/// materials (normals and colours left out).
#[derive(Debug)]
struct Surface {
    mesh: Mesh,
}

impl Surface {
    fn of(m: &Mesh) -> Surface {
        Surface {
            mesh: Mesh {
                name: m.name.clone(),
                positions: m.positions.clone(),
                indices: m.indices.clone(),
                uvs: m.uvs.clone(),
                uvs1: m.uvs1.clone(),
                alphas: m.alphas.clone(),
                material: m.material,
                triangle_materials: m.triangle_materials.clone(),
                ..Mesh::default()
            },
        }
    }

    /// Bytes of the copy of `m`.
    fn size_of(m: &Mesh) -> usize {
        m.positions.len() * 12
            + m.indices.len() * 12
            + m.uvs.as_ref().map_or(0, |u| u.len() * 8)
            + m.uvs1.as_ref().map_or(0, |u| u.len() * 8)
            + m.alphas.as_ref().map_or(0, |a| a.len() * 4)
            + m.triangle_materials.as_ref().map_or(0, |t| t.len() * 4)
    }
}

/// The alpha and back-face test of a scene's meshes and instances, owned by the backend that
/// calls it.
#[derive(Debug)]
pub struct AlphaTest {
    /// Per mesh (geometry id), its surface when one of its materials has a coverage.
    meshes: Vec<Option<Surface>>,
    /// Per prototype, its surface when an instance of it has a material with a coverage.
    prototypes: Vec<Option<Surface>>,
    /// Per instance (geometry id `first_instance + k`), the instance when it is tested.
    instances: Vec<Option<Instance>>,
    /// The geometry id of instance 0.
    first_instance: u32,
    /// Per material, its coverage.
    materials: Vec<Option<Coverage>>,
}

impl AlphaTest {
    /// The test of `scene`'s meshes and instances, `None` when none has a material with a
    /// coverage (the backends then test nothing).
    pub fn of_scene(scene: &Scene) -> Option<AlphaTest> {
        let (meshes, prototypes, instances) = Self::coverage(scene);
        if !meshes.iter().chain(&instances).any(|&c| c) {
            return None;
        }
        let copies = |list: &[Mesh], covered: &[bool]| -> Vec<Option<Surface>> {
            list.iter().zip(covered).map(|(m, &c)| c.then(|| Surface::of(m))).collect()
        };
        Some(AlphaTest {
            meshes: copies(&scene.meshes, &meshes),
            prototypes: copies(&scene.prototypes, &prototypes),
            instances: scene.instances.iter().zip(&instances).map(|(i, &c)| c.then(|| i.clone())).collect(),
            first_instance: scene.instance_geom_id(0),
            materials: scene.materials.iter().map(|m: &Material| m.coverage.as_deref().cloned()).collect(),
        })
    }

    /// Whether hits on geometry `geom` (a mesh or an instance) are tested at all.
    #[inline]
    pub fn covers(&self, geom: u32) -> bool {
        if let Some(m) = self.meshes.get(geom as usize) {
            return m.is_some();
        }
        let k = geom.checked_sub(self.first_instance);
        k.and_then(|k| self.instances.get(k as usize)).is_some_and(Option::is_some)
    }

    /// Whether hits on some mesh of the scene's own list are tested.
    pub fn covers_any_mesh(&self) -> bool {
        self.meshes.iter().any(Option::is_some)
    }

    /// Whether some instance of prototype `p` is tested: the backends then test the
    /// prototype's hits (and the test passes those of the instances it does not cover).
    pub fn covers_prototype(&self, p: u32) -> bool {
        self.prototypes.get(p as usize).is_some_and(Option::is_some)
    }

    /// Bytes the test holds (its copies of the covered meshes and prototypes).
    pub fn size_bytes(&self) -> usize {
        let surfaces =
            self.meshes.iter().chain(&self.prototypes).flatten().map(|s| Surface::size_of(&s.mesh)).sum::<usize>();
        surfaces + self.instances.iter().flatten().count() * std::mem::size_of::<Instance>()
    }

    /// [`AlphaTest::size_bytes`] of `scene`'s test, found without building it (for the memory
    /// budget, `crate::job::memory`).
    pub fn size_for(scene: &Scene) -> usize {
        let (meshes, prototypes, instances) = Self::coverage(scene);
        let copy = |list: &[Mesh], covered: &[bool]| {
            list.iter().zip(covered).filter(|(_, c)| **c).map(|(m, _)| Surface::size_of(m)).sum::<usize>()
        };
        copy(&scene.meshes, &meshes)
            + copy(&scene.prototypes, &prototypes)
            + instances.iter().filter(|&&c| c).count() * std::mem::size_of::<Instance>()
    }

    /// Which meshes, prototypes and instances of `scene` the test covers: those with a
    /// material that has a coverage (an instance's own material when it replaces the
    /// prototype's), and the prototypes of covered instances.
    fn coverage(scene: &Scene) -> (Vec<bool>, Vec<bool>, Vec<bool>) {
        let covered = |m: u32| scene.materials.get(m as usize).is_some_and(|m| m.coverage.is_some());
        let any_covered = |m: &Mesh, replaced: Option<u32>| match (replaced, &m.triangle_materials) {
            _ if m.indices.is_empty() => false,
            (Some(r), _) => covered(r),
            (None, Some(t)) => t.iter().any(|&i| covered(i)),
            (None, None) => covered(m.material),
        };
        let meshes = scene.meshes.iter().map(|m| any_covered(m, None)).collect();
        let instances: Vec<bool> = scene
            .instances
            .iter()
            .map(|i| scene.prototypes.get(i.prototype as usize).is_some_and(|p| any_covered(p, i.material)))
            .collect();
        let mut prototypes = vec![false; scene.prototypes.len()];
        for (i, _) in scene.instances.iter().zip(&instances).filter(|(_, c)| **c) {
            prototypes[i.prototype as usize] = true;
        }
        (meshes, prototypes, instances)
    }

    /// Whether the hit of `ray` (in world space) on triangle `prim` of geometry `geom` exists
    /// (module docs). Geometries and triangles the test does not know exist.
    #[inline]
    pub fn passes(&self, geom: u32, prim: u32, ray: &Ray) -> bool {
        let p = prim as usize;
        if let Some(mesh) = self.meshes.get(geom as usize) {
            let Some(surface) = mesh else { return true };
            let mesh = &surface.mesh;
            let Some(&idx) = mesh.indices.get(p) else { return true };
            let corners = idx.map(|i| mesh.positions[i as usize]);
            return self.triangle_passes(mesh, mesh.material_of(p), corners, idx, geom, prim, ray);
        }
        let k = geom.checked_sub(self.first_instance);
        let Some(Some(inst)) = k.and_then(|k| self.instances.get(k as usize)) else { return true };
        let Some(Some(surface)) = self.prototypes.get(inst.prototype as usize) else { return true };
        let mesh = &surface.mesh;
        let Some(&(mut idx)) = mesh.indices.get(p) else { return true };
        let mut corners = inst.corners(mesh, p);
        if inst.transform.flips_orientation() {
            // As `Transform::apply_to_mesh` stores the flattened twin's triangle.
            idx.swap(1, 2);
            corners.swap(1, 2);
        }
        self.triangle_passes(mesh, inst.material_of(mesh, p), corners, idx, geom, prim, ray)
    }

    /// The test of one triangle of `mesh` with world-space `corners` (of vertices `idx`).
    #[allow(clippy::too_many_arguments)]
    #[inline]
    fn triangle_passes(
        &self,
        mesh: &Mesh,
        material: u32,
        corners: [crate::math::Vec3; 3],
        idx: [u32; 3],
        geom: u32,
        prim: u32,
        ray: &Ray,
    ) -> bool {
        let Some(Some(c)) = self.materials.get(material as usize) else { return true };
        let idx = idx.map(|i| i as usize);
        if c.cull_back_faces && ray.camera && triangle::normal(corners[0], corners[1], corners[2]).dot(ray.dir) > 0.0 {
            return false;
        }
        let alpha = || {
            // A ray in the triangle's plane has no re-solved hit: its centre stands for it.
            let (u, v) =
                triangle::resolve_f64(ray.org, ray.dir, corners).map_or((1.0 / 3.0, 1.0 / 3.0), |h| (h.u, h.v));
            // Interpolated as shading interpolates (`crate::surface::barycentric2`).
            let w = 1.0 - u - v;
            let uv = |set: &Option<Vec<Vec2>>| set.as_ref().map(|t| w * t[idx[0]] + u * t[idx[1]] + v * t[idx[2]]);
            let uv0 = uv(&mesh.uvs).unwrap_or(Vec2::ZERO);
            let uv1 = uv(&mesh.uvs1).unwrap_or(uv0);
            let vertex = mesh.alphas.as_ref().map_or(1.0, |a| w * a[idx[0]] + u * a[idx[1]] + v * a[idx[2]]);
            c.alpha([uv0, uv1], vertex)
        };
        match c.mode {
            AlphaMode::Opaque => true,
            AlphaMode::Mask { cutoff } => alpha() >= cutoff,
            AlphaMode::Blend => blend_xi(ray, geom, prim) < alpha(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Vec3;

    #[test]
    fn xi_is_uniform_and_depends_on_every_word() {
        let ray = Ray::new(Vec3::new(0.1, 0.2, 0.3), Vec3::new(0.0, 0.6, 0.8));
        let n = 100_000;
        let mut below = [0u32; 4];
        for k in 0..n {
            let xi = blend_xi(&Ray { org: Vec3::new(k as f32 * 1e-3, 0.2, 0.3), ..ray }, 7, 11);
            assert!((0.0..1.0).contains(&xi));
            for (i, b) in below.iter_mut().enumerate() {
                *b += (xi < 0.25 * (i + 1) as f32) as u32;
            }
        }
        for (i, &b) in below.iter().enumerate() {
            let p = 0.25 * (i + 1) as f64;
            let sigma = (n as f64 * p * (1.0 - p)).sqrt().max(1.0);
            assert!((b as f64 - n as f64 * p).abs() < 5.0 * sigma, "P(ξ < {p}) = {}", b as f64 / n as f64);
        }
        let base = blend_xi(&ray, 7, 11);
        assert_ne!(base, blend_xi(&ray, 8, 11));
        assert_ne!(base, blend_xi(&ray, 7, 12));
        assert_ne!(base, blend_xi(&Ray { dir: Vec3::new(0.0, 0.8, 0.6), ..ray }, 7, 11));
        assert_eq!(base, blend_xi(&Ray { tfar: 2.0, tnear: 1.0, ..ray }, 7, 11));
    }
}
