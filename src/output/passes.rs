//! The passes (AOVs) a render can write, and which of them a render writes.
//!
//! The light-path passes follow Blender's meanings (Blender manual, "Render Passes"): the
//! light a camera ray brings is split by what the first hit did with it — emitted it (`Emit`),
//! or scattered it by a diffuse, glossy or transmitting lobe, directly from a light or an
//! emitter (`…Dir`) or after more bounces (`…Ind`) — plus the environment camera rays see
//! directly (`Env`). The direct and indirect passes are divided by their family's colour at the
//! first hit (`…Col`), so that, for every pixel and channel, to float rounding,
//!
//! ```text
//! Combined.RGB = (DiffDir + DiffInd)·DiffCol + (GlossDir + GlossInd)·GlossCol
//!              + (TransDir + TransInd)·TransCol + Emit + Env
//! ```
//!
//! Blender's compositor recipe. Each integrator says which of its terms go where
//! ([`crate::integrator::whitted`], [`crate::integrator::path`]); a `…Dir`/`…Ind` channel is 0
//! where its colour is 0.
//!
//! | pass (`--passes` name) | Blender layer | meaning | unit |
//! |---|---|---|---|
//! | `combined` | `Combined` (RGBA) | the beauty; A is the alpha of [`crate::output::film`] | W/(m²·sr) |
//! | `depth` | `Depth` (Z) | depth of the nearest first hit along the camera's view axis (Blender's and Nuke's Z), `+inf` on a miss | scene units |
//! | `normal` | `Normal` (XYZ) | world-space shading normal at the first hit, coverage-weighted | ≤ 1 |
//! | `albedo` | `DiffCol` (RGB) | the colour of the first hit's diffuse lobes (ρ of a Lambert surface), coverage-weighted | 1 |
//! | `emission` | `Emit` | emission `L_e` of the first hit | W/(m²·sr) |
//! | `diffuse_direct` | `DiffDir` | light from lights and emitters scattered once, by the first hit's diffuse lobes, ÷ DiffCol | W/(m²·sr) |
//! | `diffuse_indirect` | `DiffInd` | light scattered more than once, first by the first hit's diffuse lobes, ÷ DiffCol | W/(m²·sr) |
//! | `glossy_direct` | `GlossDir` | as `diffuse_direct`, for glossy and specular reflection | W/(m²·sr) |
//! | `glossy_indirect` | `GlossInd` | as `diffuse_indirect`, for glossy and specular reflection | W/(m²·sr) |
//! | `glossy_color` | `GlossCol` (RGB) | the colour of the first hit's glossy and specular reflection | 1 |
//! | `transmission_direct` | `TransDir` | as `diffuse_direct`, for transmission | W/(m²·sr) |
//! | `transmission_indirect` | `TransInd` | as `diffuse_indirect`, for transmission | W/(m²·sr) |
//! | `transmission_color` | `TransCol` (RGB) | the colour of the first hit's transmission | 1 |
//! | `background` | `Env` | the environment (background) radiance of camera rays that hit nothing | W/(m²·sr) |
//! | `position` | `Position` (XYZ) | world position of the nearest first hit, 0 on a miss | scene units |
//! | `distance` | `Distance` (Z) | length of the primary ray from its origin to the nearest first hit, `+inf` on a miss | scene units |
//! | `object_index` | `IndexOB` (X) | 1 + the object's index in the object list (0 on a miss) | 1 |
//! | `material_index` | `IndexMA` (X) | 1 + the material's index in the scene (0 on a miss) | 1 |
//! | `crypto_object` | `CryptoObject00..` | Cryptomatte ranks of the objects ([`crate::output::cryptomatte`]) | id, coverage |
//! | `crypto_material` | `CryptoMaterial00..` | Cryptomatte ranks of the materials | id, coverage |
//! | `disagreement` | `Disagreement` (X) | the fraction of the pixel's camera rays whose first hit (primitive, or none) differs between Embree and the native BVH | 1 |
//! | `sample_count` | `Debug Sample Count` (X) | the samples the pixel took divided by `spp`, as Cycles writes it: 1 but where adaptive sampling stopped the pixel early ([`crate::integrator::adaptive`]) | 1 |
//! | `variance` | `Variance` (RGB) | the variance of the pixel's beauty (the mean of its samples), per channel ([`crate::integrator::adaptive::PixelNoise::variance_of_mean`]) | (W/(m²·sr))² |
//! | `denoising_albedo` | `Denoising Albedo` (RGB) | the albedo of the first surface that is not mostly specular, seen through mirrors and glass (Fresnel-weighted), a light's or the background's colour where they are seen; mean over all samples ([`crate::integrator::features`]); OIDN's albedo | 1 |
//! | `denoising_normal` | `Denoising Normal` (XYZ) | the world-space shading normal of that surface, Fresnel-weighted through glass, 0 on lights and misses; mean over all samples; OIDN's normal | 1 |
//!
//! `--passes diffuse`, `glossy` and `transmission` name a family's three passes at once, and
//! `light` every light-path pass with the colours.
//!
//! Emit, Env and the direct and indirect light (before the division), the normal and the colours
//! are means over all of the pixel's samples, like the beauty, a sample that hits nothing
//! counting 0 (coverage-weighted, as Cycles accumulates them: at an edge against the background
//! DiffCol and Normal fade with the coverage, and the division still undoes the colour
//! exactly); depth, distance, position and the indices belong to the nearest hit sample. What is seen through a mirror (background included) is glossy light,
//! not background: `Env` holds only what camera rays see directly.
//!
//! `disagreement` traces every camera ray through both backends (the render's own and the
//! other one, [`crate::accel::paired`]): it shows, in any render, where Embree and the native
//! BVH would not agree (grazing rays along shared edges, where rounding decides;
//! `strahl crosscheck` explains them). It costs the second BVH and a second camera ray per
//! sample, so `all` leaves it out.
//!
//! `denoising_albedo` and `denoising_normal` follow the camera ray through mirrors and glass
//! ([`crate::integrator::features`]), tracing rays of their own (+10 % time on the Cornell
//! box), so `all` leaves them out too; `render --denoise` adds them, and a farm's tiles name
//! them in `--passes` for `farm slurm --denoise` to denoise with them.

use std::fmt;

/// One pass a render can write.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Pass {
    Combined,
    Depth,
    Normal,
    Albedo,
    Emission,
    DiffuseDirect,
    DiffuseIndirect,
    GlossyDirect,
    GlossyIndirect,
    GlossyColor,
    TransmissionDirect,
    TransmissionIndirect,
    TransmissionColor,
    Background,
    Position,
    Distance,
    ObjectIndex,
    MaterialIndex,
    CryptoObject,
    CryptoMaterial,
    Disagreement,
    SampleCount,
    Variance,
    DenoisingAlbedo,
    DenoisingNormal,
}

/// The light-path passes that hold radiance, in the order of
/// [`crate::integrator::Radiance::terms`].
pub const LIGHT_PASSES: [Pass; 8] = [
    Pass::Emission,
    Pass::DiffuseDirect,
    Pass::DiffuseIndirect,
    Pass::GlossyDirect,
    Pass::GlossyIndirect,
    Pass::TransmissionDirect,
    Pass::TransmissionIndirect,
    Pass::Background,
];

/// The passes of each lobe family: (direct, indirect, colour), diffuse, glossy, transmission.
pub const FAMILIES: [(Pass, Pass, Pass); 3] = [
    (Pass::DiffuseDirect, Pass::DiffuseIndirect, Pass::Albedo),
    (Pass::GlossyDirect, Pass::GlossyIndirect, Pass::GlossyColor),
    (Pass::TransmissionDirect, Pass::TransmissionIndirect, Pass::TransmissionColor),
];

impl Pass {
    /// Every pass, in the order of the module docs (and of the channels in the film).
    pub const ALL: [Pass; 25] = [
        Pass::Combined,
        Pass::Depth,
        Pass::Normal,
        Pass::Albedo,
        Pass::Emission,
        Pass::DiffuseDirect,
        Pass::DiffuseIndirect,
        Pass::GlossyDirect,
        Pass::GlossyIndirect,
        Pass::GlossyColor,
        Pass::TransmissionDirect,
        Pass::TransmissionIndirect,
        Pass::TransmissionColor,
        Pass::Background,
        Pass::Position,
        Pass::Distance,
        Pass::ObjectIndex,
        Pass::MaterialIndex,
        Pass::CryptoObject,
        Pass::CryptoMaterial,
        Pass::Disagreement,
        Pass::SampleCount,
        Pass::Variance,
        Pass::DenoisingAlbedo,
        Pass::DenoisingNormal,
    ];

    /// The name on the command line and in `[output] passes`.
    pub fn name(self) -> &'static str {
        match self {
            Pass::Combined => "combined",
            Pass::Depth => "depth",
            Pass::Normal => "normal",
            Pass::Albedo => "albedo",
            Pass::Emission => "emission",
            Pass::DiffuseDirect => "diffuse_direct",
            Pass::DiffuseIndirect => "diffuse_indirect",
            Pass::GlossyDirect => "glossy_direct",
            Pass::GlossyIndirect => "glossy_indirect",
            Pass::GlossyColor => "glossy_color",
            Pass::TransmissionDirect => "transmission_direct",
            Pass::TransmissionIndirect => "transmission_indirect",
            Pass::TransmissionColor => "transmission_color",
            Pass::Background => "background",
            Pass::Position => "position",
            Pass::Distance => "distance",
            Pass::ObjectIndex => "object_index",
            Pass::MaterialIndex => "material_index",
            Pass::CryptoObject => "crypto_object",
            Pass::CryptoMaterial => "crypto_material",
            Pass::Disagreement => "disagreement",
            Pass::SampleCount => "sample_count",
            Pass::Variance => "variance",
            Pass::DenoisingAlbedo => "denoising_albedo",
            Pass::DenoisingNormal => "denoising_normal",
        }
    }

    /// The pass called `name` ([`Pass::name`]).
    pub fn from_name(name: &str) -> Option<Pass> {
        Pass::ALL.into_iter().find(|p| p.name() == name)
    }

    /// Whether this is one of the [`LIGHT_PASSES`].
    pub fn is_light(self) -> bool {
        LIGHT_PASSES.contains(&self)
    }

    /// Whether this is a Cryptomatte pass.
    pub fn is_crypto(self) -> bool {
        matches!(self, Pass::CryptoObject | Pass::CryptoMaterial)
    }

    /// Whether this is a family's colour (`albedo`, `glossy_color`, `transmission_color`).
    pub fn is_family_colour(self) -> bool {
        matches!(self, Pass::Albedo | Pass::GlossyColor | Pass::TransmissionColor)
    }

    /// Whether the pass is a colour (radiance or reflectance). `--half` stores these, and the
    /// normals, as half floats ([`crate::output::exr`]).
    pub fn is_colour(self) -> bool {
        self == Pass::Combined || self == Pass::DenoisingAlbedo || self.is_light() || self.is_family_colour()
    }

    /// Floats per pixel in the film ([`crate::output::film::Film::aovs`]); `crypto_levels` ranks of
    /// (id, coverage) make `⌈levels/2⌉` RGBA layers for a Cryptomatte pass.
    pub fn floats_per_pixel(self, crypto_levels: u32) -> usize {
        match self {
            Pass::Combined => 4,
            Pass::Depth
            | Pass::Distance
            | Pass::ObjectIndex
            | Pass::MaterialIndex
            | Pass::Disagreement
            | Pass::SampleCount => 1,
            Pass::CryptoObject | Pass::CryptoMaterial => 4 * crypto_levels.div_ceil(2) as usize,
            _ => 3,
        }
    }
}

impl fmt::Display for Pass {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// A set of passes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct PassSet(u32);

impl Default for PassSet {
    /// `combined, depth, normal, albedo`: what strahl always wrote, 44 bytes per pixel.
    fn default() -> Self {
        PassSet::of(&[Pass::Combined, Pass::Depth, Pass::Normal, Pass::Albedo])
    }
}

impl PassSet {
    /// The passes in `passes`, plus `combined` (always written).
    pub fn of(passes: &[Pass]) -> PassSet {
        PassSet(passes.iter().fold(1 << Pass::Combined as u32, |bits, &p| bits | 1 << p as u32))
    }

    /// Every pass but `disagreement` (which traces a second backend, see the module docs) and
    /// the denoising features (which trace rays of their own; `--denoise` adds them).
    pub fn all() -> PassSet {
        let traced = [Pass::Disagreement, Pass::DenoisingAlbedo, Pass::DenoisingNormal];
        PassSet(PassSet::of(&Pass::ALL).0 & !traced.iter().fold(0, |bits, &p| bits | 1 << p as u32))
    }

    /// This set and `passes`.
    pub fn with(self, passes: &[Pass]) -> PassSet {
        PassSet(self.0 | PassSet::of(passes).0)
    }

    pub fn contains(self, pass: Pass) -> bool {
        self.0 & (1 << pass as u32) != 0
    }

    /// The passes in the set, in [`Pass::ALL`] order.
    pub fn iter(self) -> impl Iterator<Item = Pass> {
        Pass::ALL.into_iter().filter(move |&p| self.contains(p))
    }

    /// Whether any light-path pass is in the set.
    pub fn any_light(self) -> bool {
        self.iter().any(Pass::is_light)
    }

    /// Parses a list of pass names: each a [`Pass::name`], or `default` (the default set) or
    /// `all` ([`PassSet::all`]). `combined` is always included. Errors name the unknown pass and the known ones.
    pub fn parse<S: AsRef<str>>(names: &[S]) -> Result<PassSet, String> {
        let mut set = PassSet::of(&[]);
        for name in names {
            let name = name.as_ref().trim();
            let more = match name {
                "default" => PassSet::default(),
                "all" => PassSet::all(),
                "light" => PassSet::of(&LIGHT_PASSES).with(&[Pass::Albedo, Pass::GlossyColor, Pass::TransmissionColor]),
                "diffuse" | "glossy" | "transmission" => {
                    let (d, i, c) =
                        FAMILIES[["diffuse", "glossy", "transmission"].iter().position(|&f| f == name).unwrap_or(0)];
                    PassSet::of(&[d, i, c])
                }
                _ => match Pass::from_name(name) {
                    Some(p) => PassSet::of(&[p]),
                    None => {
                        let known: Vec<&str> = Pass::ALL.iter().map(|p| p.name()).collect();
                        return Err(format!(
                            "unknown pass '{name}' (known: default, all, light, diffuse, glossy, transmission, {})",
                            known.join(", ")
                        ));
                    }
                },
            };
            set.0 |= more.0;
        }
        Ok(set)
    }
}

/// What the film holds and how alpha is made: the output settings of a scene (`[output]`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct OutputSpec {
    /// The passes rendered.
    pub passes: PassSet,
    /// Rays that hit nothing return radiance 0 instead of the background, and alpha is the
    /// coverage (see [`crate::output::film`]); otherwise alpha is 1 everywhere.
    pub transparent: bool,
    /// Cryptomatte ranks of (id, coverage) per pixel ("levels"), 1 to [`MAX_CRYPTO_LEVELS`].
    pub crypto_levels: u32,
}

/// Most Cryptomatte levels (ranks) a pass may have.
pub const MAX_CRYPTO_LEVELS: u32 = 16;

impl Default for OutputSpec {
    fn default() -> Self {
        OutputSpec { passes: PassSet::default(), transparent: false, crypto_levels: 6 }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_parse() {
        for p in Pass::ALL {
            assert_eq!(Pass::from_name(p.name()), Some(p));
        }
        let set = PassSet::parse(&["depth", "crypto_object"]).unwrap();
        assert_eq!(set.iter().collect::<Vec<_>>(), [Pass::Combined, Pass::Depth, Pass::CryptoObject]);
        assert_eq!(PassSet::parse(&["all"]).unwrap(), PassSet::all());
        assert!(PassSet::parse(&["default", "nope"]).unwrap_err().starts_with("unknown pass 'nope'"));
        assert!(PassSet::default().contains(Pass::Albedo) && !PassSet::default().any_light());
        let glossy = PassSet::parse(&["glossy"]).unwrap();
        assert_eq!(
            glossy.iter().collect::<Vec<_>>(),
            [Pass::Combined, Pass::GlossyDirect, Pass::GlossyIndirect, Pass::GlossyColor]
        );
        let light = PassSet::parse(&["light"]).unwrap();
        assert_eq!(light.iter().count(), 1 + 8 + 3);
        assert!(PassSet::parse(&["specular"]).is_err());
    }

    #[test]
    fn crypto_layers_hold_two_ranks_each() {
        assert_eq!(Pass::CryptoObject.floats_per_pixel(6), 12);
        assert_eq!(Pass::CryptoObject.floats_per_pixel(5), 12);
        assert_eq!(Pass::CryptoMaterial.floats_per_pixel(1), 4);
    }
}
