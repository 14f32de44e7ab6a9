//! Throughput of the backends on one scene: build time, and Mrays/s for raw Embree calls (the
//! yardstick, [`embree::raw_bench`]), strahl's Embree wrapper (single rays and 8-wide packets
//! through [`Accel`]) and the native BVH, for each ray kind and thread count, on exactly the
//! same rays. Shadow rays are any-hit queries (`occluded`), the others closest-hit.
//!
//! The ratios printed are times relative to raw Embree: `embree x1 / raw x1` = 1.05 means the
//! wrapper costs 5 %; `native / raw x1` is the native BVH against Embree on the same BVH
//! flags (ROBUST, as strahl builds it).
//!
//! The native BVH's line also gives its surface-area cost in Embree's units ([`bvh::Stats`]:
//! the expected node visits and block tests of a random ray), to hold beside what Embree
//! prints for its own tree with `verbose=2`.
//!
//! Each figure is the median of a few runs; a run traces every ray once, in chunks spread over
//! a rayon pool of the given size whose workers flush denormals to zero (as Embree asks).
//! Besides wall-clock Mrays/s, where Linux tells (`/proc/self/task/*/schedstat`), each run
//! also records Mrays per CPU-second of the whole process: on a machine shared with other
//! work, time spent waiting for a core inflates the wall clock but not that figure.

use std::collections::HashMap;
use std::fmt;
use std::time::Instant;

use rayon::prelude::*;

use crate::accel::bvh::{self, Bvh};
use crate::accel::embree::raw_bench::{self, RawHit, RawRays};
use crate::accel::embree::{self, BuildOptions, Device, DeviceOptions, EmbreeAccel};
use crate::accel::{Accel, Hit, TraceError};
use crate::integrator::RenderError;
use crate::math::Ray;
use crate::scene::Scene;
use crate::verify::workload::{self, RayKind};

/// Rays per task handed to the pool (and per `intersect_batch` call).
pub const CHUNK: usize = 1024;

/// What to measure.
#[derive(Clone, Debug, PartialEq)]
pub struct Config {
    /// Rays per kind (primary rays: the nearest square image, see [`workload::primary_side`]).
    pub rays: usize,
    pub kinds: Vec<RayKind>,
    pub threads: Vec<usize>,
    /// The tracers to measure.
    pub engines: Vec<Engine>,
    /// Runs per figure; the median is reported.
    pub runs: usize,
    /// Seed of the random rays.
    pub seed: u64,
}

impl Default for Config {
    fn default() -> Self {
        Config {
            rays: workload::DEFAULT_RAYS,
            kinds: RayKind::ALL.to_vec(),
            threads: vec![1, 2],
            engines: Engine::ALL.to_vec(),
            runs: 3,
            seed: 1,
        }
    }
}

/// The tracers compared. On shadow rays each makes the any-hit query instead: `rtcOccluded1`,
/// `rtcOccluded8`, [`Accel::occluded`], [`Accel::occluded_batch`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Engine {
    /// Raw `rtcIntersect1` on prepared rays, no strahl types in the loop
    /// ([`embree::raw_bench`]): the yardstick of the wrapper's cost.
    RawSingle,
    /// `EmbreeAccel::intersect`, one `rtcIntersect1` per ray through strahl's wrapper.
    EmbreeSingle,
    /// Raw `rtcIntersect8` on consecutive rays.
    RawPacket,
    /// `EmbreeAccel::intersect_batch`, `rtcIntersect8` on consecutive rays.
    EmbreePacket,
    /// `Bvh::intersect`, one ray at a time.
    Native,
}

impl Engine {
    pub const ALL: [Engine; 5] =
        [Engine::RawSingle, Engine::EmbreeSingle, Engine::RawPacket, Engine::EmbreePacket, Engine::Native];

    pub fn name(self) -> &'static str {
        match self {
            Engine::RawSingle => "raw embree x1",
            Engine::EmbreeSingle => "embree x1 (strahl)",
            Engine::RawPacket => "raw embree x8",
            Engine::EmbreePacket => "embree x8 (strahl)",
            Engine::Native => "native",
        }
    }
}

impl std::str::FromStr for Engine {
    type Err = String;

    /// `raw1`, `embree1`, `raw8`, `embree8` or `native`.
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "raw1" => Ok(Engine::RawSingle),
            "embree1" => Ok(Engine::EmbreeSingle),
            "raw8" => Ok(Engine::RawPacket),
            "embree8" => Ok(Engine::EmbreePacket),
            "native" => Ok(Engine::Native),
            _ => Err(format!("unknown engine '{s}' (expected raw1, embree1, raw8, embree8 or native)")),
        }
    }
}

/// One throughput figure.
#[derive(Clone, Debug, PartialEq)]
pub struct Throughput {
    pub kind: RayKind,
    pub threads: usize,
    pub engine: Engine,
    pub rays: usize,
    /// Rays that hit something (the same for every engine, up to edge cases; see `crosscheck`).
    pub hits: usize,
    /// Median over the runs, and every run.
    pub mrays_per_s: f64,
    pub runs: Vec<f64>,
    /// Median Mrays per CPU-second of the process, where the OS reports CPU time.
    pub mrays_per_cpu_s: Option<f64>,
}

/// Build times in milliseconds (median over the runs).
#[derive(Clone, Debug, PartialEq)]
pub struct BuildTime {
    pub threads: usize,
    pub embree_ms: f64,
    pub native_ms: f64,
}

/// Everything [`run`] measured.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Report {
    /// The scene's geometry ([`super::geometry_line`]).
    pub geometry: String,
    pub builds: Vec<BuildTime>,
    /// The shape of the native BVH.
    pub native: Option<bvh::Stats>,
    pub throughput: Vec<Throughput>,
}

/// What can stop a benchmark.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    #[error(transparent)]
    Embree(#[from] embree::Error),
    #[error(transparent)]
    Native(#[from] bvh::Error),
    #[error(transparent)]
    Trace(#[from] TraceError),
    #[error(transparent)]
    Rays(#[from] RenderError),
    #[error("cannot start {threads} threads: {message}")]
    Threads { threads: usize, message: String },
}

/// A rayon pool of `threads` workers that flush denormals to zero.
pub fn pool(threads: usize) -> Result<rayon::ThreadPool, Error> {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .start_handler(|_| embree::enable_flush_to_zero())
        .build()
        .map_err(|e| Error::Threads { threads, message: e.to_string() })
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    if v.is_empty() { f64::NAN } else { v[v.len() / 2] }
}

/// Seconds `f` takes.
fn timed<T>(f: impl FnOnce() -> T) -> (T, f64) {
    let start = Instant::now();
    let out = f();
    (out, start.elapsed().as_secs_f64())
}

/// The CPU time each thread of this process has run so far, in nanoseconds, by thread id
/// (Linux's `/proc/self/task/*/schedstat`; `None` elsewhere).
pub fn thread_cpu_times() -> Option<HashMap<u64, u64>> {
    let mut times = HashMap::new();
    for task in std::fs::read_dir("/proc/self/task").ok()? {
        let task = task.ok()?;
        let Some(tid) = task.file_name().to_str().and_then(|t| t.parse().ok()) else { continue };
        // A thread that ends while we read has no schedstat any more: it ran no further.
        let Ok(stat) = std::fs::read_to_string(task.path().join("schedstat")) else { continue };
        times.insert(tid, stat.split_whitespace().next()?.parse().ok()?);
    }
    Some(times)
}

/// CPU seconds the process's threads ran between two [`thread_cpu_times`] snapshots: each
/// thread alive at the end, from its time at the start (0 if it started since). Threads that
/// ended in between are left out, so that the sum cannot go down (a pool dropped before the
/// run winding down its threads during it made the sum over live threads shrink).
pub fn cpu_seconds_between(before: &HashMap<u64, u64>, after: &HashMap<u64, u64>) -> f64 {
    let ns: u64 = after.iter().map(|(tid, &t)| t.saturating_sub(before.get(tid).copied().unwrap_or(0))).sum();
    ns as f64 * 1e-9
}

/// Any-hit queries for every ray once on the current pool: `found[i]` says whether `rays[i]` is
/// blocked; `packets` uses `occluded_batch` per chunk.
pub fn trace_occluded<A: Accel>(accel: &A, rays: &[Ray], found: &mut [bool], packets: bool) -> Result<(), TraceError> {
    rays.par_chunks(CHUNK).zip(found.par_chunks_mut(CHUNK)).try_for_each(|(rays, found)| {
        if packets {
            return accel.occluded_batch(rays, found);
        }
        for (ray, found) in rays.iter().zip(found.iter_mut()) {
            *found = accel.occluded(ray)?;
        }
        Ok(())
    })
}

/// Raw Embree closest-hit queries ([`embree::raw_bench`]) for every ray once on the current
/// pool.
pub fn trace_raw(
    scene: &embree::Scene,
    packets: bool,
    rays: &RawRays,
    hits: &mut [RawHit],
) -> Result<(), embree::Error> {
    in_chunks(rays, hits, |rays, hits| raw_bench::intersect(scene, packets, rays, hits))
}

/// Raw Embree any-hit queries for every ray once on the current pool.
pub fn trace_raw_occluded(
    scene: &embree::Scene,
    packets: bool,
    rays: &RawRays,
    occluded: &mut [u8],
) -> Result<(), embree::Error> {
    in_chunks(rays, occluded, |rays, occluded| raw_bench::occluded(scene, packets, rays, occluded))
}

/// Runs `trace` on the pool over [`CHUNK`]-sized pieces of `rays` and their answers.
fn in_chunks<T: Send>(
    rays: &RawRays,
    answers: &mut [T],
    trace: impl Fn(raw_bench::RawChunk<'_>, &mut [T]) -> Result<(), embree::Error> + Sync,
) -> Result<(), embree::Error> {
    let chunks: Vec<_> = rays.chunks(CHUNK).collect();
    chunks.into_par_iter().zip(answers.par_chunks_mut(CHUNK)).try_for_each(|(rays, answers)| trace(rays, answers))
}

/// Traces every ray once on the current pool; `packets` uses `intersect_batch` per chunk.
pub fn trace<A: Accel>(accel: &A, rays: &[Ray], hits: &mut [Option<Hit>], packets: bool) -> Result<(), TraceError> {
    rays.par_chunks(CHUNK).zip(hits.par_chunks_mut(CHUNK)).try_for_each(|(rays, hits)| {
        if packets {
            return accel.intersect_batch(rays, hits);
        }
        for (ray, hit) in rays.iter().zip(hits.iter_mut()) {
            *hit = accel.intersect(ray)?;
        }
        Ok(())
    })
}

/// The order of the `n` engines in run `run`: each run starts one engine further on (A B C,
/// B C A, C A B, ...), so over `n` runs each engine takes each place once. A loop runs faster
/// right after one that read the same BVH (its upper levels still cached), so a fixed order
/// flatters whichever engine follows its twin: raw `rtcIntersect1` timed right after itself
/// (the full dragon's primary rays, 16 runs of 5) took 0.90-1.25 of its own time on one
/// thread, median 0.95, in a fixed order, and 0.82-1.14, median 1.01, in this one (10 runs).
fn engine_order(run: usize, n: usize) -> impl Iterator<Item = usize> {
    (0..n).map(move |k| (run + k) % n)
}

/// Measures build times and throughput for `scene` as `config` says.
pub fn run(scene: &Scene, config: &Config) -> Result<Report, Error> {
    let mut report = Report { geometry: super::geometry_line(scene), ..Default::default() };
    // The rays, once for all: secondary rays from Embree's primary hits.
    let mut ray_sets = Vec::new();
    for &threads in &config.threads {
        let pool = pool(threads)?;
        let device = Device::with_options(DeviceOptions { threads: Some(threads) })?;
        let mut embree_ms = Vec::new();
        let mut native_ms = Vec::new();
        let mut built = None;
        for _ in 0..config.runs.max(1) {
            let (embree, s) = pool.install(|| timed(|| EmbreeAccel::build(&device, scene, BuildOptions::default())));
            embree_ms.push(1e3 * s);
            let (native, s) = pool.install(|| timed(|| Bvh::build(scene)));
            native_ms.push(1e3 * s);
            built = Some((embree?, native?));
        }
        report.builds.push(BuildTime { threads, embree_ms: median(embree_ms), native_ms: median(native_ms) });
        let (embree, native) = built.expect("at least one run");
        report.native = Some(native.stats());
        if ray_sets.is_empty() {
            for &kind in &config.kinds {
                let rays = pool.install(|| workload::rays(scene, kind, config.rays, config.seed, &embree))?;
                ray_sets.push((kind, rays));
            }
        }
        for (kind, rays) in &ray_sets {
            let shadow = *kind == RayKind::Shadow;
            let raw_rays = RawRays::new(rays)?;
            // Runs interleave the engines, so that a change in the machine's load hits all of
            // them alike, each run in its own order (see `engine_order`).
            let n = config.engines.len();
            let mut hits = vec![Vec::new(); n];
            let mut found = vec![Vec::new(); n];
            let mut raw_found = vec![Vec::new(); n];
            let mut raw_hits = vec![Vec::new(); n];
            let mut runs = vec![Vec::new(); n];
            let mut cpu_runs = vec![Vec::new(); n];
            for run in 0..config.runs.max(1) {
                for e in engine_order(run, n) {
                    let engine = &config.engines[e];
                    let (hits, found, raw_found) = (&mut hits[e], &mut found[e], &mut raw_found[e]);
                    let raw_hits = &mut raw_hits[e];
                    match engine {
                        Engine::RawSingle | Engine::RawPacket if shadow => raw_found.resize(rays.len(), 0u8),
                        Engine::RawSingle | Engine::RawPacket => raw_hits.resize(rays.len(), RawHit::default()),
                        _ if shadow => found.resize(rays.len(), false),
                        _ => hits.resize(rays.len(), None),
                    }
                    let cpu_before = thread_cpu_times();
                    let (result, s) = pool.install(|| {
                        timed(|| -> Result<(), Error> {
                            match (engine, shadow) {
                                (Engine::RawSingle, false) => {
                                    trace_raw(embree.embree_scene(), false, &raw_rays, raw_hits)?
                                }
                                (Engine::RawPacket, false) => {
                                    trace_raw(embree.embree_scene(), true, &raw_rays, raw_hits)?
                                }
                                (Engine::RawSingle, true) => {
                                    trace_raw_occluded(embree.embree_scene(), false, &raw_rays, raw_found)?
                                }
                                (Engine::RawPacket, true) => {
                                    trace_raw_occluded(embree.embree_scene(), true, &raw_rays, raw_found)?
                                }
                                (Engine::EmbreeSingle, false) => trace(&embree, rays, hits, false)?,
                                (Engine::EmbreePacket, false) => trace(&embree, rays, hits, true)?,
                                (Engine::Native, false) => trace(&native, rays, hits, false)?,
                                (Engine::EmbreeSingle, true) => trace_occluded(&embree, rays, found, false)?,
                                (Engine::EmbreePacket, true) => trace_occluded(&embree, rays, found, true)?,
                                (Engine::Native, true) => trace_occluded(&native, rays, found, false)?,
                            }
                            Ok(())
                        })
                    });
                    result?;
                    runs[e].push(rays.len() as f64 / s / 1e6);
                    if let (Some(before), Some(after)) = (cpu_before, thread_cpu_times()) {
                        cpu_runs[e].push(rays.len() as f64 / cpu_seconds_between(&before, &after) / 1e6);
                    }
                }
            }
            for (e, &engine) in config.engines.iter().enumerate() {
                let hit_count = hits[e].iter().filter(|h| h.is_some()).count()
                    + found[e].iter().filter(|&&f| f).count()
                    + raw_found[e].iter().filter(|&&f| f != 0).count()
                    + raw_hits[e].iter().filter(|h| h.is_hit()).count();
                report.throughput.push(Throughput {
                    kind: *kind,
                    threads,
                    engine,
                    rays: rays.len(),
                    hits: hit_count,
                    mrays_per_s: median(runs[e].clone()),
                    runs: std::mem::take(&mut runs[e]),
                    mrays_per_cpu_s: (!cpu_runs[e].is_empty()).then(|| median(std::mem::take(&mut cpu_runs[e]))),
                });
            }
        }
    }
    Ok(report)
}

impl Report {
    /// The figure for `kind`, `threads`, `engine`, if measured.
    pub fn get(&self, kind: RayKind, threads: usize, engine: Engine) -> Option<&Throughput> {
        self.throughput.iter().find(|t| t.kind == kind && t.threads == threads && t.engine == engine)
    }
}

impl fmt::Display for Report {
    /// A table: build times, then Mrays/s per engine with one column per kind and thread
    /// count, then native's time relative to Embree's single rays (1.00 = as fast).
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "{}", self.geometry)?;
        if let Some(s) = &self.native {
            writeln!(
                f,
                "native BVH: {} nodes, {} leaves, {} triangle blocks ({:.2} triangles each), depth {}, {:.1} MB, \
                 SAH {:.2} (nodes) + {:.2} (leaves)",
                s.nodes,
                s.leaves,
                s.triangle_blocks,
                s.triangles as f64 / s.triangle_blocks.max(1) as f64,
                s.depth,
                s.bytes as f64 / 1e6,
                s.sah_nodes,
                s.sah_leaves
            )?;
        }
        write!(f, "{:<24}", "build ms")?;
        for b in &self.builds {
            write!(f, "{:>14}", format!("{} thr", b.threads))?;
        }
        writeln!(f)?;
        for (name, native) in [("embree", false), ("native", true)] {
            write!(f, "{name:<24}")?;
            for b in &self.builds {
                write!(f, "{:>14.1}", if native { b.native_ms } else { b.embree_ms })?;
            }
            writeln!(f)?;
        }
        let mut columns: Vec<(RayKind, usize)> = Vec::new();
        for t in &self.throughput {
            if !columns.contains(&(t.kind, t.threads)) {
                columns.push((t.kind, t.threads));
            }
        }
        write!(f, "{:<24}", "Mrays/s")?;
        for (kind, threads) in &columns {
            write!(f, "{:>14}", format!("{kind} {threads}t"))?;
        }
        writeln!(f)?;
        let engines: Vec<Engine> =
            Engine::ALL.into_iter().filter(|&e| self.throughput.iter().any(|t| t.engine == e)).collect();
        for &engine in &engines {
            write!(f, "{:<24}", engine.name())?;
            for &(kind, threads) in &columns {
                match self.get(kind, threads, engine) {
                    Some(t) => write!(f, "{:>14.2}", t.mrays_per_s)?,
                    None => write!(f, "{:>14}", "-")?,
                }
            }
            writeln!(f)?;
        }
        // Time of `a` over time of `b` (1.00 = as fast, 1.05 = 5 % slower).
        let ratio =
            |f: &mut fmt::Formatter<'_>, a: Engine, b: Engine, get: fn(&Throughput) -> Option<f64>| -> fmt::Result {
                for &(kind, threads) in &columns {
                    let x = self.get(kind, threads, a).and_then(get);
                    let y = self.get(kind, threads, b).and_then(get);
                    match (x, y) {
                        (Some(x), Some(y)) => write!(f, "{:>14.3}", y / x)?,
                        _ => write!(f, "{:>14}", "-")?,
                    }
                }
                writeln!(f)
            };
        const RATIOS: [(&str, Engine, Engine); 4] = [
            ("embree x1 / raw x1", Engine::EmbreeSingle, Engine::RawSingle),
            ("embree x8 / raw x8", Engine::EmbreePacket, Engine::RawPacket),
            ("native / raw x1", Engine::Native, Engine::RawSingle),
            ("native / embree x1", Engine::Native, Engine::EmbreeSingle),
        ];
        let wanted = |a: Engine, b: Engine| engines.contains(&a) && engines.contains(&b);
        writeln!(f, "time ratios (wall clock)")?;
        for (name, a, b) in RATIOS.into_iter().filter(|&(_, a, b)| wanted(a, b)) {
            write!(f, "{name:<24}")?;
            ratio(f, a, b, |t| Some(t.mrays_per_s))?;
        }
        if self.throughput.iter().any(|t| t.mrays_per_cpu_s.is_some()) {
            writeln!(f, "Mrays per CPU-second (insensitive to waiting for a core)")?;
            for &engine in &engines {
                write!(f, "{:<24}", engine.name())?;
                for &(kind, threads) in &columns {
                    match self.get(kind, threads, engine).and_then(|t| t.mrays_per_cpu_s) {
                        Some(m) => write!(f, "{m:>14.2}")?,
                        None => write!(f, "{:>14}", "-")?,
                    }
                }
                writeln!(f)?;
            }
            writeln!(f, "time ratios (CPU time)")?;
            for (name, a, b) in RATIOS.into_iter().filter(|&(_, a, b)| wanted(a, b)) {
                write!(f, "{name:<24}")?;
                ratio(f, a, b, |t| t.mrays_per_cpu_s)?;
            }
        }
        write!(f, "{:<24}", "hit %")?;
        for &(kind, threads) in &columns {
            match engines.first().and_then(|&e| self.get(kind, threads, e)) {
                Some(n) => write!(f, "{:>14.1}", 100.0 * n.hits as f64 / n.rays.max(1) as f64)?,
                None => write!(f, "{:>14}", "-")?,
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::{Aabb, Vec3};
    use crate::scene::procedural;

    #[test]
    fn each_engine_takes_each_place_once_over_as_many_runs() {
        let n = Engine::ALL.len();
        let orders: Vec<Vec<usize>> = (0..n).map(|run| engine_order(run, n).collect()).collect();
        assert_eq!(orders[0], (0..n).collect::<Vec<_>>());
        assert_eq!(orders[1], (1..n).chain([0]).collect::<Vec<_>>());
        for place in 0..n {
            let mut at: Vec<usize> = orders.iter().map(|o| o[place]).collect();
            at.sort_unstable();
            assert_eq!(at, (0..n).collect::<Vec<_>>(), "place {place}: {orders:?}");
        }
        // Each run traces every engine once.
        for o in &orders {
            let mut o = o.clone();
            o.sort_unstable();
            assert_eq!(o, (0..n).collect::<Vec<_>>());
        }
    }

    #[test]
    fn a_small_run_measures_every_engine_on_the_same_rays() {
        let b = Aabb::new(Vec3::splat(-1.0), Vec3::ONE);
        let scene = Scene { spheres: procedural::random_spheres(50, b, (0.05, 0.2), 1), ..Default::default() };
        let config = Config {
            rays: 4096,
            kinds: vec![RayKind::Primary, RayKind::Random, RayKind::Shadow],
            threads: vec![1, 2],
            runs: 1,
            ..Config::default()
        };
        let report = run(&scene, &config).unwrap();
        assert_eq!(report.builds.len(), 2);
        assert_eq!(report.throughput.len(), 3 * 2 * Engine::ALL.len());
        for kind in [RayKind::Primary, RayKind::Random, RayKind::Shadow] {
            let hits: Vec<usize> = Engine::ALL.iter().map(|&e| report.get(kind, 2, e).unwrap().hits).collect();
            assert!(hits[0] > 0 && hits.iter().all(|&h| h == hits[0]), "{kind}: {hits:?}");
        }
        assert!(report.throughput.iter().all(|t| t.mrays_per_s > 0.0 && t.rays == 4096));
        assert!(report.throughput.iter().all(|t| t.mrays_per_cpu_s.is_none_or(|m| m > 0.0)));
        let table = report.to_string();
        assert!(table.contains("primary 1t") && table.contains("embree x1 / raw x1"), "{table}");
    }
}

#[cfg(test)]
mod cpu_tests {
    use super::*;

    #[test]
    fn cpu_time_leaves_out_threads_that_ended() {
        let before = HashMap::from([(1, 5_000_000_000), (2, 1_000_000_000), (3, 7_000_000_000)]);
        // Thread 3 ended, thread 4 started.
        let after = HashMap::from([(1, 5_500_000_000), (2, 1_250_000_000), (4, 250_000_000)]);
        assert_eq!(cpu_seconds_between(&before, &after), 1.0);
        if let Some(now) = thread_cpu_times() {
            assert!(now.values().sum::<u64>() > 0);
        }
    }
}
