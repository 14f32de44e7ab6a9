//! OBJ `map_Kd` image textures: a quad with texture coordinates and a checker PNG gives the
//! analytic texel colour (sRGB decoded exactly) in the albedo AOV and, under a light shining
//! along the view, in the image; a missing texture file, or one that is not an image, is an
//! error at its MTL line.

mod common;

use common::{TempDir, render};
use strahl::scene::from_toml_str;
use strahl::texture::srgb_to_linear;

/// An 8×8 PNG of 2×2 cells of 4×4 texels: top-left, top-right, bottom-left, bottom-right.
fn checker_png(cells: [[u8; 3]; 4]) -> Vec<u8> {
    let img = image::RgbImage::from_fn(8, 8, |x, y| image::Rgb(cells[(y / 4 * 2 + x / 4) as usize]));
    let mut bytes = Vec::new();
    img.write_to(&mut std::io::Cursor::new(&mut bytes), image::ImageFormat::Png).unwrap();
    bytes
}

const CELLS: [[u8; 3]; 4] = [[10, 20, 30], [250, 128, 1], [77, 0, 200], [128, 128, 128]];

const SCENE: &str = r#"
[camera]
eye = [0, 0, 4]
target = [0, 0, 0]
fov_deg = 40
[image]
width = 200
height = 200
[[lights]]
type = "directional"
direction = [0, 0, -1]
irradiance = 3.141592653589793
[[objects]]
type = "mesh"
path = "quad.obj"
"#;

#[test]
fn map_kd_shows_the_texel_colours() {
    let dir = TempDir::new("map-kd");
    dir.write("checker.png", checker_png(CELLS));
    dir.write("quad.mtl", "newmtl tex\nKd 1 1 1\nmap_Kd checker.png\n");
    dir.write(
        "quad.obj",
        "mtllib quad.mtl\nv -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n\
         usemtl tex\nf 1/1 2/2 3/3 4/4\n",
    );
    let loaded = from_toml_str(SCENE, &dir.path("s.toml")).unwrap();
    assert!(loaded.warnings.is_empty(), "{:?}", loaded.warnings);
    let (film, _) = render(&loaded.scene);
    // The quad spans ±1 at distance 4 with a 40° field: pixel of (x, y, 0).
    let t = (20f64).to_radians().tan();
    let pixel = |x: f64, y: f64| {
        let (px, py) = ((x / 4.0 / t + 1.0) * 100.0, (1.0 - y / 4.0 / t) * 100.0);
        py as usize * 200 + px as usize
    };
    // OBJ's v runs up: the image's top row is at y > 0.
    for (x, y, cell) in [(-0.5, 0.5, 0), (0.5, 0.5, 1), (-0.5, -0.5, 2), (0.5, -0.5, 3)] {
        let want = CELLS[cell].map(|c| srgb_to_linear(c as f64 / 255.0) as f32);
        let i = pixel(x, y);
        assert_eq!(film.albedo[i].to_array(), want, "albedo of cell {cell}");
        let rgb = film.rgba[i];
        for c in 0..3 {
            assert!((rgb[c] - want[c]).abs() <= 1e-6, "radiance of cell {cell}: {rgb:?} vs {want:?}");
        }
    }
}

#[test]
fn a_missing_map_kd_file_and_a_non_image_are_errors_at_its_line() {
    let dir = TempDir::new("map-kd-missing");
    dir.write("quad.mtl", "newmtl tex\nKd 0.5 0.25 0.125\nmap_Kd gone.png\n");
    dir.write("quad.obj", "mtllib quad.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl tex\nf 1 2 3\n");
    let e = from_toml_str(SCENE, &dir.path("s.toml")).unwrap_err().to_string();
    assert!(e.contains("quad.obj:1: ") && e.contains("quad.mtl:3: map_Kd: "), "{e}");
    assert!(e.contains("gone.png: cannot read the texture: No such file or directory"), "{e}");
    assert_eq!(e.lines().count(), 1);
    dir.write("gone.png", "not a png");
    let e = from_toml_str(SCENE, &dir.path("s.toml")).unwrap_err().to_string();
    assert!(e.contains("quad.mtl:3: map_Kd: ") && e.contains("gone.png: is not a PNG or JPEG image"), "{e}");
    assert_eq!(e.lines().count(), 1);
}
