//! Files strahl reads and writes besides scenes: meshes (OBJ with MTL, PLY; gzip-compressed
//! too) in, the rendered image out as OpenEXR and as a PNG preview, each written atomically.

pub mod atomic;
pub mod exr;
pub mod exr_stream;
mod exr_zip;
pub mod gltf;
pub mod mesh;
pub mod metadata;
pub mod obj;
pub mod ply;
pub mod png;
pub mod polygon;
pub mod read;
pub mod same_file;
mod text;

pub use atomic::{WriteError, write_atomically};
pub use mesh::{LoadedMesh, MeshError, MeshFormat, MeshOptions, load_mesh};
