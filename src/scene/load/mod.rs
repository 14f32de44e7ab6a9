//! The readers that make a [`crate::scene::Scene`]: the TOML scene [`file`](mod@file), glTF files
//! ([`gltf`] reads the file, [`gltf_scene`] places it in the world) and the mesh files a scene
//! names (OBJ with MTL, PLY; gzip-compressed too: [`mesh`]). Nothing downstream knows which
//! format the geometry came from.

pub mod file;
pub mod gltf;
pub mod gltf_extensions;
pub mod gltf_instancing;
pub mod gltf_modes;
pub mod gltf_morph;
pub mod gltf_scene;
pub mod gltf_sparse;
pub mod mesh;
pub mod obj;
pub mod ply;
pub mod polygon;
mod text;

pub use mesh::{LoadedMesh, MeshError, MeshFormat, MeshOptions, load_mesh};
