//! The native BVH: the same hits as testing every primitive, closest and any hit, on random
//! scenes of triangles, spheres and planes; a tree that does not depend on the thread count;
//! analytic hits through the `Accel` interface; bad input refused.

mod common;

use strahl::accel::bvh::{BuildOptions, Bvh, Kernel};
use strahl::accel::{Accel, Hit};
use strahl::geometry::triangle::{self, RayFrame};
use strahl::geometry::{Plane, Sphere, plane, sphere};
use strahl::math::{Aabb, Ray, Vec3};
use strahl::scene::{Mesh, Scene, procedural};

/// The closest hit by testing every primitive with the shared intersection routines.
fn brute_force(scene: &Scene, ray: &Ray) -> Option<Hit> {
    let mut best: Option<Hit> = None;
    let mut tfar = ray.tfar;
    if let Some((t, i)) = plane::closest(&scene.planes, ray.org, ray.dir, ray.tnear, tfar) {
        tfar = t;
        let ng = scene.planes[i as usize].normal;
        best = Some(Hit { t, ng, u: 0.0, v: 0.0, geom_id: scene.planes_geom_id(), prim_id: i });
    }
    let frame = RayFrame::new(ray.org, ray.dir);
    let mut triangle_hit = None;
    for (m, mesh) in scene.meshes.iter().enumerate() {
        for i in 0..mesh.indices.len() {
            let [p0, p1, p2] = mesh.triangle(i);
            if let Some(h) = triangle::intersect(&frame, p0, p1, p2, ray.tnear, tfar) {
                tfar = h.t;
                let ng = triangle::normal(p0, p1, p2);
                best = Some(Hit { t: h.t, ng, u: h.u, v: h.v, geom_id: m as u32, prim_id: i as u32 });
                triangle_hit = Some((m, i));
            }
        }
    }
    for (i, s) in scene.spheres.iter().enumerate() {
        if let Some(t) = sphere::intersect(ray.org, ray.dir, s.center, s.radius, ray.tnear, tfar) {
            tfar = t;
            let ng = (ray.org - s.center) + t * ray.dir;
            let (u, v) = sphere::uv(ng / s.radius);
            best = Some(Hit { t, ng, u, v, geom_id: scene.spheres_geom_id(), prim_id: i as u32 });
            triangle_hit = None;
        }
    }
    // The closest triangle reports its t as the BVH does.
    if let (Some(hit), Some((m, i))) = (&mut best, triangle_hit) {
        let tfar = plane::closest(&scene.planes, ray.org, ray.dir, ray.tnear, ray.tfar).map_or(ray.tfar, |(t, _)| t);
        hit.t = triangle::reported_t(ray.org, ray.dir, scene.meshes[m].triangle(i), hit.t, ray.tnear, tfar);
    }
    best
}

fn random_scene(seed: u64, triangles: usize, spheres: usize, planes: bool) -> Scene {
    let b = Aabb::new(Vec3::splat(-2.0), Vec3::splat(2.0));
    let mut scene = Scene::default();
    scene.meshes.push(procedural::random_triangles(triangles / 2, b, 0.3, seed));
    let mut ico = procedural::icosphere(3);
    for p in &mut ico.positions {
        *p = *p * 0.7 + Vec3::new(0.5, -0.3, 0.2);
    }
    scene.meshes.push(ico);
    scene.meshes.push(procedural::random_triangles(triangles - triangles / 2, b, 0.05, seed + 1));
    scene.spheres = procedural::random_spheres(spheres, b, (0.02, 0.3), seed + 2);
    if planes {
        scene.planes.push(Plane::through(Vec3::new(0.0, -2.5, 0.0), Vec3::Y, 0));
        scene.planes.push(Plane::through(Vec3::new(2.7, 0.0, 0.0), Vec3::new(-1.0, 0.2, 0.1), 0));
    }
    scene
}

/// Rays from inside and around the scene, plus segments that end early and start late.
fn rays(scene: &Scene, n: usize, seed: u64) -> Vec<Ray> {
    let mut rays = procedural::random_rays(n, scene.bounds(), seed);
    for (i, r) in rays.iter_mut().enumerate() {
        match i % 4 {
            1 => r.tfar = 0.5 + (i % 7) as f32 * 0.3,
            2 => r.tnear = 0.2 + (i % 5) as f32 * 0.2,
            _ => {}
        }
    }
    rays
}

fn assert_same(scene: &Scene, bvh: &Bvh, rays: &[Ray]) -> usize {
    let mut hits = 0;
    for (i, ray) in rays.iter().enumerate() {
        let got = bvh.intersect(ray).unwrap();
        let want = brute_force(scene, ray);
        match (got, want) {
            (Some(g), Some(w)) => {
                // The same routines on the same data: the same hit, bit for bit; a different
                // primitive only at the same t (a tie, e.g. a ray through a shared vertex, where
                // the two triangles' planes give t to an ulp or so).
                if (g.geom_id, g.prim_id) == (w.geom_id, w.prim_id) {
                    assert_eq!(g, w, "ray {i}");
                } else {
                    assert!((g.t - w.t).abs() <= 4.0 * f32::EPSILON * w.t, "ray {i} {ray:?}: {g:?} vs {w:?}");
                }
                hits += 1;
            }
            (g, w) => assert_eq!(g.is_some(), w.is_some(), "ray {i} {ray:?}: native {g:?}, brute force {w:?}"),
        }
        assert_eq!(bvh.occluded(ray).unwrap(), want.is_some(), "ray {i} {ray:?}: any hit");
    }
    hits
}

#[test]
fn same_hits_as_brute_force_on_random_scenes() {
    for (seed, tris, spheres, planes) in
        [(1, 3000, 200, true), (2, 500, 0, false), (3, 0, 500, true), (4, 2000, 50, false)]
    {
        let scene = random_scene(seed, tris, spheres, planes);
        let bvh = Bvh::build(&scene).unwrap();
        let rays = rays(&scene, 4000, seed + 100);
        let hits = assert_same(&scene, &bvh, &rays);
        assert!(hits > 250, "seed {seed}: only {hits} hits");
    }
}

/// The portable kernel against brute force, and every kernel this CPU runs against the
/// portable one: the same hits to the bit, closest and any, on random rays and on
/// axis-parallel rays through box faces and corners (where the slab test meets 0·∞).
#[test]
fn every_kernel_gives_the_portable_kernels_hits() {
    let kernels = [
        Kernel::Portable,
        #[cfg(target_arch = "x86_64")]
        Kernel::Avx2,
    ];
    for (seed, tris, spheres, planes) in [(5, 3000, 200, true), (6, 20_000, 0, false)] {
        let scene = random_scene(seed, tris, spheres, planes);
        let mut rays = rays(&scene, 4000, seed + 100);
        // Axis-parallel rays through a grid of points: faces and corners of the leaf boxes.
        for i in 0..2000 {
            let p = Vec3::new((i % 13) as f32 * 0.25 - 1.5, (i / 13 % 11) as f32 * 0.25 - 1.25, -3.0);
            let axis = [Vec3::X, Vec3::Y, Vec3::Z, -Vec3::X, -Vec3::Y, -Vec3::Z][i % 6];
            rays.push(Ray::new(rotate(p, i % 3) - 3.0 * axis, axis));
        }
        let portable = Bvh::build(&scene).unwrap().with_kernel(Kernel::Portable).unwrap();
        let hits = assert_same(&scene, &portable, &rays[..4000]);
        assert!(hits > 250, "seed {seed}: only {hits} hits");
        for kernel in kernels {
            let Some(bvh) = Bvh::build(&scene).unwrap().with_kernel(kernel) else {
                common::skip(&format!("the {} kernel: this CPU does not run it", kernel.name()));
                continue;
            };
            assert_eq!(bvh.kernel(), kernel);
            for (i, ray) in rays.iter().enumerate() {
                assert_eq!(bvh.intersect(ray).unwrap(), portable.intersect(ray).unwrap(), "{kernel:?}, ray {i}");
                assert_eq!(bvh.occluded(ray).unwrap(), portable.occluded(ray).unwrap(), "{kernel:?}, ray {i}");
            }
        }
    }
    // Ties: 300 copies of one triangle, every hit at the same t in every block of a leaf. The
    // kernels must pick the same copy (the first block, then the lowest lane), whether they
    // test a leaf's blocks one by one or several at once.
    let tri = [Vec3::new(0.0, 0.0, 0.0), Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.0, 1.0, 0.0)];
    let stack = Scene {
        meshes: vec![Mesh {
            name: "stack".into(),
            positions: tri.to_vec(),
            indices: vec![[0, 1, 2]; 300],
            ..Default::default()
        }],
        ..Default::default()
    };
    for max_leaf in [4, 8, 12, 16, 32] {
        let options = BuildOptions { max_leaf, traversal_cost: 2.0 };
        let portable = Bvh::build_with(&stack, &options).unwrap().with_kernel(Kernel::Portable).unwrap();
        for kernel in kernels {
            let Some(bvh) = Bvh::build_with(&stack, &options).unwrap().with_kernel(kernel) else { continue };
            for (x, y) in [(0.2, 0.2), (0.5, 0.25), (0.0, 0.5), (0.5, 0.5), (0.1, 0.7)] {
                let down = Ray::new(Vec3::new(x, y, 1.0), Vec3::new(0.01, -0.02, -1.0));
                let hit = bvh.intersect(&down).unwrap();
                assert!(hit.is_some(), "({x}, {y})");
                assert_eq!(hit, portable.intersect(&down).unwrap(), "{kernel:?}, max_leaf {max_leaf} ({x}, {y})");
                assert!(bvh.occluded(&down).unwrap());
            }
        }
    }
    for k in 0..3 {
        let scene = quad_scene(k);
        let portable = Bvh::build(&scene).unwrap().with_kernel(Kernel::Portable).unwrap();
        for kernel in kernels {
            let Some(bvh) = Bvh::build(&scene).unwrap().with_kernel(kernel) else { continue };
            for (x, y) in [(1.0, 2.0), (3.0, 2.0), (2.0, 3.0), (1.0, 1.0), (3.0, 3.0), (0.999, 2.0), (3.001, 2.0)] {
                let down = Ray::new(rotate(Vec3::new(x, y, 5.0), k), rotate(-Vec3::Z, k));
                assert_eq!(bvh.intersect(&down).unwrap(), portable.intersect(&down).unwrap(), "{kernel:?} ({x}, {y})");
                assert_eq!(bvh.occluded(&down).unwrap(), portable.occluded(&down).unwrap(), "{kernel:?} ({x}, {y})");
            }
        }
    }
}

#[test]
fn tiny_and_empty_scenes() {
    // Nothing at all; a single sphere (the root is a leaf); planes only.
    let ray = Ray::new(Vec3::new(0.0, 0.0, -5.0), Vec3::Z);
    let empty = Bvh::build(&Scene::default()).unwrap();
    assert_eq!(empty.intersect(&ray).unwrap(), None);
    assert!(!empty.occluded(&ray).unwrap());
    let mut scene = Scene::default();
    scene.spheres.push(Sphere { center: Vec3::new(0.0, 0.0, 1.0), radius: 2.0, material: 0 });
    let bvh = Bvh::build(&scene).unwrap();
    let h = bvh.intersect(&ray).unwrap().unwrap();
    // Enters at z = −1: t = 4, normal −z·r, u = v = 0.5 as Embree's callback reports.
    assert_eq!(h, Hit { t: 4.0, ng: Vec3::new(0.0, 0.0, -2.0), u: 0.5, v: 0.5, geom_id: 0, prim_id: 0 });
    let mut planes = Scene::default();
    planes.planes.push(Plane::through(Vec3::new(0.0, 0.0, 3.0), -Vec3::Z, 0));
    let bvh = Bvh::build(&planes).unwrap();
    assert_eq!(bvh.intersect(&ray).unwrap().map(|h| (h.t, h.geom_id, h.prim_id)), Some((8.0, 1, 0)));
}

/// Two triangles forming the square (1..3, 1..3) at z = 1, as in tests/embree.rs, with the
/// coordinates rotated by `k` axes (so each axis takes a turn as the quad's normal).
fn quad_scene(k: usize) -> Scene {
    let mut scene = Scene::default();
    scene.meshes.push(Mesh { name: "empty".into(), ..Default::default() });
    let corners = [[1.0, 1.0, 1.0], [3.0, 1.0, 1.0], [1.0, 3.0, 1.0], [3.0, 3.0, 1.0]];
    scene.meshes.push(Mesh {
        name: "quad".into(),
        positions: corners.iter().map(|&c| rotate(Vec3::from(c), k)).collect(),
        indices: vec![[0, 1, 2], [3, 2, 1]],
        ..Default::default()
    });
    // Far-away clutter, so that the quad is a leaf below a node whose boxes get tested.
    scene.meshes.push(procedural::random_triangles(6, Aabb::new(Vec3::splat(20.0), Vec3::splat(30.0)), 1.0, 1));
    scene
}

fn rotate(v: Vec3, k: usize) -> Vec3 {
    Vec3::new(v[k % 3], v[(k + 1) % 3], v[(k + 2) % 3])
}

#[test]
fn quad_hits_through_the_accel_interface() {
    for k in 0..3 {
        let bvh = Bvh::build(&quad_scene(k)).unwrap();
        let down = |x: f32, y: f32| Ray::new(rotate(Vec3::new(x, y, 5.0), k), rotate(-Vec3::Z, k));
        let h = bvh.intersect(&down(1.5, 1.5)).unwrap().unwrap();
        let ng = rotate(Vec3::new(0.0, 0.0, 4.0), k);
        assert_eq!(h, Hit { t: 4.0, ng, u: 0.25, v: 0.25, geom_id: 1, prim_id: 0 });
        let h = bvh.intersect(&down(2.5, 2.5)).unwrap().unwrap();
        assert_eq!((h.prim_id, h.u, h.v), (1, 0.25, 0.25));
        // Axis-aligned rays exactly on the box faces (x = 1, x = 3, y = 3) and corners: the
        // slab test sees 0·∞ there and must not cull them.
        for (x, y) in [(1.0, 2.0), (3.0, 2.0), (2.0, 3.0), (2.0, 1.0), (1.0, 1.0), (3.0, 3.0), (2.0, 2.0)] {
            let h = bvh.intersect(&down(x, y)).unwrap();
            assert_eq!(h.map(|h| h.t), Some(4.0), "axes {k}: ray at ({x}, {y})");
            assert!(bvh.occluded(&down(x, y)).unwrap(), "axes {k}: ray at ({x}, {y})");
        }
        for (x, y) in [(0.999, 2.0), (3.001, 2.0), (2.0, 3.001)] {
            assert_eq!(bvh.intersect(&down(x, y)).unwrap(), None, "axes {k}: ray at ({x}, {y})");
        }
        // In the quad's plane: parallel, no hit; along the normal from below.
        let along = Ray::new(rotate(Vec3::new(0.0, 2.0, 1.0), k), rotate(Vec3::X, k));
        assert_eq!(bvh.intersect(&along).unwrap(), None);
        let up = Ray::new(rotate(Vec3::new(2.0, 1.5, -1.0), k), rotate(Vec3::Z, k));
        assert_eq!(bvh.intersect(&up).unwrap().map(|h| h.t), Some(2.0));
        // Non-finite rays are refused quietly (no hit), not traced.
        assert_eq!(bvh.intersect(&Ray::new(Vec3::new(f32::NAN, 2.0, 5.0), -Vec3::Z)).unwrap(), None);
        assert!(!bvh.occluded(&Ray::new(Vec3::new(2.0, 2.0, 5.0), Vec3::new(0.0, f32::INFINITY, -1.0))).unwrap());
    }
}

#[test]
fn tree_does_not_depend_on_the_thread_count() {
    let scene = random_scene(9, 60_000, 2000, false);
    let pool = |n| rayon::ThreadPoolBuilder::new().num_threads(n).build().unwrap();
    let one = pool(1).install(|| Bvh::build(&scene).unwrap());
    let two = pool(2).install(|| Bvh::build(&scene).unwrap());
    let three = pool(3).install(|| Bvh::build(&scene).unwrap());
    assert_eq!(one.stats(), two.stats());
    assert_eq!(one.stats(), three.stats());
    // Same tree, so the same hits, to the bit, for every ray.
    for ray in procedural::random_rays(20_000, scene.bounds(), 5) {
        let h1 = one.intersect(&ray).unwrap();
        assert_eq!(h1, two.intersect(&ray).unwrap());
        assert_eq!(h1, three.intersect(&ray).unwrap());
    }
}

#[test]
fn bad_input_is_refused_with_its_name() {
    let mut scene = Scene::default();
    scene.spheres.push(Sphere { center: Vec3::ZERO, radius: -1.0, material: 0 });
    let err = Bvh::build(&scene).err().unwrap().to_string();
    assert_eq!(err, "sphere 0 of 'spheres': radius -1 must be > 0");
    let mut scene = Scene::default();
    scene.meshes.push(Mesh {
        name: "broken".into(),
        positions: vec![Vec3::ZERO],
        indices: vec![[0, 0, 1]],
        ..Default::default()
    });
    let err = Bvh::build(&scene).err().unwrap().to_string();
    assert!(err.starts_with("mesh 'broken': triangle 0 has index"), "{err}");
    let mut scene = Scene::default();
    scene.planes.push(Plane { normal: Vec3::new(0.0, 2.0, 0.0), dist: 0.0, material: 0 });
    let err = Bvh::build(&scene).err().unwrap().to_string();
    assert!(err.starts_with("plane 0: normal"), "{err}");
}

#[test]
fn coincident_triangles_build_and_trace() {
    // 5000 copies of one triangle: no plane separates them. The tree still has small leaves
    // and a bounded depth, and a ray through it hits one copy.
    let tri = [Vec3::new(0.0, 0.0, 0.0), Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.0, 1.0, 0.0)];
    let mut scene = Scene::default();
    scene.meshes.push(Mesh {
        name: "stack".into(),
        positions: tri.to_vec(),
        indices: vec![[0, 1, 2]; 5000],
        ..Default::default()
    });
    let bvh = Bvh::build(&scene).unwrap();
    assert!(bvh.stats().depth <= 40, "depth {}", bvh.stats().depth);
    let h = bvh.intersect(&Ray::new(Vec3::new(0.2, 0.2, 1.0), -Vec3::Z)).unwrap().unwrap();
    assert_eq!((h.t, h.geom_id), (1.0, 0));
    assert!(h.prim_id < 5000);
}

#[test]
fn deep_trees_trace_with_a_growable_stack() {
    // Triangles at geometrically growing distances along x: the SAH peels them off one at a
    // time, giving a tree deeper than the fixed traversal stack allows for.
    let mut mesh = Mesh { name: "chain".into(), ..Default::default() };
    for k in 0..2000 {
        let x = 1.02f32.powi(k);
        let i = mesh.positions.len() as u32;
        mesh.positions.extend([Vec3::new(x, -1.0, -1.0), Vec3::new(x, 1.0, -1.0), Vec3::new(x, 0.0, 1.0)]);
        mesh.indices.push([i, i + 1, i + 2]);
    }
    let scene = Scene { meshes: vec![mesh], ..Default::default() };
    let bvh = Bvh::build_with(&scene, &BuildOptions { max_leaf: 1, traversal_cost: 1.0 }).unwrap();
    assert!(bvh.stats().depth > 9, "depth {}", bvh.stats().depth);
    // Rays along the chain from just before each triangle, and some from the far end back.
    let mut rays: Vec<Ray> =
        (0..2000).map(|k| Ray::new(Vec3::new(0.999 * 1.02f32.powi(k), 0.2, 0.1), Vec3::X)).collect();
    rays.extend((0..100).map(|i| Ray::new(Vec3::new(1e18, 0.01 * i as f32 - 0.5, 0.0), -Vec3::X)));
    let hits = assert_same(&scene, &bvh, &rays);
    assert_eq!(hits, 2100);
}

/// Rays from inside a closed icosphere through every vertex and every edge midpoint, where
/// two to six triangles meet: the watertight triangle test lets none through (robust Embree
/// still misses a few of the vertex rays; tests/embree.rs).
#[test]
fn a_closed_mesh_has_no_holes_at_edges_or_vertices() {
    let mesh = procedural::icosphere(5);
    let scene = Scene { meshes: vec![mesh.clone()], ..Default::default() };
    let bvh = Bvh::build(&scene).unwrap();
    let midpoints = mesh
        .indices
        .iter()
        .flat_map(|&[a, b, c]| [(a, b), (b, c), (c, a)])
        .map(|(p, q)| 0.5 * (mesh.positions[p as usize] + mesh.positions[q as usize]));
    let targets: Vec<Vec3> = mesh.positions.iter().copied().chain(midpoints).collect();
    for org in [Vec3::ZERO, Vec3::new(0.1, -0.2, 0.05), Vec3::new(-0.3, 0.1, 0.2)] {
        for (i, t) in targets.iter().enumerate() {
            let ray = Ray::new(org, (*t - org).normalize());
            assert!(bvh.intersect(&ray).unwrap().is_some(), "ray from {org} through target {i} ({t}) slipped through");
        }
    }
}
