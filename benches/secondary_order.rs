//! Whether the order of incoherent secondary rays matters to Embree: the diffuse bounce rays
//! of a path tracer's first vertex (a cosine-distributed direction around the facing geometric
//! normal at every camera ray's hit, from the hit moved off the surface), traced on one thread
//!
//! - one at a time in pixel order, as the path tracer traces them (`rtcIntersect1`);
//! - one at a time after a stable sort by direction octant (the sign bits of `d`), the
//!   ordering of MoonRay's and Hyperion's ray queues in its simplest form;
//! - as 8-wide packets ([`Accel::intersect_batch`], `rtcIntersect8`) in pixel order and
//!   after the octant sort (Embree's stream-like path).
//!
//! The sort is timed on its own: a renderer that sorted would pay for it (and for keeping the
//! rays' paths apart, not counted here). Runs alternate between the orders; the table shows
//! each order's median Mrays/s.
//!
//! `cargo bench --bench secondary_order [-- SCENE.toml [WIDTH]]` (default
//! `scenes/cornell-path.toml` at 512 × 512).

use std::path::PathBuf;
use std::time::Instant;

use strahl::accel::embree::{BuildOptions, Device, DeviceOptions, EmbreeAccel};
use strahl::accel::{Accel, Hit};
use strahl::bsdf::Frame;
use strahl::math::{Ray, Vec2, Vec3, offset_ray_origin};
use strahl::sampling::square_to_cosine_hemisphere;
use strahl::verify::workload;

const RUNS: usize = 7;

/// A 64-bit mix (SplitMix64's finaliser) for the bounce directions' random numbers.
fn mix(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

fn unit(z: u64) -> f32 {
    (z >> 40) as f32 / (1u64 << 24) as f32
}

/// The diffuse bounce of `ray` at its hit `h`, drawn with the numbers of index `i`.
fn bounce(ray: &Ray, h: &Hit, i: u64) -> Ray {
    let n = h.ng.normalize_or_zero();
    let n = if ray.dir.dot(n) < 0.0 { n } else { -n };
    let u = Vec2::new(unit(mix(2 * i + 1)), unit(mix(2 * i + 2)));
    let dir = Frame::from_normal(n).to_world(square_to_cosine_hemisphere(u));
    Ray::new(offset_ray_origin(ray.at(h.t), n), dir)
}

fn octant(d: Vec3) -> u8 {
    (d.x < 0.0) as u8 | ((d.y < 0.0) as u8) << 1 | ((d.z < 0.0) as u8) << 2
}

fn trace(accel: &EmbreeAccel, rays: &[Ray], hits: &mut [Option<Hit>], packets: bool) -> f64 {
    let start = Instant::now();
    if packets {
        accel.intersect_batch(rays, hits).unwrap();
    } else {
        for (r, h) in rays.iter().zip(hits.iter_mut()) {
            *h = accel.intersect(r).unwrap();
        }
    }
    start.elapsed().as_secs_f64()
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).filter(|a| !a.starts_with("--")).collect();
    let path = args
        .first()
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-path.toml"));
    let side: u32 = args.get(1).map_or(512, |w| w.parse().expect("WIDTH is a number"));
    let scene = strahl::scene::load::file::load(&path).unwrap_or_else(|e| panic!("{e}")).scene;
    let device = Device::with_options(DeviceOptions { threads: Some(1) }).expect("an Embree device");
    let accel = EmbreeAccel::build(&device, &scene, BuildOptions::default()).expect("the scene's BVH");
    accel.prepare_thread();

    let camera = strahl::camera::Camera::new(&workload::primary_camera(&scene), side, side).expect("a camera");
    let primary = workload::camera_rays(&camera);
    let mut rays = Vec::with_capacity(primary.len());
    for (i, r) in primary.iter().enumerate() {
        if let Some(h) = accel.intersect(r).unwrap() {
            rays.push(bounce(r, &h, i as u64));
        }
    }
    let sort_start = Instant::now();
    let mut sorted = rays.clone();
    sorted.sort_by_key(|r| octant(r.dir));
    let sort_s = sort_start.elapsed().as_secs_f64();

    let mut hits = vec![None; rays.len()];
    let orders: [(&str, &[Ray], bool); 4] = [
        ("pixel order, single rays", &rays, false),
        ("octant-sorted, single rays", &sorted, false),
        ("pixel order, 8-wide packets", &rays, true),
        ("octant-sorted, 8-wide packets", &sorted, true),
    ];
    let mut times = vec![Vec::new(); orders.len()];
    for _ in 0..RUNS {
        for (k, &(_, r, packets)) in orders.iter().enumerate() {
            times[k].push(trace(&accel, r, &mut hits, packets));
        }
    }
    let load = std::fs::read_to_string("/proc/loadavg").unwrap_or_default();
    println!("{}: {} bounce rays of {side}² camera rays, 1 thread, load {}", path.display(), rays.len(), load.trim());
    for ((name, ..), mut t) in orders.iter().zip(times) {
        t.sort_by(f64::total_cmp);
        let median = t[t.len() / 2];
        println!("{name:32} {:7.2} Mrays/s (median of {RUNS})", rays.len() as f64 / median / 1e6);
    }
    println!("{:32} {:7.2} Mrays/s (the sort alone)", "octant sort", rays.len() as f64 / sort_s / 1e6);
}
