//! Geometry strahl makes itself: icospheres, random spheres, random triangle soups, the
//! random rays tests and benchmarks trace through them, a small Whitted scene for
//! renderer tests and benchmarks, and a room lit by a ceiling of many small emitters (the
//! light tree's test and benchmark). Deterministic for a given seed.

use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64Mcg;

use super::{CameraSpec, ImageSpec, IntegratorKind, Mesh, RenderSpec, Scene};
use crate::geometry::{Plane, Sphere};
use crate::light::Light;
use crate::material::{Material, Texture};
use crate::math::{Aabb, Ray, Vec3};

/// A unit icosphere: an icosahedron with each triangle split into four `subdivisions` times
/// (20·4ⁿ triangles), vertices pushed onto the sphere, per-vertex normals equal to positions.
pub fn icosphere(subdivisions: u32) -> Mesh {
    let phi = (1.0 + 5f32.sqrt()) / 2.0;
    let mut positions: Vec<Vec3> = [
        (-1.0, phi, 0.0),
        (1.0, phi, 0.0),
        (-1.0, -phi, 0.0),
        (1.0, -phi, 0.0),
        (0.0, -1.0, phi),
        (0.0, 1.0, phi),
        (0.0, -1.0, -phi),
        (0.0, 1.0, -phi),
        (phi, 0.0, -1.0),
        (phi, 0.0, 1.0),
        (-phi, 0.0, -1.0),
        (-phi, 0.0, 1.0),
    ]
    .iter()
    .map(|&(x, y, z)| Vec3::new(x, y, z).normalize())
    .collect();
    let mut indices: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..subdivisions {
        let mut midpoints = std::collections::HashMap::new();
        let mut midpoint = |a: u32, b: u32, positions: &mut Vec<Vec3>| -> u32 {
            *midpoints.entry((a.min(b), a.max(b))).or_insert_with(|| {
                positions.push((positions[a as usize] + positions[b as usize]).normalize());
                positions.len() as u32 - 1
            })
        };
        let mut next = Vec::with_capacity(indices.len() * 4);
        for [a, b, c] in indices {
            let ab = midpoint(a, b, &mut positions);
            let bc = midpoint(b, c, &mut positions);
            let ca = midpoint(c, a, &mut positions);
            next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        indices = next;
    }
    Mesh {
        name: format!("icosphere{subdivisions}"),
        normals: Some(positions.clone()),
        positions,
        indices,
        ..Default::default()
    }
}

/// A lumpy ball for the shipped scenes: `icosphere(subdivisions)` with each vertex moved along
/// its direction by `0.12 · sin 6x · sin(5y + 0.5) · sin(4z + 1)` (radius 0.88–1.12), with
/// area-weighted smooth normals.
pub fn blob(subdivisions: u32) -> Mesh {
    let mut m = icosphere(subdivisions);
    for p in &mut m.positions {
        let bump = 0.12 * (6.0 * p.x).sin() * (5.0 * p.y + 0.5).sin() * (4.0 * p.z + 1.0).sin();
        *p *= 1.0 + bump;
    }
    m.normals = Some(crate::scene::load::mesh::smooth_normals(&m.positions, &m.indices));
    m.name = format!("blob{subdivisions}");
    m
}

/// The meshes the shipped scenes load from `scenes/meshes/`, as `(file name, mesh, PLY comment)`:
/// the smooth blob with its normals, and a coarse blob without normals (flat facets, or smooth
/// normals when a scene asks for them). `examples/gen_meshes.rs` writes them.
pub fn shipped_meshes() -> Vec<(&'static str, Mesh, &'static str)> {
    let mut coarse = blob(2);
    coarse.normals = None;
    vec![
        ("blob.ply", blob(4), "strahl examples/gen_meshes.rs: procedural::blob(4)"),
        ("blob-coarse.ply", coarse, "strahl examples/gen_meshes.rs: procedural::blob(2) without normals"),
    ]
}

fn uniform_in(rng: &mut Pcg64Mcg, b: &Aabb) -> Vec3 {
    Vec3::new(
        rng.random_range(b.min.x..=b.max.x),
        rng.random_range(b.min.y..=b.max.y),
        rng.random_range(b.min.z..=b.max.z),
    )
}

/// A direction uniformly distributed over the unit sphere.
fn uniform_direction(rng: &mut Pcg64Mcg) -> Vec3 {
    let z: f32 = rng.random_range(-1.0..=1.0);
    let phi: f32 = rng.random_range(0.0..std::f32::consts::TAU);
    let r = (1.0 - z * z).max(0.0).sqrt();
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// `n` spheres with centres uniform in `bounds` and radii uniform in `radii`.
pub fn random_spheres(n: usize, bounds: Aabb, radii: (f32, f32), seed: u64) -> Vec<Sphere> {
    let mut rng = Pcg64Mcg::seed_from_u64(seed);
    (0..n)
        .map(|_| Sphere {
            center: uniform_in(&mut rng, &bounds),
            radius: rng.random_range(radii.0..=radii.1),
            material: 0,
        })
        .collect()
}

/// `n` random triangles: each a random centre in `bounds` with three corners within `size` of
/// it (overlapping, intersecting: a hard case for any BVH).
pub fn random_triangles(n: usize, bounds: Aabb, size: f32, seed: u64) -> Mesh {
    let mut rng = Pcg64Mcg::seed_from_u64(seed);
    let mut positions = Vec::with_capacity(3 * n);
    for _ in 0..n {
        let c = uniform_in(&mut rng, &bounds);
        for _ in 0..3 {
            positions.push(c + size * uniform_direction(&mut rng));
        }
    }
    let indices = (0..n as u32).map(|i| [3 * i, 3 * i + 1, 3 * i + 2]).collect();
    Mesh { name: format!("random{n}"), positions, indices, ..Default::default() }
}

/// `n` rays from points uniform in `bounds` scaled by 1.5 about its centre, in uniformly
/// random directions (the "random" rays of the benchmarks).
pub fn random_rays(n: usize, bounds: Aabb, seed: u64) -> Vec<Ray> {
    let mut rng = Pcg64Mcg::seed_from_u64(seed);
    let c = bounds.centroid();
    let grown = Aabb::new(c + 1.5 * (bounds.min - c), c + 1.5 * (bounds.max - c));
    (0..n).map(|_| Ray::new(uniform_in(&mut rng, &grown), uniform_direction(&mut rng))).collect()
}

/// Whitted's 1980 picture, more or less, at `width × height` pixels and `spp` samples: a
/// red-and-yellow checkered floor, a mirror ball, a glass ball (ior 1.5), a glossy icosphere
/// mesh with vertex normals, and three small diffuse balls, under a point light and a
/// directional light, against a blue background. Every kind of ray the integrator traces
/// occurs in it. It is rendered by the Whitted integrator.
pub fn whitted_showcase(width: u32, height: u32, spp: u32) -> Scene {
    let materials = vec![
        Material {
            name: "floor".into(),
            diffuse: Texture::Checker { even: Vec3::new(0.8, 0.1, 0.1), odd: Vec3::new(0.8, 0.8, 0.1), size: 1.0 },
            ..Default::default()
        },
        Material {
            name: "mirror".into(),
            diffuse: Texture::Constant(Vec3::splat(0.05)),
            mirror: Vec3::splat(0.9),
            ..Default::default()
        },
        Material::clear_glass("glass", 1.5),
        Material {
            name: "glossy".into(),
            diffuse: Texture::Constant(Vec3::new(0.1, 0.3, 0.6)),
            specular: Vec3::splat(0.3),
            shininess: 40.0,
            ..Default::default()
        },
        Material::matte("green", Vec3::new(0.2, 0.7, 0.2)),
        Material::matte("white", Vec3::splat(0.75)),
    ];
    let mut ball = icosphere(3);
    ball.name = "glossy icosphere".into();
    ball.material = 3;
    for p in &mut ball.positions {
        *p = 0.8 * *p + Vec3::new(-1.6, 0.8, -0.6);
    }
    let spheres = vec![
        Sphere { center: Vec3::new(0.0, 1.0, -1.5), radius: 1.0, material: 1 },
        Sphere { center: Vec3::new(1.3, 0.9, 0.8), radius: 0.9, material: 2 },
        Sphere { center: Vec3::new(2.6, 0.4, -1.2), radius: 0.4, material: 4 },
        Sphere { center: Vec3::new(-0.4, 0.3, 1.4), radius: 0.3, material: 5 },
        Sphere { center: Vec3::new(-2.8, 0.5, 0.9), radius: 0.5, material: 4 },
    ];
    Scene {
        camera: CameraSpec {
            eye: Vec3::new(0.5, 2.2, 6.5),
            target: Vec3::new(0.0, 0.7, 0.0),
            up: Vec3::Y,
            fov_deg: 45.0,
            lens: Default::default(),
        },
        image: ImageSpec {
            width,
            height,
            spp,
            max_depth: 8,
            background: Vec3::new(0.35, 0.55, 0.9),
            ambient: Vec3::splat(0.05),
            mesh_lights: true,
            mesh_light_samples: 1,
        },
        materials,
        lights: vec![
            Light::Point { position: Vec3::new(-3.0, 6.0, 4.0), intensity: Vec3::splat(60.0) },
            Light::Directional { direction: Vec3::new(1.0, -2.0, -1.0), irradiance: Vec3::new(1.0, 0.95, 0.8) },
        ],
        meshes: vec![ball],
        spheres,
        planes: vec![Plane::through(Vec3::ZERO, Vec3::Y, 0)],
        render: RenderSpec { integrator: IntegratorKind::Whitted, ..Default::default() },
        ..Default::default()
    }
}

/// The emitting materials of [`light_panel_room`]: colours × strengths.
const PANEL_COLOURS: [[f32; 3]; 4] = [[1.0, 0.85, 0.6], [0.6, 0.8, 1.0], [1.0, 0.4, 0.3], [0.5, 1.0, 0.5]];
const PANEL_STRENGTHS: [f32; 4] = [1.0, 4.0, 16.0, 64.0];

/// A room of `side × side` m lit by its ceiling: an `n × n` grid of small emissive quads (two
/// triangles each, so `2n²` emitting triangles) 2.5 m above a grey floor, each quad 40 % of
/// its cell's width, its radiance one of 4 colours × 4 strengths (1 to 64 W/(m²·sr)) drawn
/// at random, over eight grey icosahedra that cast shadows; seen by the path tracer looking
/// down at the floor (no emitter in view) at `width × height`, `spp` samples, depth `max_depth`. With `n = 100` it is
/// the 20,000-emitter scene of docs/performance.md ("Many lights").
pub fn light_panel_room(n: u32, side: f32, width: u32, height: u32, spp: u32, max_depth: u32) -> Scene {
    let mut rng = Pcg64Mcg::seed_from_u64(29);
    let mut materials = vec![Material::matte("floor", Vec3::splat(0.5)), Material::matte("box", Vec3::splat(0.7))];
    for c in PANEL_COLOURS {
        for k in PANEL_STRENGTHS {
            materials.push(Material {
                name: format!("panel {c:?} × {k}"),
                diffuse: Texture::Constant(Vec3::ZERO),
                emission: Vec3::from(c) * k,
                ..Default::default()
            });
        }
    }
    let half = side / 2.0;
    let (cell, height_m) = (side / n as f32, 2.5);
    let mut panel = Mesh { name: "ceiling panels".into(), ..Default::default() };
    let mut per_triangle = Vec::new();
    for i in 0..n {
        for j in 0..n {
            let c = Vec3::new(-half + (i as f32 + 0.5) * cell, height_m, -half + (j as f32 + 0.5) * cell);
            let h = 0.2 * cell;
            let base = panel.positions.len() as u32;
            // Facing down: (b − a) × (c − a) = −y.
            panel.positions.extend([
                c + Vec3::new(-h, 0.0, -h),
                c + Vec3::new(h, 0.0, -h),
                c + Vec3::new(h, 0.0, h),
                c + Vec3::new(-h, 0.0, h),
            ]);
            panel.indices.extend([[base, base + 2, base + 1], [base, base + 3, base + 2]]);
            let m = 2 + rng.random_range(0..(PANEL_COLOURS.len() * PANEL_STRENGTHS.len()) as u32);
            per_triangle.extend([m, m]);
        }
    }
    panel.triangle_materials = Some(per_triangle);
    let quad = |name: &str, corners: [Vec3; 4], material: u32| Mesh {
        name: name.into(),
        positions: corners.to_vec(),
        indices: vec![[0, 1, 2], [0, 2, 3]],
        material,
        ..Default::default()
    };
    let floor = quad(
        "floor",
        [
            Vec3::new(-half, 0.0, -half),
            Vec3::new(-half, 0.0, half),
            Vec3::new(half, 0.0, half),
            Vec3::new(half, 0.0, -half),
        ],
        0,
    );
    let mut meshes = vec![panel, floor];
    for k in 0..8 {
        let a = k as f32 / 8.0 * std::f32::consts::TAU;
        let c = Vec3::new(0.3 * side * a.cos(), 0.0, 0.3 * side * a.sin());
        let s = 0.04 * side;
        let mut b = icosphere(0);
        b.name = format!("icosahedron {k}");
        b.material = 1;
        for p in &mut b.positions {
            *p = c + Vec3::new(s * p.x, s * (p.y + 1.0) * 1.5, s * p.z);
        }
        meshes.push(b);
    }
    Scene {
        camera: CameraSpec {
            eye: Vec3::new(-0.2 * side, 2.0, 0.2 * side),
            target: Vec3::new(-0.12 * side, 0.0, 0.12 * side),
            up: Vec3::Y,
            fov_deg: 40.0,
            lens: Default::default(),
        },
        image: ImageSpec {
            width,
            height,
            spp,
            max_depth,
            background: Vec3::ZERO,
            ambient: Vec3::ZERO,
            mesh_lights: true,
            mesh_light_samples: 1,
        },
        materials,
        meshes,
        render: RenderSpec { integrator: IntegratorKind::Path, ..Default::default() },
        ..Default::default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn icosphere_counts_and_radius() {
        for k in 0..4 {
            let m = icosphere(k);
            assert_eq!(m.indices.len(), 20 * 4usize.pow(k));
            // Euler: V − E + F = 2 with E = 3F/2.
            assert_eq!(m.positions.len(), 2 + m.indices.len() / 2);
            assert!(m.positions.iter().all(|p| (p.length() - 1.0).abs() < 1e-6));
            assert_eq!(m.problem(), None);
        }
    }

    #[test]
    fn icosphere_faces_point_outward() {
        let m = icosphere(2);
        for i in 0..m.indices.len() {
            let [a, b, c] = m.triangle(i);
            assert!((b - a).cross(c - a).dot(a + b + c) > 0.0, "triangle {i} faces inward");
        }
    }

    #[test]
    fn generators_are_deterministic() {
        let b = Aabb::new(Vec3::splat(-1.0), Vec3::ONE);
        assert_eq!(random_spheres(10, b, (0.1, 0.2), 7), random_spheres(10, b, (0.1, 0.2), 7));
        assert_ne!(random_spheres(10, b, (0.1, 0.2), 7), random_spheres(10, b, (0.1, 0.2), 8));
        assert_eq!(random_rays(5, b, 1), random_rays(5, b, 1));
        let d = random_rays(1000, b, 1);
        assert!(d.iter().all(|r| (r.dir.length() - 1.0).abs() < 1e-5));
    }
}
