//! The `[[objects]]` of a scene file: spheres, planes, inline triangles, seeded random sphere
//! fields, mesh files (OBJ, PLY) and glTF files, each with a material by name and a transform.
//!
//! One flat table type with a `type` key rather than a serde-tagged enum, because a tagged
//! enum buffers its content and loses the spans; the keys a type does not take are rejected
//! by hand ([`ObjectKind::fields`]).

use std::cell::RefCell;
use std::collections::{BTreeMap, BTreeSet};
use std::ops::Range;
use std::path::{Path, PathBuf};

use glam::DVec3;
use serde::Deserialize;
use toml::Spanned;

use super::{
    Fixed, MAX_RANDOM_SPHERES, Problem, Triple, V3, at, direction, fmt3, is_finite32, number, point, required,
};
use crate::geometry::Sphere;
use crate::math::{Aabb, Vec3};
use crate::scene::load::{MeshError, MeshOptions, load_mesh};
use crate::scene::transform::Transform;
use crate::scene::{Instance, Mesh, Scene, procedural, subdivide};

/// Most triangles a `mesh` object's `subdivide` may make (2²⁵, about 3 GB with its BVH).
pub const MAX_SUBDIVIDED_TRIANGLES: u64 = 1 << 25;

#[derive(Deserialize, Clone, Copy, Debug, PartialEq)]
#[serde(rename_all = "snake_case")]
enum ObjectKind {
    Sphere,
    Plane,
    Triangles,
    RandomSpheres,
    Mesh,
    Gltf,
    Instance,
}

impl ObjectKind {
    fn name(self) -> &'static str {
        match self {
            ObjectKind::Sphere => "sphere",
            ObjectKind::Plane => "plane",
            ObjectKind::Triangles => "triangles",
            ObjectKind::RandomSpheres => "random_spheres",
            ObjectKind::Mesh => "mesh",
            ObjectKind::Gltf => "gltf",
            ObjectKind::Instance => "instance",
        }
    }

    /// The keys an object of this type takes besides `type`.
    fn fields(self) -> &'static [&'static str] {
        match self {
            ObjectKind::Sphere => &["name", "material", "translate", "rotate_deg", "scale", "center", "radius"],
            ObjectKind::Plane => {
                &["name", "material", "translate", "rotate_deg", "scale", "normal", "distance", "point"]
            }
            ObjectKind::Triangles => {
                &["name", "material", "translate", "rotate_deg", "scale", "positions", "indices", "normals", "colors"]
            }
            ObjectKind::RandomSpheres => &[
                "name",
                "material",
                "materials",
                "translate",
                "rotate_deg",
                "scale",
                "count",
                "seed",
                "bounds",
                "radii",
            ],
            ObjectKind::Mesh => {
                &["name", "material", "translate", "rotate_deg", "scale", "path", "smooth_normals", "subdivide"]
            }
            ObjectKind::Gltf => &["name", "material", "translate", "rotate_deg", "scale", "path"],
            ObjectKind::Instance => &["name", "material", "translate", "rotate_deg", "scale", "of"],
        }
    }
}

/// Every object type's keys in one table; [`ObjectKind::fields`] says which a type takes.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct ObjectFile {
    #[serde(rename = "type")]
    kind: Spanned<ObjectKind>,
    name: Option<Spanned<String>>,
    material: Option<Spanned<String>>,
    materials: Option<Spanned<Vec<Spanned<String>>>>,
    translate: Option<Spanned<V3>>,
    rotate_deg: Option<Spanned<V3>>,
    scale: Option<Spanned<Triple>>,
    // sphere
    center: Option<Spanned<V3>>,
    radius: Option<Spanned<f64>>,
    // plane
    normal: Option<Spanned<V3>>,
    distance: Option<Spanned<f64>>,
    point: Option<Spanned<V3>>,
    // triangles
    positions: Option<Spanned<Vec<V3>>>,
    indices: Option<Spanned<Vec<Fixed<u32, 3>>>>,
    normals: Option<Spanned<Vec<V3>>>,
    colors: Option<Spanned<Vec<V3>>>,
    // random_spheres
    count: Option<Spanned<u64>>,
    seed: Option<Spanned<u64>>,
    bounds: Option<Spanned<Fixed<V3, 2>>>,
    radii: Option<Spanned<Fixed<f64, 2>>>,
    // instance
    of: Option<Spanned<String>>,
    // mesh
    path: Option<Spanned<String>>,
    smooth_normals: Option<Spanned<bool>>,
    subdivide: Option<Spanned<u32>>,
}

impl ObjectFile {
    /// The keys present in this table (besides `type`) and their spans.
    fn fields(&self) -> Vec<(&'static str, Range<usize>)> {
        let mut present = Vec::new();
        macro_rules! collect {
            ($($field:ident),*) => {
                $(if let Some(value) = &self.$field {
                    present.push((stringify!($field), value.span()));
                })*
            };
        }
        collect!(name, material, materials, translate, rotate_deg, scale, center, radius, normal, distance, point);
        collect!(positions, indices, normals, colors, count, seed, bounds, radii, path, smooth_normals, of);
        collect!(subdivide);
        present
    }
}

/// What an object needs from the rest of the file.
pub(super) struct ObjectContext<'a> {
    pub(super) span: Range<usize>,
    pub(super) index: usize,
    pub(super) materials: &'a BTreeMap<&'a str, u32>,
    pub(super) base: &'a Path,
    /// Names of the objects that `instance` objects place again: their meshes are stored
    /// once, as prototypes.
    pub(super) instanced: &'a BTreeSet<String>,
    /// The prototypes each such object placed, with their transform within the object.
    pub(super) placements: &'a RefCell<BTreeMap<String, Vec<(u32, Transform)>>>,
}

impl ObjectContext<'_> {
    fn material(&self, name: &Spanned<String>) -> Result<u32, Problem> {
        self.materials.get(name.get_ref().as_str()).copied().ok_or_else(|| {
            let known: Vec<&str> = self.materials.keys().copied().collect();
            let known =
                if known.is_empty() { "none is defined".to_string() } else { format!("known: {}", known.join(", ")) };
            at(name.span(), format!("unknown material '{}' ({known})", name.get_ref()))
        })
    }
}

/// What one `[[objects]]` entry added to the scene (for `strahl info`).
#[derive(Clone, Debug, PartialEq)]
pub struct ObjectSummary {
    /// The object's `name`, if it has one.
    pub name: Option<String>,
    /// Its `type`: `sphere`, `plane`, `triangles`, `random_spheres`, `mesh` or `gltf`.
    pub kind: &'static str,
    /// The file a `mesh` object loaded, resolved against the scene file's folder.
    pub file: Option<PathBuf>,
    pub triangles: usize,
    pub spheres: usize,
    pub planes: usize,
    /// The names of the materials its primitives use, in the scene's material order.
    pub materials: Vec<String>,
    /// Triangles of zero area in the mesh file, dropped (not in `triangles`).
    pub degenerate_dropped: usize,
}

impl ObjectSummary {
    /// What an object of type `kind` added to `scene`: everything past the counts `before`
    /// (meshes, spheres, planes).
    fn of(
        scene: &Scene,
        before: (usize, usize, usize, usize),
        name: Option<String>,
        kind: &'static str,
        report: &FileReport,
    ) -> ObjectSummary {
        let (meshes, spheres, planes, instances) = before;
        let mut used = BTreeSet::new();
        for m in &scene.meshes[meshes..] {
            match &m.triangle_materials {
                Some(per_triangle) => used.extend(per_triangle.iter().copied()),
                None => {
                    used.insert(m.material);
                }
            }
        }
        for inst in &scene.instances[instances..] {
            let m = &scene.prototypes[inst.prototype as usize];
            match (inst.material, &m.triangle_materials) {
                (Some(id), _) => {
                    used.insert(id);
                }
                (None, Some(per_triangle)) => used.extend(per_triangle.iter().copied()),
                (None, None) => {
                    used.insert(m.material);
                }
            }
        }
        used.extend(scene.spheres[spheres..].iter().map(|s| s.material));
        used.extend(scene.planes[planes..].iter().map(|p| p.material));
        ObjectSummary {
            name,
            kind,
            file: report.file.clone(),
            triangles: scene.meshes[meshes..].iter().map(|m| m.indices.len()).sum::<usize>()
                + scene.instances[instances..]
                    .iter()
                    .map(|i| scene.prototypes[i.prototype as usize].indices.len())
                    .sum::<usize>(),
            spheres: scene.spheres.len() - spheres,
            planes: scene.planes.len() - planes,
            materials: used.into_iter().map(|i| scene.materials[i as usize].name.clone()).collect(),
            degenerate_dropped: report.degenerate_dropped,
        }
    }
}

/// Names what an object added to `scene` past the counts `before` in [`Scene::names`]: a
/// named object's primitives take its name (`name/group` for the several meshes of one file),
/// an unnamed object's meshes keep their own names and its spheres and planes are `object N`.
fn name_objects(scene: &mut Scene, before: (usize, usize, usize), name: Option<&str>, index: usize) {
    let (meshes, spheres, planes) = before;
    // Every object is named as it is added, so the lists already end at `before`.
    scene.names.meshes.truncate(meshes);
    scene.names.spheres.truncate(spheres);
    scene.names.planes.truncate(planes);
    let own = name.map_or_else(|| format!("object {index}"), str::to_string);
    let several = scene.meshes.len() - meshes > 1;
    for m in &scene.meshes[meshes..] {
        scene.names.meshes.push(match name {
            Some(n) if several => format!("{n}/{}", m.name),
            Some(n) => n.to_string(),
            None => m.name.clone(),
        });
    }
    scene.names.spheres.extend(std::iter::repeat_n(own.clone(), scene.spheres.len() - spheres));
    scene.names.planes.extend(std::iter::repeat_n(own, scene.planes.len() - planes));
}

impl ObjectFile {
    /// The object an `instance` object names in `of`.
    pub(super) fn instance_of(&self) -> Option<String> {
        (*self.kind.get_ref() == ObjectKind::Instance).then(|| self.of.as_ref().map(|o| o.get_ref().clone())).flatten()
    }

    /// How errors name this object: `object 3 (sphere)` or `object 'ball' (sphere)`.
    pub(super) fn label(&self, index: usize) -> String {
        match &self.name {
            Some(name) => format!("object '{}' ({})", name.get_ref(), self.kind.get_ref().name()),
            None => format!("object {index} ({})", self.kind.get_ref().name()),
        }
    }

    /// Checks the object, adds what it makes to `scene`, and says what it added. The warnings
    /// of a mesh file come back as problems at the object's `path`.
    pub(super) fn add_to(
        &self,
        scene: &mut Scene,
        ctx: &ObjectContext,
    ) -> Result<(ObjectSummary, Vec<Problem>), Problem> {
        let before = (scene.meshes.len(), scene.spheres.len(), scene.planes.len(), scene.instances.len());
        let report = self.add_geometry(scene, ctx)?;
        let name = self.name.as_ref().map(|n| n.get_ref().clone());
        name_objects(scene, (before.0, before.1, before.2), name.as_deref(), ctx.index);
        let summary = ObjectSummary::of(scene, before, name, self.kind.get_ref().name(), &report);
        let span = self.path.as_ref().map_or_else(|| ctx.span.clone(), |p| p.span());
        Ok((summary, report.warnings.into_iter().map(|w| at(span.clone(), w)).collect()))
    }

    /// Checks the object and adds its primitives to `scene`.
    fn add_geometry(&self, scene: &mut Scene, ctx: &ObjectContext) -> Result<FileReport, Problem> {
        let kind = *self.kind.get_ref();
        if let Some((key, span)) = self.fields().into_iter().find(|(key, _)| !kind.fields().contains(key)) {
            let takes = kind.fields().join(", ");
            return Err(at(span, format!("a {} has no `{key}` (it takes {takes})", kind.name())));
        }
        let transform = self.transform()?;
        let material = |ctx: &ObjectContext| ctx.material(required(&self.material, "material", &ctx.span)?);
        match kind {
            ObjectKind::Sphere => {
                let center = point(required(&self.center, "center", &ctx.span)?, "center")?;
                let radius_value = required(&self.radius, "radius", &ctx.span)?;
                let radius = number(radius_value, "radius")?;
                if radius <= 0.0 {
                    return Err(at(radius_value.span(), format!("radius {radius} must be > 0")));
                }
                let sphere = Sphere { center: center.as_vec3(), radius: radius as f32, material: material(ctx)? };
                let span = self.scale.as_ref().map_or(ctx.span.clone(), |s| s.span());
                scene.spheres.push(transform.apply_to_sphere(&sphere).map_err(|m| at(span, m))?);
            }
            ObjectKind::Plane => {
                let normal = direction(required(&self.normal, "normal", &ctx.span)?, "normal")?;
                let dist = match (&self.distance, &self.point) {
                    (Some(d), None) => number(d, "distance")?,
                    (None, Some(p)) => normal.dot(point(p, "point")?),
                    (Some(_), Some(p)) => return Err(at(p.span(), "give either `distance` or `point`, not both")),
                    (None, None) => return Err(at(ctx.span.clone(), "missing `distance` (or `point`)")),
                };
                let material = material(ctx)?;
                scene.planes.push(transform.apply_to_plane(normal, dist, material));
            }
            ObjectKind::Triangles => {
                let mut mesh = self.inline_mesh(ctx)?;
                mesh.material = material(ctx)?;
                self.place(scene, ctx, vec![mesh], &transform);
            }
            ObjectKind::RandomSpheres => {
                let materials = match (&self.material, &self.materials) {
                    (Some(m), None) => vec![ctx.material(m)?],
                    (None, Some(list)) if !list.get_ref().is_empty() => {
                        list.get_ref().iter().map(|m| ctx.material(m)).collect::<Result<_, _>>()?
                    }
                    (None, Some(list)) => return Err(at(list.span(), "`materials` is empty")),
                    (Some(_), Some(list)) => {
                        return Err(at(list.span(), "give either `material` or `materials`, not both"));
                    }
                    (None, None) => return Err(at(ctx.span.clone(), "missing `material` (or `materials`)")),
                };
                let span = self.scale.as_ref().map_or(ctx.span.clone(), |s| s.span());
                for (i, s) in self.random_spheres(ctx, scene.spheres.len())?.iter_mut().enumerate() {
                    s.material = materials[i % materials.len()];
                    scene.spheres.push(transform.apply_to_sphere(s).map_err(|m| at(span.clone(), m))?);
                }
            }
            ObjectKind::Mesh => {
                let path = required(&self.path, "path", &ctx.span)?;
                let material = self.material.as_ref().map(|m| ctx.material(m)).transpose()?;
                let options =
                    MeshOptions { smooth_normals: self.smooth_normals.as_ref().is_some_and(|s| *s.get_ref()) };
                let file = ctx.base.join(path.get_ref());
                let levels = self.subdivide.as_ref().map_or(0, |l| *l.get_ref());
                if let Some(l) = self.subdivide.as_ref().filter(|l| *l.get_ref() > subdivide::MAX_LEVELS) {
                    return Err(at(l.span(), format!("`subdivide` is {levels}, at most {}", subdivide::MAX_LEVELS)));
                }
                let (mut meshes, report) =
                    load_mesh_file(&file, &options, material, scene).map_err(|e| at(path.span(), e.to_string()))?;
                if let Some(l) = &self.subdivide {
                    let triangles = meshes.iter().map(|m| m.indices.len()).sum();
                    let after = subdivide::triangles_after(triangles, levels).unwrap_or(u64::MAX);
                    if after > MAX_SUBDIVIDED_TRIANGLES {
                        return Err(at(
                            l.span(),
                            format!(
                                "`subdivide = {levels}` makes {after} triangles of {triangles}, more than \
                                 {MAX_SUBDIVIDED_TRIANGLES} (use fewer levels, or instances of a smaller mesh)"
                            ),
                        ));
                    }
                    meshes = meshes.iter().map(|m| subdivide::subdivide(m, levels)).collect();
                }
                self.place(scene, ctx, meshes, &transform);
                return Ok(report);
            }
            ObjectKind::Instance => {
                // The named object's prototypes again, each by its transform within that
                // object followed by this object's transform.
                let of = required(&self.of, "of", &ctx.span)?;
                let material = self.material.as_ref().map(|m| ctx.material(m)).transpose()?;
                let placements = ctx.placements.borrow();
                let Some(list) = placements.get(of.get_ref()) else {
                    return Err(at(
                        of.span(),
                        format!("no earlier `mesh`, `triangles` or `gltf` object is named '{}'", of.get_ref()),
                    ));
                };
                let name = self.name.as_ref().map_or_else(|| format!("object {}", ctx.index), |n| n.get_ref().clone());
                for &(prototype, local) in list {
                    let transform = local.then(&transform);
                    scene.instances.push(Instance { name: name.clone(), prototype, transform, material });
                }
            }
            ObjectKind::Gltf => {
                // A glTF object adds its meshes, materials and lights (not its cameras): see
                // `crate::scene::load::gltf_scene`.
                let path = required(&self.path, "path", &ctx.span)?;
                let material = self.material.as_ref().map(|m| ctx.material(m)).transpose()?;
                let file = ctx.base.join(path.get_ref());
                let gltf = crate::scene::load::gltf::load_gltf(&file).map_err(|e| at(path.span(), e.to_string()))?;
                let name = self.name.as_ref().map(|n| n.get_ref().clone());
                let instanced = name.as_ref().is_some_and(|n| ctx.instanced.contains(n));
                let (_, placements) = crate::scene::load::gltf_scene::add_gltf(
                    scene, &file, &gltf, &transform, material, instanced, true,
                );
                if let Some(name) = name.filter(|_| instanced) {
                    ctx.placements.borrow_mut().insert(name, placements);
                }
                return Ok(FileReport { file: Some(file), warnings: gltf.warnings, degenerate_dropped: 0 });
            }
        }
        Ok(FileReport::default())
    }

    /// Adds the meshes of a `triangles` or `mesh` object, in the object's own coordinates, by
    /// `transform`: flattened into world space, or, when an `instance` object names this one,
    /// stored once as prototypes with an instance each.
    fn place(&self, scene: &mut Scene, ctx: &ObjectContext, meshes: Vec<Mesh>, transform: &Transform) {
        let name = self.name.as_ref().map(|n| n.get_ref().clone()).filter(|n| ctx.instanced.contains(n));
        let Some(name) = name else {
            for mut mesh in meshes {
                transform.apply_to_mesh(&mut mesh);
                scene.meshes.push(mesh);
            }
            return;
        };
        let mut placements = Vec::new();
        for mesh in meshes {
            let prototype = scene.prototypes.len() as u32;
            scene.prototypes.push(mesh);
            scene.instances.push(Instance { name: name.clone(), prototype, transform: *transform, material: None });
            placements.push((prototype, Transform::default()));
        }
        ctx.placements.borrow_mut().insert(name, placements);
    }

    fn transform(&self) -> Result<Transform, Problem> {
        let translate = self.translate.as_ref().map_or(Ok(DVec3::ZERO), |t| point(t, "translate"))?;
        let rotate = self.rotate_deg.as_ref().map_or(Ok(DVec3::ZERO), |r| point(r, "rotate_deg"))?;
        let scale = match &self.scale {
            None => DVec3::ONE,
            Some(s) => {
                let v = s.get_ref().0;
                if !v.iter().all(|&x| is_finite32(x) && x != 0.0) {
                    return Err(at(s.span(), format!("scale {} must be finite and non-zero", fmt3(v))));
                }
                DVec3::from(v)
            }
        };
        Ok(Transform::new(translate, rotate, scale))
    }

    fn inline_mesh(&self, ctx: &ObjectContext) -> Result<Mesh, Problem> {
        let vectors = |list: &Spanned<Vec<V3>>, what: &str| -> Result<Vec<Vec3>, Problem> {
            list.get_ref()
                .iter()
                .enumerate()
                .map(|(i, &Fixed(v))| {
                    if v.iter().all(|&x| is_finite32(x)) {
                        Ok(DVec3::from(v).as_vec3())
                    } else {
                        Err(at(list.span(), format!("{what}[{i}] {} is not finite", fmt3(v))))
                    }
                })
                .collect()
        };
        let positions = required(&self.positions, "positions", &ctx.span)?;
        let indices = required(&self.indices, "indices", &ctx.span)?;
        let mut mesh = Mesh {
            name: self.name.as_ref().map_or_else(|| format!("object {}", ctx.index), |n| n.get_ref().clone()),
            positions: vectors(positions, "positions")?,
            indices: indices.get_ref().iter().map(|i| i.0).collect(),
            ..Default::default()
        };
        if let Some(normals) = &self.normals {
            let mut n = vectors(normals, "normals")?;
            if let Some(i) = n.iter().position(|v| *v == Vec3::ZERO) {
                return Err(at(normals.span(), format!("normals[{i}] is zero")));
            }
            n.iter_mut().for_each(|v| *v = v.normalize());
            mesh.normals = Some(n);
        }
        if let Some(colors) = &self.colors {
            let c = vectors(colors, "colors")?;
            if let Some(i) = c.iter().position(|v| v.min_element() < 0.0) {
                return Err(at(colors.span(), format!("colors[{i}] {} must not be negative", c[i])));
            }
            mesh.colors = Some(c);
        }
        if let Some(problem) = mesh.problem() {
            // Index problems point at `indices`, length mismatches at the per-vertex array.
            let span = if problem.contains("normals") {
                self.normals.as_ref().map(|n| n.span())
            } else if problem.contains("colours") {
                self.colors.as_ref().map(|c| c.span())
            } else {
                Some(indices.span())
            };
            return Err(at(span.unwrap_or_else(|| indices.span()), problem));
        }
        Ok(mesh)
    }

    /// The spheres of a `random_spheres` object, in a scene that has `existing` spheres already
    /// (the total is bounded by [`MAX_RANDOM_SPHERES`], checked before any is made).
    fn random_spheres(&self, ctx: &ObjectContext, existing: usize) -> Result<Vec<Sphere>, Problem> {
        let count_value = required(&self.count, "count", &ctx.span)?;
        let count = *count_value.get_ref();
        if count > MAX_RANDOM_SPHERES {
            return Err(at(count_value.span(), format!("count {count} is more than {MAX_RANDOM_SPHERES}")));
        }
        let total = count + existing as u64;
        if total > MAX_RANDOM_SPHERES {
            return Err(at(
                count_value.span(),
                format!(
                    "count {count} would make {total} spheres in the scene ({existing} before this object), \
                     more than the {MAX_RANDOM_SPHERES} a scene may have"
                ),
            ));
        }
        let seed = self.seed.as_ref().map_or(0, |s| *s.get_ref());
        let bounds_value = required(&self.bounds, "bounds", &ctx.span)?;
        let Fixed([Fixed(lo), Fixed(hi)]) = *bounds_value.get_ref();
        let (lo, hi) = (DVec3::from(lo), DVec3::from(hi));
        if !(lo.to_array().into_iter().chain(hi.to_array()).all(is_finite32) && lo.cmple(hi).all()) {
            return Err(at(
                bounds_value.span(),
                format!("bounds {} – {} must be finite with min ≤ max", fmt3(lo.into()), fmt3(hi.into())),
            ));
        }
        let radii_value = required(&self.radii, "radii", &ctx.span)?;
        let Fixed([r0, r1]) = *radii_value.get_ref();
        if !(is_finite32(r0) && is_finite32(r1) && 0.0 < r0 && r0 <= r1) {
            return Err(at(radii_value.span(), format!("radii [{r0}, {r1}] must satisfy 0 < min ≤ max")));
        }
        let bounds = Aabb::new(lo.as_vec3(), hi.as_vec3());
        Ok(procedural::random_spheres(count as usize, bounds, (r0 as f32, r1 as f32), seed))
    }
}

/// What a mesh file reported while loading.
#[derive(Default)]
pub(super) struct FileReport {
    file: Option<PathBuf>,
    /// One line each, naming the mesh file (and line).
    pub(super) warnings: Vec<String>,
    degenerate_dropped: usize,
}

/// Loads the triangle meshes of an OBJ or PLY file for a `type = "mesh"` object, in the file's
/// own coordinates (the object's transform is applied afterwards), with their materials.
///
/// `material`, when given, is the material of every triangle (the file's materials are not
/// used). Otherwise the file's materials are appended to `scene.materials` under the names
/// `FILE/NAME` (`CornellBox-Original.obj/leftWall`; a scene's own material names cannot
/// contain `/`, so these never collide with them), and the meshes' material indices, which
/// index the file's list, are moved past the scene's materials.
fn load_mesh_file(
    path: &Path,
    options: &MeshOptions,
    material: Option<u32>,
    scene: &mut Scene,
) -> Result<(Vec<Mesh>, FileReport), MeshError> {
    let loaded = load_mesh(path, options)?;
    let report = FileReport {
        file: Some(path.to_owned()),
        warnings: loaded.warnings,
        degenerate_dropped: loaded.degenerate_dropped,
    };
    let mut meshes = loaded.meshes;
    match material {
        Some(material) => meshes.iter_mut().for_each(|m| (m.material, m.triangle_materials) = (material, None)),
        None => {
            let offset = scene.materials.len() as u32;
            let file = path.file_name().map_or_else(|| path.display().to_string(), |f| f.to_string_lossy().into());
            for mut m in loaded.materials {
                m.name = format!("{file}/{}", m.name);
                scene.materials.push(m);
            }
            for m in &mut meshes {
                m.material += offset;
                m.triangle_materials.iter_mut().flatten().for_each(|t| *t += offset);
            }
        }
    }
    Ok((meshes, report))
}

/// A scene of the one mesh file at `path`, as a scene file with a single `type = "mesh"`
/// object naming it (no `material`, no transform) would hold it: the file's meshes and
/// materials, and what the object added. The caller sets the camera, lights and image.
pub(super) fn mesh_file_scene(path: &Path) -> Result<(Scene, FileReport, ObjectSummary), MeshError> {
    let mut scene = Scene::default();
    let (meshes, report) = load_mesh_file(path, &MeshOptions::default(), None, &mut scene)?;
    scene.meshes = meshes;
    let summary = ObjectSummary::of(&scene, (0, 0, 0, 0), None, ObjectKind::Mesh.name(), &report);
    Ok((scene, report, summary))
}
