//! Embree and the native BVH trace the same rays to the same hits: a million rays of each kind
//! (primary, random, secondary) through 1,000 random spheres, procedural meshes, the Stanford
//! bunny and dragon (res2) and, through `strahl crosscheck`, the Cornell box OBJ; zero
//! unexplained disagreements, and `|Δt|/t ≤ 1e-5` at the 99.9th percentile. Everything traces
//! on two threads, as CI has. The command's verdict on backends that really disagree is tested
//! in `src/cli/crosscheck.rs` (the command cannot be made to disagree from outside).

mod common;

use common::{TempDir, data_dir, fails, strahl, text};
use strahl::accel::bvh::Bvh;
use strahl::accel::embree::{BuildOptions, Device, DeviceOptions, EmbreeAccel};
use strahl::geometry::Plane;
use strahl::math::{Aabb, Vec3};
use strahl::scene::{Scene, procedural};
use strahl::verify::crosscheck::{self, Report};
use strahl::verify::workload::RayKind;

const RAYS: usize = 1_000_000;

/// Two workers (as CI has) that flush denormals to zero, as Embree asks.
fn pool() -> rayon::ThreadPool {
    strahl::verify::bench::pool(2).unwrap()
}

/// The shared test mesh `name` as a scene of its own; `None` when the data folder is missing.
fn mesh_scene(name: &str) -> Option<Scene> {
    let loaded = strahl::scene::from_mesh_file(data_dir()?.join(name)).unwrap_or_else(|e| panic!("{e}"));
    assert!(loaded.warnings.is_empty(), "{:?}", loaded.warnings);
    Some(loaded.scene)
}

fn check(name: &str, scene: &Scene, rays: usize) -> Vec<Report> {
    pool().install(|| {
        let device = Device::with_options(DeviceOptions { threads: Some(2) }).unwrap();
        let embree = EmbreeAccel::build(&device, scene, BuildOptions::default()).unwrap();
        let native = Bvh::build(scene).unwrap();
        let mut reports = Vec::new();
        for kind in RayKind::CLOSEST_HIT {
            let report = crosscheck::run(scene, &embree, &native, kind, rays, 7).unwrap();
            println!("{name}, {kind}: {report}");
            for d in &report.unexplained_examples {
                println!("  unexplained: {d:?}");
            }
            assert_eq!(report.unexplained, 0, "{name}, {kind}: {report}");
            assert!(report.dt.p999 <= 1e-5, "{name}, {kind}: {report}");
            // A million of each (primary: 1000×1000; secondary: the image grows until a million
            // primary rays hit).
            assert_eq!(report.rays, rays, "{name}, {kind}");
            reports.push(report);
        }
        reports
    })
}

#[test]
fn random_spheres() {
    let b = Aabb::new(Vec3::splat(-10.0), Vec3::splat(10.0));
    let scene = Scene { spheres: procedural::random_spheres(1000, b, (0.1, 1.0), 1), ..Default::default() };
    for r in check("1000 spheres", &scene, RAYS) {
        // The same quadratic in both backends: not a single difference.
        assert_eq!((r.hit_miss(), r.other_prim, r.dt.max), (0, 0, 0.0), "{r}");
        assert!(r.both_hit > RAYS / 10, "{r}");
    }
}

#[test]
fn procedural_meshes_spheres_and_planes() {
    let b = Aabb::new(Vec3::splat(-3.0), Vec3::splat(3.0));
    let mut scene = Scene::default();
    let mut ico = procedural::icosphere(6); // 82k triangles
    for p in &mut ico.positions {
        *p = *p * 2.0 + Vec3::new(0.5, 0.2, -0.3);
    }
    scene.meshes.push(ico);
    scene.meshes.push(procedural::random_triangles(20_000, b, 0.2, 3));
    scene.spheres = procedural::random_spheres(300, b, (0.05, 0.4), 4);
    scene.planes.push(Plane::through(Vec3::new(0.0, -3.5, 0.0), Vec3::Y, 0));
    for r in check("procedural", &scene, RAYS) {
        assert!(r.both_hit > RAYS / 10, "{r}");
    }
}

#[test]
fn stanford_bunny() {
    let Some(scene) = mesh_scene("stanford/bun_zipper.ply") else { return };
    assert_eq!(scene.triangle_count(), 69_451);
    check("bunny", &scene, RAYS);
}

#[test]
fn stanford_dragon() {
    let Some(scene) = mesh_scene("stanford/dragon_vrip_res2.ply.gz") else { return };
    assert_eq!(scene.triangle_count(), 202_520);
    check("dragon (res2)", &scene, RAYS);
}

/// The hardest rays for two different triangle tests: from random eyes straight at points on
/// the mesh's edges (rounded to f32), so that every ray passes within an ulp or so of an edge.
fn edge_rays(mesh: &strahl::scene::Mesh, n: usize, seed: u64) -> Vec<strahl::math::Ray> {
    use rand::{Rng, SeedableRng};
    let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(seed);
    let eyes = procedural::random_rays(n, mesh.bounds(), seed);
    eyes.iter()
        .map(|e| {
            let [a, b, _] = mesh.triangle(rng.random_range(0..mesh.indices.len()));
            let target = a + rng.random_range(0.0f32..1.0) * (b - a);
            strahl::math::Ray::new(e.org, (target - e.org).normalize())
        })
        .collect()
}

#[test]
fn rays_through_edges_of_the_bunny() {
    let Some(scene) = mesh_scene("stanford/bun_zipper.ply") else { return };
    pool().install(|| {
        let device = Device::with_options(DeviceOptions { threads: Some(2) }).unwrap();
        let embree = EmbreeAccel::build(&device, &scene, BuildOptions::default()).unwrap();
        let native = Bvh::build(&scene).unwrap();
        let rays = edge_rays(&scene.meshes[0], RAYS, 3);
        let report = crosscheck::compare(&scene, &embree, &native, &rays).unwrap();
        println!("bunny, rays through edges: {report}");
        for d in &report.unexplained_examples {
            println!("  unexplained: {d:?}");
        }
        assert_eq!(report.unexplained, 0, "{report}");
        // Rounding decides here: the backends do disagree, and ties on shared edges abound.
        assert!(report.explained > 100 && report.other_prim_same_t > 10_000, "{report}");
        assert!(report.dt.p999 <= 1e-5, "{report}");
    });
}

/// The number after `label` on the line of `block` that starts with it (after the indent).
fn count(block: &str, label: &str) -> usize {
    let line = block.lines().find(|l| l.trim_start().starts_with(label)).unwrap_or_else(|| panic!("no {label}"));
    line.trim_start()[label.len()..].split_whitespace().next().unwrap().parse().unwrap()
}

/// `strahl crosscheck` on the Cornell box OBJ, given as a mesh file: a million rays of each
/// kind, a report per kind with every count, the tolerance stated, exit status 0.
#[test]
fn crosscheck_command_on_the_cornell_box() {
    let Some(data) = data_dir() else { return };
    let obj = data.join("cornell/CornellBox-Original.obj");
    let out = strahl(&["crosscheck", obj.to_str().unwrap(), "--threads", "2"]);
    let stdout = text(&out.stdout);
    println!("{stdout}");
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert!(text(&out.stderr).is_empty(), "{}", text(&out.stderr));
    assert!(stdout.starts_with(&format!("{}: 36 triangles, 0 spheres, 0 planes", obj.display())), "{stdout}");
    assert!(stdout.contains("\ntolerance: a disagreement is explained when the ray passes within 16 ε·M of an edge"));
    let blocks: Vec<&str> = stdout.split("\n\n").skip(1).collect();
    assert_eq!(blocks.len(), 3, "{stdout}");
    for (block, kind) in blocks.iter().zip(["primary", "random", "secondary"]) {
        assert!(block.starts_with(&format!("{kind} rays: embree vs native\n")), "{block}");
        let (hit, miss, hit_miss) = (count(block, "both hit"), count(block, "both miss"), count(block, "hit/miss"));
        assert_eq!(count(block, "rays"), RAYS, "{block}");
        assert_eq!(hit + miss + hit_miss, RAYS, "{block}");
        assert!(hit > RAYS / 3, "{block}");
        let same = count(block, "same (geom, prim)") + count(block, "other prim, same t");
        assert_eq!(same + count(block, "other prim, other t"), hit, "{block}");
        assert_eq!(count(block, "unexplained"), 0, "{block}");
        let dt = block.lines().find(|l| l.contains("|dt|/t")).unwrap();
        let p999: f64 = dt.split("p99.9 ").nth(1).unwrap().split(',').next().unwrap().parse().unwrap();
        assert!(p999 <= 1e-5, "{dt}");
    }
}

#[test]
fn crosscheck_command_options_and_errors() {
    let dir = TempDir::new("crosscheck");
    // One kind, few rays, a seed: one report.
    let lecture = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/lecture.toml");
    let out = strahl(&["crosscheck", lecture, "--rays", "1000", "--kind", "random", "--seed", "5", "--threads", "1"]);
    let stdout = text(&out.stdout);
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert!(stdout.contains("1 thread, seed 5") && stdout.contains("\nrandom rays: "), "{stdout}");
    assert_eq!(stdout.matches(" rays: embree vs native").count(), 1, "{stdout}");
    assert_eq!(count(stdout.split("\n\n").nth(1).unwrap(), "rays"), 1000);

    let missing = dir.path("missing.toml");
    let e = fails(&dir, &["crosscheck", missing.to_str().unwrap()]);
    assert!(e.starts_with(&format!("error: {}: cannot read the scene", missing.display())), "{e}");
    let bad_mesh = dir.write("bad.ply", "ply\nformat ascii 1.0\nelement vertex 1\nend_header\n1 2\n");
    let e = fails(&dir, &["crosscheck", bad_mesh.to_str().unwrap()]);
    assert!(e.starts_with(&format!("error: {}:", bad_mesh.display())), "{e}");
    let planes = dir.write(
        "planes.toml",
        "[camera]\neye = [0, 1, 5]\ntarget = [0, 0, 0]\nfov_deg = 40\n[image]\nwidth = 8\nheight = 8\n\
         [materials.m]\ndiffuse = 0.5\n[[objects]]\ntype = \"plane\"\nnormal = [0, 1, 0]\ndistance = 0\nmaterial = \"m\"\n",
    );
    let e = fails(&dir, &["crosscheck", planes.to_str().unwrap()]);
    assert!(e.ends_with("has no meshes or spheres to trace (planes are tested outside both BVHs)"), "{e}");
    // Primary and secondary rays come from the scene's own camera: inside the Cornell box,
    // most of them hit (a framing camera outside the box saw only its outside, and the
    // secondary rays then compared nothing).
    let cornell = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/cornell.toml");
    let out = strahl(&["crosscheck", cornell, "--rays", "4096", "--kind", "secondary", "--threads", "2"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let both_hit = count(&text(&out.stdout), "both hit");
    assert!(both_hit > 3000, "{}", text(&out.stdout));
    // A camera that looks away from everything: nothing compared, which is a failure.
    let away = dir.write(
        "away.toml",
        "[camera]\neye = [0, 0, 0]\ntarget = [0, 0, 1]\nfov_deg = 10\n[materials.m]\ndiffuse = 0.5\n\
         [[objects]]\ntype = \"sphere\"\ncenter = [0, 0, -5]\nradius = 1\nmaterial = \"m\"\n",
    );
    let e = fails(&dir, &["crosscheck", away.to_str().unwrap(), "--rays", "1000", "--kind", "primary"]);
    assert!(e.contains("nothing was compared: primary (1024 rays)"), "{e}");
    // Usage errors: exit status 2, one line.
    for args in [["--rays", "0"], ["--kind", "shadow"]] {
        let out = strahl(&["crosscheck", lecture, args[0], args[1]]);
        assert_eq!(out.status.code(), Some(2), "{args:?}");
        assert_eq!(text(&out.stderr).lines().count(), 1, "{}", text(&out.stderr));
    }
}
