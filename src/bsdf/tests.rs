//! The BSDFs' statistical and physical checks: χ² tests of every lobe's sampling, sampling
//! consistent with `eval`/`pdf`, reciprocity, white furnaces, energy bounds, the lecture lobes
//! against `crate::optics`, and glTF's Appendix B against an independent evaluation.

use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64Mcg;

use super::*;
use crate::optics;
use crate::sampling::chi2::{Chi2Result, Chi2Test, sidak};

/// Every χ² test of this module, for the Šidák correction.
const CHI2_TESTS: usize = 66;
const ALPHA: f64 = 0.01;

fn up() -> Frame {
    Frame::from_normal(Vec3::Z)
}

/// The unit direction at `cos θ = mu` in the `xz` plane.
fn dir(mu: f32) -> Vec3 {
    Vec3::new((1.0 - mu * mu).max(0.0).sqrt(), 0.0, mu)
}

fn glass_params(roughness: f32) -> PbrParams {
    PbrParams { metallic: 0.0, transmission: 1.0, roughness, ..Default::default() }
}

/// A glTF BSDF seen from outside (`front_face`) or from inside, with the facing normal up.
fn gltf_up(p: &PbrParams, front_face: bool) -> Bsdf {
    built(up(), Vec3::Z, front_face, |b| gltf(b, p, Vec3::Z))
}

/// The BSDF in `frame` with geometric normal `ng` that `add` fills.
fn built(frame: Frame, ng: Vec3, front_face: bool, add: impl FnOnce(&mut Bsdf)) -> Bsdf {
    let mut b = Bsdf::new(frame, ng, front_face);
    add(&mut b);
    b
}

fn chi2(b: &Bsdf, wo: Vec3) -> Chi2Result {
    let r = Chi2Test::default()
        .run(|ul, u| b.sample(wo, ul, u).filter(|s| !s.flags.is_specular()).map(|s| s.wi), |w| b.pdf(wo, w) as f64);
    assert!(r.pdf_sum <= 1.0 + 2e-3, "the density integrates to {} > 1", r.pdf_sum);
    r
}

fn assert_chi2(what: &str, b: &Bsdf, wo: Vec3) {
    let r = chi2(b, wo);
    println!("χ² {what}, cos θo = {:.2}: {r}", wo.z);
    assert!(r.passes(sidak(ALPHA, CHI2_TESTS)), "{what}, wo = {wo}: {r}");
}

/// One lobe alone in a BSDF.
fn single(lobe: Lobe) -> Bsdf {
    let mut b = Bsdf::new(up(), Vec3::Z, true);
    b.push(lobe);
    b
}

#[test]
fn chi2_lecture_lobes() {
    let lambert = single(Lobe::Lambert(lambert::Lambert { color: Vec3::splat(0.8) }));
    assert_chi2("Lambert", &lambert, dir(0.6));
    for n in [1.0, 20.0, 300.0] {
        let bp = single(Lobe::BlinnPhong(blinn_phong::BlinnPhong { ks: Vec3::ONE, exponent: n }));
        for mu in [0.95, 0.4] {
            assert_chi2(&format!("Blinn–Phong n = {n}"), &bp, dir(mu));
        }
    }
    // The mixture, with a mirror and glass taking part of the samples.
    let p = LectureParams {
        albedo: Vec3::new(0.3, 0.2, 0.1),
        specular: Vec3::splat(0.3),
        shininess: 40.0,
        mirror: Vec3::splat(0.1),
        transmission: Vec3::splat(0.2),
        ior: 1.5,
    };
    assert_chi2("lecture mixture", &built(up(), Vec3::Z, true, |b| lecture(b, &p)), dir(0.7));
}

#[test]
fn chi2_conductor_and_dielectric() {
    for r in [0.1, 0.3, 0.6, 1.0] {
        let conductor =
            gltf_up(&PbrParams { base_color: Vec3::new(0.9, 0.6, 0.3), roughness: r, ..Default::default() }, true);
        let dielectric = gltf_up(
            &PbrParams { base_color: Vec3::new(0.2, 0.5, 0.8), metallic: 0.0, roughness: r, ..Default::default() },
            true,
        );
        for mu in [0.9, 0.4, 0.1] {
            assert_chi2(&format!("conductor r = {r}"), &conductor, dir(mu));
            assert_chi2(&format!("dielectric r = {r}"), &dielectric, dir(mu));
        }
    }
}

#[test]
fn chi2_glass_both_sides() {
    for r in [0.1, 0.3, 0.6, 1.0] {
        for front in [true, false] {
            let g = gltf_up(&glass_params(r), front);
            for mu in [0.8, 0.3] {
                assert_chi2(&format!("glass r = {r} from {}", if front { "outside" } else { "inside" }), &g, dir(mu));
            }
        }
    }
}

#[test]
fn chi2_sheen_and_clearcoat() {
    let sheen = single(Lobe::Sheen(sheen::Sheen::new(Vec3::ONE, 0.5)));
    assert_chi2("sheen", &sheen, dir(0.5));
    let layered = PbrParams {
        base_color: Vec3::new(0.6, 0.1, 0.1),
        metallic: 0.0,
        roughness: 0.7,
        clearcoat: 1.0,
        clearcoat_roughness: 0.15,
        sheen_color: Vec3::new(0.3, 0.3, 0.5),
        sheen_roughness: 0.4,
        ..Default::default()
    };
    for mu in [0.9, 0.3] {
        assert_chi2("coated sheen dielectric", &gltf_up(&layered, true), dir(mu));
    }
}

/// Random unit vectors on the upper (`sign` > 0) or lower hemisphere.
fn random_dir(rng: &mut Pcg64Mcg, sign: f32) -> Vec3 {
    let w = crate::sampling::square_to_uniform_hemisphere(Vec2::new(rng.random(), rng.random()));
    Vec3::new(w.x, w.y, sign * w.z.max(1e-3)).normalize()
}

fn materials() -> Vec<(String, PbrParams)> {
    let mut v = vec![];
    for r in [0.0, 0.05, 0.3, 1.0] {
        v.push((
            format!("conductor r = {r}"),
            PbrParams { base_color: Vec3::new(0.9, 0.6, 0.3), roughness: r, ..Default::default() },
        ));
        v.push((
            format!("dielectric r = {r}"),
            PbrParams { base_color: Vec3::new(0.2, 0.5, 0.8), metallic: 0.0, roughness: r, ..Default::default() },
        ));
        v.push((format!("glass r = {r}"), glass_params(r)));
        v.push((
            format!("everything r = {r}"),
            PbrParams {
                base_color: Vec3::new(0.7, 0.4, 0.2),
                metallic: 0.3,
                roughness: r,
                transmission: 0.4,
                specular: 0.8,
                specular_color: Vec3::new(1.0, 0.8, 0.6),
                clearcoat: 0.6,
                clearcoat_roughness: 0.2,
                sheen_color: Vec3::new(0.2, 0.3, 0.1),
                sheen_roughness: 0.5,
                ior: 1.7,
            },
        ));
    }
    v
}

#[test]
fn samples_agree_with_eval_and_pdf() {
    let mut rng = Pcg64Mcg::seed_from_u64(3);
    let mut checked = 0;
    for (name, p) in materials() {
        for front in [true, false] {
            let b = gltf_up(&p, front);
            for _ in 0..2000 {
                let wo = random_dir(&mut rng, 1.0);
                let Some(s) = b.sample(wo, rng.random(), Vec2::new(rng.random(), rng.random())) else { continue };
                assert!(s.f.is_finite() && s.pdf.is_finite() && s.pdf > 0.0, "{name}: {s:?}");
                if s.flags.is_specular() {
                    continue;
                }
                let (f, pdf) = (b.eval(wo, s.wi).sum(), b.pdf(wo, s.wi));
                assert!((s.f - f).abs().max_element() <= 1e-4 * f.max_element().max(1e-3), "{name}: f {} vs {f}", s.f);
                assert!((s.pdf - pdf).abs() <= 1e-4 * pdf, "{name}: pdf {} vs {pdf}", s.pdf);
                checked += 1;
            }
        }
    }
    assert!(checked > 10_000, "{checked}");
}

/// `Bsdf::sample` of a lone lobe (its own short path) is bit for bit the sample of the same
/// lobe beside a black Lambertian one (the mixture's path, which then chooses the lobe with
/// probability `a / a = 1`): every lobe kind of the lecture and glTF materials, in shading
/// frames tilted against the geometric normal (so that the checks of the pair's sides
/// matter), from both faces, for random `wo` and sample numbers.
#[test]
fn a_lone_lobe_samples_as_the_mixture_does() {
    let mut rng = Pcg64Mcg::seed_from_u64(11);
    let mut lobes = vec![
        Lobe::Lambert(lambert::Lambert { color: Vec3::new(0.8, 0.5, 0.2) }),
        Lobe::BlinnPhong(blinn_phong::BlinnPhong { ks: Vec3::splat(0.7), exponent: 40.0 }),
        Lobe::Mirror(specular::Mirror { kr: Vec3::splat(0.9) }),
        Lobe::SmoothDielectric(specular::SmoothDielectric { kt: Vec3::ONE, eta_i: 1.0, eta_t: 1.5 }),
    ];
    for (_, p) in materials() {
        let b = gltf_up(&p, true);
        if let [lobe] = b.lobes() {
            lobes.push(*lobe);
        }
    }
    let kinds: std::collections::BTreeSet<_> =
        lobes.iter().map(std::mem::discriminant).map(|d| format!("{d:?}")).collect();
    assert!(kinds.len() >= 6, "only {} kinds of lone lobe: {kinds:?}", kinds.len());
    let (mut compared, mut sampled) = (0, 0);
    for lobe in &lobes {
        for _ in 0..400 {
            let ng = random_dir(&mut rng, 1.0);
            let n = (ng + 0.4 * random_dir(&mut rng, 1.0)).normalize();
            let front = rng.random::<bool>();
            let lone = built(Frame::from_normal(n), ng, front, |b| {
                b.push(*lobe);
            });
            let mixture = built(Frame::from_normal(n), ng, front, |b| {
                b.push(*lobe);
                b.push(Lobe::Lambert(lambert::Lambert { color: Vec3::ZERO }));
            });
            let wo = (ng + 0.9 * random_dir(&mut rng, 1.0)).normalize();
            let (ul, u) = (rng.random(), Vec2::new(rng.random(), rng.random()));
            let (a, b) = (lone.sample(wo, ul, u), mixture.sample(wo, ul, u));
            assert_eq!(a, b, "{lobe:?}, wo {wo}, n {n}, ng {ng}");
            compared += 1;
            sampled += usize::from(a.is_some());
        }
    }
    assert!(sampled > compared / 2, "{sampled} of {compared} samples");
}

#[test]
fn reflection_is_reciprocal_and_transmission_obeys_eta_squared() {
    let mut rng = Pcg64Mcg::seed_from_u64(5);
    for (name, p) in materials() {
        let (outside, inside) =
            (gltf_up(&p, true), built(Frame::from_normal(-Vec3::Z), -Vec3::Z, false, |b| gltf(b, &p, -Vec3::Z)));
        let ior = p.ior;
        for _ in 0..500 {
            let (a, b) = (random_dir(&mut rng, 1.0), random_dir(&mut rng, 1.0));
            let (f, g) = (outside.eval(a, b).sum(), outside.eval(b, a).sum());
            assert!((f - g).abs().max_element() <= 1e-4 * f.max_element().max(1e-4), "{name}: {f} vs {g}");
            // Inside: reflection between two downward directions, and transmission.
            let (c, d) = (-a, -b);
            let (f, g) = (inside.eval(c, d).sum(), inside.eval(d, c).sum());
            assert!((f - g).abs().max_element() <= 1e-4 * f.max_element().max(1e-4), "{name} inside: {f} vs {g}");
            // f(o, i)/η_o² = f(i, o)/η_i²: from outside η_o = 1, η_i = ior.
            let (t_out, t_in) = (outside.eval(a, d).sum(), inside.eval(d, a).sum());
            assert!(
                (t_out * ior * ior - t_in).abs().max_element() <= 2e-4 * t_in.max_element().max(1e-4),
                "{name}: {t_out} · η² vs {t_in}"
            );
        }
    }
    // The lecture lobes too.
    let p = LectureParams {
        albedo: Vec3::splat(0.5),
        specular: Vec3::splat(0.4),
        shininess: 30.0,
        mirror: Vec3::ZERO,
        transmission: Vec3::ZERO,
        ior: 1.5,
    };
    let b = built(up(), Vec3::Z, true, |b| lecture(b, &p));
    for _ in 0..500 {
        let (a, c) = (random_dir(&mut rng, 1.0), random_dir(&mut rng, 1.0));
        assert!((b.eval(a, c).sum() - b.eval(c, a).sum()).abs().max_element() < 1e-5);
    }
}

/// `∫ f |cos θi| dωi` from `wo`, transmission in energy units (× η_i²/η_o²), by `n` samples of
/// the BSDF's own sampling (stratified in `u_lobe`), with its standard error.
fn furnace_of(b: &Bsdf, wo: Vec3, n: usize, mut f: impl FnMut(&BsdfSample) -> Vec3) -> (f64, f64) {
    let mut rng = Pcg64Mcg::seed_from_u64(11);
    let (mut sum, mut sum2) = (0.0, 0.0);
    for i in 0..n {
        let ul = (i as f32 + rng.random::<f32>()) / n as f32;
        let w = b.sample(wo, ul, Vec2::new(rng.random(), rng.random())).map_or(0.0, |s| {
            let energy = if s.is_transmission() { s.eta * s.eta } else { 1.0 };
            (f(&s) * s.wi.dot(b.frame().n).abs() / s.pdf * energy).element_sum() as f64 / 3.0
        });
        sum += w;
        sum2 += w * w;
    }
    let mean = sum / n as f64;
    (mean, ((sum2 / n as f64 - mean * mean).max(0.0) / n as f64).sqrt())
}

fn furnace(b: &Bsdf, wo: Vec3) -> (f64, f64) {
    furnace_of(b, wo, 1 << 19, |s| s.f)
}

#[test]
fn white_furnace() {
    let roughness = [0.05f32, 0.1, 0.25, 0.5, 0.75, 1.0];
    let mus = [1.0f32, 0.7, 0.4, 0.15];
    let white = |metallic: f32, transmission: f32, r: f32| PbrParams {
        base_color: Vec3::ONE,
        metallic,
        transmission,
        roughness: r,
        ..Default::default()
    };
    let cases: [(&str, f32, f32, bool); 4] = [
        ("white conductor", 1.0, 0.0, true),
        ("white dielectric", 0.0, 0.0, true),
        ("clear glass, from outside", 0.0, 1.0, true),
        ("clear glass, from inside", 0.0, 1.0, false),
    ];
    let mut worst: f64 = 0.0;
    for (name, m, t, front) in cases {
        println!("\n{name}: ∫ f |cos θi| dωi, compensated (single scattering) [± standard error]");
        print!("{:>9}", "r \\ μo");
        for mu in mus {
            print!("{:>26}", mu);
        }
        println!();
        for r in roughness {
            print!("{r:>9}");
            let p = white(m, t, r);
            let (b, ss) = (gltf_up(&p, front), built(up(), Vec3::Z, front, |b| gltf::build(b, &p, Vec3::Z, false)));
            for mu in mus {
                let (e, se) = furnace(&b, dir(mu));
                let (e_ss, _) = furnace(&ss, dir(mu));
                print!("{:>26}", format!("{e:.4} ({e_ss:.4}) ±{se:.4}"));
                worst = worst.max((e - 1.0).abs());
                assert!((e - 1.0).abs() < 0.01, "{name}, r = {r}, μo = {mu}: {e} ± {se}");
            }
            println!();
        }
    }
    // The specification's own BRDF (Appendix B as written), white dielectric, for comparison.
    println!("\nwhite dielectric, Appendix B as written ((1 − F(V·H)) diffuse, no compensation)");
    for r in roughness {
        print!("{r:>9}");
        let b = gltf_up(&white(0.0, 0.0, r), true);
        for mu in mus {
            let wo = dir(mu);
            let (e, _) = furnace_of(&b, wo, 1 << 19, |s| {
                appendix_b(Vec3::ONE, 0.0, r, Vec3::Z, wo, s.wi) * (!s.flags.is_specular()) as u8 as f32
            });
            print!("{:>26}", format!("{e:.4}"));
        }
        println!();
    }
    println!("\nworst compensated deviation from 1: {worst:.4}");
}

#[test]
fn lecture_reproduces_whitted_optics() {
    let mut rng = Pcg64Mcg::seed_from_u64(9);
    // A tilted shading normal: the lobes must use it, as the Whitted integrator does.
    let ns = Vec3::new(0.2, -0.1, 1.0).normalize();
    let frame = Frame::from_normal(ns);
    let (albedo, ks, n) = (Vec3::new(0.5, 0.3, 0.1), Vec3::new(0.2, 0.3, 0.4), 25.0);
    let p =
        LectureParams { albedo, specular: ks, shininess: n, mirror: Vec3::ZERO, transmission: Vec3::ZERO, ior: 1.5 };
    let b = built(frame, ns, true, |b| lecture(b, &p));
    for _ in 0..1000 {
        let (wo, wi) = (frame.to_world(random_dir(&mut rng, 1.0)), frame.to_world(random_dir(&mut rng, 1.0)));
        let h = (wi + wo).normalize_or_zero();
        let whitted = optics::lambert(albedo) + ks * optics::blinn_phong(ns.dot(h), n);
        let e = b.eval(wo, wi);
        assert!((e.sum() - whitted).abs().max_element() <= 1e-5 * whitted.max_element(), "{} vs {whitted}", e.sum());
        assert!((e.diffuse - optics::lambert(albedo)).abs().max_element() < 1e-7);
    }
    // Mirror and dielectric: the value f·|cos θi| of each specular choice is Whitted's weight,
    // k_r + k_t R reflected and k_t (1 − R) refracted (× 1/η² for radiance), R from optics.rs.
    for front in [true, false] {
        let (kr, kt, ior) = (Vec3::new(0.1, 0.2, 0.3), Vec3::new(0.6, 0.5, 0.4), 1.5f32);
        let p = LectureParams {
            albedo: Vec3::ZERO,
            specular: Vec3::ZERO,
            shininess: 0.0,
            mirror: kr,
            transmission: kt,
            ior,
        };
        let b = built(up(), Vec3::Z, front, |b| lecture(b, &p));
        let (eta_i, eta_t) = if front { (1.0, ior) } else { (ior, 1.0) };
        for mu in [0.95f32, 0.6, 0.3, 0.1] {
            let wo = dir(mu);
            let r = optics::fresnel_dielectric(mu, eta_i, eta_t);
            let (mut reflected, mut refracted) = (Vec3::ZERO, Vec3::ZERO);
            let steps = 20_000;
            for i in 0..steps {
                let Some(s) = b.sample(wo, (i as f32 + 0.5) / steps as f32, Vec2::splat(0.5)) else { continue };
                assert!(s.flags.is_specular());
                // The mean weight over the discrete choices: Σ probability · weight.
                let value = s.f * s.wi.z.abs() / s.pdf / steps as f32;
                if s.is_transmission() {
                    refracted += value * s.eta * s.eta;
                    let t = optics::refract(-wo, Vec3::Z, eta_i / eta_t).unwrap();
                    assert!((s.wi - t).length() < 1e-5, "Snell: {} vs {t}", s.wi);
                } else {
                    reflected += value;
                    assert!((s.wi - Vec3::new(-wo.x, 0.0, wo.z)).length() < 1e-6);
                }
            }
            let want_r = kr + kt * r;
            let want_t = kt * (1.0 - r);
            assert!((reflected - want_r).abs().max_element() < 1e-3, "μ {mu}: reflected {reflected} vs {want_r}");
            assert!((refracted - want_t).abs().max_element() < 1e-3, "μ {mu}: refracted {refracted} vs {want_t}");
        }
    }
}

#[test]
fn random_materials_reflect_at_most_what_they_receive() {
    let mut rng = Pcg64Mcg::seed_from_u64(17);
    let mut most: f64 = 0.0;
    for i in 0..40 {
        let mut c = || Vec3::new(rng.random(), rng.random(), rng.random());
        let (base, spec_c, sheen) = (c(), c() * 2.0, c());
        let p = PbrParams {
            base_color: base,
            metallic: rng.random(),
            roughness: rng.random(),
            ior: 1.0 + 2.0 * rng.random::<f32>(),
            transmission: if i % 2 == 0 { rng.random() } else { 0.0 },
            specular: rng.random(),
            specular_color: spec_c,
            clearcoat: rng.random(),
            clearcoat_roughness: rng.random(),
            sheen_color: if i % 3 == 0 { sheen } else { Vec3::ZERO },
            sheen_roughness: rng.random(),
        };
        for front in [true, false] {
            let b = gltf_up(&p, front);
            let mu = 0.05 + 0.95 * rng.random::<f32>();
            // Per channel: the furnace of each channel separately.
            for ch in 0..3 {
                let (e, se) = furnace_of(&b, dir(mu), 1 << 15, |s| Vec3::splat(s.f[ch]));
                most = most.max(e);
                assert!(e <= 1.0 + 4.0 * se + 2e-3, "{p:?} front {front} μo {mu} channel {ch}: {e} ± {se}");
            }
        }
    }
    println!("largest albedo of 40 random materials: {most:.4}");
}

#[test]
fn size_and_flags() {
    println!("size_of::<Bsdf>() = {} bytes, Lobe = {}", std::mem::size_of::<Bsdf>(), std::mem::size_of::<Lobe>());
    let b = gltf_up(&glass_params(0.0), true);
    assert!(b.flags().contains(LobeFlags::SPECULAR | LobeFlags::TRANSMISSION | LobeFlags::REFLECTION));
    let b = gltf_up(&PbrParams { metallic: 0.0, roughness: 0.5, ..Default::default() }, true);
    assert!(b.flags().contains(LobeFlags::DIFFUSE | LobeFlags::GLOSSY) && !b.flags().is_specular());
    let c = b.colors();
    assert_eq!((c.diffuse, c.glossy, c.transmission), (Vec3::ONE, Vec3::ONE, Vec3::ZERO));
}

/// Appendix B evaluated by `tools/bsdf_reference.py` in float64 numpy from the specification's
/// text (and, in that script, again with Mitsuba 3's GGX `D` and Smith `G₁`: largest relative
/// difference 2.4e-7): `(base colour, metallic, roughness, wo, wi, f)`.
#[allow(clippy::type_complexity, clippy::excessive_precision)]
const APPENDIX_B_REFERENCE: [((f32, f32, f32), f32, f32, (f32, f32, f32), (f32, f32, f32), [f32; 3]); 6] = [
    ((1.0, 0.766, 0.336), 1.0, 0.3, (0.3, 0.1, 0.9), (-0.5, 0.2, 0.6), [1.4825825e-01, 1.1356685e-01, 4.9817712e-02]),
    ((1.0, 0.766, 0.336), 1.0, 0.8, (0.7, 0.0, 0.3), (-0.6, -0.3, 0.4), [3.7904322e-01, 2.9317998e-01, 1.3539709e-01]),
    ((0.8, 0.1, 0.1), 0.0, 0.5, (0.0, 0.0, 1.0), (0.4, 0.4, 0.8), [2.5542345e-01, 4.1519259e-02, 4.1519259e-02]),
    ((0.8, 0.1, 0.1), 0.0, 0.1, (0.6, 0.0, 0.8), (-0.6, 0.02, 0.8), [7.8821021e+00, 7.6682664e+00, 7.6682664e+00]),
    ((0.2, 0.9, 0.4), 0.5, 0.6, (0.9, 0.1, 0.2), (-0.3, -0.8, 0.5), [4.4348031e-02, 1.3653004e-01, 7.8565208e-02]),
    ((0.5, 0.5, 0.5), 0.2, 1.0, (0.1, 0.9, 0.3), (0.2, -0.2, 0.95), [1.2701963e-01, 1.2701963e-01, 1.2701963e-01]),
];

#[test]
fn appendix_b_matches_independent_reference() {
    let v3 = |t: (f32, f32, f32)| Vec3::new(t.0, t.1, t.2);
    for (base, m, r, wo, wi, want) in APPENDIX_B_REFERENCE {
        let (base, wo, wi, want) = (v3(base), v3(wo).normalize(), v3(wi).normalize(), Vec3::from_array(want));
        let got = appendix_b(base, m, r, Vec3::Z, wo, wi);
        let rel = ((got - want).abs() / want).max_element();
        assert!(rel < 2e-6, "Appendix B {got} vs numpy {want}: {rel:.1e}");
        // strahl's metal, uncompensated, is Appendix B's exactly; compensated it adds the
        // multiple-scattering term; a dielectric's base is albedo-scaled instead of (1 − F).
        let p = PbrParams { base_color: base, metallic: m, roughness: r, ..Default::default() };
        let ss = built(up(), Vec3::Z, true, |b| gltf::build(b, &p, Vec3::Z, false)).eval(wo, wi).sum();
        let full = gltf_up(&p, true).eval(wo, wi).sum();
        if m == 1.0 {
            let rel = ((ss - want).abs() / want).max_element();
            assert!(rel < 2e-5, "metal {ss} vs {want}: {rel:.1e}");
        }
        println!(
            "base {base} metallic {m} roughness {r}: Appendix B {want}, strahl single scattering {ss}, compensated {full}"
        );
    }
}

/// A glTF dielectric whose specular layer reflects nothing (`KHR_materials_specular`'s
/// `specularFactor` 0, Blender's Specular 0) is Lambertian: `f = baseColor/π` in the diffuse
/// family, nothing glossy, and cosine-weighted sampling (`pdf = cos θi/π`), at every roughness.
#[test]
fn a_black_specular_layer_leaves_a_lambertian_base() {
    let base = Vec3::new(0.8, 0.5, 0.2);
    for r in [0.05, 0.5, 1.0] {
        let b = gltf_up(
            &PbrParams { base_color: base, metallic: 0.0, roughness: r, specular: 0.0, ..Default::default() },
            true,
        );
        for (mo, mi) in [(1.0, 0.3), (0.7, 0.7), (0.2, 0.9), (0.05, 0.5)] {
            let (wo, wi) = (dir(mo), Vec3::new(-(1.0f32 - mi * mi).sqrt(), 0.0, mi));
            let f = b.eval(wo, wi);
            let want = base / std::f32::consts::PI;
            assert!(
                (f.diffuse - want).abs().max_element() <= 1e-6 * want.max_element(),
                "r {r}, μo {mo}, μi {mi}: {f:?}"
            );
            assert_eq!(f.glossy + f.transmission, Vec3::ZERO, "r {r}: {f:?}");
            let pdf = b.pdf(wo, wi);
            assert!((pdf - mi / std::f32::consts::PI).abs() <= 1e-6, "r {r}, μo {mo}, μi {mi}: pdf {pdf}");
        }
    }
}

/// A clearcoat about a normal of its own (`clearcoatNormalTexture`, or a base under a normal
/// map, which the coat does not follow), tilted 25° from the shading normal: sampled as its
/// density says, with `f` and `pdf` as `eval` and `pdf` give them; reflecting exactly as much
/// as the same coat untilted does at the same angle to its normal; and, smooth, mirroring
/// about its own normal with Schlick's weight there.
#[test]
fn a_tilted_clearcoat_reflects_about_its_own_normal() {
    let n = Vec3::new(0.42, 0.0, 0.9).normalize();
    let coated = PbrParams {
        base_color: Vec3::new(0.6, 0.1, 0.1),
        metallic: 0.0,
        roughness: 0.7,
        clearcoat: 1.0,
        clearcoat_roughness: 0.3,
        ..Default::default()
    };
    let b = built(up(), Vec3::Z, true, |b| gltf(b, &coated, n));
    assert!(matches!(b.lobes().last(), Some(Lobe::Tilted(_))), "{b:?}");
    assert!(matches!(gltf_up(&coated, true).lobes().last(), Some(Lobe::Microfacet(_))));
    for mu in [0.9, 0.4] {
        assert_chi2("tilted coat over a dielectric", &b, dir(mu));
    }
    let mut rng = Pcg64Mcg::seed_from_u64(23);
    let mut checked = 0;
    for _ in 0..4000 {
        let wo = random_dir(&mut rng, 1.0);
        let Some(s) = b.sample(wo, rng.random(), Vec2::new(rng.random(), rng.random())) else { continue };
        let (f, pdf) = (b.eval(wo, s.wi).sum(), b.pdf(wo, s.wi));
        assert!((s.f - f).abs().max_element() <= 1e-4 * f.max_element().max(1e-3), "f {} vs {f}", s.f);
        assert!((s.pdf - pdf).abs() <= 1e-4 * pdf, "pdf {} vs {pdf}", s.pdf);
        checked += 1;
    }
    assert!(checked > 3000, "{checked}");

    // The coat alone (a black base without a specular layer).
    let coat_only = PbrParams {
        base_color: Vec3::ZERO,
        metallic: 0.0,
        specular: 0.0,
        clearcoat: 1.0,
        clearcoat_roughness: 0.3,
        ..Default::default()
    };
    // (The geometric normal is the coat's here, so that no part of the coat's lobe goes into
    // the surface, where the untilted coat's would not.)
    let (tilted, straight) = (built(up(), n, true, |b| gltf(b, &coat_only, n)), gltf_up(&coat_only, true));
    let coat_frame = Frame::from_normal(n);
    for wo in [dir(0.9), dir(0.5), Vec3::new(0.2, -0.4, 0.894).normalize()] {
        let ((e, se), (e0, se0)) = (furnace(&tilted, wo), furnace(&straight, coat_frame.to_local(wo)));
        println!("tilted coat from {wo}: {e:.5} ± {se:.5}, untilted at the same angle {e0:.5} ± {se0:.5}");
        assert!((e - e0).abs() <= 4.0 * (se * se + se0 * se0).sqrt() + 1e-4, "{e} ± {se} vs {e0} ± {se0}");
    }
    // A coat over a base whose shading normal leans 30° away (a normal map the coat does not
    // follow; here the coat's normal is the geometric one): it still reflects into directions
    // below the base's horizon that leave the surface, as much as the coat alone does.
    let lean = Frame::from_normal(Vec3::new(0.5, 0.0, 0.866).normalize());
    let under_lean = built(lean, Vec3::Z, true, |b| gltf(b, &coat_only, Vec3::Z));
    let wo = Vec3::new(0.966, 0.0, 0.259).normalize();
    let ((e, se), (e0, se0)) = (furnace(&under_lean, wo), furnace(&straight, wo));
    println!("coat over a leaning base from {wo}: {e:.5} ± {se:.5}, the coat alone {e0:.5} ± {se0:.5}");
    assert!((e - e0).abs() <= 4.0 * (se * se + se0 * se0).sqrt() + 1e-4, "{e} ± {se} vs {e0} ± {se0}");
    for _ in 0..2000 {
        let Some(s) = under_lean.sample(wo, rng.random(), Vec2::new(rng.random(), rng.random())) else { continue };
        assert!(s.wi.z > 0.0 && !s.is_transmission(), "{s:?}");
        let (f, pdf) = (under_lean.eval(wo, s.wi).sum(), under_lean.pdf(wo, s.wi));
        assert!((s.f - f).abs().max_element() <= 1e-4 * f.max_element().max(1e-3), "f {} vs {f}", s.f);
        assert!((s.pdf - pdf).abs() <= 1e-4 * pdf, "pdf {} vs {pdf}", s.pdf);
    }
    let smooth = built(up(), Vec3::Z, true, |b| gltf(b, &PbrParams { clearcoat_roughness: 0.0, ..coat_only }, n));
    for wo in [dir(0.9), dir(0.5)] {
        let s = smooth.sample(wo, 0.5, Vec2::splat(0.5)).unwrap();
        assert!(s.flags.is_specular());
        assert!((s.wi - (2.0 * wo.dot(n) * n - wo)).length() < 1e-5, "{} vs the mirror about n", s.wi);
        let weight = s.f * s.wi.z.abs() / s.pdf;
        let want = fresnel::schlick(Vec3::splat(0.04), Vec3::ONE, wo.dot(n));
        assert!((weight - want).abs().max_element() < 1e-5, "{weight} vs Schlick {want}");
    }
}
