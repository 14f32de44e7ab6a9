//! `strahl merge OUT.exr PARTS…`: joins the EXRs of regions of one render (`render --region`
//! or `--tile I/N`) into the whole image, streamed to a temporary file and renamed
//! ([`strahl::output::merge`] states the rules: one scene and settings, no overlap, a complete cover,
//! sizes backed by the files, the memory bound).

use std::path::PathBuf;

use anyhow::bail;
use clap::Args;
use strahl::output::merge::Source;
use strahl::sys::atomic::commit_all;
use strahl::sys::same_file::same_file;

/// Arguments of `strahl merge`.
#[derive(Args, Debug)]
pub struct MergeArgs {
    /// The merged OpenEXR file to write.
    #[arg(value_name = "OUT.exr")]
    output: PathBuf,
    /// The parts: EXRs of regions of one render, in any order.
    #[arg(value_name = "PARTS", required = true)]
    parts: Vec<PathBuf>,
    /// Threads compressing the merged file [default: one per core; fewer if the memory
    /// budget holds fewer].
    #[arg(long, value_name = "T", value_parser = clap::value_parser!(u32).range(1..=4096))]
    threads: Option<u32>,
    /// Refuse, before writing anything, a merge whose memory bound exceeds this: bytes or
    /// K/M/G/T (e.g. 8G) [default: as `render`'s].
    #[arg(long, value_name = "SIZE", value_parser = strahl::sys::memory::parse_size)]
    max_memory: Option<u64>,
}

pub fn run(args: MergeArgs) -> anyhow::Result<()> {
    let out = &args.output;
    if !out.extension().is_some_and(|e| e.eq_ignore_ascii_case("exr")) {
        bail!("{}: the merged output must have the extension .exr", out.display());
    }
    for part in &args.parts {
        if same_file(part, out) {
            bail!("{}: is both a part and the output; merge never overwrites a part", out.display());
        }
    }
    let plan = strahl::output::merge::plan(args.parts.iter().cloned().map(Source::File).collect())?;
    let threads = strahl::job::thread_count(args.threads.map(|t| t as usize));
    let budget = args.max_memory.or_else(|| strahl::sys::memory::default_limit().map(|l| l.bytes)).unwrap_or(u64::MAX);
    let fit = plan.threads_within(threads, budget)?;
    if fit < threads {
        eprintln!("note: merging on {fit} of {threads} threads, which the memory budget holds");
    }
    if let Some(line) = strahl::sys::temporary::remove_stale_saying(strahl::sys::atomic::directory_of(out)) {
        eprintln!("{line}");
    }
    commit_all(vec![plan.stage(out, fit)?])?;
    let bytes = std::fs::metadata(out).map_or(0, |m| m.len());
    println!("merged {} parts into {} ({:.1} MB)", args.parts.len(), out.display(), bytes as f64 / 1e6);
    Ok(())
}
