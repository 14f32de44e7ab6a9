//! Cryptomatte 1.1 (Psyop's open specification): ids of names and the header attributes.
//!
//! An object (or material) name `s` gets the id `h = MurmurHash3_x86_32(utf8(s), seed 0)`;
//! the id stored in a float channel is the float whose bits are `h`, except that when `h`'s
//! exponent bits (23..30) are all 0 or all 1 the exponent's lowest bit (bit 23) is flipped,
//! so that no id is a denormal, an infinity or a NaN (`conversion = "uint32_to_float32"`).
//! The manifest maps each name to the hex of the id's bits *after* that conversion.
//!
//! A pixel's ranks are its (id, coverage) pairs sorted by coverage, highest first (ties by
//! the id's bits, smallest first), coverage being the fraction of the pixel's samples whose
//! camera ray hit that object first; `levels` ranks are kept, two per RGBA layer
//! (`r` = id, `g` = coverage, `b` = id, `a` = coverage), the layers named `<name>00`, `<name>01`, …
//! A sample that hits nothing adds no rank, so ranks sum to the pixel's coverage.
//!
//! The header holds, for each Cryptomatte pass, with `key` the first 7 hex digits of the
//! MurmurHash3 of the pass name (`ViewLayer.CryptoObject`):
//! `cryptomatte/<key>/name`, `/hash = "MurmurHash3_32"`, `/conversion = "uint32_to_float32"`
//! and `/manifest` (JSON `{"name":"hex",…}`).
//!
//! MurmurHash3 is written out here (20 lines) because Cryptomatte needs exactly its x86 32-bit
//! variant with seed 0; tests check it against published values, Python's `mmh3` and a file
//! Blender wrote.

/// MurmurHash3_x86_32 of `data` with `seed` (Austin Appleby's reference algorithm).
pub fn murmur3_32(data: &[u8], seed: u32) -> u32 {
    const C1: u32 = 0xcc9e_2d51;
    const C2: u32 = 0x1b87_3593;
    let mut h = seed;
    let mut blocks = data.chunks_exact(4);
    for block in &mut blocks {
        let k = u32::from_le_bytes([block[0], block[1], block[2], block[3]]);
        h ^= k.wrapping_mul(C1).rotate_left(15).wrapping_mul(C2);
        h = h.rotate_left(13).wrapping_mul(5).wrapping_add(0xe654_6b64);
    }
    let tail = blocks.remainder();
    if !tail.is_empty() {
        let k = tail.iter().rev().fold(0u32, |k, &b| (k << 8) | b as u32);
        h ^= k.wrapping_mul(C1).rotate_left(15).wrapping_mul(C2);
    }
    h ^= data.len() as u32;
    h ^= h >> 16;
    h = h.wrapping_mul(0x85eb_ca6b);
    h ^= h >> 13;
    h = h.wrapping_mul(0xc2b2_ae35);
    h ^ (h >> 16)
}

/// The Cryptomatte id of `name`: its hash with the exponent rule applied, as float bits.
pub fn id_bits(name: &str) -> u32 {
    let h = murmur3_32(name.as_bytes(), 0);
    let exponent = (h >> 23) & 0xff;
    if exponent == 0 || exponent == 0xff { h ^ (1 << 23) } else { h }
}

/// The id of `name` as the float stored in the id channels.
pub fn id(name: &str) -> f32 {
    f32::from_bits(id_bits(name))
}

/// The 7-hex-digit key of a Cryptomatte pass named `pass_name` in the header attributes.
pub fn key(pass_name: &str) -> String {
    format!("{:08x}", murmur3_32(pass_name.as_bytes(), 0))[..7].to_string()
}

/// The manifest of `names`: JSON `{"name":"8-hex-digit id",…}` in the given order.
pub fn manifest<S: AsRef<str>>(names: &[S]) -> String {
    let entries: Vec<String> = names
        .iter()
        .map(|n| {
            let n = n.as_ref();
            format!("{}:\"{:08x}\"", serde_json::Value::from(n), id_bits(n))
        })
        .collect();
    format!("{{{}}}", entries.join(","))
}

/// The header attributes of one Cryptomatte pass as `(attribute name, value)`.
pub fn attributes<S: AsRef<str>>(pass_name: &str, names: &[S]) -> [(String, String); 4] {
    let k = key(pass_name);
    [
        (format!("cryptomatte/{k}/name"), pass_name.to_string()),
        (format!("cryptomatte/{k}/hash"), "MurmurHash3_32".to_string()),
        (format!("cryptomatte/{k}/conversion"), "uint32_to_float32".to_string()),
        (format!("cryptomatte/{k}/manifest"), manifest(names)),
    ]
}

/// Ranks `(id bits, sample count)` by count (highest first), ties by id bits, and writes the
/// first `levels` as `(id, count / spp)` pairs into `out` (`2·levels` floats at least; the rest
/// stays 0).
pub fn write_ranks(counts: &mut [(u32, u32)], spp: u32, out: &mut [f32]) {
    counts.sort_unstable_by(|a, b| b.1.cmp(&a.1).then(a.0.cmp(&b.0)));
    for (pair, &(id, count)) in out.chunks_exact_mut(2).zip(counts.iter()) {
        pair[0] = f32::from_bits(id);
        pair[1] = count as f32 / spp as f32;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn murmur3_matches_published_values() {
        // Reference values of MurmurHash3_x86_32 (SMHasher's verification set and mmh3).
        assert_eq!(murmur3_32(b"", 0), 0);
        assert_eq!(murmur3_32(b"", 1), 0x514e_28b7);
        assert_eq!(murmur3_32(b"hello", 0), 0x248b_fa47);
        assert_eq!(murmur3_32(b"The quick brown fox jumps over the lazy dog", 0), 0x2e4f_f723);
    }

    #[test]
    fn ids_match_the_blender_file() {
        // From blender-3.4-cycles-multilayer-cryptomatte.exr's manifests and keys.
        assert_eq!(format!("{:08x}", id_bits("Cube")), "a8fce865");
        assert_eq!(format!("{:08x}", id_bits("Material")), "3913209d");
        assert_eq!(format!("{:08x}", id_bits("default_surface")), "78d05529");
        assert_eq!(key("ViewLayer.CryptoObject"), "542cafa");
        assert_eq!(key("ViewLayer.CryptoMaterial"), "c7dbf5e");
    }

    #[test]
    fn ids_are_never_denormal_inf_or_nan() {
        for i in 0..20000 {
            let x = id(&format!("object {i}"));
            assert!(x.is_normal(), "object {i}: {x:e}");
        }
    }

    #[test]
    fn ranks_sort_by_coverage_then_id() {
        let mut counts = [(7, 1), (3, 2), (5, 1)];
        let mut out = [0.0; 8];
        write_ranks(&mut counts, 4, &mut out);
        assert_eq!(out.map(f32::to_bits), [3, 0.5f32.to_bits(), 5, 0.25f32.to_bits(), 7, 0.25f32.to_bits(), 0, 0]);
        assert_eq!(manifest(&["a\"b"]), format!("{{\"a\\\"b\":\"{:08x}\"}}", id_bits("a\"b")));
    }
}
