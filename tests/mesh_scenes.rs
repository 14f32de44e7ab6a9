//! `type = "mesh"` objects in scene files: the file's MTL materials appended under `FILE/NAME`
//! after the scene's own, a material override, transforms of positions and normals, smooth
//! normals on request, paths relative to the scene file, warnings located in the scene and
//! the mesh file, and errors as one line naming both (also through `strahl render` and
//! `strahl info`: exit status 1, nothing written).

mod common;

use std::path::PathBuf;

use common::{TempDir, data_dir, fails, strahl, text};
use glam::Vec3;
use strahl::material::Texture;
use strahl::scene::{Loaded, ObjectSummary};

const HEAD: &str = "[camera]\neye = [0, 0, 5]\ntarget = [0, 0, 0]\nfov_deg = 40\n\
                    [materials.m]\ndiffuse = 0.5\n\
                    [[lights]]\ntype = \"point\"\nposition = [0, 0, 5]\nintensity = 1\n";

/// A quad of two triangles, red and green by `usemtl`, with its MTL library.
const QUAD_OBJ: &str =
    "mtllib two.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nusemtl red\nf 1 2 3\nusemtl green\nf 1 3 4\n";
const QUAD_MTL: &str = "newmtl red\nKd 1 0 0\nnewmtl green\nKd 0 1 0\n";

/// Writes the scene `HEAD + objects` into `dir` as `test.toml`; returns its path.
fn scene_file(dir: &TempDir, objects: &str) -> PathBuf {
    dir.write("test.toml", format!("{HEAD}{objects}"))
}

fn load(dir: &TempDir, objects: &str) -> Result<Loaded, String> {
    strahl::scene::load(scene_file(dir, objects)).map_err(|e| e.to_string())
}

/// `scene:LINE:COLUMN: ` of the first `path = ` value in the scene `HEAD + objects`.
fn at_path(scene: &std::path::Path, objects: &str) -> String {
    let text = format!("{HEAD}{objects}");
    let (line, l) = text.lines().enumerate().find(|(_, l)| l.starts_with("path = ")).unwrap();
    format!("{}:{}:{}: ", scene.display(), line + 1, l.find('"').unwrap() + 1)
}

fn quad_dir(tag: &str) -> TempDir {
    let dir = TempDir::new(tag);
    dir.write("two.obj", QUAD_OBJ);
    dir.write("two.mtl", QUAD_MTL);
    dir
}

#[test]
fn the_files_materials_follow_the_scenes_own_as_file_slash_name() {
    let dir = quad_dir("materials");
    let objects = "[[objects]]\ntype = \"mesh\"\nname = \"quad\"\npath = \"two.obj\"\n";
    let l = load(&dir, &format!("{objects}{objects}")).unwrap();
    assert!(l.warnings.is_empty(), "{:?}", l.warnings);
    let s = &l.scene;
    let names: Vec<&str> = s.materials.iter().map(|m| m.name.as_str()).collect();
    // Each mesh object adds the file's materials again, after what is there.
    assert_eq!(names, ["m", "two.obj/red", "two.obj/green", "two.obj/red", "two.obj/green"]);
    assert_eq!(s.materials[1].diffuse, Texture::Constant(Vec3::X));
    assert_eq!(s.materials[2].diffuse, Texture::Constant(Vec3::Y));
    assert_eq!(s.meshes[0].triangle_materials, Some(vec![1, 2]));
    assert_eq!(s.meshes[1].triangle_materials, Some(vec![3, 4]));
    assert_eq!(
        l.objects[0],
        ObjectSummary {
            name: Some("quad".into()),
            kind: "mesh",
            file: Some(dir.path("two.obj")),
            triangles: 2,
            spheres: 0,
            planes: 0,
            materials: vec!["two.obj/red".into(), "two.obj/green".into()],
            degenerate_dropped: 0,
        }
    );
}

#[test]
fn a_material_override_replaces_the_files_materials() {
    let dir = quad_dir("override");
    let l = load(&dir, "[[objects]]\ntype = \"mesh\"\npath = \"two.obj\"\nmaterial = \"m\"\n").unwrap();
    let (s, mesh) = (&l.scene, &l.scene.meshes[0]);
    assert_eq!(s.materials.len(), 1);
    assert_eq!((mesh.material, mesh.triangle_materials.clone()), (0, None));
    assert_eq!(l.objects[0].materials, ["m"]);
}

#[test]
fn the_transform_moves_positions_and_turns_normals() {
    let dir = TempDir::new("transform");
    dir.write("tri.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 1 1 0\nf 1//1 2//1 3//1\n");
    let l = load(&dir, "[[objects]]\ntype = \"mesh\"\npath = \"tri.obj\"\nscale = [2, 1, 1]\ntranslate = [1, 2, 3]\n")
        .unwrap();
    let mesh = &l.scene.meshes[0];
    assert_eq!(mesh.positions, [Vec3::new(1.0, 2.0, 3.0), Vec3::new(3.0, 2.0, 3.0), Vec3::new(1.0, 3.0, 3.0)]);
    // The normal (1, 1, 0)/√2 under diag(2, 1, 1): the inverse transpose diag(½, 1, 1) gives
    // (½, 1, 0), normalised.
    let want = Vec3::new(0.5, 1.0, 0.0).normalize();
    for n in mesh.normals.as_ref().unwrap() {
        assert!((*n - want).length() < 1e-6, "{n} vs {want}");
    }
}

#[test]
fn smooth_normals_only_when_asked_for() {
    // A tent: two faces meeting at the ridge y = 1 at right angles; no normals in the file.
    let dir = TempDir::new("smooth");
    dir.write("tent.obj", "v 0 1 0\nv 0 1 1\nv 1 0 0\nv -1 0 0\nf 1 2 3\nf 1 4 2\n");
    let flat = load(&dir, "[[objects]]\ntype = \"mesh\"\npath = \"tent.obj\"\n").unwrap();
    assert_eq!(flat.scene.meshes[0].normals, None);
    let smooth = load(&dir, "[[objects]]\ntype = \"mesh\"\npath = \"tent.obj\"\nsmooth_normals = true\n").unwrap();
    let n = smooth.scene.meshes[0].normals.as_ref().expect("smooth normals");
    assert!((n[0] - Vec3::Y).length() < 1e-6 && (n[1] - Vec3::Y).length() < 1e-6, "{n:?}");
    assert!((n[2] - Vec3::new(1.0, 1.0, 0.0).normalize()).length() < 1e-6, "{n:?}");
    // Only a mesh takes it.
    let e = load(
        &dir,
        "[[objects]]\ntype = \"sphere\"\ncenter = [0, 0, 0]\nradius = 1\nmaterial = \"m\"\nsmooth_normals = true\n",
    )
    .unwrap_err();
    assert!(e.contains("object 0 (sphere): a sphere has no `smooth_normals`"), "{e}");
}

#[test]
fn paths_are_relative_to_the_scene_file() {
    let dir = TempDir::new("relative");
    std::fs::create_dir_all(dir.path("scenes")).unwrap();
    std::fs::create_dir_all(dir.path("meshes")).unwrap();
    dir.write("meshes/tri.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    let scene =
        dir.write("scenes/s.toml", format!("{HEAD}[[objects]]\ntype = \"mesh\"\npath = \"../meshes/tri.obj\"\n"));
    let l = strahl::scene::load(&scene).unwrap();
    assert_eq!(l.scene.triangle_count(), 1);
    assert_eq!(l.objects[0].file, Some(dir.path("scenes/../meshes/tri.obj")));
}

#[test]
fn warnings_name_the_scene_object_and_the_mesh_file() {
    let dir = TempDir::new("warnings");
    // No MTL library, an undefined material, and a zero-area triangle.
    let obj =
        dir.write("lost.obj", "mtllib nowhere.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 2 0 0\nusemtl red\nf 1 2 3\nf 1 2 4\n");
    let objects = "[[objects]]\ntype = \"mesh\"\nname = \"lost\"\npath = \"lost.obj\"\n";
    let l = load(&dir, objects).unwrap();
    let at = format!("{}object 'lost' (mesh): {}", at_path(&dir.path("test.toml"), objects), obj.display());
    assert_eq!(
        l.warnings,
        [
            format!("{at}:1: material library 'nowhere.mtl' not found; its materials are replaced by a default one"),
            format!("{at}:6: material 'red' is not defined; a default material is used"),
            format!("{at}: dropped 1 degenerate (zero-area) triangles of 2"),
        ]
    );
    assert_eq!((l.objects[0].triangles, l.objects[0].degenerate_dropped), (1, 1));
    assert_eq!(l.objects[0].materials, ["lost.obj/default"]);

    // `strahl render` and `strahl info` print them on stderr and go on.
    let scene = dir.path("test.toml");
    let exr = dir.path("out.exr");
    for args in [
        vec!["render", scene.to_str().unwrap(), "-o", exr.to_str().unwrap(), "--width", "8", "--height", "6"],
        vec!["info", scene.to_str().unwrap()],
    ] {
        let out = strahl(&args);
        assert!(out.status.success(), "{args:?}: {}", text(&out.stderr));
        let want: Vec<String> = l.warnings.iter().map(|w| format!("warning: {w}")).collect();
        // `render` then says what it writes.
        let stderr = text(&out.stderr);
        let lines: Vec<&str> = stderr.lines().filter(|l| !l.starts_with("writing ")).collect();
        assert_eq!(lines, want, "{args:?}");
    }
    assert!(exr.is_file());
}

#[test]
fn mesh_file_errors_are_one_line_naming_the_scene_and_the_mesh_file() {
    let dir = TempDir::new("errors");
    let bad = dir.write("bad.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 9\n");
    let objects = "[[objects]]\ntype = \"mesh\"\nname = \"bad\"\npath = \"bad.obj\"\n";
    let scene = dir.path("test.toml");
    assert_eq!(
        load(&dir, objects).unwrap_err(),
        format!(
            "{}object 'bad' (mesh): {}:5: face index 9 out of range (4 vertices)",
            at_path(&scene, objects),
            bad.display()
        )
    );
    let objects = "[[objects]]\ntype = \"mesh\"\npath = \"nope.ply\"\n";
    assert_eq!(
        load(&dir, objects).unwrap_err(),
        format!(
            "{}object 0 (mesh): {}: No such file or directory (os error 2)",
            at_path(&scene, objects),
            dir.path("nope.ply").display()
        )
    );
}

/// `strahl render` and `strahl info` refuse the scene `objects` in `dir` with the one line
/// `error: {scene}:L:C: {object}: {mesh_error}`, exit status 1 and no output file.
fn both_commands_fail(dir: &TempDir, objects: &str, object: &str, mesh_error: &str) {
    let scene = scene_file(dir, objects);
    let want = format!("error: {}{object}: {mesh_error}", at_path(&scene, objects));
    let exr = dir.path("x.exr");
    let (scene, exr) = (scene.to_str().unwrap(), exr.to_str().unwrap());
    assert_eq!(fails(dir, &["render", scene, "-o", exr, "--png", &exr.replace(".exr", ".png")]), want);
    assert_eq!(fails(dir, &["info", scene]), want);
}

#[test]
fn a_missing_mesh_file_stops_render_and_info() {
    let dir = TempDir::new("missing-cli");
    let missing = dir.path("gone/bunny.ply");
    both_commands_fail(
        &dir,
        "[[objects]]\ntype = \"mesh\"\nname = \"bunny\"\npath = \"gone/bunny.ply\"\n",
        "object 'bunny' (mesh)",
        &format!("{}: No such file or directory (os error 2)", missing.display()),
    );
}

#[test]
fn malformed_mesh_files_stop_render_and_info() {
    let Some(data) = data_dir() else { return };
    let dir = TempDir::new("malformed-cli");
    for (file, problem) in [
        ("invalid_malformed.obj", ":23: face index 12 out of range (8 vertices)"),
        ("invalid_malformed2.obj", ":23: face has 0 vertices (a polygon needs at least 3)"),
    ] {
        let path = data.join("edge-cases/assimp-obj").join(file);
        both_commands_fail(
            &dir,
            &format!(
                "[[objects]]\ntype = \"mesh\"\nname = \"broken\"\npath = {:?}\nmaterial = \"m\"\n",
                path.display()
            ),
            "object 'broken' (mesh)",
            &format!("{}{problem}", path.display()),
        );
    }
}
