//! Ray-cone mip-mapping of camera rays (src/texture.rs, src/shading.rs): a checker-textured
//! floor receding to the horizon, written by `tools/gltf/mip_assets.py` with pygltflib (not
//! strahl's code), emitting its texture (no light, nothing reflected), rendered with one sample
//! per pixel. Far pixels see many checker cells: their value must be the texture's mean, 0.5
//! (without mip-mapping each sample reads one cell, 0 or 1). Near pixels see less than a texel:
//! they keep the sharp bilinear lookup.
//!
//! The camera at (0, 1, 0) looks at (0, 0.5, −10) with a 40° vertical field of view over
//! 96 rows: the horizon lies at row 48·(1 − 0.05/tan 20°) = 41.4. A pixel row `y` below it sees
//! the floor at an angle α below the horizon, distance `d ≈ 1/sin α`; its ray cone is
//! `d·γ` wide (`γ = 2 tan 20°/96`), `d·γ/sin α` along the floor, which the texture (a period of
//! 16 m over 64 texels) divides into `4·d·γ/sin α` texels: level of detail
//! `λ = log₂(4·d·γ/sin α)`, at least 4.07 on rows 42–46 (where level 4 and coarser hold 2 × 2
//! cells per texel, exactly 0.5) and below −0.5 on rows 75–95. The same floor with a normal map
//! instead of the emitted checker shows the mean normal there.

mod common;

use std::path::{Path, PathBuf};

use common::{TempDir, channel, read_exr, strahl, text};

const WIDTH: usize = 128;
const HEIGHT: usize = 96;

/// The asset's folder, written into `dir`; `None` (with a skip line) without pygltflib.
fn assets(dir: &TempDir) -> Option<PathBuf> {
    common::gltf_assets(dir, "mip_assets.py", "mip_maps")
}

/// The red channel of `file`'s floor, `spp` samples per pixel.
fn render(dir: &TempDir, assets: &Path, file: &str, spp: u32) -> Vec<f32> {
    render_channel(dir, assets, file, spp, "ViewLayer.Combined.R")
}

/// The channel `name` of `file`'s image (Combined and Normal passes), `spp` samples per pixel.
fn render_channel(dir: &TempDir, assets: &Path, file: &str, spp: u32, name: &str) -> Vec<f32> {
    let toml = format!(
        r#"
[camera]
eye = [0, 1, 0]
target = [0, 0.5, -10]
fov_deg = 40
[image]
width = {WIDTH}
height = {HEIGHT}
spp = {spp}
max_depth = 1
background = [0, 0, 0]
[output]
passes = ["combined", "normal"]
[[objects]]
type = "gltf"
path = "{}"
"#,
        assets.join(file).display()
    );
    let scene = dir.write("scene.toml", toml);
    let out = dir.path(&format!("{file}-{spp}.exr"));
    let run = strahl(&["render", scene.to_str().unwrap(), "-o", out.to_str().unwrap(), "--integrator", "path"]);
    assert!(run.status.success(), "{}", text(&run.stderr));
    let (w, h, channels) = read_exr(&out);
    assert_eq!((w, h), (WIDTH, HEIGHT));
    channel(&channels, name).to_vec()
}

#[test]
fn far_pixels_show_the_texture_mean_and_near_ones_stay_sharp() {
    let dir = TempDir::new("mip-maps-floor");
    let Some(assets) = assets(&dir) else { return };
    let r = render(&dir, &assets, "checker_floor.gltf", 1);
    // The sky above the horizon is black.
    assert!(r[..41 * WIDTH].iter().all(|&v| v == 0.0));
    for y in 42..47 {
        for x in 0..WIDTH {
            let v = r[y * WIDTH + x];
            assert!((v - 0.5).abs() < 1e-4, "far pixel ({x}, {y}) is {v}, not the texture's mean 0.5");
        }
    }
    let near: Vec<f32> = r[75 * WIDTH..].to_vec();
    let sharp = near.iter().filter(|&&v| v.abs() < 1e-6 || (v - 1.0).abs() < 1e-6).count();
    assert!(
        sharp as f64 >= 0.6 * near.len() as f64,
        "only {sharp} of {} near pixels are a cell's own 0 or 1: the near floor is blurred",
        near.len()
    );
    let mean = near.iter().map(|&v| v as f64).sum::<f64>() / near.len() as f64;
    assert!((mean - 0.5).abs() < 0.15, "near mean {mean}");
}

/// A sampler whose `minFilter` has no mipmaps (`LINEAR`) is read at full resolution: the far
/// rows alias as they would without mip-mapping, most of their pixels a cell's own 0 or 1.
#[test]
fn a_min_filter_without_mipmaps_turns_mip_mapping_off() {
    let dir = TempDir::new("mip-maps-linear");
    let Some(assets) = assets(&dir) else { return };
    let r = render(&dir, &assets, "checker_floor_linear.gltf", 1);
    let far = &r[42 * WIDTH..47 * WIDTH];
    let cells = far.iter().filter(|&&v| !(0.05..=0.95).contains(&v)).count();
    assert!(cells * 2 > far.len(), "only {cells} of {} far pixels alias: the floor is still mip-mapped", far.len());
}

/// With many samples a pixel, each sample's cone is a sample's (the pixel's over √spp,
/// pbrt-v4's rule), not the whole pixel's: the samples filter the pixel, and the texture is
/// not blurred twice. From the horizon to the near rows, at 64 spp, the mip-mapped floor
/// stays within 0.02 on average of the floor read at full resolution, which the 64 samples
/// filter alone (measured: 0.0057; with each sample's cone the whole pixel's, 0.0475, the
/// checker's contrast |v − 0.5| falling from 0.318 to 0.271).
#[test]
fn many_samples_narrow_each_samples_cone() {
    let dir = TempDir::new("mip-maps-spp");
    let Some(assets) = assets(&dir) else { return };
    let mip = render(&dir, &assets, "checker_floor.gltf", 64);
    let full = render(&dir, &assets, "checker_floor_linear.gltf", 64);
    let rows = 42 * WIDTH..75 * WIDTH;
    let n = rows.len() as f64;
    let mean_abs = rows.clone().map(|i| (mip[i] - full[i]).abs() as f64).sum::<f64>() / n;
    let contrast = |img: &[f32]| rows.clone().map(|i| (img[i] as f64 - 0.5).abs()).sum::<f64>() / n;
    eprintln!(
        "rows 42-74 at 64 spp: mean |mip - full| {mean_abs:.4}; mean |v - 0.5| {:.4} (mip) vs {:.4} (full)",
        contrast(&mip),
        contrast(&full)
    );
    assert!(mean_abs < 0.02, "the mip-mapped floor is {mean_abs:.4} from the full-resolution one");
}

/// Normal maps are mip-mapped as the other textures (tools/gltf/mip_assets.py's bumpy floor:
/// cells of 8 texels tilting the normal 40° one way or the other along x, whose mean is the
/// untilted normal). On the far rows the Normal pass shows that mean (measured: mean |n.x|
/// 0.0000), where the same map read at full resolution (the sampler's `minFilter` LINEAR)
/// shows each sample's cell, tilted (0.29).
#[test]
fn far_normal_maps_average_out() {
    let dir = TempDir::new("mip-maps-normal");
    let Some(assets) = assets(&dir) else { return };
    let tilt = |file: &str| {
        let x = render_channel(&dir, &assets, file, 1, "ViewLayer.Normal.X");
        let far = 42 * WIDTH..47 * WIDTH;
        let n = far.len() as f64;
        far.map(|i| x[i].abs() as f64).sum::<f64>() / n
    };
    let (mip, full) = (tilt("bumpy_floor.gltf"), tilt("bumpy_floor_linear.gltf"));
    eprintln!("far rows, mean |n.x| of the Normal pass: {mip:.4} mip-mapped, {full:.4} at full resolution");
    assert!(mip < 0.05, "the far normal map is not averaged: mean |n.x| {mip:.4}");
    // (Less than sin 40° = 0.64: at these grazing angles most tilted normals are bent towards
    // the geometric one so that the view's mirror direction leaves the floor.)
    assert!(full > 0.2, "the full-resolution control shows no tilt: mean |n.x| {full:.4}");
}
