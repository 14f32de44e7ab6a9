//! `strahl info SCENE`: loads a scene (its warnings on stderr) and prints what it holds, one
//! item per line in a fixed order: each object (name, type, mesh file, primitive count,
//! materials), then the totals (with instances: unique triangles, stored once, and instanced
//! triangles, as rays see them), the bounding box, the degenerate triangles dropped from mesh
//! files, the memory a render would need (at the scene's size and passes, or those of
//! `--width`, `--height`, `--passes`, as `strahl render` takes them), the default
//! `--max-memory` and which limit set it, and the time loading took.

use std::path::PathBuf;
use std::time::Instant;

use clap::Args;
use strahl::integrator::lights::mesh_emitters;
use strahl::scene::{Loaded, ObjectSummary, Scene};

/// Arguments of `strahl info`.
#[derive(Args, Debug)]
pub struct InfoArgs {
    /// The scene file (TOML; see docs/scene-format.md), a glTF file (.gltf, .glb), or a mesh file (OBJ, PLY;
    /// optionally .gz) on its own.
    scene: PathBuf,
    #[command(flatten)]
    confine: super::ConfineArg,
    /// Image width for the memory estimate (as `strahl render --width`).
    #[arg(long, value_name = "W", allow_negative_numbers = true, value_parser = clap::value_parser!(u32).range(1..))]
    width: Option<u32>,
    /// Image height for the memory estimate (as `strahl render --height`).
    #[arg(long, value_name = "H", allow_negative_numbers = true, value_parser = clap::value_parser!(u32).range(1..))]
    height: Option<u32>,
    /// Passes for the memory estimate (as `strahl render --passes`).
    #[arg(long, value_name = "LIST", value_delimiter = ',')]
    passes: Option<Vec<String>>,
}

pub fn run(args: InfoArgs) -> anyhow::Result<()> {
    let start = Instant::now();
    super::set_load_options(&args.confine, None)?;
    let mut loaded = super::load_scene(&args.scene)?;
    let load_seconds = start.elapsed().as_secs_f64();
    // The size and passes a render would be given, for the memory estimate.
    strahl::job::override_image(&args.scene, &mut loaded.scene.image, [args.width, args.height, None, None])?;
    if let Some(passes) = &args.passes {
        loaded.scene.output.passes = strahl::job::parse_passes(passes)?;
    }
    print!("{}", describe(&args.scene.display().to_string(), &loaded, load_seconds));
    Ok(())
}

/// The report, one `key: value` line per item.
fn describe(name: &str, loaded: &Loaded, load_seconds: f64) -> String {
    let Loaded { scene, objects, .. } = loaded;
    let mut lines = vec![format!("scene: {name}")];
    lines.extend(objects.iter().enumerate().map(|(i, o)| object_line(i, o)));
    let bounds = scene.bounds();
    let bounds = if bounds.is_empty() {
        "none (no meshes or spheres; planes are unbounded)".to_string()
    } else {
        format!("min {:.4} max {:.4} (meshes and spheres; planes are unbounded)", bounds.min, bounds.max)
    };
    let dropped: usize = objects.iter().map(|o| o.degenerate_dropped).sum();
    // With instances, the meshes' own triangles are only part of the picture: say so.
    let outside = if scene.instances.is_empty() { "" } else { " outside instances" };
    lines.extend([format!("objects: {}", objects.len()), format!("triangles: {}{outside}", scene.triangle_count())]);
    if !scene.instances.is_empty() {
        // Unique: stored once (meshes and prototypes); instanced: what rays see.
        lines.extend([
            format!(
                "instances: {} of {} prototypes ({} prototype triangles)",
                scene.instances.len(),
                scene.prototypes.len(),
                scene.prototype_triangle_count()
            ),
            format!("unique triangles: {}", scene.triangle_count() + scene.prototype_triangle_count()),
            format!("instanced triangles: {}", scene.triangle_count() + scene.instanced_triangle_count()),
        ]);
    }
    lines.extend([
        format!("spheres: {}", scene.spheres.len()),
        format!("planes: {}", scene.planes.len()),
        lights_line(scene),
        format!("materials: {}", scene.materials.len()),
        format!("bounds: {bounds}"),
        format!("degenerate triangles dropped: {dropped}"),
        format!(
            "memory estimate: {} at {} × {} (strahl render refuses more than --max-memory)",
            strahl::job::memory::estimate(scene, scene.image.width as u64 * scene.image.height as u64),
            scene.image.width,
            scene.image.height
        ),
        match strahl::job::memory::default_limit() {
            Some(limit) => format!("default --max-memory: {limit}"),
            None => "default --max-memory: none (no memory limit could be read)".into(),
        },
        format!("load time: {:.1} ms", load_seconds * 1e3),
    ]);
    lines.iter().map(|l| format!("{l}\n")).collect()
}

/// `lights: 3 (1 with an area, 1 emitting mesh)`: point and directional lights, area lights,
/// and the meshes whose emission lights the scene ([`mesh_emitters`]).
fn lights_line(scene: &Scene) -> String {
    let (area, meshes) = (scene.area_lights.len(), mesh_emitters(scene).len());
    let total = scene.lights.len() + area + meshes;
    let mut parts = Vec::new();
    if area > 0 {
        parts.push(format!("{area} with an area"));
    }
    if meshes > 0 {
        parts.push(format!("{meshes} emitting mesh{}", if meshes == 1 { "" } else { "es" }));
    }
    if parts.is_empty() { format!("lights: {total}") } else { format!("lights: {total} ({})", parts.join(", ")) }
}

/// Most material names listed for one object.
const MATERIALS_LISTED: usize = 8;

/// `object 1 'bunny': mesh ../data/bun.ply, 69451 triangles, material clay`.
fn object_line(index: usize, o: &ObjectSummary) -> String {
    let mut line = format!("object {index}");
    if let Some(name) = &o.name {
        line += &format!(" '{name}'");
    }
    line += &format!(": {}", o.kind);
    if let Some(file) = &o.file {
        line += &format!(" {}", file.display());
    }
    // A sphere or plane object makes exactly one; the others say how many.
    let counts = [(o.triangles, "triangle"), (o.spheres, "sphere"), (o.planes, "plane")];
    let counted = !matches!(o.kind, "sphere" | "plane");
    for (n, what) in counts.into_iter().filter(|&(n, _)| counted && n > 0) {
        line += &format!(", {n} {what}{}", if n == 1 { "" } else { "s" });
    }
    if o.degenerate_dropped > 0 {
        line += &format!(" ({} degenerate dropped)", o.degenerate_dropped);
    }
    let listed = o.materials.iter().take(MATERIALS_LISTED).map(String::as_str).collect::<Vec<_>>().join(", ");
    line += &match o.materials.len() {
        0 => String::new(),
        1 => format!(", material {listed}"),
        n if n <= MATERIALS_LISTED => format!(", materials {listed}"),
        n => format!(", materials {listed}, … ({n} in all)"),
    };
    line
}
