//! The lights as a shading point samples them, shared by every integrator.
//!
//! A point casts one shadow ray per [`LightSlot`]: one per point or directional light, then
//! `light_samples` per area light ([`crate::light::area`]), then `mesh_light_samples` per
//! emissive mesh ([`crate::light::mesh`], built by [`mesh_emitters`]), in that order, which is
//! the order their light is added. A slot's [`Incidence`] gives the direction to the light,
//! its distance and the irradiance `E` on a surface facing it: `E = I/d²` for a point light of
//! intensity `I` at distance `d`, `E` itself for a directional light, and for a sampled point
//! of an area light or emissive mesh `E = L·cosθ_l/(d²·pdf_A)/samples`. The sample points are
//! stratified across the pixel's samples ([`SampleDims::light`]).
//!
//! The shadow ray ([`shadow_ray`]) starts at the hit point moved off the surface
//! ([`crate::math::offset_ray_origin`], to the side of the geometric normal) and ends just
//! short of a light at a finite distance ([`SHADOW_TFAR_SCALE`]), so that a light does not
//! shadow itself and a surface a light sits on does not shadow it; a light behind the surface
//! (by the shading or the geometric normal) casts none.

use crate::light::Incidence;
use crate::light::mesh::MeshEmitter;
use crate::math::{Ray, Vec3};
use crate::sampler::{SampleDims, strata};
use crate::scene::Scene;
use crate::surface::SurfacePoint;

/// A shadow ray towards a point light at distance `d` ends at `d·SHADOW_TFAR_SCALE`, just short
/// of the light, so that a surface the light sits on does not shadow it.
pub const SHADOW_TFAR_SCALE: f32 = 1.0 - 1e-4;

/// One shadow ray a shading point may cast: towards a point or directional light, or sample
/// `j` (of the stratum grid `grid`) of an area light or an emissive mesh.
#[derive(Clone, Copy, Debug)]
pub enum LightSlot {
    Delta(usize),
    Area { light: usize, j: u32, grid: (u32, u32) },
    Emitter { emitter: usize, j: u32, grid: (u32, u32) },
}

/// The lights of a scene: its point, directional and area lights, and its emissive meshes.
pub struct Lights<'a> {
    scene: &'a Scene,
    /// The scene's emissive meshes, lighting it ([`mesh_emitters`]).
    pub emitters: Vec<MeshEmitter>,
}

impl<'a> Lights<'a> {
    /// The lights of `scene`.
    pub fn new(scene: &'a Scene) -> Self {
        Lights { scene, emitters: mesh_emitters(scene) }
    }

    /// Whether any light is sampled at points (an area light or an emissive mesh): then a
    /// pixel needs its light sample dimensions ([`SampleDims::new`]).
    pub fn sampled(&self) -> bool {
        !(self.scene.area_lights.is_empty() && self.emitters.is_empty())
    }

    /// Every shadow ray a shading point may cast, in the order their light is added: the point
    /// and directional lights, then each area light's samples, then each emissive mesh's.
    pub fn slots(&self) -> impl Iterator<Item = LightSlot> + '_ {
        let delta = (0..self.scene.lights.len()).map(LightSlot::Delta);
        let area = self.scene.area_lights.iter().enumerate().flat_map(|(light, l)| {
            let grid = strata(l.samples);
            (0..l.samples).map(move |j| LightSlot::Area { light, j, grid })
        });
        let emitters = self.emitters.iter().enumerate().flat_map(|(emitter, e)| {
            let grid = strata(e.samples);
            (0..e.samples).map(move |j| LightSlot::Emitter { emitter, j, grid })
        });
        delta.chain(area).chain(emitters)
    }

    /// How the light of `slot` reaches `p`, drawing its sample point from `dims`.
    #[inline]
    pub fn incidence(&self, slot: &LightSlot, p: Vec3, dims: &mut SampleDims) -> Option<Incidence> {
        match *slot {
            LightSlot::Delta(i) => self.scene.lights[i].incidence(p),
            LightSlot::Area { light, j, grid } => self.scene.area_lights[light].sample(p, dims.light(j, grid)),
            LightSlot::Emitter { emitter, j, grid } => self.emitters[emitter].sample(p, dims.light(j, grid)),
        }
    }
}

/// The emitters of `scene`: one per mesh with emitting triangles of non-zero area (none when
/// the scene's `image.mesh_lights` is off). A triangle emits when its material's `emission`
/// is finite and not 0, unless the material is an area light's own geometry (that light is
/// sampled as itself).
pub fn mesh_emitters(scene: &Scene) -> Vec<MeshEmitter> {
    if !scene.image.mesh_lights {
        return Vec::new();
    }
    let samples = scene.image.mesh_light_samples.max(1);
    // Each material's radiance as an emitter: its emission if finite, 0 for an area light's.
    let radiance: Vec<Vec3> = scene
        .materials
        .iter()
        .map(|m| if !m.area_light && m.emission.is_finite() { m.emission } else { Vec3::ZERO })
        .collect();
    let radiance = |m: u32| radiance.get(m as usize).copied().unwrap_or(Vec3::ZERO);
    // Every triangle is given (those that do not emit with radiance 0, which the emitter
    // leaves out, their corners not read), so the emitter knows its triangles by their index
    // in the mesh; a mesh none of whose materials emits is passed over.
    let emitting = |mesh: &crate::scene::Mesh, i: usize| {
        let l = radiance(mesh.material_of(i));
        (if l == Vec3::ZERO { [Vec3::ZERO; 3] } else { mesh.triangle(i) }, l)
    };
    let meshes = scene.meshes.iter().enumerate();
    meshes
        .filter(|(_, mesh)| match &mesh.triangle_materials {
            None => radiance(mesh.material) != Vec3::ZERO,
            Some(per_triangle) => per_triangle.iter().any(|&m| radiance(m) != Vec3::ZERO),
        })
        .filter_map(|(k, mesh)| {
            let e = MeshEmitter::new(k as u32, samples, (0..mesh.indices.len()).map(|i| emitting(mesh, i)))?;
            let one_sided = |i: u32| {
                scene.materials.get(mesh.material_of(i as usize) as usize).is_some_and(|m| m.emission_one_sided)
            };
            Some(e.with_front_only(one_sided))
        })
        .collect()
}

/// The shadow ray from `origin` (the hit point moved off the surface) towards the light of
/// `inc`, ending just short of a light at a finite distance; `None` when the light is behind
/// the surface (self-shadowed without a ray).
#[inline]
pub fn shadow_ray(sp: &SurfacePoint, origin: Vec3, inc: &Incidence) -> Option<Ray> {
    let cos = sp.ns.dot(inc.to_light);
    if cos <= 0.0 || sp.ng.dot(inc.to_light) <= 0.0 {
        return None;
    }
    Some(if inc.distance.is_finite() {
        let to = (sp.p + inc.distance * inc.to_light) - origin;
        let d = to.length();
        Ray::segment(origin, to / d, 0.0, d * SHADOW_TFAR_SCALE)
    } else {
        Ray::new(origin, inc.to_light)
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::Material;
    use crate::scene::Mesh;

    /// The unit square at height 1, emitting 2 through material 0.
    fn square_scene() -> Scene {
        let mut scene = Scene::default();
        scene.materials.push(Material { emission: Vec3::splat(2.0), ..Material::default() });
        scene.meshes.push(Mesh {
            positions: vec![
                Vec3::new(-0.5, 1.0, -0.5),
                Vec3::new(0.5, 1.0, -0.5),
                Vec3::new(0.5, 1.0, 0.5),
                Vec3::new(-0.5, 1.0, 0.5),
            ],
            indices: vec![[0, 1, 2], [0, 2, 3]],
            ..Mesh::default()
        });
        scene
    }

    #[test]
    fn an_emitting_mesh_is_a_light_unless_mesh_lights_is_off_or_it_is_an_area_lights_geometry() {
        let scene = square_scene();
        let [e] = &mesh_emitters(&scene)[..] else { panic!("one emitter") };
        assert_eq!((e.mesh, e.samples), (0, 1));
        assert!((e.area() - 1.0).abs() < 1e-12);
        let mut off = square_scene();
        off.image.mesh_lights = false;
        assert!(mesh_emitters(&off).is_empty());
        let mut own = square_scene();
        own.materials[0].area_light = true;
        assert!(mesh_emitters(&own).is_empty());
        let mut dark = square_scene();
        dark.materials[0].emission = Vec3::ZERO;
        assert!(mesh_emitters(&dark).is_empty());
        let mut samples = square_scene();
        samples.image.mesh_light_samples = 0;
        assert_eq!(mesh_emitters(&samples)[0].samples, 1);
    }
}
