//! Hostile inputs to the readers, run through the `strahl` binary: texture and gzip bombs,
//! glTF files that multiply their nodes, lie about their length or reach outside their folder,
//! and `--confine DIR`. Each is refused in one line naming the file, with nothing written. Time
//! and peak memory are measured on the child (`/usr/bin/time`'s maximum resident set size),
//! with generous bounds: they guard against a memory bomb, not a slowdown.

mod common;

use std::io::Write;
use std::path::Path;

use common::TempDir;

/// What a refused run of `strahl` did.
struct Refusal {
    /// The one line of stderr.
    line: String,
    seconds: f64,
    /// Peak resident memory of the child, MiB (`None` without `/usr/bin/time`).
    max_rss_mib: Option<f64>,
}

/// Runs `strahl args` (with `env` set), measuring its time and peak memory, and checks it fails
/// with exit status 1, one line `error: …` on stderr and nothing new in `dir`.
fn refused(dir: &TempDir, args: &[&str], env: &[(&str, &str)]) -> Refusal {
    let before = dir.entries();
    let m = common::run_measured(args, env, 60);
    assert_eq!(m.status, Some(1), "{args:?}: {}", m.stderr);
    assert_eq!(m.stderr.lines().count(), 1, "{:?}", m.stderr);
    assert!(m.stderr.starts_with("error: "), "{}", m.stderr);
    assert_eq!(dir.entries(), before, "nothing written for {args:?}");
    let max_rss_mib = m.peak_mib();
    Refusal { line: m.stderr, seconds: m.seconds, max_rss_mib }
}

/// [`refused`], within 1 s and 200 MiB.
fn refused_cheaply(dir: &TempDir, args: &[&str], env: &[(&str, &str)]) -> String {
    let r = refused(dir, args, env);
    assert!(r.seconds < 1.0, "{args:?} took {:.2} s", r.seconds);
    if let Some(mib) = r.max_rss_mib {
        assert!(mib < 200.0, "{args:?} took {mib:.0} MiB");
    }
    r.line
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

// ---------------------------------------------------------------------------------------------
// Texture bombs.

/// A PNG chunk: length, type, data, CRC-32 of type and data.
fn chunk(out: &mut Vec<u8>, kind: &[u8; 4], data: &[u8]) {
    out.extend((data.len() as u32).to_be_bytes());
    let mut crc = flate2::Crc::new();
    crc.update(kind);
    crc.update(data);
    out.extend(kind);
    out.extend(data);
    out.extend(crc.sum().to_be_bytes());
}

/// A black 1-bit greyscale PNG of `side`² pixels, its rows deflated as tightly as deflate goes
/// (23000²: 64 KB of file, 529 MB of 8-bit pixels, 6.3 GB of strahl's texels).
fn one_bit_png(side: u32) -> Vec<u8> {
    let row = 1 + side.div_ceil(8) as usize;
    let mut z = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::best());
    let zeros = vec![0u8; row * 64];
    for _ in 0..side / 64 {
        z.write_all(&zeros).unwrap();
    }
    z.write_all(&zeros[..row * (side % 64) as usize]).unwrap();
    let mut png = b"\x89PNG\r\n\x1a\n".to_vec();
    let mut ihdr = Vec::new();
    ihdr.extend(side.to_be_bytes());
    ihdr.extend(side.to_be_bytes());
    ihdr.extend([1, 0, 0, 0, 0]); // bit depth 1, greyscale, deflate, no filter, no interlace
    chunk(&mut png, b"IHDR", &ihdr);
    chunk(&mut png, b"IDAT", &z.finish().unwrap());
    chunk(&mut png, b"IEND", &[]);
    png
}

/// A real 16 × 16 JPEG whose SOF0 is made to declare `side`² pixels (a few hundred bytes).
fn forged_jpeg(side: u16) -> Vec<u8> {
    let img = image::RgbImage::from_fn(16, 16, |x, y| image::Rgb([x as u8 * 16, y as u8 * 16, 99]));
    let mut jpeg = Vec::new();
    img.write_to(&mut std::io::Cursor::new(&mut jpeg), image::ImageFormat::Jpeg).unwrap();
    let sof = jpeg.windows(2).position(|w| w == [0xFF, 0xC0]).expect("a baseline JPEG");
    // FF C0, length (2), precision (1), height (2), width (2).
    jpeg[sof + 5..sof + 7].copy_from_slice(&side.to_be_bytes());
    jpeg[sof + 7..sof + 9].copy_from_slice(&side.to_be_bytes());
    jpeg
}

const CAMERA: &str = "[camera]\neye = [0, 0, 4]\ntarget = [0, 0, 0]\nfov_deg = 40\n[image]\nwidth = 16\nheight = 16\n";

/// A scene of one textured triangle, its OBJ and MTL naming `texture` (relative to `dir`).
fn textured_scene(dir: &TempDir, texture: &str) -> std::path::PathBuf {
    dir.write("t.mtl", format!("newmtl tex\nmap_Kd {texture}\n"));
    dir.write("t.obj", "mtllib t.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nusemtl tex\nf 1/1 2/1 3/1\n");
    dir.write("s.toml", format!("{CAMERA}[[objects]]\ntype = \"mesh\"\npath = \"t.obj\"\n"))
}

/// A glTF file of one triangle (its buffer a `data:` URI) whose material's base colour is the
/// image at `image_uri`.
fn textured_gltf(image_uri: &str) -> String {
    let positions: Vec<u8> = [0f32, 0., 0., 1., 0., 0., 0., 1., 0.].iter().flat_map(|f| f.to_le_bytes()).collect();
    #[allow(deprecated)]
    let data = base64_encode(&positions);
    format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0]}}],"nodes":[{{"mesh":0}}],
        "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}},"material":0}}]}}],
        "materials":[{{"pbrMetallicRoughness":{{"baseColorTexture":{{"index":0}}}}}}],
        "textures":[{{"source":0}}],"images":[{{"uri":"{image_uri}"}}],
        "accessors":[{{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}}],
        "bufferViews":[{{"buffer":0,"byteLength":36}}],
        "buffers":[{{"byteLength":36,"uri":"data:application/octet-stream;base64,{data}"}}]}}"#
    )
}

/// Standard base64 (the tests need only encoding, of a few bytes).
fn base64_encode(bytes: &[u8]) -> String {
    const ABC: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::new();
    for c in bytes.chunks(3) {
        let n = (c[0] as u32) << 16 | (*c.get(1).unwrap_or(&0) as u32) << 8 | *c.get(2).unwrap_or(&0) as u32;
        for k in 0..4 {
            out.push(if k <= c.len() { ABC[(n >> (18 - 6 * k) & 63) as usize] as char } else { '=' });
        }
    }
    out
}

#[test]
fn texture_bombs_are_refused_from_their_header() {
    let dir = TempDir::new("texture-bombs");
    let png = one_bit_png(23000);
    assert!(png.len() < 70_000, "{}", png.len());
    dir.write("bomb.png", &png);
    dir.write("bomb.jpg", forged_jpeg(13000));
    let out = dir.path("out.exr");
    let scene = textured_scene(&dir, "bomb.png");
    // The PNG is a real image, backed by its bytes: what refuses it is the budget (a 2 GB job),
    // before a texel is allocated.
    let e = refused_cheaply(&dir, &["render", s(&scene), "--max-memory", "2G", "-o", s(&out)], &[]);
    assert!(e.contains("t.mtl:2: map_Kd: ") && e.contains("bomb.png: decoding 23000 × 23000 texels would take"), "{e}");
    assert!(e.ends_with("bytes left of the memory budget (--max-memory)"), "{e}");
    // The same image named by a glTF file.
    let gltf = dir.write("bomb.gltf", textured_gltf("bomb.png"));
    let e = refused_cheaply(&dir, &["render", s(&gltf), "--max-memory", "2G", "-o", s(&out)], &[]);
    assert!(e.contains("bomb.gltf: material 0: texture 0: image 0: ") && e.contains("decoding 23000 × 23000"), "{e}");
    // The JPEG's SOF declares more than its 600-odd bytes can hold: refused whatever the budget.
    let scene = textured_scene(&dir, "bomb.jpg");
    let e = refused_cheaply(&dir, &["info", s(&scene)], &[]);
    assert!(
        e.contains("bomb.jpg: declares 13000 × 13000 pixels, which need at least 20707 bytes of image data"),
        "{e}"
    );
    let gltf = dir.write("bomb.gltf", textured_gltf("bomb.jpg"));
    let e = refused_cheaply(&dir, &["render", s(&gltf), "-o", s(&out)], &[]);
    assert!(e.contains("(truncated or forged)"), "{e}");
}

#[test]
fn a_texture_within_the_budget_loads_and_one_over_it_is_named() {
    let dir = TempDir::new("texture-budget");
    // 2048² texels of 12 bytes: 50 MB. The budget less the process's 40 MiB base must hold them.
    let img = image::GrayImage::from_pixel(2048, 2048, image::Luma([200]));
    img.save(dir.path("grey.png")).unwrap();
    let scene = textured_scene(&dir, "grey.png");
    let out = dir.path("out.exr");
    let e = refused(&dir, &["render", s(&scene), "--max-memory", "80M", "-o", s(&out)], &[]).line;
    assert!(e.contains("grey.png: decoding 2048 × 2048 texels would take 50331648 bytes"), "{e}");
    let ok = common::strahl(&["render", s(&scene), "--max-memory", "200M", "-o", s(&out)]);
    assert!(ok.status.success(), "{}", common::text(&ok.stderr));
}

// ---------------------------------------------------------------------------------------------
// gzip whose trailer lies.

#[test]
fn a_forged_gzip_trailer_is_refused_after_the_mesh_limit_in_little_memory() {
    let dir = TempDir::new("gzip-forged");
    // 512 MiB of zeros in one member whose ISIZE is forged to 0xFFFFFFFF: the ratio allowance
    // gives way to the trailer, so only the mesh limit (lowered to 256 MiB to keep the test
    // short; the default 4 GiB measures the same way, in more time) stops it.
    let mut z = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::best());
    let zeros = vec![0u8; 1 << 20];
    for _ in 0..512 {
        z.write_all(&zeros).unwrap();
    }
    let mut bomb = z.finish().unwrap();
    let n = bomb.len();
    bomb[n - 4..].copy_from_slice(&u32::MAX.to_le_bytes());
    let path = dir.write("bomb.ply.gz", &bomb);
    let limit = (256u64 << 20).to_string();
    let e = refused_cheaply(&dir, &["info", s(&path)], &[("STRAHL_MAX_MESH_BYTES", &limit)]);
    assert!(
        e.contains(&format!("gzip data inflates to more than {limit} bytes ({n} compressed, 4294967295 declared")),
        "{e}"
    );
}

// ---------------------------------------------------------------------------------------------
// glTF.

/// A glTF file of a triangle mesh whose buffer is the file `tri.bin` (or `buffer_uri`), with the
/// given nodes and root list.
fn gltf_with(nodes: &str, roots: &str, buffer_uri: &str) -> String {
    format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":{roots}}}],"nodes":{nodes},
        "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}}}}]}}],
        "accessors":[{{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}}],
        "bufferViews":[{{"buffer":0,"byteLength":36}}],"buffers":[{{"byteLength":36,"uri":"{buffer_uri}"}}]}}"#
    )
}

fn triangle_bin() -> Vec<u8> {
    [0f32, 0., 0., 1., 0., 0., 0., 1., 0.].iter().flat_map(|f| f.to_le_bytes()).collect()
}

#[test]
fn gltf_nodes_form_a_forest() {
    let dir = TempDir::new("gltf-nodes");
    dir.write("tri.bin", triangle_bin());
    // 24 levels of two nodes, each the child of both nodes above: 2²⁴ paths to the meshes. The
    // walk goes depth first: the first node it meets twice is on the last level.
    let mut nodes = vec!["{\"children\":[1,2]}".to_string()];
    for level in 0..24 {
        let (a, b) = (1 + 2 * level, 2 + 2 * level);
        let children =
            if level == 23 { "\"mesh\":0".to_string() } else { format!("\"children\":[{},{}]", a + 2, b + 2) };
        nodes.push(format!("{{{children}}}"));
        nodes.push(format!("{{{children}}}"));
    }
    let dag = dir.write("dag.gltf", gltf_with(&format!("[{}]", nodes.join(",")), "[0]", "tri.bin"));
    let e = refused_cheaply(&dir, &["info", s(&dag)], &[]);
    assert_eq!(
        e,
        format!(
            "error: {}: node 47: is reached from both node 45 and node 46 (a glTF node has one parent at most, and no cycle)",
            dag.display()
        )
    );
    let cycle = dir.write("cycle.gltf", gltf_with(r#"[{"children":[1]},{"children":[0],"mesh":0}]"#, "[0]", "tri.bin"));
    let e = refused_cheaply(&dir, &["info", s(&cycle)], &[]);
    assert!(e.ends_with("node 0: is reached from both the scene's roots and node 1 (a glTF node has one parent at most, and no cycle)"), "{e}");
    let twice = dir.write("twice.gltf", gltf_with(r#"[{"mesh":0}]"#, "[0,0]", "tri.bin"));
    let e = refused_cheaply(&dir, &["info", s(&twice)], &[]);
    assert!(e.contains("node 0: is reached from both the scene's roots and the scene's roots"), "{e}");
    // A tree of the same nodes loads: one mesh, placed by two nodes (instances).
    let tree = dir.write("tree.gltf", gltf_with(r#"[{"children":[1,2]},{"mesh":0},{"mesh":0}]"#, "[0]", "tri.bin"));
    let out = common::strahl(&["info", s(&tree)]);
    assert!(out.status.success(), "{}", common::text(&out.stderr));
    assert!(common::text(&out.stdout).contains("instances: 2 of 1 prototypes"), "{}", common::text(&out.stdout));
}

/// A GLB of `json` and a binary chunk `bin`.
fn glb(json: &str, bin: &[u8]) -> Vec<u8> {
    let mut json = json.as_bytes().to_vec();
    while json.len() % 4 != 0 {
        json.push(b' ');
    }
    let mut bin = bin.to_vec();
    while bin.len() % 4 != 0 {
        bin.push(0);
    }
    let length = 12 + 8 + json.len() + 8 + bin.len();
    let mut out = b"glTF".to_vec();
    out.extend(2u32.to_le_bytes());
    out.extend((length as u32).to_le_bytes());
    out.extend((json.len() as u32).to_le_bytes());
    out.extend(b"JSON");
    out.extend(&json);
    out.extend((bin.len() as u32).to_le_bytes());
    out.extend(b"BIN\0");
    out.extend(&bin);
    out
}

#[test]
fn a_glb_whose_length_is_not_the_file_and_a_mesh_without_primitives_are_refused() {
    let dir = TempDir::new("gltf-glb");
    let json = gltf_with(r#"[{"mesh":0}]"#, "[0]", "x").replace(r#","uri":"x""#, "");
    let good = glb(&json, &triangle_bin());
    let ok = dir.write("ok.glb", &good);
    assert!(common::strahl(&["info", s(&ok)]).status.success());
    let mut longer = good.clone();
    longer.extend([0u8; 64]);
    let path = dir.write("longer.glb", &longer);
    let e = refused_cheaply(&dir, &["info", s(&path)], &[]);
    let n = good.len();
    assert!(
        e.ends_with(&format!("not a valid GLB file: its header says {n} bytes, but the file has {}", n + 64)),
        "{e}"
    );
    let path = dir.write("shorter.glb", &good[..n - 4]);
    let e = refused_cheaply(&dir, &["info", s(&path)], &[]);
    assert!(e.ends_with(&format!("its header says {n} bytes, but the file has {}", n - 4)), "{e}");

    let empty = json.replace(r#"[{"attributes":{"POSITION":0}}]"#, "[]");
    let path = dir.write("empty.glb", glb(&empty, &triangle_bin()));
    let e = refused_cheaply(&dir, &["info", s(&path)], &[]);
    assert!(e.ends_with("mesh 0: has no primitives (glTF asks for at least one)"), "{e}");
}

#[test]
fn gltf_uris_are_relative_paths_and_read_once() {
    let dir = TempDir::new("gltf-uris");
    dir.write("tri.bin", triangle_bin());
    // Absolute paths and schemes are refused, with or without --confine, encoded or not.
    for uri in ["/etc/passwd", "%2Fetc%2Fpasswd", "file:///etc/passwd", "file:tri.bin", "C:/tri.bin"] {
        let path = dir.write("abs.gltf", gltf_with(r#"[{"mesh":0}]"#, "[0]", uri));
        let e = refused_cheaply(&dir, &["info", s(&path)], &[]);
        assert!(
            e.ends_with(&format!(
                "buffer 0: URI {uri:?}: only paths relative to the glTF file and data: URIs are read (not absolute paths or other schemes)"
            )),
            "{e}"
        );
    }
    // A file named by many buffers is read once; together they may not pass the mesh limit.
    let buffers: Vec<String> = (0..200).map(|_| r#"{"byteLength":36,"uri":"big.bin"}"#.to_string()).collect();
    let mut big = triangle_bin();
    big.resize(1 << 20, 0);
    dir.write("big.bin", &big);
    let text = gltf_with(r#"[{"mesh":0}]"#, "[0]", "big.bin")
        .replace(r#"[{"byteLength":36,"uri":"big.bin"}]"#, &format!("[{}]", buffers.join(",")));
    let path = dir.write("many.gltf", text);
    let out = common::strahl(&["info", s(&path)]);
    assert!(out.status.success(), "{}", common::text(&out.stderr));
    dir.write("other.bin", &big);
    let text = gltf_with(r#"[{"mesh":0}]"#, "[0]", "big.bin").replace(
        r#"[{"byteLength":36,"uri":"big.bin"}]"#,
        r#"[{"byteLength":36,"uri":"big.bin"},{"byteLength":36,"uri":"other.bin"}]"#,
    );
    let path = dir.write("two.gltf", text);
    let e = refused_cheaply(&dir, &["info", s(&path)], &[("STRAHL_MAX_MESH_BYTES", "1500000")]);
    assert!(
        e.contains("buffer 1: ")
            && e.contains("other.bin: the buffers' files hold more than the limit of 1500000 bytes together"),
        "{e}"
    );
}

// ---------------------------------------------------------------------------------------------
// --confine.

#[test]
fn confine_refuses_every_input_outside_the_folder() {
    let dir = TempDir::new("confine");
    let inside = dir.path("scene");
    let outside = dir.path("elsewhere");
    std::fs::create_dir_all(&inside).unwrap();
    std::fs::create_dir_all(&outside).unwrap();
    let put = |folder: &Path, name: &str, bytes: &[u8]| {
        let p = folder.join(name);
        std::fs::write(&p, bytes).unwrap();
        p
    };
    let grey = image::GrayImage::from_pixel(2, 2, image::Luma([128]));
    let mut png = Vec::new();
    grey.write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png).unwrap();
    let triangle = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nusemtl tex\nf 1/1 2/1 3/1\n";
    let scene = |mesh: &str| {
        format!(
            "{CAMERA}[[lights]]\ntype = \"point\"\nposition = [0, 0, 4]\nintensity = 10\n[[objects]]\ntype = \"mesh\"\npath = \"{mesh}\"\n"
        )
    };
    let out = dir.path("out.exr");
    let confine = inside.to_str().unwrap();
    let render = |scene: &Path| ["render", s(scene), "--confine", confine, "-o", s(&out)].map(str::to_string);
    let refused_confined = |scene: &Path, culprit: &str| {
        let args = render(scene);
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let e = refused_cheaply(&dir, &args, &[]);
        assert!(e.contains(culprit) && e.ends_with("(--confine): not read"), "{culprit}: {e}");
        assert!(!out.exists());
        e
    };

    // Everything inside: renders.
    put(&inside, "t.png", &png);
    put(&inside, "t.mtl", b"newmtl tex\nmap_Kd t.png\n");
    put(&inside, "t.obj", &[b"mtllib t.mtl\n".as_slice(), triangle].concat());
    let ok = put(&inside, "ok.toml", scene("t.obj").as_bytes());
    let args = render(&ok);
    let r = common::strahl(&args.iter().map(String::as_str).collect::<Vec<_>>());
    assert!(r.status.success(), "{}", common::text(&r.stderr));
    std::fs::remove_file(&out).unwrap();

    // The scene itself outside.
    let away = put(&outside, "s.toml", scene("../scene/t.obj").as_bytes());
    refused_confined(&away, "elsewhere/s.toml: cannot read the scene: resolves to ");
    // A mesh that is a symlink out of the folder.
    put(&outside, "m.obj", &[b"mtllib ../scene/t.mtl\n".as_slice(), triangle].concat());
    std::os::unix::fs::symlink(outside.join("m.obj"), inside.join("link.obj")).unwrap();
    let s1 = put(&inside, "link.toml", scene("link.obj").as_bytes());
    refused_confined(&s1, "link.obj: resolves to ");
    // An MTL library outside.
    put(&outside, "o.mtl", b"newmtl tex\nKd 1 1 1\n");
    put(&inside, "o.obj", &[b"mtllib ../elsewhere/o.mtl\n".as_slice(), triangle].concat());
    let s2 = put(&inside, "o.toml", scene("o.obj").as_bytes());
    refused_confined(&s2, "o.obj:1: ");
    // A texture outside, by `../` and by an absolute path.
    put(&outside, "t.png", &png);
    for (name, texture) in
        [("up", "../elsewhere/t.png".to_string()), ("abs", outside.join("t.png").display().to_string())]
    {
        put(&inside, &format!("{name}.mtl"), format!("newmtl tex\nmap_Kd {texture}\n").as_bytes());
        put(&inside, &format!("{name}.obj"), &[format!("mtllib {name}.mtl\n").as_bytes(), triangle].concat());
        let sc = put(&inside, &format!("{name}.toml"), scene(&format!("{name}.obj")).as_bytes());
        refused_confined(&sc, &format!("{name}.mtl:2: map_Kd: "));
    }
    // glTF buffers and images by `../` (absolute URIs are refused in any case).
    put(&outside, "tri.bin", &triangle_bin());
    let g = put(&inside, "up.gltf", gltf_with(r#"[{"mesh":0}]"#, "[0]", "../elsewhere/tri.bin").as_bytes());
    refused_confined(&g, "up.gltf: buffer 0: ");
    let g = put(&inside, "img.gltf", textured_gltf("../elsewhere/t.png").as_bytes());
    refused_confined(&g, "img.gltf: material 0: texture 0: image 0: ");
    // Unconfined, the `../` files are read.
    let r = common::strahl(&["info", s(&g)]);
    assert!(r.status.success(), "{}", common::text(&r.stderr));
    // The folder must exist.
    let e = common::fails(&dir, &["info", s(&ok), "--confine", s(&dir.path("nowhere"))]);
    assert!(e.starts_with(&format!("error: --confine {}: No such file", dir.path("nowhere").display())), "{e}");
}
