//! Hostile input files, run through the `strahl` binary: special files, decompression bombs and
//! headers whose counts no file can back are refused quickly, in little memory, with one line
//! naming the file. Peak memory is measured on the child process (`/usr/bin/time`'s maximum
//! resident set size, which is `getrusage` of the child) with a generous bound, and a child still
//! running after 20 s is killed and fails its test: they guard against a memory bomb and a hang,
//! not a slowdown (no wall-clock bound: a loaded machine would fail it). That a bomb is refused
//! early, before it has inflated, shows in the limit its error names.

mod common;

use std::io::Write;
use std::path::Path;
use std::process::Command;

use common::TempDir;

/// Runs `strahl args`, measuring its peak memory and killing it after 20 s so that a hang
/// fails the test instead of stalling the suite.
fn run(_dir: &TempDir, args: &[&str]) -> common::Measured {
    common::run_measured(args, &[], 20)
}

/// Runs `strahl info FILE` and checks it fails (before the 20 s kill) in under 200 MiB with one
/// line `error: FILE…`; returns that line.
fn refused_quickly(dir: &TempDir, file: &Path) -> String {
    let r = run(dir, &["info", file.to_str().unwrap()]);
    assert_eq!(r.status, Some(1), "{file:?}: {}", r.stderr);
    assert_eq!(r.stderr.lines().count(), 1, "{:?}", r.stderr);
    assert!(r.stderr.starts_with(&format!("error: {}", file.display())), "{}", r.stderr);
    if let Some(mib) = r.peak_mib() {
        assert!(mib < 200.0, "{file:?} took {mib:.0} MiB");
    }
    r.stderr
}

fn mkfifo(path: &Path) {
    let ok = Command::new("mkfifo").arg(path).status().expect("mkfifo runs").success();
    assert!(ok, "mkfifo {path:?}");
}

const SCENE_HEAD: &str = "[camera]\neye = [0, 0, 5]\ntarget = [0, 0, 0]\nfov_deg = 40\n";

#[test]
fn fifos_are_refused_without_being_opened() {
    let dir = TempDir::new("fifo");
    for name in ["scene.toml", "mesh.obj", "mesh.ply"] {
        let fifo = dir.path(name);
        mkfifo(&fifo);
        let e = refused_quickly(&dir, &fifo);
        assert!(e.ends_with("not a regular file (a FIFO): only regular files are read"), "{e}");
    }
    // A scene naming a FIFO as its mesh: the error points at the `path` value.
    let scene = dir.write("s.toml", format!("{SCENE_HEAD}[[objects]]\ntype = \"mesh\"\npath = \"mesh.obj\"\n"));
    let e = refused_quickly(&dir, &scene);
    assert!(e.contains("s.toml:7:8: object 0 (mesh): "), "{e}");
    assert!(e.ends_with("mesh.obj: not a regular file (a FIFO): only regular files are read"), "{e}");
    // An MTL library that is a FIFO.
    mkfifo(&dir.path("lib.mtl"));
    let obj = dir.write("m.obj", "mtllib lib.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    let e = refused_quickly(&dir, &obj);
    assert!(e.ends_with("lib.mtl: not a regular file (a FIFO): only regular files are read"), "{e}");
}

#[test]
fn devices_and_directories_are_refused() {
    let dir = TempDir::new("devices");
    let e = refused_quickly(&dir, Path::new("/dev/zero"));
    assert_eq!(
        e,
        "error: /dev/zero: cannot read the scene: not a regular file (a character device): only regular files are read"
    );
    // Symlinks are followed to what they name.
    for (name, target) in [("zero.ply", "/dev/zero"), ("random.obj", "/dev/urandom"), ("random.ply.gz", "/dev/urandom")]
    {
        let link = dir.path(name);
        std::os::unix::fs::symlink(target, &link).unwrap();
        let e = refused_quickly(&dir, &link);
        assert!(e.ends_with("not a regular file (a character device): only regular files are read"), "{e}");
    }
    std::fs::create_dir(dir.path("folder.obj")).unwrap();
    let e = refused_quickly(&dir, &dir.path("folder.obj"));
    assert!(e.ends_with("not a regular file (a directory): only regular files are read"), "{e}");
}

/// A gzip member holding `n` zero bytes.
fn gzip_zeros(n: usize) -> Vec<u8> {
    let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::best());
    e.write_all(&vec![0u8; n]).unwrap();
    e.finish().unwrap()
}

#[test]
fn a_gzip_bomb_is_refused_early() {
    let dir = TempDir::new("gzbomb");
    // 4096 members of 1 MiB of zeros: about 4 MB that inflate to 4 GiB.
    let member = gzip_zeros(1 << 20);
    let bomb: Vec<u8> = member.iter().copied().cycle().take(member.len() * 4096).collect();
    assert!(bomb.len() < 8 << 20, "{}", bomb.len());
    let path = dir.write("bomb.ply.gz", &bomb);
    let e = refused_quickly(&dir, &path);
    let limit = 16 * bomb.len();
    assert!(e.contains(&format!("gzip data inflates to more than {limit} bytes")), "{e}");
    assert!(e.contains("STRAHL_MAX_MESH_BYTES"), "{e}");

    // One member whose trailer is honest, over a lowered limit: refused, and the message says
    // how to raise it; raised, the same limit check passes and the PLY parser takes over.
    let z = gzip_zeros(1 << 20);
    let path = dir.write("zeros.ply.gz", &z);
    let out = Command::new(env!("CARGO_BIN_EXE_strahl"))
        .args(["info", path.to_str().unwrap()])
        .env("STRAHL_MAX_MESH_BYTES", "100000")
        .output()
        .unwrap();
    let e = String::from_utf8_lossy(&out.stderr);
    assert!(e.contains("gzip data inflates to more than 100000 bytes"), "{e}");
    let out = Command::new(env!("CARGO_BIN_EXE_strahl")).args(["info", path.to_str().unwrap()]).output().unwrap();
    let e = String::from_utf8_lossy(&out.stderr);
    assert!(e.trim_end().ends_with("zeros.ply.gz: not a PLY file"), "{e}");
    let out = Command::new(env!("CARGO_BIN_EXE_strahl"))
        .args(["info", path.to_str().unwrap()])
        .env("STRAHL_MAX_MESH_BYTES", "lots")
        .output()
        .unwrap();
    let e = String::from_utf8_lossy(&out.stderr);
    assert!(e.contains("STRAHL_MAX_MESH_BYTES=\"lots\" is not a number of bytes"), "{e}");
}

#[test]
fn ply_counts_no_file_can_back_are_refused_at_once() {
    let dir = TempDir::new("plycounts");
    let vertices = "element vertex 3\nproperty float x\nproperty float y\nproperty float z\n";
    let mut body = Vec::new();
    for p in [[0f32, 0., 0.], [1., 0., 0.], [0., 1., 0.]] {
        p.iter().for_each(|c| body.extend(c.to_le_bytes()));
    }
    body.extend([3u8, 0, 0, 0, 0, 1, 0, 0, 0, 2, 0, 0, 0]);
    let faces = "element face 1\nproperty list uchar uint vertex_indices\n";
    let file = |middle: &str| {
        let mut d = format!("ply\nformat binary_little_endian 1.0\n{vertices}{faces}{middle}end_header\n").into_bytes();
        d.extend(&body);
        d
    };
    // The 2^63 − 1 items of nothing that used to spin forever.
    let path = dir.write("empty-items.ply", file("element junk 9223372036854775807\n"));
    let e = refused_quickly(&dir, &path);
    assert!(e.ends_with(":9: element 'junk' has 9223372036854775807 items but no properties (nothing to read)"), "{e}");
    // Items of one byte each, more than the file holds.
    let path = dir.write("big-count.ply", file("element junk 4611686018427387904\nproperty uchar a\n"));
    let e = refused_quickly(&dir, &path);
    assert!(
        e.ends_with(
            ":9: element 'junk' declares 4611686018427387904 items of at least 1 bytes each, but only 0 bytes remain \
             (truncated or corrupt binary PLY)"
        ),
        "{e}"
    );
    // The same in ASCII: each item needs a line.
    let ascii = format!(
        "ply\nformat ascii 1.0\n{vertices}element face 4611686018427387904\nproperty list uchar uint vertex_indices\n\
         end_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"
    );
    let path = dir.write("ascii-count.ply", ascii);
    let e = refused_quickly(&dir, &path);
    assert!(e.contains(":7: element 'face' declares 4611686018427387904 items, but only 9 bytes remain"), "{e}");
    // The untouched file loads.
    let path = dir.write("fine.ply", file(""));
    let r = run(&dir, &["info", path.to_str().unwrap()]);
    assert_eq!(r.status, Some(0), "{}", r.stderr);
}

#[test]
fn sample_counts_and_depths_beyond_the_limits_are_refused_at_their_place() {
    let dir = TempDir::new("limits");
    let scene = |image: &str| {
        format!("[camera]\neye = [0, 0, 5]\ntarget = [0, 0, 0]\nup = [0, 1, 0]\nfov_deg = 40\n\n[image]\n{image}\n")
    };
    let spp = dir.write("spp.toml", scene("spp = 4294967295"));
    let e = refused_quickly(&dir, &spp);
    assert_eq!(
        e,
        format!(
            "error: {}:8:7: image: spp 4294967295 is more than the 65536 samples per pixel strahl takes",
            spp.display()
        )
    );
    let depth = dir.write("depth.toml", scene("max_depth = 1000"));
    let e = refused_quickly(&dir, &depth);
    assert_eq!(
        e,
        format!("error: {}:8:13: image: max_depth 1000 is more than the 256 bounces strahl follows", depth.display())
    );
    // The command line's override is checked too, before anything is rendered.
    let ok = dir.write("ok.toml", scene("spp = 1"));
    let out = dir.path("out.exr");
    let r = run(&dir, &["render", ok.to_str().unwrap(), "--spp", "4294967295", "-o", out.to_str().unwrap()]);
    assert_eq!(r.status, Some(1), "{}", r.stderr);
    assert!(r.stderr.contains("spp 4294967295 is more than the 65536"), "{}", r.stderr);
    assert!(!out.exists());
}

#[test]
fn an_output_that_is_an_input_is_refused_and_the_input_kept() {
    let dir = TempDir::new("clobber");
    let mesh = dir.write("m.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    let text = concat!(
        "[camera]\neye = [0, 0, 5]\ntarget = [0, 0, 0]\nup = [0, 1, 0]\nfov_deg = 40\n\n[image]\nwidth = 4\nheight = 3\n\n",
        "[[objects]]\ntype = \"mesh\"\npath = \"m.obj\"\n"
    );
    let png_named = dir.write("scene.png", text);
    let exr_named = dir.write("scene.exr", text);
    let toml = dir.write("scene.toml", text);
    std::fs::hard_link(&toml, dir.path("hard.exr")).unwrap();
    std::os::unix::fs::symlink(&toml, dir.path("soft.png")).unwrap();
    std::fs::hard_link(&mesh, dir.path("mesh.exr")).unwrap();
    let s = |p: &Path| p.to_str().unwrap().to_owned();
    let cases: Vec<(Vec<String>, &Path)> = vec![
        (vec![s(&png_named), "-o".into(), s(&dir.path("out.exr")), "--png".into(), s(&png_named)], &png_named),
        (vec![s(&exr_named), "-o".into(), s(&exr_named)], &exr_named),
        (vec![s(&toml), "-o".into(), s(&dir.path("hard.exr"))], &toml),
        (vec![s(&toml), "-o".into(), s(&dir.path("out.exr")), "--png".into(), s(&dir.path("soft.png"))], &toml),
        (vec![s(&toml), "-o".into(), s(&dir.path("mesh.exr"))], &mesh),
    ];
    for (args, input) in cases {
        let mut all = vec!["render"];
        all.extend(args.iter().map(String::as_str));
        let e = common::fails(&dir, &all);
        assert!(e.contains(&format!("is an input ({})", input.display())), "{all:?}: {e}");
    }
    for f in [&png_named, &exr_named, &toml] {
        assert_eq!(std::fs::read_to_string(f).unwrap(), text, "{f:?} changed");
    }
    assert_eq!(std::fs::read_to_string(&mesh).unwrap(), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");

    // The files a mesh names are inputs too: its MTL library and the library's texture.
    let textured = dir.write("t.obj", "mtllib t.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nusemtl a\nf 1/1 2/1 3/1\n");
    let mtl = dir.write("t.mtl", "newmtl a\nKd 1 1 1\nmap_Kd tex.png\n");
    image::RgbImage::from_pixel(2, 2, image::Rgb([200, 100, 50])).save(dir.path("tex.png")).unwrap();
    let texture = std::fs::read(dir.path("tex.png")).unwrap();
    let scene = dir.write("textured.toml", text.replace("m.obj", "t.obj"));
    std::fs::hard_link(&mtl, dir.path("mtl.exr")).unwrap();
    for (args, input) in [
        (vec![s(&scene), "-o".into(), s(&dir.path("mtl.exr"))], mtl.clone()),
        (
            vec![s(&scene), "-o".into(), s(&dir.path("out.exr")), "--png".into(), s(&dir.path("tex.png"))],
            dir.path("tex.png"),
        ),
    ] {
        let mut all = vec!["render"];
        all.extend(args.iter().map(String::as_str));
        let e = common::fails(&dir, &all);
        assert!(e.contains(&format!("is an input ({})", input.display())), "{all:?}: {e}");
    }
    assert_eq!(std::fs::read(dir.path("tex.png")).unwrap(), texture);
    assert_eq!(std::fs::read_to_string(&mtl).unwrap(), "newmtl a\nKd 1 1 1\nmap_Kd tex.png\n");
    assert!(!dir.path("out.exr").exists());
    let _ = textured;
}

#[test]
fn fixed_length_arrays_refuse_extra_and_missing_elements_at_their_place() {
    let dir = TempDir::new("arrays");
    let camera = |eye: &str| format!("[camera]\neye = {eye}\ntarget = [0, 0, 0]\nup = [0, 1, 0]\nfov_deg = 40\n");
    let cases = [
        (camera("[0, 1, 5, 6]"), "2:7: more than the 3 elements expected"),
        (camera("[0, 1]"), "2:7: 2 elements where 3 are expected"),
        (
            camera("[0, 1, 5]") + "\n[[lights]]\ntype = \"point\"\nposition = [4, 8, 6, \"x\"]\nintensity = 100\n",
            "9:12: more than the 3 elements expected",
        ),
        (
            camera("[0, 1, 5]")
                + "\n[[objects]]\ntype = \"triangles\"\npositions = [[0, 0, 0], [1, 0, 0], [0, 1, 0]]\nindices = [[0, 1, 2, 7]]\n",
            "10:12: more than the 3 elements expected",
        ),
    ];
    for (i, (text, expected)) in cases.iter().enumerate() {
        let file = dir.write(&format!("s{i}.toml"), text);
        let e = refused_quickly(&dir, &file);
        assert_eq!(e, format!("error: {}:{expected}", file.display()));
    }
}

#[test]
fn repeated_libraries_and_many_unknown_statements_load_with_bounded_warnings() {
    let dir = TempDir::new("statements");
    let triangle = "v 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl red\nf 1 2 3\n";
    // A library named 5,000 times, and the OBJ naming itself as its library 5,000 times: each
    // file is parsed once (this took minutes and gigabytes before), and later definitions win.
    dir.write("red.mtl", "newmtl red\nKd 1 0 0\n");
    dir.write("blue.mtl", "newmtl red\nKd 0 0 1\n");
    let many = dir.write("many.obj", "mtllib blue.mtl\n".to_owned() + &"mtllib red.mtl\n".repeat(5000) + triangle);
    let r = run(&dir, &["info", many.to_str().unwrap()]);
    assert_eq!(r.status, Some(0), "{}", r.stderr);
    let me = dir.write("me.obj", "mtllib me.obj\n".repeat(5000) + "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    let r = run(&dir, &["info", me.to_str().unwrap()]);
    assert_eq!(r.status, Some(0), "{}", r.stderr);
    let warnings: Vec<&str> = r.stderr.lines().filter(|l| l.starts_with("warning:")).collect();
    assert_eq!(warnings.len(), 1, "{warnings:?}");
    assert!(
        warnings[0]
            .ends_with("ignored (not supported): mtllib before any newmtl, v before any newmtl, f before any newmtl"),
        "{}",
        warnings[0]
    );
    // 20,000 distinct unknown statements: 16 listed, the rest summed in one line.
    let unknown: String = (0..20_000).map(|i| format!("zz{i} 1 2\n")).collect();
    let obj = dir.write("unknown.obj", unknown.clone() + "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    let r = run(&dir, &["info", obj.to_str().unwrap()]);
    assert_eq!(r.status, Some(0), "{}", r.stderr);
    let warnings: Vec<&str> = r.stderr.lines().filter(|l| l.starts_with("warning:")).collect();
    assert_eq!(warnings.len(), 17, "{warnings:?}");
    assert_eq!(warnings[0], format!("warning: {}:1: skipped 1 unknown statements 'zz0'", obj.display()));
    assert_eq!(
        warnings[16],
        format!("warning: {}:17: skipped 19984 more statements of 19984 other unknown keywords", obj.display())
    );
    dir.write("unknown.mtl", "newmtl red\n".to_owned() + &unknown);
    let obj = dir.write("uses.obj", "mtllib unknown.mtl\n".to_owned() + triangle);
    let r = run(&dir, &["info", obj.to_str().unwrap()]);
    assert_eq!(r.status, Some(0), "{}", r.stderr);
    assert!(r.stderr.contains("zz14, zz15, and 19984 more"), "{}", r.stderr);
}

#[test]
fn the_spheres_of_all_random_spheres_objects_together_are_bounded() {
    let dir = TempDir::new("spheres");
    // Each object within its own limit, the scene over it: refused at the count that passes it,
    // before any of its spheres is made (25 objects of 10,000,000 took 5 GB).
    let object = |count: u64| {
        format!(
            "\n[[objects]]\ntype = \"random_spheres\"\ncount = {count}\nbounds = [[-1, -1, -1], [1, 1, 1]]\n\
             radii = [0.1, 0.2]\nmaterial = \"m\"\n"
        )
    };
    let head = "[camera]\neye = [0, 0, 5]\ntarget = [0, 0, 0]\nup = [0, 1, 0]\nfov_deg = 40\n\n\
                [materials.m]\ndiffuse = [0.5, 0.5, 0.5]\n\n[[objects]]\ntype = \"sphere\"\n\
                center = [0, 0, 0]\nradius = 1\nmaterial = \"m\"\n";
    let scene = dir.write("many.toml", head.to_owned() + &object(4) + &object(9_999_996));
    let e = refused_quickly(&dir, &scene);
    assert_eq!(
        e,
        format!(
            "error: {}:25:9: object 2 (random_spheres): count 9999996 would make 10000001 spheres in the scene \
             (5 before this object), more than the 10000000 a scene may have",
            scene.display()
        )
    );
    // Counts that fit load.
    let fits = dir.write("fits.toml", head.to_owned() + &object(4) + &object(5));
    let r = run(&dir, &["info", fits.to_str().unwrap()]);
    assert_eq!(r.status, Some(0), "{}", r.stderr);
}

#[test]
fn a_scene_over_the_size_limit_is_refused_before_it_is_parsed() {
    let dir = TempDir::new("big_scene");
    // 32 MiB + 1 byte of comment: refused before the TOML parse, whose memory grows about 40×
    // the inline geometry (a 200 MB `triangles` object took 6.3 GB).
    let limit = 32usize << 20;
    let mut text = "# padding\n".repeat(limit / 10 + 1).into_bytes();
    text.truncate(limit + 1);
    let scene = dir.write("big.toml", &text);
    let e = refused_quickly(&dir, &scene);
    assert_eq!(
        e,
        format!(
            "error: {}: cannot read the scene: 33554433 bytes is more than the limit of 33554432 bytes; put large \
             geometry in a file of its own (an OBJ or PLY `mesh` object, a `gltf` object)",
            scene.display()
        )
    );
}

#[test]
fn non_planar_and_self_crossing_polygons_load_with_one_warning() {
    use strahl::scene::load::{MeshOptions, load_mesh};
    let dir = TempDir::new("polygons");
    // A unit cube of six planar quads (12 triangles), then at line 23 a non-planar quad whose
    // projection onto the zx plane folds over itself (its Newell normal is (-4, -9, -6)), at
    // line 24 a bow tie, at line 25 the non-planar quad again.
    let cube = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n\
                f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n";
    let extra = "v -1 2 1\nv 2 -1 -2\nv 2 0 2\nv -1 -1 0\nv 5 0 0\nv 6 1 0\nv 6 0 0\nv 5 1 0\n\
                 f 9 10 11 12\nf 13 14 15 16\nf 9 10 11 12\n";
    let obj = dir.write("scan.obj", cube.to_owned() + extra);
    let l = load_mesh(&obj, &MeshOptions::default()).unwrap();
    assert_eq!(l.triangles_read, 18);
    assert_eq!(l.triangle_count(), 18);
    assert_eq!(l.degenerate_dropped, 0);
    assert_eq!(
        l.warnings,
        vec![format!(
            "{}:23: 3 faces are not simple polygons: 2 non-planar (triangulated in their best-fit plane), \
             1 crossing or overlapping themselves (split as fans)",
            obj.display()
        )]
    );
    // The same through the command line: one warning line, and it loads.
    let r = run(&dir, &["info", obj.to_str().unwrap()]);
    assert_eq!(r.status, Some(0), "{}", r.stderr);
    assert_eq!(r.stderr.lines().filter(|l| l.starts_with("warning:")).count(), 1, "{}", r.stderr);
    // The bow tie alone, as ASCII PLY: two fan triangles, the warning at the face's line.
    let ply = dir.write(
        "bow.ply",
        "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n\
         element face 1\nproperty list uchar int vertex_indices\nend_header\n\
         0 0 0\n1 1 0\n1 0 0\n0 1 0\n4 0 1 2 3\n",
    );
    let l = load_mesh(&ply, &MeshOptions::default()).unwrap();
    assert_eq!((l.triangles_read, l.triangle_count()), (2, 2));
    assert_eq!(
        l.warnings,
        vec![format!(
            "{}:14: 1 face is not a simple polygon: 1 crossing or overlapping themselves (split as fans)",
            ply.display()
        )]
    );
}

#[test]
fn a_million_corner_polygon_loads_as_a_fan() {
    use strahl::scene::load::{MeshOptions, load_mesh};
    let dir = TempDir::new("star");
    // A star of 1,000,000 corners (alternating radii 1 and 0.5): beyond the ear-clipping bound,
    // so a fan of n − 2 triangles (ear clipping it did not finish in 60 s).
    let n = 1_000_000;
    let mut text = String::with_capacity(40 * n);
    for i in 0..n {
        let phi = std::f64::consts::TAU * i as f64 / n as f64;
        let r = if i % 2 == 0 { 1.0 } else { 0.5 };
        text += &format!("v {} {} 0\n", r * phi.cos(), r * phi.sin());
    }
    text += "f";
    for i in 1..=n {
        text += &format!(" {i}");
    }
    text += "\n";
    let obj = dir.write("star.obj", text);
    let l = load_mesh(&obj, &MeshOptions::default()).unwrap();
    assert_eq!(l.triangles_read, n - 2);
    assert_eq!(l.triangle_count() + l.degenerate_dropped, n - 2);
    assert_eq!(
        l.warnings[0],
        format!(
            "{}:{}: 1 face is not a simple polygon: 1 with more than 10000 corners (split as fans)",
            obj.display(),
            n + 1
        )
    );
}

#[test]
fn a_texture_that_is_a_fifo_or_a_device_is_refused_at_its_map_kd_line() {
    let dir = TempDir::new("texture-special");
    mkfifo(&dir.path("fifo.png"));
    dir.write("t.obj", "mtllib t.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nusemtl a\nf 1/1 2/1 3/1\n");
    for (texture, kind) in [("fifo.png", "a FIFO"), ("/dev/zero", "a character device")] {
        dir.write("t.mtl", format!("newmtl a\nKd 1 1 1\nmap_Kd {texture}\n"));
        let scene = dir.write(
            "s.toml",
            "[camera]\neye = [0, 0, 5]\ntarget = [0, 0, 0]\nfov_deg = 40\n[[objects]]\ntype = \"mesh\"\npath = \"t.obj\"\n",
        );
        let e = refused_quickly(&dir, &scene);
        assert!(e.contains("t.mtl:3: map_Kd: ") && e.contains(&format!("not a regular file ({kind})")), "{e}");
    }
}

/// The memory budget: `strahl info` prints the estimate, a render over `--max-memory` is
/// refused before anything is built or written, and the estimate covers what a render really
/// takes (peak RSS read by /usr/bin/time, when there is one) without overstating it wildly.
#[test]
fn the_memory_estimate_bounds_the_render_and_max_memory_refuses_beyond_it() {
    let dir = TempDir::new("budget");
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/lecture.toml");
    let estimate_mb = |width: u32, height: u32| -> f64 {
        let text = scene_text_sized(width, height);
        let file = dir.write(&format!("lecture-{width}.toml"), text);
        let out = common::strahl(&["info", file.to_str().unwrap()]);
        let stdout = common::text(&out.stdout);
        let line = stdout.lines().find(|l| l.starts_with("memory estimate: ")).unwrap_or_else(|| panic!("{stdout}"));
        line["memory estimate: ".len()..].split(' ').next().unwrap().parse().unwrap()
    };
    let big = estimate_mb(4000, 3000);
    // 12 M pixels × 44 bytes of film (528 MB), a quarter of it and 17 MB for the output, 42 MB
    // of base.
    assert!((715.0..725.0).contains(&big), "{big} MB");
    let out = dir.path("big.exr");
    let r = run(
        &dir,
        &["render", scene, "--width", "4000", "--height", "3000", "--max-memory", "600M", "-o", out.to_str().unwrap()],
    );
    assert_eq!(r.status, Some(1), "{}", r.stderr);
    assert!(
        r.stderr.contains("this render needs about ") && r.stderr.contains("more than --max-memory 630 MB"),
        "{}",
        r.stderr
    );
    assert!(!out.exists());
    assert_eq!(dir.entries().iter().filter(|e| e.ends_with(".tmp")).count(), 0);

    // A real render stays under its estimate.
    let small = dir.path("small.exr");
    let r = run(&dir, &["render", scene, "--width", "1600", "--height", "1200", "-o", small.to_str().unwrap()]);
    assert_eq!(r.status, Some(0), "{}", r.stderr);
    if let Some(mib) = r.peak_mib() {
        let estimate = estimate_mb(1600, 1200);
        let measured = mib * 1.048576;
        assert!(
            measured <= estimate && estimate <= 3.0 * measured,
            "measured {measured:.0} MB, estimate {estimate} MB"
        );
    }
}

/// scenes/lecture.toml at another size.
fn scene_text_sized(width: u32, height: u32) -> String {
    let text = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/lecture.toml")).unwrap();
    let (before, after) = text.split_once("[image]\n").unwrap();
    format!(
        "{before}[image]\nwidth = {width}\nheight = {height}\n{}",
        after
            .lines()
            .filter(|l| !l.starts_with("width") && !l.starts_with("height"))
            .map(|l| format!("{l}\n"))
            .collect::<String>()
    )
}
