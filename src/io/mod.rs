//! Files strahl reads and writes besides scenes: the rendered image as OpenEXR and as a PNG
//! preview, each written atomically.

pub mod atomic;
pub mod exr;
pub mod png;

pub use atomic::{WriteError, write_atomically};
