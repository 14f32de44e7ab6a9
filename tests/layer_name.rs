//! `strahl render --layer-name NAME`: the EXR's channels and Cryptomatte names are
//! `NAME.Pass.C` (Blender's multilayer names for the view layer NAME), the pixels those of
//! the default `ViewLayer` render bit for bit; a name Blender could not give a view layer
//! (empty, over 63 bytes, control characters) is refused in one line naming the option, with
//! nothing written. A property test runs hostile strings (shell and option syntax, dots,
//! quotes, non-ASCII, control characters) through the command line: each is carried exactly
//! or refused in one line, as `strahl::output::layer_name::problem` says.

mod common;

use std::path::Path;

use common::{TempDir, fails, read_exr, read_exr_image, strahl, text};

fn cornell() -> String {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell.toml").display().to_string()
}

/// Renders the Cornell box (16 × 12, 1 spp, Whitted) with `extra`; the output's channels.
fn render(out: &Path, extra: &[&str]) -> Vec<(String, Vec<f32>)> {
    let scene = cornell();
    let mut args = vec!["render", &scene, "-o", out.to_str().unwrap(), "--integrator", "whitted"];
    args.extend(["--width", "16", "--height", "12", "--spp", "1", "--threads", "1"]);
    args.extend(["--passes", "combined,depth,albedo,crypto_object"]);
    args.extend(extra);
    let o = strahl(&args);
    assert!(o.status.success(), "{args:?}: {}", text(&o.stderr));
    read_exr(out).2
}

#[test]
fn channels_and_cryptomatte_carry_the_layer_name() {
    let dir = TempDir::new("layer-name");
    let default = render(&dir.path("default.exr"), &[]);
    let named = render(&dir.path("named.exr"), &["--layer-name", "Beauty.v2 pass"]);
    assert_eq!(default.len(), named.len());
    for ((a, x), (b, y)) in default.iter().zip(&named) {
        assert_eq!(b, &a.replacen("ViewLayer.", "Beauty.v2 pass.", 1), "channel names in the same order");
        assert!(x.iter().zip(y).all(|(p, q)| p.to_bits() == q.to_bits()), "{b}: other pixels");
    }
    let image = read_exr_image(&dir.path("named.exr"));
    let names: Vec<String> = image.layer_data[0]
        .attributes
        .other
        .iter()
        .filter(|(k, _)| k.to_string().ends_with("/name"))
        .map(|(_, v)| format!("{v:?}"))
        .collect();
    assert_eq!(names.len(), 1, "{names:?}");
    assert!(names[0].contains("Beauty.v2 pass.CryptoObject"), "{names:?}");
}

#[test]
fn bad_names_and_combinations_are_refused_in_one_line() {
    let dir = TempDir::new("layer-name-bad");
    let out = dir.path("x.exr");
    let scene = cornell();
    let base = ["render", &scene, "-o", out.to_str().unwrap(), "--width", "8", "--height", "8"];
    let long = "x".repeat(64);
    for (name, extra, says) in [
        ("", None, "is empty"),
        ("a\nb", None, "control character"),
        ("\x1b[31m", None, "control character"),
        (long.as_str(), None, "64 bytes"),
        ("Beauty", Some("--exr-layout=nuke"), "other layout"),
    ] {
        let mut args = base.to_vec();
        args.extend(["--layer-name", name]);
        args.extend(extra);
        let e = fails(&dir, &args);
        assert!(e.contains("--layer-name") && e.contains(says), "{name:?}: {e}");
    }
}

/// Pieces of hostile names.
const PIECES: &[&str] = &[
    "a",
    "Z9",
    " ",
    ".",
    "..",
    "'",
    "\"",
    "\\",
    "$(touch PWNED)",
    "`touch PWNED`",
    ";",
    "#",
    "%",
    "-",
    "--",
    "-o",
    "=",
    ",",
    "\n",
    "\r",
    "\t",
    "\x1b",
    "\u{7f}",
    "\u{85}",
    "ш",
    "❤",
    "*",
    "ViewLayer",
    "Combined",
    "R",
];

#[test]
fn hostile_names_are_carried_exactly_or_refused_in_one_line() {
    use rand::{Rng, SeedableRng};
    let dir = TempDir::new("layer-name-hostile");
    let scene = cornell();
    let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(30);
    let (mut carried, mut refused) = (0, 0);
    for case in 0..60 {
        let name: String = (0..rng.random_range(0..=8)).map(|_| PIECES[rng.random_range(0..PIECES.len())]).collect();
        let out = dir.path(&format!("case{case}.exr"));
        let args = [
            "render",
            &scene,
            "-o",
            out.to_str().unwrap(),
            "--integrator",
            "whitted",
            "--width",
            "4",
            "--height",
            "4",
            "--spp",
            "1",
            "--threads",
            "1",
            "--passes",
            "combined,crypto_object",
            "--layer-name",
            &name,
        ];
        match strahl::output::layer_name::problem(&name) {
            None => {
                let o = strahl(&args);
                assert!(o.status.success(), "{name:?}: {}", text(&o.stderr));
                let (_, _, channels) = read_exr(&out);
                assert!(!channels.is_empty());
                for (latin1, _) in &channels {
                    // The exr crate shows a name's bytes one char each: its UTF-8 back.
                    let channel = String::from_utf8(latin1.chars().map(|c| c as u32 as u8).collect()).unwrap();
                    let rest = channel.strip_prefix(&format!("{name}.")).unwrap_or_else(|| panic!("{channel:?}"));
                    assert!(!rest.is_empty() && rest.matches('.').count() == 1, "{name:?}: {channel:?}");
                }
                std::fs::remove_file(&out).unwrap();
                carried += 1;
            }
            Some(_) => {
                let e = fails(&dir, &args);
                assert!(e.starts_with("error: --layer-name "), "{name:?}: {e}");
                refused += 1;
            }
        }
    }
    assert!(carried >= 10 && refused >= 10, "carried {carried}, refused {refused}: the cases test little");
    assert!(!Path::new("PWNED").exists());
}
