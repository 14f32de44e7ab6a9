//! The options of `strahl render` that say where and how its image is written: the EXR and
//! the PNG preview, the EXR's channel names, precision and compression, and the checkpoint
//! (flattened into the render's arguments, so `farm slurm` checks them with the same parser).

use std::path::PathBuf;

use clap::Args;
use strahl::job::Output;
use strahl::output::exr::Compression;

use super::LayoutArg;

/// Where and how `strahl render` writes its image.
#[derive(Args, Debug)]
pub struct OutputArgs {
    /// Where to write the OpenEXR image (linear RGBA, Z, N, albedo).
    #[arg(short, long, value_name = "OUT.exr")]
    pub output: PathBuf,
    /// Also write an 8-bit sRGB PNG preview here.
    #[arg(long, value_name = "OUT.png")]
    pub png: Option<PathBuf>,
    /// Exposure of the PNG preview in stops: its radiance is multiplied by 2^EV.
    #[arg(long, value_name = "EV", default_value_t = 0.0, allow_negative_numbers = true)]
    pub exposure: f32,
    /// Channel naming of the EXR: Blender's multilayer names, or Nuke's.
    #[arg(long, value_enum, default_value_t = LayoutArg::Blender)]
    pub exr_layout: LayoutArg,
    /// The view layer of Blender's layout: channels are named NAME.Pass.C (Blender's
    /// multilayer names; dots allowed, as Blender writes them; at most 63 bytes, no control
    /// characters) [default: ViewLayer].
    #[arg(long, value_name = "NAME", allow_hyphen_values = true)]
    pub layer_name: Option<String>,
    /// Store colour passes and normals as half floats (depth, distance, position, indices, Cryptomatte stay float32).
    #[arg(long)]
    pub half: bool,
    /// EXR compression: none, rle, zips, zip, piz, pxr24, b44, b44a.
    #[arg(long, value_name = "C", default_value = "zip", value_parser = strahl::job::parse_compression)]
    pub compression: Compression,
    /// Save the finished tiles to OUT.exr.checkpoint every this many seconds; SIGINT and SIGTERM save it too
    /// before exiting. 0 saves after every tile, each save writing all tiles finished so far: a 960×540
    /// Cornell box took 2× as long at 4 spp, 66× at 1 spp, and its ETA, extrapolated linearly, runs short.
    #[arg(long, value_name = "SECONDS", default_value_t = 60.0, allow_negative_numbers = true)]
    pub checkpoint_every: f64,
    /// Continue from OUT.exr.checkpoint (when it exists): trace only the tiles it lacks. The
    /// result is the same bytes as an uninterrupted render.
    #[arg(long)]
    pub resume: bool,
    /// The frame number the image is of, written to the EXR header as Blender's `Frame` and
    /// `Time` (a farm or the Blender add-on rendering an animation passes it); no pixel changes.
    #[arg(long, value_name = "N", default_value_t = 1)]
    pub frame: u32,
    /// Frames per second for the header's `Time` timecode (`hh:mm:ss:ff`).
    #[arg(long, value_name = "FPS", default_value_t = 24, value_parser = clap::value_parser!(u32).range(1..=1000))]
    pub fps: u32,
}

impl OutputArgs {
    /// The job's output (checked by [`Output::check`] before the scene is loaded).
    pub fn into_output(self) -> Output {
        Output {
            exr: self.output,
            png: self.png,
            exposure: self.exposure,
            layout: self.exr_layout.into(),
            layer_name: self.layer_name,
            half: self.half,
            compression: self.compression,
            checkpoint_every: self.checkpoint_every,
            resume: self.resume,
            frame: self.frame,
            fps: self.fps,
        }
    }
}
