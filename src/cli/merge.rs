//! `strahl merge OUT.exr PARTS…`: joins the EXRs of regions of one render (`render --region`
//! or `--tile I/N`) into the whole image, written atomically ([`strahl::output::merge`] states the
//! rules: one scene and settings, no overlap, a complete cover).

use std::path::PathBuf;

use anyhow::bail;
use clap::Args;
use strahl::sys::atomic::write_atomically;
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
    /// Threads compressing the merged file [default: one per core].
    #[arg(long, value_name = "T", value_parser = clap::value_parser!(u32).range(1..=4096))]
    threads: Option<u32>,
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
    let threads = strahl::job::thread_count(args.threads.map(|t| t as usize));
    let bytes = strahl::output::merge::merge(&args.parts, threads)?;
    write_atomically(out, &bytes)?;
    println!("merged {} parts into {} ({:.1} MB)", args.parts.len(), out.display(), bytes.len() as f64 / 1e6);
    Ok(())
}
