//! Finds the installed Embree, generates bindings from its own headers with bindgen, links it,
//! and sets `cfg(embree3)` or `cfg(embree4)` so the wrapper can hide the API differences.
//!
//! Overrides: `EMBREE_INCLUDE_DIR` (the directory holding `embree3/` or `embree4/`),
//! `EMBREE_LIB_DIR` (the directory holding `libembree3.so` or `libembree4.so`) and
//! `EMBREE_VERSION` (major version `3` or `4`, or a full `3.13.5`).
//!
//! With the `denoise` feature, the binaries also get the run paths of Intel Open Image
//! Denoise's libraries (the `oidn` crate links them from `OIDN_DIR/lib`):
//! `$ORIGIN/../lib/strahl/oidn/lib`, where `make install` copies them, then `OIDN_DIR/lib`, where
//! `make oidn` unpacked them. The libraries find each other (OIDN's core, its CPU device, TBB) by
//! their own run path, `$ORIGIN/../lib`, and a binary's run path is not searched for its
//! libraries' libraries: so wherever they go, they keep a folder named `lib` to themselves.

use std::env;
use std::fs;
use std::path::{Path, PathBuf};
use std::process::exit;

const INCLUDE_DIRS: &[&str] = &["/usr/include", "/usr/local/include", "/opt/homebrew/include"];
const LIB_DIRS: &[&str] = &[
    "/usr/lib/x86_64-linux-gnu",
    "/usr/lib/aarch64-linux-gnu",
    "/usr/lib64",
    "/usr/lib",
    "/usr/local/lib",
    "/opt/homebrew/lib",
];
const HOW_TO_FIX: &str = "install Debian's libembree-dev (`sudo apt-get install libembree-dev`, or \
    `make deps`), or set EMBREE_INCLUDE_DIR, EMBREE_LIB_DIR and EMBREE_VERSION";

/// Stops the build with one line saying what is wrong and how to fix it.
fn fail(msg: &str) -> ! {
    println!("cargo::error={msg}");
    eprintln!("error: {msg}");
    exit(1);
}

fn env_var(name: &str) -> Option<String> {
    println!("cargo::rerun-if-env-changed={name}");
    env::var(name).ok().filter(|s| !s.trim().is_empty())
}

/// The major versions to try, newest first, or the one `EMBREE_VERSION` names.
fn wanted_majors() -> Vec<u32> {
    match env_var("EMBREE_VERSION") {
        None => vec![4, 3],
        Some(v) => match v.trim().split('.').next().and_then(|m| m.parse::<u32>().ok()) {
            Some(m @ (3 | 4)) => vec![m],
            _ => fail(&format!("EMBREE_VERSION={v:?} is not an Embree 3 or 4 version")),
        },
    }
}

/// `(include dir, major)` of the first Embree whose `embreeN/rtcore.h` exists.
fn find_headers(majors: &[u32]) -> (PathBuf, u32) {
    let dirs: Vec<PathBuf> = match env_var("EMBREE_INCLUDE_DIR") {
        Some(d) => vec![PathBuf::from(d)],
        None => INCLUDE_DIRS.iter().map(PathBuf::from).collect(),
    };
    for &major in majors {
        for dir in &dirs {
            if dir.join(format!("embree{major}/rtcore.h")).is_file() {
                return (dir.clone(), major);
            }
        }
    }
    let looked: Vec<String> = dirs.iter().map(|d| d.display().to_string()).collect();
    fail(&format!("Embree headers (embree{{3,4}}/rtcore.h) not found in {}: {HOW_TO_FIX}", looked.join(", ")));
}

fn find_library(major: u32) -> PathBuf {
    let dirs: Vec<PathBuf> = match env_var("EMBREE_LIB_DIR") {
        Some(d) => vec![PathBuf::from(d)],
        None => LIB_DIRS.iter().map(PathBuf::from).collect(),
    };
    let names = [
        format!("libembree{major}.so"),
        format!("libembree{major}.so.{major}"),
        format!("libembree{major}.dylib"),
        format!("embree{major}.lib"),
    ];
    for dir in &dirs {
        if names.iter().any(|n| dir.join(n).exists()) {
            return dir.clone();
        }
    }
    fail(&format!("the Embree {major} library (libembree{major}.so) was not found: {HOW_TO_FIX}"));
}

/// `RTC_VERSION` (e.g. 31305) from the headers' `rtcore_config.h`.
fn header_version(include: &Path, major: u32) -> u32 {
    let path = include.join(format!("embree{major}/rtcore_config.h"));
    let text = fs::read_to_string(&path).unwrap_or_else(|e| fail(&format!("cannot read {}: {e}", path.display())));
    text.lines()
        .filter_map(|l| l.trim().strip_prefix("#define RTC_VERSION "))
        .find_map(|v| v.trim().parse().ok())
        .unwrap_or_else(|| fail(&format!("{} has no RTC_VERSION", path.display())))
}

fn main() {
    println!("cargo::rerun-if-changed=ffi/embree.h");
    println!("cargo::rerun-if-changed=build.rs");
    println!("cargo::rustc-check-cfg=cfg(embree3)");
    println!("cargo::rustc-check-cfg=cfg(embree4)");
    println!("cargo::rustc-check-cfg=cfg(embree_inst_prim_id)");

    let (include, major) = find_headers(&wanted_majors());
    let lib_dir = find_library(major);
    let version = header_version(&include, major);
    if let Some(v) = env_var("EMBREE_VERSION") {
        let want: Vec<u32> = v.trim().split('.').filter_map(|p| p.parse().ok()).collect();
        let have = [version / 10000, version / 100 % 100, version % 100];
        if want.len() > 1 && want[..] != have[..want.len().min(3)] {
            fail(&format!(
                "EMBREE_VERSION={v} but the headers in {} are {}.{}.{}",
                include.display(),
                have[0],
                have[1],
                have[2]
            ));
        }
    }
    println!("cargo::rerun-if-changed={}", include.join(format!("embree{major}")).display());

    println!("cargo::rustc-link-search=native={}", lib_dir.display());
    println!("cargo::rustc-link-lib=dylib=embree{major}");
    println!("cargo::rustc-cfg=embree{major}");
    println!("cargo::rustc-env=STRAHL_EMBREE_HEADERS={}", include.display());

    let out = PathBuf::from(env::var("OUT_DIR").expect("cargo sets OUT_DIR"));
    let bindings = bindgen::Builder::default()
        .header("ffi/embree.h")
        .clang_arg(format!("-I{}", include.display()))
        .clang_arg(format!("-DSTRAHL_EMBREE_MAJOR={major}"))
        .allowlist_function("rtc.*")
        .allowlist_type("RTC.*")
        .allowlist_var("RTC_.*")
        // Const-style enums keep the same Rust names across Embree versions and can never hold
        // an out-of-range value that Embree hands back.
        .default_enum_style(bindgen::EnumVariation::Consts)
        .prepend_enum_name(false)
        .derive_default(true)
        .layout_tests(true)
        .generate()
        .unwrap_or_else(|e| {
            fail(&format!(
                "bindgen could not read the Embree {major} headers in {} ({e}); bindgen needs \
                 libclang and clang's builtin headers: install libclang-dev",
                include.display()
            ))
        });
    // Embree >= 4.3 built with instance arrays adds `instPrimID` to RTCHit and the query
    // context (an empty `#define RTC_GEOMETRY_INSTANCE_ARRAY` that bindgen cannot export);
    // user-geometry callbacks must then fill it too, so tell the wrapper.
    let text = bindings.to_string();
    if text.contains("instPrimID") {
        println!("cargo::rustc-cfg=embree_inst_prim_id");
    }
    fs::write(out.join("embree_bindings.rs"), text)
        .unwrap_or_else(|e| fail(&format!("cannot write the Embree bindings: {e}")));
    if env::var_os("CARGO_FEATURE_DENOISE").is_some() {
        oidn_run_paths();
    }
}

/// The run paths by which `strahl` and the test binaries find OIDN's shared libraries.
fn oidn_run_paths() {
    let Some(dir) = env_var("OIDN_DIR") else {
        fail("the `denoise` feature needs OIDN_DIR, the folder `make oidn` fills (it prints it)");
    };
    let lib = Path::new(&dir).join("lib");
    if !lib.join("libOpenImageDenoise.so").is_file() {
        fail(&format!("OIDN_DIR={dir} holds no lib/libOpenImageDenoise.so: run `make oidn`"));
    }
    println!("cargo::rustc-link-arg=-Wl,-rpath,$ORIGIN/../lib/strahl/oidn/lib");
    println!("cargo::rustc-link-arg=-Wl,-rpath,{}", lib.display());
}
