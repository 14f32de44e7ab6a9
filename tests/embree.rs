//! The Embree layer: analytic hits through Embree's triangles and strahl's user-geometry
//! spheres, packet vs single-ray vs multi-threaded agreement, errors, bad input, panics.

use strahl::accel::embree::{BuildOptions, Device, EmbreeAccel, Error, SceneBuilder, sys};
use strahl::accel::{Accel, Hit};
use strahl::geometry::{Plane, Sphere};
use strahl::math::{Aabb, Ray, Vec3};
use strahl::scene::{Mesh, Scene, procedural};

fn device() -> Device {
    Device::new().expect("an Embree device")
}

fn rel(a: f32, b: f64) -> f64 {
    ((a as f64) - b).abs() / b.abs()
}

/// Whether a barycentric coordinate is within 1e-6 of `b` (a few ulps near 0.25).
fn near(a: f32, b: f32) -> bool {
    (a - b).abs() <= 1e-6
}

/// One sphere of radius 2 around (1, 2, 3), nothing else.
fn sphere_scene() -> strahl::accel::embree::Scene {
    let mut b = SceneBuilder::new(&device(), BuildOptions::default()).unwrap();
    let id = b.add_spheres("ball", &[Sphere { center: Vec3::new(1.0, 2.0, 3.0), radius: 2.0, material: 0 }]).unwrap();
    assert_eq!(id, 0);
    b.commit().unwrap()
}

#[test]
fn version_of_the_library_matches_the_headers() {
    let d = device();
    assert_eq!(d.version() / 100, Device::header_version() / 100);
    assert_eq!(Device::header_version(), sys::RTC_VERSION);
    #[cfg(embree3)]
    assert_eq!(sys::RTC_VERSION_MAJOR, 3);
}

#[test]
fn sphere_from_outside_inside_tangent_away_and_behind() {
    let s = sphere_scene();
    let c = Vec3::new(1.0, 2.0, 3.0);
    // From outside along +z: enters at z = 1, t = 8, normal −z.
    let h = s.intersect(&Ray::new(Vec3::new(1.0, 2.0, -7.0), Vec3::Z)).unwrap().unwrap();
    assert_eq!((h.t, h.ng, h.geom_id, h.prim_id), (8.0, Vec3::new(0.0, 0.0, -2.0), 0, 0));
    assert_eq!((h.u, h.v), (0.5, 0.5));
    // From the centre: the far side, t = r, normal outward.
    let h = s.intersect(&Ray::new(c, Vec3::X)).unwrap().unwrap();
    assert_eq!((h.t, h.ng), (2.0, Vec3::new(2.0, 0.0, 0.0)));
    // Tangent at (1, 4, 3): the double root t = 10.
    let h = s.intersect(&Ray::new(Vec3::new(1.0, 4.0, -7.0), Vec3::Z)).unwrap().unwrap();
    assert_eq!((h.t, h.ng), (10.0, Vec3::new(0.0, 2.0, 0.0)));
    // Pointing away, and with the sphere behind the origin.
    assert_eq!(s.intersect(&Ray::new(Vec3::new(1.0, 2.0, -7.0), -Vec3::Z)).unwrap(), None);
    assert_eq!(s.intersect(&Ray::new(Vec3::new(1.0, 2.0, 7.0), Vec3::Z)).unwrap(), None);
    // Just past the tangent: a miss.
    assert_eq!(s.intersect(&Ray::new(Vec3::new(1.0, 4.0001, -7.0), Vec3::Z)).unwrap(), None);
    // Occlusion agrees, and respects tfar.
    assert!(s.occluded(&Ray::new(Vec3::new(1.0, 2.0, -7.0), Vec3::Z)).unwrap());
    assert!(!s.occluded(&Ray::segment(Vec3::new(1.0, 2.0, -7.0), Vec3::Z, 0.0, 7.9)).unwrap());
    assert!(!s.occluded(&Ray::new(Vec3::new(1.0, 2.0, -7.0), -Vec3::Z)).unwrap());
}

#[test]
fn sphere_hits_match_the_closed_form_in_f64() {
    // Rays from far away at random points of the sphere's disc (impact parameter < 0.9 r,
    // away from tangency where t is ill-conditioned): t within 1e-6 of the f64 root.
    let s = sphere_scene();
    let c = Vec3::new(1.0, 2.0, 3.0).as_dvec3();
    let origins = procedural::random_rays(2000, Aabb::new(Vec3::splat(-30.0), Vec3::splat(30.0)), 11);
    let mut checked = 0;
    for (i, o) in origins.iter().enumerate() {
        let org = o.org;
        let to_c = (Vec3::new(1.0, 2.0, 3.0) - org).normalize();
        let side = to_c.any_orthonormal_vector();
        let aim = Vec3::new(1.0, 2.0, 3.0) + side * (1.8 * (i as f32 / 2000.0)) - org;
        let dir = aim.normalize();
        if (org.as_dvec3() - c).length() < 2.5 {
            continue;
        }
        let h = s.intersect(&Ray::new(org, dir)).unwrap().expect("aimed inside the disc");
        let (e, d) = (org.as_dvec3(), dir.as_dvec3());
        let f = e - c;
        let (a, b, cc) = (d.dot(d), 2.0 * d.dot(f), f.dot(f) - 4.0);
        let t = (-b - (b * b - 4.0 * a * cc).sqrt()) / (2.0 * a);
        assert!(rel(h.t, t) <= 1e-6, "ray {i}: t {} vs {t}", h.t);
        checked += 1;
    }
    assert!(checked > 1900);
}

/// Two triangles forming the square (1..3, 1..3) in the plane z = 1, facing +z.
fn quad() -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let p =
        vec![Vec3::new(1.0, 1.0, 1.0), Vec3::new(3.0, 1.0, 1.0), Vec3::new(1.0, 3.0, 1.0), Vec3::new(3.0, 3.0, 1.0)];
    (p, vec![[0, 1, 2], [3, 2, 1]])
}

fn quad_scene() -> strahl::accel::embree::Scene {
    let (p, i) = quad();
    let mut b = SceneBuilder::new(&device(), BuildOptions::default()).unwrap();
    b.add_triangle_mesh("empty", &[], &[]).unwrap(); // takes id 0, adds nothing
    assert_eq!(b.add_triangle_mesh("quad", &p, &i).unwrap(), 1);
    b.commit().unwrap()
}

fn down_at(x: f32, y: f32) -> Ray {
    Ray::new(Vec3::new(x, y, 5.0), -Vec3::Z)
}

#[test]
fn triangle_interior_barycentrics_and_normal() {
    let s = quad_scene();
    let h = s.intersect(&down_at(1.5, 1.5)).unwrap().unwrap();
    // Ng = (p1 − p0) × (p2 − p0) = (2,0,0) × (0,2,0) = (0,0,4); u, v weight p1, p2. Embree's
    // triangle test rounds differently per ISA (AVX2 gives t = 3.9999998, u = 0.24999999 where
    // AVX-512 gives 4 and 0.25 exactly), so t, u and v are checked to a few ulps.
    assert_eq!((h.ng, h.geom_id, h.prim_id), (Vec3::new(0.0, 0.0, 4.0), 1, 0));
    assert!(rel(h.t, 4.0) <= 1e-6 && near(h.u, 0.25) && near(h.v, 0.25), "{h:?}");
    let h = s.intersect(&down_at(2.5, 2.5)).unwrap().unwrap();
    assert_eq!(h.prim_id, 1);
    assert!(near(h.u, 0.25) && near(h.v, 0.25), "{h:?}");
    // Oblique ray: t is the distance to (1.5, 1.2, 1).
    let org = Vec3::new(0.0, 0.0, 5.0);
    let target = Vec3::new(1.5, 1.2, 1.0);
    let h = s.intersect(&Ray::new(org, (target - org).normalize())).unwrap().unwrap();
    let expect = (target - org).as_dvec3().length();
    assert!(rel(h.t, expect) <= 1e-6, "t {} vs {expect}", h.t);
    assert!((h.u - 0.25).abs() < 1e-6 && (h.v - 0.1).abs() < 1e-6, "u {} v {}", h.u, h.v);
}

#[test]
fn triangle_edges_vertices_and_parallel_rays() {
    let s = quad_scene();
    let e = 1e-3;
    // Just inside / outside each outer edge of triangle 0 (y = 1, x = 1) and of the square.
    for (x, y, hit) in [
        (2.0, 1.0 + e, true),
        (2.0, 1.0 - e, false),
        (1.0 + e, 2.0, true),
        (1.0 - e, 2.0, false),
        (3.0 - e, 2.0, true),
        (3.0 + e, 2.0, false),
        (2.0, 3.0 - e, true),
        (2.0, 3.0 + e, false),
        // Near each corner.
        (1.0 + e, 1.0 + e, true),
        (1.0 - e, 1.0 - e, false),
        (3.0 - e, 1.0 + e, true),
        (1.0 + e, 3.0 - e, true),
        (3.0 - e, 3.0 - e, true),
        (3.0 + e, 3.0 + e, false),
    ] {
        let h = s.intersect(&down_at(x, y)).unwrap();
        assert_eq!(h.is_some(), hit, "ray at ({x}, {y})");
        if let Some(h) = h {
            assert!(rel(h.t, 4.0) <= 1e-6, "ray at ({x}, {y}): t {}", h.t);
        }
    }
    // Through the shared diagonal x + y = 4: one of the two triangles, never a gap.
    for k in 1..100 {
        let x = 1.0 + 2.0 * k as f32 / 100.0;
        assert!(s.intersect(&down_at(x, 4.0 - x)).unwrap().is_some(), "gap at x = {x}");
    }
    // Parallel to the plane, above it and within it: no hit.
    assert_eq!(s.intersect(&Ray::new(Vec3::new(0.0, 2.0, 2.0), Vec3::X)).unwrap(), None);
    assert_eq!(s.intersect(&Ray::new(Vec3::new(0.0, 2.0, 1.5), Vec3::X)).unwrap(), None);
    // Behind the origin.
    assert_eq!(s.intersect(&Ray::new(Vec3::new(2.0, 2.0, 0.0), -Vec3::Z)).unwrap(), None);
}

/// 1,000 random spheres and 10k random triangles, overlapping in one box.
fn busy_scene() -> (Scene, Aabb) {
    let bounds = Aabb::new(Vec3::splat(-10.0), Vec3::splat(10.0));
    let mesh = procedural::random_triangles(10_000, bounds, 0.6, 1);
    let spheres = procedural::random_spheres(1000, bounds, (0.05, 0.5), 2);
    let scene = Scene { meshes: vec![mesh], spheres, ..Default::default() };
    (scene, bounds)
}

/// 100k rays: half random, half a coherent 250×200 pinhole grid looking into the box.
fn test_rays(bounds: Aabb) -> Vec<Ray> {
    let mut rays = procedural::random_rays(50_000, bounds, 3);
    let eye = Vec3::new(0.0, 0.0, 30.0);
    for y in 0..200 {
        for x in 0..250 {
            let d = Vec3::new((x as f32 - 125.0) / 400.0, (y as f32 - 100.0) / 400.0, -1.0);
            rays.push(Ray::new(eye, d.normalize()));
        }
    }
    rays
}

#[test]
fn single_rays_packets_and_threads_agree_on_100k_rays() {
    let (scene, bounds) = busy_scene();
    let accel = EmbreeAccel::build(&device(), &scene, BuildOptions::default()).unwrap();
    let rays = test_rays(bounds);
    assert_eq!(rays.len(), 100_000);

    let single: Vec<Option<Hit>> = rays.iter().map(|r| accel.intersect(r).unwrap()).collect();
    let mut packets = vec![None; rays.len()];
    accel.intersect_batch(&rays, &mut packets).unwrap();
    let hits = single.iter().filter(|h| h.is_some()).count();
    let sphere_hits = single.iter().flatten().filter(|h| h.geom_id == scene.spheres_geom_id()).count();
    assert!(hits > 30_000 && sphere_hits > 5_000, "{hits} hits, {sphere_hits} on spheres: not a busy scene");
    for (i, (a, b)) in single.iter().zip(&packets).enumerate() {
        assert_eq!(a, b, "ray {i}: rtcIntersect1 and rtcIntersect8 differ");
    }

    // Two threads at once, each tracing every other chunk, give the same answers.
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .start_handler(|_| strahl::accel::embree::enable_flush_to_zero())
        .build()
        .unwrap();
    let threaded: Vec<Option<Hit>> = pool.install(|| {
        use rayon::prelude::*;
        rays.par_iter().with_min_len(64).map(|r| accel.intersect(r).unwrap()).collect()
    });
    assert_eq!(single, threaded);
    let occluded: Vec<bool> = pool.install(|| {
        use rayon::prelude::*;
        rays.par_iter().map(|r| accel.occluded(r).unwrap()).collect()
    });
    for (i, (h, o)) in single.iter().zip(&occluded).enumerate() {
        assert_eq!(h.is_some(), *o, "ray {i}: occluded disagrees with intersect");
    }
}

#[test]
fn planes_are_traced_with_the_rest() {
    let mut scene = Scene {
        spheres: vec![Sphere { center: Vec3::new(0.0, 1.0, 0.0), radius: 1.0, material: 0 }],
        planes: vec![Plane { normal: Vec3::Y, dist: 0.0, material: 0 }],
        ..Default::default()
    };
    scene.meshes.push(Mesh::default());
    let accel = EmbreeAccel::build(&device(), &scene, BuildOptions::default()).unwrap();
    // Straight down onto the sphere: it is in front of the floor.
    let h = accel.intersect(&Ray::new(Vec3::new(0.0, 5.0, 0.0), -Vec3::Y)).unwrap().unwrap();
    assert_eq!((h.t, h.geom_id), (3.0, scene.spheres_geom_id()));
    // Beside it: the floor.
    let h = accel.intersect(&Ray::new(Vec3::new(3.0, 5.0, 0.0), -Vec3::Y)).unwrap().unwrap();
    assert_eq!((h.t, h.geom_id, h.prim_id, h.ng), (5.0, scene.planes_geom_id(), 0, Vec3::Y));
    assert!(accel.occluded(&Ray::new(Vec3::new(3.0, 5.0, 0.0), -Vec3::Y)).unwrap());
    assert!(!accel.occluded(&Ray::segment(Vec3::new(3.0, 5.0, 0.0), -Vec3::Y, 0.0, 4.0)).unwrap());
    let mut batch = [None; 2];
    accel
        .intersect_batch(
            &[Ray::new(Vec3::new(0.0, 5.0, 0.0), -Vec3::Y), Ray::new(Vec3::new(3.0, 5.0, 0.0), -Vec3::Y)],
            &mut batch,
        )
        .unwrap();
    assert_eq!(batch[0].unwrap().t, 3.0);
    assert_eq!(batch[1].unwrap().geom_id, scene.planes_geom_id());
}

#[test]
fn an_invalid_embree_call_comes_back_as_an_error_with_its_code() {
    let err = device().invalid_call_for_tests().unwrap_err();
    assert_eq!(err.code(), Some(sys::RTC_ERROR_INVALID_OPERATION), "{err}");
    let text = err.to_string();
    assert!(
        text.contains("RTC_ERROR_INVALID_OPERATION") && text.contains("rtcSetGeometryUserPrimitiveCount"),
        "{text}"
    );
    // The error was taken: the next call reports its own, and the device keeps working.
    assert!(device().invalid_call_for_tests().is_err());
    let s = quad_scene();
    assert!(s.intersect(&down_at(1.5, 1.5)).unwrap().is_some());
}

fn rejected(result: Result<u32, Error>) -> String {
    match result {
        Err(e @ Error::InvalidInput { .. }) => e.to_string(),
        other => panic!("expected InvalidInput, got {other:?}"),
    }
}

#[test]
fn bad_input_is_rejected_before_it_reaches_embree() {
    let d = device();
    let mut b = SceneBuilder::new(&d, BuildOptions::default()).unwrap();
    let ok = Sphere { center: Vec3::ZERO, radius: 1.0, material: 0 };
    for (bad, what) in [
        (Sphere { radius: 0.0, ..ok }, "radius 0 must be > 0"),
        (Sphere { radius: -1.0, ..ok }, "radius -1 must be > 0"),
        (Sphere { radius: f32::NAN, ..ok }, "radius NaN is not finite"),
        (Sphere { radius: f32::INFINITY, ..ok }, "radius inf is not finite"),
        (Sphere { center: Vec3::new(0.0, f32::NAN, 0.0), ..ok }, "is not finite"),
    ] {
        let msg = rejected(b.add_spheres("balls", &[ok, ok, ok, bad]));
        assert!(msg.starts_with("sphere 3 of 'balls': ") && msg.contains(what), "{msg}");
    }
    let (p, _) = quad();
    let msg = rejected(b.add_triangle_mesh("bunny", &p, &[[0, 1, 2], [1, 2, 4]]));
    assert_eq!(msg, "mesh 'bunny': triangle 1 has index [1, 2, 4] out of range (the mesh has 4 vertices)");
    let mut nan = p.clone();
    nan[3].z = f32::INFINITY;
    let msg = rejected(b.add_triangle_mesh("bunny", &nan, &[[0, 1, 2]]));
    assert_eq!(msg, "mesh 'bunny': vertex 3 [3, 3, inf] is not finite");
    // Nothing was added: the ids are still free and the scene commits empty.
    assert_eq!(b.next_geom_id(), 0);
    let s = b.commit().unwrap();
    assert_eq!(s.intersect(&down_at(2.0, 2.0)).unwrap(), None);

    let scene = Scene {
        planes: vec![Plane { normal: Vec3::new(0.0, 2.0, 0.0), dist: 0.0, material: 0 }],
        ..Default::default()
    };
    let err = EmbreeAccel::build(&d, &scene, BuildOptions::default()).err().unwrap();
    assert_eq!(err.to_string(), "plane 0: normal [0, 2, 0] is not of unit length");
}

#[test]
fn a_panic_in_a_callback_becomes_an_error_not_an_unwind() {
    let d = device();
    let mut b = SceneBuilder::new(&d, BuildOptions::default()).unwrap();
    b.panic_in_sphere_callbacks_for_tests();
    b.add_spheres("ball", &[Sphere { center: Vec3::ZERO, radius: 1.0, material: 0 }]).unwrap();
    let s = b.commit().unwrap();
    let ray = Ray::new(Vec3::new(0.0, 0.0, -5.0), Vec3::Z);
    for result in [
        s.intersect(&ray).map(|_| ()),
        s.occluded(&ray).map(|_| ()),
        s.intersect_packets(&[ray; 3], &mut [None; 3], |_, hit| hit),
    ] {
        match result {
            Err(Error::CallbackPanic(m)) => assert!(m.contains("test hook"), "{m}"),
            other => panic!("expected CallbackPanic, got {other:?}"),
        }
    }
    // And other scenes on this thread are unaffected.
    assert!(sphere_scene().intersect(&Ray::new(Vec3::new(1.0, 2.0, -5.0), Vec3::Z)).unwrap().is_some());
}

#[test]
fn scenes_are_send_and_sync_and_denormals_flush() {
    fn send_sync<T: Send + Sync>() {}
    send_sync::<strahl::accel::embree::Scene>();
    send_sync::<EmbreeAccel>();
    send_sync::<Device>();
    std::thread::spawn(|| {
        strahl::accel::embree::enable_flush_to_zero();
        assert!(strahl::accel::embree::flush_to_zero_enabled());
        let tiny = std::hint::black_box(f32::MIN_POSITIVE);
        assert_eq!(std::hint::black_box(tiny * 0.5), 0.0, "denormal result not flushed");
    })
    .join()
    .unwrap();
}

/// Rays from inside a closed icosphere through every vertex and every edge midpoint: exactly
/// where two or more triangles meet and a non-watertight test lets rays slip through (a miss
/// is a hole that light leaks through). This is why `BuildOptions::default()` sets
/// `RTC_SCENE_FLAG_ROBUST`: without it Embree 3.13.5 let 11,909 of these 215,046 rays through
/// (5.5 %), and 2 of 2M random rays from inside an 82k-triangle icosphere (none with it).
/// Even robust Embree misses some rays aimed exactly at a vertex where five or six triangles
/// meet (220 of 61,446 here); the native BVH misses none (tests/bvh.rs).
#[test]
fn robust_embree_has_no_holes_at_edges_and_few_at_vertices() {
    let mesh = procedural::icosphere(5); // 20,480 triangles, 10,242 vertices
    let mut b = SceneBuilder::new(&device(), BuildOptions::default()).unwrap();
    b.add_triangle_mesh("icosphere", &mesh.positions, &mesh.indices).unwrap();
    let s = b.commit().unwrap();
    let midpoints: Vec<Vec3> = mesh
        .indices
        .iter()
        .flat_map(|&[a, b, c]| [(a, b), (b, c), (c, a)])
        .map(|(p, q)| 0.5 * (mesh.positions[p as usize] + mesh.positions[q as usize]))
        .collect();
    // Off-centre origins too, so the rays cross edges at many angles.
    let origins = [Vec3::ZERO, Vec3::new(0.1, -0.2, 0.05), Vec3::new(-0.3, 0.1, 0.2)];
    let misses = |targets: &[Vec3]| -> usize {
        let through = |org: Vec3| targets.iter().map(move |&t| Ray::new(org, (t - org).normalize()));
        origins.into_iter().flat_map(through).filter(|r| s.intersect(r).unwrap().is_none()).count()
    };
    assert_eq!(misses(&midpoints), 0, "rays through shared edges slipped through");
    let vertex_rays = origins.len() * mesh.positions.len();
    let vertex_misses = misses(&mesh.positions);
    assert!(
        vertex_misses * 100 < vertex_rays,
        "{vertex_misses} of {vertex_rays} rays through vertices slipped through"
    );
}
