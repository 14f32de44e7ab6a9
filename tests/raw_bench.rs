//! The yardstick of `strahl bench` answers as strahl's wrapper does: the raw `rtcIntersect1`
//! and `rtcIntersect8` loops (`strahl::accel::embree::raw_bench`) keep, for every ray, the hit that
//! `EmbreeAccel::intersect` and `intersect_batch` hand over (distance, normal, barycentrics,
//! ids, bit for bit), and the raw any-hit loops the same answers as `occluded`; on the
//! Stanford bunny, 40,000 rays of each kind, two threads.

mod common;

use strahl::accel::Hit;
use strahl::accel::embree::raw_bench::{RawHit, RawRays};
use strahl::accel::embree::{BuildOptions, Device, DeviceOptions, EmbreeAccel};
use strahl::verify::bench::{self, CHUNK};
use strahl::verify::workload::{self, RayKind};

fn same(raw: &RawHit, hit: &Option<Hit>) -> bool {
    match hit {
        None => !raw.is_hit(),
        Some(h) => {
            raw.is_hit()
                && raw.t.to_bits() == h.t.to_bits()
                && raw.ng.map(f32::to_bits) == h.ng.to_array().map(f32::to_bits)
                && (raw.u.to_bits(), raw.v.to_bits()) == (h.u.to_bits(), h.v.to_bits())
                && (raw.prim_id, raw.geom_id) == (h.prim_id, h.geom_id)
        }
    }
}

#[test]
fn the_raw_loops_keep_the_hits_the_wrapper_hands_over() {
    let Some(dir) = common::data_dir() else { return };
    let scene = strahl::scene::from_mesh_file(dir.join("stanford/bun_zipper.ply")).unwrap().scene;
    bench::pool(2).unwrap().install(|| {
        let device = Device::with_options(DeviceOptions { threads: Some(2) }).unwrap();
        let embree = EmbreeAccel::build(&device, &scene, BuildOptions::default()).unwrap();
        for kind in RayKind::ALL {
            let rays = workload::rays(&scene, kind, 40_000, 3, &embree).unwrap();
            assert!(rays.len() > 2 * CHUNK, "{kind}: several chunks, a partial packet at the end");
            let raw_rays = RawRays::new(&rays).expect("rays");
            if kind == RayKind::Shadow {
                let mut want = vec![false; rays.len()];
                bench::trace_occluded(&embree, &rays, &mut want, false).unwrap();
                assert!(want.iter().any(|&o| o) && want.iter().any(|&o| !o), "{kind}: blocked and free rays");
                for packets in [false, true] {
                    let mut got = vec![7u8; rays.len()];
                    bench::trace_raw_occluded(embree.embree_scene(), packets, &raw_rays, &mut got).unwrap();
                    assert!(got.iter().zip(&want).all(|(&g, &w)| g == w as u8), "{kind}, packets {packets}");
                }
                continue;
            }
            let mut want = vec![None; rays.len()];
            bench::trace(&embree, &rays, &mut want, false).unwrap();
            let hits = want.iter().filter(|h| h.is_some()).count();
            assert!(hits > rays.len() / 20, "{kind}: {hits} hits");
            for packets in [false, true] {
                let mut got = vec![RawHit::default(); rays.len()];
                bench::trace_raw(embree.embree_scene(), packets, &raw_rays, &mut got).unwrap();
                let differ = got.iter().zip(&want).filter(|(g, w)| !same(g, w)).count();
                assert_eq!(differ, 0, "{kind}, packets {packets}: {differ} of {} rays", rays.len());
            }
        }
    });
}
