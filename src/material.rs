//! Surface materials for Whitted shading: a diffuse albedo (constant or Whitted's 1980
//! checkerboard), a normalised Blinn–Phong highlight, an ideal mirror, a dielectric
//! (Snell + Fresnel) and emission. All reflectances are in [0, 1] per channel.
//!
//! The formulas themselves live in [`crate::optics`]; this module holds the parameters and
//! evaluates the texture (image textures: [`crate::texture`]).

use crate::math::{Vec2, Vec3};
use crate::texture::ImageTexture;

/// How the diffuse albedo varies over a surface.
#[derive(Clone, Debug, PartialEq)]
pub enum Texture {
    /// The same albedo everywhere.
    Constant(Vec3),
    /// A world-space 3-D checkerboard of cubes of edge `size`: `even` where
    /// `⌊x/size⌋ + ⌊y/size⌋ + ⌊z/size⌋` is even, `odd` elsewhere.
    Checker { even: Vec3, odd: Vec3, size: f32 },
    /// An image looked up at the surface's texture coordinates (glTF `baseColorTexture`, OBJ
    /// `map_Kd`); surfaces without texture coordinates look it up at `(0, 0)`.
    Image(ImageTexture),
}

/// How far (in units of the checker `size`) a texture lookup moves a point against the
/// surface's outward normal before choosing its cell.
const CHECKER_INSET: f32 = 1e-4;

impl Texture {
    /// The albedo at world-space point `p` of a surface whose outward geometric normal is
    /// `ng_outward` (unit, not flipped towards the viewer) and whose texture coordinates there
    /// are `uv`.
    ///
    /// A surface lying exactly on a cell boundary (Whitted's floor at `y = 0` or `y = −1` with
    /// `size = 1`) would otherwise pick one of the two cells at random from the rounding of
    /// its hit points. The lookup therefore moves `p` by `10⁻⁴·size` into the object (against
    /// the outward normal), which decides such ties the same way everywhere and moves the
    /// checker's edges by a negligible amount elsewhere.
    pub fn albedo_at(&self, p: Vec3, ng_outward: Vec3, uv: Vec2) -> Vec3 {
        match self {
            Texture::Constant(c) => *c,
            &Texture::Checker { even, odd, size } => {
                let q = (p - CHECKER_INSET * size * ng_outward) / size;
                let cell = q.x.floor() as i64 + q.y.floor() as i64 + q.z.floor() as i64;
                if cell.rem_euclid(2) == 0 { even } else { odd }
            }
            Texture::Image(t) => t.lookup(uv),
        }
    }

    /// Why this texture cannot be used, if it cannot.
    pub fn problem(&self) -> Option<String> {
        match *self {
            Texture::Constant(c) => bad_colour("diffuse", c),
            Texture::Image(ref t) => bad_colour("texture factor", t.factor),
            Texture::Checker { even, odd, size } => bad_colour("checker even", even)
                .or_else(|| bad_colour("checker odd", odd))
                .or_else(|| (!(size > 0.0 && size.is_finite())).then(|| format!("checker size {size} must be > 0"))),
        }
    }
}

/// A surface material.
///
/// Energy: a surface reflects at most what it receives when `diffuse + specular + mirror +
/// transmission ≤ 1` per channel. `transmission` is the weight of the dielectric interface,
/// which Fresnel splits into reflection (`R`) and refraction (`T = 1 − R`).
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    pub name: String,
    /// Diffuse albedo ρ: the surface reflects `ρ/π` (Lambert). Multiplied by the mesh's
    /// per-vertex colour where it has one.
    pub diffuse: Texture,
    /// Weight `k_s` of the normalised Blinn–Phong lobe `k_s · K(n) · (n·h)^n`, with
    /// `K(n)` from [`crate::optics::blinn_phong_normalization`].
    pub specular: Vec3,
    /// Blinn–Phong exponent `n` (≥ 0).
    pub shininess: f32,
    /// Reflectance of the ideal mirror direction.
    pub mirror: Vec3,
    /// Weight of the dielectric interface, zero for an opaque material: of the light it
    /// governs, the Fresnel reflectance `R` is mirrored and `T = 1 − R` refracted (Snell).
    /// A colour tints both, at every crossing of the surface.
    pub transmission: Vec3,
    /// Index of refraction of the inside (the side the geometric normal points away from);
    /// the outside is vacuum (1).
    pub ior: f32,
    /// Emitted radiance.
    pub emission: Vec3,
    /// Whether only the front (the side the geometric normal points to) emits; both do
    /// otherwise. The geometry of a one-sided area light has it.
    pub emission_one_sided: bool,
    /// Whether this is the material of an area light's visible geometry
    /// ([`crate::scene::emitters`]): that light is sampled as itself, never as a mesh light.
    pub area_light: bool,
}

impl Default for Material {
    /// A mid-grey diffuse surface.
    fn default() -> Self {
        Material {
            name: "default".into(),
            diffuse: Texture::Constant(Vec3::splat(0.5)),
            specular: Vec3::ZERO,
            shininess: 0.0,
            mirror: Vec3::ZERO,
            transmission: Vec3::ZERO,
            ior: 1.5,
            emission: Vec3::ZERO,
            emission_one_sided: false,
            area_light: false,
        }
    }
}

impl Material {
    /// A Lambertian surface of albedo `rho` and nothing else.
    pub fn matte(name: &str, rho: Vec3) -> Self {
        Material { name: name.into(), diffuse: Texture::Constant(rho), ..Default::default() }
    }

    /// An ideal mirror of the given reflectance, with no diffuse part.
    pub fn mirror(name: &str, reflectance: Vec3) -> Self {
        Material {
            name: name.into(),
            diffuse: Texture::Constant(Vec3::ZERO),
            mirror: reflectance,
            ..Default::default()
        }
    }

    /// Clear glass of index of refraction `ior`, with no diffuse part: what it does not
    /// reflect (Fresnel) it refracts.
    pub fn clear_glass(name: &str, ior: f32) -> Self {
        Material {
            name: name.into(),
            diffuse: Texture::Constant(Vec3::ZERO),
            transmission: Vec3::ONE,
            ior,
            ..Default::default()
        }
    }

    /// Whether light passes through the surface (a dielectric).
    #[inline]
    pub fn is_dielectric(&self) -> bool {
        self.transmission != Vec3::ZERO
    }

    /// Why this material cannot be rendered, if it cannot: a negative or non-finite
    /// coefficient, a negative or non-finite exponent, an index of refraction ≤ 0.
    pub fn problem(&self) -> Option<String> {
        self.diffuse
            .problem()
            .or_else(|| bad_colour("specular", self.specular))
            .or_else(|| bad_colour("mirror", self.mirror))
            .or_else(|| bad_colour("transmission", self.transmission))
            .or_else(|| bad_colour("emission", self.emission))
            .or_else(|| {
                (!(self.shininess >= 0.0 && self.shininess.is_finite()))
                    .then(|| format!("shininess {} must be a finite number ≥ 0", self.shininess))
            })
            .or_else(|| {
                (!(self.ior > 0.0 && self.ior.is_finite()))
                    .then(|| format!("ior {} must be a finite number > 0", self.ior))
            })
    }
}

fn bad_colour(what: &str, c: Vec3) -> Option<String> {
    (!(c.is_finite() && c.min_element() >= 0.0)).then(|| format!("{what} {c} must be finite and ≥ 0"))
}

#[cfg(test)]
mod tests {
    use super::*;

    const CHECKER: &Texture = &Texture::Checker { even: Vec3::ONE, odd: Vec3::ZERO, size: 1.0 };

    #[test]
    fn checker_cells_alternate() {
        let up = Vec3::Y;
        assert_eq!(CHECKER.albedo_at(Vec3::new(0.5, 0.5, 0.5), up, Vec2::ZERO), Vec3::ONE);
        assert_eq!(CHECKER.albedo_at(Vec3::new(1.5, 0.5, 0.5), up, Vec2::ZERO), Vec3::ZERO);
        assert_eq!(CHECKER.albedo_at(Vec3::new(-0.5, 0.5, 0.5), up, Vec2::ZERO), Vec3::ZERO);
        assert_eq!(CHECKER.albedo_at(Vec3::new(-0.5, -0.5, 0.5), up, Vec2::ZERO), Vec3::ONE);
    }

    #[test]
    fn a_floor_on_a_cell_boundary_is_one_cell_thick() {
        // Points on y = 0, a hair above and below it: all take the cell below (y ∈ [−1, 0)).
        for y in [0.0f32, 1e-7, -1e-7] {
            assert_eq!(CHECKER.albedo_at(Vec3::new(0.5, y, 0.5), Vec3::Y, Vec2::ZERO), Vec3::ZERO, "y = {y}");
            assert_eq!(CHECKER.albedo_at(Vec3::new(1.5, y, 0.5), Vec3::Y, Vec2::ZERO), Vec3::ONE, "y = {y}");
        }
    }

    #[test]
    fn problems_are_named() {
        assert_eq!(Material::default().problem(), None);
        let m = Material { ior: 0.0, ..Default::default() };
        assert!(m.problem().unwrap().starts_with("ior 0"));
        let m = Material { mirror: Vec3::new(0.0, -1.0, 0.0), ..Default::default() };
        assert!(m.problem().unwrap().starts_with("mirror"));
        let m =
            Material { diffuse: Texture::Checker { even: Vec3::ONE, odd: Vec3::ONE, size: 0.0 }, ..Default::default() };
        assert!(m.problem().unwrap().starts_with("checker size 0"));
    }
}
