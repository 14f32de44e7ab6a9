//! The pinhole camera against the lecture's construction: the basis, the field of view the
//! pixel-centre rays span, the centre ray, and the errors.

use glam::DVec3;
use strahl::camera::{Camera, CameraError};
use strahl::math::Vec3;
use strahl::scene::CameraSpec;

fn spec(eye: [f32; 3], target: [f32; 3], up: [f32; 3], fov_deg: f32) -> CameraSpec {
    CameraSpec {
        eye: Vec3::from(eye),
        target: Vec3::from(target),
        up: Vec3::from(up),
        fov_deg,
        lens: Default::default(),
    }
}

/// A few cameras in general position (and the textbook one).
fn cameras() -> Vec<CameraSpec> {
    vec![
        spec([0.0, 0.0, 5.0], [0.0, 0.0, 0.0], [0.0, 1.0, 0.0], 40.0),
        spec([1.0, 2.0, 3.0], [-2.0, 0.5, 1.0], [0.1, 1.0, 0.2], 60.0),
        spec([-7.5, 3.25, -0.5], [4.0, -1.0, 2.0], [0.0, 0.0, 1.0], 25.0),
        spec([0.3, 100.0, 0.2], [0.0, 0.0, 0.0], [0.0, 0.0, -1.0], 120.0),
    ]
}

/// The angle between two directions, accurate at every size: atan2(|a×b|, a·b).
fn angle(a: Vec3, b: Vec3) -> f64 {
    let (a, b) = (a.as_dvec3(), b.as_dvec3());
    a.cross(b).length().atan2(a.dot(b))
}

#[test]
fn basis_is_orthonormal_right_handed_and_looks_at_the_target() {
    for s in cameras() {
        let (u, v, w) = Camera::new(&s, 64, 48).unwrap().basis();
        for (name, x) in [("u", u), ("v", v), ("w", w)] {
            assert!((x.length() - 1.0).abs() < 1e-6, "{name} = {x} is not unit for {s:?}");
        }
        assert!(u.dot(v).abs() < 1e-6 && v.dot(w).abs() < 1e-6 && w.dot(u).abs() < 1e-6, "{s:?}");
        // Right-handed: u × v = w.
        assert!((u.cross(v) - w).length() < 1e-6, "{s:?}: u×v = {} but w = {w}", u.cross(v));
        // w points from the target back to the eye; u is perpendicular to up; v leans to up.
        let back = (s.eye - s.target).normalize();
        assert!((w - back).length() < 1e-6);
        assert!(u.dot(s.up).abs() < 1e-6 && v.dot(s.up) > 0.0);
    }
}

#[test]
fn centre_rows_span_the_vertical_fov_minus_one_pixel() {
    // The top and bottom rows' centres lie half a pixel inside the image plane's edges:
    // v = ±t(1 − 1/H) with t = tan(fov/2), so the angle between their rays (middle column of
    // an odd width, u = 0) is 2·atan((1 − 1/H)·tan(fov/2)): the fov less the two outer half
    // pixels, one pixel's worth of the image plane.
    for s in cameras() {
        for (w, h) in [(5u32, 3u32), (101, 75), (33, 480)] {
            let c = Camera::new(&s, w, h).unwrap();
            let (top, bottom) = (c.centre_ray(w / 2, 0), c.centre_ray(w / 2, h - 1));
            let half = 0.5 * (s.fov_deg as f64).to_radians();
            let expected = 2.0 * ((1.0 - 1.0 / h as f64) * half.tan()).atan();
            let got = angle(top.dir, bottom.dir);
            assert!((got - expected).abs() / expected <= 1e-5, "{s:?} {w}×{h}: {got} vs {expected}");
            // On the image plane the missing part is exactly one pixel (two half pixels at
            // the edges). As an angle it is less than the angle of one edge pixel, because
            // the outer half of a pixel subtends less than its inner half (atan is concave).
            let missing = 2.0 * half - got;
            let edge_pixel = half - ((1.0 - 2.0 / h as f64) * half.tan()).atan();
            assert!(missing > 0.0 && missing < edge_pixel, "{s:?} {w}×{h}");
            // The top row looks up (+v), the bottom row down; both start at the eye.
            let (_, v, _) = c.basis();
            assert!(top.dir.dot(v) > 0.0 && bottom.dir.dot(v) < 0.0);
            assert_eq!(top.org, s.eye);
        }
    }
}

#[test]
fn left_and_right_columns_span_the_horizontal_fov_from_the_aspect() {
    for s in cameras() {
        let (w, h) = (64u32, 27u32); // odd height: the middle row has v = 0
        let c = Camera::new(&s, w, h).unwrap();
        let (left, right) = (c.centre_ray(0, h / 2), c.centre_ray(w - 1, h / 2));
        let r = (0.5 * (s.fov_deg as f64).to_radians()).tan() * w as f64 / h as f64;
        let expected = 2.0 * ((1.0 - 1.0 / w as f64) * r).atan();
        let got = angle(left.dir, right.dir);
        assert!((got - expected).abs() / expected <= 1e-5, "{s:?}: {got} vs {expected}");
        let (u, _, _) = c.basis();
        assert!(left.dir.dot(u) < 0.0 && right.dir.dot(u) > 0.0);
    }
}

#[test]
fn centre_pixel_of_an_odd_image_looks_exactly_along_minus_w() {
    for s in cameras() {
        for (w, h) in [(1u32, 1u32), (3, 3), (101, 75), (641, 481)] {
            let c = Camera::new(&s, w, h).unwrap();
            let (_, _, basis_w) = c.basis();
            let r = c.centre_ray(w / 2, h / 2);
            assert_eq!(r.dir, -basis_w, "{s:?} {w}×{h}");
            assert_eq!((r.org, r.tnear, r.tfar), (s.eye, 0.0, f32::INFINITY));
        }
    }
}

#[test]
fn every_ray_is_the_lecture_formula_with_a_unit_direction() {
    // Against the construction written out again in f64, for every pixel of a small image
    // and at sample positions other than the centre.
    let s = cameras()[1];
    let (w, h) = (7u32, 5u32);
    let c = Camera::new(&s, w, h).unwrap();
    let e = s.eye.as_dvec3();
    let bw = (e - s.target.as_dvec3()).normalize();
    let bu = s.up.as_dvec3().cross(bw).normalize();
    let bv = bw.cross(bu);
    let t = (0.5 * (s.fov_deg as f64).to_radians()).tan();
    let r = t * w as f64 / h as f64;
    for y in 0..h {
        for x in 0..w {
            for (ox, oy) in [(0.5f32, 0.5f32), (0.0, 0.0), (0.9, 0.25)] {
                let pu = -r + 2.0 * r * (x as f64 + ox as f64) / w as f64;
                let pv = t - 2.0 * t * (y as f64 + oy as f64) / h as f64;
                let expected: DVec3 = (pu * bu + pv * bv - bw).normalize();
                let got = c.ray(x, y, strahl::math::Vec2::new(ox, oy)).dir;
                assert!((got.as_dvec3() - expected).length() < 1e-7, "pixel ({x}, {y}) + ({ox}, {oy})");
                assert!((got.length() - 1.0).abs() < 1e-6);
            }
        }
    }
}

#[test]
fn bad_cameras_are_refused_with_one_line() {
    let ok = spec([0.0, 1.0, 5.0], [0.0, 1.0, 0.0], [0.0, 1.0, 0.0], 40.0);
    // up parallel (and anti-parallel, and nearly parallel) to the view direction.
    for up in [[0.0, 0.0, -1.0], [0.0, 0.0, 3.0], [1e-9, 0.0, -1.0]] {
        let e = Camera::new(&CameraSpec { up: Vec3::from(up), ..ok }, 4, 4).unwrap_err();
        assert!(matches!(e, CameraError::UpParallelToView { .. }), "{up:?}: {e:?}");
        assert!(e.to_string().starts_with("camera: up") && e.to_string().contains("parallel to the view direction"));
    }
    let e = Camera::new(&CameraSpec { target: ok.eye, ..ok }, 4, 4).unwrap_err();
    assert_eq!(e, CameraError::EyeIsTarget(ok.eye));
    assert_eq!(e.to_string(), "camera: eye and target are the same point [0, 1, 5], so there is no view direction");
    for fov in [0.0, -10.0, 180.0, 200.0] {
        let e = Camera::new(&CameraSpec { fov_deg: fov, ..ok }, 4, 4).unwrap_err();
        assert_eq!(e, CameraError::FovOutOfRange(fov));
    }
    assert!(matches!(Camera::new(&ok, 0, 4), Err(CameraError::EmptyImage { width: 0, height: 4 })));
    let e = Camera::new(&CameraSpec { target: Vec3::new(0.0, f32::NAN, 0.0), ..ok }, 4, 4).unwrap_err();
    assert!(e.to_string().starts_with("camera: target") && !e.to_string().contains('\n'));
}
