//! The scene as plain data that both backends and the integrator read: world-space triangle
//! meshes, spheres and planes, materials, lights, the camera and the image settings.
//!
//! Loading a scene file ([`load()`]: TOML, and the OBJ and PLY files it names) produces a
//! [`Scene`], with the warnings to show and a summary of each object ([`Loaded`]); so does a
//! lone mesh file ([`from_mesh_file`]) and a lone glTF file ([`from_gltf_file`]). Nothing downstream knows which file format the
//! geometry came from.

pub mod alpha;
pub mod emitters;
pub mod hash;
pub mod instance;
pub mod load;
pub mod magnitude;
pub mod mesh;
pub mod procedural;
pub mod subdivide;
pub mod tangents;
pub mod transform;

pub use instance::Instance;
pub use load::file::{Loaded, ObjectSummary, SceneError, from_mesh_file, from_toml_str, load};
pub use load::gltf_scene::{from_gltf_file, from_gltf_file_lit};
pub use mesh::Mesh;

use crate::geometry::{Plane, Sphere};
use crate::light::Light;
use crate::light::area::AreaLight;
use crate::material::Material;
use crate::math::{Aabb, Vec3};

/// Where the camera stands and looks (the lecture's `e`, `z`, `up`, vertical field of view),
/// and its lens.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraSpec {
    pub eye: Vec3,
    pub target: Vec3,
    pub up: Vec3,
    pub fov_deg: f32,
    pub lens: Lens,
}

/// A thin lens (see [`crate::camera`]): the radius of its aperture and the distance, along the
/// view direction, of the plane it keeps in focus. An aperture of 0 is the lecture's pinhole.
/// An orthographic camera (glTF's) has no lens: parallel rays from an image plane of
/// half-height `ortho_half_height` (glTF `ymag`) through the eye.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Lens {
    /// Radius of the aperture, metres; 0 for a pinhole.
    pub aperture: f32,
    /// Distance of the plane in focus from the eye along the view direction, metres; 0 for
    /// the distance from the eye to the target.
    pub focus_distance: f32,
    /// Half the height of an orthographic camera's view, metres; 0 for a perspective camera.
    pub ortho_half_height: f32,
}

impl Lens {
    /// The lecture's pinhole: everything in focus.
    pub const PINHOLE: Lens = Lens { aperture: 0.0, focus_distance: 0.0, ortho_half_height: 0.0 };
}

impl Default for CameraSpec {
    fn default() -> Self {
        CameraSpec {
            eye: Vec3::new(0.0, 0.0, 5.0),
            target: Vec3::ZERO,
            up: Vec3::Y,
            fov_deg: 40.0,
            lens: Lens::PINHOLE,
        }
    }
}

impl CameraSpec {
    /// A camera looking along −z (up +y) at the centre of `bounds`, from just far enough away
    /// that the bounding sphere fills the vertical field of view `fov_deg`. Empty bounds (a
    /// scene of planes only) are framed as the unit cube at the origin.
    pub fn framing(bounds: Aabb, fov_deg: f32) -> CameraSpec {
        let bounds = if bounds.is_empty() { Aabb::new(Vec3::splat(-0.5), Vec3::splat(0.5)) } else { bounds };
        let target = bounds.centroid();
        let radius = (0.5 * bounds.extent().length()).max(f32::MIN_POSITIVE);
        let distance = radius / (0.5 * fov_deg.to_radians()).sin();
        CameraSpec { eye: target + distance * Vec3::Z, target, up: Vec3::Y, fov_deg, lens: Lens::PINHOLE }
    }
}

/// What to render: size, samples, recursion, and the radiance of rays that escape.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImageSpec {
    pub width: u32,
    pub height: u32,
    /// Samples per pixel (stratified); 1 traces exactly the pixel centre.
    pub spp: u32,
    /// Longest chain of reflected/refracted rays after the primary one.
    pub max_depth: u32,
    /// Radiance of rays that hit nothing.
    pub background: Vec3,
    /// Uniform ambient radiance: a diffuse surface of albedo ρ reflects ρ·ambient.
    pub ambient: Vec3,
    /// Whether meshes with an emitting material light the scene ([`crate::light::mesh`]);
    /// they glow either way.
    pub mesh_lights: bool,
    /// Shadow rays per shading point toward each emitting mesh (`light_samples` of the quad,
    /// disk and sphere lights), 1..=[`crate::light::area::MAX_LIGHT_SAMPLES`].
    pub mesh_light_samples: u32,
}

impl Default for ImageSpec {
    fn default() -> Self {
        ImageSpec {
            width: 640,
            height: 480,
            spp: 1,
            max_depth: 8,
            background: Vec3::ZERO,
            ambient: Vec3::ZERO,
            mesh_lights: true,
            mesh_light_samples: 1,
        }
    }
}

/// Which integrator renders a scene (`[render] integrator`, `--integrator`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum IntegratorKind {
    /// The lecture's ray tracer: direct light, mirrors, glass, an ambient term
    /// ([`crate::integrator::whitted`]). Scenes written for it say so (`[render] integrator =
    /// "whitted"`), as the lecture scenes in `scenes/` do.
    Whitted,
    /// Unidirectional path tracing with next-event estimation and MIS
    /// ([`crate::integrator::path`]): the default.
    #[default]
    Path,
}

impl IntegratorKind {
    /// Its name in the scene file, on the command line and in the EXR header.
    pub fn name(self) -> &'static str {
        match self {
            IntegratorKind::Whitted => "whitted",
            IntegratorKind::Path => "path",
        }
    }

    /// The integrator called `name`, or the one-line reason it is not one.
    pub fn parse(name: &str) -> Result<IntegratorKind, String> {
        match name {
            "whitted" => Ok(IntegratorKind::Whitted),
            "path" => Ok(IntegratorKind::Path),
            _ => Err(format!("integrator {name:?} is not one of \"path\", \"whitted\"")),
        }
    }
}

/// How a scene is rendered beyond the image settings (`[render]`): the integrator, the path
/// tracer's clamp, adaptive sampling, the light sampler and the seed.
#[derive(Clone, Copy, Default, PartialEq)]
pub struct RenderSpec {
    pub integrator: IntegratorKind,
    /// The path tracer's clamp of indirect light: a sample's contribution through two or more
    /// bounces is scaled down so that its largest channel is at most this (`None`: no clamp).
    pub clamp: Option<f32>,
    /// Adaptive sampling (`[render] adaptive_threshold`, `adaptive_min_samples`;
    /// [`crate::integrator::adaptive`]); `None`: every pixel takes `image.spp` samples.
    pub adaptive: Option<AdaptiveSpec>,
    /// How the path tracer chooses a light per shading point (`[render] light_sampler`,
    /// [`crate::light::set`]).
    pub light_sampler: crate::light::set::LightSampler,
    /// The seed of every pixel's sample sequence (`[render] seed`, `--seed`; 0 by default, at
    /// most [`MAX_SEED`]):
    /// renders with different seeds have independent noise ([`crate::sampling::seeded_pixel`]).
    pub seed: u32,
}

/// The largest seed (`[render] seed`, `--seed`): a non-negative 32-bit signed integer, as
/// Blender's (and Cycles') seed and the EXR header's `strahl/seed` hold it.
pub const MAX_SEED: u32 = i32::MAX as u32;

/// Adaptive sampling as the user sets it, Cycles' two settings: the noise threshold and the
/// minimum samples (0: Cycles' automatic rule). [`crate::integrator::adaptive::Adaptive`]
/// turns them into the rule the tile loop applies.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct AdaptiveSpec {
    /// Cycles' noise threshold (> 0; 0.01 is Cycles' default).
    pub threshold: f32,
    /// Samples every pixel takes before it may stop; 0 chooses them from the threshold.
    pub min_samples: u32,
}

impl RenderSpec {
    /// Sets adaptive sampling's threshold (`--adaptive-threshold`), keeping the minimum
    /// samples; 0 turns it off.
    pub fn set_adaptive_threshold(&mut self, threshold: f32) {
        let min_samples = self.adaptive.map_or(0, |a| a.min_samples);
        self.adaptive = (threshold != 0.0).then_some(AdaptiveSpec { threshold, min_samples });
    }

    /// Why these settings cannot be rendered, if they cannot.
    pub fn problem(&self) -> Option<String> {
        if let Some(c) = self.clamp.filter(|c| !(c.is_finite() && *c > 0.0)) {
            return Some(format!("clamp {c} must be finite and > 0"));
        }
        if self.seed > MAX_SEED {
            return Some(format!("seed {} is more than {MAX_SEED}", self.seed));
        }
        let t = self.adaptive.map(|a| a.threshold)?;
        (!(t.is_finite() && t > 0.0)).then(|| format!("adaptive_threshold {t} must be finite and > 0 (0 turns it off)"))
    }
}

/// The fields as text, adaptive sampling only when it is on, the seed only when not 0: scene fingerprints
/// ([`hash`]) hash this text, and those of renders without it stay as they were.
impl std::fmt::Debug for RenderSpec {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let mut d = f.debug_struct("RenderSpec");
        d.field("integrator", &self.integrator).field("clamp", &self.clamp);
        if let Some(a) = &self.adaptive {
            d.field("adaptive", a);
        }
        if self.light_sampler != Default::default() {
            d.field("light_sampler", &self.light_sampler);
        }
        if self.seed != 0 {
            d.field("seed", &self.seed);
        }
        d.finish()
    }
}

/// The largest `image.max_depth` accepted. Reflection and refraction recurse once per
/// bounce; this bounds the stack a worker thread needs (well inside rayon's default), and
/// no image changes visibly beyond it (even between perfect mirrors the `max_depth`-th image
/// is a speck).
pub const MAX_DEPTH_LIMIT: u32 = 256;

/// What kind of object a hit's `geom_id` names.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GeomKind {
    /// `Scene::meshes[i]`; the hit's `prim_id` is the triangle.
    Mesh(u32),
    /// The scene's spheres; the hit's `prim_id` indexes `Scene::spheres`.
    Spheres,
    /// The scene's planes; the hit's `prim_id` indexes `Scene::planes`.
    Planes,
    /// `Scene::instances[i]`; the hit's `prim_id` is the triangle of its prototype.
    Instance(u32),
}

/// A whole scene in world space.
#[derive(Clone, Debug, Default)]
pub struct Scene {
    pub camera: CameraSpec,
    pub image: ImageSpec,
    pub materials: Vec<Material>,
    pub lights: Vec<Light>,
    /// Lights with a shape; their visible geometry is among the meshes and spheres
    /// ([`emitters`]).
    pub area_lights: Vec<AreaLight>,
    pub meshes: Vec<Mesh>,
    pub spheres: Vec<Sphere>,
    pub planes: Vec<Plane>,
    /// The names objects go by in Cryptomatte and the object index ([`ObjectNames`]).
    pub names: ObjectNames,
    /// Passes, alpha and Cryptomatte levels (the `[output]` table).
    pub output: crate::output::passes::OutputSpec,
    /// Meshes stored once in their own object space, placed by [`Self::instances`] (not
    /// traced themselves).
    pub prototypes: Vec<Mesh>,
    /// Placements of the prototypes (see [`instance`]).
    pub instances: Vec<Instance>,
    /// The integrator and its settings (the `[render]` table).
    pub render: RenderSpec,
    /// Radiance from far away along rays that leave the scene (the `[environment]` table,
    /// `--environment`); without one, rays that escape see `image.background`.
    pub environment: Option<crate::light::environment::Environment>,
}

/// The object names of a scene's primitives, filled by the scene loader: `meshes[i]` names
/// `Scene::meshes[i]`, and so on. A primitive beyond the end of its list goes by the mesh's own
/// `name`, `sphere N` or `plane N`. Several primitives may share a name (the spheres of one
/// `random_spheres` object, the groups of a mesh file are `object/group`): they are one object.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct ObjectNames {
    pub meshes: Vec<String>,
    pub spheres: Vec<String>,
    pub planes: Vec<String>,
    /// The camera's name, when the scene file gives it one (a glTF camera's node name, else the
    /// camera's own name): the EXR header's `Camera`, as Blender writes its camera object's name.
    pub camera: Option<String>,
}

impl Scene {
    /// The geometry id of every sphere hit: one past the last mesh.
    pub fn spheres_geom_id(&self) -> u32 {
        self.meshes.len() as u32
    }

    /// The geometry id of every plane hit: two past the last mesh.
    pub fn planes_geom_id(&self) -> u32 {
        self.meshes.len() as u32 + 1
    }

    /// The geometry id of hits on instance `k`: past the planes.
    pub fn instance_geom_id(&self, k: usize) -> u32 {
        self.meshes.len() as u32 + 2 + k as u32
    }

    /// Which object a hit's `geom_id` names (see [`crate::accel::Hit`]).
    pub fn geom_kind(&self, geom_id: u32) -> GeomKind {
        let m = self.meshes.len() as u32;
        match geom_id {
            id if id < m => GeomKind::Mesh(id),
            id if id == m => GeomKind::Spheres,
            id if id == m + 1 => GeomKind::Planes,
            id => GeomKind::Instance(id - m - 2),
        }
    }

    /// The world-space corners of triangle `prim` of a mesh or instance hit's object.
    pub fn world_triangle(&self, kind: GeomKind, prim: usize) -> Option<[Vec3; 3]> {
        match kind {
            GeomKind::Mesh(m) => Some(self.meshes[m as usize].triangle(prim)),
            GeomKind::Instance(k) => {
                let inst = &self.instances[k as usize];
                Some(inst.corners(&self.prototypes[inst.prototype as usize], prim))
            }
            _ => None,
        }
    }

    /// Triangles stored once in the prototypes.
    pub fn prototype_triangle_count(&self) -> usize {
        self.prototypes.iter().map(|m| m.indices.len()).sum()
    }

    /// Triangles the instances place in the world (each prototype counted once per instance).
    pub fn instanced_triangle_count(&self) -> usize {
        self.instances.iter().map(|i| self.prototypes[i.prototype as usize].indices.len()).sum()
    }

    /// Why an instance cannot be traced, if one cannot: a prototype or material that does not
    /// exist, or a prototype mesh that is not traceable.
    pub fn instances_problem(&self) -> Option<(String, String)> {
        if let Some((m, p)) = self.prototypes.iter().find_map(|m| m.problem().map(|e| (m, e))) {
            return Some((format!("prototype '{}'", m.name), p));
        }
        self.instances.iter().enumerate().find_map(|(k, inst)| {
            let object = format!("instance {k} '{}'", inst.name);
            if inst.prototype as usize >= self.prototypes.len() {
                return Some((object, format!("prototype {} does not exist", inst.prototype)));
            }
            inst.material
                .filter(|&m| m as usize >= self.materials.len())
                .map(|m| (object, format!("material {m} does not exist")))
        })
    }

    /// The object name of mesh `i` (see [`ObjectNames`]).
    pub fn mesh_name(&self, i: usize) -> &str {
        self.names.meshes.get(i).unwrap_or(&self.meshes[i].name)
    }

    /// The object name of sphere `i` (see [`ObjectNames`]).
    pub fn sphere_name(&self, i: usize) -> String {
        self.names.spheres.get(i).cloned().unwrap_or_else(|| format!("sphere {i}"))
    }

    /// The object name of plane `i` (see [`ObjectNames`]).
    pub fn plane_name(&self, i: usize) -> String {
        self.names.planes.get(i).cloned().unwrap_or_else(|| format!("plane {i}"))
    }

    /// Total triangle count over all meshes (not the prototypes of instances).
    pub fn triangle_count(&self) -> usize {
        self.meshes.iter().map(|m| m.indices.len()).sum()
    }

    /// Bounds of the meshes, spheres and instances (planes are unbounded and left out).
    pub fn bounds(&self) -> Aabb {
        let meshes = self.meshes.iter().map(|m| m.bounds());
        let spheres = self.spheres.iter().map(|s| s.bounds());
        let proto: Vec<Aabb> = self.prototypes.iter().map(Mesh::bounds).collect();
        let instances = self.instances.iter().map(|i| i.bounds(proto[i.prototype as usize]));
        meshes.chain(spheres).chain(instances).fold(Aabb::EMPTY, Aabb::union)
    }
}
