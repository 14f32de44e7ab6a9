//! The lecture's pinhole camera: ray generation, the first of the tracer's three steps.
//!
//! From the eye `e`, the target `z` and the `up` vector it builds the orthonormal basis
//!
//! ```text
//! w = (e − z) / |e − z|      (points backwards, away from what the camera sees)
//! u = up × w / |up × w|      (to the right)
//! v = w × u                  (up in the image)
//! ```
//!
//! and puts the image plane at distance `d` in front of the eye (along `−w`), with edges
//! `t = d·tan(fov/2)`, `b = −t`, `r = t·W/H`, `l = −r` from the vertical field of view and the
//! aspect ratio. Pixel `(x, y)`, with `y = 0` the top row, is the square
//! `[x, x+1) × [y, y+1)`; the point `(x + ox, y + oy)` inside it (`ox = oy = 0.5` is the
//! centre) lies at image-plane coordinates
//!
//! ```text
//! u = l + (r − l)(x + ox)/W,    v = t + (b − t)(y + oy)/H
//! ```
//!
//! and its ray is `r(t) = e + t·s/|s|` with `s = u·u + v·v − d·w`. The direction has unit
//! length, so `t` along a camera ray is a distance from the eye.
//!
//! **Thin lens.** With an aperture of radius `a > 0` and a focus distance `f` (along `−w`;
//! by default `|e − z|`), the ray of image point `s` starts at a point of the lens disk
//! `o = e + a·(x·u + y·v)` (`(x, y)` the lens sample mapped onto the unit disk) and passes
//! through the point `e + f·s` where the pinhole ray meets the plane in focus:
//! `r(t) = o + t·(e + f·s − o)/|e + f·s − o|`. Points on that plane stay sharp (every lens
//! point sees them through the same pixel point); a point at distance `z` spreads over a
//! disk of radius `a·|1/f − 1/z|` on the image plane at distance 1, the thin-lens circle of
//! confusion. `a = 0` is the pinhole above, bit for bit.
//!
//! **Orthographic.** With `ortho_half_height = h > 0` (glTF's `ymag`) the image plane passes
//! through the eye with edges `t = h`, `b = −t`, `r = t·W/H`, `l = −r` (metres), and every ray
//! leaves its own point of it along the view direction: `r(t) = e + u·u + v·v − t·w`. `fov_deg`
//! plays no part, and a lens is refused.
//!
//! The basis and the ray directions are computed in f64 and rounded to f32 once, so a ray is
//! the correctly rounded lecture formula: the centre pixel of an odd-sized image looks exactly
//! along `−w` (as f32), and rays of neighbouring pixels differ by what the geometry says, not
//! by rounding noise.

use glam::DVec3;

use crate::math::{Ray, Vec2, Vec3};
use crate::scene::CameraSpec;

/// Distance `d` from the eye to the image plane. Any `d > 0` gives the same rays (`l, r, b, t`
/// scale with it); 1 keeps the numbers small.
pub const IMAGE_PLANE_DISTANCE: f64 = 1.0;

/// Why a camera cannot be built. Each message is one line and starts with `camera`.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum CameraError {
    #[error("camera: {what} {value} is not finite")]
    NotFinite { what: &'static str, value: String },
    #[error("camera: eye and target are the same point {0}, so there is no view direction")]
    EyeIsTarget(Vec3),
    #[error("camera: up {up} is zero or parallel to the view direction {view}")]
    UpParallelToView { up: Vec3, view: Vec3 },
    #[error("camera: fov_deg {0} is not between 0 and 180 degrees (exclusive)")]
    FovOutOfRange(f32),
    #[error("camera: an orthographic camera has no lens (aperture {0})")]
    OrthographicLens(f32),
    #[error("camera: the image size {width}×{height} has no pixels")]
    EmptyImage { width: u32, height: u32 },
    /// A point or length beyond the range strahl traces ([`crate::scene::magnitude`]).
    #[error("camera: {0}")]
    OutOfRange(String),
}

/// A pinhole camera for an image of `width × height` pixels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    eye: DVec3,
    u: DVec3,
    v: DVec3,
    w: DVec3,
    /// Image-plane edges at distance [`IMAGE_PLANE_DISTANCE`]: left, right, bottom, top.
    l: f64,
    r: f64,
    b: f64,
    t: f64,
    width: u32,
    height: u32,
    /// Lens radius `a` (0: pinhole) and focus distance `f`.
    aperture: f64,
    focus: f64,
    /// Whether the rays are parallel (an orthographic camera; the edges are then in metres).
    ortho: bool,
}

/// A camera ray's cone ([`Camera::ray_cone`]): width `width + spread·d` at distance `d`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RayCone {
    /// Width at the ray's origin (world units).
    pub width: f32,
    /// Growth of the width per unit of distance (the spread angle, radians, small).
    pub spread: f32,
}

impl RayCone {
    /// The cone's width at distance `d`.
    #[inline]
    pub fn width_at(&self, d: f32) -> f32 {
        self.width + self.spread * d
    }

    /// The cone of one of a pixel's `spp` samples: the pixel's cone narrowed by `1/√spp`, at
    /// most 8 times (pbrt-v4 scales its camera-ray differentials so). The samples themselves
    /// filter the pixel; a texture filtered over the whole pixel for each of them would be
    /// blurred twice, and thin detail (text, lines) would fade as the samples add up.
    pub fn per_sample(self, spp: u32) -> RayCone {
        let k = (1.0 / (spp.max(1) as f32).sqrt()).max(0.125);
        RayCone { width: self.width * k, spread: self.spread * k }
    }
}

/// `up` counts as parallel to the view direction when the sine of the angle between them is
/// below this: the basis would then be dominated by rounding.
const PARALLEL_SINE: f64 = 1e-6;

impl Camera {
    /// The camera of `spec` for an image of `width × height` pixels.
    pub fn new(spec: &CameraSpec, width: u32, height: u32) -> Result<Camera, CameraError> {
        let finite = |what: &'static str, v: Vec3| {
            if v.is_finite() { Ok(()) } else { Err(CameraError::NotFinite { what, value: v.to_string() }) }
        };
        finite("eye", spec.eye)?;
        finite("target", spec.target)?;
        finite("up", spec.up)?;
        if !spec.fov_deg.is_finite() {
            return Err(CameraError::NotFinite { what: "fov_deg", value: spec.fov_deg.to_string() });
        }
        if !(spec.fov_deg > 0.0 && spec.fov_deg < 180.0) {
            return Err(CameraError::FovOutOfRange(spec.fov_deg));
        }
        if width == 0 || height == 0 {
            return Err(CameraError::EmptyImage { width, height });
        }
        let (eye, target, up) = (spec.eye.as_dvec3(), spec.target.as_dvec3(), spec.up.as_dvec3());
        let back = eye - target;
        if back == DVec3::ZERO {
            return Err(CameraError::EyeIsTarget(spec.eye));
        }
        let w = back.normalize();
        let side = up.cross(w);
        if up == DVec3::ZERO || side.length() < PARALLEL_SINE * up.length() {
            return Err(CameraError::UpParallelToView { up: spec.up, view: (-w).as_vec3() });
        }
        let u = side.normalize();
        let v = w.cross(u).normalize();
        let ortho = spec.lens.ortho_half_height > 0.0;
        if ortho && spec.lens.aperture != 0.0 {
            return Err(CameraError::OrthographicLens(spec.lens.aperture));
        }
        let t = match ortho {
            true => spec.lens.ortho_half_height as f64,
            false => IMAGE_PLANE_DISTANCE * (0.5 * (spec.fov_deg as f64).to_radians()).tan(),
        };
        let r = t * width as f64 / height as f64;
        let (aperture, focus) = (spec.lens.aperture as f64, spec.lens.focus_distance as f64);
        let h = spec.lens.ortho_half_height;
        if !(aperture >= 0.0 && aperture.is_finite() && focus >= 0.0 && focus.is_finite() && h >= 0.0 && h.is_finite())
        {
            return Err(CameraError::NotFinite { what: "lens", value: format!("{:?}", spec.lens) });
        }
        // Rays from beyond the range would abort Embree (crate::scene::magnitude).
        if let Some((_, problem)) = crate::scene::magnitude::camera_problem(spec) {
            return Err(CameraError::OutOfRange(problem));
        }
        let focus = if focus > 0.0 { focus } else { back.length() };
        Ok(Camera { eye, u, v, w, l: -r, r, b: -t, t, width, height, aperture, focus, ortho })
    }

    /// The basis `(u, v, w)`: right, up, and backwards (away from the target).
    pub fn basis(&self) -> (Vec3, Vec3, Vec3) {
        (self.u.as_vec3(), self.v.as_vec3(), self.w.as_vec3())
    }

    /// The eye point `e`, where every camera ray starts.
    pub fn eye(&self) -> Vec3 {
        self.eye.as_vec3()
    }

    /// The image-plane edges `(l, r, b, t)` at distance [`IMAGE_PLANE_DISTANCE`].
    pub fn edges(&self) -> (f64, f64, f64, f64) {
        (self.l, self.r, self.b, self.t)
    }

    /// The depth of `p` along the view axis: `−w·(p − e)`, its `z` in camera space (Blender's
    /// Depth pass, Cycles' `camera_z_depth`; for a point on a pixel's primary ray of length `t`,
    /// `t·cos θ` with θ the ray's angle to the view axis). Computed in f64, rounded once.
    pub fn depth_of(&self, p: Vec3) -> f32 {
        (-self.w).dot(p.as_dvec3() - self.eye) as f32
    }

    /// Image size in pixels.
    pub fn size(&self) -> (u32, u32) {
        (self.width, self.height)
    }

    /// The unnormalised direction `s = u·u + v·v − d·w` through the point `(x + ox, y + oy)` of
    /// the image, in f64.
    pub fn direction_f64(&self, x: u32, y: u32, offset: Vec2) -> DVec3 {
        let fx = (x as f64 + offset.x as f64) / self.width as f64;
        let fy = (y as f64 + offset.y as f64) / self.height as f64;
        let u = self.l + (self.r - self.l) * fx;
        let v = self.t + (self.b - self.t) * fy;
        u * self.u + v * self.v - IMAGE_PLANE_DISTANCE * self.w
    }

    /// The ray through the point `offset` (each coordinate in `[0, 1)`, `(0.5, 0.5)` the
    /// centre) of pixel `(x, y)`, with a unit direction.
    #[inline]
    pub fn ray(&self, x: u32, y: u32, offset: Vec2) -> Ray {
        let s = self.direction_f64(x, y, offset);
        if self.ortho {
            // `s = u·u + v·v − d·w`: the origin is its part in the image plane.
            let origin = self.eye + s + IMAGE_PLANE_DISTANCE * self.w;
            return Ray::new(origin.as_vec3(), (-self.w).as_vec3()).from_camera();
        }
        Ray::new(self.eye.as_vec3(), (s / s.length()).as_vec3()).from_camera()
    }

    /// The ray cone of a camera ray (Akenine-Möller et al., "Texture Level of Detail
    /// Strategies for Real-Time Ray Tracing", Ray Tracing Gems ch. 20): its width at distance
    /// `d` along the ray is `width + spread·d`. A perspective camera's rays start as points and
    /// spread by the angle of one pixel, `γ = 2·tan(fov/2)/height` (the image plane's height
    /// over its pixels, at distance 1); an orthographic camera's keep the width of one pixel.
    /// A lens's aperture is not counted.
    pub fn ray_cone(&self) -> RayCone {
        let pixel = (self.t - self.b) / self.height as f64;
        if self.ortho {
            RayCone { width: pixel as f32, spread: 0.0 }
        } else {
            RayCone { width: 0.0, spread: (pixel / IMAGE_PLANE_DISTANCE) as f32 }
        }
    }

    /// Whether the rays are parallel (an orthographic camera).
    pub fn is_orthographic(&self) -> bool {
        self.ortho
    }

    /// Whether the camera has a lens (an aperture > 0) and so needs lens samples.
    pub fn has_lens(&self) -> bool {
        self.aperture > 0.0
    }

    /// The ray through the point `offset` of pixel `(x, y)` from the point `lens` (in
    /// `[0, 1)²`, mapped onto the lens disk) of the lens; [`Camera::ray`] for a pinhole.
    #[inline]
    pub fn lens_ray(&self, x: u32, y: u32, offset: Vec2, lens: Vec2) -> Ray {
        if self.aperture == 0.0 {
            return self.ray(x, y, offset);
        }
        let s = self.direction_f64(x, y, offset);
        let (lx, ly) = crate::sampler::concentric_disk(lens);
        let origin = self.eye + self.aperture * (lx * self.u + ly * self.v);
        let dir = self.eye + self.focus * s - origin;
        Ray::new(origin.as_vec3(), (dir / dir.length()).as_vec3()).from_camera()
    }

    /// The ray through the centre of pixel `(x, y)`: the lecture's one ray per pixel.
    pub fn centre_ray(&self, x: u32, y: u32) -> Ray {
        self.ray(x, y, Vec2::splat(0.5))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Lens;

    fn spec(eye: Vec3, target: Vec3, up: Vec3, fov_deg: f32) -> CameraSpec {
        CameraSpec { eye, target, up, fov_deg, lens: Default::default() }
    }

    #[test]
    fn looking_down_minus_z_is_the_textbook_basis() {
        let c = Camera::new(&spec(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO, Vec3::Y, 90.0), 4, 2).unwrap();
        assert_eq!(c.basis(), (Vec3::X, Vec3::Y, Vec3::Z));
        let (l, r, b, t) = c.edges();
        assert!((t - 1.0).abs() < 1e-15 && (b + 1.0).abs() < 1e-15);
        assert!((r - 2.0).abs() < 1e-15 && (l + 2.0).abs() < 1e-15);
    }

    #[test]
    fn the_focus_plane_is_sharp_and_other_planes_blur_by_the_circle_of_confusion() {
        let (a, f) = (0.05f32, 4.0f32);
        let lens = Lens { aperture: a, focus_distance: f, ..Lens::PINHOLE };
        let spec = CameraSpec { lens, ..spec(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO, Vec3::Y, 40.0) };
        let c = Camera::new(&spec, 64, 48).unwrap();
        let pinhole = Camera::new(&CameraSpec { lens: Lens::PINHOLE, ..spec }, 64, 48).unwrap();
        // Where a ray meets the plane z = 5 − depth (perpendicular to the view, at `depth`).
        let at = |r: Ray, depth: f64| {
            let (o, d) = (r.org.as_dvec3(), r.dir.as_dvec3());
            o + d * ((o.z - (5.0 - depth)) / -d.z)
        };
        let lens_points = [Vec2::new(0.0, 0.0), Vec2::new(0.99, 0.5), Vec2::new(0.5, 0.01), Vec2::new(0.3, 0.8)];
        for (x, y) in [(0, 0), (40, 30), (63, 47)] {
            let o = Vec2::new(0.25, 0.75);
            let sharp = at(pinhole.ray(x, y, o), f as f64);
            for &l in &lens_points {
                // On the focus plane every lens point meets the pinhole ray's point.
                assert!((at(c.lens_ray(x, y, o, l), f as f64) - sharp).length() < 1e-5);
                // At depth z the spread from the pinhole point is the lens offset times
                // (1 − z/f): the circle of confusion a·|1/f − 1/z| on the image plane, times z.
                let z = 10.0;
                let spread = (at(c.lens_ray(x, y, o, l), z) - at(pinhole.ray(x, y, o), z)).length();
                let (lx, ly) = crate::sampler::concentric_disk(l);
                let expected = a as f64 * (lx * lx + ly * ly).sqrt() * (1.0 - z / f as f64).abs();
                assert!((spread - expected).abs() < 1e-5 * z, "{spread} vs {expected}");
            }
        }
        // Aperture 0 is the pinhole, bit for bit.
        assert_eq!(pinhole.lens_ray(3, 4, Vec2::splat(0.5), Vec2::splat(0.9)), pinhole.centre_ray(3, 4));
    }

    #[test]
    fn orthographic_rays_are_parallel_from_the_view_rectangle() {
        let lens = Lens { ortho_half_height: 1.5, ..Lens::PINHOLE };
        let spec = CameraSpec { lens, ..spec(Vec3::new(1.0, 2.0, 5.0), Vec3::new(1.0, 2.0, 0.0), Vec3::Y, 40.0) };
        let c = Camera::new(&spec, 4, 2).unwrap();
        assert!(c.is_orthographic());
        // Edges t = 1.5, r = 3 (metres); pixel (0, 0)'s centre is at u = −3 + 6·0.5/4, v = 1.5 − 3·0.5/2.
        let r = c.centre_ray(0, 0);
        assert_eq!(r.org, Vec3::new(1.0 - 2.25, 2.0 + 0.75, 5.0));
        assert_eq!(r.dir, -Vec3::Z);
        assert_eq!(c.centre_ray(3, 1).org, Vec3::new(1.0 + 2.25, 2.0 - 0.75, 5.0));
        // The lens path gives the same rays; a lens is refused.
        assert_eq!(c.lens_ray(2, 1, Vec2::splat(0.5), Vec2::splat(0.3)), c.centre_ray(2, 1));
        let with_lens = CameraSpec { lens: Lens { aperture: 0.1, ..lens }, ..spec };
        assert!(Camera::new(&with_lens, 4, 2).unwrap_err().to_string().contains("orthographic"));
    }

    #[test]
    fn errors_are_one_line_and_named() {
        let ok = spec(Vec3::Z, Vec3::ZERO, Vec3::Y, 40.0);
        let err = |s: CameraSpec, w: u32, h: u32| Camera::new(&s, w, h).unwrap_err().to_string();
        assert!(err(CameraSpec { fov_deg: 180.0, ..ok }, 1, 1).contains("fov_deg 180"));
        assert!(err(CameraSpec { fov_deg: 0.0, ..ok }, 1, 1).contains("fov_deg 0"));
        assert!(err(CameraSpec { fov_deg: f32::NAN, ..ok }, 1, 1).contains("not finite"));
        assert!(err(CameraSpec { eye: Vec3::new(f32::INFINITY, 0.0, 0.0), ..ok }, 1, 1).contains("eye"));
        assert!(err(CameraSpec { up: Vec3::ZERO, ..ok }, 1, 1).contains("parallel"));
        assert!(err(ok, 0, 3).contains("0×3"));
        let far = err(CameraSpec { eye: Vec3::new(0.0, 1.0, 5e18), ..ok }, 1, 1);
        assert!(far.starts_with("camera: eye [0, 1, 5e18] lies beyond ±1e9"), "{far}");
        let wide = CameraSpec { lens: Lens { aperture: 1e30, ..Lens::PINHOLE }, ..ok };
        assert!(err(wide, 1, 1).starts_with("camera: aperture 1e30 is beyond ±1e9"));
        for e in [err(ok, 3, 0), err(CameraSpec { target: Vec3::Z, ..ok }, 1, 1)] {
            assert!(e.starts_with("camera: ") && !e.contains('\n'), "{e}");
        }
    }
}
