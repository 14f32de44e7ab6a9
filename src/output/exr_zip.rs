//! OpenEXR's ZIP block compression (`ZIP_COMPRESSION`, `ZIPS_COMPRESSION`), as OpenEXR's
//! `ImfZip.cpp` defines it, with a faster deflate than the `exr` crate's:
//!
//! 1. the block's little-endian bytes are split into the even-indexed bytes followed by the
//!    odd-indexed ones (so the high and low bytes of the samples gather);
//! 2. every byte but the first becomes `b[i] − b[i−1] + 128` (mod 256), of the split bytes;
//! 3. the result is zlib-compressed (RFC 1950, as OpenEXR's `compress()` call).
//!
//! A block whose compressed form is not smaller than its raw bytes is stored raw, as OpenEXR
//! does (a reader tells the two apart by the size). Any zlib level gives a valid file; the
//! `exr` crate deflates with miniz_oxide at level 4, strahl with `flate2`'s default backend
//! (miniz_oxide too) at [`ZLIB_LEVEL`] (measured in the module `crate::output::exr` docs). The preprocessing is
//! written out here because the `exr` crate keeps its own private.

use std::io::Write;

use flate2::write::ZlibEncoder;

/// The zlib level strahl compresses ZIP blocks with (1 fastest, 9 smallest).
pub const ZLIB_LEVEL: u32 = 1;

/// The bytes stored for an uncompressed block `raw` (little-endian samples, line by line).
pub fn compress_block(raw: &[u8]) -> Vec<u8> {
    let n = raw.len();
    // 1. Even-indexed bytes, then odd-indexed ones (pairwise, so that the compiler
    //    vectorises it; an odd last byte is even-indexed).
    let pairs = raw.chunks_exact(2);
    let last = pairs.remainder().first().copied();
    let mut split = Vec::with_capacity(n);
    split.extend(pairs.clone().map(|p| p[0]));
    split.extend(last);
    split.extend(pairs.map(|p| p[1]));
    // 2. Differences of neighbours, from a second buffer (no loop-carried dependency).
    let mut delta = Vec::with_capacity(n);
    delta.extend(split.first().copied());
    delta.extend(split.windows(2).map(|w| w[1].wrapping_sub(w[0]).wrapping_add(128)));
    let split = delta;
    let mut encoder = ZlibEncoder::new(Vec::with_capacity(n / 2), flate2::Compression::new(ZLIB_LEVEL));
    // Writing into a Vec cannot fail.
    let compressed = encoder.write_all(&split).and_then(|()| encoder.finish()).unwrap_or_default();
    if compressed.is_empty() || compressed.len() >= n { raw.to_vec() } else { compressed }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Read;

    /// Undoes the three steps, as a reader does.
    fn decompress(stored: &[u8], n: usize) -> Vec<u8> {
        if stored.len() == n {
            return stored.to_vec();
        }
        let mut split = Vec::new();
        flate2::read::ZlibDecoder::new(stored).read_to_end(&mut split).unwrap();
        for i in 1..split.len() {
            split[i] = split[i].wrapping_add(split[i - 1]).wrapping_sub(128);
        }
        let half = n.div_ceil(2);
        (0..n).map(|i| split[if i % 2 == 0 { i / 2 } else { half + i / 2 }]).collect()
    }

    /// The preprocessing exactly as OpenEXR's ImfZip.cpp writes it, byte by byte.
    fn reference_preprocess(raw: &[u8]) -> Vec<u8> {
        let n = raw.len();
        let half = n.div_ceil(2);
        let mut split = vec![0u8; n];
        for (i, &b) in raw.iter().enumerate() {
            split[if i % 2 == 0 { i / 2 } else { half + i / 2 }] = b;
        }
        let mut previous = split.first().copied().unwrap_or(0);
        for b in split.iter_mut().skip(1) {
            let current = *b;
            *b = current.wrapping_sub(previous).wrapping_add(128);
            previous = current;
        }
        split
    }

    #[test]
    fn the_vectorised_preprocessing_is_openexrs_byte_for_byte() {
        // Pseudo-random bytes (a fixed LCG) of even and odd lengths, incompressible and
        // compressible: the compressed bytes equal zlib's of the reference preprocessing.
        let mut x = 12345u32;
        let mut noise = || {
            x = x.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (x >> 24) as u8
        };
        for n in [0usize, 1, 2, 3, 17, 1000, 4097] {
            let random: Vec<u8> = (0..n).map(|_| noise()).collect();
            let smooth: Vec<u8> = (0..n).map(|i| (i / 7) as u8).collect();
            for raw in [random, smooth] {
                let want = reference_preprocess(&raw);
                let stored = compress_block(&raw);
                if stored.len() == raw.len() {
                    assert_eq!(stored, raw);
                    continue;
                }
                let mut got = Vec::new();
                flate2::read::ZlibDecoder::new(&stored[..]).read_to_end(&mut got).unwrap();
                assert_eq!(got, want, "length {n}");
            }
        }
    }

    #[test]
    fn round_trips_and_stores_incompressible_blocks_raw() {
        let smooth: Vec<u8> = (0..4001u32).flat_map(|i| (i as f32 * 0.25).to_le_bytes()).take(16001).collect();
        let stored = compress_block(&smooth);
        assert!(stored.len() < smooth.len() / 2);
        assert_eq!(decompress(&stored, smooth.len()), smooth);
        let tiny = [7u8, 200, 3];
        assert_eq!(compress_block(&tiny), tiny);
    }
}
