//! A render as one job: its settings checked, then the budget ([`memory`]), the accel, the
//! integrator and the outputs.

pub mod memory;
