//! glTF geometry beyond plain triangle lists: `EXT_mesh_gpu_instancing`, morph targets at their
//! default weights, triangle strips and fans, sparse accessors (files written by
//! `tools/gltf/geometry_cases.py` with pygltflib, not by strahl; skipped, saying so, without
//! it), and the refusals that name a missing extension or a newer glTF version (files written
//! here as JSON).

mod common;

use std::path::PathBuf;
use std::process::Command;

use common::{TempDir, fails, lecture_ray, render, strahl, text};
use glam::DVec3;
use strahl::scene::{IntegratorKind, from_gltf_file};

/// Writes the generated cases into `dir`; `None` (with a loud message) without pygltflib.
fn cases(dir: &TempDir) -> Option<PathBuf> {
    let has = Command::new("python3").args(["-c", "import pygltflib"]).output();
    if !has.is_ok_and(|o| o.status.success()) {
        common::skip("python3 with pygltflib is not installed (pip install pygltflib)");
        return None;
    }
    let script = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tools/gltf/geometry_cases.py");
    let out = Command::new("python3").arg(script).arg(&dir.0).output().unwrap();
    assert!(out.status.success(), "{}", text(&out.stderr));
    Some(dir.0.clone())
}

#[test]
fn gpu_instancing_places_125_boxes_each_at_its_depth() {
    let dir = TempDir::new("instancing");
    let Some(dir) = cases(&dir) else { return };
    let loaded = from_gltf_file(&dir.join("instancing.gltf"), None).unwrap();
    assert!(loaded.warnings.iter().all(|w| !w.contains("EXT_mesh_gpu_instancing")), "{:?}", loaded.warnings);
    assert_eq!(loaded.objects[0].triangles, 125 * 12);
    let mut scene = loaded.scene;
    assert_eq!((scene.prototypes.len(), scene.instances.len()), (1, 125));
    scene.render.integrator = IntegratorKind::Whitted;
    let (w, h) = (scene.image.width, scene.image.height);
    assert_eq!((w, h), (640, 160), "aspectRatio 4");
    let (film, _) = render(&scene);
    let eye = scene.camera.eye.as_dvec3();
    let t = (0.45f64).tan();
    let r = t * w as f64 / h as f64;
    for k in 0..125 {
        let (i, j) = (k % 25, k / 25);
        let scale_z = 1.0 + (k % 3) as f64 / 4.0;
        let front = DVec3::new(i as f64 - 12.0, j as f64 - 2.0, -1.0 + 0.25 * scale_z);
        // The pixel whose centre is nearest the front face's centre.
        let d = front - eye;
        let (su, sv) = (d.x / -d.z, d.y / -d.z);
        let x = ((su + r) / (2.0 * r) * w as f64 - 0.5).round() as u32;
        let y = ((t - sv) / (2.0 * t) * h as f64 - 0.5).round() as u32;
        let (org, dir) = lecture_ray(&scene.camera, w, h, x, y);
        let expected = common::axis_depth(&scene.camera, dir, (front.z - org.z) / dir.z);
        let got = film.depth[(y * w + x) as usize] as f64;
        assert!(
            (got - expected).abs() < 1e-4 * expected,
            "box {k} at pixel ({x}, {y}): depth {got}, expected {expected}"
        );
    }
}

#[test]
fn morph_targets_take_the_node_weights_else_the_mesh_weights() {
    let dir = TempDir::new("morph");
    let Some(dir) = cases(&dir) else { return };
    let loaded = from_gltf_file(&dir.join("morph.gltf"), None).unwrap();
    let scene = &loaded.scene;
    assert_eq!(scene.meshes.len(), 2, "one mesh per set of weights");
    let mut positions: Vec<Vec<[f32; 3]>> =
        scene.meshes.iter().map(|m| m.positions.iter().map(|p| p.to_array()).collect()).collect();
    positions.sort_by(|a, b| a[0][0].total_cmp(&b[0][0]));
    // mesh.weights [0.5, 1]: 0.5·(0, 0, 1) everywhere, 1·(0, 0.5, 0) on vertex 1 (sparse).
    assert_eq!(positions[0], [[-3.0, 0.0, 0.5], [-2.0, 0.5, 0.5], [-3.0, 1.0, 0.5]]);
    // node.weights [1, 0].
    assert_eq!(positions[1], [[3.0, 0.0, 1.0], [4.0, 0.0, 1.0], [3.0, 1.0, 1.0]]);
}

/// Twice the signed area of triangle `t` of `p`, seen from +z.
fn area_z(p: &[glam::Vec3], t: [u32; 3]) -> f64 {
    let [a, b, c] = t.map(|i| p[i as usize].as_dvec3());
    (b - a).cross(c - a).z
}

#[test]
fn strips_fans_and_sparse_positions_make_the_triangles_they_describe() {
    let dir = TempDir::new("modes");
    let Some(dir) = cases(&dir) else { return };
    let loaded = from_gltf_file(&dir.join("modes.gltf"), None).unwrap();
    assert!(loaded.warnings.iter().all(|w| !w.contains("is not triangles")), "{:?}", loaded.warnings);
    let mesh = &loaded.scene.meshes[0];
    assert_eq!(mesh.indices.len(), 2 + 6 + 1);
    let areas: Vec<f64> = mesh.indices.iter().map(|&t| area_z(&mesh.positions, t) / 2.0).collect();
    assert!(areas.iter().all(|&a| a > 0.0), "every triangle wound counter-clockwise: {areas:?}");
    let strip: f64 = areas[..2].iter().sum();
    let fan: f64 = areas[2..8].iter().sum();
    assert!((strip - 1.0).abs() < 1e-6, "{strip}");
    assert!((fan - 1.5 * 3f64.sqrt()).abs() < 1e-5, "regular hexagon of radius 1: {fan}");
    // The sparse vertex 2 (0, 2, -1) replaces (0, 1, -1): area 1, not 0.5.
    assert!((areas[8] - 1.0).abs() < 1e-6, "{}", areas[8]);
}

#[test]
fn bad_sparse_accessors_are_refused_naming_the_accessor() {
    let dir = TempDir::new("sparse-bad");
    let Some(dir_path) = cases(&dir) else { return };
    let json = std::fs::read_to_string(dir_path.join("modes.gltf")).unwrap();
    let mut doc: serde_json::Value = serde_json::from_str(&json).unwrap();
    let sparse_accessor = doc["meshes"][0]["primitives"][2]["attributes"]["POSITION"].as_u64().unwrap() as usize;
    doc["accessors"][sparse_accessor]["sparse"]["count"] = 4.into();
    std::fs::remove_file(dir_path.join("instancing.gltf")).unwrap();
    std::fs::remove_file(dir_path.join("morph.gltf")).unwrap();
    std::fs::remove_file(dir_path.join("modes.gltf")).unwrap();
    let path = dir.write("sparse.gltf", doc.to_string());
    let out = dir.path("out.exr");
    let e = fails(&dir, &["render", path.to_str().unwrap(), "--integrator", "whitted", "-o", out.to_str().unwrap()]);
    assert!(e.contains("sparse.gltf") && e.contains(&format!("accessor {sparse_accessor}")), "{e}");
    assert!(e.contains("sparse.count 4 is not in 1..=3"), "{e}");
}

/// A one-triangle glTF file with `top` (JSON members) added at the top level.
fn triangle_with(top: &str) -> String {
    let data = [0f32, 0., 0., 1., 0., 0., 0., 1., 0.].iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>();
    let b64 = base64::encode(&data);
    format!(
        r#"{{"asset":{{"version":"2.0"}}{top},"scene":0,"scenes":[{{"nodes":[0]}}],"nodes":[{{"mesh":0}}],
        "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}}}}]}}],
        "accessors":[{{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}}],
        "bufferViews":[{{"buffer":0,"byteLength":36}}],
        "buffers":[{{"byteLength":36,"uri":"data:application/octet-stream;base64,{b64}"}}]}}"#
    )
}

#[test]
fn missing_extensions_and_newer_versions_are_refused_by_name() {
    let dir = TempDir::new("refusals");
    let out = dir.path("out.exr");
    let render_args = |p: &str| {
        [
            "render".to_string(),
            p.to_string(),
            "--integrator".into(),
            "whitted".into(),
            "-o".into(),
            out.to_str().unwrap().into(),
        ]
    };
    let check = |name: &str, top: &str, says: &str| {
        let path = dir.write(name, triangle_with(top));
        let args = render_args(path.to_str().unwrap());
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let e = fails(&dir, &args);
        assert!(e.contains(name) && e.contains(says), "{e}");
        std::fs::remove_file(path).unwrap();
    };
    for ext in [
        "KHR_draco_mesh_compression",
        "EXT_meshopt_compression",
        "KHR_texture_basisu",
        "KHR_mesh_quantization",
        "VENDOR_unknown",
    ] {
        let top = format!(r#","extensionsUsed":["{ext}"],"extensionsRequired":["{ext}"]"#);
        check(&format!("{ext}.gltf"), &top, &format!("extensionsRequired: {ext}"));
    }
    let e = {
        let path = dir.write(
            "v21.gltf",
            triangle_with("").replace(r#""version":"2.0""#, r#""version":"2.1","minVersion":"2.1""#),
        );
        let args = render_args(path.to_str().unwrap());
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let e = fails(&dir, &args);
        std::fs::remove_file(path).unwrap();
        e
    };
    assert!(e.contains("v21.gltf") && e.contains("asset.minVersion \"2.1\""), "{e}");

    // A used (not required) extension strahl does not read: rendered, with a warning naming it.
    let path = dir.write("used.gltf", triangle_with(r#","extensionsUsed":["VENDOR_unknown"]"#));
    let run = strahl(&[
        "render",
        path.to_str().unwrap(),
        "--integrator",
        "whitted",
        "--width",
        "8",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(run.status.success(), "{}", text(&run.stderr));
    let warned: Vec<String> =
        text(&run.stderr).lines().filter(|l| l.contains("VENDOR_unknown")).map(str::to_string).collect();
    assert_eq!(warned.len(), 1, "{}", text(&run.stderr));
    assert!(warned[0].contains("used.gltf") && warned[0].contains("not supported; ignored"), "{}", warned[0]);
}

#[test]
fn an_orthographic_camera_sends_parallel_rays_from_its_view_rectangle() {
    let dir = TempDir::new("ortho");
    let Some(cases_dir) = cases(&dir) else { return };
    let out = dir.path("ortho.exr");
    // --width alone: the height follows xmag / ymag = 2.
    let run = strahl(&[
        "render",
        cases_dir.join("ortho.gltf").to_str().unwrap(),
        "--integrator",
        "whitted",
        "--width",
        "64",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(run.status.success(), "{}", text(&run.stderr));
    let (w, h, channels) = common::read_exr(&out);
    assert_eq!((w, h), (64, 32));
    let depth = common::channel(&channels, "ViewLayer.Depth.Z");
    // The view is x in [-2, 2], y in [-1, 1] at the eye; the card at z = 1 covers its top-right
    // quarter (pixel centres x > 0, y > 0), the floor at z = 0 the rest.
    for y in 0..h {
        for x in 0..w {
            let expected = if x >= w / 2 && y < h / 2 { 4.0 } else { 5.0 };
            assert_eq!(depth[y * w + x], expected, "pixel ({x}, {y})");
        }
    }
}

#[test]
fn width_alone_keeps_the_cameras_aspect_ratio() {
    let dir = TempDir::new("aspect");
    let Some(cases_dir) = cases(&dir) else { return };
    let out = dir.path("boxes.exr");
    let file = cases_dir.join("instancing.gltf");
    let run = strahl(&[
        "render",
        file.to_str().unwrap(),
        "--integrator",
        "whitted",
        "--width",
        "100",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(run.status.success(), "{}", text(&run.stderr));
    let (w, h, _) = common::read_exr(&out);
    assert_eq!((w, h), (100, 25), "aspectRatio 4");
    // Both given: both kept.
    let run = strahl(&[
        "render",
        file.to_str().unwrap(),
        "--integrator",
        "whitted",
        "--width",
        "30",
        "--height",
        "20",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(run.status.success(), "{}", text(&run.stderr));
    let (w, h, _) = common::read_exr(&out);
    assert_eq!((w, h), (30, 20));
}

#[test]
fn instancing_that_the_file_cannot_back_is_refused_before_it_is_built() {
    let dir = TempDir::new("instancing-bad");
    let out = dir.path("out.exr");
    let with_instances = |count: u64| {
        triangle_with(r#","extensionsUsed":["EXT_mesh_gpu_instancing"]"#)
            .replace(
                r#""nodes":[{"mesh":0}]"#,
                r#""nodes":[{"mesh":0,"extensions":{"EXT_mesh_gpu_instancing":{"attributes":{"TRANSLATION":1}}}}]"#,
            )
            .replace(
                r#""max":[1,1,0]}]"#,
                &format!(r#""max":[1,1,0]}},{{"bufferView":0,"componentType":5126,"count":{count},"type":"VEC3"}}]"#),
            )
    };
    // 10¹² placements declared: refused by the memory budget, from the declared count.
    let path = dir.write("many.gltf", with_instances(1_000_000_000_000));
    let e = fails(&dir, &["render", path.to_str().unwrap(), "--integrator", "whitted", "-o", out.to_str().unwrap()]);
    assert!(e.contains("many.gltf") && e.contains("1000000000001 mesh placements"), "{e}");
    std::fs::remove_file(path).unwrap();
    // 5 translations in the 36 bytes of 3.
    let path = dir.write("short.gltf", with_instances(5));
    let e = fails(&dir, &["render", path.to_str().unwrap(), "--integrator", "whitted", "-o", out.to_str().unwrap()]);
    assert!(
        e.contains("short.gltf") && e.contains("accessor 1 (node 0: EXT_mesh_gpu_instancing TRANSLATION): 5 elements"),
        "{e}"
    );
    std::fs::remove_file(path).unwrap();
    // 3 translations: the triangle placed 3 times.
    let path = dir.write("three.gltf", with_instances(3));
    let loaded = from_gltf_file(&path, None).unwrap();
    assert_eq!((loaded.scene.prototypes.len(), loaded.scene.instances.len()), (1, 3));
}
