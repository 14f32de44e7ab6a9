//! glTF's `alphaMode` (MASK, BLEND) and `doubleSided: false`, on both backends: pixel values
//! read back from the EXR against closed forms, on small files written by
//! `tools/gltf/alpha_assets.py` with pygltflib (not strahl's code; see its docstring for the
//! quads and their alphas).
//!
//! - In front of an emissive backdrop (red, 1 W/(m²·sr)), a black quad emitting green shows
//!   exactly green where its hits exist and exactly red where they do not.
//! - Under a directional light of π W/m² straight down, a white (ρ = 0.5) floor has radiance
//!   0.5 where the light reaches it and 0 where the sheet 2 m above casts its shadow; the
//!   camera looks at the floor from below the sheet, so only shadow rays meet the sheet.

mod common;

use std::path::{Path, PathBuf};

use common::{TempDir, channel, read_exr, strahl, text};

const SIZE: u32 = 64;
/// The width and height of the floor views.
const FLOOR_SIZE: u32 = 96;
/// The assets' alphas (tools/gltf/alpha_assets.py).
const BLEND_ALPHA: f64 = 0.25;

/// The assets, written into `dir`; `None` (with a skip line) without pygltflib.
fn assets(dir: &TempDir) -> Option<PathBuf> {
    common::gltf_assets(dir, "alpha_assets.py", "gltf_alpha")
}

type Channels = Vec<(String, Vec<f32>)>;

/// Renders `toml` (written into `dir`) with `args`; its EXR's channels and strahl's stderr.
fn render(dir: &TempDir, toml: &str, args: &[&str]) -> (Channels, String) {
    let scene = dir.write("scene.toml", toml);
    let out = dir.path("out.exr");
    let mut all = vec!["render", scene.to_str().unwrap(), "-o", out.to_str().unwrap()];
    all.extend(args);
    let run = strahl(&all);
    assert!(run.status.success(), "{}", text(&run.stderr));
    let (_, _, channels) = read_exr(&out);
    (channels, text(&run.stderr))
}

/// `gltf` (placed by `place`, TOML transform keys) seen from z = ±4 (`behind`: from −z) in
/// front of a red emissive backdrop 1 m behind it, rendered by the path tracer.
fn in_front_of_backdrop(gltf: &Path, place: &str, behind: bool, spp: u32) -> String {
    let (eye, backdrop_z, corners) = if behind {
        (-4, 1, "[[-5, -5, 0], [-5, 5, 0], [5, 5, 0], [5, -5, 0]]")
    } else {
        (4, -1, "[[-5, -5, 0], [5, -5, 0], [5, 5, 0], [-5, 5, 0]]")
    };
    format!(
        r#"
[camera]
eye = [0, 0, {eye}]
target = [0, 0, 0]
fov_deg = 40
[image]
width = {SIZE}
height = {SIZE}
spp = {spp}
max_depth = 3
[render]
integrator = "path"
[materials.backdrop]
diffuse = 0
emission = [1, 0, 0]
[[objects]]
type = "triangles"
positions = {corners}
indices = [[0, 1, 2], [0, 2, 3]]
material = "backdrop"
translate = [0, 0, {backdrop_z}]
[[objects]]
type = "gltf"
path = "{}"
{place}
"#,
        gltf.display()
    )
}

/// A white floor (z = 0) under a directional light straight down, `gltf` (placed by `place`)
/// 5 m above it, seen from (0, −2.5, 4) below the sheet by the Whitted integrator.
fn under_a_sheet(gltf: &Path, place: &str, spp: u32) -> String {
    format!(
        r#"
[camera]
eye = [0, -2.5, 4]
target = [0, 0, 0]
up = [0, 0, 1]
fov_deg = 40
[image]
width = {FLOOR_SIZE}
height = {FLOOR_SIZE}
spp = {spp}
max_depth = 1
[render]
integrator = "whitted"
[materials.floor]
diffuse = 0.5
[[lights]]
type = "directional"
direction = [0, 0, -1]
irradiance = 3.141592653589793
[[objects]]
type = "plane"
normal = [0, 0, 1]
distance = 0
material = "floor"
[[objects]]
type = "gltf"
path = "{}"
translate = [0, 0, 5]
{place}
"#,
        gltf.display()
    )
}

/// The pixel that sees the point (x, y, 0) from (0, 0, 4) (40° field of view).
fn pixel_of(x: f64, y: f64) -> usize {
    let half = 4.0 * 20f64.to_radians().tan();
    let n = SIZE as f64;
    let (px, py) = ((x / half * 0.5 + 0.5) * n, (0.5 - y / half * 0.5) * n);
    py as usize * SIZE as usize + px as usize
}

fn rgb(channels: &Channels, pixel: usize) -> [f64; 3] {
    ["R", "G", "B"].map(|c| channel(channels, &format!("ViewLayer.Combined.{c}"))[pixel] as f64)
}

fn disagreements(channels: &Channels) -> usize {
    channel(channels, "ViewLayer.Disagreement.X").iter().filter(|&&d| d != 0.0).count()
}

/// Pixels whose floor point lies under the sheet, at least 0.15 inside its edges and `inner`
/// away from its centre lines, with their floor point `(x, y)`. (The position pass holds a pixel's nearest
/// hit, so its other samples lie up to a pixel's footprint, 0.13 in y, farther up the floor.)
fn floor_pixels(channels: &Channels, inner: f64) -> Vec<(usize, f64, f64)> {
    let (px, py, pz) = (
        channel(channels, "ViewLayer.Position.X"),
        channel(channels, "ViewLayer.Position.Y"),
        channel(channels, "ViewLayer.Position.Z"),
    );
    (0..px.len())
        .filter(|&i| pz[i].abs() < 1e-4)
        .map(|i| (i, px[i] as f64, py[i] as f64))
        .filter(|&(_, x, y)| {
            let inside = |c: f64| c.abs() < 0.85 && c.abs() >= inner;
            inside(x) && inside(y)
        })
        .collect()
}

/// Where the mask's quadrant at (x, y) is there: the top-left (x < 0, y > 0) and bottom-right.
fn mask_is_there(x: f64, y: f64) -> bool {
    (x < 0.0) == (y > 0.0)
}

const GREEN: [f64; 3] = [0.0, 1.0, 0.0];
const RED: [f64; 3] = [1.0, 0.0, 0.0];

fn close(a: [f64; 3], b: [f64; 3], tol: f64) -> bool {
    a.iter().zip(b).all(|(x, y)| (x - y).abs() <= tol)
}

#[test]
fn a_mask_quad_shows_the_backdrop_where_alpha_is_below_the_cutoff_on_both_backends() {
    let dir = TempDir::new("gltf-alpha-mask");
    let Some(assets) = assets(&dir) else { return };
    let toml = in_front_of_backdrop(&assets.join("mask_lit.gltf"), "", false, 4);
    for backend in ["embree", "native"] {
        let (channels, stderr) =
            render(&dir, &toml, &["--backend", backend, "--integrator", "path", "--passes", "combined,disagreement"]);
        assert!(!stderr.contains("alphaMode"), "{stderr}");
        // alpha = COLOR_0.a · texture.a: 0.7, 0, 0.56, 0.7 against the cutoff 0.6.
        for (x, y) in [(-0.5, 0.5), (0.5, 0.5), (-0.5, -0.5), (0.5, -0.5), (-0.8, 0.2), (0.3, -0.85)] {
            let want = if mask_is_there(x, y) { GREEN } else { RED };
            let got = rgb(&channels, pixel_of(x, y));
            assert!(close(got, want, 1e-6), "{backend}: at ({x}, {y}) {got:?}, want {want:?}");
        }
        // Outside the quad: the backdrop.
        assert!(close(rgb(&channels, pixel_of(1.3, 0.0)), RED, 1e-6));
        assert_eq!(disagreements(&channels), 0, "{backend}: the backends' first hits differ");
    }
}

#[test]
fn a_mask_sheet_casts_the_shadow_of_its_opaque_quadrants_only() {
    let dir = TempDir::new("gltf-alpha-mask-shadow");
    let Some(assets) = assets(&dir) else { return };
    let toml = under_a_sheet(&assets.join("mask_sheet.gltf"), "", 4);
    for backend in ["embree", "native"] {
        let (channels, _) =
            render(&dir, &toml, &["--backend", backend, "--integrator", "whitted", "--passes", "combined,position"]);
        // The 4 × 4 texture's bilinear alpha is its quadrant's own value from a texel centre
        // (0.25 from the centre lines) outwards; nearer the centre lines it blends.
        let pixels = floor_pixels(&channels, 0.4);
        assert!(pixels.len() > 100, "{} floor pixels under the sheet", pixels.len());
        let (mut lit, mut dark) = (0, 0);
        for (i, x, y) in pixels {
            // ρ/π · E · V with E = π: 0.5 where the light passes.
            let want = if mask_is_there(x, y) { 0.0 } else { 0.5 };
            let got = rgb(&channels, i)[0];
            assert!((got - want).abs() < 1e-5, "{backend}: floor ({x:.3}, {y:.3}): {got}, want {want}");
            *(if want > 0.0 { &mut lit } else { &mut dark }) += 1;
        }
        assert!(lit > 40 && dark > 40, "{lit} lit, {dark} shadowed pixels");
    }
}

#[test]
fn a_blend_quad_of_alpha_a_quarter_covers_a_quarter_of_the_camera_rays() {
    let dir = TempDir::new("gltf-alpha-blend");
    let Some(assets) = assets(&dir) else { return };
    let toml = in_front_of_backdrop(&assets.join("blend_lit.gltf"), "", false, 32);
    let mut images = Vec::new();
    for (backend, threads) in [("embree", "2"), ("native", "2"), ("embree", "1")] {
        let args = ["--backend", backend, "--threads", threads, "--integrator", "path", "--passes", "combined"];
        let (channels, _) = render(&dir, &toml, &args);
        // Over the quad's inner part (−0.9 .. 0.9): green = α, red = 1 − α, in expectation.
        let mut n = 0usize;
        let mut sum = [0.0; 3];
        for py in 0..SIZE as usize {
            for px in 0..SIZE as usize {
                let half = 4.0 * 20f64.to_radians().tan();
                let x = ((px as f64 + 0.5) / SIZE as f64 - 0.5) * 2.0 * half;
                let y = (0.5 - (py as f64 + 0.5) / SIZE as f64) * 2.0 * half;
                if x.abs() < 0.9 && y.abs() < 0.9 {
                    let c = rgb(&channels, py * SIZE as usize + px);
                    sum.iter_mut().zip(c).for_each(|(s, c)| *s += c);
                    n += 1;
                }
            }
        }
        let samples = (n * 32) as f64;
        let sigma = (BLEND_ALPHA * (1.0 - BLEND_ALPHA) / samples).sqrt();
        let (g, r) = (sum[1] / n as f64, sum[0] / n as f64);
        assert!((g - BLEND_ALPHA).abs() < 5.0 * sigma, "{backend}: coverage {g}, want {BLEND_ALPHA} ± {sigma}");
        assert!((r - (1.0 - BLEND_ALPHA)).abs() < 5.0 * sigma, "{backend}: backdrop {r}");
        assert!((r + g - 1.0).abs() < 1e-5, "{backend}: every ray sees one or the other: {r} + {g}");
        images.push(channels);
    }
    // The hits are decided by a hash of the ray, not by the backend or the thread.
    assert!(images[0] == images[1], "embree and native images differ");
    assert!(images[0] == images[2], "one thread and two give different images");
}

#[test]
fn a_blend_sheet_of_alpha_a_quarter_passes_three_quarters_of_the_light() {
    let dir = TempDir::new("gltf-alpha-blend-shadow");
    let Some(assets) = assets(&dir) else { return };
    let toml = under_a_sheet(&assets.join("blend_sheet.gltf"), "", 16);
    let mut means = Vec::new();
    for backend in ["embree", "native"] {
        let (channels, _) =
            render(&dir, &toml, &["--backend", backend, "--integrator", "whitted", "--passes", "combined,position"]);
        let pixels = floor_pixels(&channels, 0.0);
        let mean = pixels.iter().map(|&(i, _, _)| rgb(&channels, i)[0]).sum::<f64>() / pixels.len() as f64;
        // Each pixel's 16 shadow rays pass with probability 1 − α: radiance 0.5 · (1 − α).
        let samples = (pixels.len() * 16) as f64;
        let sigma = 0.5 * (BLEND_ALPHA * (1.0 - BLEND_ALPHA) / samples).sqrt();
        let want = 0.5 * (1.0 - BLEND_ALPHA);
        assert!((mean - want).abs() < 5.0 * sigma, "{backend}: floor {mean}, want {want} ± {sigma}");
        means.push(mean);
    }
    assert_eq!(means[0], means[1], "the backends pass different shadow rays");
}

#[test]
fn a_one_sided_quad_seen_from_behind_shows_what_is_behind_it_and_still_casts_its_shadow() {
    let dir = TempDir::new("gltf-alpha-one-sided");
    let Some(assets) = assets(&dir) else { return };
    let lit = assets.join("one_sided_lit.gltf");
    for backend in ["embree", "native"] {
        let args = ["--backend", backend, "--integrator", "path", "--passes", "combined,disagreement"];
        // From the front: the quad.
        let (front, _) = render(&dir, &in_front_of_backdrop(&lit, "", false, 4), &args);
        assert!(
            close(rgb(&front, pixel_of(0.0, 0.0)), GREEN, 1e-6),
            "{backend}: {:?}",
            rgb(&front, pixel_of(0.0, 0.0))
        );
        // From behind: the backdrop through it.
        let (back, _) = render(&dir, &in_front_of_backdrop(&lit, "", true, 4), &args);
        for (x, y) in [(0.0, 0.0), (0.5, 0.5), (-0.5, -0.5)] {
            let got = rgb(&back, pixel_of(x, y));
            assert!(close(got, RED, 1e-6), "{backend}: the back face at ({x}, {y}) shows {got:?}");
        }
        assert_eq!(disagreements(&back), 0, "{backend}");
        // Turned over (its front facing the floor), the light reaches its back: the shadow stays.
        let toml = under_a_sheet(&assets.join("one_sided_sheet.gltf"), "rotate_deg = [180, 0, 0]", 4);
        let (channels, _) =
            render(&dir, &toml, &["--backend", backend, "--integrator", "whitted", "--passes", "combined,position"]);
        let pixels = floor_pixels(&channels, 0.0);
        assert!(pixels.len() > 100, "{} floor pixels under the sheet", pixels.len());
        for (i, x, y) in pixels {
            assert_eq!(rgb(&channels, i)[0], 0.0, "{backend}: floor ({x:.3}, {y:.3}) is lit through the sheet");
        }
    }
}

#[test]
fn a_one_sided_emissive_quad_emits_from_its_front_only() {
    let dir = TempDir::new("gltf-alpha-one-sided-emitter");
    let Some(assets) = assets(&dir) else { return };
    let emitter = assets.join("one_sided_emitter.gltf");
    let scene = |place: &str| {
        under_a_sheet(&emitter, place, 16)
            .replace("irradiance = 3.141592653589793", "irradiance = 0")
            .replace("integrator = \"whitted\"", "integrator = \"path\"")
            .replace("max_depth = 1", "max_depth = 2")
    };
    let args = ["--integrator", "path", "--passes", "combined,position"];
    // Facing up, away from the floor: the floor gets nothing; facing down, it is lit.
    let (up, _) = render(&dir, &scene(""), &args);
    let (down, _) = render(&dir, &scene("rotate_deg = [180, 0, 0]"), &args);
    let mean = |c: &Channels| {
        let p = floor_pixels(c, 0.0);
        p.iter().map(|&(i, _, _)| rgb(c, i)[0]).sum::<f64>() / p.len() as f64
    };
    // (Not exactly 0: light bounced off the emitter's back may sample the emitter itself, in
    // its own plane, at a cosine of rounding size: 1e-13.)
    assert!(mean(&up) < 1e-9, "the back of a one-sided emitter emits {}", mean(&up));
    // About ρ/π · L·A/d² = 0.5/π · 4/25 ≈ 0.025 below the middle.
    assert!(mean(&down) > 0.01, "the front emits {}", mean(&down));
}

/// The offset of the two placements of `*_twice.gltf` (tools/gltf/alpha_assets.py).
const TWICE_OFFSET: f64 = 1.1;

/// The world point of the quad's point `(x, y)` in placement `k` of `*_twice.gltf` (0: scaled
/// by 1/2 and moved along −x; 1: moved along +x and mirrored in x).
fn placed(k: usize, x: f64, y: f64) -> (f64, f64) {
    if k == 0 { (-TWICE_OFFSET + 0.5 * x, 0.5 * y) } else { (TWICE_OFFSET - 0.5 * x, 0.5 * y) }
}

/// TOML keys placing a glTF object as node `k` of `*_twice.gltf` places its quad.
fn placement_keys(k: usize) -> String {
    let (sx, tx) = if k == 0 { (0.5, -TWICE_OFFSET) } else { (-0.5, TWICE_OFFSET) };
    format!("scale = [{sx}, 0.5, 0.5]\ntranslate = [{tx}, 0, 0]\n")
}

/// `lit` placed twice, once as a glTF object named `q` and once by an `instance` object, as
/// `*_twice.gltf` places its quad.
fn instanced_twice(lit: &Path, behind: bool) -> String {
    let mut toml = in_front_of_backdrop(lit, &format!("name = \"q\"\n{}", placement_keys(0)), behind, 4);
    toml += &format!("[[objects]]\ntype = \"instance\"\nof = \"q\"\n{}", placement_keys(1));
    toml
}

/// `lit` placed twice by two glTF objects: meshes placed once, flattened into world space.
fn flattened_twice(lit: &Path, behind: bool) -> String {
    let mut toml = in_front_of_backdrop(lit, &placement_keys(0), behind, 4);
    toml += &format!("[[objects]]\ntype = \"gltf\"\npath = \"{}\"\n{}", lit.display(), placement_keys(1));
    toml
}

fn combined(channels: &Channels) -> Vec<u32> {
    ["R", "G", "B"]
        .iter()
        .flat_map(|c| channel(channels, &format!("ViewLayer.Combined.{c}")).iter().map(|v| v.to_bits()))
        .collect()
}

/// A mesh with a MASK or one-sided material that is instanced — used by two glTF nodes, or
/// placed again by a TOML `instance` object, one placement mirrored — keeps its holes and its
/// culled back faces on both backends, bit for bit as its flattened copies render.
#[test]
fn instanced_mask_and_one_sided_meshes_render_as_their_flattened_copies() {
    let dir = TempDir::new("gltf-alpha-instances");
    let Some(assets) = assets(&dir) else { return };
    for backend in ["embree", "native"] {
        let args = ["--backend", backend, "--integrator", "path", "--passes", "combined,disagreement"];
        // The quad of `name`_lit.gltf placed twice: flattened, by a TOML instance, by two nodes.
        let placements = |name: &str, behind: bool| {
            let lit = assets.join(format!("{name}_lit.gltf"));
            let twice = assets.join(format!("{name}_twice.gltf"));
            let (flat, _) = render(&dir, &flattened_twice(&lit, behind), &args);
            let (toml, _) = render(&dir, &instanced_twice(&lit, behind), &args);
            let (gltf, _) = render(&dir, &in_front_of_backdrop(&twice, "", behind, 4), &args);
            [("flattened", flat), ("TOML instance", toml), ("two glTF nodes", gltf)]
        };
        let rendered = placements("mask", false);
        for (what, channels) in &rendered {
            for k in 0..2 {
                for (x, y) in [(-0.5, 0.5), (0.5, 0.5), (-0.5, -0.5), (0.5, -0.5)] {
                    let want = if mask_is_there(x, y) { GREEN } else { RED };
                    let (wx, wy) = placed(k, x, y);
                    let got = rgb(channels, pixel_of(wx, wy));
                    assert!(
                        close(got, want, 1e-6),
                        "{backend}, {what}, placement {k}: at ({x}, {y}) {got:?}, want {want:?}"
                    );
                }
            }
            assert_eq!(disagreements(channels), 0, "{backend}, {what}: the backends' first hits differ");
        }
        same_as_flattened(backend, &rendered);
        // Seen from behind, the one-sided quads show the backdrop, instanced or not.
        let rendered = placements("one_sided", true);
        for (what, channels) in &rendered {
            for k in 0..2 {
                // Seen from −z the image's x runs the other way.
                let (wx, wy) = placed(k, 0.3, 0.3);
                let got = rgb(channels, pixel_of(-wx, wy));
                assert!(close(got, RED, 1e-6), "{backend}, {what}, placement {k}: the back face shows {got:?}");
            }
        }
        same_as_flattened(backend, &rendered);
    }
}

/// The instanced renders' Combined channels bit for bit those of the flattened copies (first).
fn same_as_flattened(backend: &str, rendered: &[(&str, Channels)]) {
    let flat = combined(&rendered[0].1);
    for (what, channels) in &rendered[1..] {
        assert!(combined(channels) == flat, "{backend}: the {what} placements differ from the flattened copies");
    }
}
