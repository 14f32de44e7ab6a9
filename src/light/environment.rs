//! The environment: radiance arriving from infinitely far away along every direction that
//! leaves the scene, a constant colour or an equirectangular (latitude–longitude) map, times
//! `strength`, turned by `rotation` about the up axis.
//!
//! **Orientation** (Blender's, so a map lights a scene as it does in Cycles). strahl's up axis
//! is `+y` (glTF's, which Blender's exporter maps from its `+z`; Blender's `−y` is strahl's
//! `+z`). For a direction `d` in the map's frame, the map's column `u ∈ [0, 1)` (left to
//! right) and row `t ∈ [0, 1)` (top to bottom) are
//!
//! ```text
//! u = ½ + atan2(d_z, d_x) / 2π          t = acos(d_y) / π
//! d = (sin θ·cos φ, cos θ, sin θ·sin φ),  θ = π·t,  φ = 2π(u − ½)
//! ```
//!
//! so the top row is straight up, the centre column faces `+x` (Blender's `+x` too), the
//! column at three quarters faces `+z` (Blender's `−y`) and the one at a quarter `−z`
//! (Blender's `+y`): Cycles' `direction_to_equirectangular` with Blender's axes. `rotation`
//! (degrees) turns the environment right-handedly about `+y` (counter-clockwise seen from
//! above): what faced `+x` faces `cos α·x − sin α·z`, i.e. the map is looked up along
//! `R_y(−α)·d`.
//!
//! **Lookup**: nearest texel (the texel whose cell holds `(u, t)`; no filtering), so the
//! radiance is piecewise constant exactly as the sampling density is.
//!
//! **Sampling**: a map is sampled texel by texel in proportion to luminance × solid angle,
//! by the piecewise-constant 2-D distribution
//! ([`crate::sampling::distribution::Distribution2D`]; marginal over rows, conditional
//! along each row) of
//!
//! ```text
//! f(i, j) = Y(texel(i, j)) · ΔΩ_j,   ΔΩ_j = (2π/W)·(cos θ_j − cos θ_{j+1}) = (2π/W)·∫_row sin θ dθ
//! ```
//!
//! (`Y` the Rec. 709 luminance, `θ_j = π·j/H` the row's upper edge), and inside the texel
//! uniformly in `φ` and in `cos θ`, i.e. uniformly by solid angle. The density of a direction
//! is then constant over each texel,
//!
//! ```text
//! p_ω(d) = P(i, j) / ΔΩ_j = Y(i, j) / Σ Y·ΔΩ
//! ```
//!
//! which is bounded at the poles (sampling `θ` uniformly inside a row, as pbrt-v4 does, gives
//! `p_ω ∝ 1/sin θ` there) and makes `L/p_ω` constant for a grey map. A constant environment
//! is sampled uniformly over the sphere (`p_ω = 1/4π`). The density and radiance of a sample
//! are those of the direction returned ([`Environment::pdf`], [`Environment::radiance`]), so
//! `sample` and `pdf` agree exactly.

use std::f32::consts::PI;
use std::sync::Arc;

use crate::math::{Vec2, Vec3};
use crate::sampling::distribution::Distribution2D;
use crate::sampling::{UNIFORM_SPHERE_PDF, square_to_uniform_sphere};
use crate::texture::Image;

/// Rec. 709 luminance of a linear RGB triple.
#[inline]
pub fn luminance(c: Vec3) -> f32 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}

/// An equirectangular map and its sampling distribution.
#[derive(Clone, PartialEq)]
pub struct EnvironmentMap {
    /// The texels, linear RGB, row 0 at the top (straight up).
    pub image: Image,
    distribution: Distribution2D,
    /// `cos θ_j` of each row's upper edge, and 1 past the last (`h + 1` values, `cos θ_h = −1`).
    cos_edge: Vec<f64>,
    /// The solid angle of one texel of each row, `ΔΩ_j`.
    texel_solid_angle: Vec<f64>,
}

impl std::fmt::Debug for EnvironmentMap {
    /// The map's name and size, without its texels (a scene's `Debug` text stays short).
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "EnvironmentMap({:?}, {} × {})", self.image.name, self.image.width, self.image.height)
    }
}

impl EnvironmentMap {
    /// The map of `image` (linear RGB, finite and ≥ 0) and its distribution.
    pub fn new(image: Image) -> EnvironmentMap {
        let (w, h) = (image.width, image.height);
        let cos_edge: Vec<f64> = (0..=h).map(|j| (std::f64::consts::PI * j as f64 / h as f64).cos()).collect();
        let texel_solid_angle: Vec<f64> =
            (0..h).map(|j| 2.0 * std::f64::consts::PI / w as f64 * (cos_edge[j] - cos_edge[j + 1])).collect();
        let mut func = Vec::with_capacity(w * h);
        for (j, omega) in texel_solid_angle.iter().enumerate() {
            func.extend(image.texels[j * w..(j + 1) * w].iter().map(|&c| luminance(c) * *omega as f32));
        }
        let distribution = Distribution2D::new(&func, w, h);
        EnvironmentMap { image, distribution, cos_edge, texel_solid_angle }
    }

    /// The row of `t ∈ [0, 1)`.
    #[inline]
    fn row(&self, t: f32) -> usize {
        ((t * self.image.height as f32) as usize).min(self.image.height - 1)
    }

    /// The solid-angle density at map coordinates `(u, t)`: the texel's probability over its
    /// solid angle.
    fn pdf(&self, u: f32, t: f32) -> f32 {
        let cells = (self.image.width * self.image.height) as f64;
        let p = self.distribution.pdf([u, t]) as f64 / cells;
        (p / self.texel_solid_angle[self.row(t)]) as f32
    }

    /// A direction in the map's frame for `u`: a texel by the distribution, then a point of
    /// it uniform in `φ` and `cos θ`.
    fn sample(&self, u: Vec2) -> Vec3 {
        let ([su, st], _) = self.distribution.sample([u.x, u.y]);
        let j = self.row(st);
        let within = (st as f64 * self.image.height as f64 - j as f64).clamp(0.0, 1.0);
        let cos_theta = self.cos_edge[j] + within * (self.cos_edge[j + 1] - self.cos_edge[j]);
        let sin_theta = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
        let phi = 2.0 * std::f64::consts::PI * (su as f64 - 0.5);
        Vec3::new((sin_theta * phi.cos()) as f32, cos_theta as f32, (sin_theta * phi.sin()) as f32)
    }

    /// The texel whose cell holds `(u, t)`.
    #[inline]
    fn texel(&self, u: f32, t: f32) -> Vec3 {
        let (w, h) = (self.image.width, self.image.height);
        let i = ((u * w as f32) as usize).min(w - 1);
        let j = ((t * h as f32) as usize).min(h - 1);
        self.image.texels[j * w + i]
    }

    /// `∫ L dω` over the sphere, per channel (each texel times its solid angle).
    fn radiant_integral(&self) -> Vec3 {
        let (w, h) = (self.image.width, self.image.height);
        let mut sum = glam::DVec3::ZERO;
        for j in 0..h {
            let (t0, t1) =
                (std::f64::consts::PI * j as f64 / h as f64, std::f64::consts::PI * (j + 1) as f64 / h as f64);
            let omega = 2.0 * std::f64::consts::PI / w as f64 * (t0.cos() - t1.cos());
            let row: glam::DVec3 = self.image.texels[j * w..(j + 1) * w].iter().map(|c| c.as_dvec3()).sum();
            sum += row * omega;
        }
        sum.as_vec3()
    }
}

/// What the environment shows.
#[derive(Clone, Debug, PartialEq)]
pub enum EnvironmentSource {
    /// The same radiance (W/(m²·sr) per channel) from every direction.
    Constant(Vec3),
    /// An equirectangular map of radiance (shared: a scene clone keeps one copy of the texels).
    Map(Arc<EnvironmentMap>),
}

/// The environment light (see the module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct Environment {
    pub source: EnvironmentSource,
    /// Multiplies the radiance.
    pub strength: f32,
    /// Degrees about the up axis, right-handed.
    pub rotation_deg: f32,
}

impl Environment {
    /// A constant environment of radiance `color`.
    pub fn constant(color: Vec3) -> Environment {
        Environment { source: EnvironmentSource::Constant(color), strength: 1.0, rotation_deg: 0.0 }
    }

    /// The environment of an equirectangular map.
    pub fn map(image: Image) -> Environment {
        Environment {
            source: EnvironmentSource::Map(Arc::new(EnvironmentMap::new(image))),
            strength: 1.0,
            rotation_deg: 0.0,
        }
    }

    /// Why this environment cannot be rendered, if it cannot.
    pub fn problem(&self) -> Option<String> {
        if !(self.strength.is_finite() && self.strength >= 0.0) {
            return Some(format!("strength {} must be finite and ≥ 0", self.strength));
        }
        if !self.rotation_deg.is_finite() {
            return Some(format!("rotation {} must be finite", self.rotation_deg));
        }
        match &self.source {
            EnvironmentSource::Constant(c) if !(c.is_finite() && c.min_element() >= 0.0) => {
                Some(format!("color {c} must be finite and ≥ 0"))
            }
            _ => None,
        }
    }

    /// `(cos α, sin α)` of the rotation.
    #[inline]
    fn turn(&self) -> (f32, f32) {
        let (s, c) = self.rotation_deg.to_radians().sin_cos();
        (c, s)
    }

    /// The world direction `d` in the map's frame: `R_y(−α)·d`.
    #[inline]
    fn world_to_map(&self, d: Vec3) -> Vec3 {
        let (c, s) = self.turn();
        Vec3::new(c * d.x - s * d.z, d.y, s * d.x + c * d.z)
    }

    /// The map's frame back to the world: `R_y(α)·d`.
    #[inline]
    fn map_to_world(&self, d: Vec3) -> Vec3 {
        let (c, s) = self.turn();
        Vec3::new(c * d.x + s * d.z, d.y, -s * d.x + c * d.z)
    }

    /// The map coordinates `(u, t)` of the unit world direction `wi`.
    #[inline]
    fn coordinates(&self, wi: Vec3) -> (f32, f32) {
        let d = self.world_to_map(wi);
        let y = d.y.clamp(-1.0, 1.0);
        let mut u = 0.5 + d.z.atan2(d.x) / (2.0 * PI);
        if u >= 1.0 {
            u -= 1.0;
        }
        let t = (y.acos() / PI).clamp(0.0, 1.0f32.next_down());
        (u.clamp(0.0, 1.0f32.next_down()), t)
    }

    /// The radiance arriving along `−wi` from the environment in the unit direction `wi`.
    pub fn radiance(&self, wi: Vec3) -> Vec3 {
        match &self.source {
            EnvironmentSource::Constant(c) => *c * self.strength,
            EnvironmentSource::Map(m) => {
                let (u, t) = self.coordinates(wi);
                m.texel(u, t) * self.strength
            }
        }
    }

    /// The solid-angle density with which [`Environment::sample`] draws the unit direction `wi`.
    pub fn pdf(&self, wi: Vec3) -> f32 {
        match &self.source {
            EnvironmentSource::Constant(_) => UNIFORM_SPHERE_PDF,
            EnvironmentSource::Map(m) => {
                let (u, t) = self.coordinates(wi);
                m.pdf(u, t)
            }
        }
    }

    /// A direction drawn for `u ∈ [0, 1)²`, the radiance arriving along it and its density;
    /// `None` where the density is 0 (a pole).
    pub fn sample(&self, u: Vec2) -> Option<(Vec3, Vec3, f32)> {
        let wi = match &self.source {
            EnvironmentSource::Constant(_) => square_to_uniform_sphere(u),
            EnvironmentSource::Map(m) => self.map_to_world(m.sample(u)).normalize(),
        };
        let pdf = self.pdf(wi);
        (pdf > 0.0 && pdf.is_finite()).then(|| (wi, self.radiance(wi), pdf))
    }

    /// The mean radiance over all directions, `∫ L dω / 4π`, per channel (strength applied).
    pub fn mean_radiance(&self) -> Vec3 {
        match &self.source {
            EnvironmentSource::Constant(c) => *c * self.strength,
            EnvironmentSource::Map(m) => m.radiant_integral() * (self.strength / (4.0 * PI)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::chi2::{Chi2Test, sidak};

    /// A map with a bright square, a dim sky and a black band, turned by 30°.
    fn map(rotation_deg: f32) -> Environment {
        let (w, h) = (64, 32);
        let mut texels = vec![Vec3::splat(0.2); w * h];
        for j in 0..h {
            for i in 0..w {
                if (20..28).contains(&i) && (6..12).contains(&j) {
                    texels[j * w + i] = Vec3::new(40.0, 30.0, 10.0);
                }
                if j >= 24 {
                    texels[j * w + i] = Vec3::ZERO;
                }
            }
        }
        let image = Image::from_texels("test map", w, h, texels).unwrap();
        Environment { rotation_deg, strength: 2.0, ..Environment::map(image) }
    }

    #[test]
    fn map_sampling_passes_chi2() {
        let tests = 2;
        for rotation in [0.0, 30.0] {
            let env = map(rotation);
            // The χ² harness's φ bins are about +z; the map's poles are ±y, so look at it turned.
            let r = Chi2Test { cos_bins: 51, phi_bins: 100, ..Default::default() }
                .run(|_, u| env.sample(u).map(|(w, _, _)| w), |w| env.pdf(w) as f64);
            assert!(r.passes(sidak(0.01, tests)), "rotation {rotation}: {r}");
        }
    }

    #[test]
    fn a_wrong_density_fails_chi2() {
        // The map's samples tested against the density of the map turned by 6° (about one
        // texel): rejected.
        let (env, turned) = (map(0.0), map(6.0));
        let r = Chi2Test { cos_bins: 51, phi_bins: 100, ..Default::default() }
            .run(|_, u| env.sample(u).map(|(w, _, _)| w), |w| turned.pdf(w) as f64);
        assert!(!r.passes(0.01), "{r}");
    }

    #[test]
    fn sample_reports_the_pdf_and_radiance_of_its_direction() {
        for env in [map(0.0), map(30.0), Environment::constant(Vec3::new(1.0, 2.0, 3.0))] {
            let n = 200;
            for i in 0..n {
                for j in 0..n {
                    let u = Vec2::new((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32);
                    let Some((w, l, pdf)) = env.sample(u) else { continue };
                    assert!((w.length() - 1.0).abs() < 1e-5);
                    assert_eq!(pdf, env.pdf(w));
                    assert_eq!(l, env.radiance(w));
                    assert!(l.max_element() > 0.0, "a sample where nothing shines: {w}");
                }
            }
        }
    }

    #[test]
    fn orientation_is_blenders() {
        // One texel bright per test: the centre column (4 of 8: u ∈ [½, ⅝)) starts at +x,
        // column 6 at +z (three quarters), column 2 at −z (a quarter), the top row is +y; a
        // rotation of 90° moves +x to −z.
        let (w, h) = (8, 4);
        let at = |i: usize, j: usize, rotation_deg: f32| {
            let mut texels = vec![Vec3::ZERO; w * h];
            texels[j * w + i] = Vec3::ONE;
            Environment { rotation_deg, ..Environment::map(Image::from_texels("t", w, h, texels).unwrap()) }
        };
        let horizon = |x: f32, z: f32| Vec3::new(x, -0.2, z).normalize();
        assert_eq!(at(4, 2, 0.0).radiance(horizon(1.0, 0.05)), Vec3::ONE);
        assert_eq!(at(6, 2, 0.0).radiance(horizon(-0.3, 1.0)), Vec3::ONE);
        assert_eq!(at(2, 2, 0.0).radiance(horizon(0.05, -1.0)), Vec3::ONE);
        assert_eq!(at(0, 0, 0.0).radiance(Vec3::new(-1.0, 5.0, -0.1).normalize()), Vec3::ONE);
        assert_eq!(at(4, 2, 0.0).radiance(horizon(0.05, -1.0)), Vec3::ZERO);
        assert_eq!(at(4, 2, 90.0).radiance(horizon(0.05, -1.0)), Vec3::ONE);
        assert_eq!(at(4, 2, 90.0).radiance(horizon(1.0, 0.05)), Vec3::ZERO);
    }

    #[test]
    fn mean_radiance_of_a_constant_map_is_its_value() {
        let image = Image::from_texels("t", 16, 8, vec![Vec3::new(1.0, 2.0, 3.0); 128]).unwrap();
        let env = Environment { strength: 0.5, ..Environment::map(image) };
        assert!((env.mean_radiance() - Vec3::new(0.5, 1.0, 1.5)).abs().max_element() < 1e-5);
    }
}
