//! `strahl crosscheck SCENE [--rays N] [--kind primary|random|secondary|all] [--threads T]
//! [--seed S]`: traces the same rays through Embree and the native BVH
//! ([`strahl::verify::crosscheck::run`]) and prints, per kind of ray, how often they agree and how any
//! disagreement is explained; then fails (exit status 1, one `error:` line) if any is not.
//! SCENE is a scene file, or a mesh file on its own.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Context, bail};
use clap::Args;
use strahl::accel::bvh::Bvh;
use strahl::accel::embree::{BuildOptions, EmbreeAccel};
use strahl::verify::crosscheck::{self, Disagreement, Report};
use strahl::verify::workload::{self, RayKind};

use super::CrosscheckKind;

/// Unexplained disagreements printed per kind, for diagnosis.
const EXAMPLES: usize = 5;

/// Arguments of `strahl crosscheck`.
#[derive(Args, Debug)]
pub struct CrosscheckArgs {
    /// The scene file (TOML), a glTF file (.gltf, .glb), or a mesh file (OBJ, PLY; optionally .gz) on its own.
    scene: PathBuf,
    #[command(flatten)]
    confine: super::ConfineArg,
    /// Rays of each kind (primary rays: the nearest square image, 1000 × 1000 for a million).
    #[arg(long, value_name = "N", default_value_t = workload::DEFAULT_RAYS as u64, value_parser = clap::value_parser!(u64).range(1..=super::MAX_RAYS))]
    rays: u64,
    /// Which rays: primary (the scene's camera; a lone mesh file's frames it), random
    /// (uniform origins and directions), secondary (mirror reflections at the primary hits),
    /// or all three. A kind of which no ray hits anything in either backend fails the check.
    #[arg(long, value_enum, default_value_t = CrosscheckKind::All)]
    kind: CrosscheckKind,
    /// Worker threads for tracing and for both BVH builds [default: one per core].
    #[arg(long, value_name = "T", value_parser = clap::value_parser!(u32).range(1..=4096))]
    threads: Option<u32>,
    /// Seed of the random rays.
    #[arg(long, value_name = "S", default_value_t = 1)]
    seed: u64,
}

pub fn run(args: CrosscheckArgs) -> anyhow::Result<()> {
    super::set_load_options(&args.confine, None)?;
    let scene = super::load_scene(&args.scene)?.scene;
    super::check_bounded(&args.scene, &scene)?;
    let threads = strahl::job::thread_count(args.threads.map(|t| t as usize));
    let pool = strahl::job::thread_pool(threads)?;
    let device = strahl::job::embree_device(threads)?;
    let shown = args.scene.display();

    let start = Instant::now();
    let embree = EmbreeAccel::build(&device, &scene, BuildOptions::default())
        .with_context(|| format!("{shown}: cannot build Embree's BVH"))?;
    let embree_ms = 1e3 * start.elapsed().as_secs_f64();
    let start = Instant::now();
    let native =
        pool.install(|| Bvh::build(&scene)).with_context(|| format!("{shown}: cannot build the native BVH"))?;
    let native_ms = 1e3 * start.elapsed().as_secs_f64();

    println!(
        "{shown}: {}; BVH built in {embree_ms:.1} ms (embree), {native_ms:.1} ms (native); {threads} thread{}, seed {}",
        strahl::verify::geometry_line(&scene),
        if threads == 1 { "" } else { "s" },
        args.seed
    );
    println!("tolerance: {}", crosscheck::tolerance());
    let mut reports = Vec::new();
    for kind in args.kind.kinds() {
        let report = pool
            .install(|| crosscheck::run(&scene, &embree, &native, kind, args.rays as usize, args.seed))
            .with_context(|| format!("{shown}: tracing {kind} rays failed"))?;
        println!("\n{kind} rays: {}", describe(&report));
        reports.push((kind, report));
    }
    verdict(&reports)
}

/// The report, followed by the first unexplained disagreements, if any.
fn describe(report: &Report) -> String {
    let mut text = report.to_string();
    for d in report.unexplained_examples.iter().take(EXAMPLES) {
        text += &format!("\n    {}", example(report, d));
    }
    text
}

/// `ray 12: org (…) dir (…): embree t 1.5 (geom 0, prim 3), native miss; 3.1e5 ε·M from an edge`.
fn example(report: &Report, d: &Disagreement) -> String {
    let hit = |h: &Option<strahl::Hit>| match h {
        Some(h) => format!("t {} (geom {}, prim {})", h.t, h.geom_id, h.prim_id),
        None => "miss".into(),
    };
    format!(
        "ray {}: org {} dir {}: {} {}, {} {}; {:.3e} ε·M from an edge",
        d.index,
        d.ray.org,
        d.ray.dir,
        report.a,
        hit(&d.a),
        report.b,
        hit(&d.b),
        d.margin
    )
}

/// Fails when any disagreement is unexplained, saying how many and of which kinds, or when a
/// kind compared nothing (no ray hit anything in either backend).
fn verdict(reports: &[(RayKind, Report)]) -> anyhow::Result<()> {
    let vacuous: Vec<String> = reports
        .iter()
        .filter(|(_, r)| r.both_hit + r.hit_miss() == 0)
        .map(|(kind, r)| format!("{kind} ({} rays)", r.rays))
        .collect();
    if !vacuous.is_empty() {
        bail!(
            "no ray hit anything in either backend, so nothing was compared: {} (does the scene's camera see \
             the geometry?)",
            vacuous.join(", ")
        );
    }
    let bad: Vec<String> = reports
        .iter()
        .filter(|(_, r)| r.unexplained > 0)
        .map(|(kind, r)| format!("{} of {} {kind} rays", r.unexplained, r.rays))
        .collect();
    if !bad.is_empty() {
        let total: usize = reports.iter().map(|(_, r)| r.unexplained).sum();
        bail!("{total} unexplained disagreement{} between the backends: {}", plural(total), bad.join(", "));
    }
    Ok(())
}

fn plural(n: usize) -> &'static str {
    if n == 1 { "" } else { "s" }
}

#[cfg(test)]
mod tests {
    use strahl::accel::embree::Device;
    use strahl::math::Vec3;
    use strahl::scene::{Mesh, Scene};

    use super::*;

    /// A unit square of two triangles parallel to z = 0, its corner at `corner`.
    fn square(corner: Vec3) -> Scene {
        let positions = [Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::new(1.0, 1.0, 0.0)].map(|p| p + corner).to_vec();
        let mesh = Mesh { name: "square".into(), positions, indices: vec![[0, 1, 2], [3, 2, 1]], ..Default::default() };
        Scene { meshes: vec![mesh], ..Default::default() }
    }

    /// Two backends that really disagree (the native BVH is built over the square moved by a
    /// fifth of its size, so some rays hit only one of them, and some hit the other triangle
    /// at another `t`) give unexplained disagreements, and the command's verdict fails and
    /// says how many.
    #[test]
    fn unexplained_disagreements_fail_the_command() {
        let (seen, built) = (square(Vec3::ZERO), square(Vec3::new(0.2, 0.1, 0.3)));
        let embree = EmbreeAccel::build(&Device::new().unwrap(), &seen, BuildOptions::default()).unwrap();
        let native = Bvh::build(&built).unwrap();
        let rays = workload::primary(&seen, 4096).unwrap();
        let report = crosscheck::compare(&seen, &embree, &native, &rays).unwrap();
        assert!(report.unexplained > 100, "{report}");
        assert!(report.other_prim_unexplained() > 0 && report.hit_miss_unexplained > 0, "{report}");
        let text = describe(&report);
        assert!(text.contains(&format!("unexplained         {:>10}", report.unexplained)), "{text}");
        assert_eq!(text.matches("ε·M from an edge").count(), EXAMPLES + 1, "{text}");
        let error = verdict(&[(RayKind::Random, report.clone())]).unwrap_err();
        assert_eq!(
            error.to_string(),
            format!(
                "{} unexplained disagreements between the backends: {} of 4096 random rays",
                report.unexplained, report.unexplained
            )
        );
        // The same backends over the same square agree.
        let native = Bvh::build(&seen).unwrap();
        let report = crosscheck::compare(&seen, &embree, &native, &rays).unwrap();
        assert_eq!(report.unexplained, 0, "{report}");
        verdict(&[(RayKind::Primary, report)]).unwrap();
        // Rays that all miss in both backends compared nothing: a failure, not a pass.
        let vacuous = Report { rays: 10, both_miss: 10, ..Report::default() };
        let error = verdict(&[(RayKind::Secondary, vacuous)]).unwrap_err().to_string();
        assert!(
            error.starts_with("no ray hit anything in either backend, so nothing was compared: secondary (10 rays)")
        );
    }
}
