//! `strahl denoise IN.exr -o OUT.exr`: denoises a strahl EXR with Intel Open Image Denoise,
//! keeping every layer and adding Blender's denoising layers
//! ([`strahl::output::denoise`] states what is written and why).

use std::path::PathBuf;

use anyhow::bail;
use clap::Args;

/// Arguments of `strahl denoise`.
#[derive(Args, Debug)]
pub struct DenoiseArgs {
    /// The EXR to denoise: any strahl render with the combined, albedo and normal passes.
    #[arg(value_name = "IN.exr")]
    input: PathBuf,
    /// The denoised EXR to write (never the input).
    #[arg(short, long, value_name = "OUT.exr")]
    output: PathBuf,
}

pub fn run(args: DenoiseArgs) -> anyhow::Result<()> {
    let out = &args.output;
    if !out.extension().is_some_and(|e| e.eq_ignore_ascii_case("exr")) {
        bail!("{}: the denoised output must have the extension .exr", out.display());
    }
    if let Some(line) = strahl::sys::temporary::remove_stale_saying(strahl::sys::atomic::directory_of(out)) {
        eprintln!("{line}");
    }
    strahl::output::denoise::denoise_file(&args.input, out)?;
    println!("denoised {} into {}", args.input.display(), out.display());
    Ok(())
}
