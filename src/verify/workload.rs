//! The standard ray sets that `crosscheck` and `bench` trace through a scene: coherent primary
//! rays, incoherent random rays, secondary (reflected) rays and shadow rays (from primary hits
//! to a light, the integrator's any-hit queries). Deterministic for a given
//! scene, count and seed, so every backend traces exactly the same rays.

use std::fmt;
use std::str::FromStr;

use rayon::prelude::*;

use crate::accel::{Accel, TraceError};
use crate::camera::Camera;
use crate::integrator::RenderError;
use crate::integrator::lights::SHADOW_TFAR_SCALE;
use crate::light::Light;
use crate::math::{Ray, Vec3, offset_ray_origin};
use crate::scene::{CameraSpec, Scene, procedural};

/// Which rays to trace.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum RayKind {
    /// One ray through each pixel centre of a square image of the scene's camera as the
    /// lecture's pinhole [`Camera`] ([`primary_camera`]; a lone mesh file's camera frames its
    /// bounds with a vertical fov of 40°), in 4×2-pixel tiles (the order packets like).
    Primary,
    /// Rays from points uniform in 1.5× the scene's bounding box, in uniformly random
    /// directions ([`procedural::random_rays`]).
    Random,
    /// The mirror reflections of primary rays at their hits, leaving from the hit point moved
    /// off the surface with [`offset_ray_origin`].
    Secondary,
    /// Segments from primary hits (moved off the surface to the side the ray came from)
    /// towards the scene's first light ([`shadow_light`]), ending just short of a point light
    /// as the integrator's do; traced as any-hit (`occluded`) queries by `bench`.
    Shadow,
}

impl RayKind {
    pub const ALL: [RayKind; 4] = [RayKind::Primary, RayKind::Random, RayKind::Secondary, RayKind::Shadow];
    /// The kinds traced as closest-hit queries: what `crosscheck` compares hit by hit.
    pub const CLOSEST_HIT: [RayKind; 3] = [RayKind::Primary, RayKind::Random, RayKind::Secondary];

    pub fn name(self) -> &'static str {
        match self {
            RayKind::Primary => "primary",
            RayKind::Random => "random",
            RayKind::Secondary => "secondary",
            RayKind::Shadow => "shadow",
        }
    }
}

impl fmt::Display for RayKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for RayKind {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        RayKind::ALL
            .into_iter()
            .find(|k| k.name() == s)
            .ok_or_else(|| format!("unknown ray kind '{s}' (expected primary, random, secondary or shadow)"))
    }
}

/// Rays of each kind `strahl crosscheck` and `strahl bench` trace unless told otherwise.
pub const DEFAULT_RAYS: usize = 1_000_000;

/// Vertical field of view of the primary rays, degrees.
pub const PRIMARY_FOV_DEG: f32 = 40.0;

/// The camera of the primary rays: the scene's own (a lone mesh file's is
/// [`CameraSpec::framing`] of its bounds, see [`crate::scene::from_mesh_file`]), as a pinhole
/// (rays through pixel centres, whatever its lens), on a square image.
pub fn primary_camera(scene: &Scene) -> CameraSpec {
    CameraSpec { lens: crate::scene::Lens::PINHOLE, ..scene.camera }
}

/// The rays through the pixel centres of `camera` (the camera `strahl render` uses, so these
/// are exactly the rays of rendering at one sample per pixel), in 4×2 tiles: row-major
/// tiles, row-major pixels within each; edge tiles are clipped.
pub fn camera_rays(camera: &Camera) -> Vec<Ray> {
    let (width, height) = camera.size();
    let (tw, th) = (4, 2);
    let mut rays = Vec::with_capacity(width as usize * height as usize);
    for ty in (0..height).step_by(th) {
        for tx in (0..width).step_by(tw) {
            for y in ty..(ty + th as u32).min(height) {
                for x in tx..(tx + tw as u32).min(width) {
                    rays.push(camera.centre_ray(x, y));
                }
            }
        }
    }
    rays
}

/// The side of the square primary image for about `n` rays: `⌈√n⌉` rounded up to a multiple
/// of 8 (1024 for `n = 2²⁰`, 1000 for a million).
pub fn primary_side(n: usize) -> u32 {
    ((n as f64).sqrt().ceil() as u32).div_ceil(8) * 8
}

/// Primary rays of `scene`'s camera (see [`RayKind::Primary`]), about `n` of them.
pub fn primary(scene: &Scene, n: usize) -> Result<Vec<Ray>, RenderError> {
    let side = primary_side(n);
    Ok(camera_rays(&Camera::new(&primary_camera(scene), side, side)?))
}

/// Exactly `n` rays of `kind` through `scene`. Secondary rays need the primary rays' hits:
/// `tracer` finds them (pass the reference backend; every backend then traces the same rays).
/// The primary image grows until it has `n` hits; a scene nothing can be hit in yields fewer
/// (possibly no) secondary rays.
pub fn rays<A: Accel>(scene: &Scene, kind: RayKind, n: usize, seed: u64, tracer: &A) -> Result<Vec<Ray>, RenderError> {
    match kind {
        RayKind::Primary => primary(scene, n),
        RayKind::Random => Ok(procedural::random_rays(n, scene.bounds(), seed)),
        RayKind::Secondary => from_primary_hits(scene, n, tracer, reflect),
        RayKind::Shadow => {
            let light = shadow_light(scene);
            from_primary_hits(scene, n, tracer, |ray, t, ng| shadow(ray, t, ng, &light))
        }
    }
}

/// The light the shadow rays aim at: the scene's first point or directional light; else a point
/// light at the middle of its first area light (a sphere light's point nearest the middle of the
/// scene), where that light's own samples lie; or, in a scene without lights (a bare mesh), a
/// point light a quarter of the bounding box's diagonal beyond its maximum corner (above, to
/// the side, like a key light).
pub fn shadow_light(scene: &Scene) -> Light {
    use crate::light::area::Shape;
    let b = scene.bounds();
    let b = if b.min.cmple(b.max).all() { b } else { crate::math::Aabb::new(Vec3::ZERO, Vec3::ONE) };
    let area = scene.area_lights.first().map(|l| match l.shape {
        Shape::Quad { corner, edge1, edge2 } => corner + 0.5 * (edge1 + edge2),
        Shape::Disk { center, .. } => center,
        Shape::Sphere { center, radius } => center + radius * (b.centroid() - center).normalize_or(Vec3::Y),
    });
    scene.lights.first().copied().unwrap_or_else(|| Light::Point {
        position: area.unwrap_or(b.max + 0.25 * (b.max - b.min)),
        intensity: Vec3::ONE,
    })
}

/// The shadow ray from the hit of `ray` at `t` (geometric normal `ng`) towards `light`: from
/// the hit point moved off the surface to the side the ray came from, ending at
/// [`SHADOW_TFAR_SCALE`] of a point light's distance (unbounded towards a directional light).
pub fn shadow(ray: &Ray, t: f32, ng: Vec3, light: &Light) -> Ray {
    let p = ray.at(t);
    let n = ng.normalize_or_zero();
    let origin = offset_ray_origin(p, if ray.dir.dot(n) < 0.0 { n } else { -n });
    match light.incidence(p) {
        Some(inc) if inc.distance.is_finite() => {
            let to = (p + inc.distance * inc.to_light) - origin;
            let d = to.length();
            Ray::segment(origin, to / d, 0.0, d * SHADOW_TFAR_SCALE)
        }
        Some(inc) => Ray::new(origin, inc.to_light),
        None => Ray::segment(origin, Vec3::Y, 0.0, 0.0), // at the light: nothing to block
    }
}

/// `n` rays made by `make(ray, t, ng)` from the hits of primary rays (traced by `tracer`).
fn from_primary_hits<A: Accel>(
    scene: &Scene,
    n: usize,
    tracer: &A,
    make: impl Fn(&Ray, f32, Vec3) -> Ray + Sync,
) -> Result<Vec<Ray>, RenderError> {
    let mut want = n;
    let mut reflected = Vec::new();
    for _ in 0..4 {
        let hits: Vec<Option<Ray>> = primary(scene, want)?
            .par_iter()
            .map(|ray| Ok(tracer.intersect(ray)?.map(|hit| make(ray, hit.t, hit.ng))))
            .collect::<Result<_, TraceError>>()?;
        reflected = hits.into_iter().flatten().collect();
        if reflected.len() >= n || reflected.is_empty() {
            break;
        }
        // Too few hits: a bigger image, with some margin.
        want = (want as f64 * (n as f64 / reflected.len() as f64) * 1.05).ceil() as usize + 64;
    }
    reflected.truncate(n);
    Ok(reflected)
}

/// The mirror reflection of `ray` at its hit `t` on a surface of geometric normal `ng`,
/// leaving from the hit point offset to the side the ray came from.
pub fn reflect(ray: &Ray, t: f32, ng: Vec3) -> Ray {
    let n = ng.normalize_or_zero();
    let d = ray.dir;
    let facing = if d.dot(n) < 0.0 { n } else { -n };
    let dir = d - 2.0 * d.dot(n) * n;
    Ray::new(offset_ray_origin(ray.at(t), facing), dir)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Aabb;

    fn camera(eye: Vec3, target: Vec3, width: u32, height: u32) -> Camera {
        Camera::new(&CameraSpec { eye, target, up: Vec3::Y, fov_deg: 40.0, lens: Default::default() }, width, height)
            .unwrap()
    }

    #[test]
    fn centre_rays_look_at_the_target() {
        let eye = Vec3::new(0.0, 0.0, 5.0);
        let rays = camera_rays(&camera(eye, Vec3::ZERO, 2, 2));
        assert_eq!(rays.len(), 4);
        // The four pixel centres are symmetric about the view axis: ±tan(20°)/2 each way.
        let h = 0.5 * 20f32.to_radians().tan();
        let expect = [(-h, h), (h, h), (-h, -h), (h, -h)];
        for (r, (x, y)) in rays.iter().zip(expect) {
            let want = Vec3::new(x, y, -1.0).normalize();
            assert!((r.dir - want).length() < 1e-6, "{} vs {want}", r.dir);
            assert_eq!(r.org, eye);
        }
    }

    #[test]
    fn edge_pixels_span_the_field_of_view() {
        // 1×H column: the top pixel centre is half a pixel below the top of the fov.
        let rays = camera_rays(&camera(Vec3::Z, Vec3::ZERO, 1, 100));
        let top = rays[0].dir;
        let angle = top.y.atan2(-top.z).to_degrees();
        let expect = (20f32.to_radians().tan() * (1.0 - 1.0 / 100.0)).atan().to_degrees();
        assert!((angle - expect).abs() < 1e-4, "{angle} vs {expect}");
    }

    #[test]
    fn tiles_cover_every_pixel_once() {
        let (w, h) = (13, 7);
        let cam = camera(Vec3::Z, Vec3::ZERO, w, h);
        let rays = camera_rays(&cam);
        assert_eq!(rays.len(), (w * h) as usize);
        let mut dirs: Vec<[u32; 3]> = rays.iter().map(|r| r.dir.to_array().map(f32::to_bits)).collect();
        dirs.sort();
        dirs.dedup();
        assert_eq!(dirs.len(), (w * h) as usize);
        // The first tile is the top-left 4×2 pixels, the second starts at pixel (4, 0): each
        // ray is the camera's own ray of its pixel.
        assert_eq!(rays[0], cam.centre_ray(0, 0));
        assert_eq!(rays[3], cam.centre_ray(3, 0));
        assert_eq!(rays[4], cam.centre_ray(0, 1));
        assert_eq!(rays[8], cam.centre_ray(4, 0));
    }

    #[test]
    fn framing_sees_the_whole_box() {
        let b = Aabb::new(Vec3::new(-1.0, 2.0, 3.0), Vec3::new(4.0, 3.0, 5.0));
        let spec = CameraSpec::framing(b, PRIMARY_FOV_DEG);
        assert_eq!((spec.target, spec.up, spec.fov_deg), (b.centroid(), Vec3::Y, PRIMARY_FOV_DEG));
        let half_fov = 20f32.to_radians();
        for i in 0..8 {
            let corner = Vec3::new(
                if i & 1 == 0 { b.min.x } else { b.max.x },
                if i & 2 == 0 { b.min.y } else { b.max.y },
                if i & 4 == 0 { b.min.z } else { b.max.z },
            );
            let to = (corner - spec.eye).normalize();
            assert!(to.angle_between(-Vec3::Z) <= half_fov + 1e-5);
        }
        // Nothing bounded: the unit cube at the origin.
        assert_eq!(CameraSpec::framing(Aabb::EMPTY, 40.0).target, Vec3::ZERO);
        assert_eq!(primary_side(1 << 20), 1024);
        assert_eq!(primary_side(1_000_000), 1000);
        assert_eq!(primary_side(10), 8);
    }

    #[test]
    fn primary_rays_are_the_render_camera_rays() {
        let scene = Scene {
            spheres: vec![crate::geometry::Sphere { center: Vec3::X, radius: 2.0, material: 0 }],
            ..Default::default()
        };
        let rays = primary(&scene, 64).unwrap();
        let cam = Camera::new(&primary_camera(&scene), 8, 8).unwrap();
        assert_eq!(rays, camera_rays(&cam));
        // The scene's own camera, as a pinhole.
        assert_eq!(primary_camera(&scene), scene.camera);
    }

    #[test]
    fn shadow_rays_of_an_area_lit_scene_aim_at_its_area_light() {
        use crate::accel::Accel;
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell.toml");
        let scene = crate::scene::load(&path).unwrap().scene;
        let Light::Point { position, .. } = shadow_light(&scene) else { panic!() };
        // The middle of the published light's opening, 0.1 mm under the ceiling.
        assert!((position - Vec3::new(0.278, 0.5487, 0.2795)).length() < 1e-6, "{position}");
        // From inside the box most primary hits see it (a light outside the box, as for a
        // bare mesh, would be hidden from every one of them by the walls).
        let bvh = crate::accel::bvh::Bvh::build(&scene).unwrap();
        let shadow = rays(&scene, RayKind::Shadow, 4096, 1, &bvh).unwrap();
        let lit = shadow.iter().filter(|r| !bvh.occluded(r).unwrap()).count();
        assert!(lit * 2 > shadow.len(), "{lit} of {}", shadow.len());
    }

    #[test]
    fn reflection_mirrors_and_leaves_the_surface() {
        let ray = Ray::new(Vec3::new(0.0, 1.0, 0.0), Vec3::new(1.0, -1.0, 0.0).normalize());
        let r = reflect(&ray, 2f32.sqrt(), Vec3::new(0.0, 3.0, 0.0));
        assert!((r.dir - Vec3::new(1.0, 1.0, 0.0).normalize()).length() < 1e-6);
        assert!(r.org.y > 0.0 && (r.org.x - 1.0).abs() < 1e-6, "{}", r.org);
        // From below, the offset goes down.
        let ray = Ray::new(Vec3::new(0.0, -1.0, 0.0), Vec3::Y);
        let r = reflect(&ray, 1.0, Vec3::new(0.0, 3.0, 0.0));
        assert!(r.org.y < 0.0 && r.dir == -Vec3::Y);
    }

    #[test]
    fn kinds_parse() {
        for k in RayKind::ALL {
            assert_eq!(k.name().parse::<RayKind>(), Ok(k));
        }
        assert!("umbra".parse::<RayKind>().unwrap_err().contains("unknown ray kind 'umbra'"));
    }
}
