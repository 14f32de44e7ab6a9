//! `strahl merge` on parts someone else made: every size a part's header declares (data window,
//! channels, blocks, offset table) is checked against what its file holds before anything of
//! that size is allocated, each refusal one line naming the file with nothing written; the
//! merge's memory stays under its bound ([`strahl::output::merge::Plan::memory`], measured here as the
//! child's peak RSS) and within `--max-memory`.

mod common;

use std::path::{Path, PathBuf};

use common::{TempDir, fails, strahl, text};

/// Runs `strahl args` and returns its exit code, stderr and peak resident memory in bytes
/// ([`common::run_measured`]).
fn run_measured(_dir: &TempDir, args: &[&str]) -> (Option<i32>, String, Option<u64>) {
    let m = common::run_measured(args, &[], 600);
    (m.status, m.stderr, m.peak_bytes)
}

fn attribute(name: &str, kind: &str, value: &[u8]) -> Vec<u8> {
    let mut out = Vec::new();
    for s in [name, kind] {
        out.extend(s.as_bytes());
        out.push(0);
    }
    out.extend((value.len() as i32).to_le_bytes());
    out.extend(value);
    out
}

/// The header of a single-part scan-line file of `w × h` pixels and `channels` float
/// channels with the compression numbered `compression` (OpenEXR's: 0 none, 3 ZIP, 8 DWAA).
fn header(w: i32, h: i32, channels: usize, compression: u8) -> Vec<u8> {
    let mut list = Vec::new();
    for c in 0..channels {
        list.extend(format!("c{c:02}\0").as_bytes());
        list.extend(2i32.to_le_bytes()); // FLOAT
        list.extend([0u8; 4]);
        list.extend(1i32.to_le_bytes());
        list.extend(1i32.to_le_bytes());
    }
    list.push(0);
    let window: Vec<u8> = [0, 0, w - 1, h - 1].iter().flat_map(|v: &i32| v.to_le_bytes()).collect();
    let mut out = vec![0x76, 0x2f, 0x31, 0x01, 2, 0, 0, 0];
    out.extend(attribute("channels", "chlist", &list));
    out.extend(attribute("compression", "compression", &[compression]));
    out.extend(attribute("dataWindow", "box2i", &window));
    out.extend(attribute("displayWindow", "box2i", &window));
    out.extend(attribute("lineOrder", "lineOrder", &[0]));
    out.extend(attribute("pixelAspectRatio", "float", &1f32.to_le_bytes()));
    out.extend(attribute("screenWindowCenter", "v2f", &[0; 8]));
    out.extend(attribute("screenWindowWidth", "float", &1f32.to_le_bytes()));
    out.push(0);
    out
}

/// A file of `header` whose `blocks` offsets all point at one small block (line 0, an empty
/// zlib stream).
fn with_blocks(mut file: Vec<u8>, blocks: usize) -> Vec<u8> {
    let block_at = (file.len() + 8 * blocks) as u64;
    for _ in 0..blocks {
        file.extend(block_at.to_le_bytes());
    }
    file.extend(0i32.to_le_bytes());
    file.extend(8i32.to_le_bytes());
    file.extend([0x78, 0x9c, 0x03, 0x00, 0x00, 0x00, 0x00, 0x01]);
    file
}

#[test]
fn a_17_kb_part_declaring_275_gb_is_refused_at_once_in_little_memory() {
    let dir = TempDir::new("bomb");
    // 32768² pixels of 64 float channels, ZIP: 2048 blocks of 16 lines, 275 GB raw.
    let bomb = dir.write("bomb.exr", with_blocks(header(32768, 32768, 64, 3), 2048));
    assert!(std::fs::metadata(&bomb).unwrap().len() < 18_000);
    let out = dir.path("out.exr");
    let (code, stderr, rss) = run_measured(&dir, &["merge", out.to_str().unwrap(), bomb.to_str().unwrap()]);
    assert_eq!(code, Some(1), "{stderr}");
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
    assert!(stderr.starts_with(&format!("error: {}: ", bomb.display())), "{stderr}");
    assert!(!out.exists());
    if let Some(rss) = rss {
        assert!(rss < 200 << 20, "peak RSS {} MB", rss >> 20);
        eprintln!("refused with a peak RSS of {:.1} MB: {stderr}", rss as f64 / 1e6);
    }
}

#[test]
fn every_declared_size_is_checked_against_the_file() {
    let dir = TempDir::new("sizes");
    let out = dir.path("out.exr");
    let refuse = |name: &str, bytes: Vec<u8>| -> String {
        let part = dir.write(name, bytes);
        let e = fails(&dir, &["merge", out.to_str().unwrap(), part.to_str().unwrap()]);
        assert!(e.starts_with(&format!("error: {}: ", part.display())), "{e}");
        std::fs::remove_file(&part).unwrap();
        e
    };
    // The offset table and the blocks' headers do not fit in the file.
    let e = refuse("table.exr", header(32768, 32768, 64, 3));
    assert!(e.contains("2048 blocks need"), "{e}");
    // The table fits; the pixels are more than ZIP can make of the file's bytes.
    let e = refuse("ratio.exr", with_blocks(header(32768, 32, 64, 3), 2));
    assert!(e.contains("at most 1032:1"), "{e}");
    // DWAA (lossy, not written by strahl) is not taken.
    let e = refuse("dwaa.exr", with_blocks(header(8, 8, 1, 8), 1));
    assert!(e.contains("dwaa"), "{e}");

    // A real part, damaged in its block table and blocks.
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell.toml");
    let good = dir.path("good.exr");
    let o =
        strahl(&["render", scene.to_str().unwrap(), "-o", good.to_str().unwrap(), "--width", "40", "--height", "40"]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let bytes = std::fs::read(&good).unwrap();
    std::fs::remove_file(&good).unwrap();
    // 40 lines: three ZIP blocks; the offset table follows the header.
    let start = header_end(&bytes);
    let offset = |k: usize| u64::from_le_bytes(bytes[start + 8 * k..start + 8 * k + 8].try_into().unwrap()) as usize;
    let patched = |at: usize, value: &[u8]| {
        let mut b = bytes.clone();
        b[at..at + value.len()].copy_from_slice(value);
        b
    };
    let e = refuse("offset.exr", patched(start + 8, &u64::MAX.to_le_bytes()));
    assert!(e.contains("block 1 of 3: its offset"), "{e}");
    let e = refuse("line.exr", patched(offset(2), &5i32.to_le_bytes()));
    assert!(e.contains("block 2 of 3: holds line 5 where line 32 belongs"), "{e}");
    let e = refuse("size.exr", patched(offset(0) + 4, &i32::MAX.to_le_bytes()));
    assert!(e.contains("block 0 of 3: declares 2147483647 stored bytes"), "{e}");
    let e = refuse("tiny.exr", patched(offset(0) + 4, &1i32.to_le_bytes()));
    assert!(e.contains("block 0 of 3: declares") && e.contains("at most 1032:1"), "{e}");
    let e = refuse("cut.exr", bytes[..bytes.len() - 100].to_vec());
    assert!(e.contains("block 2 of 3: declares"), "{e}");
    // A block whose bytes do not inflate to its pixels fails while merging, naming the file,
    // and leaves nothing.
    let mut garbage = bytes.clone();
    let at = offset(1) + 8;
    for b in &mut garbage[at..at + 16] {
        *b ^= 0x5a;
    }
    let e = refuse("garbage.exr", garbage);
    assert!(e.contains("cannot read its pixels"), "{e}");
    assert_eq!(dir.entries(), Vec::<String>::new());
}

/// Where the header of the single-part file `bytes` ends (its attributes, then a NUL).
fn header_end(bytes: &[u8]) -> usize {
    let mut at = 8;
    loop {
        if bytes[at] == 0 {
            return at + 1;
        }
        for _ in 0..2 {
            at += bytes[at..].iter().position(|&c| c == 0).unwrap() + 1;
        }
        let size = i32::from_le_bytes(bytes[at..at + 4].try_into().unwrap()) as usize;
        at += 4 + size;
    }
}

/// Renders the Cornell box at `w × h` in `n` tiles into `dir`; returns the parts.
fn tiles(dir: &TempDir, w: u32, h: u32, n: u32, extra: &[&str]) -> Vec<PathBuf> {
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell.toml");
    let (ws, hs) = (w.to_string(), h.to_string());
    (1..=n)
        .map(|i| {
            let part = dir.path(&format!("t{i}.exr"));
            let tile = format!("{i}/{n}");
            let mut args = vec!["render", scene.to_str().unwrap(), "-o", part.to_str().unwrap(), "--width", &ws];
            args.extend(["--height", &hs, "--spp", "1", "--tile", &tile]);
            args.extend(extra);
            let o = strahl(&args);
            assert!(o.status.success(), "{}", text(&o.stderr));
            part
        })
        .collect()
}

#[test]
fn a_merge_stays_under_its_memory_bound_and_within_max_memory() {
    let dir = TempDir::new("memory");
    // 1600 × 1200, every pass: 4 parts of 21 MB raw (88 bytes a pixel), blocks of 2.2 MB.
    let parts = tiles(&dir, 1600, 1200, 4, &["--passes", "all"]);
    let plan =
        strahl::output::merge::plan(parts.iter().cloned().map(strahl::output::merge::Source::File).collect()).unwrap();
    let names: Vec<&str> = parts.iter().map(|p| p.to_str().unwrap()).collect();
    let out = dir.path("merged.exr");
    let mut args = vec!["merge", out.to_str().unwrap(), "--threads", "2"];
    args.extend(&names);
    let (code, stderr, rss) = run_measured(&dir, &args);
    assert_eq!(code, Some(0), "{stderr}");
    let bound = plan.memory(2);
    if let Some(rss) = rss {
        eprintln!("merge peak RSS {:.1} MB, bound {:.1} MB", rss as f64 / 1e6, bound as f64 / 1e6);
        assert!(rss <= bound, "peak RSS {rss} over the bound {bound}");
    }
    let whole = std::fs::read(&out).unwrap();

    // A budget that holds one thread but not two: the same file, on one thread, saying so.
    let budget = ((plan.memory(1) + plan.memory(2)) / 2).to_string();
    let mut args = vec!["merge", out.to_str().unwrap(), "--threads", "2", "--max-memory", &budget];
    args.extend(&names);
    std::fs::remove_file(&out).unwrap();
    let o = strahl(&args);
    assert!(o.status.success(), "{}", text(&o.stderr));
    assert!(text(&o.stderr).contains("merging on 1 of 2 threads"), "{}", text(&o.stderr));
    assert!(std::fs::read(&out).unwrap() == whole, "one thread gives the same bytes");
    std::fs::remove_file(&out).unwrap();

    // A budget under one thread's: refused in one line, nothing written.
    let small = (plan.memory(1) - 1).to_string();
    let mut args = vec!["merge", out.to_str().unwrap(), "--max-memory", &small];
    args.extend(&names);
    let e = fails(&dir, &args);
    assert!(e.contains("more than the memory budget"), "{e}");
}
