//! The range of magnitudes strahl traces: every coordinate and length of a scene lies within
//! ±[`MAX_COORDINATE`] = 10⁹ (metres: 2.6 times the distance to the Moon), checked when the
//! scene is loaded, before any BVH is built, and again before rendering ([`problem`]).
//!
//! ```text
//! |x|, |y|, |z| ≤ 10⁹   for every mesh vertex (after its transforms; a prototype's in its own
//!                       space, and its world-space bounds under every instance), sphere
//!                       centre ± radius, the camera's eye and target, a point light, every
//!                       point of an area light's shape
//! ≤ 10⁹                 the aperture, the focus distance, a plane's distance from the origin
//! ‖L⁻¹‖∞ ≤ 10⁸          an instance's linear part L shrinks its prototype at most 10⁸ times
//! ```
//!
//! **Why.** Embree aborts the process (an assertion, `RayK::valid()` in `kernels/common/ray.h`)
//! on a ray whose origin or direction has a component beyond `FLT_LARGE` = 1.844·10¹⁸, and it
//! silently drops a triangle whose vertex lies beyond it (the native BVH would not). Every ray
//! strahl makes has a unit direction and starts
//! - at the camera: the eye plus at most the aperture, within 2.5·10⁹ per axis;
//! - at a hit on a mesh, sphere or instance, inside the scene's bounds (10⁹), moved off the
//!   surface by at most 256 ulps ([`crate::math::offset_ray_origin`]);
//! - at a hit on a plane: a grazing ray meets an unbounded plane arbitrarily far away (one
//!   whose direction has y = −10⁻²⁰ meets y = −1 at x = 10²⁰), so planes end at
//!   [`PLANE_EXTENT`] = 4·10⁹ per axis ([`crate::geometry::plane`]): a hit beyond is a miss.
//!
//! So world-space origins stay within 4·10⁹ per axis, 4.6·10⁸ times inside Embree's range.
//! An instance is traced in its prototype's space, `M⁻¹·o = L⁻¹·(o − T)`; with
//! `‖L⁻¹‖∞ ≤ 10⁸` (the largest absolute row sum of the inverse) and the prototype and its
//! placement within 10⁹, object-space origins stay below 10⁸·(4·10⁹ + 10⁹) + 10⁹ ≈ 5·10¹⁷
//! and directions below 10⁸: inside Embree's range by a factor of 3.6.
//!
//! The bound also keeps the f32 arithmetic of shading finite: the unnormalised normal of a
//! triangle, `(p1 − p0) × (p2 − p0)`, has a squared length of at most `(2√3·10⁹)⁴` =
//! 1.44·10³⁸, below f32's largest 3.4·10³⁸ (at 1.24·10⁹ it would overflow), and so has a
//! sphere's `|o − c|²`. (f32 itself resolves 64 m at 10⁹: a scene that large is a sky, not
//! a place to look closely at.)

use std::path::Path;

use glam::DVec3;

use super::load::file::SceneError;
use super::{CameraSpec, Scene};
use crate::light::Light;
use crate::light::area::Shape;
use crate::math::Vec3;

/// The largest magnitude of any coordinate or length of a scene (see the module docs).
pub const MAX_COORDINATE: f32 = 1e9;

pub use crate::geometry::plane::PLANE_EXTENT;

/// The most an instance may shrink its prototype: the bound on `‖L⁻¹‖∞`, the largest absolute
/// row sum of the inverse of its linear part.
pub const MAX_INSTANCE_SHRINK: f64 = 1e8;

/// Why `scene` cannot be traced for the size of its numbers, as `(object, problem)`:
/// `("sphere 0 'ball'", "centre [0, 0, 0] and radius 3e38 reach beyond ±1e9, …")`.
pub fn problem(scene: &Scene) -> Option<(String, String)> {
    if let Some((_, problem)) = camera_problem(&scene.camera) {
        return Some(("camera".into(), problem));
    }
    for (i, light) in scene.lights.iter().enumerate() {
        let p = match light {
            Light::Point { position, .. } => point_beyond("position", *position),
            Light::Directional { .. } => None,
        };
        if let Some(p) = p {
            return Some((format!("light {i}"), p));
        }
    }
    for (i, light) in scene.area_lights.iter().enumerate() {
        let p = match light.shape {
            Shape::Quad { corner, edge1, edge2 } => {
                let (c, a, b) = (corner.as_dvec3(), edge1.as_dvec3(), edge2.as_dvec3());
                let reach = [c, c + a, c + b, c + a + b].iter().map(|p| p.abs().max_element()).fold(0.0, f64::max);
                beyond(reach).then(|| {
                    format!("corner {} and edges {}, {} reach {RANGE}", vec3(corner), vec3(edge1), vec3(edge2))
                })
            }
            Shape::Disk { center, radius, .. } | Shape::Sphere { center, radius } => ball_beyond(center, radius),
        };
        if let Some(p) = p {
            return Some((format!("area light {i}"), p));
        }
    }
    for (i, mesh) in scene.meshes.iter().enumerate() {
        if let Some(p) = vertices_beyond(&mesh.positions) {
            return Some((named("mesh", i, Some(scene.mesh_name(i))), p));
        }
    }
    for (i, mesh) in scene.prototypes.iter().enumerate() {
        if let Some(p) = vertices_beyond(&mesh.positions) {
            return Some((format!("prototype {i} '{}'", mesh.name), p));
        }
    }
    for (k, inst) in scene.instances.iter().enumerate() {
        let object = format!("instance {k} '{}'", inst.name);
        let Some(prototype) = scene.prototypes.get(inst.prototype as usize) else { continue };
        let inverse = inst.transform.affine().matrix3.inverse();
        let shrink = (0..3).map(|r| inverse.row(r).abs().element_sum()).fold(0.0, f64::max);
        if !(shrink <= MAX_INSTANCE_SHRINK) {
            let problem = format!(
                "its transform shrinks the prototype {} times (the largest absolute row sum of its inverse), more \
                 than the {} of the range strahl traces (docs/scene-format.md, \"Range of numbers\")",
                num(shrink),
                num(MAX_INSTANCE_SHRINK)
            );
            return Some((object, problem));
        }
        let bounds = inst.bounds(prototype.bounds());
        if !bounds.is_empty() {
            let reach = bounds.min.abs().max(bounds.max.abs()).max_element() as f64;
            if beyond(reach) {
                return Some((object, format!("its placement reaches {}, {RANGE}", num(reach))));
            }
        }
    }
    for (i, s) in scene.spheres.iter().enumerate() {
        if let Some(p) = ball_beyond(s.center, s.radius) {
            return Some((named("sphere", i, scene.names.spheres.get(i).map(String::as_str)), p));
        }
    }
    for (i, plane) in scene.planes.iter().enumerate() {
        if beyond(plane.dist.abs() as f64) {
            let problem = format!("distance {} from the origin is {RANGE}", num(plane.dist as f64));
            return Some((named("plane", i, scene.names.planes.get(i).map(String::as_str)), problem));
        }
    }
    None
}

/// [`problem`] as the error of the scene file at `path`: `scene.toml: sphere 0 'ball': …`.
pub fn check(path: &Path, scene: &Scene) -> Result<(), SceneError> {
    match problem(scene) {
        Some((object, problem)) => {
            Err(SceneError::Invalid { path: path.into(), message: format!("{object}: {problem}") })
        }
        None => Ok(()),
    }
}

/// Why the camera's numbers are too large, as `(field, problem)`: the eye, the target, the
/// aperture or the focus distance beyond [`MAX_COORDINATE`].
pub fn camera_problem(camera: &CameraSpec) -> Option<(&'static str, String)> {
    let lens = &camera.lens;
    let points = [("eye", camera.eye), ("target", camera.target)];
    let lengths = [
        ("aperture", lens.aperture),
        ("focus_distance", lens.focus_distance),
        ("ortho_half_height", lens.ortho_half_height),
    ];
    points.into_iter().find_map(|(field, p)| point_beyond(field, p).map(|m| (field, m))).or_else(|| {
        lengths.into_iter().find_map(|(field, x)| {
            beyond(x.abs() as f64).then(|| (field, format!("{field} {} is {RANGE}", num(x as f64))))
        })
    })
}

/// The end of every message: what the bound is and where it is explained.
const RANGE: &str = "beyond ±1e9, the range strahl traces (docs/scene-format.md, \"Range of numbers\")";

/// Whether a magnitude lies beyond [`MAX_COORDINATE`] (NaN does).
fn beyond(magnitude: f64) -> bool {
    !(magnitude <= MAX_COORDINATE as f64)
}

fn point_beyond(what: &str, p: Vec3) -> Option<String> {
    beyond(p.abs().max_element() as f64).then(|| format!("{what} {} lies {RANGE}", vec3(p)))
}

/// A sphere or disk: its centre ± radius per axis.
fn ball_beyond(center: Vec3, radius: f32) -> Option<String> {
    let reach = center.as_dvec3().abs().max_element() + (radius as f64).abs();
    beyond(reach).then(|| format!("centre {} and radius {} reach {RANGE}", vec3(center), num(radius as f64)))
}

/// The first vertex beyond the bound.
fn vertices_beyond(positions: &[Vec3]) -> Option<String> {
    let i = positions.iter().position(|p| beyond(p.abs().max_element() as f64))?;
    Some(format!("vertex {i} {} lies {RANGE}", vec3(positions[i])))
}

/// `sphere 3 'ball'`, or `sphere 3` without a name.
fn named(kind: &str, i: usize, name: Option<&str>) -> String {
    match name {
        Some(n) => format!("{kind} {i} '{n}'"),
        None => format!("{kind} {i}"),
    }
}

/// A number as a person would write it, in f32's shortest digits: `5e18` rather than nineteen
/// digits.
fn num(x: f64) -> String {
    let y = x as f32;
    match (y.is_finite() || !x.is_finite(), x != 0.0 && !(1e-4..1e7).contains(&x.abs())) {
        (true, true) => format!("{y:e}"),
        (true, false) => format!("{y}"),
        (false, _) => format!("{x:e}"),
    }
}

fn vec3(v: Vec3) -> String {
    let v: DVec3 = v.as_dvec3();
    format!("[{}, {}, {}]", num(v.x), num(v.y), num(v.z))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{Plane, Sphere};
    use crate::scene::procedural::whitted_showcase;

    fn problem_of(edit: impl FnOnce(&mut Scene)) -> Option<String> {
        let mut scene = whitted_showcase(8, 6, 1);
        edit(&mut scene);
        problem(&scene).map(|(object, p)| format!("{object}: {p}"))
    }

    #[test]
    fn scenes_inside_the_range_pass_and_each_kind_of_excess_is_named() {
        assert_eq!(problem_of(|_| {}), None);
        let at_bound = problem_of(|s| {
            s.camera.eye = Vec3::new(0.0, 1.0, MAX_COORDINATE);
            s.camera.lens.aperture = MAX_COORDINATE;
            s.spheres.push(Sphere { center: Vec3::new(9e8, 0.0, 0.0), radius: 1e8, material: 0 });
            s.planes.push(Plane { normal: Vec3::Y, dist: -MAX_COORDINATE, material: 0 });
        });
        assert_eq!(at_bound, None);
        type Edit = Box<dyn FnOnce(&mut Scene)>;
        let cases: [(&str, Edit); 7] = [
            ("camera: eye [0, 1, 5e18]", Box::new(|s| s.camera.eye = Vec3::new(0.0, 1.0, 5e18))),
            ("camera: aperture 1e30", Box::new(|s| s.camera.lens.aperture = 1e30)),
            ("camera: focus_distance 2e9", Box::new(|s| s.camera.lens.focus_distance = 2e9)),
            (
                "sphere 0: centre [0, 0, 0] and radius 3e38",
                Box::new(|s| s.spheres[0] = Sphere { center: Vec3::ZERO, radius: 3e38, material: 0 }),
            ),
            ("plane 0: distance -1.5e9", Box::new(|s| s.planes[0].dist = -1.5e9)),
            (
                "light 0: position [0, 0, inf]",
                Box::new(|s| {
                    s.lights[0] = Light::Point { position: Vec3::new(0.0, 0.0, f32::INFINITY), intensity: Vec3::ONE }
                }),
            ),
            ("vertex 1 [1.1e9, 0, 0]", Box::new(|s| s.meshes[0].positions[1] = Vec3::new(1.1e9, 0.0, 0.0))),
        ];
        for (expected, edit) in cases {
            let p = problem_of(edit).unwrap_or_else(|| panic!("{expected}: accepted"));
            assert!(
                p.contains(expected) && p.contains("beyond ±1e9, the range strahl traces") && !p.contains('\n'),
                "{p}"
            );
        }
    }

    #[test]
    fn instances_are_checked_where_they_are_placed_and_by_how_much_they_shrink() {
        use crate::scene::Instance;
        use crate::scene::transform::Transform;
        let place = |translate: f64, scale: f64| {
            let mut s = whitted_showcase(8, 6, 1);
            s.prototypes.push(s.meshes[0].clone());
            let transform = Transform::new(DVec3::new(translate, 0.0, 0.0), DVec3::ZERO, DVec3::splat(scale));
            s.instances.push(Instance { name: "copy".into(), prototype: 0, transform, material: None });
            problem(&s).map(|(o, p)| format!("{o}: {p}"))
        };
        assert_eq!(place(1e6, 1e-7), None);
        let far = place(2e9, 1.0).unwrap();
        assert!(far.starts_with("instance 0 'copy': its placement reaches 2"), "{far}");
        let tiny = place(0.0, 1e-9).unwrap();
        assert!(tiny.starts_with("instance 0 'copy': its transform shrinks the prototype 1e9 times"), "{tiny}");
    }
}
