//! The mesh loaders against the shared test data (every file, each with its expected outcome),
//! the Stanford models, the Cornell box's materials, bad input written here, concave polygons,
//! and the generated mesh the shipped scenes use.
//!
//! The data folder is `../shared/data/meshes` beside the crate, or `$STRAHL_TEST_DATA`. When it
//! is missing the data tests fail under CI (`CI` set) and are skipped loudly elsewhere.

mod common;

use std::path::Path;

use common::{TempDir, data_dir};
use strahl::material::Texture;
use strahl::math::Vec3;
use strahl::scene::load::{LoadedMesh, MeshError, MeshOptions, load_mesh, ply};
use strahl::scene::procedural;

fn load(path: &Path) -> Result<LoadedMesh, MeshError> {
    load_mesh(path, &MeshOptions::default())
}

/// What loading a file must give.
#[derive(Debug)]
enum Expect {
    /// Loads: `read` triangles from the faces (Σ corners − 2, counted from the face lines by a
    /// separate script), of which `dropped` have zero area (exact arithmetic on the f32
    /// coordinates, same script).
    Loads { read: usize, dropped: usize },
    /// Fails with a message containing this (after the file's path).
    Fails(&'static str),
    /// Not a mesh file (MTL libraries, READMEs): not loaded, but listed so that every file is.
    NotMesh,
}

use Expect::{Fails, Loads, NotMesh};

/// An OBJ whose MTL library (named at line 3) names a texture that is not there: an error at
/// the `mtllib` line (docs/scene-format.md).
const MISSING_TEXTURE_AT_3: &str = ":3: ";

const fn ok(read: usize) -> Expect {
    Loads { read, dropped: 0 }
}

const NO_FACES: &str = ": no faces to render";

/// Every file of the test data, with its expected outcome.
const TABLE: &[(&str, Expect)] = &[
    ("cornell/CornellBox-Empty-CO.mtl", NotMesh),
    ("cornell/CornellBox-Empty-CO.obj", ok(12)),
    ("cornell/CornellBox-Empty-RG.mtl", NotMesh),
    ("cornell/CornellBox-Empty-RG.obj", ok(12)),
    ("cornell/CornellBox-Empty-Squashed.mtl", NotMesh),
    ("cornell/CornellBox-Empty-Squashed.obj", ok(12)),
    ("cornell/CornellBox-Empty-White.mtl", NotMesh),
    ("cornell/CornellBox-Empty-White.obj", ok(12)),
    ("cornell/CornellBox-Glossy-Floor.mtl", NotMesh),
    ("cornell/CornellBox-Glossy-Floor.obj", ok(1112)),
    ("cornell/CornellBox-Glossy.mtl", NotMesh),
    ("cornell/CornellBox-Glossy.obj", ok(1112)),
    ("cornell/CornellBox-Mirror.mtl", NotMesh),
    ("cornell/CornellBox-Mirror.obj", ok(36)),
    ("cornell/CornellBox-Original.mtl", NotMesh),
    ("cornell/CornellBox-Original.obj", ok(36)),
    ("cornell/CornellBox-Sphere.mtl", NotMesh),
    ("cornell/CornellBox-Sphere.obj", ok(2188)),
    ("cornell/CornellBox-Water.mtl", NotMesh),
    ("cornell/CornellBox-Water.obj", ok(7088)),
    ("cornell/README.mcguire.md", NotMesh),
    ("cornell/copyright.txt", NotMesh),
    ("cornell/water.mtl", NotMesh),
    ("cornell/water.obj", ok(4900)),
    ("edge-cases/assimp-obj/WusonOBJ.obj", ok(3732)),
    ("edge-cases/assimp-obj/box.obj", ok(12)),
    // UTF-16 big endian with a byte-order mark: decoded.
    ("edge-cases/assimp-obj/box_UTF16BE.obj", ok(12)),
    // One face of 936 corners going round the same square 234 times: not a simple polygon, so a
    // fan from its first corner (934 triangles, the 466 that touch corner 1 again have zero
    // area), with a warning; then five quads.
    ("edge-cases/assimp-obj/box_longline.obj", Loads { read: 944, dropped: 466 }),
    ("edge-cases/assimp-obj/box_mat_with_spaces.obj", ok(12)),
    ("edge-cases/assimp-obj/box_spaces.mtl", NotMesh),
    ("edge-cases/assimp-obj/box_without_lineending.obj", ok(12)),
    ("edge-cases/assimp-obj/concave_polygon.mtl", NotMesh),
    // One concave face of 66 corners.
    ("edge-cases/assimp-obj/concave_polygon.obj", ok(64)),
    ("edge-cases/assimp-obj/cube_mtllib_after_g.mtl", NotMesh),
    ("edge-cases/assimp-obj/cube_mtllib_after_g.obj", ok(12)),
    ("edge-cases/assimp-obj/cube_usemtl.mtl", NotMesh),
    ("edge-cases/assimp-obj/cube_usemtl.obj", ok(12)),
    ("edge-cases/assimp-obj/cube_with_vertexcolors.obj", ok(12)),
    ("edge-cases/assimp-obj/cube_with_vertexcolors_uni.obj", ok(12)),
    ("edge-cases/assimp-obj/empty_mat.mtl", NotMesh),
    // `usemtl` and `newmtl` with empty names, `Ks 0`.
    ("edge-cases/assimp-obj/empty_mat.obj", ok(256)),
    ("edge-cases/assimp-obj/invalid_malformed.obj", Fails(":23: face index 12 out of range (8 vertices)")),
    ("edge-cases/assimp-obj/invalid_malformed2.obj", Fails(":23: face has 0 vertices (a polygon needs at least 3)")),
    ("edge-cases/assimp-obj/multiple_spaces.obj", ok(1)),
    // `3.1+e2` is not a number.
    ("edge-cases/assimp-obj/number_formats.obj", Fails(":11: '3.1+e2' is not a number")),
    ("edge-cases/assimp-obj/point_cloud.obj", Fails(NO_FACES)),
    ("edge-cases/assimp-obj/regr01.mtl", NotMesh),
    ("edge-cases/assimp-obj/regr01.obj", Loads { read: 2710, dropped: 4 }),
    ("edge-cases/assimp-obj/regr_3429812.mtl", NotMesh),
    ("edge-cases/assimp-obj/regr_3429812.obj", ok(4)),
    ("edge-cases/assimp-obj/space_in_material_name.mtl", NotMesh),
    ("edge-cases/assimp-obj/space_in_material_name.obj", ok(64)),
    ("edge-cases/assimp-obj/spider.mtl", NotMesh),
    ("edge-cases/assimp-obj/spider.obj", Fails(MISSING_TEXTURE_AT_3)),
    ("edge-cases/assimp-obj/testline.obj", Fails(NO_FACES)),
    ("edge-cases/assimp-obj/testmixed.obj", ok(12)),
    ("edge-cases/assimp-obj/testpoints.obj", Fails(NO_FACES)),
    // A header line without `comment`: a warning.
    ("edge-cases/assimp-ply/Wuson.ply", ok(3732)),
    ("edge-cases/assimp-ply/cube.ply", ok(12)),
    ("edge-cases/assimp-ply/cube_binary.ply", ok(12)),
    ("edge-cases/assimp-ply/cube_uv.ply", ok(12)),
    ("edge-cases/assimp-ply/float-color.ply", ok(1)),
    // A list property in the vertex element that the data lines do not have.
    ("edge-cases/assimp-ply/issue623.ply", Fails(":13: missing vertex_indices")),
    ("edge-cases/assimp-ply/points.ply", Fails(NO_FACES)),
    ("edge-cases/obj-rs/cube.mtl", NotMesh),
    ("edge-cases/obj-rs/cube.obj", Fails(MISSING_TEXTURE_AT_3)),
    ("edge-cases/obj-rs/dome.obj", ok(62)),
    ("edge-cases/obj-rs/empty.obj", Fails(NO_FACES)),
    // Nine faces `f 1 1 1`.
    ("edge-cases/obj-rs/group.obj", Fails(": all 9 triangles have zero area")),
    ("edge-cases/obj-rs/lines_points.obj", Fails(NO_FACES)),
    ("edge-cases/obj-rs/normal-cone.obj", ok(32)),
    ("edge-cases/obj-rs/textured-cube.obj", Fails(":1: ")), // its cube.mtl names a texture the data lacks
    ("edge-cases/obj-rs/untitled.mtl", NotMesh),
    ("edge-cases/obj-rs/untitled.obj", ok(24)),
    // ply-rs's "ok" files without faces are valid PLY but nothing to render.
    ("edge-cases/ply-rs/all_atomic_types_ok_ascii.ply", Fails(NO_FACES)),
    ("edge-cases/ply-rs/empty_2_ok_ascii.ply", Fails(NO_FACES)),
    ("edge-cases/ply-rs/empty_2_ok_little_endian.ply", Fails(NO_FACES)),
    ("edge-cases/ply-rs/empty_ok_ascii.ply", Fails(NO_FACES)),
    ("edge-cases/ply-rs/exponent_values_ok_ascii.ply", Fails(NO_FACES)),
    ("edge-cases/ply-rs/greg_turk_example1_ok_ascii.ply", ok(12)),
    ("edge-cases/ply-rs/greg_turk_example2_ok_ascii.ply", ok(12)),
    ("edge-cases/ply-rs/header_min_ok_ascii.ply", Fails(NO_FACES)),
    ("edge-cases/ply-rs/house_2_ok_ascii.ply", ok(3)),
    ("edge-cases/ply-rs/house_2_ok_little_endian.ply", ok(3)),
    ("edge-cases/ply-rs/house_ok_ascii.ply", ok(3)),
    ("edge-cases/ply-rs/leading_spaces_ok_ascii.ply", Fails(NO_FACES)),
    ("edge-cases/ply-rs/single_elements_err_ascii.ply", Fails(":10: the file ends after 1 of 2 'point' elements")),
    ("edge-cases/ply-rs/single_elements_ok_ascii.ply", Fails(NO_FACES)),
    ("edge-cases/pyvista/airplane.ply", ok(2452)),
    ("edge-cases/pyvista/ant.ply", ok(912)),
    ("edge-cases/pyvista/nut.ply", ok(1046)),
    ("edge-cases/pyvista/sphere.ply", ok(840)),
    ("stanford/README.bunny-reconstruction", NotMesh),
    ("stanford/README.dragon-vrip", NotMesh),
    ("stanford/STANFORD_TERMS.md", NotMesh),
    ("stanford/bun_zipper.ply", ok(69451)),
    ("stanford/bun_zipper_res3.ply", ok(3851)),
    ("stanford/bun_zipper_res4.ply", ok(948)),
    ("stanford/dragon_vrip.ply.gz", Loads { read: 871_414, dropped: 108 }),
    ("stanford/dragon_vrip_res2.ply.gz", ok(202_520)),
    ("stanford/dragon_vrip_res4.ply.gz", ok(11102)),
    ("stanford/stanford-bunny.obj", ok(69451)),
    ("teapot/README.mcguire.md", NotMesh),
    ("teapot/default.mtl", NotMesh),
    // 352 triangles and 7676 quads.
    ("teapot/teapot.obj", Fails(":1: ")),
];

fn walk(dir: &Path, root: &Path, out: &mut Vec<String>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            walk(&path, root, out);
        } else {
            out.push(path.strip_prefix(root).unwrap().to_string_lossy().replace('\\', "/"));
        }
    }
}

#[test]
fn every_file_of_the_test_data_has_its_expected_outcome() {
    let Some(root) = data_dir() else { return };
    let mut files = Vec::new();
    walk(&root, &root, &mut files);
    files.sort();
    let unlisted: Vec<&String> = files.iter().filter(|f| !TABLE.iter().any(|(t, _)| t == f)).collect();
    assert!(unlisted.is_empty(), "files without an expected outcome in TABLE: {unlisted:?}");
    let vanished: Vec<&str> = TABLE.iter().map(|(t, _)| *t).filter(|t| !files.iter().any(|f| f == t)).collect();
    assert!(vanished.is_empty(), "TABLE lists files that are not there: {vanished:?}");

    let mut failures = Vec::new();
    for (name, expect) in TABLE {
        let path = root.join(name);
        let result = std::panic::catch_unwind(|| load(&path));
        let outcome = match (expect, result) {
            (_, Err(_)) => Err("panicked".to_string()),
            (NotMesh, Ok(r)) => match r {
                Err(MeshError::Invalid { problem, .. }) if problem.starts_with("unknown mesh format") => Ok(()),
                other => Err(format!("expected 'unknown mesh format', got {other:?}")),
            },
            (Loads { read, dropped }, Ok(Ok(l))) => {
                let kept = l.meshes.iter().map(|m| m.indices.len()).sum::<usize>();
                if (l.triangles_read, l.degenerate_dropped, kept) != (*read, *dropped, read - dropped) {
                    Err(format!(
                        "read {} dropped {} kept {kept}, expected {read} {dropped} {}",
                        l.triangles_read,
                        l.degenerate_dropped,
                        read - dropped
                    ))
                } else if let Some(p) = l.meshes.iter().find_map(|m| m.problem()) {
                    Err(format!("invalid mesh: {p}"))
                } else if l.meshes.iter().flat_map(|m| m.indices.iter().enumerate().map(move |(i, _)| (m, i))).any(
                    |(m, i)| {
                        let [a, b, c] = m.triangle(i);
                        (b - a).cross(c - a) == Vec3::ZERO || m.material_of(i) as usize >= l.materials.len()
                    },
                ) {
                    Err("a zero-area triangle or a material index out of range was passed on".into())
                } else {
                    Ok(())
                }
            }
            (Loads { .. }, Ok(Err(e))) => Err(format!("failed: {e}")),
            (Fails(fragment), Ok(Err(e))) => {
                let msg = e.to_string();
                let prefix = format!("{}", path.display());
                if msg.starts_with(&prefix) && msg[prefix.len()..].starts_with(fragment) && !msg.contains('\n') {
                    Ok(())
                } else {
                    Err(format!("message {msg:?} is not '{prefix}{fragment}…'"))
                }
            }
            (Fails(fragment), Ok(Ok(_))) => Err(format!("loaded, expected failure '{fragment}'")),
        };
        if let Err(why) = outcome {
            failures.push(format!("{name}: {why}"));
        }
    }
    assert!(failures.is_empty(), "{} files not as expected:\n{}", failures.len(), failures.join("\n"));
}

#[test]
fn bunny_ply_and_obj_give_the_same_mesh() {
    let Some(root) = data_dir() else { return };
    let ply = load(&root.join("stanford/bun_zipper.ply")).unwrap();
    let obj = load(&root.join("stanford/stanford-bunny.obj")).unwrap();
    let (p, o) = (&ply.meshes[0], &obj.meshes[0]);
    assert_eq!((ply.meshes.len(), obj.meshes.len()), (1, 1));
    // 35,947 vertices in both files, of which the faces use 34,834 (the rest are left out).
    assert_eq!(p.positions.len(), 34834);
    assert_eq!(p.positions.len(), o.positions.len());
    let worst = p.positions.iter().zip(&o.positions).map(|(a, b)| (*a - *b).abs().max_element()).fold(0.0, f32::max);
    assert!(worst <= 1e-6, "vertices differ by up to {worst}");
    assert_eq!(p.indices.len(), 69451);
    assert_eq!(p.indices, o.indices);
    // The bunny's confidence and intensity properties are skipped; no normals in either file.
    assert!(p.normals.is_none() && o.normals.is_none() && p.colors.is_none());
}

#[test]
fn dragon_drops_its_108_zero_area_triangles() {
    let Some(root) = data_dir() else { return };
    let path = root.join("stanford/dragon_vrip.ply.gz");
    let l = load(&path).unwrap();
    assert_eq!((l.triangles_read, l.degenerate_dropped, l.triangle_count()), (871_414, 108, 871_306));
    assert_eq!(l.meshes[0].positions.len(), 437_645);
    assert!(
        l.warnings.iter().any(|w| w.contains("dropped 108 degenerate (zero-area) triangles of 871414")),
        "{:?}",
        l.warnings
    );
    // Smooth normals on request: unit length, and facing the way the triangles do.
    let s = load_mesh(&root.join("stanford/dragon_vrip_res4.ply.gz"), &MeshOptions { smooth_normals: true }).unwrap();
    let m = &s.meshes[0];
    let n = m.normals.as_ref().expect("smooth normals");
    assert!(n.iter().all(|n| (n.length() - 1.0).abs() < 1e-5));
    let agree = (0..m.indices.len())
        .filter(|&i| {
            let [a, b, c] = m.triangle(i);
            (b - a).cross(c - a).dot(n[m.indices[i][0] as usize]) > 0.0
        })
        .count();
    assert!(agree as f64 > 0.95 * m.indices.len() as f64, "{agree} of {}", m.indices.len());
}

#[test]
fn cornell_box_has_its_mtl_colours_and_per_triangle_materials() {
    let Some(root) = data_dir() else { return };
    let l = load(&root.join("cornell/CornellBox-Original.obj")).unwrap();
    assert!(l.warnings.is_empty(), "{:?}", l.warnings);
    let names: Vec<&str> = l.materials.iter().map(|m| m.name.as_str()).collect();
    assert_eq!(names, ["leftWall", "rightWall", "floor", "ceiling", "backWall", "shortBox", "tallBox", "light"]);
    let mat = |name: &str| l.materials.iter().find(|m| m.name == name).unwrap();
    assert_eq!(mat("leftWall").diffuse, Texture::Constant(Vec3::new(0.63, 0.065, 0.05)));
    assert_eq!(mat("rightWall").diffuse, Texture::Constant(Vec3::new(0.14, 0.45, 0.091)));
    assert_eq!(mat("floor").diffuse, Texture::Constant(Vec3::new(0.725, 0.71, 0.68)));
    assert_eq!(mat("light").emission, Vec3::new(17.0, 12.0, 4.0));
    assert_eq!((mat("floor").specular, mat("floor").shininess), (Vec3::ZERO, 10.0));

    let meshes: Vec<(&str, usize)> = l.meshes.iter().map(|m| (m.name.as_str(), m.indices.len())).collect();
    assert_eq!(
        meshes,
        [
            ("floor", 2),
            ("ceiling", 2),
            ("backWall", 2),
            ("rightWall", 2),
            ("leftWall", 14),
            ("shortBox", 12),
            ("light", 2)
        ]
    );
    let material_names = |i: usize| -> Vec<&str> {
        let m = &l.meshes[i];
        (0..m.indices.len()).map(|t| l.materials[m.material_of(t) as usize].name.as_str()).collect()
    };
    // The group `leftWall` holds the wall and, after `usemtl shortBox`, the short box.
    let mut expected = vec!["leftWall"; 2];
    expected.extend(["shortBox"; 12]);
    assert_eq!(material_names(4), expected);
    // The group `shortBox` holds the tall box (`usemtl tallBox`).
    assert_eq!(material_names(5), vec!["tallBox"; 12]);
    assert_eq!(material_names(6), vec!["light"; 2]);
    // The light is the quad at y = 1.98 with corners (−0.24, −0.22) to (0.23, 0.16) in x, z,
    // facing down (its tab-separated `v` lines and relative indices read right).
    let light = &l.meshes[6];
    assert_eq!(light.positions.len(), 4);
    assert!(light.positions.iter().all(|p| p.y == 1.98));
    assert_eq!((light.bounds().min, light.bounds().max), (Vec3::new(-0.24, 1.98, -0.22), Vec3::new(0.23, 1.98, 0.16)));
    for i in 0..2 {
        let [a, b, c] = light.triangle(i);
        assert!((b - a).cross(c - a).y < 0.0);
    }
}

#[test]
fn vertex_colours_and_normals_of_an_obj_cube() {
    let Some(root) = data_dir() else { return };
    let l = load(&root.join("edge-cases/assimp-obj/cube_with_vertexcolors.obj")).unwrap();
    let m = &l.meshes[0];
    // `f 1//2 7//2 5//2`: the first vertex is v 1 with normal vn 2.
    assert_eq!(m.positions[0], Vec3::ZERO);
    assert_eq!(m.colors.as_ref().unwrap()[0], Vec3::new(0.48627, 0.43137, 0.47059));
    assert_eq!(m.normals.as_ref().unwrap()[0], Vec3::new(0.0, 0.0, -1.0));
    // The UTF-16 box is the UTF-8 box.
    let a = load(&root.join("edge-cases/assimp-obj/box.obj")).unwrap();
    let b = load(&root.join("edge-cases/assimp-obj/box_UTF16BE.obj")).unwrap();
    assert_eq!(a.meshes[0].positions, b.meshes[0].positions);
    assert_eq!(a.meshes[0].indices, b.meshes[0].indices);
}

#[test]
fn ply_vertex_attributes() {
    let Some(root) = data_dir() else { return };
    let mesh = |name: &str| load(&root.join(name)).unwrap().meshes.remove(0);
    // Float colours taken as they are, alpha ignored.
    assert_eq!(mesh("edge-cases/assimp-ply/float-color.ply").colors.unwrap(), vec![Vec3::Z; 3]);
    // uchar colours scaled to 0–1: the first four vertices red, the last four blue.
    let c = mesh("edge-cases/ply-rs/greg_turk_example2_ok_ascii.ply").colors.unwrap();
    assert_eq!((c[0], c[7]), (Vec3::X, Vec3::Z));
    // `s t` texture coordinates and normals (Blender).
    let m = mesh("edge-cases/assimp-ply/cube_uv.ply");
    assert_eq!((m.uvs.as_ref().map(Vec::len), m.normals.as_ref().map(Vec::len)), (Some(24), Some(24)));
    assert!(m.uvs.unwrap().iter().all(|uv| (0.0..=1.0).contains(&uv.x) && (0.0..=1.0).contains(&uv.y)));
    // Binary little endian from VTK, and CRLF ASCII.
    assert_eq!(mesh("edge-cases/pyvista/sphere.ply").positions.len(), 422);
    assert_eq!(mesh("edge-cases/pyvista/airplane.ply").indices.len(), 2452);
}

#[test]
fn gzip_compressed_obj_reads_like_the_plain_file() {
    use std::io::Write;
    let dir = TempDir::new("gz");
    let text = "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nusemtl red\nf 1 2 3 4\n";
    dir.write("m.mtl", b"newmtl red\nKd 1 0 0\n");
    let mut gz = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
    gz.write_all(text.as_bytes()).unwrap();
    let packed = dir.write("quad.obj.gz", gz.finish().unwrap());
    let plain = dir.write("quad.obj", text.as_bytes());
    let (a, b) = (load(&packed).unwrap(), load(&plain).unwrap());
    assert_eq!(a.meshes[0].indices, vec![[0, 1, 2], [0, 2, 3]]);
    assert_eq!((a.meshes[0].positions.clone(), a.materials.clone()), (b.meshes[0].positions.clone(), b.materials));
    assert_eq!(a.materials[0].diffuse, Texture::Constant(Vec3::X));
}

#[test]
fn mutated_real_files_never_panic() {
    use rand::{Rng, SeedableRng};
    let Some(root) = data_dir() else { return };
    let files = [
        "edge-cases/assimp-obj/cube_usemtl.obj",
        "edge-cases/obj-rs/textured-cube.obj",
        "cornell/CornellBox-Original.mtl",
        "edge-cases/assimp-ply/cube_binary.ply",
        "edge-cases/ply-rs/greg_turk_example2_ok_ascii.ply",
        "edge-cases/ply-rs/house_2_ok_little_endian.ply",
        "edge-cases/pyvista/ant.ply",
    ];
    let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(17);
    let options = MeshOptions { smooth_normals: true };
    for name in files {
        let original = std::fs::read(root.join(name)).unwrap();
        let path = Path::new("/nonexistent/strahl-fuzz").join(name);
        for _ in 0..1500 {
            let mut d = original.clone();
            for _ in 0..rng.random_range(1..8) {
                let i = rng.random_range(0..d.len());
                match rng.random_range(0..4) {
                    0 => d[i] = rng.random(),
                    1 => {
                        let alphabet = b" \n-0123456789/.e#f";
                        d[i] = alphabet[rng.random_range(0..alphabet.len())];
                    }
                    2 => {
                        d.remove(i);
                    }
                    _ => d.insert(i, rng.random()),
                }
            }
            d.truncate(rng.random_range(d.len() / 2..=d.len()));
            let result = std::panic::catch_unwind(|| {
                if name.ends_with(".ply") {
                    let _ = ply::parse(&path, &d, &options);
                } else if name.ends_with(".mtl") {
                    let _ = strahl::scene::load::obj::parse_mtl(&path, &d, &mut Vec::new());
                } else {
                    let _ = strahl::scene::load::obj::parse(&path, &d, &options);
                }
            });
            assert!(result.is_ok(), "{name} mutated to {:?} panicked", String::from_utf8_lossy(&d));
        }
    }
}

#[test]
fn bad_input_is_one_line_naming_the_file_and_line() {
    let dir = TempDir::new("bad");
    let err = |name: &str, bytes: &[u8]| {
        let path = dir.write(name, bytes);
        let msg = load(&path).unwrap_err().to_string();
        assert!(!msg.contains('\n'), "{msg}");
        msg.strip_prefix(&path.display().to_string())
            .unwrap_or_else(|| panic!("{msg} does not name the file"))
            .to_owned()
    };
    let cube8 = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n";
    assert_eq!(
        err("bad.obj", format!("{cube8}f 1 2 3\n\n# x\nf 1 2 9\n").as_bytes()),
        ":12: face index 9 out of range (8 vertices)"
    );
    assert_eq!(err("rel.obj", format!("{cube8}f -9 1 2\n").as_bytes()), ":9: face index -9 out of range (8 vertices)");
    assert_eq!(err("nan.obj", b"v 0 0 0\nv 1 0 inf\n"), ":2: vertex 2 is not finite");
    assert_eq!(err("empty.obj", b""), ": no faces to render (0 vertices and no polygons: a point cloud or lines?)");
    assert_eq!(
        err("garbage.obj", &[0u8, 159, 146, 150, 0, 1]),
        ": binary data, not OBJ text (UTF-16 without a byte-order mark?)"
    );
    assert_eq!(err("empty.ply", b""), ": empty file");
    assert_eq!(err("text.ply", b"hello\nworld\n"), ": not a PLY file (the first line is not 'ply')");
    assert_eq!(err("noend.ply", b"ply\nformat ascii 1.0\n"), ": the header has no end_header line");
    let head = |format: &str, faces: usize| {
        format!(
            "ply\nformat {format} 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n\
             element face {faces}\nproperty list uchar uint vertex_indices\nend_header\n"
        )
    };
    assert_eq!(err("x.ply", head("binary_middle_endian", 1).as_bytes()), ": unknown PLY format 'binary_middle_endian'");
    // A binary PLY that stops inside its 2000 faces, after 1200 of them.
    let mut bin = head("binary_little_endian", 2000).into_bytes();
    for p in [[0f32, 0., 0.], [1., 0., 0.], [1., 1., 0.], [0., 1., 0.]] {
        p.iter().for_each(|c| bin.extend(c.to_le_bytes()));
    }
    for _ in 0..1200 {
        bin.extend([3u8]);
        [0u32, 1, 2].iter().for_each(|i| bin.extend(i.to_le_bytes()));
    }
    bin.extend([3, 0, 0]);
    assert_eq!(err("x.ply", &bin), ": truncated binary PLY: 1200 of 2000 faces");
    let ascii = head("ascii", 1) + "0 0 0\n1 0 0\n1 1 0\n0 1 0\n3 0 1 4\n";
    assert_eq!(err("range.ply", ascii.as_bytes()), ":14: face index 4 out of range (4 vertices)");
    assert_eq!(err("gz.ply.gz", b"ply\n"), ": named .gz but not gzip-compressed");
    assert_eq!(err("x.stl", b"solid"), ": unknown mesh format: expected a .obj or .ply file (optionally .gz)");
    let missing = dir.path("missing.obj");
    assert!(load(&missing).unwrap_err().to_string().starts_with(&format!("{}: ", missing.display())));
    // A missing MTL library is a warning and a default material, not a failure.
    let path = dir.write("nomtl.obj", b"mtllib nowhere.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl red\nf 1 2 3\n");
    let l = load(&path).unwrap();
    assert_eq!((l.materials.len(), l.meshes[0].material), (1, 0));
    assert_eq!(l.warnings.len(), 2, "{:?}", l.warnings);
    assert!(l.warnings[0].contains(":1: material library 'nowhere.mtl' not found"));
}

/// The area of a polygon in its plane (half the Newell normal's length) and its outline
/// projected onto that plane's best coordinate plane.
fn polygon_area(corners: &[Vec3]) -> f64 {
    strahl::scene::load::polygon::newell_normal(corners).length() / 2.0
}

fn inside(p: [f64; 2], outline: &[[f64; 2]]) -> bool {
    let mut inside = false;
    for i in 0..outline.len() {
        let (a, b) = (outline[i], outline[(i + 1) % outline.len()]);
        if (a[1] > p[1]) != (b[1] > p[1]) && p[0] < a[0] + (p[1] - a[1]) * (b[0] - a[0]) / (b[1] - a[1]) {
            inside = !inside;
        }
    }
    inside
}

/// Loads a one-face OBJ and checks its triangles tile exactly the face.
fn check_tiles_the_polygon(path: &Path, corners: &[Vec3]) {
    let l = load(path).unwrap();
    let m = &l.meshes[0];
    assert_eq!(l.triangles_read, corners.len() - 2);
    let total: f64 = (0..m.indices.len())
        .map(|i| m.triangle(i))
        .map(|[a, b, c]| ((b - a).cross(c - a)).as_dvec3().length() / 2.0)
        .sum();
    let area = polygon_area(corners);
    assert!((total - area).abs() < 1e-5 * area, "triangles cover {total}, the polygon is {area}");
    let normal = strahl::scene::load::polygon::newell_normal(corners);
    let outline = strahl::scene::load::polygon::project(corners, normal);
    for i in 0..m.indices.len() {
        let [a, b, c] = m.triangle(i);
        let centroid = (a + b + c) / 3.0;
        let mut with_centroid = corners.to_vec();
        with_centroid.push(centroid);
        let projected = strahl::scene::load::polygon::project(&with_centroid, normal);
        assert!(inside(projected[corners.len()], &outline), "triangle {i}'s centroid {centroid} is outside");
        // And the triangle faces the way the polygon does.
        assert!((b - a).cross(c - a).as_dvec3().dot(normal) > 0.0, "triangle {i} is flipped");
    }
}

#[test]
fn concave_polygons_are_tiled_exactly() {
    // A comb of six 1 × 2 teeth on an 11 × 1 back (24 corners, area 23) in a tilted plane.
    let mut outline = vec![(0.0, 0.0), (11.0, 0.0)];
    for t in (0..6).rev() {
        let (left, right) = (2.0 * t as f32, 2.0 * t as f32 + 1.0);
        outline.extend([(right, 3.0), (left, 3.0)]);
        if t > 0 {
            outline.extend([(left, 1.0), (left - 1.0, 1.0)]);
        }
    }
    let tilt = glam::Quat::from_axis_angle(Vec3::new(0.3, 1.0, 0.2).normalize(), 0.7);
    let corners: Vec<Vec3> = outline.iter().map(|&(x, y)| tilt * Vec3::new(x, y, 0.0) + Vec3::splat(5.0)).collect();
    let mut obj = String::new();
    for c in &corners {
        obj += &format!("v {} {} {}\n", c.x, c.y, c.z);
    }
    obj += "f";
    for i in 1..=corners.len() {
        obj += &format!(" {i}");
    }
    let dir = TempDir::new("concave");
    let path = dir.write("comb.obj", obj.as_bytes());
    check_tiles_the_polygon(&path, &corners);
    assert_eq!(corners.len(), 24);
    assert!((polygon_area(&corners) - 23.0).abs() < 1e-3, "{}", polygon_area(&corners));

    // assimp's concave test polygon (66 corners).
    let Some(root) = data_dir() else { return };
    let path = root.join("edge-cases/assimp-obj/concave_polygon.obj");
    let text = std::fs::read_to_string(&path).unwrap();
    let vertices: Vec<Vec3> = text
        .lines()
        .filter_map(|l| l.strip_prefix("v "))
        .map(|l| {
            let v: Vec<f32> = l.split_whitespace().map(|x| x.parse().unwrap()).collect();
            Vec3::new(v[0], v[1], v[2])
        })
        .collect();
    let face = text.lines().find_map(|l| l.strip_prefix("f ")).unwrap();
    let corners: Vec<Vec3> =
        face.split_whitespace().map(|c| vertices[c.split('/').next().unwrap().parse::<usize>().unwrap() - 1]).collect();
    assert_eq!(corners.len(), 66);
    check_tiles_the_polygon(&path, &corners);
}

#[test]
fn the_shipped_meshes_are_up_to_date_and_load() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/meshes");
    for (name, mesh, comment) in procedural::shipped_meshes() {
        let mut fresh = Vec::new();
        ply::write_ascii(&mesh, &mut fresh, comment).unwrap();
        let on_disk = std::fs::read(dir.join(name)).expect("scenes/meshes/ (run `cargo run --example gen_meshes`)");
        assert!(on_disk == fresh, "scenes/meshes/{name} is stale: run `cargo run --example gen_meshes`");
    }
    let l = load(&dir.join("blob.ply")).unwrap();
    let m = &l.meshes[0];
    assert_eq!((l.triangle_count(), m.positions.len()), (5120, 2562));
    assert!(l.warnings.is_empty(), "{:?}", l.warnings);
    assert!(m.normals.as_ref().unwrap().iter().all(|n| (n.length() - 1.0).abs() < 1e-5));
    // The coarse blob has no normals of its own: flat unless smooth normals are asked for.
    let l = load(&dir.join("blob-coarse.ply")).unwrap();
    assert_eq!((l.triangle_count(), l.meshes[0].positions.len(), l.meshes[0].normals.is_none()), (320, 162, true));
    let s = load_mesh(&dir.join("blob-coarse.ply"), &MeshOptions { smooth_normals: true }).unwrap();
    assert!(s.meshes[0].normals.as_ref().unwrap().iter().all(|n| (n.length() - 1.0).abs() < 1e-5));
}
