//! strahl: an offline Whitted-style ray tracer that traces through Intel Embree, with a
//! pure-Rust BVH that renders the same scenes and cross-checks Embree's hits.
//!
//! The rooms follow the data of a frame (docs/architecture.md): [`scene`] (plain data and
//! its loaders) → [`accel`] (the tracing interface and its two backends) → [`integrator`]
//! (the tile loop and the Whitted shading) → [`output`] (the film, its passes and the files
//! it is written to), driven by a [`job`]; [`verify`] holds the tools that check and time the
//! backends, [`sys`] what talks to the operating system.

// `!(x > 0.0)` is used on purpose where a NaN must count as "not positive".
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod accel;
pub mod bsdf;
pub mod camera;
pub mod farm;
pub mod geometry;
pub mod integrator;
pub mod job;
pub mod light;
pub mod material;
pub mod math;
pub mod normal_map;
pub mod optics;
pub mod output;
pub mod sampler;
pub mod sampling;
pub mod scene;
pub mod shading;
pub mod surface;
pub mod sys;
pub mod texture;
pub mod verify;

pub use accel::{Accel, Hit, TraceError};
pub use math::{Aabb, Ray, Vec2, Vec3};
pub use scene::Scene;
