//! Determinism and antialiasing: the same film for any thread count, `spp = 1` is the lecture's
//! pixel-centre ray, `spp = 4` averages four distinct stratified, reproducible samples, and a
//! tile's rays traced in batches give the bits of its rays shaded one by one.

mod common;

use strahl::Accel;
use strahl::camera::Camera;
use strahl::integrator::{self, RayCounts, Whitted};
use strahl::math::Vec3;
use strahl::sampler::{self, SampleDims};
use strahl::scene::procedural::whitted_showcase;

fn pool(threads: usize) -> rayon::ThreadPool {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .start_handler(|_| strahl::accel::embree::enable_flush_to_zero())
        .build()
        .unwrap()
}

#[test]
fn one_and_two_threads_render_bit_identical_films() {
    // 53×37 at 4 spp: partial tiles at the right and bottom edges; mirrors, glass, a mesh,
    // a checkered plane, two lights: every kind of ray.
    let scene = whitted_showcase(53, 37, 4);
    let accel = common::accel(&scene);
    let render = |threads| pool(threads).install(|| integrator::render(&scene, &accel, &|_| {}).unwrap());
    let (one, counts_one) = render(1);
    let (two, counts_two) = render(2);
    assert!(common::same_bits(&one, &two), "1 and 2 threads differ");
    assert_eq!(counts_one, counts_two);
    // And again on the same pool: nothing depends on the order tiles finish in.
    let (again, counts_again) = render(2);
    assert!(common::same_bits(&two, &again) && counts_two == counts_again);
    // The scene really exercises every kind of ray.
    let RayCounts { primary, shadow, reflected, refracted } = counts_one;
    assert_eq!(primary, 53 * 37 * 4);
    assert!(shadow > primary && reflected > 1000 && refracted > 1000, "{counts_one:?}");
}

#[test]
fn the_native_backend_renders_the_same_bytes_on_one_and_two_threads() {
    // The native BVH is built on the render pool: its tree, and so the film, must not depend
    // on the thread count either.
    let scene = whitted_showcase(53, 37, 4);
    let render = |threads| {
        pool(threads).install(|| {
            let bvh = strahl::accel::bvh::Bvh::build(&scene).unwrap();
            integrator::render(&scene, &bvh, &|_| {}).unwrap()
        })
    };
    let ((one, counts_one), (two, counts_two)) = (render(1), render(2));
    assert!(common::same_bits(&one, &two), "1 and 2 threads differ");
    assert_eq!(counts_one, counts_two);
    assert_eq!(counts_one.primary, 53 * 37 * 4);
}

#[test]
fn one_sample_per_pixel_is_exactly_the_pixel_centre_ray() {
    let scene = whitted_showcase(24, 18, 1);
    let accel = common::accel(&scene);
    let (film, counts) = integrator::render(&scene, &accel, &|_| {}).unwrap();
    // The same pixel traced by hand: the centre ray, Embree's single-ray query, the shader.
    let camera = Camera::new(&scene.camera, 24, 18).unwrap();
    let whitted = Whitted::new(&scene, &accel, camera);
    let mut by_hand = RayCounts::default();
    for y in 0..18 {
        for x in 0..24 {
            assert_eq!(sampler::offsets(1, (y * 24 + x) as u64), vec![strahl::Vec2::splat(0.5)]);
            let ray = camera.centre_ray(x, y);
            let hit = accel.intersect(&ray).unwrap();
            let (rgb, first) =
                whitted.shade_primary(&ray, hit.as_ref(), &mut SampleDims::unused(), &mut by_hand).unwrap();
            let i = film.index(x, y);
            // An opaque frame: alpha 1 everywhere, the sky in RGB.
            assert_eq!(film.rgba[i], [rgb.x, rgb.y, rgb.z, 1.0], "pixel ({x}, {y})");
            assert_eq!(film.depth[i], first.map_or(f32::INFINITY, |f| camera.depth_of(f.p)));
            if let Some(f) = first {
                // Depth is along the view axis: the ray's length times its cosine to the axis.
                let along = f.t as f64 * ray.dir.as_dvec3().dot(-camera.basis().2.as_dvec3());
                assert!((film.depth[i] as f64 - along).abs() <= 1e-6 * along, "pixel ({x}, {y})");
            }
            assert_eq!(film.normal[i], first.map_or(Vec3::ZERO, |f| f.normal));
        }
    }
    by_hand.primary = 24 * 18;
    assert_eq!(counts, by_hand);
}

#[test]
fn four_samples_are_four_distinct_stratified_positions_averaged() {
    let (w, h) = (20u32, 14u32);
    // Transparent: rays that escape give 0 and alpha is the coverage.
    let mut scene = whitted_showcase(w, h, 4);
    scene.output.transparent = true;
    let accel = common::accel(&scene);
    let (film, _) = integrator::render(&scene, &accel, &|_| {}).unwrap();
    let camera = Camera::new(&scene.camera, w, h).unwrap();
    let whitted = Whitted::new(&scene, &accel, camera);
    let mut counts = RayCounts::default();
    let mut partial_coverage = 0;
    for y in 0..h {
        for x in 0..w {
            let index = (y * w + x) as u64;
            let offsets = sampler::offsets(4, index);
            // One sample in each quadrant of the pixel (2×2 strata), in order, none at the
            // centre; the same positions every time for this pixel, others elsewhere.
            for (s, o) in offsets.iter().enumerate() {
                let quadrant = ((o.x >= 0.5) as usize, (o.y >= 0.5) as usize);
                assert_eq!(quadrant, (s % 2, s / 2), "pixel ({x}, {y}) sample {s} at {o}");
                assert!(o.x > 0.0 && o.x < 1.0 && o.y > 0.0 && o.y < 1.0 && o.x != 0.5 && o.y != 0.5);
            }
            assert_eq!(offsets, sampler::offsets(4, index));
            assert_ne!(offsets, sampler::offsets(4, index + 1));
            // The pixel is the box filter (mean) of those four rays, summed in sample order.
            let mut sum = Vec3::ZERO;
            let mut hits = 0;
            for o in &offsets {
                let ray = camera.ray(x, y, *o);
                let hit = accel.intersect(&ray).unwrap();
                hits += hit.is_some() as u32;
                sum += whitted.shade_primary(&ray, hit.as_ref(), &mut SampleDims::unused(), &mut counts).unwrap().0;
            }
            let mean = sum / 4.0;
            let i = film.index(x, y);
            assert_eq!(film.rgba[i], [mean.x, mean.y, mean.z, hits as f32 / 4.0], "pixel ({x}, {y})");
            partial_coverage += (hits == 1 || hits == 2 || hits == 3) as u32;
        }
    }
    // The horizon is a plane's: every ray hits something or the sky, and some pixels straddle
    // the horizon, so coverage takes fractional values.
    assert!(partial_coverage > 0);
    // Rendering again gives the same film.
    let (again, _) = integrator::render(&scene, &accel, &|_| {}).unwrap();
    assert!(common::same_bits(&film, &again));
}

#[test]
fn the_cornell_box_renders_as_its_camera_rays_shaded_one_by_one() {
    // Triangles, an area light sampled 4 times, a mirror and a glass sphere, 2 spp. The
    // renderer traces the shadow rays of a tile's camera hits light sample by light sample as
    // one batch (Embree: 8-wide packets); every pixel must still be exactly what shading its
    // camera rays one at a time gives: the same light samples, sums in the same order, the
    // same depth.
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell.toml");
    let mut scene = strahl::scene::load::file::load(&path).unwrap_or_else(|e| panic!("{e}")).scene;
    let (w, h, spp) = (40u32, 30u32, 2u32);
    (scene.image.width, scene.image.height, scene.image.spp) = (w, h, spp);
    assert!(!scene.area_lights.is_empty());
    scene.area_lights[0].samples = 4;
    let accel = common::accel(&scene);
    let (film, counts) = integrator::render(&scene, &accel, &|_| {}).unwrap();
    let camera = Camera::new(&scene.camera, w, h).unwrap();
    let whitted = Whitted::new(&scene, &accel, camera);
    let mut by_hand = RayCounts::default();
    for y in 0..h {
        for x in 0..w {
            let index = (y * w + x) as u64;
            let mut offsets = sampler::PixelSampler::new(spp, index);
            let mut dims = SampleDims::new(spp, index, true, false);
            let (mut sum, mut nearest) = (Vec3::ZERO, None::<strahl::integrator::FirstHit>);
            for s in 0..spp {
                dims.begin(s);
                let ray = camera.ray(x, y, offsets.next_offset());
                let hit = accel.intersect(&ray).unwrap();
                let (rgb, first) = whitted.shade_primary(&ray, hit.as_ref(), &mut dims, &mut by_hand).unwrap();
                sum += rgb;
                if let Some(f) = first.filter(|f| nearest.is_none_or(|n| f.t < n.t)) {
                    nearest = Some(f);
                }
            }
            let mean = sum / spp as f32;
            let i = film.index(x, y);
            assert_eq!(film.rgba[i], [mean.x, mean.y, mean.z, 1.0], "pixel ({x}, {y})");
            let depth = nearest.map_or(f32::INFINITY, |f| camera.depth_of(f.p));
            assert_eq!(film.depth[i].to_bits(), depth.to_bits(), "depth of pixel ({x}, {y})");
        }
    }
    by_hand.primary = (w * h * spp) as u64;
    assert_eq!(counts, by_hand);
    assert!(counts.shadow > 2 * counts.primary && counts.reflected > 0 && counts.refracted > 0, "{counts:?}");
}

/// The path tracer: the same film for 1 and 2 threads, and two regions rendered apart hold
/// the bits of the whole frame's pixels (every random number is a function of the pixel's
/// index, its sample number and the dimension).
#[test]
fn the_path_tracer_renders_the_same_bits_on_any_threads_and_in_any_split() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-path.toml");
    let mut scene = strahl::scene::load(&path).unwrap().scene;
    assert_eq!(scene.render.integrator, strahl::scene::IntegratorKind::Path);
    (scene.image.width, scene.image.height, scene.image.spp) = (37, 29, 4);
    let accel = common::accel(&scene);
    let render = |threads| pool(threads).install(|| integrator::render(&scene, &accel, &|_| {}).unwrap());
    let (one, counts_one) = render(1);
    let (two, counts_two) = render(2);
    assert!(common::same_bits(&one, &two), "1 and 2 threads differ");
    assert_eq!(counts_one, counts_two);
    assert!(counts_one.reflected > counts_one.primary, "paths bounce: {counts_one:?}");
    // Two bands (the second not on a tile boundary) against the whole frame.
    use strahl::output::region::Region;
    for band in [Region { x0: 0, y0: 0, x1: 37, y1: 13 }, Region { x0: 0, y0: 13, x1: 37, y1: 29 }] {
        let (part, _) = pool(2).install(|| integrator::render_region(&scene, &accel, band, &|_| {}).unwrap());
        for y in band.y0..band.y1 {
            for x in 0..37 {
                let (a, b) = (part.rgba[part.index(x, y)], one.rgba[one.index(x, y)]);
                assert_eq!(a.map(f32::to_bits), b.map(f32::to_bits), "pixel {x},{y}");
            }
        }
    }
    // Not a black image: the box is lit, and its ceiling (lit only indirectly) too.
    let mean: f32 = one.rgba.iter().map(|p| p[0]).sum::<f32>() / one.rgba.len() as f32;
    assert!(mean > 0.05, "{mean}");
}

/// `[render] seed`: seed 0 is the render without one (same bits, same fingerprint); another
/// seed renders the same bits on any threads and in any split, and its noise is independent of
/// seed 0's: the mean of two seeds' images has half the squared error of one (against a render
/// of 64 times the samples), where two renders of one seed would keep all of it.
#[test]
fn a_seed_gives_independent_noise_and_seed_0_is_the_render_without_one() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-path.toml");
    let mut scene = strahl::scene::load(&path).unwrap().scene;
    assert_eq!(scene.render.seed, 0);
    (scene.image.width, scene.image.height, scene.image.spp) = (32, 32, 16);
    let accel = common::accel(&scene);
    let render = |scene: &strahl::scene::Scene, threads| {
        pool(threads).install(|| integrator::render(scene, &accel, &|_| {}).unwrap()).0
    };
    let seeded = |seed| {
        let mut s = scene.clone();
        s.render.seed = seed;
        s
    };
    let unseeded = render(&scene, 2);
    assert!(common::same_bits(&unseeded, &render(&seeded(0), 2)), "seed 0 is not the render without a seed");
    let hash = strahl::scene::hash::scene_hash;
    assert_eq!(hash(&seeded(0)), hash(&scene));
    assert_ne!(hash(&seeded(1)), hash(&scene), "a seeded render's checkpoint would resume an unseeded one");
    // Any threads, any split.
    let (one, two) = (render(&seeded(1), 1), render(&seeded(1), 2));
    assert!(common::same_bits(&one, &two), "seed 1: 1 and 2 threads differ");
    use strahl::output::region::Region;
    let band = Region { x0: 0, y0: 11, x1: 32, y1: 32 };
    let (part, _) = pool(2).install(|| integrator::render_region(&seeded(1), &accel, band, &|_| {}).unwrap());
    for y in band.y0..band.y1 {
        for x in 0..32 {
            let (a, b) = (part.rgba[part.index(x, y)], one.rgba[one.index(x, y)]);
            assert_eq!(a.map(f32::to_bits), b.map(f32::to_bits), "seed 1, pixel {x},{y}");
        }
    }
    // Independent noise.
    let mut reference = seeded(7);
    reference.image.spp = 1024;
    let reference = render(&reference, 2);
    let luminance =
        |f: &strahl::output::film::Film| f.rgba.iter().map(|p| (p[0] + p[1] + p[2]) as f64).collect::<Vec<_>>();
    let r = luminance(&reference);
    let mse = |img: &[f64]| img.iter().zip(&r).map(|(a, b)| (a - b).powi(2)).sum::<f64>() / r.len() as f64;
    let mean_of = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| 0.5 * (x + y)).collect::<Vec<_>>();
    let (a, b, c) = (luminance(&unseeded), luminance(&one), luminance(&render(&seeded(2), 2)));
    let differ = a.iter().zip(&b).filter(|(x, y)| x != y).count();
    assert!(differ > a.len() * 9 / 10, "seed 1 changed only {differ} of {} pixels", a.len());
    for (x, y) in [(&a, &b), (&b, &c), (&a, &c)] {
        // Independent: 1/2 (and the reference's own noise, 1/64 of a render's); one seed twice: 1.
        let ratio = mse(&mean_of(x, y)) / (0.5 * (mse(x) + mse(y)));
        eprintln!("squared error of the mean of two seeds over one seed's: {ratio:.3}");
        assert!((0.38..0.64).contains(&ratio), "{ratio}: the seeds' noise is not independent");
    }
    assert!((mse(&mean_of(&a, &a)) / mse(&a) - 1.0).abs() < 1e-12);
}
