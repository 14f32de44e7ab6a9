//! The names of strahl's temporary files, and the rule that tells a stale one (its writer is
//! gone) from a live one, so that a run can remove what killed runs left behind.
//!
//! **The name.** `.strahl-HOST-PID-START-N.tmp`: the host's name, the writer's process id, the
//! writer's start time (clock ticks since boot, field 22 of `/proc/PID/stat`) and a counter
//! unique within the process. The name does not grow with the output's, so any legal output
//! name works. HOST is the kernel's host name kept to `[A-Za-z0-9._-]` and 40 bytes; a name
//! that had to be changed (another character, longer) gets `_` and 8 hex digits of the XXH3
//! hash of its raw bytes appended, so that two hosts whose names differ only in what was
//! replaced still differ (a host name is input like any other: a farm's node names are chosen
//! by whoever runs it).
//!
//! **Stale.** A temporary is removed by [`remove_stale`] only when all of these hold:
//! - its name has exactly the form above, with this host's HOST;
//! - it is a regular file (not a link, not a directory) owned by this process's user;
//! - its writer is gone: no process PID runs (`/proc/PID/stat` is missing), or the process
//!   PID that runs started at another time than START (the PID was reused), or the file was
//!   last written before this boot (after a reboot any PID and start time may come again).
//!
//! So a live writer's temporary is never removed, whatever its age, nor another host's (on a
//! shared farm folder its writer cannot be seen from here), nor any other file. The rule
//! assumes that the processes of one host name share a PID namespace (containers that share a
//! host name but not their process ids, writing to one folder, would see each other's writers
//! as gone). Where `/proc` is missing (not Linux), nothing is ever stale.
//!
//! Temporaries of strahl before this rule (`.strahl-PID-N.tmp`) name no host: they are left
//! alone, and are safe to delete by hand.

use std::fs;
use std::io;
use std::os::unix::fs::MetadataExt;
use std::path::Path;
use std::sync::OnceLock;
use std::time::{Duration, SystemTime, UNIX_EPOCH};

/// This process as temporary names carry it.
#[derive(Clone, Debug, PartialEq, Eq)]
struct Writer {
    host: String,
    pid: u32,
    /// Clock ticks since boot when the process started; 0 where unknown.
    start: u64,
}

/// The writer of this process (read once).
fn this_writer() -> &'static Writer {
    static WRITER: OnceLock<Writer> = OnceLock::new();
    WRITER.get_or_init(|| {
        let pid = std::process::id();
        let host = fs::read("/proc/sys/kernel/hostname").map(|raw| host_tag(raw.trim_ascii())).unwrap_or_default();
        Writer { host: if host.is_empty() { "nohost".into() } else { host }, pid, start: start_ticks(pid).unwrap_or(0) }
    })
}

/// The name of this process's temporary number `n` (see the module docs).
pub fn name(n: u64) -> String {
    let w = this_writer();
    format!(".strahl-{}-{}-{}-{n}.tmp", w.host, w.pid, w.start)
}

/// A host name as temporary names carry it (see the module docs).
pub fn host_tag(raw: &[u8]) -> String {
    const KEEP: usize = 40;
    let safe = |b: u8| b.is_ascii_alphanumeric() || matches!(b, b'.' | b'_' | b'-');
    let kept: String = raw.iter().take(KEEP).map(|&b| if safe(b) { b as char } else { '_' }).collect();
    if raw.len() <= KEEP && raw.iter().all(|&b| safe(b)) && !raw.is_empty() {
        return kept;
    }
    format!("{kept}_{:08x}", xxhash_rust::xxh3::xxh3_64(raw) as u32)
}

/// The writer a temporary's file name names, when it has exactly the form of the module docs.
fn parse(file_name: &str) -> Option<Writer> {
    let inner = file_name.strip_prefix(".strahl-")?.strip_suffix(".tmp")?;
    // HOST may itself hold '-': the three numbers are the last fields.
    let mut fields = inner.rsplitn(4, '-');
    let digits = |s: &str| !s.is_empty() && s.len() <= 20 && s.bytes().all(|b| b.is_ascii_digit());
    fields.next().filter(|s| digits(s))?;
    let start = fields.next().filter(|s| digits(s))?;
    let pid = fields.next().filter(|s| digits(s))?;
    let host = fields.next().filter(|h| !h.is_empty())?;
    Some(Writer { host: host.to_string(), pid: pid.parse().ok()?, start: start.parse().ok()? })
}

/// When process `pid` started, in clock ticks since boot (field 22 of `/proc/PID/stat`, after
/// the command name in parentheses, which may itself hold spaces and parentheses).
fn start_ticks(pid: u32) -> Option<u64> {
    let stat = fs::read_to_string(format!("/proc/{pid}/stat")).ok()?;
    let after_name = &stat[stat.rfind(')')? + 1..];
    // Fields 3, 4, … follow the name: field 22 is the 20th of them.
    after_name.split_ascii_whitespace().nth(19)?.parse().ok()
}

/// When this boot began (`btime` of `/proc/stat`).
fn boot_time() -> Option<SystemTime> {
    let stat = fs::read_to_string("/proc/stat").ok()?;
    let seconds: u64 = stat.lines().find_map(|l| l.strip_prefix("btime "))?.trim().parse().ok()?;
    Some(UNIX_EPOCH + Duration::from_secs(seconds))
}

/// Whether the writer `w` of a temporary last written at `modified` is gone (module docs).
fn is_gone(w: &Writer, modified: SystemTime, boot: SystemTime) -> bool {
    if modified < boot {
        return true;
    }
    match fs::read_to_string(format!("/proc/{}/stat", w.pid)) {
        Err(e) => e.kind() == io::ErrorKind::NotFound,
        Ok(_) => start_ticks(w.pid).is_some_and(|t| t != w.start),
    }
}

/// Removes the stale temporaries in `dir` ([`remove_stale`]) and says what it removed, in one
/// line (`None`: nothing was). Every command that writes a file into a folder calls it for that
/// folder before it writes.
pub fn remove_stale_saying(dir: &Path) -> Option<String> {
    let removed = remove_stale(dir);
    (removed.files > 0).then(|| {
        format!(
            "removed {} temporar{} ({:.1} MB) that killed runs of this host left in {}",
            removed.files,
            if removed.files == 1 { "y" } else { "ies" },
            removed.bytes as f64 / 1e6,
            dir.display()
        )
    })
}

/// What [`remove_stale`] removed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Removed {
    pub files: usize,
    pub bytes: u64,
}

/// Removes the stale temporaries of this host in `dir` (see the module docs); any other
/// entry is left as it is. Entries that cannot be read or removed are skipped: the render
/// goes on as before.
pub fn remove_stale(dir: &Path) -> Removed {
    let mut removed = Removed::default();
    let me = this_writer();
    let (Some(boot), Ok(own)) = (boot_time(), fs::metadata("/proc/self")) else { return removed };
    if me.start == 0 {
        return removed;
    }
    let Ok(entries) = fs::read_dir(dir) else { return removed };
    for entry in entries.flatten() {
        let name = entry.file_name();
        let Some(writer) = name.to_str().and_then(parse) else { continue };
        if writer.host != me.host || writer == *me {
            continue;
        }
        // Not followed: a link is never removed, nor what it points to.
        let Ok(meta) = entry.path().symlink_metadata() else { continue };
        if !meta.file_type().is_file() || meta.uid() != own.uid() {
            continue;
        }
        let Ok(modified) = meta.modified() else { continue };
        if is_gone(&writer, modified, boot) && fs::remove_file(entry.path()).is_ok() {
            removed.files += 1;
            removed.bytes += meta.len();
        }
    }
    removed
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn host_names_are_kept_to_a_safe_charset_and_stay_apart() {
        assert_eq!(host_tag(b"node-07.farm"), "node-07.farm");
        for hostile in [&b"a/../../b"[..], b"x\ny", b"$(touch PWNED)", b"\xff\xfe", b"", b"a b", &[b'n'; 64]] {
            let tag = host_tag(hostile);
            assert!(tag.bytes().all(|b| b.is_ascii_alphanumeric() || b".-_".contains(&b)), "{tag}");
            assert!(tag.len() <= 49, "{tag}");
        }
        // Names that differ only in the characters replaced differ in their tags.
        assert_ne!(host_tag(b"a b"), host_tag(b"a_b"));
        assert_ne!(host_tag("nodé".as_bytes()), host_tag(b"nod__"));
        assert_ne!(host_tag(&[b'n'; 41]), host_tag(&[b'n'; 42]));
    }

    /// A fresh directory, removed on drop.
    struct TempDir(std::path::PathBuf);
    impl Drop for TempDir {
        fn drop(&mut self) {
            let _ = fs::remove_dir_all(&self.0);
        }
    }

    #[test]
    fn only_this_hosts_temporaries_whose_writer_is_gone_are_removed() {
        let dir = TempDir(std::env::temp_dir().join(format!("strahl-temporary-{}", std::process::id())));
        let _ = fs::remove_dir_all(&dir.0);
        fs::create_dir_all(&dir.0).unwrap();
        let me = this_writer();
        let host = &me.host;
        // A process that has ended, and one that runs.
        let mut ended = std::process::Command::new("true").spawn().unwrap();
        ended.wait().unwrap();
        let mut live_child = std::process::Command::new("sleep").arg("60").spawn().unwrap();
        let (ended, live) = (ended.id(), live_child.id());
        let live_start = start_ticks(live).unwrap();
        let stale = [
            format!(".strahl-{host}-{ended}-{}-0.tmp", me.start),
            // This PID, another start time: the PID was reused.
            format!(".strahl-{host}-{}-{}-0.tmp", me.pid, me.start + 1),
            format!(".strahl-{host}-{live}-{}-1.tmp", live_start + 1),
        ];
        let kept = [
            name(123_456),
            format!(".strahl-{host}-{live}-{live_start}-0.tmp"),
            format!(".strahl-other{host}-{ended}-{}-0.tmp", me.start),
            format!(".strahl-{ended}-0.tmp"),
            format!("strahl-{host}-{ended}-{}-0.tmp", me.start),
            "out.exr".to_string(),
        ];
        for n in stale.iter().chain(&kept) {
            fs::write(dir.0.join(n), b"twelve bytes").unwrap();
        }
        // Written before this boot: stale whoever runs under that PID now.
        let before_boot = format!(".strahl-{host}-{live}-{live_start}-9.tmp");
        let file = fs::File::create(dir.0.join(&before_boot)).unwrap();
        file.set_modified(UNIX_EPOCH + Duration::from_secs(1)).unwrap();
        // A directory and a link with a stale name are left.
        let as_dir = format!(".strahl-{host}-{ended}-{}-1.tmp", me.start);
        fs::create_dir(dir.0.join(&as_dir)).unwrap();
        let as_link = format!(".strahl-{host}-{ended}-{}-2.tmp", me.start);
        std::os::unix::fs::symlink(dir.0.join("out.exr"), dir.0.join(&as_link)).unwrap();
        let removed = remove_stale(&dir.0);
        live_child.kill().unwrap();
        live_child.wait().unwrap();
        let mut left: Vec<String> =
            fs::read_dir(&dir.0).unwrap().map(|e| e.unwrap().file_name().into_string().unwrap()).collect();
        left.sort();
        let mut want: Vec<String> = kept.iter().cloned().chain([as_dir, as_link]).collect();
        want.sort();
        assert_eq!(left, want);
        assert_eq!(removed, Removed { files: 4, bytes: 36 });
    }

    #[test]
    fn names_parse_back_to_their_writer() {
        let name = name(7);
        assert_eq!(parse(&name).as_ref(), Some(this_writer()), "{name}");
        assert_eq!(parse(".strahl-node-1-2-3-4.tmp").unwrap(), Writer { host: "node-1".into(), pid: 2, start: 3 });
        for other in [
            ".strahl-12-0.tmp",
            ".strahl-h-1-2-x.tmp",
            ".strahl--1-2-3.tmp",
            "strahl-h-1-2-3.tmp",
            ".strahl-h-1-2-3.tmpx",
        ] {
            assert_eq!(parse(other), None, "{other}");
        }
    }
}
