//! The range of numbers strahl takes, through the `strahl` binary: the range it traces
//! (`strahl::scene::magnitude`, docs/scene-format.md "Range of numbers"), where scenes whose
//! rays Embree aborted on are refused by both backends alike with one line naming the object
//! and scenes at the edge of the range render on both backends alike (a run killed by a
//! signal, as Embree's assertion aborts, fails); and numbers of the command line that panicked.

mod common;

use common::{TempDir, channel, fails, read_exr, strahl, text};

const BACKENDS: [&str; 2] = ["embree", "native"];

/// A small scene: a sphere on a plane under a point light; `camera` and `extra` are spliced in.
fn scene(camera: &str, extra: &str) -> String {
    format!(
        r#"[camera]
{camera}
fov_deg = 40
[image]
width = 16
height = 12
spp = 4
max_depth = 4
background = [0.25, 0.5, 0.75]
[materials.m]
diffuse = 0.5
mirror = 0.3
[[lights]]
type = "point"
position = [2, 4, 3]
intensity = 50
[[objects]]
type = "sphere"
name = "ball"
center = [0, 0, 0]
radius = 1
material = "m"
[[objects]]
type = "plane"
normal = [0, 1, 0]
distance = -1
material = "m"
{extra}
"#
    )
}

/// A triangle named "tri" for `instance` objects to place.
const TRIANGLE: &str = r#"[[objects]]
type = "triangles"
name = "tri"
positions = [[0, 0, 0], [1, 0, 0], [0, 1, 0]]
indices = [[0, 1, 2]]
material = "m"
"#;

#[test]
fn scenes_that_aborted_embree_are_refused_alike_by_both_backends() {
    let dir = TempDir::new("range-refused");
    let cases = [
        ("aperture", scene("eye = [0, 1, 5]\ntarget = [0, 0, 0]\naperture = 1e30", ""), "camera: aperture 1e30 is"),
        ("eye", scene("eye = [0, 1, 5e18]\ntarget = [0, 0, 0]", ""), "camera: eye [0, 1, 5e18] lies"),
        (
            "radius",
            scene(
                "eye = [0, 1, 5]\ntarget = [0, 0, 0]",
                "[[objects]]\ntype = \"sphere\"\nname = \"sun\"\ncenter = [0, 0, 0]\nradius = 3e38\nmaterial = \"m\"\n",
            ),
            "sphere 1 'sun': centre [0, 0, 0] and radius 3e38 reach",
        ),
        (
            "shrunk",
            scene(
                "eye = [0, 1, 5]\ntarget = [0, 0, 0]",
                &format!("{TRIANGLE}[[objects]]\ntype = \"instance\"\nname = \"speck\"\nof = \"tri\"\nscale = 1e-13\n"),
            ),
            "instance 1 'speck': its transform shrinks the prototype 1e13 times",
        ),
        (
            "mesh",
            scene("eye = [0, 1, 5]\ntarget = [0, 0, 0]", &TRIANGLE.replace("[1, 0, 0]", "[2e9, 0, 0]")),
            "vertex 1 [2e9, 0, 0] lies",
        ),
    ];
    for (name, text, expected) in cases {
        let path = dir.write(&format!("{name}.toml"), text);
        let path = path.to_str().unwrap();
        let mut messages = Vec::new();
        for backend in BACKENDS {
            let out = dir.path(&format!("{name}-{backend}.exr"));
            let e = fails(&dir, &["render", path, "-o", out.to_str().unwrap(), "--backend", backend]);
            assert!(e.contains(expected) && e.contains("the range strahl traces (docs/scene-format.md"), "{name}: {e}");
            messages.push(e);
        }
        assert_eq!(messages[0], messages[1], "{name}: the backends refuse alike");
        // crosscheck traces both backends on rays made from the scene's bounds and camera
        // (a sphere of radius 3e38 made it panic: NonFinite bounds).
        let e = fails(&dir, &["crosscheck", path, "--rays", "1000"]);
        assert!(e.contains(expected), "crosscheck {name}: {e}");
    }
}

/// Renders `text` with each backend; each must succeed. Returns each EXR's RGBA.
fn render_both(dir: &TempDir, name: &str, text: &str) -> Vec<Vec<Vec<f32>>> {
    let path = dir.write(&format!("{name}.toml"), text);
    BACKENDS
        .iter()
        .map(|backend| {
            let out = dir.path(&format!("{name}-{backend}.exr"));
            let run = strahl(&["render", path.to_str().unwrap(), "-o", out.to_str().unwrap(), "--backend", backend]);
            // `code()` is None when a signal (Embree's abort) ended the process.
            assert_eq!(run.status.code(), Some(0), "{name} on {backend}: {}", text_of(&run));
            let (_, _, channels) = read_exr(&out);
            ["R", "G", "B", "A"]
                .iter()
                .map(|c| channel(&channels, &format!("ViewLayer.Combined.{c}")).to_vec())
                .collect()
        })
        .collect()
}

fn text_of(run: &std::process::Output) -> String {
    format!("status {:?}, stderr {}", run.status, text(&run.stderr))
}

#[test]
fn a_plane_met_beyond_the_range_is_missed_on_both_backends() {
    // The one ray (one pixel, its centre) has direction (1, −1e-20, 0): it met the plane y = −1 at x = 1e20,
    // and the shadow ray from there aborted Embree (its origin beyond 1.844e18).
    let dir = TempDir::new("range-graze");
    let text = scene("eye = [0, 0, 0]\ntarget = [1, -1e-20, 0]", "")
        .replace("width = 16\nheight = 12\nspp = 4", "width = 1\nheight = 1\nspp = 1")
        .replace("center = [0, 0, 0]", "center = [0, 5, 0]");
    let images = render_both(&dir, "graze", &text);
    for (backend, rgba) in BACKENDS.iter().zip(&images) {
        // The plane ends at 4e9: the ray misses it and sees the background.
        let pixel: Vec<f32> = rgba.iter().map(|c| c[0]).collect();
        assert_eq!(pixel, [0.25, 0.5, 0.75, 1.0], "{backend}");
    }
}

#[test]
fn scenes_at_the_edge_of_the_range_render_alike_on_both_backends() {
    // The eye at 1e9 with an aperture of 1e9 (lens points 2e9 out), a mirror sphere and plane
    // at the bound, a triangle shrunk 5·10⁷ times (object-space origins near 2e17), grazing
    // rays over the plane: every ray inside Embree's range, every image value finite.
    let dir = TempDir::new("range-edge");
    let text = scene(
        "eye = [0, 0, 1e9]\ntarget = [0, -1e9, 0]\naperture = 1e9\nfocus_distance = 1e9",
        &format!(
            "{}[[objects]]\ntype = \"instance\"\nof = \"tri\"\nscale = 2e-8\ntranslate = [0, 0, 9e8]\n\
             [[objects]]\ntype = \"sphere\"\ncenter = [0, -9e8, 0]\nradius = 1e8\nmaterial = \"m\"\n",
            TRIANGLE.replace("[1, 0, 0], [0, 1, 0]", "[1e8, 0, 0], [0, 1e8, 0]")
        ),
    )
    .replace("distance = -1\n", "distance = -1e9\n");
    let images = render_both(&dir, "edge", &text);
    assert!(images[0].iter().flatten().all(|x| x.is_finite()));
    assert_eq!(images[0], images[1], "both backends give the same image");
}

#[test]
fn checkpoint_intervals_without_a_duration_are_refused_in_one_line() {
    // 1e20 s has no Duration: Duration::from_secs_f64 panicked.
    let dir = TempDir::new("range-checkpoint");
    let path = dir.write("s.toml", scene("eye = [0, 1, 5]\ntarget = [0, 0, 0]", ""));
    let out = dir.path("out.exr");
    for (every, shown) in [("1e20", "1e20"), ("2e9", "2e9"), ("-1", "-1"), ("nan", "NaN"), ("inf", "inf")] {
        let args = ["render", path.to_str().unwrap(), "-o", out.to_str().unwrap(), "--checkpoint-every", every];
        let e = fails(&dir, &args);
        assert!(e.ends_with(&format!("--checkpoint-every {shown} is not a number of seconds from 0 to 1e9")), "{e}");
    }
}

#[test]
fn more_threads_than_cores_are_cut_to_the_cores_with_a_note() {
    // 4096 rayon workers on 2 cores took 50 s for an 8 × 8 image: idle workers steal from each other.
    let dir = TempDir::new("range-threads");
    let path = dir.write(
        "s.toml",
        scene("eye = [0, 1, 5]\ntarget = [0, 0, 0]", "").replace("width = 16\nheight = 12", "width = 8\nheight = 8"),
    );
    let cores = std::thread::available_parallelism().unwrap().get();
    for backend in BACKENDS {
        let out = dir.path(&format!("{backend}.exr"));
        let args =
            ["render", path.to_str().unwrap(), "-o", out.to_str().unwrap(), "--threads", "4096", "--backend", backend];
        let run = strahl(&args);
        assert_eq!(run.status.code(), Some(0), "{}", text_of(&run));
        let note = format!("note: --threads 4096 is more than the {cores} cores this process may use: using {cores}\n");
        assert!(text(&run.stderr).starts_with(&note), "{}", text(&run.stderr));
        let threads = format!(", {cores} thread{}\n", if cores == 1 { "" } else { "s" });
        assert!(
            text(&run.stdout).lines().next().is_some_and(|l| format!("{l}\n").ends_with(&threads)),
            "{}",
            text(&run.stdout)
        );
    }
}
