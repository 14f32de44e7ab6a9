//! Helpers shared by the integration tests (and the benches, through `#[path]`).

pub mod ply_stopgap;
