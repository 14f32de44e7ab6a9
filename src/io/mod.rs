//! Reading and writing files: meshes (OBJ with MTL, PLY; gzip-compressed too).

pub mod mesh;
pub mod obj;
pub mod ply;
pub mod polygon;
mod text;

pub use mesh::{LoadedMesh, MeshError, MeshFormat, MeshOptions, load_mesh};
