//! What shading needs to know about a hit: the point, its normals, its material and albedo,
//! reconstructed from the [`Hit`] and the scene data.
//!
//! On triangles this is the lecture's barycentric interpolation: with the hit's `u, v`,
//! every per-vertex quantity `q` (position, normal, colour, texture coordinates) becomes
//! `q = (1 − u − v)·q0 + u·q1 + v·q2`. Spheres use their exact normal `(p − c)/r`, planes
//! their `n`.
//!
//! Points are recomputed on the surface rather than taken as `org + t·dir`, whose rounding
//! error grows with `t` and would let secondary rays start below the surface: triangles
//! interpolate their corners, sphere points are projected back onto the sphere, plane points
//! onto the plane.
//!
//! On triangles the hit's `t, u, v` are first re-solved in f64 against the world-space
//! corners ([`triangle::resolve_f64`]), whichever backend found the hit: an instance's
//! triangle is rebuilt exactly as flattening stores it (corners and vertex normals transformed
//! one by one with the same f64 transform, the winding swapped under a mirroring transform,
//! see [`crate::scene::instance`]), so an instanced scene shades bit for bit like the same
//! scene flattened into world space, on both backends.
//!
//! Normals: the geometric normal `ng` is the primitive's own (outward for spheres, the
//! winding's `(p1 − p0) × (p2 − p0)` for triangles, the plane's `n`). The shading normal `ns`
//! is first put on the same side as that outward `ng` (so meshes whose vertex normals
//! disagree with their winding still shade), then both are flipped together towards the side
//! the ray came from: whether a ray enters or leaves an object is decided by the geometric
//! normal alone. Where an interpolated `ns` still faces away from the viewer (near
//! silhouettes of coarse meshes) it is replaced by `ng`.
//!
//! Normal maps: where the material has a `normalTexture` and the mesh tangents, `ns` is the
//! mapped normal ([`crate::normal_map`]: the interpolated normal perturbed in its tangent
//! frame, then flipped with `ng`), kept so that the viewer's mirror direction leaves the
//! geometric surface (Cycles' rule, [`normal_map::valid_reflection`]); camera rays of the
//! path tracer read the map through their ray cone ([`SurfacePoint::with_footprint`]). Every
//! integrator, and the `normal` pass, see that normal. A clearcoat has its own normal
//! (`n_coat`): its `clearcoatNormalTexture` mapped the same way, or else the normal before
//! mapping.

use crate::accel::Hit;
use crate::geometry::triangle;
use crate::material::{TexCoords, TextureSlot};
use crate::math::{Ray, Vec2, Vec3, Vec4};
use crate::normal_map;
use crate::scene::{GeomKind, Scene};

/// The shading data of one hit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfacePoint {
    /// The hit point, on the surface.
    pub p: Vec3,
    /// Unit geometric normal as the primitive defines it (not flipped).
    pub ng_outward: Vec3,
    /// Unit geometric normal on the side the ray arrived from (`ng · dir < 0`).
    pub ng: Vec3,
    /// Unit shading normal, on the same side as `ng` and facing the viewer.
    pub ns: Vec3,
    /// The clearcoat layer's unit normal (`KHR_materials_clearcoat`), on `ns`'s side: mapped
    /// by the material's `clearcoatNormalTexture`, or without one the interpolated normal
    /// before normal mapping, as the extension asks; `ns` itself where the coat cannot differ
    /// from it ([`crate::material::Pbr::coat_has_own_normal`]).
    pub n_coat: Vec3,
    /// Whether the ray arrived on the side `ng_outward` points to, i.e. enters the object.
    pub front_face: bool,
    /// Index into `Scene::materials`.
    pub material: u32,
    /// Texture coordinates `TEXCOORD_0` and `TEXCOORD_1` (the first where the mesh has no
    /// second set), bottom-left origin; zero where the surface has none.
    pub uv: [Vec2; 2],
    /// The interpolated vertex colour (`COLOR_0`), 1 where the mesh has none.
    pub color: Vec3,
    /// The ray parameter of the hit (on triangles re-solved in f64, see the module docs).
    pub t: f32,
    /// Texture-coordinate units per unit of length on the triangle, per set:
    /// `√(uv area / world area)` (Δ₀ of ray-cone texture LOD, [`crate::shading`]); 0 where
    /// the surface has no texture coordinates.
    pub uv_density: [f32; 2],
}

/// `(1 − u − v)·q0 + u·q1 + v·q2`.
#[inline]
pub fn barycentric(q: [Vec3; 3], u: f32, v: f32) -> Vec3 {
    (1.0 - u - v) * q[0] + u * q[1] + v * q[2]
}

/// `(1 − u − v)·t0 + u·t1 + v·t2` for texture coordinates.
#[inline]
pub fn barycentric2(t: [Vec2; 3], u: f32, v: f32) -> Vec2 {
    (1.0 - u - v) * t[0] + u * t[1] + v * t[2]
}

/// The texture coordinates of sets 0 and 1 at `(u, v)` on the triangle of `mesh` with
/// vertex indices `idx`: `(0, 0)` without a set; a mesh without a second set reads its first
/// for `TEXCOORD_1`.
pub fn texture_coordinates(mesh: &crate::scene::Mesh, idx: [usize; 3], u: f32, v: f32) -> [Vec2; 2] {
    let uv = |set: &Option<Vec<Vec2>>| set.as_ref().map(|t| barycentric2(idx.map(|i| t[i]), u, v));
    let uv0 = uv(&mesh.uvs).unwrap_or(Vec2::ZERO);
    [uv0, uv(&mesh.uvs1).unwrap_or(uv0)]
}

impl SurfacePoint {
    /// The shading data of `hit`, the closest hit of `ray` in `scene`.
    ///
    /// The hit's ids must name objects of `scene` and their materials must exist (the
    /// integrator checks the scene before tracing).
    pub fn new(scene: &Scene, ray: &Ray, hit: &Hit) -> SurfacePoint {
        Self::with_footprint(scene, ray, hit, 0.0)
    }

    /// [`SurfacePoint::new`] for a ray whose cone is `footprint` wide at the hit (world units;
    /// 0: a point sample): normal maps are read at the level of detail the footprint covers,
    /// as [`crate::shading`] reads the other textures.
    pub fn with_footprint(scene: &Scene, ray: &Ray, hit: &Hit, footprint: f32) -> SurfacePoint {
        let prim = hit.prim_id as usize;
        let (p, ng_outward, ns, colour, (uv, uv_density), material, t, tangent) = match scene.geom_kind(hit.geom_id) {
            GeomKind::Mesh(m) => {
                let mesh = &scene.meshes[m as usize];
                let idx = mesh.indices[prim].map(|i| i as usize);
                let corners = idx.map(|i| mesh.positions[i]);
                let normals = mesh.normals.as_ref().map(|n| idx.map(|i| n[i]));
                let tangents = mesh.tangents.as_ref().map(|t| idx.map(|i| t[i]));
                let (p, ng, ns, colour, uv, t, tangent) =
                    on_triangle(mesh, ray, hit, idx, corners, normals, tangents, false);
                (p, ng, ns, colour, uv, mesh.material_of(prim), t, tangent)
            }
            GeomKind::Instance(k) => {
                // The triangle as flattening stores it (see `crate::scene::instance`).
                let inst = &scene.instances[k as usize];
                let mesh = &scene.prototypes[inst.prototype as usize];
                let mut idx = mesh.indices[prim].map(|i| i as usize);
                let swapped = inst.transform.flips_orientation();
                if swapped {
                    idx.swap(1, 2);
                }
                let corners = idx.map(|i| inst.transform.point(mesh.positions[i]));
                let normals = mesh.normals.as_ref().map(|n| idx.map(|i| inst.transform.normal(n[i])));
                let tangents = mesh.tangents.as_ref().map(|t| idx.map(|i| inst.transform.tangent(t[i])));
                let (p, ng, ns, colour, uv, t, tangent) =
                    on_triangle(mesh, ray, hit, idx, corners, normals, tangents, swapped);
                (p, ng, ns, colour, uv, inst.material_of(mesh, prim), t, tangent)
            }
            GeomKind::Spheres => {
                let s = &scene.spheres[prim];
                let n = (ray.at(hit.t) - s.center).normalize_or_zero();
                let uv = ([Vec2::ZERO; 2], [0.0; 2]);
                (s.center + s.radius * n, n, n, Vec3::ONE, uv, s.material, hit.t, Vec4::ZERO)
            }
            GeomKind::Planes => {
                let pl = &scene.planes[prim];
                let x = ray.at(hit.t);
                let p = x - (pl.normal.dot(x) - pl.dist) * pl.normal;
                (p, pl.normal, pl.normal, Vec3::ONE, ([Vec2::ZERO; 2], [0.0; 2]), pl.material, hit.t, Vec4::ZERO)
            }
        };
        // A degenerate triangle (zero area) has no normal of its own: face the ray.
        let ng_outward = if ng_outward == Vec3::ZERO { -ray.dir.normalize() } else { ng_outward };
        let ns = if ns == Vec3::ZERO { ng_outward } else { ns };
        let ns = if ns.dot(ng_outward) < 0.0 { -ns } else { ns };
        let (mapped, coat) = if tangent == Vec4::ZERO {
            (None, None)
        } else {
            let at = TexCoords::through_cone(uv, uv_density, ng_outward, -ray.dir, footprint);
            mapped_normals(scene, material, ns, tangent, at)
        };
        let front_face = ray.dir.dot(ng_outward) < 0.0;
        let (ng, ns) = if front_face { (ng_outward, ns) } else { (-ng_outward, -ns) };
        let shading = facing(mapped, ns, ng, ray.dir, front_face);
        let n_coat = match coat {
            None => shading,
            Some(mapped) => facing(mapped, ns, ng, ray.dir, front_face),
        };
        let ns = shading;
        SurfacePoint { p, ng_outward, ng, ns, n_coat, front_face, material, uv, color: colour, t, uv_density }
    }

    /// The diffuse albedo ρ here: the material's diffuse texture (a PBR material's lecture
    /// form's, [`crate::material::Pbr::lecture_form`]) times the interpolated vertex colour.
    /// What the Whitted integrator and the lecture BSDF shade with, computed when asked: the
    /// path tracer reads a PBR material's own textures instead ([`crate::shading`]).
    pub fn albedo(&self, scene: &Scene) -> Vec3 {
        scene.materials[self.material as usize].diffuse.albedo_at(self.p, self.ng_outward, self.uv) * self.color
    }
}

/// Both texture coordinate sets at a hit and their densities ([`SurfacePoint::uv_density`]).
type Uvs = ([Vec2; 2], [f32; 2]);

/// The normal a shading frame takes at a hit seen along `dir`, given the normal map's normal
/// `mapped` (outward; `None` without one), the interpolated normal `ns` and the geometric
/// normal `ng` (both already on the viewer's side), and whether the hit is on the front
/// (module docs: a mapped normal kept so that the mirror direction leaves the surface, an
/// interpolated one replaced by `ng` where it faces away).
#[inline]
fn facing(mapped: Option<Vec3>, ns: Vec3, ng: Vec3, dir: Vec3, front_face: bool) -> Vec3 {
    match mapped {
        Some(n) => normal_map::valid_reflection(ng, -dir.normalize(), if front_face { n } else { -n }),
        None if ns.dot(dir) >= 0.0 => ng,
        None => ns,
    }
}

/// The normal-mapped normals at a point of `material` whose interpolated normal (on the
/// outward side) is `n`, tangent `tangent` (not zero) and texture coordinates `at`: the
/// shading normal, if the material has a `normalTexture`, and the coat's, if it has a coat
/// with a normal of its own ([`crate::material::Pbr::coat_has_own_normal`]): `Some` of its
/// `clearcoatNormalTexture`'s normal, or of `None` (the normal before mapping). Out of line:
/// most hits have no tangent and skip it.
#[inline(never)]
fn mapped_normals(
    scene: &Scene,
    material: u32,
    n: Vec3,
    tangent: Vec4,
    at: TexCoords,
) -> (Option<Vec3>, Option<Option<Vec3>>) {
    let Some(m) = scene.materials[material as usize].pbr.as_deref() else { return (None, None) };
    let mapped = mapped_normal(m.normal_texture.as_ref(), m.normal_scale, n, tangent, at);
    let coat = m
        .coat_has_own_normal()
        .then(|| mapped_normal(m.clearcoat_normal_texture.as_ref(), m.clearcoat_normal_scale, n, tangent, at));
    (mapped, coat)
}

/// The normal that the normal map `slot` (with its `scale`) gives a point whose interpolated
/// normal (on the outward side) is `n`, tangent `tangent` (not zero) and texture coordinates
/// `at` (and the footprint's width there), if there is a map and the tangent gives a frame
/// ([`crate::normal_map`]).
fn mapped_normal(slot: Option<&TextureSlot>, scale: f32, n: Vec3, tangent: Vec4, at: TexCoords) -> Option<Vec3> {
    normal_map::perturb(n, tangent, normal_map::tangent_space_normal(slot?.at(at), scale))
}

/// Point, unit geometric normal, shading normal, colour, texture coordinates, `t` and
/// interpolated tangent of `hit` on the world-space triangle `corners` (vertex indices `idx`
/// into `mesh`, world-space vertex normals `normals` and tangents `tangents`), with `t, u, v`
/// re-solved on it. `swapped`: the corners are `p0 p2 p1`
/// of the triangle the backend hit, so its `u, v` trade places (used only if the re-solve
/// fails, for a ray in the triangle's plane).
#[allow(clippy::too_many_arguments)] // the hit, its triangle and its per-vertex data
fn on_triangle(
    mesh: &crate::scene::Mesh,
    ray: &Ray,
    hit: &Hit,
    idx: [usize; 3],
    corners: [Vec3; 3],
    normals: Option<[Vec3; 3]>,
    tangents: Option<[Vec4; 3]>,
    swapped: bool,
) -> (Vec3, Vec3, Vec3, Vec3, Uvs, f32, Vec4) {
    let (u, v) = if swapped { (hit.v, hit.u) } else { (hit.u, hit.v) };
    let h = triangle::resolve_f64(ray.org, ray.dir, corners).unwrap_or(triangle::TriangleHit { t: hit.t, u, v });
    let p = barycentric(corners, h.u, h.v);
    let ng = triangle::normal(corners[0], corners[1], corners[2]).normalize_or_zero();
    let ns = normals.map_or(Vec3::ZERO, |n| barycentric(n, h.u, h.v));
    let colour = mesh.colors.as_ref().map_or(Vec3::ONE, |c| barycentric(idx.map(|i| c[i]), h.u, h.v));
    let area = (corners[1] - corners[0]).cross(corners[2] - corners[0]).length();
    let density = |set: &Option<Vec<Vec2>>| {
        let t = set.as_ref().map(|t| idx.map(|i| t[i]));
        t.map_or(0.0, |t| {
            let uv_area = (t[1] - t[0]).perp_dot(t[2] - t[0]).abs();
            if area > 0.0 && uv_area.is_finite() { (uv_area / area).sqrt() } else { 0.0 }
        })
    };
    let d0 = density(&mesh.uvs);
    let d1 = if mesh.uvs1.is_some() { density(&mesh.uvs1) } else { d0 };
    let tangent = tangents.map_or(Vec4::ZERO, |t| (1.0 - h.u - h.v) * t[0] + h.u * t[1] + h.v * t[2]);
    let uv = texture_coordinates(mesh, idx, h.u, h.v);
    (p, ng, ns.normalize_or_zero(), colour, (uv, [d0, d1]), h.t, tangent)
}
