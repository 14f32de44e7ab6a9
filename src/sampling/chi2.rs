//! Pearson's χ² goodness-of-fit test of a direction sampler against its density, in the
//! manner of Mitsuba 3's `chi2` module.
//!
//! The sphere is cut into bins over `(cos θ, φ)` (`cos θ ∈ [−1, 1]`, `φ ∈ [−π, π]`, so each bin
//! has the solid angle `Δcos θ · Δφ`). `N` samples are drawn and counted per bin (`Oᵢ`); the
//! expected count is `Eᵢ = N ∫∫_bin pdf(ω(cos θ, φ)) dcos θ dφ`, integrated by adaptive
//! Simpson quadrature ([`super::quadrature`]). Bins are sorted by `Eᵢ`; those with `Eᵢ < 5` are
//! pooled (added up until the pool reaches 5, then counted as one bin), and
//!
//! ```text
//! χ² = Σ (Oᵢ − Eᵢ)² / Eᵢ,     dof = bins counted − 1,     p = Q(dof/2, χ²/2)
//! ```
//!
//! with `Q` the regularised upper incomplete gamma function. The sampler is rejected when
//! `p < α'`, where `α' = 1 − (1 − α)^(1/m)` is the Šidák-corrected significance for `m` tests
//! run together ([`sidak`]), or outright when a sample lands where the density integrates to
//! zero, a direction is not finite, or the density integrates to more than 1.
//!
//! A sampler may fail (return `None`: no direction, e.g. below the horizon); such samples
//! count in `N` but in no bin, exactly as the density's mass there is missing from `Σ Eᵢ`.
//!
//! The incomplete gamma function is written here (series and Lentz continued fraction,
//! Numerical Recipes §6.2) rather than taken from `statrs`, which would bring `nalgebra` into
//! every build for one function used by tests.

use std::fmt;

use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64Mcg;

use super::quadrature::adaptive_simpson_2d;
use crate::math::{Vec2, Vec3};

/// The χ² test's settings.
#[derive(Clone, Copy, Debug)]
pub struct Chi2Test {
    /// Bins over `cos θ ∈ [−1, 1]` (odd, so that `cos θ = 0` falls inside a bin, not on an edge
    /// that rounding would move samples across).
    pub cos_bins: usize,
    /// Bins over `φ ∈ [−π, π]`.
    pub phi_bins: usize,
    /// Samples drawn.
    pub samples: usize,
    /// Seed of the samples' random numbers.
    pub seed: u64,
    /// Bins expecting fewer samples than this are pooled.
    pub pool_threshold: f64,
}

impl Default for Chi2Test {
    fn default() -> Self {
        Chi2Test { cos_bins: 101, phi_bins: 100, samples: 1_000_000, seed: 7, pool_threshold: 5.0 }
    }
}

/// What a run found.
#[derive(Clone, Debug)]
pub struct Chi2Result {
    pub statistic: f64,
    pub dof: usize,
    pub p_value: f64,
    /// Bins pooled, and the pooled bins they became.
    pub pooled: (usize, usize),
    /// The share of samples that landed in a bin, and `Σ Eᵢ / N`.
    pub histogram_sum: f64,
    pub pdf_sum: f64,
    /// Why the test failed before the statistic was looked at.
    pub failure: Option<String>,
}

impl Chi2Result {
    /// Whether the sampler matches its density at significance `alpha` (already corrected for
    /// the number of tests, see [`sidak`]).
    pub fn passes(&self, alpha: f64) -> bool {
        self.failure.is_none() && self.p_value.is_finite() && self.p_value >= alpha
    }
}

impl fmt::Display for Chi2Result {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "χ² = {:.1}, dof = {}, p = {:.4}, histogram sum {:.5}, pdf sum {:.5}, pooled {} bins into {}",
            self.statistic, self.dof, self.p_value, self.histogram_sum, self.pdf_sum, self.pooled.0, self.pooled.1
        )?;
        if let Some(why) = &self.failure {
            write!(f, "; failed: {why}")?;
        }
        Ok(())
    }
}

/// The Šidák-corrected significance of each of `tests` independent tests whose family is to
/// have significance `alpha`: `1 − (1 − α)^(1/m)`.
pub fn sidak(alpha: f64, tests: usize) -> f64 {
    1.0 - (1.0 - alpha).powf(1.0 / tests.max(1) as f64)
}

impl Chi2Test {
    /// The direction of the point `(cos θ, φ)` of the parameter domain.
    fn direction(cos_theta: f64, phi: f64) -> Vec3 {
        let sin_theta = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
        Vec3::new((sin_theta * phi.cos()) as f32, (sin_theta * phi.sin()) as f32, cos_theta as f32)
    }

    /// Runs the test: `sample(u_lobe, u)` draws one direction from uniform numbers in `[0, 1)`,
    /// `pdf(ω)` is the density it claims, per steradian.
    pub fn run(&self, mut sample: impl FnMut(f32, Vec2) -> Option<Vec3>, pdf: impl Fn(Vec3) -> f64) -> Chi2Result {
        let (nc, np) = (self.cos_bins, self.phi_bins);
        let mut failure = None;
        let mut observed = vec![0.0f64; nc * np];
        let mut rng = Pcg64Mcg::seed_from_u64(self.seed);
        let mut landed = 0usize;
        for _ in 0..self.samples {
            let u_lobe: f32 = rng.random();
            let u = Vec2::new(rng.random(), rng.random());
            let Some(w) = sample(u_lobe, u) else { continue };
            if !w.is_finite() || (w.length() - 1.0).abs() > 1e-3 {
                failure.get_or_insert_with(|| format!("sample {w} is not a unit direction"));
                continue;
            }
            let c = ((w.z as f64 + 1.0) * 0.5 * nc as f64).floor().clamp(0.0, (nc - 1) as f64) as usize;
            let phi = (w.y as f64).atan2(w.x as f64);
            let p = ((phi + std::f64::consts::PI) / std::f64::consts::TAU * np as f64)
                .floor()
                .clamp(0.0, (np - 1) as f64) as usize;
            observed[c * np + p] += 1.0;
            landed += 1;
        }

        let n = self.samples as f64;
        let (dc, dp) = (2.0 / nc as f64, std::f64::consts::TAU / np as f64);
        let mut expected = vec![0.0f64; nc * np];
        let mut f = |c: f64, p: f64| pdf(Self::direction(c, p)).max(0.0);
        for (i, e) in expected.iter_mut().enumerate() {
            let (c0, p0) = (-1.0 + (i / np) as f64 * dc, -std::f64::consts::PI + (i % np) as f64 * dp);
            *e = n * adaptive_simpson_2d(&mut f, (c0, c0 + dc), (p0, p0 + dp), 1e-9, 9);
        }
        let pdf_sum = expected.iter().sum::<f64>() / n;
        if pdf_sum > 1.01 {
            failure.get_or_insert_with(|| format!("the density integrates to {pdf_sum:.4} > 1"));
        }
        if let Some(i) = (0..nc * np).find(|&i| expected[i] == 0.0 && observed[i] > 0.0) {
            failure.get_or_insert_with(|| {
                let c = -1.0 + (i / np) as f64 * dc;
                format!("{} samples in bin cos θ ∈ [{c:.3}, {:.3}) whose density is 0", observed[i], c + dc)
            });
        }

        // Pool low-expectation bins, in increasing order of expectation.
        let mut order: Vec<usize> = (0..nc * np).collect();
        order.sort_by(|&a, &b| expected[a].total_cmp(&expected[b]));
        let (mut chi2, mut dof, mut pooled_in, mut pooled_out) = (0.0, 0usize, 0usize, 0usize);
        let (mut pool_o, mut pool_e) = (0.0, 0.0);
        for i in order {
            let (o, e) = (observed[i], expected[i]);
            if e == 0.0 {
                continue;
            }
            if e < self.pool_threshold {
                pool_o += o;
                pool_e += e;
                pooled_in += 1;
                if pool_e >= self.pool_threshold {
                    chi2 += (pool_o - pool_e) * (pool_o - pool_e) / pool_e;
                    dof += 1;
                    pooled_out += 1;
                    (pool_o, pool_e) = (0.0, 0.0);
                }
            } else {
                chi2 += (o - e) * (o - e) / e;
                dof += 1;
            }
        }
        let dof = dof.saturating_sub(1);
        if dof < 1 {
            failure.get_or_insert_with(|| "too few degrees of freedom".into());
        }
        let p_value = gamma_q(dof as f64 / 2.0, chi2 / 2.0);
        Chi2Result {
            statistic: chi2,
            dof,
            p_value,
            pooled: (pooled_in, pooled_out),
            histogram_sum: landed as f64 / n,
            pdf_sum,
            failure,
        }
    }
}

/// `ln Γ(x)` for `x > 0` (Lanczos, g = 7, 9 terms; relative error ≈ 1e-15).
fn ln_gamma(x: f64) -> f64 {
    const G: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    if x < 0.5 {
        // Reflection: Γ(x)Γ(1 − x) = π / sin(πx).
        let pi = std::f64::consts::PI;
        return (pi / (pi * x).sin()).ln() - ln_gamma(1.0 - x);
    }
    let x = x - 1.0;
    let t = x + 7.5;
    let s = G[1..].iter().enumerate().fold(G[0], |s, (i, g)| s + g / (x + 1.0 + i as f64));
    0.5 * (2.0 * std::f64::consts::PI).ln() + (x + 0.5) * t.ln() - t + s.ln()
}

/// The regularised upper incomplete gamma function `Q(a, x) = Γ(a, x)/Γ(a)`: the probability
/// that a χ² variable with `2a` degrees of freedom exceeds `2x`.
pub fn gamma_q(a: f64, x: f64) -> f64 {
    if !(a > 0.0) || !(x >= 0.0) {
        return f64::NAN;
    }
    if x == 0.0 {
        return 1.0;
    }
    let prefactor = (-x + a * x.ln() - ln_gamma(a)).exp();
    if x < a + 1.0 {
        // Series for P(a, x) = e^(−x) x^a / Γ(a) · Σ xⁿ / (a (a+1) … (a+n)).
        let (mut term, mut sum, mut ap) = (1.0 / a, 1.0 / a, a);
        for _ in 0..10_000 {
            ap += 1.0;
            term *= x / ap;
            sum += term;
            if term.abs() < sum.abs() * 1e-16 {
                break;
            }
        }
        (1.0 - sum * prefactor).max(0.0)
    } else {
        // Continued fraction for Q (modified Lentz).
        let tiny = 1e-300;
        let mut b = x + 1.0 - a;
        let mut c = 1.0 / tiny;
        let mut d = 1.0 / b;
        let mut h = d;
        for i in 1..10_000 {
            let an = -(i as f64) * (i as f64 - a);
            b += 2.0;
            d = an * d + b;
            if d.abs() < tiny {
                d = tiny;
            }
            c = b + an / c;
            if c.abs() < tiny {
                c = tiny;
            }
            d = 1.0 / d;
            let delta = d * c;
            h *= delta;
            if (delta - 1.0).abs() < 1e-16 {
                break;
            }
        }
        (prefactor * h).min(1.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chi2_tail_matches_known_values() {
        // dof = 2: Q(1, x/2) = e^(−x/2) exactly.
        for x in [0.1f64, 1.0, 5.0, 30.0] {
            assert!((gamma_q(1.0, x / 2.0) - (-x / 2.0).exp()).abs() < 1e-12, "x = {x}");
        }
        // Tabulated 1 % critical values: dof 10 → 23.209, dof 100 → 135.807, dof 1 → 6.635.
        for (dof, crit) in [(10.0, 23.209_251), (100.0, 135.806_723), (1.0, 6.634_897)] {
            let p = gamma_q(dof / 2.0, crit / 2.0);
            assert!((p - 0.01).abs() < 1e-6, "dof {dof}: p = {p}");
        }
        assert!((ln_gamma(10.0) - 362_880f64.ln()).abs() < 1e-12);
        assert!((ln_gamma(0.5) - std::f64::consts::PI.sqrt().ln()).abs() < 1e-12);
    }

    #[test]
    fn sidak_correction() {
        assert!((sidak(0.01, 1) - 0.01).abs() < 1e-15);
        let a = sidak(0.01, 10);
        assert!((1.0 - (1.0 - a).powi(10) - 0.01).abs() < 1e-12);
    }
}
