//! The Whitted integrator against closed forms, at one sample per pixel: diffuse and glossy
//! radiance under point and directional lights, hard shadows, a perfect mirror, a glass slab
//! at normal incidence, the AOVs, barycentric interpolation, the checkerboard, ray counts and
//! refused scenes.

mod common;

use std::f64::consts::PI;

use common::{lecture_ray, rel};
use glam::DVec3;
use strahl::geometry::{Plane, Sphere};
use strahl::integrator::whitted::THROUGHPUT_CUTOFF;
use strahl::integrator::{self, RayCounts, RenderError};
use strahl::light::Light;
use strahl::material::{Material, Texture};
use strahl::math::Vec3;
use strahl::scene::{CameraSpec, ImageSpec, IntegratorKind, Mesh, RenderSpec, Scene};

const RHO: Vec3 = Vec3::new(0.8, 0.5, 0.2);
const AMBIENT: Vec3 = Vec3::new(0.1, 0.2, 0.05);
const BACKGROUND: Vec3 = Vec3::new(0.3, 0.6, 0.9);
const POINT: Vec3 = Vec3::new(1.0, 3.0, -1.0);
const INTENSITY: Vec3 = Vec3::new(10.0, 20.0, 30.0);

/// The integrator these tests check.
fn whitted() -> RenderSpec {
    RenderSpec { integrator: IntegratorKind::Whitted, ..Default::default() }
}

/// A floor `y = 0` of albedo ρ under a point light, seen from above at 9×7 pixels, all of
/// which see the floor.
fn floor_scene() -> Scene {
    Scene {
        render: whitted(),
        camera: CameraSpec {
            eye: Vec3::new(0.0, 2.0, 4.0),
            target: Vec3::ZERO,
            up: Vec3::Y,
            fov_deg: 50.0,
            lens: Default::default(),
        },
        image: ImageSpec {
            width: 9,
            height: 7,
            spp: 1,
            max_depth: 8,
            background: BACKGROUND,
            ambient: AMBIENT,
            mesh_lights: true,
            mesh_light_samples: 1,
        },
        materials: vec![Material::matte("diffuse", RHO)],
        lights: vec![Light::Point { position: POINT, intensity: INTENSITY }],
        planes: vec![Plane::through(Vec3::ZERO, Vec3::Y, 0)],
        ..Default::default()
    }
}

/// Where the pixel-centre ray of `(x, y)` meets the floor `y = 0`, in f64: `(t, p)`.
fn floor_hit(s: &Scene, x: u32, y: u32) -> (f64, DVec3) {
    let (e, d) = lecture_ray(&s.camera, s.image.width, s.image.height, x, y);
    let t = -e.y / d.y;
    (t, e + t * d)
}

/// The irradiance `I·cosθ/d²` at floor point `p` from the point light, per channel.
fn point_irradiance(p: DVec3) -> DVec3 {
    let to = POINT.as_dvec3() - p;
    let cos = to.y / to.length();
    INTENSITY.as_dvec3() * cos / to.length_squared()
}

fn assert_rgb(film: &strahl::output::film::Film, x: u32, y: u32, expected: DVec3, what: &str) {
    let px = film.rgba[film.index(x, y)];
    for c in 0..3 {
        assert!(rel(px[c], expected[c]) <= 1e-5, "{what}: pixel ({x}, {y}) channel {c}: {} vs {}", px[c], expected[c]);
    }
}

#[test]
fn diffuse_floor_under_a_point_light_is_rho_over_pi_times_irradiance_plus_ambient() {
    let s = floor_scene();
    let (film, counts) = common::render(&s);
    let rho = RHO.as_dvec3();
    for y in 0..7 {
        for x in 0..9 {
            let (t, p) = floor_hit(&s, x, y);
            let expected = rho / PI * point_irradiance(p) + rho * AMBIENT.as_dvec3();
            assert_rgb(&film, x, y, expected, "diffuse floor");
            let i = film.index(x, y);
            assert_eq!(film.rgba[i][3], 1.0);
            let (_, dir) = common::lecture_ray(&s.camera, s.image.width, s.image.height, x, y);
            let z = common::axis_depth(&s.camera, dir, t);
            assert!(rel(film.depth[i], z) <= 1e-5, "depth {} vs {z}", film.depth[i]);
            assert_eq!((film.normal[i], film.albedo[i]), (Vec3::Y, RHO));
        }
    }
    assert_eq!(counts, RayCounts { primary: 63, shadow: 63, reflected: 0, refracted: 0 });
}

#[test]
fn point_and_directional_lights_add_and_a_glossy_lobe_adds_its_highlight() {
    // Both kinds of light, and a normalised Blinn–Phong lobe k_s·K(n)·(n·h)^n on top of ρ/π.
    let (ks, n) = (Vec3::new(0.3, 0.2, 0.1), 20.0f32);
    let sun_dir = Vec3::new(-1.0, -2.0, 0.5);
    let sun_e = Vec3::new(2.0, 1.5, 1.0);
    let mut s = floor_scene();
    s.materials[0].specular = ks;
    s.materials[0].shininess = n;
    s.lights.push(Light::Directional { direction: sun_dir, irradiance: sun_e });
    let (film, counts) = common::render(&s);
    let (rho, ks, nd) = (RHO.as_dvec3(), ks.as_dvec3(), n as f64);
    let k = (nd + 2.0) * (nd + 4.0) / (8.0 * PI * ((-0.5 * nd).exp2() + nd));
    for y in 0..7 {
        for x in 0..9 {
            let (_, p) = floor_hit(&s, x, y);
            let wo = (s.camera.eye.as_dvec3() - p).normalize();
            let to_point = (POINT.as_dvec3() - p).normalize();
            let to_sun = -sun_dir.as_dvec3().normalize();
            let brdf = |wi: DVec3| rho / PI + ks * k * (wi + wo).normalize().y.powf(nd);
            let expected = brdf(to_point) * point_irradiance(p)
                + brdf(to_sun) * sun_e.as_dvec3() * to_sun.y
                + rho * AMBIENT.as_dvec3();
            assert_rgb(&film, x, y, expected, "two lights, glossy");
        }
    }
    assert_eq!(counts.shadow, 2 * 63);
}

#[test]
fn a_shadowed_point_gets_the_ambient_term_only() {
    // A ball halfway between the light and the floor point the centre pixel sees (the
    // origin: the camera looks at it), out of the camera's view of that point.
    let mut s = floor_scene();
    let centre = 0.5 * POINT;
    s.spheres.push(Sphere { center: centre, radius: 0.3, material: 0 });
    let (film, _) = common::render(&s);
    let (_, p) = floor_hit(&s, 4, 3);
    assert!(p.length() < 1e-6, "the centre pixel sees the origin, not {p}");
    let expected = RHO.as_dvec3() * AMBIENT.as_dvec3();
    assert_rgb(&film, 4, 3, expected, "shadowed");
    assert_eq!(film.albedo[film.index(4, 3)], RHO); // still the floor, not the ball
    // A corner pixel far from the shadow keeps its direct light.
    let (_, p) = floor_hit(&s, 0, 6);
    let rho = RHO.as_dvec3();
    assert_rgb(&film, 0, 6, rho / PI * point_irradiance(p) + rho * AMBIENT.as_dvec3(), "lit");
}

#[test]
fn a_perfect_mirror_shows_the_background_exactly() {
    let mut s = floor_scene();
    s.materials[0] = Material::mirror("mirror", Vec3::ONE);
    let (film, counts) = common::render(&s);
    for (i, px) in film.rgba.iter().enumerate() {
        assert_eq!(px, &[BACKGROUND.x, BACKGROUND.y, BACKGROUND.z, 1.0], "pixel {i}");
        assert_eq!(film.albedo[i], Vec3::ZERO);
    }
    // No diffuse or glossy part, so no shadow rays; one reflected ray per pixel.
    assert_eq!(counts, RayCounts { primary: 63, shadow: 0, reflected: 63, refracted: 0 });
}

/// Glass between the planes `z = 0` and `z = −1`, normals outward, seen head-on through a
/// one-pixel camera (whose one ray is exactly −z) against a uniform background.
fn slab_scene(max_depth: u32) -> Scene {
    let glass = Material::clear_glass("glass", 1.5);
    Scene {
        render: whitted(),
        camera: CameraSpec {
            eye: Vec3::new(0.0, 0.0, 5.0),
            target: Vec3::ZERO,
            up: Vec3::Y,
            fov_deg: 30.0,
            lens: Default::default(),
        },
        image: ImageSpec {
            width: 1,
            height: 1,
            spp: 1,
            max_depth,
            background: BACKGROUND,
            ambient: AMBIENT,
            mesh_lights: true,
            mesh_light_samples: 1,
        },
        materials: vec![glass],
        lights: vec![Light::Point { position: Vec3::new(0.0, 0.0, 3.0), intensity: Vec3::ONE }],
        planes: vec![Plane::through(Vec3::ZERO, Vec3::Z, 0), Plane::through(-Vec3::Z, -Vec3::Z, 0)],
        ..Default::default()
    }
}

/// The slab's radiance by the integrator's documented rules, in f64: at a hit of depth `k`
/// a reflected ray (weight R) and a refracted one (weight T) are traced if `k < max_depth`
/// and their throughput reaches the cut-off; escaping rays bring the background `b`.
/// The front face reflects out and refracts in; an inner face reflects in and refracts out.
/// Returns the radiance and the ray counts.
fn slab_series(max_depth: u32, r: f64, b: f64) -> (f64, u64, u64) {
    struct Slab {
        max_depth: u32,
        r: f64,
        t: f64,
        b: f64,
        cut: f64,
        reflected: u64,
        refracted: u64,
    }
    impl Slab {
        /// A hit on an inner face at depth `k` by a ray of throughput `tp`.
        fn inner(&mut self, k: u32, tp: f64) -> f64 {
            if k == self.max_depth {
                return 0.0;
            }
            let mut l = 0.0;
            if tp * self.r >= self.cut {
                self.reflected += 1;
                l += self.r * self.inner(k + 1, tp * self.r);
            }
            if tp * self.t >= self.cut {
                self.refracted += 1;
                l += self.t * self.b;
            }
            l
        }
    }
    let t = 1.0 - r;
    let mut slab = Slab { max_depth, r, t, b, cut: THROUGHPUT_CUTOFF as f64, reflected: 0, refracted: 0 };
    let mut l = 0.0;
    if max_depth > 0 {
        // The front face at depth 0: R out to the background, T into the glass.
        slab.reflected += 1;
        l += r * b;
        slab.refracted += 1;
        l += t * slab.inner(1, t);
    }
    (l, slab.reflected, slab.refracted)
}

#[test]
fn a_glass_slab_at_normal_incidence_transmits_what_fresnel_predicts() {
    let r = ((1.5f64 - 1.0) / (1.5 + 1.0)).powi(2); // 0.04
    let t = 1.0 - r;
    for max_depth in [0u32, 1, 2, 3, 8] {
        let s = slab_scene(max_depth);
        let (film, counts) = common::render(&s);
        let px = film.rgba[0];
        for c in 0..3 {
            let b = BACKGROUND[c] as f64;
            let (expected, reflected, refracted) = slab_series(max_depth, r, b);
            // The short series in closed form: no rays; R·b; (R + T²)·b; (R + T²(1 + R))·b.
            let closed = match max_depth {
                0 => Some(0.0),
                1 => Some(r * b),
                2 => Some((r + t * t) * b),
                3 => Some((r + t * t * (1.0 + r)) * b),
                _ => None,
            };
            if let Some(closed) = closed {
                assert!((expected - closed).abs() <= 1e-12, "the series itself, depth {max_depth}");
            }
            assert!(
                (px[c] as f64 - expected).abs() <= 1e-5 * expected.max(1e-30),
                "depth {max_depth} channel {c}: {} vs {expected}",
                px[c]
            );
            assert_eq!((counts.reflected, counts.refracted), (reflected, refracted), "depth {max_depth}");
        }
        // Glass has no diffuse albedo: no ambient, no shadow rays.
        assert_eq!((counts.primary, counts.shadow), (1, 0));
        assert_eq!(film.albedo[0], Vec3::ZERO);
        assert_eq!(film.depth[0], 5.0);
    }
    // The slab is lossless and the background uniform, so all the light that enters leaves
    // again: the infinite series is R·b + T²·b·Σ Rⁱ = b. At the default depth the truncated
    // series (cut where the throughput T·Rⁱ falls below the cut-off) loses less than the
    // cut-off's share of it.
    let b = BACKGROUND.x as f64;
    let (l8, _, _) = slab_series(8, r, b);
    assert!(l8 < b && (b - l8) / b < THROUGHPUT_CUTOFF as f64, "{l8} vs {b}");
}

#[test]
fn total_internal_reflection_keeps_light_inside() {
    // Looking up at the inside of a glass-to-air interface from within the glass, at 60°
    // from its normal (beyond the 41.8° critical angle of ior 1.5): the refracted ray does
    // not exist, everything is reflected. The camera sits inside a glass half-space y < 0.
    let glass = Material::clear_glass("glass", 1.5);
    let theta = 60f32.to_radians();
    let s = Scene {
        render: whitted(),
        camera: CameraSpec {
            eye: Vec3::new(0.0, -1.0, 0.0),
            target: Vec3::new(theta.tan(), 0.0, 0.0),
            up: Vec3::Z,
            fov_deg: 10.0,
            lens: Default::default(),
        },
        image: ImageSpec {
            width: 1,
            height: 1,
            spp: 1,
            max_depth: 1,
            background: BACKGROUND,
            ambient: Vec3::ZERO,
            mesh_lights: true,
            mesh_light_samples: 1,
        },
        materials: vec![glass],
        planes: vec![Plane::through(Vec3::ZERO, Vec3::Y, 0)],
        ..Default::default()
    };
    let (film, counts) = common::render(&s);
    // All of it reflected (R = 1), back down into the glass where it escapes: the background.
    let px = film.rgba[0];
    for c in 0..3 {
        assert!(rel(px[c], BACKGROUND[c] as f64) <= 1e-6, "channel {c}: {}", px[c]);
    }
    assert_eq!(counts, RayCounts { primary: 1, shadow: 0, reflected: 1, refracted: 0 });
}

#[test]
fn facing_perfect_mirrors_bounce_to_the_depth_limit_without_exhausting_the_stack() {
    // Two parallel perfect mirrors (y = 0 facing up, y = 1 facing down), the eye between them
    // looking straight down: every bounce hits the other mirror with throughput 1, so the
    // ray bounces exactly max_depth times and then sees nothing (the mirrors are black).
    let mirror = Material::mirror("mirror", Vec3::ONE);
    let max_depth = strahl::scene::MAX_DEPTH_LIMIT;
    let s = Scene {
        render: whitted(),
        camera: CameraSpec {
            eye: Vec3::new(0.0, 0.5, 0.0),
            target: Vec3::ZERO,
            up: Vec3::Z,
            fov_deg: 10.0,
            lens: Default::default(),
        },
        image: ImageSpec {
            width: 3,
            height: 3,
            spp: 1,
            max_depth,
            background: BACKGROUND,
            ambient: AMBIENT,
            mesh_lights: true,
            mesh_light_samples: 1,
        },
        materials: vec![mirror],
        planes: vec![Plane::through(Vec3::ZERO, Vec3::Y, 0), Plane::through(Vec3::Y, -Vec3::Y, 0)],
        ..Default::default()
    };
    // On a pool with rayon's default stack size.
    let pool = rayon::ThreadPoolBuilder::new().num_threads(2).build().unwrap();
    let (film, counts) = pool.install(|| common::render(&s));
    assert_eq!(counts.reflected, 9 * max_depth as u64);
    assert!(film.rgba.iter().all(|px| px[..3] == [0.0; 3]));
    let too_deep = Scene { image: ImageSpec { max_depth: max_depth + 1, ..s.image }, ..s.clone() };
    let e = integrator::render(&too_deep, &common::accel(&s), &|_| {}).unwrap_err();
    assert_eq!(e.to_string(), format!("image: max_depth {} exceeds {max_depth}", max_depth + 1));
}

#[test]
fn vertex_colours_and_normals_are_interpolated_barycentrically() {
    // One triangle facing the camera with red, green and blue corners and tilted normals,
    // beside a sphere: the albedo and normal AOVs are (1−u−v)q0 + u·q1 + v·q2 of the hit's
    // barycentrics (solved here in f64), and the sphere's normal is (p − c)/r.
    let corners = [Vec3::new(-1.5, -1.0, 0.0), Vec3::new(0.5, -1.0, 0.0), Vec3::new(-1.5, 1.2, 0.0)];
    let colours = [Vec3::X, Vec3::Y, Vec3::Z];
    let normals = [Vec3::new(-0.3, 0.0, 1.0), Vec3::new(0.3, 0.0, 1.0), Vec3::new(0.0, 0.4, 1.0)];
    let sphere = Sphere { center: Vec3::new(1.2, 0.3, -0.5), radius: 0.6, material: 0 };
    let s = Scene {
        render: whitted(),
        camera: CameraSpec {
            eye: Vec3::new(0.0, 0.0, 4.0),
            target: Vec3::ZERO,
            up: Vec3::Y,
            fov_deg: 40.0,
            lens: Default::default(),
        },
        image: ImageSpec { width: 32, height: 24, spp: 1, ..Default::default() },
        materials: vec![Material::matte("diffuse", Vec3::ONE)],
        meshes: vec![Mesh {
            name: "tri".into(),
            positions: corners.to_vec(),
            indices: vec![[0, 1, 2]],
            normals: Some(normals.to_vec()),
            colors: Some(colours.to_vec()),
            ..Default::default()
        }],
        spheres: vec![sphere],
        ..Default::default()
    };
    let (film, _) = common::render(&s);
    let [p0, p1, p2] = corners.map(|c| c.as_dvec3());
    let (mut on_triangle, mut on_sphere) = (0, 0);
    for y in 0..24 {
        for x in 0..32 {
            let i = film.index(x, y);
            let (e, d) = lecture_ray(&s.camera, 32, 24, x, y);
            // Ray–triangle by Cramer's rule: e + t·d = p0 + u(p1 − p0) + v(p2 − p0).
            let (e1, e2, q) = (p1 - p0, p2 - p0, e - p0);
            let det = (-d).dot(e1.cross(e2));
            let t = q.dot(e1.cross(e2)) / det;
            let u = (-d).dot(q.cross(e2)) / det;
            let v = (-d).dot(e1.cross(q)) / det;
            let margin = 1e-3;
            if u > margin && v > margin && u + v < 1.0 - margin {
                on_triangle += 1;
                let bary = |q: [Vec3; 3]| (1.0 - u - v) * q[0].as_dvec3() + u * q[1].as_dvec3() + v * q[2].as_dvec3();
                let (albedo, normal) = (bary(colours), bary(normals).normalize());
                assert!((film.albedo[i].as_dvec3() - albedo).abs().max_element() <= 1e-5, "pixel ({x}, {y})");
                assert!((film.normal[i].as_dvec3() - normal).abs().max_element() <= 1e-5, "pixel ({x}, {y})");
                assert!(rel(film.depth[i], common::axis_depth(&s.camera, d, t)) <= 1e-5);
                continue;
            }
            let f = e - sphere.center.as_dvec3();
            let (b, c) = (d.dot(f), f.dot(f) - (sphere.radius as f64).powi(2));
            if b * b - c > 1e-3 && !(u > -margin && v > -margin && u + v < 1.0 + margin) {
                on_sphere += 1;
                let t = -b - (b * b - c).sqrt();
                let normal = (e + t * d - sphere.center.as_dvec3()) / sphere.radius as f64;
                assert!((film.normal[i].as_dvec3() - normal).abs().max_element() <= 1e-5, "pixel ({x}, {y})");
                assert_eq!(film.albedo[i], Vec3::ONE);
            }
        }
    }
    assert!(on_triangle > 100 && on_sphere > 20, "{on_triangle} triangle and {on_sphere} sphere pixels");
}

#[test]
fn the_checkerboard_floor_alternates_by_world_cell() {
    // Whitted's floor: a checker of unit cubes on the plane y = −1 (a cell boundary), seen
    // from above; the albedo AOV names the cell of each pixel's hit point.
    let (even, odd) = (Vec3::new(1.0, 0.2, 0.2), Vec3::new(0.9, 0.9, 0.1));
    let s = Scene {
        render: whitted(),
        camera: CameraSpec {
            eye: Vec3::new(0.3, 6.0, 2.0),
            target: Vec3::new(0.2, -1.0, -0.5),
            up: Vec3::Y,
            fov_deg: 60.0,
            lens: Default::default(),
        },
        image: ImageSpec { width: 40, height: 30, spp: 1, ..Default::default() },
        materials: vec![Material { diffuse: Texture::Checker { even, odd, size: 1.0 }, ..Default::default() }],
        planes: vec![Plane::through(-Vec3::Y, Vec3::Y, 0)],
        ..Default::default()
    };
    let (film, _) = common::render(&s);
    let (mut seen_even, mut seen_odd) = (0, 0);
    for y in 0..30 {
        for x in 0..40 {
            let (e, d) = lecture_ray(&s.camera, 40, 30, x, y);
            let p = e + (-1.0 - e.y) / d.y * d;
            let near_edge = [p.x, p.z].iter().any(|c| (c - c.round()).abs() < 1e-3);
            if near_edge {
                continue;
            }
            // The floor's cell below y = −1 is ⌊y⌋ = −2 (the lookup goes into the floor).
            let cell = p.x.floor() as i64 + p.z.floor() as i64 - 2;
            let expected = if cell.rem_euclid(2) == 0 { even } else { odd };
            assert_eq!(film.albedo[film.index(x, y)], expected, "pixel ({x}, {y}) at {p}");
            if expected == even { seen_even += 1 } else { seen_odd += 1 }
        }
    }
    assert!(seen_even > 100 && seen_odd > 100);
}

#[test]
fn rays_that_miss_everything_see_the_background_and_leave_empty_aovs() {
    let mut s = floor_scene();
    s.camera.target = Vec3::new(0.0, 4.0, 0.0); // looking up, away from the floor
    let (film, counts) = common::render(&s);
    for i in 0..film.rgba.len() {
        // An opaque frame: the background in RGB, alpha 1.
        assert_eq!(film.rgba[i], [BACKGROUND.x, BACKGROUND.y, BACKGROUND.z, 1.0]);
        assert_eq!((film.depth[i], film.normal[i], film.albedo[i]), (f32::INFINITY, Vec3::ZERO, Vec3::ZERO));
    }
    assert_eq!(counts, RayCounts { primary: 63, ..Default::default() });
    // Transparent: RGBA 0 where nothing is hit.
    s.output.transparent = true;
    let (film, _) = common::render(&s);
    assert!(film.rgba.iter().all(|&px| px == [0.0; 4]));
}

#[test]
fn progress_adds_up_to_the_pixel_count() {
    let mut s = floor_scene();
    (s.image.width, s.image.height) = (37, 20); // tiles of 16: partial ones at the edges
    let done = std::sync::atomic::AtomicU64::new(0);
    let accel = common::accel(&s);
    integrator::render(&s, &accel, &|n| {
        done.fetch_add(n, std::sync::atomic::Ordering::Relaxed);
    })
    .unwrap();
    assert_eq!(done.into_inner(), 37 * 20);
}

#[test]
fn scenes_that_cannot_be_rendered_are_refused_with_one_line() {
    let err = |s: Scene| integrator::render(&s, &common::accel(&s), &|_| {}).unwrap_err();
    let mut s = floor_scene();
    s.spheres.push(Sphere { center: Vec3::ZERO, radius: 1.0, material: 3 });
    let e = err(s);
    assert!(matches!(e, RenderError::InvalidScene(_)));
    assert_eq!(e.to_string(), "sphere 0: material 3 does not exist (the scene has 1)");
    let mut s = floor_scene();
    s.image.spp = 0;
    assert_eq!(err(s).to_string(), "image: spp 0 must be at least 1");
    let mut s = floor_scene();
    s.camera.up = Vec3::new(0.0, -2.0, -4.0); // along the view direction
    let e = err(s);
    assert!(matches!(e, RenderError::Camera(_)), "{e:?}");
    assert!(e.to_string().starts_with("camera: up"));
    let mut s = floor_scene();
    s.materials[0].ior = f32::NAN;
    assert!(err(s).to_string().starts_with("material 0 'diffuse': ior NaN"));
    let mut s = floor_scene();
    s.lights.push(Light::Directional { direction: Vec3::ZERO, irradiance: Vec3::ONE });
    assert!(err(s).to_string().starts_with("light 1: direction"));
}
