//! Which Embree strahl runs on: the library reported at device creation agrees with the headers
//! the bindings came from, and — when `STRAHL_EXPECT_EMBREE_MAJOR` says which major version a
//! run must test (tools/test-embree4.sh sets 4) — it is that one, so a mis-set include path
//! cannot silently test Embree 3 twice. `strahl --version` names the same library.

use std::process::Command;

use strahl::accel::embree::Device;

#[test]
fn the_linked_library_is_the_expected_major_version() {
    let device = Device::new().expect("Embree device");
    let (library, headers) = (device.version(), Device::header_version());
    assert_eq!(library / 100, headers / 100, "library {library} vs headers {headers}");
    assert!((30000..50000).contains(&library), "Embree version {library} is neither 3 nor 4");
    match std::env::var("STRAHL_EXPECT_EMBREE_MAJOR") {
        Ok(expected) => {
            let expected: u32 = expected.trim().parse().expect("STRAHL_EXPECT_EMBREE_MAJOR is a number");
            assert_eq!(
                library / 10000,
                expected,
                "linked Embree {} but this run must test {expected}",
                device.version_string()
            );
            // The bindings too: Embree >= 4.3 built with instance arrays has a 96-byte RTCRayHit.
            let ray_hit = std::mem::size_of::<strahl::accel::embree::sys::RTCRayHit>();
            if expected == 4 && library >= 40300 {
                assert_eq!(ray_hit, 96, "RTCRayHit of Embree {} headers", device.version_string());
            }
            if expected == 3 {
                assert_eq!(ray_hit, 80);
            }
        }
        Err(_) => eprintln!(
            "note: STRAHL_EXPECT_EMBREE_MAJOR is not set: checked only that the library ({}) matches the headers",
            device.version_string()
        ),
    }
}

#[test]
fn version_names_embree_and_its_isa() {
    let out = Command::new(env!("CARGO_BIN_EXE_strahl")).arg("--version").output().unwrap();
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).unwrap();
    let device = Device::new().unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some(format!("strahl {}", env!("CARGO_PKG_VERSION")).as_str()));
    let embree = lines.next().unwrap_or_default();
    assert!(embree.starts_with(&format!("Embree {} ", device.version_string())), "{text}");
    let width = device.native_packet_width();
    assert!([4, 8, 16].contains(&width), "native packet width {width}");
    assert!(embree.contains(&format!("native {width}-wide packets")), "{text}");
    assert!(["SSE", "AVX", "AVX2", "AVX-512"].iter().any(|isa| embree.contains(&format!("ISA {isa}:"))), "{text}");
    // Every subcommand answers --version the same way.
    let sub = Command::new(env!("CARGO_BIN_EXE_strahl")).args(["render", "--version"]).output().unwrap();
    assert_eq!(String::from_utf8(sub.stdout).unwrap(), text);
}
