//! Khronos glTF sample models, rendered as their authors meant them. The models ship in
//! tests/data/khronos/ with their licences (tests/data/khronos/README.md); the files are read
//! as they are, a camera node added (they have none) in a copy beside them.
//!
//! - **TextureTransformTest** (`KHR_texture_transform`): in the three lower quads an arrow
//!   texture is rotated, scaled, or both; on each quad a green marker shows where the arrow
//!   must point, a red one where it points when the rotation is applied the wrong way round, a
//!   yellow one where it points when the transform is ignored. Checked on strahl's image alone:
//!   the arrow's tip (its dark pixels) touches the green marker and not the others. And against
//!   Cycles (Blender's importer reads the file; tools/blender/render_gltf.py), under a uniform
//!   white world: every 8 × 8 block within 8 % (measured: at most 5.0 %, strahl 1.7 % darker
//!   over the image: Cycles' Principled BSDF adds its specular layer to the diffuse without
//!   taking the reflected energy from it, so a white surface under a white world returns 1.05,
//!   where glTF's Fresnel mix returns 1.00).
//! - **MorphPrimitivesTest** (morph targets at the mesh's default `weights`, two primitives):
//!   the depth of every pixel, at pixel centres, against Cycles' Depth pass.
//!
//! The Cycles comparisons skip, saying so, when Blender is not installed; `make test-cycles`
//! runs them with `STRAHL_REQUIRE_BLENDER=1`, which turns the skip into a failure.

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

use common::{TempDir, channel, read_exr, strahl};
use glam::{Mat3, Quat, Vec3};

const SIZE: usize = 128;

/// A camera looking from `eye` at `target` (glTF coordinates, up +y).
#[derive(Clone, Copy)]
struct View {
    eye: [f32; 3],
    target: [f32; 3],
    yfov_deg: f32,
}

/// TextureTransformTest's six quads, face on.
const FACE_ON: View = View { eye: [0.0, 0.0, 4.0], target: [0.0, 0.0, 0.0], yfov_deg: 45.0 };

fn model(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/khronos").join(name).join(format!("{name}.gltf"))
}

/// A copy of the model's JSON in `dir`, beside copies of the files it names, with a square
/// perspective camera node at `view` added to its scene.
fn with_camera(dir: &TempDir, name: &str, view: View) -> PathBuf {
    let src = model(name);
    let mut doc: serde_json::Value = serde_json::from_slice(&std::fs::read(&src).unwrap()).unwrap();
    for key in ["buffers", "images"] {
        for item in doc[key].as_array().into_iter().flatten() {
            let uri = item["uri"].as_str().unwrap();
            std::fs::copy(src.parent().unwrap().join(uri), dir.path(uri)).unwrap();
        }
    }
    let (eye, target) = (Vec3::from(view.eye), Vec3::from(view.target));
    // glTF cameras look along their −z with +y up.
    let w = (eye - target).normalize();
    let u = Vec3::Y.cross(w).normalize();
    let rotation = Quat::from_mat3(&Mat3::from_cols(u, w.cross(u), w));
    let cameras = doc.as_object_mut().unwrap().entry("cameras").or_insert(serde_json::json!([]));
    cameras.as_array_mut().unwrap().push(serde_json::json!({
        "type": "perspective",
        "perspective": {"yfov": view.yfov_deg.to_radians(), "aspectRatio": 1.0, "znear": 0.01}
    }));
    let camera = cameras.as_array().unwrap().len() - 1;
    let nodes = doc["nodes"].as_array_mut().unwrap();
    nodes.push(serde_json::json!({"camera": camera, "translation": view.eye, "rotation": rotation.to_array()}));
    let node = nodes.len() - 1;
    let scene = doc["scene"].as_u64().unwrap_or(0) as usize;
    doc["scenes"][scene]["nodes"].as_array_mut().unwrap().push(node.into());
    dir.write("scene.gltf", serde_json::to_vec(&doc).unwrap())
}

/// strahl's render of `gltf` under a white environment of 1; `extra` arguments appended.
fn render(dir: &TempDir, gltf: &Path, spp: u32, extra: &[&str]) -> PathBuf {
    let exr = dir.path("strahl.exr");
    let (size, spp) = (SIZE.to_string(), spp.to_string());
    let mut args = vec![
        "render",
        gltf.to_str().unwrap(),
        "-o",
        exr.to_str().unwrap(),
        "--width",
        &size,
        "--height",
        &size,
        "--spp",
        &spp,
        "--depth",
        "8",
        "--environment",
        "1,1,1",
    ];
    args.extend_from_slice(extra);
    let out = strahl(&args);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "strahl failed: {stderr}");
    // The models have no lights: the environment lights them, and no default light is added.
    assert!(!stderr.contains("has no lights"), "a default light was added under --environment: {stderr}");
    exr
}

/// Cycles' render of the model `name` from `view` (tools/blender/render_gltf.py); `None`, with
/// a loud line, when Blender is missing.
fn cycles(dir: &TempDir, name: &str, view: View, spp: u32, flags: &[&str]) -> Option<PathBuf> {
    if !common::blender_installed("the Khronos models are not compared with Cycles") {
        return None;
    }
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tools/blender/render_gltf.py");
    let out_dir = dir.path("cycles");
    let numbers = [view.eye.to_vec(), view.target.to_vec(), vec![view.yfov_deg]].concat();
    let out = Command::new("blender")
        .args(["-b", "--factory-startup", "--python"])
        .arg(&script)
        .arg("--")
        .arg(model(name))
        .arg(&out_dir)
        .args([SIZE.to_string(), spp.to_string(), "8".into()])
        .args(numbers.iter().map(|x| x.to_string()))
        .args(flags)
        .output()
        .expect("blender runs");
    let exr = out_dir.join("cycles.exr");
    assert!(
        out.status.success() && exr.exists(),
        "blender failed:\n{}\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    Some(exr)
}

/// The R, G, B planes of `path` (`prefix` + R, …).
fn rgb(path: &Path, prefix: &str) -> [Vec<f32>; 3] {
    let (w, h, channels) = read_exr(path);
    assert_eq!((w, h), (SIZE, SIZE), "{}", path.display());
    ["R", "G", "B"].map(|c| channel(&channels, &format!("{prefix}{c}")).to_vec())
}

/// In each lower quad of TextureTransformTest (the lower half of the image, in thirds), the
/// distance in pixels from the arrow's nearest dark pixel to the centre of each marker colour
/// present: `[green, red, yellow]`, `None` where the quad has no such marker.
fn arrow_to_markers(img: &[Vec<f32>; 3]) -> [[Option<f64>; 3]; 3] {
    let [r, g, b] = img;
    let class = |i: usize| {
        let (r, g, b) = (r[i], g[i], b[i]);
        if r + g + b < 0.45 {
            Some(3) // the arrow
        } else if g > 0.3 && r < 0.25 && b < 0.25 {
            Some(0)
        } else if r > 0.5 && g < 0.25 && b < 0.25 {
            Some(1)
        } else if r > 0.5 && g > 0.5 && b < 0.3 {
            Some(2)
        } else {
            None
        }
    };
    std::array::from_fn(|quad| {
        let (x0, x1) = (quad * SIZE / 3, (quad + 1) * SIZE / 3);
        let mut dark = Vec::new();
        let mut sums = [(0.0, 0.0, 0usize); 3];
        for y in SIZE / 2..SIZE {
            for x in x0..x1 {
                match class(y * SIZE + x) {
                    Some(3) => dark.push((x as f64, y as f64)),
                    Some(k) => {
                        let s = &mut sums[k];
                        (s.0, s.1, s.2) = (s.0 + x as f64, s.1 + y as f64, s.2 + 1);
                    }
                    None => {}
                }
            }
        }
        assert!(dark.len() > 10, "quad {quad}: no arrow ({} dark pixels)", dark.len());
        sums.map(|(sx, sy, n)| {
            (n > 0).then(|| {
                let (cx, cy) = (sx / n as f64, sy / n as f64);
                dark.iter().map(|&(x, y)| (x - cx).hypot(y - cy)).fold(f64::INFINITY, f64::min)
            })
        })
    })
}

#[test]
fn texture_transform_test_arrows_point_at_the_green_markers() {
    let dir = TempDir::new("khronos-transform");
    let gltf = with_camera(&dir, "TextureTransformTest", FACE_ON);
    let img = rgb(&render(&dir, &gltf, 8, &["--integrator", "path"]), "ViewLayer.Combined.");
    for (quad, [green, red, yellow]) in ["rotation", "scale", "all three"].iter().zip(arrow_to_markers(&img)) {
        eprintln!("{quad}: arrow to green {green:?}, red {red:?}, yellow {yellow:?} pixels");
        let green = green.unwrap_or_else(|| panic!("{quad}: no green marker"));
        assert!(green < 10.0, "{quad}: the arrow ends {green:.1} pixels from the green marker");
        for (colour, d) in [("red", red), ("yellow", yellow)] {
            if let Some(d) = d {
                assert!(d > green + 4.0, "{quad}: the arrow is as near the {colour} marker ({d:.1}) as the green");
            }
        }
    }
}

#[test]
fn texture_transform_test_agrees_with_cycles() {
    let dir = TempDir::new("khronos-transform-cycles");
    let Some(cycles_exr) = cycles(&dir, "TextureTransformTest", FACE_ON, 64, &[]) else { return };
    let gltf = with_camera(&dir, "TextureTransformTest", FACE_ON);
    let sum = |img: [Vec<f32>; 3]| (0..SIZE * SIZE).map(|i| (img[0][i] + img[1][i] + img[2][i]) as f64).collect();
    let s: Vec<f64> = sum(rgb(&render(&dir, &gltf, 64, &["--integrator", "path"]), "ViewLayer.Combined."));
    let c: Vec<f64> = sum(rgb(&cycles_exr, ""));
    let (ms, mc) = (common::block_means(&s, SIZE, 8), common::block_means(&c, SIZE, 8));
    let worst = ms.iter().zip(&mc).map(|(a, b)| (a - b) / b).fold(0.0f64, |w, r| if r.abs() > w.abs() { r } else { w });
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    let relative = mean(&s) / mean(&c) - 1.0;
    eprintln!(
        "TextureTransformTest vs Cycles: worst 8×8 block {:+.2} %, image {:+.2} %",
        100.0 * worst,
        100.0 * relative
    );
    assert!(worst.abs() < 0.08, "a block differs from Cycles' by {:.1} %", 100.0 * worst);
    assert!(relative.abs() < 0.03, "the image differs from Cycles' by {:.1} %", 100.0 * relative);
}

#[test]
fn morph_primitives_test_depth_agrees_with_cycles() {
    let view = View { eye: [0.0, 1.0, 1.2], target: [0.0, 0.0, 0.0], yfov_deg: 45.0 };
    let dir = TempDir::new("khronos-morph-cycles");
    let Some(cycles_exr) = cycles(&dir, "MorphPrimitivesTest", view, 1, &["depth"]) else { return };
    let gltf = with_camera(&dir, "MorphPrimitivesTest", view);
    let strahl_exr = render(&dir, &gltf, 1, &["--integrator", "whitted", "--passes", "depth"]);
    let ((_, _, c), (_, _, s)) = (read_exr(&cycles_exr), read_exr(&strahl_exr));
    let (cz, sz) = (channel(&c, "ViewLayer.Depth.Z"), channel(&s, "ViewLayer.Depth.Z"));
    let (mut compared, mut worst) = (0, 0f64);
    for y in 1..SIZE - 1 {
        for x in 1..SIZE - 1 {
            let i = y * SIZE + x;
            let z = sz[i] as f64;
            let step = [i - 1, i + 1, i - SIZE, i + SIZE].iter().map(|&j| (sz[j] as f64 - z).abs()).fold(0.0, f64::max);
            if !z.is_finite() || z > 1e6 || step > 0.05 * z {
                continue; // the background, or a silhouette
            }
            compared += 1;
            worst = worst.max((cz[i] as f64 - z).abs() / z);
        }
    }
    eprintln!("MorphPrimitivesTest depth vs Cycles on {compared} pixels: at most {worst:.2e} relative");
    assert!(compared > SIZE * SIZE / 4, "only {compared} pixels compared");
    assert!(worst < 1e-4, "depth differs from Cycles' by {worst:e}");
}
