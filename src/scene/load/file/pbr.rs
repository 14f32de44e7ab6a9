//! A TOML material given by the glTF metallic-roughness keys (`base_color`, `metallic`,
//! `roughness`, …): the same [`Pbr`] material a glTF file gives, so TOML and glTF scenes shade
//! with one BSDF (`bsdf::gltf`), and its lecture form for the Whitted integrator
//! ([`Pbr::lecture_form`]).
//!
//! A table is such a material when it has any of `base_color`, `base_color_texture`,
//! `metallic`, `roughness`, `metallic_roughness_texture`, `emission_texture`, `clearcoat`,
//! `clearcoat_roughness`, `sheen_color`, `sheen_roughness`; it then takes no lecture key
//! (`diffuse`, `checker`, `specular`, `shininess`, `mirror`), and `transmission` is the glTF
//! transmission factor (a number, or a grey triple), `ior` and `emission` keep their meaning.
//! Textures are PNG or JPEG files relative to the scene file: `base_color_texture` and
//! `emission_texture` sRGB-encoded, `metallic_roughness_texture` linear (blue metalness,
//! green roughness); each multiplies its factor.

use std::path::Path;

use super::{MaterialFile, Problem, Triple, at, color, number};
use crate::bsdf::PbrParams;
use crate::material::{Material, Pbr, TextureSlot};
use crate::math::Vec3;
use crate::texture::{Encoding, ImageTexture, Wrap, open_shared_as};
use toml::Spanned;

/// The PBR material `m` describes, or `None` when it has no PBR key (a lecture material).
/// Defaults: glTF's, except `metallic` (0: a TOML material is a dielectric unless it says).
pub(super) fn material(m: &MaterialFile, name: &str, base: &Path) -> Result<Option<Material>, Problem> {
    let given = [
        m.base_color.as_ref().map(Spanned::span),
        m.base_color_texture.as_ref().map(Spanned::span),
        m.metallic.as_ref().map(Spanned::span),
        m.roughness.as_ref().map(Spanned::span),
        m.metallic_roughness_texture.as_ref().map(Spanned::span),
        m.emission_texture.as_ref().map(Spanned::span),
        m.clearcoat.as_ref().map(Spanned::span),
        m.clearcoat_roughness.as_ref().map(Spanned::span),
        m.sheen_color.as_ref().map(Spanned::span),
        m.sheen_roughness.as_ref().map(Spanned::span),
    ];
    if given.iter().all(Option::is_none) {
        return Ok(None);
    }
    let lecture = [
        ("diffuse", m.diffuse.as_ref().map(Spanned::span)),
        ("checker", m.checker.as_ref().map(Spanned::span)),
        ("specular", m.specular.as_ref().map(Spanned::span)),
        ("shininess", m.shininess.as_ref().map(Spanned::span)),
        ("mirror", m.mirror.as_ref().map(Spanned::span)),
    ];
    if let Some((key, Some(span))) = lecture.into_iter().find(|(_, s)| s.is_some()) {
        return Err(at(
            span,
            format!(
                "`{key}` is a lecture material's key; a material with `base_color`, `metallic`, `roughness`, … takes none"
            ),
        ));
    }
    let unit = |v: &Option<Spanned<f64>>, what: &str, default: f32| -> Result<f32, Problem> {
        let Some(v) = v else { return Ok(default) };
        let x = number(v, what)?;
        if !(0.0..=1.0).contains(&x) {
            return Err(at(v.span(), format!("{what} {x} must lie in [0, 1]")));
        }
        Ok(x as f32)
    };
    let colour = |v: &Option<Spanned<Triple>>, what: &str, default: Vec3, max: Option<f64>| {
        v.as_ref().map_or(Ok(default), |v| color(v, what, max))
    };
    let texture =
        |v: &Option<Spanned<String>>, what: &str, encoding: Encoding| -> Result<Option<TextureSlot>, Problem> {
            let Some(path) = v else { return Ok(None) };
            let image = open_shared_as(&base.join(path.get_ref()), encoding)
                .map_err(|e| at(path.span(), format!("{what}: {e}")))?;
            let texture =
                ImageTexture { image, wrap_u: Wrap::Repeat, wrap_v: Wrap::Repeat, factor: Vec3::ONE, mipmaps: true };
            Ok(Some(TextureSlot::plain(texture)))
        };
    let transmission = match &m.transmission {
        None => 0.0,
        Some(t) => {
            let [a, b, c] = color(t, "transmission", Some(1.0))?.to_array();
            if a != b || b != c {
                return Err(at(
                    t.span(),
                    "transmission of a PBR material is one number in [0, 1] (glTF's transmissionFactor)",
                ));
            }
            a
        }
    };
    let ior = match &m.ior {
        None => 1.5,
        Some(v) => {
            let x = number(v, "ior")?;
            if x < 1.0 {
                return Err(at(v.span(), format!("ior {x} must be ≥ 1")));
            }
            x as f32
        }
    };
    let pbr = Pbr {
        factors: PbrParams {
            base_color: colour(&m.base_color, "base_color", Vec3::ONE, Some(1.0))?,
            metallic: unit(&m.metallic, "metallic", 0.0)?,
            roughness: unit(&m.roughness, "roughness", 1.0)?,
            ior,
            transmission,
            clearcoat: unit(&m.clearcoat, "clearcoat", 0.0)?,
            clearcoat_roughness: unit(&m.clearcoat_roughness, "clearcoat_roughness", 0.0)?,
            sheen_color: colour(&m.sheen_color, "sheen_color", Vec3::ZERO, Some(1.0))?,
            sheen_roughness: unit(&m.sheen_roughness, "sheen_roughness", 0.0)?,
            ..PbrParams::default()
        },
        base_color_texture: texture(&m.base_color_texture, "base_color_texture", Encoding::Srgb)?,
        metallic_roughness_texture: texture(
            &m.metallic_roughness_texture,
            "metallic_roughness_texture",
            Encoding::Linear,
        )?,
        emission: colour(&m.emission, "emission", Vec3::ZERO, None)?,
        emissive_texture: texture(&m.emission_texture, "emission_texture", Encoding::Srgb)?,
        ..Pbr::default()
    };
    Ok(Some(Material { pbr: Some(Box::new(pbr.clone())), ..pbr.lecture_form(name.to_string()) }))
}
