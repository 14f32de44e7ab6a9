//! The thin-lens camera through the whole renderer: `aperture = 0` is the lecture's pinhole
//! bit for bit; an edge on the plane in focus stays sharp; an edge off it is blurred by the
//! circle of confusion the thin-lens formula predicts, `R = a·|1/f − 1/z|` on the image plane
//! at distance 1, read back pixel by pixel from the rendered profile.

mod common;

use std::f64::consts::PI;
use std::path::Path;

use strahl::scene::{Scene, from_toml_str};

fn scene(text: &str) -> Scene {
    from_toml_str(text, Path::new("lens.toml")).unwrap_or_else(|e| panic!("{e}")).scene
}

#[test]
fn aperture_zero_is_the_pinhole_bit_for_bit() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    for name in ["lecture", "whitted"] {
        let text = std::fs::read_to_string(dir.join(format!("{name}.toml"))).unwrap();
        let small = |t: &str| {
            let mut s = scene(t);
            (s.image.width, s.image.height) = (48, 36);
            s
        };
        let pinhole = small(&text);
        let lens = small(&text.replacen("[camera]", "[camera]\naperture = 0\nfocus_distance = 3", 1));
        assert_eq!(lens.camera.lens.aperture, 0.0);
        assert!(common::same_bits(&common::render(&pinhole).0, &common::render(&lens).0), "{name}");
    }
}

/// The fraction of a disk of radius 1 whose centre lies at signed distance `d` (in radii) from
/// a straight edge that falls on the edge's positive side.
fn disk_fraction(d: f64) -> f64 {
    let d = d.clamp(-1.0, 1.0);
    0.5 + (d.asin() + d * (1.0 - d * d).sqrt()) / PI
}

/// A 200 × 16 image of an emitting half-plane (x ≥ 0, radiance 1) at distance `z`, seen by a
/// lens of radius `a` focused at `f`, with 64 samples per pixel: its middle row.
fn edge_row(a: f64, f: f64, z: f64) -> Vec<f64> {
    let text = format!(
        "[camera]\neye = [0, 0, 0]\ntarget = [0, 0, -1]\nfov_deg = 40\naperture = {a}\nfocus_distance = {f}\n\
         [image]\nwidth = 200\nheight = 16\nspp = 64\nmax_depth = 0\n\
         [materials.glow]\nemission = 1\n\
         [[objects]]\ntype = \"triangles\"\n\
         positions = [[0, -50, {z}], [100, -50, {z}], [100, 50, {z}], [0, 50, {z}]]\n\
         indices = [[0, 1, 2], [0, 2, 3]]\nmaterial = \"glow\"\n",
        z = -z
    );
    let film = common::render(&scene(&text)).0;
    (0..200).map(|x| film.rgba[film.index(x, 8)][0] as f64).collect()
}

#[test]
fn an_edge_in_focus_is_sharp_and_one_out_of_focus_blurs_by_the_circle_of_confusion() {
    // In focus: every pixel wholly on one side of the edge (it falls between pixels 99 and
    // 100), whatever the lens point.
    let sharp = edge_row(0.5, 4.0, 4.0);
    assert!(sharp[..100].iter().all(|&v| v == 0.0) && sharp[100..].iter().all(|&v| v == 1.0), "{sharp:?}");

    // Out of focus: a = 0.5, f = 1, z = 4 → R = 0.5·|1 − 1/4| = 0.375 on the image plane, and a
    // pixel is 2·tan(20°)/16 wide there: R ≈ 10.3 pixels.
    let (a, f, z) = (0.5, 1.0, 4.0);
    let radius = a * (1.0 / f - 1.0 / z);
    let pixel = 2.0 * (20f64).to_radians().tan() / 16.0;
    let row = edge_row(a, f, z);
    // Expected: the disk fraction averaged over the pixel's width (box filter).
    let expected: Vec<f64> = (0..200)
        .map(|x| {
            let n = 64;
            (0..n)
                .map(|k| {
                    let u = (x as f64 - 100.0 + (k as f64 + 0.5) / n as f64) * pixel;
                    disk_fraction(u / radius)
                })
                .sum::<f64>()
                / n as f64
        })
        .collect();
    // 64 stratified lens samples per pixel: values in steps of 1/64, each within a few steps.
    let errors: Vec<f64> = row.iter().zip(&expected).map(|(r, e)| (r - e).abs()).collect();
    let worst = errors.iter().copied().fold(0.0, f64::max);
    let mean = errors[85..115].iter().sum::<f64>() / 30.0;
    assert!(worst < 0.05 && mean < 0.015, "worst pixel off by {worst}, mean {mean}: {row:?}");
    // The blurred width, from where the profile leaves 0 to where it reaches 1, is the
    // circle's diameter (± the pixel the box filter adds on each side).
    let first = row.iter().position(|&v| v > 0.0).unwrap() as f64;
    let last = row.iter().position(|&v| v >= 1.0).unwrap() as f64;
    let diameter = 2.0 * radius / pixel;
    assert!((last - first - diameter).abs() <= 2.5, "blur {} px, circle of confusion {diameter} px", last - first);
}
