//! The memory this process may use: the default `--max-memory` ([`default_limit`]: the smallest
//! of 3/4 of the machine's memory, the memory limit of the process's cgroup — a Slurm job's
//! `--mem` — and its `RLIMIT_AS` less the address space a render reserves), sizes as the
//! command line writes them ([`parse_size`]), and the base every process takes
//! ([`BASE_BYTES`]). What a render will need is estimated in [`crate::job::memory`]; the
//! readers bound what a load may allocate by what is left ([`crate::sys::read`]).

use std::path::{Path, PathBuf};

/// The process, Embree's device and the thread pool (measured: 30–37 MB for the smallest scene).
pub const BASE_BYTES: u64 = 40 << 20;

/// BVH memory per instance (the top level's node and the instance record): the render's
/// estimate counts it, and the glTF reader bounds how many placements a file may make by it.
pub const BVH_BYTES_PER_INSTANCE: u64 = 256;

/// `n` bytes as whole megabytes (10⁶ bytes), e.g. `42 MB`.
pub fn megabytes(n: u64) -> String {
    format!("{} MB", n.div_ceil(1_000_000))
}

/// The default `--max-memory` and what set it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Limit {
    pub bytes: u64,
    /// `3/4 of physical memory, 25277 MB`, `the cgroup memory limit in /sys/fs/cgroup/job/memory.max`,
    /// `RLIMIT_AS 4295 MB less 940 MB of address space kept for threads and Embree`.
    pub source: String,
}

impl std::fmt::Display for Limit {
    /// `4295 MB (the cgroup memory limit in /sys/fs/cgroup/job/memory.max)`.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{} ({})", megabytes(self.bytes), self.source)
    }
}

/// The machine's physical memory (`MemTotal` of `/proc/meminfo`), if it can be read.
pub fn physical_memory() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemTotal:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024)
}

/// Address space a render reserves beyond what it touches, which an `RLIMIT_AS` must leave
/// room for: per core, a thread's stack and malloc arena (64 MiB each).
pub const ADDRESS_SPACE_PER_CORE: u64 = 64 << 20;
/// The same, for the process (TBB's and Embree's reservations). Measured with `prlimit --as`:
/// one dragon (133 MB peak RSS) needs 800 MB of address space with Embree on 2 cores, six
/// (760 MB) 1.5 GB; the native backend reserves about 250 MB less.
pub const ADDRESS_SPACE_BASE: u64 = 768 << 20;

/// The default `--max-memory`: the smallest of three quarters of the physical memory (the
/// rest for the system and the render's transient buffers), the memory limit of the
/// process's cgroup (`memory.max` in cgroup v2, `memory.limit_in_bytes` in v1, of its own
/// cgroup and every one above it: Slurm's `--mem`), and its `RLIMIT_AS` or `RLIMIT_DATA` less
/// the address space a render reserves ([`ADDRESS_SPACE_BASE`], [`ADDRESS_SPACE_PER_CORE`]);
/// `None` when none can be read.
pub fn default_limit() -> Option<Limit> {
    let physical = physical_memory()
        .map(|m| Limit { bytes: m / 4 * 3, source: format!("3/4 of physical memory, {}", megabytes(m)) });
    let read = |path: &Path| std::fs::read_to_string(path).ok();
    let cgroup = match (read(Path::new("/proc/self/cgroup")), read(Path::new("/proc/self/mountinfo"))) {
        (Some(cgroups), Some(mounts)) => cgroup_limit(&cgroups, &mounts, &read)
            .map(|(bytes, file)| Limit { bytes, source: format!("the cgroup memory limit in {}", file.display()) }),
        _ => None,
    };
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get()) as u64;
    let reserve = ADDRESS_SPACE_BASE + cores * ADDRESS_SPACE_PER_CORE;
    let rlimit = read(Path::new("/proc/self/limits")).and_then(|l| rlimit(&l)).map(|(name, bytes)| Limit {
        bytes: bytes.saturating_sub(reserve),
        source: format!(
            "{name} {} less {} of address space kept for threads and Embree",
            megabytes(bytes),
            megabytes(reserve)
        ),
    });
    [physical, cgroup, rlimit].into_iter().flatten().min_by_key(|l| l.bytes)
}

/// The smallest memory limit of the cgroups of the process and above, and the file that says
/// so: `cgroups` is `/proc/self/cgroup` (`0::/PATH` in v2, `N:memory:/PATH` in v1), `mounts`
/// `/proc/self/mountinfo` (where each hierarchy is mounted, and which of its cgroups is the
/// mount's root), `read` reads a file of the cgroup file system.
pub fn cgroup_limit(cgroups: &str, mounts: &str, read: &dyn Fn(&Path) -> Option<String>) -> Option<(u64, PathBuf)> {
    let mut best: Option<(u64, PathBuf)> = None;
    for line in cgroups.lines() {
        let mut parts = line.splitn(3, ':');
        let (Some(_), Some(controllers), Some(path)) = (parts.next(), parts.next(), parts.next()) else { continue };
        let (fs, file) = if controllers.is_empty() {
            ("cgroup2", "memory.max")
        } else if controllers.split(',').any(|c| c == "memory") {
            ("cgroup", "memory.limit_in_bytes")
        } else {
            continue;
        };
        for (root, mount_point) in cgroup_mounts(mounts, fs) {
            // The process's cgroup as a folder of this mount (its root may be a cgroup below
            // the hierarchy's, as in a container).
            let Ok(below) = Path::new(path).strip_prefix(&root) else { continue };
            let mut dir = mount_point.join(below);
            loop {
                let limit = read(&dir.join(file)).and_then(|t| parse_limit(&t));
                if let Some(bytes) = limit.filter(|&b| best.as_ref().is_none_or(|(least, _)| b < *least)) {
                    best = Some((bytes, dir.join(file)));
                }
                if dir == mount_point || !dir.pop() {
                    break;
                }
            }
        }
    }
    best
}

/// The mounts of cgroup file system `fs` (`cgroup2`, or `cgroup` with the memory controller)
/// in `/proc/self/mountinfo`: (the cgroup at the mount's root, where it is mounted).
fn cgroup_mounts(mounts: &str, fs: &str) -> Vec<(PathBuf, PathBuf)> {
    mounts
        .lines()
        .filter_map(|line| {
            let (left, right) = line.split_once(" - ")?;
            let left: Vec<&str> = left.split(' ').collect();
            let right: Vec<&str> = right.split(' ').collect();
            let memory = fs == "cgroup2" || right.get(2)?.split(',').any(|o| o == "memory");
            if right.first() != Some(&fs) || !memory {
                return None;
            }
            Some((PathBuf::from(unescape(left.get(3)?)), PathBuf::from(unescape(left.get(4)?))))
        })
        .collect()
}

/// A mountinfo path with its octal escapes (`\040` for a space) decoded.
fn unescape(field: &str) -> String {
    let bytes = field.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        let octal =
            bytes.get(i + 1..i + 4).filter(|d| bytes[i] == b'\\' && d.iter().all(|c| (b'0'..=b'7').contains(c)));
        match octal {
            Some(d) => {
                out.push(d.iter().fold(0u8, |n, c| n.wrapping_mul(8) + (c - b'0')));
                i += 4;
            }
            None => {
                out.push(bytes[i]);
                i += 1;
            }
        }
    }
    String::from_utf8_lossy(&out).into_owned()
}

/// A cgroup memory limit file's value: bytes, or `None` for no limit (v2 `max`; v1's
/// "unlimited" is the largest page-aligned `i64`, anything from 2⁶² on is taken as none).
fn parse_limit(text: &str) -> Option<u64> {
    text.trim().parse::<u64>().ok().filter(|&b| b < 1 << 62)
}

/// The smaller of the soft `RLIMIT_AS` and `RLIMIT_DATA` of `/proc/self/limits`, and its name.
fn rlimit(limits: &str) -> Option<(&'static str, u64)> {
    let soft = |prefix: &str| -> Option<u64> {
        let line = limits.lines().find(|l| l.starts_with(prefix))?;
        line[prefix.len()..].split_whitespace().next()?.parse().ok()
    };
    [("RLIMIT_AS", soft("Max address space")), ("RLIMIT_DATA", soft("Max data size"))]
        .into_iter()
        .filter_map(|(name, b)| Some((name, b?)))
        .min_by_key(|&(_, b)| b)
}

/// Parses a size: a number of bytes with an optional suffix `K`, `M`, `G`, `T` (powers of
/// 1024; `KiB`, `MB`, … read the same way, case-insensitive): `512M`, `24G`, `1.5G`.
pub fn parse_size(text: &str) -> Result<u64, String> {
    let t = text.trim();
    let split = t.find(|c: char| !(c.is_ascii_digit() || c == '.')).unwrap_or(t.len());
    let (number, unit) = t.split_at(split);
    let value: f64 = number.parse().map_err(|_| format!("'{text}' is not a size (e.g. 512M, 24G)"))?;
    let shift = match unit.trim().to_ascii_lowercase().trim_end_matches("ib").trim_end_matches('b') {
        "" => 0,
        "k" => 10,
        "m" => 20,
        "g" => 30,
        "t" => 40,
        _ => return Err(format!("'{text}': unknown unit '{unit}' (use K, M, G or T)")),
    };
    let bytes = value * (1u64 << shift) as f64;
    if !(bytes.is_finite() && bytes >= 1.0 && bytes < u64::MAX as f64) {
        return Err(format!("'{text}' is not a size of at least one byte"));
    }
    Ok(bytes as u64)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_parse_with_binary_units() {
        assert_eq!(parse_size("512M"), Ok(512 << 20));
        assert_eq!(parse_size("24G"), Ok(24 << 30));
        assert_eq!(parse_size("1.5g"), Ok(3 << 29));
        assert_eq!(parse_size("100"), Ok(100));
        assert_eq!(parse_size("2GiB"), Ok(2 << 30));
        for bad in ["", "G", "-1G", "3X", "0"] {
            assert!(parse_size(bad).is_err(), "{bad}");
        }
    }

    /// A fake cgroup file system: `files` by path.
    fn reader(files: &[(&str, &str)]) -> impl Fn(&Path) -> Option<String> {
        let files: Vec<(PathBuf, String)> = files.iter().map(|(p, t)| (PathBuf::from(p), t.to_string())).collect();
        move |path: &Path| files.iter().find(|(p, _)| p == path).map(|(_, t)| t.clone())
    }

    #[test]
    fn the_smallest_cgroup_limit_up_the_hierarchy_is_found_in_v1_and_v2() {
        // cgroup v2 alone, as systemd and Slurm set it up: the job's limit is below its step's.
        let cgroups = "0::/system.slice/slurmstepd.scope/job_7/step_0/user/task_0\n";
        let mounts = "30 23 0:26 / /sys/fs/cgroup rw,nosuid - cgroup2 cgroup2 rw,nsdelegate\n";
        let base = "/sys/fs/cgroup/system.slice/slurmstepd.scope/job_7";
        let files = [
            (format!("{base}/step_0/user/task_0/memory.max"), "max\n"),
            (format!("{base}/step_0/memory.max"), "8589934592\n"),
            (format!("{base}/memory.max"), "4294967296\n"),
            ("/sys/fs/cgroup/system.slice/memory.max".to_string(), "max\n"),
        ];
        let files: Vec<(&str, &str)> = files.iter().map(|(p, t)| (p.as_str(), *t)).collect();
        let found = cgroup_limit(cgroups, mounts, &reader(&files));
        assert_eq!(found, Some((4 << 30, PathBuf::from(format!("{base}/memory.max")))));

        // Hybrid (v1 memory controller, an empty v2 hierarchy), the mount's root a cgroup
        // below the hierarchy's (a container), with a space in a folder's name.
        let cgroups = "9:name=systemd:/\n4:memory,hugetlb:/docker/ab c/job\n0::/\n";
        let mounts = "35 31 0:32 /docker/ab\\040c /sys/fs/cgroup/memory rw - cgroup cgroup rw,memory,hugetlb\n\
                      41 31 0:38 / /sys/fs/cgroup/unified rw - cgroup2 cgroup2 rw\n";
        let files = [
            ("/sys/fs/cgroup/memory/job/memory.limit_in_bytes", "9223372036854771712\n"),
            ("/sys/fs/cgroup/memory/memory.limit_in_bytes", "1073741824\n"),
        ];
        let found = cgroup_limit(cgroups, mounts, &reader(&files));
        assert_eq!(found, Some((1 << 30, PathBuf::from("/sys/fs/cgroup/memory/memory.limit_in_bytes"))));

        // No limit anywhere, or no memory hierarchy mounted.
        assert_eq!(cgroup_limit(cgroups, mounts, &reader(&[])), None);
        assert_eq!(cgroup_limit("4:memory:/a\n", "", &reader(&files)), None);
    }

    #[test]
    fn the_smaller_of_the_address_space_and_data_limits_is_read() {
        let limits = "Limit                     Soft Limit           Hard Limit           Units\n\
                      Max data size             unlimited            unlimited            bytes\n\
                      Max address space         4294967296           unlimited            bytes\n";
        assert_eq!(rlimit(limits), Some(("RLIMIT_AS", 4 << 30)));
        let both = limits.replace("Max data size             unlimited", "Max data size             2147483648");
        assert_eq!(rlimit(&both), Some(("RLIMIT_DATA", 2 << 30)));
        assert_eq!(rlimit(&limits.replace("4294967296", "unlimited")), None);
    }
}
