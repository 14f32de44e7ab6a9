//! The tools that check and time the backends rather than render: the standard ray sets
//! ([`workload`]), the cross-check of Embree's hits against the native BVH's ([`crosscheck`])
//! and the throughput benchmark ([`bench`](mod@bench), beside Embree's own loops in
//! [`crate::accel::embree::raw_bench`]).

pub mod bench;
pub mod crosscheck;
pub mod workload;
