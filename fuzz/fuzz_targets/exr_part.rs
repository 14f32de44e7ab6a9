//! Arbitrary bytes as `strahl merge` parts: read, checked, planned and merged in memory
//! ([`strahl::output::merge::merge_bytes`]) within a 1 GB budget. The input is one part, or several
//! separated by the 8 bytes `\0strahl\0`. A refusal is fine; a panic, a hang or an allocation
//! past libFuzzer's RSS limit is a finding.
#![no_main]
use libfuzzer_sys::fuzz_target;

const SEPARATOR: &[u8] = b"\0strahl\0";

fuzz_target!(|data: &[u8]| {
    let mut parts = Vec::new();
    let mut rest = data;
    while let Some(at) = rest.windows(SEPARATOR.len()).position(|w| w == SEPARATOR) {
        parts.push(rest[..at].to_vec());
        rest = &rest[at + SEPARATOR.len()..];
    }
    parts.push(rest.to_vec());
    let _ = strahl::output::merge::merge_bytes(parts, 1 << 30);
});
