//! `[environment]`: the radiance from far away along rays that leave the scene
//! ([`crate::light::environment`]), a constant `color` or an equirectangular map `file` (EXR or
//! Radiance `.hdr`, relative to the scene file), with `strength` (default 1) and `rotation`
//! (degrees about the up axis, default 0).
//!
//! ```toml
//! [environment]
//! file = "sky.exr"      # or: color = [0.8, 0.9, 1.0]
//! strength = 1.5
//! rotation = 90
//! ```

use std::ops::Range;
use std::path::Path;

use serde::Deserialize;
use toml::Spanned;

use super::{Problem, Triple, at, color, number};
use crate::light::environment::Environment;
use crate::light::environment_file::read_environment_map;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct EnvironmentFile {
    color: Option<Spanned<Triple>>,
    file: Option<Spanned<String>>,
    strength: Option<Spanned<f64>>,
    rotation: Option<Spanned<f64>>,
}

impl EnvironmentFile {
    /// The environment, its map read from `base` (the scene file's folder).
    pub(super) fn to_environment(&self, span: &Range<usize>, base: &Path) -> Result<Environment, Problem> {
        let mut env = match (&self.color, &self.file) {
            (Some(c), None) => Environment::constant(color(c, "environment: color", None)?),
            (None, Some(f)) => {
                let image = read_environment_map(&base.join(f.get_ref())).map_err(|m| at(f.span(), m))?;
                Environment::map(image)
            }
            (Some(_), Some(f)) => return Err(at(f.span(), "environment: give `color` or `file`, not both")),
            (None, None) => return Err(at(span.clone(), "environment: missing `color` or `file`")),
        };
        if let Some(s) = &self.strength {
            env.strength = number(s, "environment: strength")? as f32;
            if env.strength < 0.0 {
                return Err(at(s.span(), format!("environment: strength {} must be ≥ 0", s.get_ref())));
            }
        }
        if let Some(r) = &self.rotation {
            env.rotation_deg = number(r, "environment: rotation")? as f32;
        }
        Ok(env)
    }
}
