//! Helpers shared by the renderer tests: an Embree backend for a scene, a render call, and the
//! lecture's pinhole camera written out again in f64 as an independent reference.

#![allow(dead_code)] // each test file uses a different subset

use glam::DVec3;
use strahl::embree::{BuildOptions, Device, EmbreeAccel};
use strahl::film::Film;
use strahl::integrator::{self, RayCounts};
use strahl::scene::{CameraSpec, Scene};

pub fn accel(scene: &Scene) -> EmbreeAccel {
    let device = Device::new().expect("an Embree device");
    EmbreeAccel::build(&device, scene, BuildOptions::default()).expect("the scene builds")
}

/// Renders `scene` with Embree on the current rayon pool.
pub fn render(scene: &Scene) -> (Film, RayCounts) {
    integrator::render(scene, &accel(scene), &|_| {}).expect("the scene renders")
}

/// `|a − b| / |b|`.
pub fn rel(a: f32, b: f64) -> f64 {
    ((a as f64) - b).abs() / b.abs()
}

/// The lecture's pixel-centre ray direction (unit), computed from scratch in f64:
/// `w = (e−z)/|e−z|`, `u = up×w`, `v = w×u`, `t = tan(fov/2)`, `r = t·W/H`,
/// `u = l + (r−l)(x+0.5)/W`, `v = t + (b−t)(y+0.5)/H`, `s = u·u + v·v − w`.
pub fn lecture_ray(cam: &CameraSpec, width: u32, height: u32, x: u32, y: u32) -> (DVec3, DVec3) {
    let (e, z, up) = (cam.eye.as_dvec3(), cam.target.as_dvec3(), cam.up.as_dvec3());
    let w = (e - z).normalize();
    let u = up.cross(w).normalize();
    let v = w.cross(u);
    let t = (cam.fov_deg as f64).to_radians().mul_add(0.5, 0.0).tan();
    let (b, r) = (-t, t * width as f64 / height as f64);
    let l = -r;
    let su = l + (r - l) * (x as f64 + 0.5) / width as f64;
    let sv = t + (b - t) * (y as f64 + 0.5) / height as f64;
    (e, (su * u + sv * v - w).normalize())
}

/// Films compared bit for bit (so `-0.0 ≠ 0.0` and NaNs compare too).
pub fn same_bits(a: &Film, b: &Film) -> bool {
    let bits3 = |v: &[glam::Vec3]| v.iter().flat_map(|x| x.to_array()).map(f32::to_bits).collect::<Vec<_>>();
    a.width == b.width
        && a.height == b.height
        && a.rgba.iter().flatten().map(|x| x.to_bits()).eq(b.rgba.iter().flatten().map(|x| x.to_bits()))
        && a.depth.iter().map(|x| x.to_bits()).eq(b.depth.iter().map(|x| x.to_bits()))
        && bits3(&a.normal) == bits3(&b.normal)
        && bits3(&a.albedo) == bits3(&b.albedo)
}
