//! Image textures: a diffuse albedo read from a PNG or JPEG file at the hit's texture
//! coordinates.
//!
//! - **Decoding** (the `image` crate): 8- and 16-bit images are sRGB-encoded, so each channel
//!   `c ∈ [0, 1]` is turned into linear reflectance once, at load time, with the sRGB transfer
//!   function `c ≤ 0.04045 ? c/12.92 : ((c + 0.055)/1.055)^2.4` (computed in f64). Colour
//!   textures drop alpha; a texture a material's alpha test reads ([`crate::scene::alpha`]) is
//!   decoded a second time as its alpha plane ([`Encoding::Alpha`]: the alpha channel, linear,
//!   in all three channels; 1 for images without one), counted in the budget like any texels. The header is checked before anything is
//!   allocated: the texels must fit in what is left of the memory budget
//!   ([`crate::sys::read::remaining_memory`]; they are counted there while the image lives) and
//!   the declared size in what the file's bytes can hold; the pixels are then decoded into the
//!   texel array itself and widened in place ([`Image::decode`]).
//! - **Coordinates**: `(u, v)` with `(0, 0)` the **bottom-left** corner of the image and
//!   `(1, 1)` the top-right, as OBJ and PLY store them (glTF's top-left origin is converted
//!   when its files are read). Texel `(i, j)` (column `i`, row `j` from the top) has its
//!   centre at `u = (i + ½)/W`, `v = 1 − (j + ½)/H`.
//! - **Wrap modes** ([`Wrap`]) map any `u` into `[0, 1)` before the lookup: repeat
//!   (`u − ⌊u⌋`), clamp to edge, mirrored repeat (every other copy reflected). The wrap applies
//!   to texel indices, so bilinear filtering at an edge wraps the same way.
//! - **Bilinear filtering**: the four texels around `(u·W − ½, (1 − v)·H − ½)` weighted by the
//!   fractional parts, as OpenGL's `GL_LINEAR` does.
//! - **Mip-mapping** (camera rays of the path tracer): a decoded image keeps a pyramid of
//!   box-filtered levels ([`Image::levels`]), level `k + 1` of size `⌊W_k/2⌋ × ⌊H_k/2⌋` (at
//!   least 1), each texel the area-weighted mean of the level-`k` texels its square covers
//!   (so every level keeps the image's mean), down to 1 × 1; it costs a third of the texels
//!   again and is counted with them. A lookup at level of detail `λ`
//!   ([`ImageTexture::lookup_lod`]) is trilinear: bilinear in levels `⌊λ⌋` and `⌊λ⌋ + 1`,
//!   mixed by `λ − ⌊λ⌋`, `λ` clamped to the pyramid; `λ ≤ 0` is the bilinear lookup of the
//!   image itself. Which `λ` a ray asks for: [`crate::shading`] (ray cones).
//!
//! Texture memory is shared: [`open_shared`] decodes each file once and materials hold an
//! [`Arc`] to the same texels.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, Weak};
use std::time::SystemTime;

use crate::math::{Vec2, Vec3};
use crate::sys::read::{Held, check_memory, remaining_memory};

/// What a texture coordinate outside `[0, 1)` maps to (glTF sampler `wrapS`/`wrapT`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Wrap {
    /// The image tiles the plane (glTF `REPEAT`, 10497; OBJ's only mode).
    #[default]
    Repeat,
    /// Coordinates are clamped to the edge texels (glTF `CLAMP_TO_EDGE`, 33071).
    Clamp,
    /// The image tiles the plane, every other copy mirrored (glTF `MIRRORED_REPEAT`, 33648).
    MirroredRepeat,
}

impl Wrap {
    /// The texel index for a (possibly out-of-range) integer index `i` of an axis of `n`
    /// texels.
    #[inline]
    fn index(self, i: i64, n: usize) -> usize {
        let n = n as i64;
        let k = match self {
            Wrap::Repeat => i.rem_euclid(n),
            Wrap::Clamp => i.clamp(0, n - 1),
            Wrap::MirroredRepeat => {
                let m = i.rem_euclid(2 * n);
                if m < n { m } else { 2 * n - 1 - m }
            }
        };
        k as usize
    }
}

/// A decoded image: linear RGB texels, row 0 at the top.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    /// Where it came from, for messages (`tex.png`, `model.glb image 2`).
    pub name: String,
    pub width: usize,
    pub height: usize,
    /// `width·height` linear reflectances, row-major from the top-left.
    pub texels: Vec<Vec3>,
    /// The texels' bytes, counted against the memory budget while the image lives.
    held: Held,
    /// The mip pyramid's levels 1, 2, … down to 1 × 1 (empty for an image that is not a
    /// material's texture, e.g. an environment map), see the module header.
    pub levels: Vec<Level>,
    /// The levels' bytes, counted like the texels'.
    levels_held: Held,
}

/// One level of an image's mip pyramid: `width·height` texels, row-major from the top-left.
#[derive(Clone, Debug, PartialEq)]
pub struct Level {
    pub width: usize,
    pub height: usize,
    pub texels: Vec<Vec3>,
}

/// How an image's channels encode their values.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Encoding {
    /// Colours: the sRGB transfer function (glTF's base colour and emissive textures, OBJ's
    /// `map_Kd`).
    #[default]
    Srgb,
    /// Data, one for one (glTF's metallic-roughness and normal textures).
    Linear,
    /// The alpha channel, linear, in every channel of the texel (1 where the image has no
    /// alpha): the plane a material's alpha test reads.
    Alpha,
}

/// The sRGB transfer function's inverse: an encoded channel in [0, 1] to linear.
pub fn srgb_to_linear(c: f64) -> f64 {
    if c <= 0.04045 { c / 12.92 } else { ((c + 0.055) / 1.055).powf(2.4) }
}

/// Bytes of one texel as strahl keeps it (linear RGB, f32).
pub const TEXEL_BYTES: u64 = std::mem::size_of::<Vec3>() as u64;

/// Deflate's largest compression ratio (a 258-byte match in a 1-bit code, about 1032:1): a PNG
/// cannot hold more raw pixel bytes than this many times its own size.
const DEFLATE_MAX_RATIO: u64 = 1032;

/// Why the file `bytes` cannot hold the `width × height` image its header declares, if it
/// cannot: its pixels would need more data than the format can compress them into.
/// - PNG: the raw pixel bytes `⌈W·H·bits/8⌉` (bits per pixel from the IHDR chunk, which a PNG
///   starts with: bit depth × channels) over deflate's maximum ratio ([`DEFLATE_MAX_RATIO`]).
/// - JPEG (Huffman-coded, what the decoder reads): every 8 × 8 block of every component costs
///   at least one bit (its DC code) in the first scan, and the least-sampled component
///   (sampling factors are at most 4) has at least `⌈W/32⌉·⌈H/32⌉` blocks.
fn unbacked(format: image::ImageFormat, bytes: &[u8], width: u32, height: u32) -> Option<String> {
    let (w, h) = (width as u64, height as u64);
    let needed = match format {
        image::ImageFormat::Png => {
            // IHDR: bytes 16..24 the size, 24 the bit depth, 25 the colour type.
            let channels = match bytes.get(25) {
                Some(2) => 3,
                Some(4) => 2,
                Some(6) => 4,
                _ => 1,
            };
            let bits = bytes.get(24).map_or(1, |&b| b.max(1) as u64) * channels;
            (w * h * bits).div_ceil(8) / DEFLATE_MAX_RATIO
        }
        image::ImageFormat::Jpeg => (w.div_ceil(32) * h.div_ceil(32)).div_ceil(8),
        _ => 0,
    };
    let file_bytes = bytes.len();
    (needed > file_bytes as u64).then(|| {
        format!(
            "declares {width} × {height} pixels, which need at least {needed} bytes of image data; the file has \
             {file_bytes} (truncated or forged)"
        )
    })
}

impl Image {
    /// The image's name and size without its texels (to describe it without copying them).
    pub fn without_texels(&self) -> Image {
        Image {
            name: self.name.clone(),
            width: self.width,
            height: self.height,
            texels: Vec::new(),
            held: Held::nothing(),
            levels: Vec::new(),
            levels_held: Held::nothing(),
        }
    }

    /// An image of the given texels (`width·height` of them, row-major from the top-left),
    /// counted against the memory budget.
    pub fn from_texels(name: &str, width: usize, height: usize, texels: Vec<Vec3>) -> Result<Image, String> {
        if texels.len() != width * height || texels.is_empty() {
            return Err(format!("{name}: {} texels for {width} × {height}", texels.len()));
        }
        let held =
            Held::take(texels.len() as u64 * TEXEL_BYTES, format!("{name}: the texels")).map_err(|e| e.to_string())?;
        Ok(Image {
            name: name.to_string(),
            width,
            height,
            texels,
            held,
            levels: Vec::new(),
            levels_held: Held::nothing(),
        })
    }

    /// Decodes a PNG or JPEG file's bytes (the format is read from the bytes, not a file
    /// name); `name` names the image in errors.
    ///
    /// The header is read first: a size the file cannot hold ([`unbacked`]) or whose texels
    /// (and, for JPEG, the decoder's coefficients, 2 bytes per sample) do not fit in what is
    /// left of the memory budget ([`crate::sys::read::remaining_memory`], also given to the
    /// decoder as the `image` crate's `Limits`) is refused before anything is allocated. The
    /// pixels are then decoded into the tail of the texel array itself and widened in place,
    /// front to back, to linear f32 RGB (a texel of at most 12 bytes never overtakes the
    /// encoded texels still ahead of it): the texels are the one full-size allocation. 8-bit
    /// channels go through a 256-entry table, 16-bit ones through the formula.
    pub fn decode(bytes: &[u8], name: &str) -> Result<Image, String> {
        Image::decode_as(bytes, name, Encoding::Srgb)
    }

    /// [`Image::decode`] with the channels' `encoding`: sRGB (colours) or linear (data:
    /// glTF's metallic-roughness and normal textures).
    pub fn decode_as(bytes: &[u8], name: &str, encoding: Encoding) -> Result<Image, String> {
        use image::ImageDecoder;
        let mut reader = image::ImageReader::new(std::io::Cursor::new(bytes))
            .with_guessed_format()
            .map_err(|e| format!("{name}: cannot read the image: {e}"))?;
        let format = match reader.format() {
            Some(f @ (image::ImageFormat::Png | image::ImageFormat::Jpeg)) => f,
            _ => return Err(format!("{name}: is not a PNG or JPEG image")),
        };
        let mut limits = image::Limits::no_limits();
        limits.max_alloc = Some(remaining_memory());
        reader.limits(limits.clone());
        let mut decoder = reader.into_decoder().map_err(|e| format!("{name}: cannot read the image: {e}"))?;
        let (width, height) = decoder.dimensions();
        if width == 0 || height == 0 {
            return Err(format!("{name}: the image has no pixels"));
        }
        if let Some(problem) = unbacked(format, bytes, width, height) {
            return Err(format!("{name}: {problem}"));
        }
        let color = decoder.color_type();
        let bpp = color.bytes_per_pixel() as usize;
        if !matches!(
            color,
            image::ColorType::L8
                | image::ColorType::La8
                | image::ColorType::Rgb8
                | image::ColorType::Rgba8
                | image::ColorType::L16
                | image::ColorType::La16
                | image::ColorType::Rgb16
                | image::ColorType::Rgba16
        ) {
            return Err(format!("{name}: {color:?} pixels are not read (8- or 16-bit images only)"));
        }
        let pixels = width as u64 * height as u64;
        let texel_bytes = pixels * TEXEL_BYTES;
        let decoder_bytes = match format {
            image::ImageFormat::Jpeg => pixels * color.channel_count() as u64 * 2,
            _ => 0,
        };
        let what = format!("{name}: decoding {width} × {height} texels");
        check_memory(texel_bytes + decoder_bytes, what.clone()).map_err(|e| e.to_string())?;
        let held = Held::take(texel_bytes, what).map_err(|e| e.to_string())?;
        limits.max_alloc = Some(remaining_memory());
        limits.max_image_width = Some(width);
        limits.max_image_height = Some(height);
        decoder.set_limits(limits).map_err(|e| format!("{name}: cannot decode the image: {e}"))?;
        let n = pixels as usize;
        let mut texels = vec![Vec3::ZERO; n];
        let buffer: &mut [u8] = bytemuck::cast_slice_mut(&mut texels);
        let encoded = buffer.len() - n * bpp;
        decoder.read_image(&mut buffer[encoded..]).map_err(|e| format!("{name}: cannot decode the image: {e}"))?;
        let decode = |c: f64| match encoding {
            Encoding::Srgb => srgb_to_linear(c),
            Encoding::Linear | Encoding::Alpha => c,
        };
        let t8: Vec<f32> = (0..256).map(|c| decode(c as f64 / 255.0) as f32).collect();
        let t8 = |c: u8| t8[c as usize];
        let l16 = |b: &[u8]| decode(u16::from_ne_bytes([b[0], b[1]]) as f64 / 65535.0) as f32;
        if encoding == Encoding::Alpha {
            match color {
                image::ColorType::L8 => widen::<1>(buffer, n, |_| [1.0; 3]),
                image::ColorType::La8 => widen::<2>(buffer, n, |p| [t8(p[1]); 3]),
                image::ColorType::Rgb8 => widen::<3>(buffer, n, |_| [1.0; 3]),
                image::ColorType::Rgba8 => widen::<4>(buffer, n, |p| [t8(p[3]); 3]),
                image::ColorType::L16 => widen::<2>(buffer, n, |_| [1.0; 3]),
                image::ColorType::La16 => widen::<4>(buffer, n, |p| [l16(&p[2..]); 3]),
                image::ColorType::Rgb16 => widen::<6>(buffer, n, |_| [1.0; 3]),
                _ => widen::<8>(buffer, n, |p| [l16(&p[6..]); 3]),
            }
        } else {
            match color {
                image::ColorType::L8 => widen::<1>(buffer, n, |p| [t8(p[0]); 3]),
                image::ColorType::La8 => widen::<2>(buffer, n, |p| [t8(p[0]); 3]),
                image::ColorType::Rgb8 => widen::<3>(buffer, n, |p| [t8(p[0]), t8(p[1]), t8(p[2])]),
                image::ColorType::Rgba8 => widen::<4>(buffer, n, |p| [t8(p[0]), t8(p[1]), t8(p[2])]),
                image::ColorType::L16 => widen::<2>(buffer, n, |p| [l16(&p[..]); 3]),
                image::ColorType::La16 => widen::<4>(buffer, n, |p| [l16(&p[..]); 3]),
                image::ColorType::Rgb16 => widen::<6>(buffer, n, |p| [l16(&p[..]), l16(&p[2..]), l16(&p[4..])]),
                _ => widen::<8>(buffer, n, |p| [l16(&p[..]), l16(&p[2..]), l16(&p[4..])]),
            }
        }
        let image = Image {
            name: name.to_string(),
            width: width as usize,
            height: height as usize,
            texels,
            held,
            levels: Vec::new(),
            levels_held: Held::nothing(),
        };
        // The alpha test reads level 0 only (both backends must decide alike): no pyramid.
        if encoding == Encoding::Alpha { Ok(image) } else { image.with_levels() }
    }

    /// The image with its mip pyramid (module header), whose bytes are taken from the memory
    /// budget first.
    pub fn with_levels(mut self) -> Result<Image, String> {
        let (mut w, mut h, mut bytes) = (self.width, self.height, 0u64);
        while w > 1 || h > 1 {
            (w, h) = ((w / 2).max(1), (h / 2).max(1));
            bytes += (w * h) as u64 * TEXEL_BYTES;
        }
        let what = format!("{}: its mip levels", self.name);
        self.levels_held = Held::take(bytes, what).map_err(|e| e.to_string())?;
        let mut levels: Vec<Level> = Vec::new();
        let (mut w, mut h) = (self.width, self.height);
        while w > 1 || h > 1 {
            let next = halve(w, h, levels.last().map_or(&self.texels, |l| &l.texels));
            (w, h) = (next.width, next.height);
            levels.push(next);
        }
        self.levels = levels;
        Ok(self)
    }

    /// Reads and decodes the image file at `path` (a regular file of at most
    /// [`crate::sys::read::max_mesh_bytes`]).
    pub fn open(path: &Path, encoding: Encoding) -> Result<Image, String> {
        let cannot = |e: &dyn std::fmt::Display| format!("{}: cannot read the texture: {e}", path.display());
        let limit = crate::sys::read::max_mesh_bytes().map_err(|e| cannot(&e))?;
        let bytes =
            crate::sys::read::read_regular(path, limit, crate::sys::read::MESH_LIMIT_HINT).map_err(|e| cannot(&e))?;
        Image::decode_as(&bytes, &path.display().to_string(), encoding)
    }

    /// The mean texel (summed in f64).
    pub fn mean(&self) -> Vec3 {
        if self.texels.is_empty() {
            return Vec3::ZERO;
        }
        let sum = self.texels.iter().fold(glam::DVec3::ZERO, |s, t| s + t.as_dvec3());
        (sum / self.texels.len() as f64).as_vec3()
    }

    /// Bytes the texels and the mip levels take.
    pub fn size_bytes(&self) -> usize {
        (self.texels.len() + self.levels.iter().map(|l| l.texels.len()).sum::<usize>()) * std::mem::size_of::<Vec3>()
    }

    /// Level `k` of the pyramid (0: the image) as its size and texels, clamped to the last.
    fn level(&self, k: usize) -> (usize, usize, &[Vec3]) {
        match k.min(self.levels.len()) {
            0 => (self.width, self.height, &self.texels),
            k => {
                let l = &self.levels[k - 1];
                (l.width, l.height, &l.texels)
            }
        }
    }
}

/// The next level below a `w × h` level: `⌊w/2⌋ × ⌊h/2⌋` (at least 1), each texel the
/// area-weighted mean of the texels its square covers (a box filter, separable: rows, then
/// columns; summed in f64).
fn halve(w: usize, h: usize, texels: &[Vec3]) -> Level {
    let (w2, h2) = ((w / 2).max(1), (h / 2).max(1));
    // The weights of source indices for each target index: the overlap of source cell
    // [k, k + 1) with target cell [i·n/m, (i + 1)·n/m), over n/m.
    let weights = |n: usize, m: usize| -> Vec<Vec<(usize, f64)>> {
        let step = n as f64 / m as f64;
        (0..m)
            .map(|i| {
                let (a, b) = (i as f64 * step, (i + 1) as f64 * step);
                (a.floor() as usize..(b.ceil() as usize).min(n))
                    .map(|k| (k, ((b.min(k as f64 + 1.0) - a.max(k as f64)) / step)))
                    .filter(|&(_, weight)| weight > 0.0)
                    .collect()
            })
            .collect()
    };
    let (wx, wy) = (weights(w, w2), weights(h, h2));
    let mut rows = vec![glam::DVec3::ZERO; w2 * h];
    for y in 0..h {
        for (i, ws) in wx.iter().enumerate() {
            rows[y * w2 + i] = ws.iter().map(|&(k, weight)| texels[y * w + k].as_dvec3() * weight).sum();
        }
    }
    let mut out = Vec::with_capacity(w2 * h2);
    for ws in &wy {
        for i in 0..w2 {
            let t: glam::DVec3 = ws.iter().map(|&(k, weight)| rows[k * w2 + i] * weight).sum();
            out.push(t.as_vec3());
        }
    }
    Level { width: w2, height: h2, texels: out }
}

/// Widens `n` encoded pixels of `B` bytes, which fill the tail of `buffer` (`n` texels of
/// [`TEXEL_BYTES`]), into texels in place, front to back: writing texel `i` ends at byte
/// `12(i + 1)`, and pixel `i + 1` starts at `12n − B(n − i − 1) ≥ 12(i + 1)` for `B ≤ 12`.
fn widen<const B: usize>(buffer: &mut [u8], n: usize, texel: impl Fn(&[u8; B]) -> [f32; 3]) {
    const { assert!(B as u64 <= TEXEL_BYTES) };
    let start = buffer.len() - n * B;
    for i in 0..n {
        let at = start + i * B;
        let pixel: [u8; B] = buffer[at..at + B].try_into().expect("B bytes");
        let rgb = texel(&pixel);
        buffer[i * 12..i * 12 + 12].copy_from_slice(bytemuck::cast_slice(&rgb));
    }
}

/// A diffuse albedo from an image: `factor · bilinear(image, wrap(uv))`.
#[derive(Clone, Debug, PartialEq)]
pub struct ImageTexture {
    pub image: Arc<Image>,
    /// Wrap mode along `u` (glTF `wrapS`).
    pub wrap_u: Wrap,
    /// Wrap mode along `v` (glTF `wrapT`).
    pub wrap_v: Wrap,
    /// Multiplies every texel (glTF `baseColorFactor`; OBJ's `Kd`, 1 when the MTL gives none).
    pub factor: Vec3,
    /// Whether [`Self::lookup_lod`] reads the mip pyramid: false for a glTF sampler whose
    /// `minFilter` is `NEAREST` or `LINEAR` (the file asks for no mip-mapping); true for any
    /// other, an unset `minFilter`, and OBJ and TOML textures.
    pub mipmaps: bool,
}

impl ImageTexture {
    /// The filtered, linear albedo at texture coordinates `uv` (see the module header).
    pub fn lookup(&self, uv: Vec2) -> Vec3 {
        self.factor * self.bilinear(0, uv)
    }

    /// The trilinear lookup at level of detail `lod` (`log₂` of the footprint's width in
    /// texels; see the module header): the bilinear lookup where `lod ≤ 0`.
    pub fn lookup_lod(&self, uv: Vec2, lod: f32) -> Vec3 {
        let last = self.image.levels.len();
        if !(lod > 0.0) || last == 0 || !self.mipmaps {
            return self.lookup(uv);
        }
        let lod = lod.min(last as f32);
        let k = lod.floor();
        let f = lod - k;
        let k = k as usize;
        let a = self.bilinear(k, uv);
        let mixed = if f > 0.0 { a * (1.0 - f) + self.bilinear(k + 1, uv) * f } else { a };
        self.factor * mixed
    }

    /// The bilinear lookup in level `k` of the pyramid, without the factor.
    fn bilinear(&self, k: usize, uv: Vec2) -> Vec3 {
        let (width, height, texels) = self.image.level(k);
        // Continuous texel coordinates, texel centres at integers + ½ from the top-left.
        let x = uv.x as f64 * width as f64 - 0.5;
        let y = (1.0 - uv.y as f64) * height as f64 - 0.5;
        if !(x.is_finite() && y.is_finite()) {
            return Vec3::ZERO;
        }
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = ((x - x0) as f32, (y - y0) as f32);
        let (x0, y0) = (x0 as i64, y0 as i64);
        let (i0, i1) = (self.wrap_u.index(x0, width), self.wrap_u.index(x0 + 1, width));
        let (j0, j1) = (self.wrap_v.index(y0, height), self.wrap_v.index(y0 + 1, height));
        let texel = |i: usize, j: usize| texels[j * width + i];
        let top = texel(i0, j0) * (1.0 - fx) + texel(i1, j0) * fx;
        let bottom = texel(i0, j1) * (1.0 - fx) + texel(i1, j1) * fx;
        top * (1.0 - fy) + bottom * fy
    }
}

/// The decoded image of the file at `path`, shared: every material of the process that names
/// the same file (same canonical path, size and modification time) while another still holds
/// it gets the same texels, decoded once.
pub fn open_shared(path: &Path) -> Result<Arc<Image>, String> {
    open_shared_as(path, Encoding::Srgb)
}

/// [`open_shared`] with the channels' `encoding` (a file read both ways is decoded twice).
pub fn open_shared_as(path: &Path, encoding: Encoding) -> Result<Arc<Image>, String> {
    /// A file by canonical path, size in bytes and modification time, and how it is decoded.
    type FileKey = (PathBuf, u64, Option<SystemTime>, Encoding);
    static CACHE: Mutex<BTreeMap<FileKey, Weak<Image>>> = Mutex::new(BTreeMap::new());
    let meta = std::fs::metadata(path).map_err(|e| format!("{}: cannot read the texture: {e}", path.display()))?;
    let key = (path.canonicalize().unwrap_or_else(|_| path.to_path_buf()), meta.len(), meta.modified().ok(), encoding);
    let mut cache = CACHE.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
    cache.retain(|_, image| image.strong_count() > 0);
    if let Some(image) = cache.get(&key).and_then(Weak::upgrade) {
        crate::sys::read::note_input(path).map_err(|e| format!("{}: cannot read the texture: {e}", path.display()))?;
        return Ok(image);
    }
    let image = Arc::new(Image::open(path, encoding)?);
    cache.insert(key, Arc::downgrade(&image));
    Ok(image)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 2×2 image: top row red, green; bottom row blue, white (linear values).
    fn quad(wrap: Wrap) -> ImageTexture {
        let texels = vec![Vec3::X, Vec3::Y, Vec3::Z, Vec3::ONE];
        let image = Arc::new(Image::from_texels("t", 2, 2, texels).unwrap());
        ImageTexture { image, wrap_u: wrap, wrap_v: wrap, factor: Vec3::ONE, mipmaps: true }
    }

    #[test]
    fn texel_centres_give_the_texel() {
        let t = quad(Wrap::Repeat);
        assert_eq!(t.lookup(Vec2::new(0.25, 0.75)), Vec3::X); // top-left
        assert_eq!(t.lookup(Vec2::new(0.75, 0.75)), Vec3::Y);
        assert_eq!(t.lookup(Vec2::new(0.25, 0.25)), Vec3::Z); // bottom-left
        assert_eq!(t.lookup(Vec2::new(0.75, 0.25)), Vec3::ONE);
    }

    #[test]
    fn bilinear_between_centres() {
        let t = quad(Wrap::Clamp);
        // Halfway between the two top texel centres.
        assert_eq!(t.lookup(Vec2::new(0.5, 0.75)), Vec3::new(0.5, 0.5, 0.0));
        // The centre of the image: the mean of all four.
        assert_eq!(t.lookup(Vec2::new(0.5, 0.5)), Vec3::new(0.5, 0.5, 0.5));
    }

    #[test]
    fn wrap_modes() {
        // u = 1.25 is a quarter into the next copy (repeat), past the edge (clamp), or a
        // quarter back into the mirrored copy (mirrored repeat).
        let top = 0.75;
        assert_eq!(quad(Wrap::Repeat).lookup(Vec2::new(1.25, top)), Vec3::X);
        assert_eq!(quad(Wrap::Clamp).lookup(Vec2::new(1.25, top)), Vec3::Y);
        assert_eq!(quad(Wrap::MirroredRepeat).lookup(Vec2::new(1.25, top)), Vec3::Y);
        assert_eq!(quad(Wrap::MirroredRepeat).lookup(Vec2::new(1.75, top)), Vec3::X);
        assert_eq!(quad(Wrap::Repeat).lookup(Vec2::new(-0.25, top)), Vec3::Y);
        assert_eq!(quad(Wrap::Clamp).lookup(Vec2::new(-3.0, top)), Vec3::X);
        assert_eq!(quad(Wrap::MirroredRepeat).lookup(Vec2::new(-0.25, top)), Vec3::X);
        // Along v: v = 1.25 is a quarter into the copy above.
        assert_eq!(quad(Wrap::Repeat).lookup(Vec2::new(0.25, 1.25)), Vec3::Z);
        assert_eq!(quad(Wrap::Clamp).lookup(Vec2::new(0.25, 1.25)), Vec3::X);
        assert_eq!(quad(Wrap::MirroredRepeat).lookup(Vec2::new(0.25, 1.25)), Vec3::X);
    }

    #[test]
    fn srgb_decoding_is_exact() {
        assert_eq!(srgb_to_linear(0.0), 0.0);
        assert_eq!(srgb_to_linear(1.0), 1.0);
        assert!((srgb_to_linear(0.5) - 0.214_041_140_482_232_55).abs() < 1e-15);
        assert!((srgb_to_linear(0.04045) - 0.04045 / 12.92).abs() < 1e-17);
    }

    /// A `w × h` checkerboard of cells of `cell` texels, white and black.
    fn checker(w: usize, h: usize, cell: usize) -> ImageTexture {
        let texels = (0..w * h).map(|k| if (k % w / cell + k / w / cell) % 2 == 0 { Vec3::ONE } else { Vec3::ZERO });
        let image = Image::from_texels("checker", w, h, texels.collect()).unwrap().with_levels().unwrap();
        ImageTexture {
            image: Arc::new(image),
            wrap_u: Wrap::Repeat,
            wrap_v: Wrap::Repeat,
            factor: Vec3::ONE,
            mipmaps: true,
        }
    }

    #[test]
    fn mip_levels_halve_and_keep_the_mean() {
        for (w, h) in [(64, 64), (7, 5), (1, 9), (10, 3)] {
            let t = checker(w, h, 2);
            let mean = t.image.mean();
            let sizes: Vec<_> = t.image.levels.iter().map(|l| (l.width, l.height)).collect();
            assert_eq!(sizes.last(), Some(&(1, 1)), "{w} × {h}: {sizes:?}");
            assert_eq!(sizes[0], ((w / 2).max(1), (h / 2).max(1)));
            for l in &t.image.levels {
                let sum: Vec3 = l.texels.iter().sum();
                let m = sum / l.texels.len() as f32;
                assert!(
                    (m - mean).abs().max_element() < 1e-5,
                    "{w} × {h}, level {} × {}: {m} vs {mean}",
                    l.width,
                    l.height
                );
            }
        }
        // 64 × 64 texels and 1/3 as many again.
        assert_eq!(checker(64, 64, 8).image.size_bytes(), (4096 + 1365) * 12);
    }

    #[test]
    fn trilinear_lookup() {
        let t = checker(64, 64, 8);
        let uv = Vec2::new(0.3, 0.7);
        // λ ≤ 0 is the bilinear lookup, bit for bit; the last level is the mean.
        assert_eq!(t.lookup_lod(uv, 0.0), t.lookup(uv));
        assert_eq!(t.lookup_lod(uv, -3.0), t.lookup(uv));
        assert_eq!(t.lookup_lod(uv, 6.0), Vec3::splat(0.5));
        assert_eq!(t.lookup_lod(uv, 40.0), Vec3::splat(0.5));
        // Level 3 (8 × 8) holds one cell per texel; level 4 (4 × 4) two by two cells: 0.5.
        assert_eq!(t.lookup_lod(uv, 4.0), Vec3::splat(0.5));
        let (a, b) = (t.lookup_lod(uv, 3.0), t.lookup_lod(uv, 4.0));
        assert!((t.lookup_lod(uv, 3.25) - (0.75 * a + 0.25 * b)).abs().max_element() < 1e-6);
    }

    #[test]
    fn bad_bytes_are_named() {
        let e = Image::decode(b"not an image at all", "x.png").unwrap_err();
        assert!(e.starts_with("x.png: "), "{e}");
    }
}

#[cfg(test)]
mod sharing {
    use super::*;

    #[test]
    fn one_file_is_decoded_once_while_in_use() {
        let dir = std::env::temp_dir().join(format!("strahl-texture-share-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("t.png");
        image::RgbImage::from_pixel(2, 1, image::Rgb([255, 128, 0])).save(&path).unwrap();
        let a = open_shared(&path).unwrap();
        let b = open_shared(&dir.join(".").join("t.png")).unwrap();
        assert!(Arc::ptr_eq(&a, &b));
        assert_eq!(a.texels[0], Vec3::new(1.0, srgb_to_linear(128.0 / 255.0) as f32, 0.0));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
