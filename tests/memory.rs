//! The memory budget through the `strahl` binary (`strahl::job::memory`): the default
//! `--max-memory` is the smallest limit the process runs under (`RLIMIT_AS` set with
//! util-linux's `prlimit`, the memory limit of a cgroup made for the test) and `strahl info`
//! says which; a render over it is refused up front; and the estimate is an upper bound of
//! what real renders take (peak RSS of the child, `getrusage` as `/usr/bin/time` reads it),
//! on both backends. Tools or rights missing here skip their part with one loud line.

mod common;

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use common::{TempDir, data_dir, text};

fn strahl_bin() -> &'static str {
    env!("CARGO_BIN_EXE_strahl")
}

fn skip(why: &str) {
    common::skip(why);
}

/// The `default --max-memory: …` line of `strahl info scene` run by `command`.
fn default_line(mut command: Command) -> String {
    let out = command.stderr(Stdio::piped()).output().expect("strahl info runs");
    assert!(out.status.success(), "{}", text(&out.stderr));
    let stdout = text(&out.stdout);
    stdout.lines().find(|l| l.starts_with("default --max-memory: ")).unwrap_or_else(|| panic!("{stdout}")).to_string()
}

fn lecture() -> &'static str {
    concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/lecture.toml")
}

/// Whole megabytes (10⁶ bytes, rounded up), as strahl prints them.
fn mb(bytes: u64) -> String {
    format!("{} MB", bytes.div_ceil(1_000_000))
}

/// Address space strahl keeps out of an `RLIMIT_AS` budget on this machine.
fn reserve() -> u64 {
    let cores = std::thread::available_parallelism().unwrap().get() as u64;
    strahl::sys::memory::ADDRESS_SPACE_BASE + cores * strahl::sys::memory::ADDRESS_SPACE_PER_CORE
}

fn has_prlimit() -> bool {
    Command::new("prlimit").arg("--version").output().is_ok_and(|o| o.status.success())
}

#[test]
fn an_address_space_limit_lowers_the_default_and_refuses_a_render_up_front() {
    if !has_prlimit() {
        return skip("prlimit (util-linux) is missing: RLIMIT_AS not tested");
    }
    let limited = |option: &str, bytes: u64| {
        let mut c = Command::new("prlimit");
        c.arg(format!("{option}={bytes}")).arg(strahl_bin());
        c
    };
    let as_limit = 3u64 << 30;
    let mut c = limited("--as", as_limit);
    c.args(["info", lecture()]);
    let expected = format!(
        "default --max-memory: {} (RLIMIT_AS {} less {} of address space kept for threads and Embree)",
        mb(as_limit - reserve()),
        mb(as_limit),
        mb(reserve())
    );
    assert_eq!(default_line(c), expected);
    let mut c = limited("--data", 2u64 << 30);
    c.args(["info", lecture()]);
    assert!(default_line(c).contains(&format!("(RLIMIT_DATA {} less", mb(2 << 30))));

    // 4000 × 3000 pixels need about 720 MB: more than 1.5 GiB of address space leaves.
    let dir = TempDir::new("memory-rlimit");
    let out = dir.path("big.exr");
    let mut c = limited("--as", 3 << 29);
    c.args(["render", lecture(), "--width", "4000", "--height", "3000", "-o", out.to_str().unwrap()]);
    let run = c.output().unwrap();
    let stderr = text(&run.stderr);
    assert_eq!(run.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains("this render needs about ") && stderr.contains("(the default: RLIMIT_AS 1611 MB less"),
        "{stderr}"
    );
    assert!(dir.entries().is_empty(), "nothing written: {:?}", dir.entries());
}

/// The folder of this process's memory cgroup, v1 (`memory` controller) or v2, on the usual
/// mounts.
fn own_memory_cgroup() -> Option<(PathBuf, &'static str)> {
    let cgroups = std::fs::read_to_string("/proc/self/cgroup").ok()?;
    for line in cgroups.lines() {
        let mut parts = line.splitn(3, ':');
        let (_, controllers, path) = (parts.next()?, parts.next()?, parts.next()?);
        let path = path.trim_start_matches('/');
        if controllers.split(',').any(|c| c == "memory") {
            let dir = Path::new("/sys/fs/cgroup/memory").join(path);
            if dir.join("memory.limit_in_bytes").exists() {
                return Some((dir, "memory.limit_in_bytes"));
            }
        }
        if controllers.is_empty() {
            let dir = Path::new("/sys/fs/cgroup").join(path);
            let controllers = std::fs::read_to_string(dir.join("cgroup.subtree_control")).unwrap_or_default();
            if controllers.split_whitespace().any(|c| c == "memory") {
                return Some((dir, "memory.max"));
            }
        }
    }
    None
}

#[test]
fn a_cgroup_memory_limit_lowers_the_default() {
    let Some((parent, file)) = own_memory_cgroup() else {
        return skip("no memory cgroup of this process with the memory controller for children: cgroups not tested");
    };
    let child = parent.join(format!("strahl-test-{}", std::process::id()));
    if let Err(e) = std::fs::create_dir(&child) {
        return skip(&format!("cannot create the cgroup {}: {e}: cgroups not tested", child.display()));
    }
    let limit = 2u64 << 30;
    let result = std::fs::write(child.join(file), limit.to_string()).map(|_| {
        let procs = child.join("cgroup.procs");
        let script = format!("echo $$ > '{}' && exec '{}' info '{}'", procs.display(), strahl_bin(), lecture());
        let mut c = Command::new("sh");
        c.args(["-c", &script]);
        default_line(c)
    });
    // The shell and strahl have exited: the cgroup is empty and can go.
    let removed = std::fs::remove_dir(&child);
    let line = match result {
        Ok(line) => line,
        Err(e) => return skip(&format!("cannot set {} of {}: {e}: cgroups not tested", file, child.display())),
    };
    removed.unwrap();
    let expected =
        format!("default --max-memory: {} (the cgroup memory limit in {})", mb(limit), child.join(file).display());
    assert_eq!(line, expected);
}

/// Peak RSS in bytes of `strahl args`, which must succeed ([`common::run_measured`]).
fn peak(_dir: &TempDir, args: &[&str]) -> Option<u64> {
    let m = common::run_measured(args, &[], 600);
    assert_eq!(m.status, Some(0), "{args:?}: {}", m.stderr);
    m.peak_bytes
}

/// `strahl info`'s estimate for `scene` with `extra` options, bytes (whole MB rounded up).
fn estimate(scene: &Path, extra: &[&str]) -> u64 {
    let out = common::strahl(&[&["info", scene.to_str().unwrap()][..], extra].concat());
    assert!(out.status.success(), "{}", text(&out.stderr));
    let stdout = text(&out.stdout);
    let line = stdout.lines().find(|l| l.starts_with("memory estimate: ")).unwrap();
    line["memory estimate: ".len()..].split(' ').next().unwrap().parse::<u64>().unwrap() * 1_000_000
}

const CAMERA: &str = "[camera]\neye = [0, 0.1, 3]\ntarget = [0, 0.05, 0]\nfov_deg = 40\n[image]\nwidth = 320\nheight = 240\n\
                      [materials.m]\ndiffuse = 0.7\n[[lights]]\ntype = \"point\"\nposition = [1, 2, 2]\nintensity = 20\n";

#[test]
fn the_estimate_bounds_the_peak_of_real_renders_on_both_backends() {
    let dir = TempDir::new("memory-peak");
    let mut scenes: Vec<(String, PathBuf, Vec<&str>)> = Vec::new();
    // Six Stanford dragons as separate meshes (871,306 triangles each): estimated 537 MB
    // for a 780 MB peak before the BVH's build was counted.
    match data_dir() {
        Some(data) => {
            let dragon = data.join("stanford/dragon_vrip.ply.gz");
            let objects: String = (0..6)
                .map(|i| {
                    format!(
                        "[[objects]]\ntype = \"mesh\"\npath = \"{}\"\nmaterial = \"m\"\ntranslate = [{}, 0, 0]\n",
                        dragon.display(),
                        0.3 * i as f64
                    )
                })
                .collect();
            scenes.push(("six dragons".into(), dir.write("dragons.toml", format!("{CAMERA}{objects}")), vec![]));
        }
        None => skip("the test data is missing: six dragons not measured"),
    }
    // 500,000 spheres, each with its name.
    let spheres = "[[objects]]\ntype = \"random_spheres\"\ncount = 500000\nseed = 3\n\
                   bounds = [[-2, -2, -2], [2, 2, 2]]\nradii = [0.001, 0.002]\nmaterials = [\"m\"]\n";
    scenes.push(("spheres".into(), dir.write("spheres.toml", format!("{CAMERA}{spheres}")), vec![]));
    // 20,000 meshes of one triangle each (an OBJ's objects).
    let obj: String = (0..20_000)
        .map(|i| {
            let (x, y) = ((i % 200) as f64 * 0.01 - 1.0, (i / 200) as f64 * 0.01 - 0.5);
            format!("o m{i}\nv {x} {y} 0\nv {} {y} 0\nv {x} {} 0\nf -3 -2 -1\n", x + 0.005, y + 0.005)
        })
        .collect();
    dir.write("many.obj", obj);
    let many = "[[objects]]\ntype = \"mesh\"\npath = \"many.obj\"\nmaterial = \"m\"\n";
    scenes.push(("20,000 meshes".into(), dir.write("many.toml", format!("{CAMERA}{many}")), vec![]));
    // The film's share: every pass at 1920 × 1080.
    let whitted = PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/whitted.toml"));
    scenes.push((
        "whitted, all passes".into(),
        whitted,
        vec!["--width", "1920", "--height", "1080", "--passes", "all"],
    ));

    let out = dir.path("out.exr");
    for (name, scene, extra) in &scenes {
        let estimated = estimate(scene, extra);
        for backend in ["embree", "native"] {
            let mut args = vec!["render", scene.to_str().unwrap(), "-o", out.to_str().unwrap(), "--backend", backend];
            args.extend(extra);
            let Some(measured) = peak(&dir, &args) else {
                return skip("/usr/bin/time is missing: peak memory not measured");
            };
            eprintln!("{name}, {backend}: estimated {} MB, peak {} MB", estimated / 1_000_000, measured / 1_000_000);
            assert!(measured <= estimated, "{name}, {backend}: peak {measured} bytes above the estimate {estimated}");
            // An upper bound, not a wild one (the base alone is 42 MB).
            assert!(estimated <= 2 * measured + (64 << 20), "{name}, {backend}: {estimated} for a peak of {measured}");
        }
    }
}
