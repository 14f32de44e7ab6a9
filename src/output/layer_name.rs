//! The view layer name of the `blender` layout (`--layer-name`): the EXR's channels are
//! `NAME.Pass.C` (`ViewLayer.Combined.R` by default), as Blender's multilayer writer names a
//! view layer's passes.
//!
//! The rule, Blender's own: any name Blender can give a view layer is carried as it is, dots
//! included. Blender 3.4 writes a layer named `a.b c` as `a.b c.Combined.R`, and its reader
//! (`imb_exr_split_channel_name`) takes the last dot-separated word as the channel, the one
//! before as the pass and everything before that as the layer, so a dotted name reads back
//! whole. Refused, in one line naming the option: the empty name (it would read as no
//! layer), names of more than [`MAX_BYTES`] bytes (Blender's `MAX_NAME` less its NUL; it
//! also keeps channel names far under OpenEXR's 255 bytes) and control characters (NUL ends
//! an EXR name; a newline or escape garbles the logs and terminals that print channel names).

/// Most bytes of a layer name: Blender's longest view layer name.
pub const MAX_BYTES: usize = 63;

/// Why `name` cannot be a layer name, or `None` when it can.
pub fn problem(name: &str) -> Option<String> {
    if name.is_empty() {
        return Some("is empty".into());
    }
    if name.len() > MAX_BYTES {
        return Some(format!("is {} bytes long; at most {MAX_BYTES} (Blender's longest view layer name)", name.len()));
    }
    if let Some(c) = name.chars().find(|c| c.is_control()) {
        return Some(format!("holds the control character {:?}", c));
    }
    None
}

/// `Ok` for a name [`problem`] accepts, else the one-line error naming `--layer-name`.
pub fn check(name: &str) -> Result<(), String> {
    match problem(name) {
        None => Ok(()),
        Some(p) => Err(format!("--layer-name {:?}: {p}", name)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn blenders_names_pass_and_the_rest_is_refused() {
        for ok in ["ViewLayer", "a.b c", "Beauty pass", "$(touch x)", "-o", "ш❤", &"x".repeat(63)] {
            assert_eq!(problem(ok), None, "{ok:?}");
        }
        for bad in ["", "a\nb", "a\0b", "\x1b[31m", "tab\t", "\r", "\u{85}", &"x".repeat(64)] {
            let e = check(bad).unwrap_err();
            assert!(e.starts_with("--layer-name ") && !e.contains('\n'), "{e:?}");
        }
    }
}
