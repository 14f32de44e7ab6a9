//! strahl: an offline Whitted-style ray tracer that traces through Intel Embree, with a
//! pure-Rust BVH that renders the same scenes and cross-checks Embree's hits.

// `!(x > 0.0)` is used on purpose where a NaN must count as "not positive".
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod accel;
pub mod bench;
pub mod bsdf;
pub mod bvh;
pub mod camera;
pub mod checkpoint;
pub mod crosscheck;
pub mod cryptomatte;
pub mod embree;
pub mod film;
pub mod geometry;
pub mod ids;
pub mod integrator;
pub mod io;
pub mod light;
pub mod material;
pub mod math;
pub mod memory;
pub mod merge;
pub mod optics;
pub mod passes;
pub mod region;
pub mod sampler;
pub mod sampling;
pub mod scene;
pub mod signals;
pub mod surface;
pub mod texture;
pub mod workload;

pub use accel::{Accel, Hit, TraceError};
pub use math::{Aabb, Ray, Vec2, Vec3};
pub use scene::Scene;
