//! The geometry that makes area lights visible: every
//! [`AreaLight`](crate::light::area::AreaLight) of a scene also becomes an object that camera,
//! mirror and glass rays hit, with a material that emits the light's radiance (on its front
//! only, unless the light is two-sided) and reflects nothing.
//!
//! A quad is two triangles wound so that their normal is `edge1 × edge2`, a sphere an exact
//! sphere, and a disk a fan of [`DISK_SEGMENTS`] triangles inscribed in the circle: its area is
//! `(N/2π)·sin(2π/N)` of the disk's, 0.9999 for N = 256, so the visible disk is smaller
//! than the lit one by 1e-4 of its area (samples stay on the exact disk; a shadow ray ends short
//! of its light sample, so the fan never hides the light it draws). The objects are named
//! `area light N` (Cryptomatte, object index) and so are their materials.

use crate::geometry::Sphere;
use crate::light::area::{Shape, basis};
use crate::material::{Material, Texture};
use crate::math::Vec3;
use crate::scene::{Mesh, Scene};

/// Triangles of the fan that draws a disk light.
pub const DISK_SEGMENTS: u32 = 256;

/// Adds the visible geometry of every area light of `scene`, after its other objects.
pub fn add_emitters(scene: &mut Scene) {
    for k in 0..scene.area_lights.len() {
        let light = scene.area_lights[k];
        let name = format!("area light {k}");
        let material = scene.materials.len() as u32;
        scene.materials.push(Material {
            name: name.clone(),
            diffuse: Texture::Constant(Vec3::ZERO),
            emission: light.radiance,
            emission_one_sided: !light.two_sided,
            area_light: true,
            ..Material::default()
        });
        let mesh = |positions: Vec<Vec3>, indices: Vec<[u32; 3]>| Mesh {
            name: name.clone(),
            positions,
            indices,
            material,
            ..Mesh::default()
        };
        match light.shape {
            Shape::Quad { corner, edge1, edge2 } => {
                let corners = vec![corner, corner + edge1, corner + edge1 + edge2, corner + edge2];
                push_mesh(scene, mesh(corners, vec![[0, 1, 2], [0, 2, 3]]));
            }
            Shape::Disk { center, normal, radius } => {
                let (t, b) = basis(normal.as_dvec3().normalize());
                let mut positions = vec![center];
                positions.extend((0..DISK_SEGMENTS).map(|i| {
                    let phi = std::f64::consts::TAU * i as f64 / DISK_SEGMENTS as f64;
                    (center.as_dvec3() + radius as f64 * (phi.cos() * t + phi.sin() * b)).as_vec3()
                }));
                let indices = (0..DISK_SEGMENTS).map(|i| [0, 1 + i, 1 + (i + 1) % DISK_SEGMENTS]).collect();
                push_mesh(scene, mesh(positions, indices));
            }
            Shape::Sphere { center, radius } => {
                if scene.names.spheres.len() == scene.spheres.len() {
                    scene.names.spheres.push(name.clone());
                }
                scene.spheres.push(Sphere { center, radius, material });
            }
        }
    }
}

fn push_mesh(scene: &mut Scene, mesh: Mesh) {
    if scene.names.meshes.len() == scene.meshes.len() {
        scene.names.meshes.push(mesh.name.clone());
    }
    scene.meshes.push(mesh);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::light::area::AreaLight;

    #[test]
    fn quads_face_their_light_and_disks_are_inscribed() {
        let mut scene = Scene::default();
        let quad = Shape::Quad { corner: Vec3::ZERO, edge1: Vec3::Z, edge2: Vec3::X };
        let disk = Shape::Disk { center: Vec3::Y, normal: Vec3::NEG_Y, radius: 2.0 };
        for shape in [quad, disk] {
            scene.area_lights.push(AreaLight { shape, radiance: Vec3::ONE, two_sided: false, samples: 1 });
        }
        add_emitters(&mut scene);
        let normal = |m: &Mesh, i: usize| {
            let [a, b, c] = m.triangle(i);
            (b - a).cross(c - a).normalize()
        };
        // edge1 × edge2 = z × x = y.
        assert_eq!(normal(&scene.meshes[0], 0), Vec3::Y);
        assert_eq!(normal(&scene.meshes[0], 1), Vec3::Y);
        let disk = &scene.meshes[1];
        assert_eq!(disk.indices.len(), DISK_SEGMENTS as usize);
        for i in 0..disk.indices.len() {
            assert!((normal(disk, i) - Vec3::NEG_Y).length() < 1e-6);
        }
        for p in &disk.positions[1..] {
            assert!(((*p - Vec3::Y).length() - 2.0).abs() < 1e-6 && (p.y - 1.0).abs() < 1e-7);
        }
        assert!(scene.materials.iter().all(|m| m.emission == Vec3::ONE && m.emission_one_sided));
        assert_eq!(scene.mesh_name(1), "area light 1");
    }
}
