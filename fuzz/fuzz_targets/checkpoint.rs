//! Arbitrary bytes as a checkpoint, read through the resume path
//! ([`strahl::output::checkpoint::read_from`]) into the film of a 40 × 24 region (6 tiles, 2 of
//! them partial) with every pass. The first byte chooses how much of the file is made valid, so
//! that the fuzzer reaches past the magic, the key and the checksum: 0 the bytes as they are,
//! 1 a valid header (magic, version, key) before them, 2 that header and the correct checksum
//! after them. A refusal is fine; a panic, a hang or an allocation past libFuzzer's RSS limit
//! is a finding, and so is a checkpoint accepted with tiles outside the region.
#![no_main]
use std::path::Path;

use libfuzzer_sys::fuzz_target;
use strahl::output::checkpoint::read_from;
use strahl::output::film::Film;
use strahl::output::passes::{OutputSpec, PassSet};
use strahl::output::region::Region;
use strahl::scene::hash::Fnv1a;

const KEY: &str = "strahl fuzz key";

fuzz_target!(|data: &[u8]| {
    let Some((&mode, rest)) = data.split_first() else { return };
    let mut file = Vec::new();
    if mode % 3 != 0 {
        file.extend_from_slice(b"STRAHLCK");
        file.extend_from_slice(&1u32.to_le_bytes());
        file.extend_from_slice(&(KEY.len() as u32).to_le_bytes());
        file.extend_from_slice(KEY.as_bytes());
    }
    file.extend_from_slice(rest);
    if mode % 3 == 2 {
        let mut hash = Fnv1a::default();
        hash.bytes(&file);
        file.extend_from_slice(&hash.value().to_le_bytes());
    }
    let region = Region::parse("8,4,48,28").unwrap();
    let output = OutputSpec { passes: PassSet::all(), transparent: false, crypto_levels: 2 };
    let mut film = Film::for_region(64, 32, region, &output);
    let tiles = region.tiles();
    if let Ok(done) = read_from(&file[..], file.len() as u64, Path::new("fuzz.checkpoint"), KEY, &tiles, &mut film) {
        assert!(done.iter().all(|&k| k < tiles.len()));
    }
});
