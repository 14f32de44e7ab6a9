//! Real meshes rendered through scene files: the Cornell box OBJ with its MTL colours under a
//! point light, and the Stanford bunny PLY, each pixel against a brute-force f64 intersection
//! of its lecture ray with every triangle of the scene.
//!
//! The meshes come from the shared test data (see `common::data_dir`); the scene files are
//! written to a temporary folder and name them by absolute path.

mod common;

use std::f64::consts::PI;

use common::{TempDir, data_dir, lecture_ray, rel, render, triangle_hit};
use glam::{DMat3, DVec3};
use rayon::prelude::*;
use strahl::light::Light;
use strahl::scene::Scene;
use strahl::scene::load::{MeshOptions, load_mesh};

/// How close (in barycentric terms) to a triangle's outline a ray may pass before f32 and f64
/// might disagree on which triangle it hits.
const EDGE_MARGIN: f64 = 1e-4;

/// Every triangle of a scene's meshes in f64, with the mesh and triangle index it came from.
struct Soup {
    triangles: Vec<[DVec3; 3]>,
    origin: Vec<(usize, usize)>,
}

impl Soup {
    fn of(scene: &Scene) -> Soup {
        let mut soup = Soup { triangles: Vec::new(), origin: Vec::new() };
        for (m, mesh) in scene.meshes.iter().enumerate() {
            for t in 0..mesh.indices.len() {
                soup.triangles.push(mesh.triangle(t).map(|p| p.as_dvec3()));
                soup.origin.push((m, t));
            }
        }
        soup
    }

    /// What the ray sees first: `Some(Some((t, triangle)))`, `Some(None)` for nothing, `None`
    /// when it passes too close to an outline in front of (or near) its first hit, or two
    /// surfaces there are too close in depth to tell apart.
    fn first_hit(&self, org: DVec3, dir: DVec3) -> Option<Option<(f64, usize)>> {
        let (mut best, mut second, mut near_edge) = ((f64::INFINITY, usize::MAX), f64::INFINITY, f64::INFINITY);
        for (i, &tri) in self.triangles.iter().enumerate() {
            match triangle_hit(org, dir, tri, EDGE_MARGIN) {
                Ok(Some(t)) if t < best.0 => (second, best) = (best.0, (t, i)),
                Ok(Some(t)) => second = second.min(t),
                Ok(None) => {}
                Err(t) => near_edge = near_edge.min(t),
            }
        }
        let (t, tri) = best;
        let clear = |other: f64| other > t * (1.0 + 1e-4);
        match tri {
            usize::MAX if near_edge.is_infinite() => Some(None),
            usize::MAX => None,
            _ if clear(near_edge) && clear(second) => Some(Some((t, tri))),
            _ => None,
        }
    }

    /// Whether the segment from `p` along unit `dir` to `tmax` is blocked; `None` when it
    /// passes too close to an outline to say. Hits within 10⁻⁶ of `p` are the surface itself.
    fn blocked(&self, p: DVec3, dir: DVec3, tmax: f64) -> Option<bool> {
        let mut blocked = false;
        for &tri in &self.triangles {
            match triangle_hit(p, dir, tri, EDGE_MARGIN) {
                Ok(Some(t)) => blocked |= t > 1e-6 && t < tmax,
                Ok(None) => {}
                Err(t) if t > 1e-6 && t < tmax => return None,
                Err(_) => {}
            }
        }
        Some(blocked)
    }

    /// The unit geometric normal of triangle `i`, turned towards the side `dir` comes from.
    fn normal_facing(&self, i: usize, dir: DVec3) -> DVec3 {
        let [a, b, c] = self.triangles[i];
        let n = (b - a).cross(c - a).normalize();
        if n.dot(dir) > 0.0 { -n } else { n }
    }
}

/// The scene file `text` for the Whitted integrator (whose pixel-centre rays and direct light
/// these tests check), in which `MESH` stands for the path of the data file `mesh`, written
/// to a temporary folder and loaded (without warnings); `None` when the test data is missing.
fn data_scene(mesh: &str, text: &str) -> Option<Scene> {
    let path = data_dir()?.join(mesh);
    let dir = TempDir::new(mesh.split('/').next().unwrap());
    let text = format!("[render]\nintegrator = \"whitted\"\n{text}");
    let scene = dir.write("scene.toml", text.replace("MESH", &format!("{:?}", path.display())));
    let loaded = strahl::scene::load(scene).unwrap_or_else(|e| panic!("{e}"));
    assert!(loaded.warnings.is_empty(), "{:?}", loaded.warnings);
    Some(loaded.scene)
}

/// The Cornell box's MTL (cornell/CornellBox-Original.mtl): `(material, Kd, Ke)`. Every
/// material is `illum 2` with `Ks 0`: purely diffuse.
const CORNELL_MTL: [(&str, [f64; 3], [f64; 3]); 8] = [
    ("leftWall", [0.63, 0.065, 0.05], [0.0; 3]),
    ("rightWall", [0.14, 0.45, 0.091], [0.0; 3]),
    ("floor", [0.725, 0.71, 0.68], [0.0; 3]),
    ("ceiling", [0.725, 0.71, 0.68], [0.0; 3]),
    ("backWall", [0.725, 0.71, 0.68], [0.0; 3]),
    ("shortBox", [0.725, 0.71, 0.68], [0.0; 3]),
    ("tallBox", [0.725, 0.71, 0.68], [0.0; 3]),
    ("light", [0.78, 0.78, 0.78], [17.0, 12.0, 4.0]),
];

#[test]
fn cornell_box_obj_has_its_mtl_radiance_under_a_point_light() {
    // The scene's own material comes first, so the file's materials are moved past it.
    let Some(scene) = data_scene(
        "cornell/CornellBox-Original.obj",
        "[camera]\neye = [0, 1, 3.9]\ntarget = [0, 1, 0]\nfov_deg = 40\n\
         [image]\nwidth = 40\nheight = 40\nspp = 1\nambient = 0.05\nmesh_lights = false\n\
         [materials.unused]\ndiffuse = 0.5\n\
         [[lights]]\ntype = \"point\"\nposition = [0, 1.8, 0.2]\nintensity = 3\n\
         [[objects]]\ntype = \"mesh\"\nname = \"box\"\npath = MESH\n",
    ) else {
        return;
    };
    let (w, h) = (scene.image.width, scene.image.height);
    assert_eq!(scene.materials.len(), 1 + 8);
    let Light::Point { position, intensity } = scene.lights[0] else { unreachable!() };
    let (light, intensity) = (position.as_dvec3(), intensity.x as f64);
    let ambient = scene.image.ambient.x as f64;
    let (film, _) = render(&scene);
    let soup = Soup::of(&scene);

    // What the reference sees at a pixel: the material's name without the `FILE/` prefix.
    let material_at = |x: u32, y: u32| -> Option<String> {
        let (org, dir) = lecture_ray(&scene.camera, w, h, x, y);
        let (_, tri) = soup.first_hit(org, dir)??;
        let (m, t) = soup.origin[tri];
        let name = &scene.materials[scene.meshes[m].material_of(t) as usize].name;
        Some(name.strip_prefix("CornellBox-Original.obj/").expect("the file's material").to_string())
    };
    // Per-triangle materials: red on the left, green on the right, the short box (in the
    // file's `leftWall` group, after `usemtl shortBox`) white.
    assert_eq!(material_at(3, 20).as_deref(), Some("leftWall"));
    assert_eq!(material_at(36, 20).as_deref(), Some("rightWall"));
    let [r, g, _, _] = film.rgba[film.index(3, 20)];
    assert!(r > 5.0 * g, "the left wall is red: {:?}", film.rgba[film.index(3, 20)]);
    let [r, g, _, _] = film.rgba[film.index(36, 20)];
    assert!(g > 2.0 * r, "the right wall is green: {:?}", film.rgba[film.index(36, 20)]);

    let mut seen = std::collections::BTreeMap::<&str, usize>::new();
    let (mut misses, mut shadowed, mut floor_depths) = (0, 0, 0);
    for y in 0..h {
        for x in 0..w {
            let i = film.index(x, y);
            let (org, dir) = lecture_ray(&scene.camera, w, h, x, y);
            let Some(first) = soup.first_hit(org, dir) else { continue };
            let Some((t, tri)) = first else {
                misses += 1;
                // The background is black; the frame is opaque (alpha 1 everywhere).
                assert_eq!(
                    (film.rgba[i], film.depth[i]),
                    ([0.0, 0.0, 0.0, 1.0], f32::INFINITY),
                    "pixel ({x}, {y}) sees nothing"
                );
                continue;
            };
            let (m, k) = soup.origin[tri];
            let name = scene.materials[scene.meshes[m].material_of(k) as usize].name.as_str();
            let &(mtl, kd, ke) = CORNELL_MTL
                .iter()
                .find(|(n, _, _)| name.strip_prefix("CornellBox-Original.obj/") == Some(n))
                .unwrap_or_else(|| panic!("pixel ({x}, {y}): material {name}"));
            let p = org + t * dir;
            let n = soup.normal_facing(tri, dir);
            let to_light = light - p;
            let d = to_light.length();
            let cos = n.dot(to_light / d);
            let direct = if cos <= 0.0 {
                0.0
            } else {
                match soup.blocked(p, to_light / d, d) {
                    None => continue,
                    Some(true) => {
                        shadowed += 1;
                        0.0
                    }
                    Some(false) => intensity * cos / (d * d),
                }
            };
            *seen.entry(mtl).or_default() += 1;
            // L = Le + ρ·La + ρ/π · I·cosθ/d².
            for c in 0..3 {
                let want = ke[c] + kd[c] * ambient + kd[c] / PI * direct;
                let got = film.rgba[i][c];
                assert!(rel(got, want) <= 1e-4, "pixel ({x}, {y}) on {mtl}, channel {c}: {got} vs {want}");
            }
            assert_eq!(film.rgba[i][3], 1.0);
            let z = common::axis_depth(&scene.camera, dir, t);
            assert!(rel(film.depth[i], z) <= 1e-5, "pixel ({x}, {y}): Z {} vs {z}", film.depth[i]);
            assert!((film.albedo[i].as_dvec3() - DVec3::from(kd)).length() < 1e-6, "pixel ({x}, {y}): albedo");
            if mtl == "floor" {
                // The floor is the plane y = 0: the hit lies at t = −e_y / d_y along the ray.
                let analytic = common::axis_depth(&scene.camera, dir, -org.y / dir.y);
                assert!(rel(film.depth[i], analytic) <= 1e-5, "pixel ({x}, {y}): Z {} vs {analytic}", film.depth[i]);
                floor_depths += 1;
            }
        }
    }
    println!(
        "cornell: pixels by material {seen:?}; {shadowed} in shadow, {misses} misses, {floor_depths} on the floor"
    );
    // Every part of the box was seen, in quantity where it is large.
    for (mtl, _, _) in CORNELL_MTL {
        assert!(seen.get(mtl).is_some_and(|&n| n > 0), "no pixel on {mtl}: {seen:?}");
    }
    assert!(seen["leftWall"] > 50 && seen["rightWall"] > 50 && seen["backWall"] > 200, "{seen:?}");
    assert!(floor_depths > 50 && shadowed > 10 && misses > 10, "{floor_depths} {shadowed} {misses}");
}

#[test]
fn bunny_ply_depth_normals_and_coverage_match_brute_force() {
    let Some(scene) = data_scene(
        "stanford/bun_zipper.ply",
        "[camera]\neye = [-0.2, 1.3, 4.5]\ntarget = [-0.2, 1.1, 0]\nfov_deg = 26\n\
         [image]\nwidth = 48\nheight = 48\nspp = 1\n\
         [materials.clay]\ndiffuse = 0.7\n\
         [[lights]]\ntype = \"directional\"\ndirection = [-1, -1, -1]\nirradiance = 2\n\
         [[objects]]\ntype = \"mesh\"\nname = \"bunny\"\npath = MESH\nmaterial = \"clay\"\n\
         scale = 10\nrotate_deg = [0, 30, 0]\ntranslate = [0, 0, 0.1]\n",
    ) else {
        return;
    };
    let (w, h) = (scene.image.width, scene.image.height);
    // The object's transform, written out: p' = Ry(30°)·10·p + (0, 0, 0.1).
    let file = load_mesh(&data_dir().unwrap().join("stanford/bun_zipper.ply"), &MeshOptions::default()).unwrap();
    let (bunny, raw) = (&scene.meshes[0], &file.meshes[0]);
    assert_eq!((scene.meshes.len(), bunny.indices.len(), bunny.material), (1, 69451, 0));
    assert_eq!(bunny.indices, raw.indices);
    let ry = DMat3::from_cols_array(&{
        let (s, c) = 30f64.to_radians().sin_cos();
        [c, 0.0, -s, 0.0, 1.0, 0.0, s, 0.0, c]
    });
    for (p, q) in bunny.positions.iter().zip(&raw.positions) {
        let want = ry * (10.0 * q.as_dvec3()) + DVec3::new(0.0, 0.0, 0.1);
        assert!((p.as_dvec3() - want).length() <= 1e-6 * want.length(), "{p} vs {want}");
    }

    let (film, _) = render(&scene);
    let soup = Soup::of(&scene);
    let pixels: Vec<(u32, u32)> = (0..h).flat_map(|y| (0..w).map(move |x| (x, y))).collect();
    let reference: Vec<_> = pixels
        .par_iter()
        .map(|&(x, y)| {
            let (org, dir) = lecture_ray(&scene.camera, w, h, x, y);
            soup.first_hit(org, dir).map(|first| {
                first.map(|(t, tri)| (common::axis_depth(&scene.camera, dir, t), soup.normal_facing(tri, dir)))
            })
        })
        .collect();
    let (mut hits, mut misses, mut ambiguous, mut worst_z, mut worst_n) = (0, 0, 0, 0f64, 0f64);
    for (&(x, y), seen) in pixels.iter().zip(&reference) {
        let i = film.index(x, y);
        match seen {
            None => ambiguous += 1,
            Some(None) => {
                misses += 1;
                // An opaque frame: alpha 1 on a miss too; depth +inf.
                assert_eq!((film.rgba[i][3], film.depth[i]), (1.0, f32::INFINITY), "pixel ({x}, {y}) misses");
            }
            Some(Some((t, n))) => {
                hits += 1;
                assert_eq!(film.rgba[i][3], 1.0, "pixel ({x}, {y}) hits");
                worst_z = worst_z.max(rel(film.depth[i], *t));
                worst_n = worst_n.max((film.normal[i].as_dvec3() - *n).length());
            }
        }
    }
    println!("bunny: {hits} hits, {misses} misses, {ambiguous} ambiguous; worst Z {worst_z:e}, worst N {worst_n:e}");
    assert!(worst_z <= 1e-5, "Z off by {worst_z:e} (relative)");
    assert!(worst_n <= 1e-5, "N off by {worst_n:e}");
    // Coverage: the fraction of pixel-centre rays that hit, i.e. of finite depths (the frame is
    // opaque, so alpha is 1 everywhere; spp 1: each pixel hits or not).
    let coverage: f64 = film.depth.iter().filter(|z| z.is_finite()).count() as f64 / pixels.len() as f64;
    let bounds = (hits as f64 / pixels.len() as f64, (hits + ambiguous) as f64 / pixels.len() as f64);
    assert!(bounds.0 <= coverage && coverage <= bounds.1, "coverage {coverage} outside {bounds:?}");
    assert!(hits > 600 && misses > 600 && ambiguous < pixels.len() / 50, "{hits} {misses} {ambiguous}");
}
