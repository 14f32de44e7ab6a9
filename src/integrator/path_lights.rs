//! The scene's lights as the path tracer samples them: a [`LightSet`] built from the scene
//! (choosing by its `[render] light_sampler`: the light tree by default), and the map from a hit on an emitter (an area light's geometry, a triangle of an emissive
//! mesh) to the light it is, for [`LightSet::pdf_hit`].
//!
//! The environment is the scene's `environment`, or, without one, a constant environment of
//! the scene's `background` when that is not 0 (so the background lights the scene and is
//! sampled as a light). Emitters that are not lights (emissive instances and spheres, or
//! meshes with `mesh_lights = false`) have density 0 there: BSDF sampling alone finds them,
//! with full weight.

use crate::accel::Hit;
use crate::light::environment::Environment;
use crate::light::set::{Emitter, LightSample, LightSet, MeshPoint};
use crate::math::{Vec2, Vec3};
use crate::scene::{GeomKind, Scene};
use crate::surface::{SurfacePoint, texture_coordinates};

use super::lights::mesh_emitters;

/// The scene's [`LightSet`] and the map from hits to its emitters.
pub struct PathLights<'a> {
    scene: &'a Scene,
    set: LightSet,
    /// Per material: the area light whose geometry it is.
    area_of_material: Vec<Option<u32>>,
    /// Per mesh: its emitter.
    emitter_of_mesh: Vec<Option<u32>>,
}

/// The environment the path tracer sees: the scene's, else its non-zero background.
pub fn environment_of(scene: &Scene) -> Option<Environment> {
    scene.environment.clone().or_else(|| {
        let b = scene.image.background;
        (b != Vec3::ZERO).then(|| Environment::constant(b))
    })
}

impl<'a> PathLights<'a> {
    /// The lights of `scene`.
    pub fn new(scene: &'a Scene) -> Self {
        let emitters = mesh_emitters(scene);
        // The area lights' materials were added in the lights' order
        // ([`crate::scene::emitters::add_emitters`]).
        let mut next = 0u32;
        let area_of_material = scene
            .materials
            .iter()
            .map(|m| {
                (m.area_light && (next as usize) < scene.area_lights.len()).then(|| {
                    next += 1;
                    next - 1
                })
            })
            .collect();
        let mut emitter_of_mesh = vec![None; scene.meshes.len()];
        for (k, e) in emitters.iter().enumerate() {
            emitter_of_mesh[e.mesh as usize] = Some(k as u32);
        }
        let bounds = scene.bounds();
        let radius = 0.5 * (bounds.max - bounds.min).length();
        let set = LightSet::new(
            &scene.lights,
            &scene.area_lights,
            emitters,
            environment_of(scene),
            radius,
            scene.render.light_sampler,
        );
        PathLights { scene, set, area_of_material, emitter_of_mesh }
    }

    /// See [`LightSet::sample`]; a point on an emissive mesh gets the radiance its material
    /// emits there ([`PathLights::mesh_radiance`]).
    #[inline]
    pub fn sample(&self, p: Vec3, n: Vec3, u: Vec2) -> Option<(LightSample, f32)> {
        let (mut sample, choice) = self.set.sample(p, n, u)?;
        if let Some(at) = sample.on_mesh {
            sample.radiance = self.mesh_radiance(at, sample.radiance);
        }
        Some((sample, choice))
    }

    /// The radiance leaving the mesh point `at`, where the light set gave the triangle's mean
    /// `mean`: the material's emissive texture looked up at the point's texture coordinates
    /// (as a ray that hits the point sees it, [`crate::shading::shade_at`]), else `mean` as it
    /// is. (The light set already gives no sample behind a one-sided emitter.)
    fn mesh_radiance(&self, at: MeshPoint, mean: Vec3) -> Vec3 {
        let Some(mesh) = self.scene.meshes.get(at.mesh as usize) else { return mean };
        let material = self.scene.materials.get(mesh.material_of(at.prim as usize) as usize);
        match (material.and_then(|m| m.pbr.as_deref()), mesh.indices.get(at.prim as usize)) {
            (Some(pbr), Some(idx)) if pbr.emissive_texture.is_some() => {
                pbr.emission_at(texture_coordinates(mesh, idx.map(|i| i as usize), at.u, at.v))
            }
            _ => mean,
        }
    }

    /// The density (choice × solid angle) with which [`LightSet::sample`] from `p` would have
    /// produced the direction `wi` that reached the emitter hit `hit`, shaded as `sp_light`;
    /// 0 when what was hit is not a light.
    pub fn pdf_hit(&self, p: Vec3, n: Vec3, wi: Vec3, hit: &Hit, sp_light: &SurfacePoint) -> f32 {
        let emitter = if let Some(Some(k)) = self.area_of_material.get(sp_light.material as usize) {
            Emitter::Area(*k)
        } else if let GeomKind::Mesh(m) = self.scene.geom_kind(hit.geom_id) {
            match self.emitter_of_mesh.get(m as usize) {
                Some(Some(e)) => Emitter::Triangle { mesh: *e, prim: hit.prim_id },
                _ => return 0.0,
            }
        } else {
            return 0.0;
        };
        self.set.pdf_hit(p, n, wi, emitter, sp_light.p, sp_light.ng_outward)
    }

    /// See [`LightSet::pdf_environment`].
    #[inline]
    pub fn pdf_environment(&self, p: Vec3, n: Vec3, wi: Vec3) -> f32 {
        self.set.pdf_environment(p, n, wi)
    }

    /// See [`LightSet::environment`].
    #[inline]
    pub fn environment(&self, wi: Vec3) -> Vec3 {
        self.set.environment(wi)
    }
}
