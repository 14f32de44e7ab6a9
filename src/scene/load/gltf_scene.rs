//! glTF files as scenes: on their own ([`from_gltf_file`]: `strahl render model.gltf`) and as
//! `type = "gltf"` objects of a TOML scene ([`add_gltf`]).
//!
//! The file is read by [`crate::scene::load::gltf`]; here its meshes are placed in the world by their
//! nodes (a mesh that several nodes use is stored once, as a prototype with an instance per
//! node; see [`crate::scene::instance`]), its materials appended to the scene's, its lights added.
//!
//! **Names** (Cryptomatte, the index passes, `strahl info`) are those Blender's glTF importer
//! gives, so that a matte picked by name in a Cycles render of the same file picks the same
//! pixels in strahl's: an object is named by its node, else by its mesh (`Mesh_N` when that has
//! no name either), a material by its name (`Material_N` when it has none). Materials of a glTF
//! object in a TOML scene are named `FILE/NAME`, as a mesh file's are, so that two files'
//! materials stay apart. A lone glTF file also brings its camera (chosen by index, by its name or its node's name,
//! the first by default) and image size (640 pixels wide, the height from the camera's
//! `aspectRatio`, else 480); without a camera it is framed as a lone mesh file is, and without
//! lights it gets the **default light**, a directional light shining along the view direction
//! with irradiance π W/m² (so a white Lambertian surface facing the camera has radiance 1),
//! each said in a warning. A file rendered with an environment (`--environment`) is lit by it
//! and gets no default light.

use std::path::Path;

use super::file::{Loaded, ObjectSummary, SceneError};
use crate::light::Light;
use crate::math::Vec3;
use crate::scene::load::gltf::{GltfCamera, GltfFile, load_gltf};
use crate::scene::transform::Transform;
use crate::scene::{CameraSpec, ImageSpec, Instance, Mesh, Scene};

/// Irradiance of the default light of a glTF file without lights, W/m².
pub const DEFAULT_LIGHT_IRRADIANCE: f32 = std::f32::consts::PI;

/// Adds what `file` (read from `path`) places to `scene`, every node's transform followed by
/// `transform`; `material` replaces every material of the file when given. With
/// `instance_all`, every mesh becomes a prototype (so that TOML `instance` objects can place
/// the file again), else only meshes that several nodes use. With `prefix_materials` the
/// materials are named `FILE/NAME` (module docs). Returns what was added, for
/// `strahl info`, and the placements of the prototypes: (prototype, node transform).
pub fn add_gltf(
    scene: &mut Scene,
    path: &Path,
    file: &GltfFile,
    transform: &Transform,
    material: Option<u32>,
    instance_all: bool,
    prefix_materials: bool,
) -> (ObjectSummary, Vec<(u32, Transform)>) {
    let offset = scene.materials.len() as u32;
    if material.is_none() {
        let name = path.file_name().map_or_else(|| path.display().to_string(), |f| f.to_string_lossy().into());
        for m in &file.materials {
            let mut m = m.clone();
            if prefix_materials {
                m.name = format!("{name}/{}", m.name);
            }
            scene.materials.push(m);
        }
    }
    let meshes_before = scene.meshes.len();
    let prototypes_before = scene.prototypes.len();
    let instances_before = scene.instances.len();
    let with_materials = |mut mesh: Mesh| {
        match material {
            Some(id) => (mesh.material, mesh.triangle_materials) = (id, None),
            None => {
                mesh.material += offset;
                mesh.triangle_materials.iter_mut().flatten().for_each(|t| *t += offset);
            }
        }
        mesh
    };
    // A mesh placed by several nodes is stored once, as a prototype with an instance per node
    // (its alpha and back faces tested per instance, `crate::scene::alpha`); one placed once
    // is flattened into world space.
    let mut uses = vec![0usize; file.meshes.len()];
    file.nodes.iter().for_each(|n| uses[n.mesh] += 1);
    let mut prototype_of: Vec<Option<u32>> = vec![None; file.meshes.len()];
    let mut placements = Vec::new();
    for node in &file.nodes {
        let world = node.transform.then(transform);
        let name = node.name.clone().unwrap_or_else(|| file.meshes[node.mesh].name.clone());
        if uses[node.mesh] > 1 || instance_all {
            let prototype = *prototype_of[node.mesh].get_or_insert_with(|| {
                scene.prototypes.push(with_materials(file.meshes[node.mesh].clone()));
                scene.prototypes.len() as u32 - 1
            });
            scene.instances.push(Instance { name, prototype, transform: world, material: None });
            placements.push((prototype, node.transform));
        } else {
            let mut mesh = with_materials(file.meshes[node.mesh].clone());
            mesh.name = name;
            world.apply_to_mesh(&mut mesh);
            scene.meshes.push(mesh);
        }
    }
    for light in &file.lights {
        scene.lights.push(match *light {
            Light::Point { position, intensity } => Light::Point { position: transform.point(position), intensity },
            Light::Directional { direction, irradiance } => Light::Directional {
                direction: transform.vector_f64(direction.as_dvec3()).normalize().as_vec3(),
                irradiance,
            },
        });
    }
    let mut used: Vec<u32> = Vec::new();
    for m in scene.meshes[meshes_before..].iter().chain(&scene.prototypes[prototypes_before..]) {
        match &m.triangle_materials {
            Some(t) => used.extend(t),
            None => used.push(m.material),
        }
    }
    used.sort_unstable();
    used.dedup();
    let summary = ObjectSummary {
        name: None,
        kind: "gltf",
        file: Some(path.to_owned()),
        triangles: scene.meshes[meshes_before..].iter().map(|m| m.indices.len()).sum::<usize>()
            + scene.instances[instances_before..]
                .iter()
                .map(|i| scene.prototypes[i.prototype as usize].indices.len())
                .sum::<usize>(),
        spheres: 0,
        planes: 0,
        materials: used.into_iter().map(|i| scene.materials[i as usize].name.clone()).collect(),
        degenerate_dropped: 0,
    };
    (summary, placements)
}

/// The placed camera `wanted` names: a camera index (in the file's `cameras`), the camera's own
/// name or the name of its node, in that order; else an error that lists the cameras there are.
fn find_camera<'a>(cameras: &'a [GltfCamera], wanted: &str) -> Result<&'a GltfCamera, String> {
    let by_index = |c: &&GltfCamera| wanted.parse::<usize>().is_ok_and(|i| i == c.index);
    let by_name = |c: &&GltfCamera| c.name.as_deref() == Some(wanted);
    let by_node = |c: &&GltfCamera| c.node_name.as_deref() == Some(wanted);
    let found = cameras.iter().find(by_index).or_else(|| cameras.iter().find(by_name));
    if let Some(camera) = found.or_else(|| cameras.iter().find(by_node)) {
        return Ok(camera);
    }
    if cameras.is_empty() {
        return Err(format!("--camera {wanted:?}: the file has no camera"));
    }
    let describe = |c: &GltfCamera| {
        let mut words = vec![format!("index {}", c.index)];
        words.extend(c.name.as_ref().map(|n| format!("name {n:?}")));
        words.extend(c.node_name.as_ref().map(|n| format!("node {n:?}")));
        words.join(", ")
    };
    let list: Vec<String> = cameras.iter().map(describe).collect();
    Err(format!(
        "no camera matches --camera {wanted:?} (by index, name or node name); the cameras are: {}",
        list.join("; ")
    ))
}

/// A scene of the one glTF file at `path`: its meshes, materials and lights (the default light
/// when it has none), and its camera `camera` (a camera index, or the name of a camera or of
/// its node; the first when `None`).
pub fn from_gltf_file(path: &Path, camera: Option<&str>) -> Result<Loaded, SceneError> {
    from_gltf_file_lit(path, camera, false)
}

/// [`from_gltf_file`] for a render that gives the scene an environment (`lit_by_environment`):
/// the environment lights the scene, so a file without lights gets no default light.
pub fn from_gltf_file_lit(path: &Path, camera: Option<&str>, lit_by_environment: bool) -> Result<Loaded, SceneError> {
    let invalid = |message: String| SceneError::Invalid { path: path.to_owned(), message };
    let file = load_gltf(path)?;
    let mut warnings = file.warnings.clone();
    let mut scene = Scene::default();
    let (summary, _) = add_gltf(&mut scene, path, &file, &Transform::default(), None, false, false);
    let chosen = match camera {
        None => file.cameras.first(),
        Some(wanted) => Some(find_camera(&file.cameras, wanted).map_err(invalid)?),
    };
    scene.image = ImageSpec::default();
    match chosen {
        Some(c) => {
            scene.camera = c.spec;
            scene.names.camera = c.node_name.clone().or_else(|| c.name.clone());
            if let Some(aspect) = c.aspect_ratio.filter(|a| a.is_finite() && *a > 0.0) {
                scene.image.height = ((scene.image.width as f32 / aspect).round() as u32).max(1);
            }
            if let Some((_, problem)) = super::file::camera_problem(&scene.camera) {
                return Err(invalid(format!("camera {}: {problem}", c.index)));
            }
        }
        None => {
            scene.camera = CameraSpec::framing(scene.bounds(), CameraSpec::default().fov_deg);
            warnings.push(format!("{}: has no camera; framing the scene from +z", path.display()));
        }
    }
    if scene.lights.is_empty() && !emits(&scene) && !lit_by_environment {
        let direction = (scene.camera.target - scene.camera.eye).normalize();
        scene.lights.push(Light::Directional { direction, irradiance: Vec3::splat(DEFAULT_LIGHT_IRRADIANCE) });
        warnings.push(format!(
            "{}: has no lights; added a directional light along the view direction (irradiance π W/m²)",
            path.display()
        ));
    }
    crate::scene::magnitude::check(path, &scene)?;
    Ok(Loaded { scene, warnings, objects: vec![summary] })
}

/// Whether some mesh of `scene` has an emitting material: such a file lights itself, and gets
/// no added light.
fn emits(scene: &Scene) -> bool {
    let emissive = |m: u32| scene.materials.get(m as usize).is_some_and(|m| m.emission != Vec3::ZERO);
    scene.meshes.iter().any(|mesh| match &mesh.triangle_materials {
        Some(ids) => ids.iter().any(|&m| emissive(m)),
        None => emissive(mesh.material),
    })
}
