//! Golden images: every shipped scene (`scenes/*.toml`), rendered at 96×72 with its own samples
//! and depth, hashes to the value recorded here, bit for bit over every pass of the film
//! (RGBA, Z, N, albedo and the extra passes).
//!
//! A speed change (a new kernel, packets, a different wrapper) must not change one bit of an
//! image: if it does, this test names the scene and the backend. A change that is *meant* to
//! change images (a new shading rule) updates the table below, in the same commit, saying why.
//!
//! The native BVH is pure Rust with fixed-order arithmetic, so its hashes hold on any x86_64
//! machine. Embree's depend on its release and the instruction set it traces with (its
//! triangle test differs in the last bits between ISAs), so they are checked only on the
//! release and ISA they were recorded with, and the run says so when it skips them. (Shading
//! re-solves the `t, u, v` of every triangle hit in f64, so only Embree's hit-or-miss and
//! which-triangle decisions reach the image: on these scenes its hashes equal the native ones.)
//! FNV-1a (64-bit) over the little-endian bits: a fixed, documented hash, unlike std's.

mod common;

use std::path::Path;

use strahl::accel::embree::Device;
use strahl::integrator;
use strahl::output::film::Film;
use strahl::scene::load::file;

const WIDTH: u32 = 96;
const HEIGHT: u32 = 72;

/// (scene, native BVH hash, Embree hash)
const GOLDEN: &[(&str, u64, u64)] = &[
    // Depth is the view-axis depth (Blender's) and normal and albedo are coverage-weighted
    // (Cycles'), issue 29: RGBA hashes as before on every scene, and the former depth (the
    // ray's length) is now the `distance` pass, bit for bit.
    ("blob", 0x265a_98e1_e050_e0ac, 0x265a_98e1_e050_e0ac),
    ("cornell", 0x01dc_5431_2a4b_046d, 0x01dc_5431_2a4b_046d),
    // The path tracer's scene: its light chosen and sampled with one 2-D point
    // (`LightSet::sample`) and Russian roulette from the third vertex with `√β` (issue 32);
    // the Whitted scenes' hashes are unchanged by either.
    ("cornell-path", 0x3d2f_0992_e119_d592, 0x3d2f_0992_e119_d592),
    ("lecture", 0x4673_5f6d_5fce_910c, 0x4673_5f6d_5fce_910c),
    ("spheres", 0x336b_2220_7080_eeb8, 0x336b_2220_7080_eeb8),
    ("whitted", 0x0b6d_edcb_95e8_9ba9, 0x0b6d_edcb_95e8_9ba9),
];

/// The Embree release and ISA the Embree column was recorded with (`strahl --version`).
const EMBREE_RECORDED: &str = "Embree 3.13.5 (ISA AVX-512";

fn fnv1a(hash: &mut u64, bytes: &[u8]) {
    for &b in bytes {
        *hash ^= b as u64;
        *hash = hash.wrapping_mul(0x0000_0100_0000_01b3);
    }
}

fn film_hash(film: &Film) -> u64 {
    let mut h = 0xcbf2_9ce4_8422_2325;
    let mut floats = |v: &mut dyn Iterator<Item = f32>| {
        for x in v {
            fnv1a(&mut h, &x.to_bits().to_le_bytes());
        }
    };
    floats(&mut film.rgba.iter().flatten().copied());
    floats(&mut film.depth.iter().copied());
    floats(&mut film.normal.iter().flat_map(|n| n.to_array()));
    floats(&mut film.albedo.iter().flat_map(|a| a.to_array()));
    for aov in &film.aovs {
        floats(&mut aov.data.iter().copied());
    }
    h
}

fn scene(name: &str) -> strahl::scene::Scene {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes").join(format!("{name}.toml"));
    let mut scene = file::load(&path).unwrap_or_else(|e| panic!("{e}")).scene;
    (scene.image.width, scene.image.height) = (WIDTH, HEIGHT);
    scene
}

#[test]
fn every_shipped_scene_is_in_the_table() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    let mut shipped: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .filter_map(|e| {
            let name = e.unwrap().file_name().into_string().unwrap();
            name.strip_suffix(".toml").map(str::to_owned)
        })
        .collect();
    shipped.sort();
    let table: Vec<&str> = GOLDEN.iter().map(|g| g.0).collect();
    assert_eq!(shipped, table, "scenes/*.toml and the golden table differ");
}

#[test]
fn native_bvh_images_are_bit_identical_to_the_recorded_ones() {
    let mut wrong = Vec::new();
    for &(name, golden, _) in GOLDEN {
        let scene = scene(name);
        let bvh = strahl::accel::bvh::Bvh::build(&scene).unwrap();
        let (film, _) = integrator::render(&scene, &bvh, &|_| {}).unwrap();
        let hash = film_hash(&film);
        println!("{name}: native {hash:#018x}");
        if hash != golden {
            wrong.push(format!("{name}: {hash:#018x}, recorded {golden:#018x}"));
        }
    }
    assert!(wrong.is_empty(), "native images changed: {wrong:?}");
}

#[test]
fn embree_images_are_bit_identical_to_the_recorded_ones() {
    let running = Device::new().unwrap().describe();
    if !running.starts_with(EMBREE_RECORDED) {
        common::skip(&format!("the Embree hashes were recorded with {EMBREE_RECORDED}…), this is {running}"));
        return;
    }
    let mut wrong = Vec::new();
    for &(name, _, golden) in GOLDEN {
        let scene = scene(name);
        let (film, _) = common::render(&scene);
        let hash = film_hash(&film);
        println!("{name}: embree {hash:#018x}");
        if hash != golden {
            wrong.push(format!("{name}: {hash:#018x}, recorded {golden:#018x}"));
        }
    }
    assert!(wrong.is_empty(), "Embree images changed: {wrong:?}");
}
