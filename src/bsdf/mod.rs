//! Bidirectional scattering distribution functions for the path tracer, in pbrt-v4's
//! conventions:
//!
//! * directions point away from the surface (`wo` towards the viewer, `wi` towards the light);
//! * `f(wo, wi)` excludes the cosine: reflected radiance is `∫ f(wo, wi) L(wi) |cos θi| dωi`;
//! * densities are per steradian of `wi`;
//! * a perfectly specular lobe is a discrete choice: its sample carries the probability of
//!   choosing it as `pdf` and a value `f` such that `f |cos θi| / pdf` is its weight, and it has
//!   no value or density at any given pair of directions (`eval`, `pdf` leave it out);
//! * transmission carries radiance: refraction into a denser medium scales it by `1/η²`
//!   ([`glass`]), and `BsdfSample::eta` tells the integrator what was crossed.
//!
//! A [`Bsdf`] is a small fixed set of weighted lobes in a shading [`Frame`], plus the geometric
//! normal: reflection needs `wo` and `wi` on the same side of both the shading and the
//! geometric normal, transmission on opposite sides of both (no light leaks through shading
//! normals). Lobes are values of one enum (no allocation, no trait objects). Each lobe belongs
//! to a pass family ([`PassClass`], Blender's Diff/Gloss/Trans) so the integrator can split its
//! light the way Blender's passes do.
//!
//! The lobes are layered by **albedo scaling**: a lobe beneath a layer of directional albedo
//! `A(μ)` is multiplied by `min(1 − A(μo), 1 − A(μi))` (the form `KHR_materials_sheen`
//! specifies): reciprocal and energy-conserving over any base (the base reflects at most
//! `1 − A(μo)` of what it receives). glTF's sheen and clearcoat layer this way; the Lambertian
//! base under the specular layer uses the exact, energy-preserving form of [`lambert`].
//!
//! Constructors: [`Bsdf::new`] (black), then [`lecture`] (strahl's Whitted materials as lobes)
//! or [`gltf`] (the glTF 2.0 metallic-roughness material and its extensions) add the lobes.

mod albedo;
mod blinn_phong;
mod denoising;
mod frame;
mod fresnel;
mod ggx;
mod glass;
mod gltf;
mod lambert;
mod lecture;
mod microfacet;
mod sheen;
mod specular;

#[cfg(test)]
mod tests;

pub use denoising::DenoisingSplit;
pub use frame::Frame;
pub use ggx::SMOOTH_ALPHA;
pub use gltf::{PbrParams, appendix_b, gltf};
pub use lecture::{LectureParams, lecture};

use arrayvec::ArrayVec;

use crate::math::{Vec2, Vec3};

/// What a lobe does: reflect and/or transmit, and how (diffuse, glossy or perfectly specular).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct LobeFlags(u8);

impl LobeFlags {
    pub const NONE: LobeFlags = LobeFlags(0);
    pub const REFLECTION: LobeFlags = LobeFlags(1);
    pub const TRANSMISSION: LobeFlags = LobeFlags(2);
    pub const DIFFUSE: LobeFlags = LobeFlags(4);
    pub const GLOSSY: LobeFlags = LobeFlags(8);
    pub const SPECULAR: LobeFlags = LobeFlags(16);

    /// Both sets of flags.
    #[inline]
    pub const fn union(self, o: LobeFlags) -> LobeFlags {
        LobeFlags(self.0 | o.0)
    }

    /// Whether every flag of `o` is set.
    #[inline]
    pub const fn contains(self, o: LobeFlags) -> bool {
        self.0 & o.0 == o.0
    }

    /// Whether any flag of `o` is set.
    #[inline]
    pub const fn intersects(self, o: LobeFlags) -> bool {
        self.0 & o.0 != 0
    }

    #[inline]
    pub const fn is_specular(self) -> bool {
        self.contains(LobeFlags::SPECULAR)
    }

    pub const fn bits(self) -> u8 {
        self.0
    }
}

impl std::ops::BitOr for LobeFlags {
    type Output = LobeFlags;
    fn bitor(self, o: LobeFlags) -> LobeFlags {
        self.union(o)
    }
}

/// Blender's pass families: light scattered by diffuse, glossy (including specular
/// reflection) or transmitting lobes lands in DiffDir/DiffInd, GlossDir/GlossInd or
/// TransDir/TransInd.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum PassClass {
    Diffuse,
    Glossy,
    Transmission,
}

/// A value per pass family: `f` split by the lobes' classes, or the classes' colours.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BsdfEval {
    pub diffuse: Vec3,
    pub glossy: Vec3,
    pub transmission: Vec3,
}

impl BsdfEval {
    /// The total over the families.
    #[inline]
    pub fn sum(&self) -> Vec3 {
        self.diffuse + self.glossy + self.transmission
    }

    /// Adds `v` to the family `class`.
    #[inline]
    pub fn add(&mut self, class: PassClass, v: Vec3) {
        match class {
            PassClass::Diffuse => self.diffuse += v,
            PassClass::Glossy => self.glossy += v,
            PassClass::Transmission => self.transmission += v,
        }
    }

    /// The family `class`.
    #[inline]
    pub fn get(&self, class: PassClass) -> Vec3 {
        match class {
            PassClass::Diffuse => self.diffuse,
            PassClass::Glossy => self.glossy,
            PassClass::Transmission => self.transmission,
        }
    }
}

/// A sampled direction (see the module docs for specular samples).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BsdfSample {
    /// World-space unit direction towards the light.
    pub wi: Vec3,
    /// The total `f` of the non-specular lobes at `(wo, wi)`, or the sampled specular lobe's
    /// value such that `f |cos θi| / pdf` is its weight.
    pub f: Vec3,
    /// The mixture's density at `wi` (per steradian), or the discrete probability of the
    /// specular choice.
    pub pdf: f32,
    /// The sampled lobe's flags, with REFLECTION or TRANSMISSION as the sample went.
    pub flags: LobeFlags,
    /// The sampled lobe's pass family.
    pub class: PassClass,
    /// The relative index crossed, `η_wi side / η_wo side` (1 for reflection).
    pub eta: f32,
}

impl BsdfSample {
    /// Whether the sample went through the surface.
    #[inline]
    pub fn is_transmission(&self) -> bool {
        self.flags.contains(LobeFlags::TRANSMISSION)
    }
}

/// One lobe's sample, in local coordinates.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct LobeSample {
    pub wi: Vec3,
    pub f: Vec3,
    pub pdf: f32,
    pub specular: bool,
    pub eta: f32,
}

/// The lobes a BSDF may hold.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Lobe {
    Lambert(lambert::Lambert),
    LayeredDiffuse(lambert::LayeredDiffuse),
    BlinnPhong(blinn_phong::BlinnPhong),
    Mirror(specular::Mirror),
    SmoothDielectric(specular::SmoothDielectric),
    Microfacet(microfacet::Microfacet),
    Tilted(microfacet::Tilted),
    Glass(glass::Glass),
    Sheen(sheen::Sheen),
}

impl Lobe {
    fn flags(&self) -> LobeFlags {
        match self {
            Lobe::Lambert(_) | Lobe::LayeredDiffuse(_) => lambert::FLAGS,
            Lobe::BlinnPhong(_) => blinn_phong::FLAGS,
            Lobe::Mirror(_) => specular::MIRROR_FLAGS,
            Lobe::SmoothDielectric(_) => specular::DIELECTRIC_FLAGS,
            Lobe::Microfacet(m) => m.flags(),
            Lobe::Tilted(t) => t.lobe.flags(),
            Lobe::Glass(g) => g.flags(),
            Lobe::Sheen(_) => sheen::FLAGS,
        }
    }

    /// The directional albedo from the local direction `w`: [`Lobe::albedo`] at `w.z`, a
    /// [`Lobe::Tilted`]'s at its own `cos θ'`.
    #[inline]
    fn albedo_from(&self, w: Vec3) -> Vec3 {
        if let Lobe::Tilted(t) = self { t.albedo(w) } else { self.albedo(w.z) }
    }

    /// Whether the lobe has nothing for a pair that is `transmitted`, or a reflection `below`
    /// the shading normal's horizon ([`Bsdf::local_pair`]): a [`Lobe::Tilted`] only reflects,
    /// into either; the others, whose own checks are in the shading frame, see no such
    /// reflection.
    #[inline]
    fn skips(&self, transmitted: bool, below: bool) -> bool {
        if let Lobe::Tilted(_) = self { transmitted } else { below }
    }

    /// The pass family of light the lobe reflects, or transmits when `transmitted`.
    fn class(&self, transmitted: bool) -> PassClass {
        if transmitted {
            return PassClass::Transmission;
        }
        match self {
            Lobe::Lambert(_) | Lobe::LayeredDiffuse(_) => lambert::CLASS,
            Lobe::Sheen(_) => sheen::CLASS,
            Lobe::BlinnPhong(_) => blinn_phong::CLASS,
            Lobe::Mirror(_) | Lobe::SmoothDielectric(_) | Lobe::Glass(_) => PassClass::Glossy,
            Lobe::Microfacet(_) | Lobe::Tilted(_) => microfacet::CLASS,
        }
    }

    #[inline]
    fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        match self {
            Lobe::Lambert(l) => lambert::eval(l, wo, wi),
            Lobe::LayeredDiffuse(l) => lambert::eval(l, wo, wi),
            Lobe::Mirror(_) | Lobe::SmoothDielectric(_) => Vec3::ZERO,
            _ => self.eval_half_vector(wo, wi),
        }
    }

    /// [`Lobe::eval`] of the lobes that need the half vector. Out of line: inlined into the
    /// loops over the lobes ([`Bsdf::eval`]), the compiler computed the half vector and its
    /// Fresnel term (a square root and a division) before the loop for every BSDF, a
    /// Lambertian one too.
    #[inline(never)]
    fn eval_half_vector(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        match self {
            Lobe::BlinnPhong(b) => b.eval(wo, wi),
            Lobe::Microfacet(m) => m.weight * m.layer.eval(wo, wi),
            Lobe::Tilted(t) => t.eval(wo, wi),
            Lobe::Glass(g) => g.eval(wo, wi),
            Lobe::Sheen(s) => s.color * s.value(wo, wi),
            // Not reached: [`Lobe::eval`] answers for the others.
            _ => Vec3::ZERO,
        }
    }

    #[inline]
    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        match self {
            Lobe::Lambert(_) | Lobe::LayeredDiffuse(_) | Lobe::Sheen(_) => lambert::pdf(wo, wi),
            Lobe::Mirror(_) | Lobe::SmoothDielectric(_) => 0.0,
            _ => self.pdf_half_vector(wo, wi),
        }
    }

    /// [`Lobe::pdf`] of the lobes that need the half vector, out of line for the reason of
    /// [`Lobe::eval_half_vector`].
    #[inline(never)]
    fn pdf_half_vector(&self, wo: Vec3, wi: Vec3) -> f32 {
        match self {
            Lobe::BlinnPhong(b) => b.pdf(wo, wi),
            Lobe::Microfacet(m) => m.layer.pdf(wo, wi),
            Lobe::Tilted(t) => t.pdf(wo, wi),
            Lobe::Glass(g) => g.pdf(wo, wi),
            // Not reached: [`Lobe::pdf`] answers for the others.
            _ => 0.0,
        }
    }

    #[inline]
    fn sample(&self, wo: Vec3, uc: f32, u: Vec2) -> Option<LobeSample> {
        match self {
            Lobe::Lambert(l) => lambert::sample(l, wo, u),
            Lobe::LayeredDiffuse(l) => lambert::sample(l, wo, u),
            Lobe::Sheen(s) => {
                let wi = crate::sampling::square_to_cosine_hemisphere(u);
                let pdf = lambert::pdf(wo, wi);
                (pdf > 0.0).then(|| LobeSample { wi, f: s.color * s.value(wo, wi), pdf, specular: false, eta: 1.0 })
            }
            Lobe::BlinnPhong(b) => b.sample(wo, u),
            Lobe::Mirror(m) => m.sample(wo),
            Lobe::SmoothDielectric(d) => d.sample(wo, uc),
            Lobe::Microfacet(m) => m.layer.sample(wo, uc, u).map(|s| LobeSample { f: m.weight * s.f, ..s }),
            Lobe::Tilted(t) => t.sample(wo, uc, u),
            Lobe::Glass(g) => g.sample(wo, uc, u),
        }
    }

    /// The directional albedo at `μ` (transmission in energy units), exact for the layered
    /// diffuse lobe and the microfacet layers, an estimate for the others (a
    /// [`Lobe::Tilted`]'s is at its own `cos θ'`: [`Lobe::albedo_from`]).
    #[inline]
    fn albedo(&self, mu: f32) -> Vec3 {
        use lambert::Diffuse;
        match self {
            Lobe::Lambert(l) => l.albedo_at(mu),
            Lobe::LayeredDiffuse(l) => l.albedo_at(mu),
            Lobe::BlinnPhong(b) => b.ks,
            Lobe::Mirror(m) => m.kr,
            Lobe::SmoothDielectric(d) => d.kt,
            Lobe::Microfacet(m) => m.weight * m.layer.albedo(mu),
            Lobe::Tilted(t) => t.lobe.weight * t.lobe.layer.albedo(mu),
            Lobe::Glass(g) => g.albedo(mu),
            Lobe::Sheen(s) => s.albedo(mu),
        }
    }

    /// The colour weights per family, as Cycles' closure weights (Fresnel tints excluded).
    fn colors(&self) -> BsdfEval {
        use lambert::Diffuse;
        let mut c = BsdfEval::default();
        match self {
            Lobe::Lambert(l) => c.diffuse = l.colour(),
            Lobe::LayeredDiffuse(l) => c.diffuse = l.colour(),
            Lobe::Sheen(s) => c.diffuse = s.color,
            Lobe::BlinnPhong(b) => c.glossy = b.ks,
            Lobe::Mirror(m) => c.glossy = m.kr,
            Lobe::SmoothDielectric(d) => (c.glossy, c.transmission) = (d.kt, d.kt),
            Lobe::Microfacet(m) => c.glossy = m.weight,
            Lobe::Tilted(t) => c.glossy = t.lobe.weight,
            Lobe::Glass(g) => (c.glossy, c.transmission) = (g.reflect_weight(), g.tint()),
        }
        c
    }
}

/// The most lobes a BSDF holds (glTF: specular, diffuse, glass, sheen, clearcoat).
pub const MAX_LOBES: usize = 5;

/// Layering bits of a lobe: beneath the sheen, beneath the clearcoat.
const UNDER_SHEEN: u8 = 1;
const UNDER_COAT: u8 = 2;
const NO_LOBE: u8 = u8::MAX;

/// A BSDF at one surface point (module docs).
///
/// The lobes are kept in an [`ArrayVec`]: a BSDF is built at every path vertex and most hold
/// one lobe, so only the lobes pushed are written (an array of [`MAX_LOBES`] slots of 112 bytes
/// each, all initialised, was written out whole at every vertex).
#[derive(Clone, Debug)]
pub struct Bsdf {
    frame: Frame,
    ng: Vec3,
    front_face: bool,
    /// The index of the sheen and of the clearcoat lobe, when there is one.
    sheen: u8,
    coat: u8,
    /// Whether a lobe has a normal of its own ([`Lobe::Tilted`]): it may reflect below the
    /// shading normal's horizon (see [`Bsdf::local_pair`]).
    tilted: bool,
    under: [u8; MAX_LOBES],
    lobes: ArrayVec<Lobe, MAX_LOBES>,
}

/// Black, about `+z`.
impl Default for Bsdf {
    fn default() -> Self {
        Bsdf::new(Frame::from_normal(Vec3::Z), Vec3::Z, true)
    }
}

impl Bsdf {
    /// An empty BSDF (black) in `frame` with geometric normal `ng` (facing `wo`'s side).
    pub fn new(frame: Frame, ng: Vec3, front_face: bool) -> Self {
        Bsdf {
            frame,
            ng,
            front_face,
            sheen: NO_LOBE,
            coat: NO_LOBE,
            tilted: false,
            under: [0; MAX_LOBES],
            lobes: ArrayVec::new(),
        }
    }

    /// Makes this BSDF [`Bsdf::new`]'s, in place.
    pub fn reset(&mut self, frame: Frame, ng: Vec3, front_face: bool) {
        *self = Bsdf::new(frame, ng, front_face);
    }

    /// Gives this BSDF `template`'s lobes and their layering, keeping its own frame and
    /// geometric normal: for lobes that do not depend on the frame (no [`Lobe::Tilted`]) and
    /// were built for this side ([`crate::shading::ConstantBsdfs`]).
    #[inline]
    pub fn set_lobes(&mut self, template: &Bsdf) {
        debug_assert!(!template.tilted && template.front_face == self.front_face);
        self.sheen = template.sheen;
        self.coat = template.coat;
        self.tilted = template.tilted;
        self.under = template.under;
        self.lobes.clone_from(&template.lobes);
    }

    /// Adds a lobe (ignored past [`MAX_LOBES`]; the constructors never exceed it).
    pub(crate) fn push(&mut self, lobe: Lobe) -> usize {
        let k = self.lobes.len();
        debug_assert!(k < MAX_LOBES, "too many lobes");
        self.tilted |= matches!(lobe, Lobe::Tilted(_));
        let _ = self.lobes.try_push(lobe);
        k
    }

    /// Puts every lobe added so far beneath the lobe `top`, which is the sheen (or else the
    /// clearcoat) layer.
    pub(crate) fn layer_over(&mut self, top: usize, sheen: bool) {
        let bit = if sheen { UNDER_SHEEN } else { UNDER_COAT };
        for k in 0..top {
            self.under[k] |= bit;
        }
        if sheen {
            self.sheen = top as u8;
        } else {
            self.coat = top as u8;
        }
    }

    #[inline]
    fn lobes(&self) -> &[Lobe] {
        &self.lobes
    }

    /// The shading frame.
    pub fn frame(&self) -> &Frame {
        &self.frame
    }

    /// The geometric normal, on `wo`'s side.
    pub fn ng(&self) -> Vec3 {
        self.ng
    }

    /// Whether the surface was hit on its front: a transmitted sample then enters the object
    /// (its medium), otherwise it leaves it.
    pub fn front_face(&self) -> bool {
        self.front_face
    }

    /// The layering factors for each combination of [`UNDER_SHEEN`] and [`UNDER_COAT`], with
    /// `albedo(lobe, o)` a lobe's directional albedo from `o` (`μ`, or a local direction for a
    /// BSDF with a [`Lobe::Tilted`]: its layer's albedo at the layer's own `cos θ'`).
    #[inline(always)]
    fn scales_with<T: Copy>(&self, o: T, i: T, albedo: impl Fn(&Lobe, T) -> Vec3) -> [f32; 4] {
        let factor = |top: u8| {
            if top == NO_LOBE {
                1.0
            } else {
                let lobe = &self.lobes[top as usize];
                (1.0 - albedo(lobe, o).max_element()).min(1.0 - albedo(lobe, i).max_element()).clamp(0.0, 1.0)
            }
        };
        let (s, c) = (factor(self.sheen), factor(self.coat));
        [1.0, s, c, s * c]
    }

    /// The probability of sampling each lobe from `o`: in proportion to its mean albedo there,
    /// layering included (`albedo` as for [`Bsdf::scales_with`]).
    #[inline(always)]
    fn selection_with<T: Copy>(&self, o: T, albedo: impl Fn(&Lobe, T) -> Vec3 + Copy) -> [f32; MAX_LOBES] {
        let scales = self.scales_with(o, o, albedo);
        let mut p = [0.0; MAX_LOBES];
        let mut total = 0.0;
        for (k, lobe) in self.lobes().iter().enumerate() {
            p[k] = albedo(lobe, o).element_sum().max(0.0) * scales[self.under[k] as usize];
            total += p[k];
        }
        if total > 0.0 {
            p.iter_mut().for_each(|x| *x /= total);
        }
        p
    }

    // A BSDF with a [`Lobe::Tilted`] needs the directions, not `μ`, for its layer's albedo; its
    // layering factors and selection are out of line (`_tilted`), so that the common case
    // compiles as before: one function taking directions for both cost every other BSDF 3–4 %
    // more instructions per sample on the glTF rooms (callgrind).

    #[inline]
    fn scales(&self, mu_o: f32, mu_i: f32) -> [f32; 4] {
        self.scales_with(mu_o, mu_i, Lobe::albedo)
    }

    #[inline]
    fn selection(&self, mu_o: f32) -> [f32; MAX_LOBES] {
        self.selection_with(mu_o, Lobe::albedo)
    }

    #[inline(never)]
    fn scales_tilted(&self, wo: Vec3, wi: Vec3) -> [f32; 4] {
        self.scales_with(wo, wi, Lobe::albedo_from)
    }

    #[inline(never)]
    fn selection_tilted(&self, wo: Vec3) -> [f32; MAX_LOBES] {
        self.selection_with(wo, Lobe::albedo_from)
    }

    /// The layering factors for the local `wo` and `wi` (`wi` on `wo`'s side).
    #[inline]
    fn scales_at(&self, wo: Vec3, wi: Vec3) -> [f32; 4] {
        if self.tilted { self.scales_tilted(wo, wi) } else { self.scales(wo.z, wi.z) }
    }

    /// The lobes' selection probabilities from the local `wo`.
    #[inline]
    fn selection_at(&self, wo: Vec3) -> [f32; MAX_LOBES] {
        if self.tilted { self.selection_tilted(wo) } else { self.selection(wo.z) }
    }

    /// `wo`, `wi` in local coordinates and whether `wi` is transmitted, if the pair is one the
    /// lobes may scatter (module docs). A lobe about a normal of its own ([`Lobe::Tilted`])
    /// also reflects into directions below the shading normal's horizon that leave the
    /// geometric surface on `wo`'s side: such a pair is a reflection with `wi.z < 0`, which
    /// only that lobe scatters.
    #[inline]
    fn local_pair(&self, wo: Vec3, wi: Vec3) -> Option<(Vec3, Vec3, bool)> {
        self.local_pair_from(self.frame.to_local(wo), wo, wi)
    }

    /// [`Bsdf::local_pair`] where `lo` is `wo` in local coordinates already.
    #[inline]
    fn local_pair_from(&self, lo: Vec3, wo: Vec3, wi: Vec3) -> Option<(Vec3, Vec3, bool)> {
        let li = self.frame.to_local(wi);
        if lo.z <= 0.0 || li.z == 0.0 {
            return None;
        }
        let geometric = wo.dot(self.ng) * wi.dot(self.ng) <= 0.0;
        let shading = li.z < 0.0;
        if geometric == shading {
            return Some((lo, li, shading));
        }
        (self.tilted && !geometric).then_some((lo, li, false))
    }

    /// `f(wo, wi)` per pass family (world-space unit vectors), specular lobes excluded.
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> BsdfEval {
        match self.local_pair(wo, wi) {
            Some((wo, wi, transmitted)) if self.tilted => self.eval_local::<true>(wo, wi, transmitted),
            Some((wo, wi, transmitted)) => self.eval_local::<false>(wo, wi, transmitted),
            None => BsdfEval::default(),
        }
    }

    /// [`Bsdf::eval`] of a pair already in local coordinates ([`Bsdf::local_pair`]); `TILTED`:
    /// whether the BSDF has a [`Lobe::Tilted`] (the check of which lobes see the pair is left
    /// out of the common case).
    #[inline(always)]
    fn eval_local<const TILTED: bool>(&self, wo: Vec3, wi: Vec3, transmitted: bool) -> BsdfEval {
        match (TILTED, self.lobes()) {
            // A lone lobe has nothing above it (its layering factor is 1): the mixture's sum
            // with its scales left out, the same values, inlined into the caller.
            (false, [lobe]) => {
                let mut out = BsdfEval::default();
                out.add(lobe.class(transmitted), lobe.eval(wo, wi));
                out
            }
            _ => self.eval_mixture::<TILTED>(wo, wi, transmitted),
        }
    }

    /// [`Bsdf::eval_local`] of any BSDF: the lobes' values, scaled by the layers above them.
    #[inline(never)]
    fn eval_mixture<const TILTED: bool>(&self, wo: Vec3, wi: Vec3, transmitted: bool) -> BsdfEval {
        let mut out = BsdfEval::default();
        let scales = if TILTED {
            self.scales_tilted(wo, Vec3::new(wi.x, wi.y, wi.z.abs()))
        } else {
            self.scales(wo.z, wi.z.abs())
        };
        let below = TILTED && !transmitted && wi.z < 0.0;
        for (k, lobe) in self.lobes().iter().enumerate() {
            if TILTED && lobe.skips(transmitted, below) {
                continue;
            }
            let f = lobe.eval(wo, wi);
            if f != Vec3::ZERO {
                out.add(lobe.class(transmitted), f * scales[self.under[k] as usize]);
            }
        }
        out
    }

    /// The density of [`Bsdf::sample`] at `wi` (per steradian), specular lobes excluded.
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        let Some((wo, wi, transmitted)) = self.local_pair(wo, wi) else { return 0.0 };
        let p = self.selection_at(wo);
        if self.tilted {
            self.pdf_local::<true>(wo, wi, transmitted, &p)
        } else {
            self.pdf_local::<false>(wo, wi, transmitted, &p)
        }
    }

    /// [`Bsdf::pdf`] of a pair already in local coordinates, with the lobes' selection
    /// probabilities `p` at `wo` ([`Bsdf::selection`]).
    #[inline(always)]
    fn pdf_local<const TILTED: bool>(&self, wo: Vec3, wi: Vec3, transmitted: bool, p: &[f32; MAX_LOBES]) -> f32 {
        match (TILTED, self.lobes()) {
            // A lone lobe: the mixture's sum of one term, inlined into the caller.
            (false, [lobe]) => {
                if p[0] > 0.0 {
                    p[0] * lobe.pdf(wo, wi)
                } else {
                    0.0
                }
            }
            _ => self.pdf_mixture::<TILTED>(wo, wi, transmitted, p),
        }
    }

    /// [`Bsdf::pdf_local`] of any BSDF: the lobes' densities weighted by their selection.
    #[inline(never)]
    fn pdf_mixture<const TILTED: bool>(&self, wo: Vec3, wi: Vec3, transmitted: bool, p: &[f32; MAX_LOBES]) -> f32 {
        let below = TILTED && !transmitted && wi.z < 0.0;
        self.lobes()
            .iter()
            .zip(p)
            .filter(|(lobe, p)| **p > 0.0 && !(TILTED && lobe.skips(transmitted, below)))
            .map(|(lobe, p)| p * lobe.pdf(wo, wi))
            .sum()
    }

    /// A direction for `wo`: `u_lobe` chooses the lobe (and is reused, rescaled, for the
    /// lobe's own discrete choices), `u` the direction. `None` when nothing is scattered.
    pub fn sample(&self, wo: Vec3, u_lobe: f32, u: Vec2) -> Option<BsdfSample> {
        let lo = self.frame.to_local(wo);
        if lo.z <= 0.0 {
            return None;
        }
        if let (false, [lobe]) = (self.tilted, self.lobes()) {
            return self.sample_lone(lobe, wo, lo, u_lobe, u);
        }
        let p = self.selection_at(lo);
        let mut k = 0;
        let mut before = 0.0;
        while k + 1 < self.lobes.len() && (p[k] == 0.0 || u_lobe >= before + p[k]) {
            before += p[k];
            k += 1;
        }
        if p[k] == 0.0 {
            return None;
        }
        let uc = ((u_lobe - before) / p[k]).clamp(0.0, 1.0 - f32::EPSILON / 2.0);
        let lobe = &self.lobes[k];
        let s = lobe.sample(lo, uc, u)?;
        let wi = self.frame.to_world(s.wi).normalize_or_zero();
        // A lobe about its own normal only reflects, also below the shading normal's horizon.
        let transmitted = s.wi.z < 0.0 && !matches!(lobe, Lobe::Tilted(_));
        if wi == Vec3::ZERO || (wo.dot(self.ng) * wi.dot(self.ng) <= 0.0) != transmitted {
            return None;
        }
        let side = if transmitted { LobeFlags::TRANSMISSION } else { LobeFlags::REFLECTION };
        let class = lobe.class(transmitted);
        if s.specular {
            let scale = self.scales_at(lo, Vec3::new(s.wi.x, s.wi.y, s.wi.z.abs()))[self.under[k] as usize];
            let flags = LobeFlags::SPECULAR | side;
            return Some(BsdfSample { wi, f: s.f * scale, pdf: s.pdf * p[k], flags, class, eta: s.eta });
        }
        // `f` and the density at the world-space `wi` (what `eval` and `pdf` give there),
        // from the local `wo` and the selection computed above.
        let (lo, li, transmitted) = self.local_pair_from(lo, wo, wi)?;
        let (f, pdf) = if self.tilted {
            (self.eval_local::<true>(lo, li, transmitted).sum(), self.pdf_local::<true>(lo, li, transmitted, &p))
        } else {
            (self.eval_local::<false>(lo, li, transmitted).sum(), self.pdf_local::<false>(lo, li, transmitted, &p))
        };
        let kind = LobeFlags(lobe.flags().0 & (LobeFlags::DIFFUSE.0 | LobeFlags::GLOSSY.0));
        (pdf > 0.0).then_some(BsdfSample { wi, f, pdf, flags: kind | side, class, eta: s.eta })
    }

    /// [`Bsdf::sample`] of a BSDF of one lobe, not [`Lobe::Tilted`] (most BSDFs), from the
    /// local `lo` (`lo.z > 0`): the same sample, bit for bit, without the mixture's machinery.
    /// The lobe is chosen when it reflects anything, with probability 1, and nothing above it
    /// scales it, so `u_lobe` goes to the lobe as it is, a specular sample is the lobe's own,
    /// and `f` and the density at the world-space `wi` are the lobe's at its local coordinates.
    #[inline]
    fn sample_lone(&self, lobe: &Lobe, wo: Vec3, lo: Vec3, u_lobe: f32, u: Vec2) -> Option<BsdfSample> {
        if !(lobe.albedo(lo.z).element_sum() > 0.0) {
            return None;
        }
        let s = lobe.sample(lo, u_lobe.clamp(0.0, 1.0 - f32::EPSILON / 2.0), u)?;
        let wi = self.frame.to_world(s.wi).normalize_or_zero();
        let transmitted = s.wi.z < 0.0;
        if wi == Vec3::ZERO || (wo.dot(self.ng) * wi.dot(self.ng) <= 0.0) != transmitted {
            return None;
        }
        let side = if transmitted { LobeFlags::TRANSMISSION } else { LobeFlags::REFLECTION };
        let class = lobe.class(transmitted);
        if s.specular {
            let flags = LobeFlags::SPECULAR | side;
            return Some(BsdfSample { wi, f: s.f, pdf: s.pdf, flags, class, eta: s.eta });
        }
        // What `eval` and `pdf` give at the world-space `wi`.
        let (lo, li, _) = self.local_pair_from(lo, wo, wi)?;
        let (f, pdf) = (lobe.eval(lo, li), lobe.pdf(lo, li));
        let kind = LobeFlags(lobe.flags().0 & (LobeFlags::DIFFUSE.0 | LobeFlags::GLOSSY.0));
        (pdf > 0.0).then_some(BsdfSample { wi, f, pdf, flags: kind | side, class, eta: s.eta })
    }

    /// The union of the lobes' flags.
    pub fn flags(&self) -> LobeFlags {
        self.lobes().iter().fold(LobeFlags::NONE, |f, l| f | l.flags())
    }

    /// DiffCol / GlossCol / TransCol: the sums of the lobes' colour weights per family, as
    /// Cycles writes its closures' weights (Fresnel excluded: a gold metal's GlossCol is its
    /// metallic weight, white; the gold is in GlossDir).
    pub fn colors(&self) -> BsdfEval {
        let mut c = BsdfEval::default();
        for lobe in self.lobes() {
            let l = lobe.colors();
            c.diffuse += l.diffuse;
            c.glossy += l.glossy;
            c.transmission += l.transmission;
        }
        c
    }

    /// An estimate of the directional albedo `∫ f |cos θi| dωi` from `wo` (transmission in
    /// energy units): for OIDN's albedo pass. Exact for the glTF base and specular layers.
    pub fn albedo(&self, wo: Vec3) -> Vec3 {
        let lo = self.frame.to_local(wo);
        if lo.z <= 0.0 {
            return Vec3::ZERO;
        }
        let scales = self.scales_at(lo, lo);
        self.lobes().iter().enumerate().map(|(k, l)| l.albedo_from(lo) * scales[self.under[k] as usize]).sum()
    }
}
