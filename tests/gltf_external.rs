//! glTF files written by tools strahl did not write: Blender's own glTF exporter (a camera, a
//! point light and a sun, a textured quad, a glass cube and a linked duplicate), rendered and
//! compared with the same scene built by hand in TOML (and a hand-written OBJ/MTL for the
//! textured quad). Skips, saying so, when Blender is not installed; `make test-gltf-blender`
//! runs it.

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

use common::{TempDir, render};
use strahl::scene::{from_gltf_file, from_toml_str};

/// Exports `tools/gltf/blender_export.py`'s scene into `dir`; `None` (with a loud message)
/// when Blender is absent.
fn blender_export(dir: &Path) -> Option<PathBuf> {
    if !common::blender_installed("Blender's exported files are not read") {
        return None;
    }
    let glb = dir.join("blender.glb");
    common::run_blender_script("tools/gltf/blender_export.py", &[dir.into()], &[&glb]);
    Some(glb)
}

const CUBE: &str = r#"positions = [[-1, -1, -1], [1, -1, -1], [1, 1, -1], [-1, 1, -1], [-1, -1, 1], [1, -1, 1], [1, 1, 1], [-1, 1, 1]]
indices = [[0, 3, 2], [0, 2, 1], [4, 5, 6], [4, 6, 7], [0, 1, 5], [0, 5, 4], [3, 7, 6], [3, 6, 2], [0, 4, 7], [0, 7, 3], [1, 2, 6], [1, 6, 5]]"#;

#[test]
fn blender_export_renders_like_the_scene_built_by_hand() {
    let dir = TempDir::new("blender");
    let Some(glb) = blender_export(&dir.0) else { return };
    let loaded = from_gltf_file(&glb, None).unwrap();
    assert!(loaded.warnings.is_empty(), "{:?}", loaded.warnings);
    let scene = loaded.scene;
    // The linked duplicate is one mesh placed twice.
    assert_eq!((scene.prototypes.len(), scene.instances.len()), (1, 2));

    // 50 mm lens on a 36 mm sensor, 4:3: yfov = 2·atan(tan(xfov/2)·3/4) = 2·atan(0.27).
    let fov_deg = ((2.0 * 0.27f64.atan()) as f32).to_degrees();
    dir.write(
        "wall.obj",
        "mtllib wall.mtl\nv -3 -3 -4\nv 3 -3 -4\nv 3 3 -4\nv -3 3 -4\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n\
         usemtl wall\nf 1/1 2/2 3/3\nf 1/1 3/3 4/4\n",
    );
    dir.write("wall.mtl", "newmtl wall\nKd 1 1 1\nmap_Kd checker.png\n");
    let toml = format!(
        r#"
[camera]
eye = [0, 0, 8]
target = [0, 0, 7]
fov_deg = {fov_deg:?}
[image]
width = 640
height = 480
[materials.red]
diffuse = [0.8, 0.3, 0.2]
[materials.glass]
transmission = 1
ior = 1.45
[[lights]]
type = "point"
position = [2, 4, 3]
intensity = {point}
[[lights]]
type = "directional"
direction = [0, -1, 0]
irradiance = 2
[[objects]]
type = "mesh"
path = "wall.obj"
[[objects]]
type = "triangles"
material = "red"
{CUBE}
scale = 0.5
translate = [-1.5, 0, -2]
[[objects]]
type = "triangles"
material = "red"
{CUBE}
scale = 0.5
translate = [-1.5, 1.5, -2]
[[objects]]
type = "triangles"
material = "glass"
{CUBE}
scale = 0.6
translate = [1.5, 0, -1]
"#,
        point = 1000.0 / (4.0 * std::f64::consts::PI)
    );
    let by_hand = from_toml_str(&toml, &dir.path("by-hand.toml")).unwrap().scene;
    assert_eq!(scene.camera, by_hand.camera);
    // The Whitted integrator, which renders a glTF material in its lecture form (as the
    // scene by hand has it); the path tracer shades glTF materials with the glTF BSDF.
    let (a, _) = render(&whitted(scene.clone()));
    let (b, _) = render(&whitted(by_hand.clone()));
    let rel = |x: f32, y: f32| if x == y { 0.0 } else { (x - y).abs() / x.abs().max(y.abs()).max(1.0) };
    let (mut worst_z, mut worst_n, mut worst_rgb, mut hits, mut edge) = (0.0f32, 0.0f32, 0.0f32, 0, 0);
    for i in 0..a.depth.len() {
        assert_eq!(a.depth[i].is_finite(), b.depth[i].is_finite(), "hit or miss at pixel {i}");
        if a.depth[i].is_finite() {
            hits += 1;
            worst_z = worst_z.max(rel(a.depth[i], b.depth[i]));
        }
        let dn = (a.normal[i] - b.normal[i]).abs().max_element();
        let drgb = (0..3).map(|c| rel(a.rgba[i][c], b.rgba[i][c])).fold(0.0f32, f32::max);
        if dn > 1e-5 || drgb > 1e-4 {
            // A ray exactly through a cube's edge may take either face (the two files split
            // the faces' quads into triangles differently): Z agrees, the face differs.
            edge += 1;
            continue;
        }
        (worst_n, worst_rgb) = (worst_n.max(dn), worst_rgb.max(drgb));
    }
    println!(
        "{hits} pixels hit; worst Z {worst_z:e} (relative), N {worst_n:e}, RGB {worst_rgb:e}; \
         {edge} pixels on a cube edge take the other face"
    );
    assert!(hits > 150_000, "{hits}");
    assert!(worst_z <= 1e-5, "Z {worst_z:e}");
    assert!(edge <= 20, "{edge} pixels differ in N or RGB");
}

#[test]
fn pygltflib_hierarchy_renders_like_the_scene_built_by_hand() {
    let python_ok = Command::new("python3").args(["-c", "import pygltflib"]).output().is_ok_and(|o| o.status.success());
    if !python_ok {
        common::skip("python3 with pygltflib is not installed (make test-deps installs it)");
        return;
    }
    let dir = TempDir::new("pygltflib");
    let path = dir.path("py.gltf");
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tools/gltf/pygltflib_scene.py");
    let out = Command::new("python3").arg(&script).arg(&path).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let loaded = from_gltf_file(&path, None).unwrap();
    assert!(loaded.warnings.is_empty(), "{:?}", loaded.warnings);
    let scene = loaded.scene;
    // The square is one non-indexed mesh used by two nodes.
    assert_eq!((scene.prototypes.len(), scene.instances.len()), (1, 2));
    let toml = format!(
        r#"
[camera]
eye = [0, 0, 10]
target = [0, 0, 9]
fov_deg = {fov:?}
[image]
width = 640
height = 640
[materials.blue]
diffuse = [0.2, 0.6, 0.9]
[[lights]]
type = "point"
position = [0, 0, 5]
intensity = 30
[[objects]]
type = "triangles"
material = "blue"
positions = [[2, 1, 0], [0, 1, 0], [0, -1, 0], [2, 1, 0], [0, -1, 0], [2, -1, 0]]
indices = [[0, 1, 2], [3, 4, 5]]
[[objects]]
type = "triangles"
material = "blue"
positions = [[2, 4, -2], [0, 4, -2], [0, 2, -2], [2, 4, -2], [0, 2, -2], [2, 2, -2]]
indices = [[0, 1, 2], [3, 4, 5]]
"#,
        fov = 0.6f32.to_degrees()
    );
    let by_hand = from_toml_str(&toml, &dir.path("by-hand.toml")).unwrap().scene;
    assert_eq!(scene.camera, by_hand.camera);
    assert_eq!((scene.image.width, scene.image.height), (640, 640));
    // The Whitted integrator, which renders a glTF material in its lecture form (as the
    // scene by hand has it); the path tracer shades glTF materials with the glTF BSDF.
    let (a, _) = render(&whitted(scene.clone()));
    let (b, _) = render(&whitted(by_hand.clone()));
    let mut hits = 0;
    for i in 0..a.depth.len() {
        assert_eq!(a.depth[i].to_bits(), b.depth[i].to_bits(), "Z at pixel {i}");
        assert!((a.normal[i] - b.normal[i]).abs().max_element() <= 1e-6, "N at pixel {i}");
        for c in 0..3 {
            let (x, y) = (a.rgba[i][c], b.rgba[i][c]);
            assert!((x - y).abs() <= 1e-4 * y.abs().max(1e-3), "RGB at pixel {i}: {x} vs {y}");
        }
        hits += a.depth[i].is_finite() as usize;
    }
    assert!(hits > 20_000, "{hits}");
}

/// `scene` for the Whitted integrator.
fn whitted(mut scene: strahl::scene::Scene) -> strahl::scene::Scene {
    scene.render.integrator = strahl::scene::IntegratorKind::Whitted;
    scene
}
