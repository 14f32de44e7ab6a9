//! Surface materials: the lecture material (a diffuse albedo, constant or Whitted's 1980
//! checkerboard, a normalised Blinn–Phong highlight, an ideal mirror, a dielectric (Snell +
//! Fresnel) and emission; all reflectances in [0, 1] per channel), and, for glTF materials and
//! TOML's `base_color`/`metallic`/`roughness` keys, the glTF metallic-roughness material
//! ([`Pbr`]) beside it.
//!
//! The path tracer shades a material with a [`Pbr`] part by `bsdf::gltf` and the others by
//! `bsdf::lecture` ([`crate::shading`]). The Whitted integrator shades the lecture fields
//! alone: a PBR material carries its closest lecture form there too ([`Pbr::lecture_form`]).
//!
//! The lecture formulas live in [`crate::optics`]; this module holds the parameters and
//! evaluates the textures (image textures: [`crate::texture`]).

use crate::bsdf::PbrParams;
use crate::math::{Vec2, Vec3};

/// Where a texture is read: the hit's texture coordinate sets (`TEXCOORD_0`, `TEXCOORD_1`,
/// strahl's bottom-left convention) and the width of the ray's footprint in each set's units
/// (0: a point sample, the bilinear lookup; see [`crate::shading`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TexCoords {
    pub uv: [Vec2; 2],
    pub width: [f32; 2],
}

impl TexCoords {
    /// Texture coordinates `uv` of a surface of normal `ng` with texture-coordinate densities
    /// `density` ([`crate::surface::SurfacePoint::uv_density`]), seen from direction `wo` by a
    /// ray whose cone is `footprint` wide there: the footprint's width in each set's units,
    /// `density·footprint/|ng·wo|` ([`crate::shading`]).
    pub fn through_cone(uv: [Vec2; 2], density: [f32; 2], ng: Vec3, wo: Vec3, footprint: f32) -> TexCoords {
        if !(footprint > 0.0) {
            return uv.into();
        }
        let cos = ng.dot(wo.normalize_or_zero()).abs().max(1e-6);
        let along = footprint / cos;
        TexCoords { uv, width: density.map(|d| d * along) }
    }
}

impl From<[Vec2; 2]> for TexCoords {
    /// A point sample at `uv`.
    fn from(uv: [Vec2; 2]) -> TexCoords {
        TexCoords { uv, width: [0.0; 2] }
    }
}
use crate::texture::ImageTexture;

/// How the diffuse albedo varies over a surface.
#[derive(Clone, Debug, PartialEq)]
pub enum Texture {
    /// The same albedo everywhere.
    Constant(Vec3),
    /// A world-space 3-D checkerboard of cubes of edge `size`: `even` where
    /// `⌊x/size⌋ + ⌊y/size⌋ + ⌊z/size⌋` is even, `odd` elsewhere.
    Checker { even: Vec3, odd: Vec3, size: f32 },
    /// An image looked up at the surface's texture coordinates (glTF `baseColorTexture` with its
    /// coordinate set and transform, OBJ `map_Kd`); surfaces without texture coordinates look
    /// it up at `(0, 0)`.
    Image(TextureSlot),
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
    pub fn albedo_at(&self, p: Vec3, ng_outward: Vec3, uv: impl Into<TexCoords>) -> Vec3 {
        match self {
            Texture::Constant(c) => *c,
            &Texture::Checker { even, odd, size } => {
                let q = (p - CHECKER_INSET * size * ng_outward) / size;
                let cell = q.x.floor() as i64 + q.y.floor() as i64 + q.z.floor() as i64;
                if cell.rem_euclid(2) == 0 { even } else { odd }
            }
            Texture::Image(t) => t.at(uv),
        }
    }

    /// Why this texture cannot be used, if it cannot.
    pub fn problem(&self) -> Option<String> {
        match *self {
            Texture::Constant(c) => bad_colour("diffuse", c),
            Texture::Image(ref t) => bad_colour("texture factor", t.texture.factor),
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
    /// The glTF metallic-roughness material the path tracer shades, when the material is one
    /// (glTF, or TOML's PBR keys); the fields above are then its lecture form.
    pub pbr: Option<Box<Pbr>>,
    /// Which hits on the surface exist (glTF `alphaMode`, `doubleSided`), when not all do:
    /// decided while tracing ([`crate::scene::alpha`]).
    pub coverage: Option<Box<Coverage>>,
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
            pbr: None,
            coverage: None,
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

    /// Every image the material samples, in a fixed order: the diffuse texture's, then the
    /// PBR part's ([`Pbr::slots`]), then the alpha plane's.
    pub fn images(&self) -> Vec<&std::sync::Arc<crate::texture::Image>> {
        let mut images = Vec::new();
        if let Texture::Image(t) = &self.diffuse {
            images.push(&t.texture.image);
        }
        if let Some(p) = &self.pbr {
            for slot in p.slots() {
                images.push(&slot.texture.image);
            }
        }
        if let Some(slot) = self.coverage.as_ref().and_then(|c| c.texture.as_ref()) {
            images.push(&slot.texture.image);
        }
        images
    }

    /// A copy whose images keep their names and sizes but no texels (what a scene hash
    /// prints; the texels are hashed as bytes).
    pub fn without_texels(&self) -> Material {
        let bare =
            |t: &ImageTexture| ImageTexture { image: std::sync::Arc::new(t.image.without_texels()), ..t.clone() };
        let mut m = self.clone();
        if let Texture::Image(t) = &mut m.diffuse {
            t.texture = bare(&t.texture);
        }
        if let Some(p) = &mut m.pbr {
            for slot in p.slots_mut() {
                slot.texture = bare(&slot.texture);
            }
        }
        if let Some(slot) = m.coverage.as_mut().and_then(|c| c.texture.as_mut()) {
            slot.texture = bare(&slot.texture);
        }
        m
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
            .or_else(|| self.pbr.as_ref().and_then(|p| p.problem()))
            .or_else(|| self.coverage.as_ref().and_then(|c| c.problem()))
    }
}

/// Roughness at or below which a metallic (`metallic = 1`) material's lecture form is an ideal
/// mirror.
pub const MIRROR_ROUGHNESS: f32 = 0.1;

/// Exponent of the Blinn–Phong lobe matching a glTF roughness `r`: with `α = r²`,
/// `n = 2/α² − 2` (the usual Beckmann–Phong correspondence), at most 10⁴.
pub fn shininess_of_roughness(roughness: f32) -> f32 {
    let alpha = (roughness.clamp(0.0, 1.0) as f64).powi(2);
    if alpha <= 0.0 { 1e4 } else { (2.0 / (alpha * alpha) - 2.0).clamp(0.0, 1e4) as f32 }
}

/// A texture a [`Pbr`] material samples: an image with its sampler's wrap modes (`factor` 1:
/// the material's factors multiply it), the texture coordinate set it reads (`TEXCOORD_n`), and
/// `KHR_texture_transform`.
#[derive(Clone, Debug, PartialEq)]
pub struct TextureSlot {
    pub texture: ImageTexture,
    /// `TEXCOORD_0` or `TEXCOORD_1`.
    pub tex_coord: u32,
    /// `KHR_texture_transform` as the affine map of glTF's coordinates (origin top-left):
    /// `(u', v') = M·(u, v, 1)`, rows of `M` = `[[a, b, c], [d, e, f]]`.
    pub transform: Option<[[f32; 3]; 2]>,
}

impl TextureSlot {
    /// An image read at `TEXCOORD_0` without a transform.
    pub fn plain(texture: ImageTexture) -> TextureSlot {
        TextureSlot { texture, tex_coord: 0, transform: None }
    }

    /// The filtered texel at a hit whose texture coordinate sets are `at.uv` (strahl's
    /// bottom-left convention, as [`crate::surface::SurfacePoint`] holds them): bilinear for a
    /// point sample, trilinear at the level of detail `λ = log₂(width·s·√(W·H))` of a footprint
    /// `width` wide in the set's units (`s = √|det M|`, the transform's scale; `W × H` texels).
    pub fn at(&self, at: impl Into<TexCoords>) -> Vec3 {
        let at = at.into();
        let set = (self.tex_coord as usize).min(1);
        let (uv, width) = (at.uv[set], at.width[set]);
        let (uv, scale) = match self.transform {
            None => (uv, 1.0),
            Some([r0, r1]) => {
                let (u, v) = (uv.x, 1.0 - uv.y);
                let (u2, v2) = (r0[0] * u + r0[1] * v + r0[2], r1[0] * u + r1[1] * v + r1[2]);
                (Vec2::new(u2, 1.0 - v2), (r0[0] * r1[1] - r0[1] * r1[0]).abs().sqrt())
            }
        };
        if !(width > 0.0) {
            return self.texture.lookup(uv);
        }
        let image = &self.texture.image;
        let texels = ((image.width * image.height) as f32).sqrt();
        self.texture.lookup_lod(uv, (width * scale * texels).log2())
    }

    /// The image's mean texel (for the lecture form).
    fn mean(slot: &Option<TextureSlot>) -> Vec3 {
        slot.as_ref().map_or(Vec3::ONE, |t| t.texture.image.mean())
    }

    /// What an optional texture multiplies its factor by at a hit: its filtered texel
    /// ([`TextureSlot::at`]), or 1 when there is no texture.
    #[inline]
    pub fn or_one(slot: &Option<TextureSlot>, at: TexCoords) -> Vec3 {
        slot.as_ref().map_or(Vec3::ONE, |t| t.at(at))
    }
}

/// The textures of the material extensions strahl renders, each multiplying its factor in
/// [`PbrParams`] at a hit (the channel each extension names; colour textures sRGB-decoded, the
/// others linear; a texture read from the alpha channel is decoded as the image's alpha plane,
/// [`crate::texture::Encoding::Alpha`], which holds α in every channel):
///
/// ```text
/// transmission        = transmissionFactor        · transmissionTexture.r        KHR_materials_transmission
/// specular            = specularFactor            · specularTexture.a            KHR_materials_specular
/// specular colour     = specularColorFactor       · specularColorTexture.rgb     (sRGB)
/// clearcoat           = clearcoatFactor           · clearcoatTexture.r           KHR_materials_clearcoat
/// clearcoat roughness = clearcoatRoughnessFactor  · clearcoatRoughnessTexture.g
/// sheen colour        = sheenColorFactor          · sheenColorTexture.rgb        (sRGB) KHR_materials_sheen
/// sheen roughness     = sheenRoughnessFactor      · sheenRoughnessTexture.a
/// ```
///
/// (`KHR_materials_volume`'s `thicknessTexture` is for renderers that cannot trace the
/// distance through the mesh; as that extension asks of ray tracers, strahl ignores it.)
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ExtensionTextures {
    pub transmission: Option<TextureSlot>,
    /// Decoded as the alpha plane.
    pub specular: Option<TextureSlot>,
    pub specular_color: Option<TextureSlot>,
    pub clearcoat: Option<TextureSlot>,
    pub clearcoat_roughness: Option<TextureSlot>,
    pub sheen_color: Option<TextureSlot>,
    /// Decoded as the alpha plane.
    pub sheen_roughness: Option<TextureSlot>,
}

impl ExtensionTextures {
    /// The factors `f` multiplied by the textures at `at` (the table above).
    pub fn apply(&self, f: PbrParams, at: TexCoords) -> PbrParams {
        if self.slots().iter().all(Option::is_none) {
            // Every factor times 1: the factors themselves, without seven lookups of nothing.
            return f;
        }
        let t = |slot: &Option<TextureSlot>| TextureSlot::or_one(slot, at);
        PbrParams {
            transmission: f.transmission * t(&self.transmission).x,
            specular: f.specular * t(&self.specular).x,
            specular_color: f.specular_color * t(&self.specular_color),
            clearcoat: f.clearcoat * t(&self.clearcoat).x,
            clearcoat_roughness: f.clearcoat_roughness * t(&self.clearcoat_roughness).y,
            sheen_color: f.sheen_color * t(&self.sheen_color),
            sheen_roughness: f.sheen_roughness * t(&self.sheen_roughness).x,
            ..f
        }
    }

    fn slots(&self) -> [Option<&TextureSlot>; 7] {
        [
            self.transmission.as_ref(),
            self.specular.as_ref(),
            self.specular_color.as_ref(),
            self.clearcoat.as_ref(),
            self.clearcoat_roughness.as_ref(),
            self.sheen_color.as_ref(),
            self.sheen_roughness.as_ref(),
        ]
    }

    fn slots_mut(&mut self) -> [Option<&mut TextureSlot>; 7] {
        [
            self.transmission.as_mut(),
            self.specular.as_mut(),
            self.specular_color.as_mut(),
            self.clearcoat.as_mut(),
            self.clearcoat_roughness.as_mut(),
            self.sheen_color.as_mut(),
            self.sheen_roughness.as_mut(),
        ]
    }
}

/// The glTF 2.0 metallic-roughness material and the extensions strahl renders, as factors and
/// the textures that multiply them (the specification's defaults in [`Default`]):
///
/// ```text
/// base colour = base_color · baseColorTexture(uv) (sRGB-decoded) · COLOR_0
/// metallic    = metallic  · metallicRoughnessTexture(uv).b     (linear)
/// roughness   = roughness · metallicRoughnessTexture(uv).g     (linear)
/// emission    = emission  · emissiveTexture(uv) (sRGB-decoded), emission = emissiveFactor · strength
/// ```
///
/// and the extensions' factors times their textures ([`ExtensionTextures`]).
#[derive(Clone, Debug, PartialEq)]
pub struct Pbr {
    /// The factors: `baseColorFactor` (RGB, linear), `metallicFactor`, `roughnessFactor` and
    /// those of `KHR_materials_ior`, `_transmission`, `_specular`, `_clearcoat` and `_sheen`, as
    /// [`crate::bsdf::gltf`] takes them; the textures below multiply some of them at a hit.
    pub factors: PbrParams,
    pub base_color_texture: Option<TextureSlot>,
    /// Blue: metalness, green: roughness (linear).
    pub metallic_roughness_texture: Option<TextureSlot>,
    /// `emissiveFactor · KHR_materials_emissive_strength`, W/(m²·sr).
    pub emission: Vec3,
    pub emissive_texture: Option<TextureSlot>,
    /// `normalTexture` (linear): the shading normal's direction in the tangent frame
    /// ([`crate::normal_map`]), its `x` and `y` multiplied by `normal_scale`.
    pub normal_texture: Option<TextureSlot>,
    pub normal_scale: f32,
    /// `KHR_materials_clearcoat`'s `clearcoatNormalTexture` (linear) and its `scale`: the
    /// coat's own normal, mapped as `normalTexture` maps the base's. Without it the coat
    /// takes the surface's normal before normal mapping ([`crate::surface::SurfacePoint::n_coat`]).
    pub clearcoat_normal_texture: Option<TextureSlot>,
    pub clearcoat_normal_scale: f32,
    /// `KHR_materials_volume`: `thicknessFactor` (0: thin-walled, no volume),
    /// `attenuationColor` and `attenuationDistance` (infinite: no absorption).
    pub thickness: f32,
    pub attenuation_color: Vec3,
    pub attenuation_distance: f32,
    /// `KHR_materials_unlit`: the surface shows its base colour as emitted radiance and
    /// scatters nothing.
    pub unlit: bool,
    /// The textures of `KHR_materials_transmission`, `_specular`, `_clearcoat` and `_sheen`.
    pub extension_textures: ExtensionTextures,
}

impl Default for Pbr {
    fn default() -> Self {
        Pbr {
            factors: PbrParams::default(),
            base_color_texture: None,
            metallic_roughness_texture: None,
            emission: Vec3::ZERO,
            emissive_texture: None,
            normal_texture: None,
            normal_scale: 1.0,
            clearcoat_normal_texture: None,
            clearcoat_normal_scale: 1.0,
            thickness: 0.0,
            attenuation_color: Vec3::ONE,
            attenuation_distance: f32::INFINITY,
            unlit: false,
            extension_textures: ExtensionTextures::default(),
        }
    }
}

impl Pbr {
    /// The texture slots, in a fixed order: base colour, metallic-roughness, emissive, normal,
    /// clearcoat normal, then the extensions' ([`ExtensionTextures`]).
    pub fn slots(&self) -> impl Iterator<Item = &TextureSlot> {
        [
            self.base_color_texture.as_ref(),
            self.metallic_roughness_texture.as_ref(),
            self.emissive_texture.as_ref(),
            self.normal_texture.as_ref(),
            self.clearcoat_normal_texture.as_ref(),
        ]
        .into_iter()
        .chain(self.extension_textures.slots())
        .flatten()
    }

    fn slots_mut(&mut self) -> impl Iterator<Item = &mut TextureSlot> {
        [
            self.base_color_texture.as_mut(),
            self.metallic_roughness_texture.as_mut(),
            self.emissive_texture.as_mut(),
            self.normal_texture.as_mut(),
            self.clearcoat_normal_texture.as_mut(),
        ]
        .into_iter()
        .chain(self.extension_textures.slots_mut())
        .flatten()
    }

    /// The base colour at a hit: factor × texture × vertex colour `color`.
    pub fn base_color_at(&self, uv: impl Into<TexCoords>, color: Vec3) -> Vec3 {
        self.factors.base_color * TextureSlot::or_one(&self.base_color_texture, uv.into()) * color
    }

    /// What `bsdf::gltf` takes at a hit with texture coordinates `uv` and vertex colour `color`.
    #[inline]
    pub fn params_at(&self, uv: impl Into<TexCoords>, color: Vec3) -> PbrParams {
        let uv = uv.into();
        let mr = TextureSlot::or_one(&self.metallic_roughness_texture, uv);
        let factors = PbrParams {
            base_color: self.base_color_at(uv, color),
            metallic: self.factors.metallic * mr.z,
            roughness: self.factors.roughness * mr.y,
            ..self.factors
        };
        self.extension_textures.apply(factors, uv)
    }

    /// Whether the clearcoat layer may have a normal other than the shading normal: a coat,
    /// and a normal map on it or on the base (which the coat then does not follow).
    pub fn coat_has_own_normal(&self) -> bool {
        self.factors.clearcoat > 0.0 && (self.normal_texture.is_some() || self.clearcoat_normal_texture.is_some())
    }

    /// The texture coordinate set the mesh's tangents serve (`TANGENT`, or MikkTSpace's from
    /// that set): `normalTexture`'s, else `clearcoatNormalTexture`'s; `None` without either.
    pub fn tangent_set(&self) -> Option<u32> {
        self.normal_texture.as_ref().or(self.clearcoat_normal_texture.as_ref()).map(|t| t.tex_coord.min(1))
    }

    /// The emitted radiance at a hit: `emission × emissiveTexture(uv)`.
    pub fn emission_at(&self, uv: impl Into<TexCoords>) -> Vec3 {
        self.emission * TextureSlot::or_one(&self.emissive_texture, uv.into())
    }

    /// The absorption coefficient inside (`KHR_materials_volume`, Beer–Lambert):
    /// `σ_a = −ln(attenuationColor) / attenuationDistance`, per unit of world length; `None`
    /// for a thin-walled or non-absorbing material.
    pub fn sigma_a(&self) -> Option<Vec3> {
        let d = self.attenuation_distance;
        if !(self.thickness > 0.0 && d > 0.0 && d.is_finite()) || self.attenuation_color == Vec3::ONE {
            return None;
        }
        let c = self.attenuation_color.clamp(Vec3::splat(1e-30), Vec3::ONE);
        Some(Vec3::new(-c.x.ln(), -c.y.ln(), -c.z.ln()) / d)
    }

    /// The lecture material closest to this one, which the Whitted integrator renders
    /// (the table in `docs/scene-format.md`). Textures other than the base colour's enter by
    /// their mean texel: `m = metallic · mean(B)`, `r = roughness · mean(G)`, emission
    /// `emission · mean(emissiveTexture)`, `t = transmission · mean(transmissionTexture.r)`;
    /// `base` is `base_color · mean(baseColorTexture)`.
    ///
    /// - transmission `t > 0` → glass: `k_t = t·base`, `η = ior`, diffuse
    ///   `(1 − t)(1 − m)·baseColor(uv)`;
    /// - `m = 1` and `r ≤ 0.1` → an ideal mirror of reflectance `base`;
    /// - otherwise Lambert `(1 − m)·baseColor(uv)` plus, for a partly metallic surface, a
    ///   normalised Blinn–Phong highlight of weight `m·base` and exponent
    ///   [`shininess_of_roughness`]. A dielectric's own 4 % specular reflection is left out, so
    ///   a non-metal is exactly Lambertian.
    /// - unlit: Lambert of the base colour (Whitted has no unlit surface).
    pub fn lecture_form(&self, name: String) -> Material {
        let mr = TextureSlot::mean(&self.metallic_roughness_texture);
        let metallic = (self.factors.metallic * mr.z).clamp(0.0, 1.0);
        let roughness = self.factors.roughness * mr.y;
        let base = (self.factors.base_color * TextureSlot::mean(&self.base_color_texture)).clamp(Vec3::ZERO, Vec3::ONE);
        let diffuse = |k: f32| match &self.base_color_texture {
            Some(t) => Texture::Image(TextureSlot {
                texture: ImageTexture { factor: self.factors.base_color * k, ..t.texture.clone() },
                ..t.clone()
            }),
            None => Texture::Constant(self.factors.base_color * k),
        };
        let emission = self.emission * TextureSlot::mean(&self.emissive_texture);
        let transmission = self.factors.transmission * TextureSlot::mean(&self.extension_textures.transmission).x;
        let mut m = Material { name, emission, ior: self.factors.ior, ..Material::default() };
        if self.unlit {
            m.diffuse = diffuse(1.0);
            m.emission = Vec3::ZERO;
        } else if transmission > 0.0 {
            let t = transmission.min(1.0);
            m.transmission = base * t;
            m.diffuse = diffuse((1.0 - t) * (1.0 - metallic));
        } else if metallic >= 1.0 && roughness <= MIRROR_ROUGHNESS {
            m.diffuse = Texture::Constant(Vec3::ZERO);
            m.mirror = base;
        } else {
            m.diffuse = diffuse(1.0 - metallic);
            if metallic > 0.0 {
                m.specular = metallic * base;
                m.shininess = shininess_of_roughness(roughness);
            }
        }
        m
    }

    /// Why this material cannot be rendered, if it cannot: a value that is not a finite
    /// number, a negative colour.
    pub fn problem(&self) -> Option<String> {
        let numbers = [
            ("metallic", self.factors.metallic),
            ("roughness", self.factors.roughness),
            ("ior", self.factors.ior),
            ("transmission", self.factors.transmission),
            ("specular", self.factors.specular),
            ("clearcoat", self.factors.clearcoat),
            ("clearcoat roughness", self.factors.clearcoat_roughness),
            ("sheen roughness", self.factors.sheen_roughness),
            ("thickness", self.thickness),
        ];
        numbers
            .iter()
            .find(|(_, x)| !(x.is_finite() && *x >= 0.0))
            .map(|(what, x)| format!("{what} {x} must be a finite number ≥ 0"))
            .or_else(|| bad_colour("base colour", self.factors.base_color))
            .or_else(|| bad_colour("emission", self.emission))
            .or_else(|| bad_colour("specular colour", self.factors.specular_color))
            .or_else(|| bad_colour("sheen colour", self.factors.sheen_color))
            .or_else(|| bad_colour("attenuation colour", self.attenuation_color))
            .or_else(|| {
                (!self.normal_scale.is_finite()).then(|| format!("normal scale {} must be finite", self.normal_scale))
            })
            .or_else(|| {
                (!self.clearcoat_normal_scale.is_finite())
                    .then(|| format!("clearcoat normal scale {} must be finite", self.clearcoat_normal_scale))
            })
            .or_else(|| {
                (!(self.attenuation_distance > 0.0))
                    .then(|| format!("attenuation distance {} must be > 0", self.attenuation_distance))
            })
    }
}

fn bad_colour(what: &str, c: Vec3) -> Option<String> {
    (!(c.is_finite() && c.min_element() >= 0.0)).then(|| format!("{what} {c} must be finite and ≥ 0"))
}

/// glTF's `alphaMode`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum AlphaMode {
    /// Every hit exists (`OPAQUE`, the default).
    Opaque,
    /// A hit exists where `α ≥ cutoff` (`MASK`, `alphaCutoff`).
    Mask { cutoff: f32 },
    /// A hit exists with probability `α` (`BLEND`, as stochastic transparency).
    Blend,
}

/// What decides whether a hit on a material's surface exists: glTF's `alphaMode`, the base
/// colour's alpha and `doubleSided`, tested while tracing by [`crate::scene::alpha`].
#[derive(Clone, Debug, PartialEq)]
pub struct Coverage {
    pub mode: AlphaMode,
    /// `baseColorFactor`'s alpha.
    pub factor: f32,
    /// The base colour texture's alpha plane, with the colour texture's sampler, `texCoord`
    /// and transform.
    pub texture: Option<TextureSlot>,
    /// `doubleSided: false`: camera rays do not see the back face.
    pub cull_back_faces: bool,
}

impl Coverage {
    /// The coverage of a glTF material, `None` when every hit exists (opaque and two-sided).
    pub fn of(mode: AlphaMode, factor: f32, texture: Option<TextureSlot>, double_sided: bool) -> Option<Coverage> {
        (mode != AlphaMode::Opaque || !double_sided).then_some(Coverage {
            mode,
            factor,
            texture: if mode == AlphaMode::Opaque { None } else { texture },
            cull_back_faces: !double_sided,
        })
    }

    /// `α` at texture coordinates `uv` with vertex alpha `vertex`.
    #[inline]
    pub fn alpha(&self, uv: [Vec2; 2], vertex: f32) -> f32 {
        let texture = self.texture.as_ref().map_or(1.0, |t| t.at(uv).x);
        self.factor * texture * vertex
    }

    /// Why this coverage cannot be rendered, if it cannot.
    pub fn problem(&self) -> Option<String> {
        if !self.factor.is_finite() {
            return Some(format!("base colour alpha {} is not finite", self.factor));
        }
        match self.mode {
            AlphaMode::Mask { cutoff } if !cutoff.is_finite() => Some(format!("alphaCutoff {cutoff} is not finite")),
            _ => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const CHECKER: &Texture = &Texture::Checker { even: Vec3::ONE, odd: Vec3::ZERO, size: 1.0 };

    #[test]
    fn checker_cells_alternate() {
        let up = Vec3::Y;
        assert_eq!(CHECKER.albedo_at(Vec3::new(0.5, 0.5, 0.5), up, [Vec2::ZERO; 2]), Vec3::ONE);
        assert_eq!(CHECKER.albedo_at(Vec3::new(1.5, 0.5, 0.5), up, [Vec2::ZERO; 2]), Vec3::ZERO);
        assert_eq!(CHECKER.albedo_at(Vec3::new(-0.5, 0.5, 0.5), up, [Vec2::ZERO; 2]), Vec3::ZERO);
        assert_eq!(CHECKER.albedo_at(Vec3::new(-0.5, -0.5, 0.5), up, [Vec2::ZERO; 2]), Vec3::ONE);
    }

    #[test]
    fn a_floor_on_a_cell_boundary_is_one_cell_thick() {
        // Points on y = 0, a hair above and below it: all take the cell below (y ∈ [−1, 0)).
        for y in [0.0f32, 1e-7, -1e-7] {
            assert_eq!(CHECKER.albedo_at(Vec3::new(0.5, y, 0.5), Vec3::Y, [Vec2::ZERO; 2]), Vec3::ZERO, "y = {y}");
            assert_eq!(CHECKER.albedo_at(Vec3::new(1.5, y, 0.5), Vec3::Y, [Vec2::ZERO; 2]), Vec3::ONE, "y = {y}");
        }
    }

    #[test]
    fn roughness_to_shininess() {
        assert_eq!(shininess_of_roughness(1.0), 0.0);
        assert_eq!(shininess_of_roughness(0.5), 30.0);
        assert_eq!(shininess_of_roughness(0.0), 1e4);
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
