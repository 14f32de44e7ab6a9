//! A polygon's corners (the bytes as f32 triples): triangulation never panics, never emits
//! more than n − 2 triangles, and only indexes its corners.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let corners: Vec<strahl::math::Vec3> = data
        .chunks_exact(12)
        .map(|c| {
            let f = |i: usize| f32::from_le_bytes([c[i], c[i + 1], c[i + 2], c[i + 3]]);
            strahl::math::Vec3::new(f(0), f(4), f(8))
        })
        .collect();
    if corners.len() < 3 || corners.iter().any(|c| !c.is_finite()) {
        return;
    }
    let mut out = Vec::new();
    let _ = strahl::scene::load::polygon::triangulate(&corners, &mut out);
    assert!(out.len() <= corners.len() - 2, "{} triangles for {} corners", out.len(), corners.len());
    assert!(out.iter().flatten().all(|&i| (i as usize) < corners.len()));
});
