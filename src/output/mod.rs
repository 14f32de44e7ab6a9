//! What a render produces and where it goes: the [`film`] and its [`passes`] (with the
//! [`ids`] and [`cryptomatte`] of the objects hit), the [`region`] of the image a process
//! renders, and the files: OpenEXR ([`exr`], streamed while rendering by [`exr_stream`]), the
//! PNG preview ([`png`]), the EXR header's [`metadata`], the [`checkpoint`] of a render under
//! way, the [`merge`] of the regions of one image and its [`denoise`]ing.

pub mod checkpoint;
pub mod cryptomatte;
pub mod denoise;
pub mod exr;
pub mod exr_stream;
mod exr_zip;
pub mod film;
pub mod ids;
pub mod layer_name;
pub mod merge;
pub mod metadata;
pub mod passes;
pub mod png;
pub mod region;
