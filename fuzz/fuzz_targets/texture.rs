//! An image file's bytes (PNG, JPEG, or anything else: an HDR or GIF is refused as not a PNG or
//! JPEG) through strahl's texture decoding, with 64 MiB of memory budget left: a header that
//! declares more texels than the budget holds, or than its bytes can back, is refused before
//! anything is allocated; nothing panics.
#![no_main]
use libfuzzer_sys::fuzz_target;
use strahl::sys::read::{LoadOptions, set_load_options};

fuzz_target!(
    init: {
        let max_memory = Some(strahl::job::memory::BASE_BYTES + (64 << 20));
        set_load_options(LoadOptions { max_memory, confine: None }).expect("no folder to check");
    },
    |data: &[u8]| {
        let _ = strahl::texture::Image::decode(data, "fuzz");
    }
);
