//! STUB, to be replaced by the Whitted integrator (issue 3). The signature of [`render`] and
//! [`RayCounts`] is the contract between the renderer core and the `strahl` command.

use crate::accel::{Accel, TraceError};
use crate::film::Film;
use crate::scene::Scene;

/// Rays traced, by kind, for the summary the command prints.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RayCounts {
    pub primary: u64,
    pub shadow: u64,
    pub reflected: u64,
    pub refracted: u64,
}

impl RayCounts {
    pub fn total(&self) -> u64 {
        self.primary + self.shadow + self.reflected + self.refracted
    }
}

/// Renders `scene` (its `image` settings: size, spp, depth, background) with `accel`, in
/// parallel over tiles on the current rayon pool. `progress` is called with the number of
/// pixels finished since its last call. Deterministic: the same bytes for any thread count.
pub fn render<A: Accel>(
    scene: &Scene,
    accel: &A,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<(Film, RayCounts), TraceError> {
    let _ = accel;
    let img = &scene.image;
    let mut film = Film::new(img.width, img.height);
    for px in &mut film.rgba {
        *px = [img.background.x, img.background.y, img.background.z, 0.0];
    }
    progress(img.width as u64 * img.height as u64);
    Ok((film, RayCounts::default()))
}
