//! Deterministic numerical integration: Gauss–Legendre rules for the BSDF energy tables and
//! adaptive Simpson quadrature for the expected counts of the χ² test.
//!
//! ```text
//! Gauss–Legendre:    ∫₀¹ f(x) dx ≈ Σᵢ wᵢ f(xᵢ),  xᵢ the roots of Pₙ mapped to [0, 1]
//!                    (exact for polynomials of degree ≤ 2n − 1)
//! adaptive Simpson:  S(a, b) = (b − a)/6 · (f(a) + 4 f(m) + f(b)); an interval is split while
//!                    |S(a, m) + S(m, b) − S(a, b)| > 15 ε, and the answer takes Richardson's
//!                    correction (S(a, m) + S(m, b) + Δ/15)
//! ```
//!
//! Written here rather than taken from a crate: the two rules are a few lines each, and the
//! crates that offer them (`quadrature`, `gauss-quad`) would add a dependency to every build
//! for code that only fills tables and checks tests.

/// The `n`-point Gauss–Legendre rule on `[0, 1]`: `(nodes, weights)`, weights summing to 1.
/// Nodes by Newton's iteration on the Legendre recurrence, in f64 (converges to 1e-15).
pub fn gauss_legendre(n: usize) -> (Vec<f64>, Vec<f64>) {
    let mut nodes = vec![0.0; n];
    let mut weights = vec![0.0; n];
    for i in 0..n {
        // Tricomi's initial guess for the i-th root of P_n on [−1, 1].
        let mut x = (std::f64::consts::PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
        let mut dp = 1.0;
        for _ in 0..100 {
            let (mut p0, mut p1) = (1.0, x);
            for k in 2..=n {
                let p2 = ((2 * k - 1) as f64 * x * p1 - (k - 1) as f64 * p0) / k as f64;
                p0 = p1;
                p1 = p2;
            }
            let p = if n == 0 { 1.0 } else { p1 };
            let pm1 = if n == 0 { 0.0 } else { p0 };
            dp = n as f64 * (x * p - pm1) / (x * x - 1.0);
            let dx = p / dp;
            x -= dx;
            if dx.abs() < 1e-15 {
                break;
            }
        }
        // Map [−1, 1] to [0, 1]: x → (1 − x)/2 (ascending order), weight w/2.
        nodes[i] = 0.5 * (1.0 - x);
        weights[i] = 1.0 / ((1.0 - x * x) * dp * dp);
    }
    (nodes, weights)
}

/// `∫ₐᵇ f(x) dx` by adaptive Simpson quadrature to absolute tolerance `eps`, splitting at most
/// `depth` times along any branch.
pub fn adaptive_simpson(f: &mut impl FnMut(f64) -> f64, a: f64, b: f64, eps: f64, depth: u32) -> f64 {
    let (fa, fm, fb) = (f(a), f(0.5 * (a + b)), f(b));
    let whole = (b - a) / 6.0 * (fa + 4.0 * fm + fb);
    simpson_step(f, a, b, fa, fm, fb, whole, eps, depth)
}

#[allow(clippy::too_many_arguments)] // the interval, its three values, its estimate and the budget
fn simpson_step(
    f: &mut impl FnMut(f64) -> f64,
    a: f64,
    b: f64,
    fa: f64,
    fm: f64,
    fb: f64,
    whole: f64,
    eps: f64,
    depth: u32,
) -> f64 {
    let m = 0.5 * (a + b);
    let (lm, rm) = (0.5 * (a + m), 0.5 * (m + b));
    let (flm, frm) = (f(lm), f(rm));
    let left = (m - a) / 6.0 * (fa + 4.0 * flm + fm);
    let right = (b - m) / 6.0 * (fm + 4.0 * frm + fb);
    let delta = left + right - whole;
    if depth == 0 || delta.abs() <= 15.0 * eps {
        return left + right + delta / 15.0;
    }
    simpson_step(f, a, m, fa, flm, fm, left, 0.5 * eps, depth - 1)
        + simpson_step(f, m, b, fm, frm, fb, right, 0.5 * eps, depth - 1)
}

/// `∫∫ f(x, y) dy dx` over `[x0, x1] × [y0, y1]` by nested adaptive Simpson quadrature.
pub fn adaptive_simpson_2d(
    f: &mut impl FnMut(f64, f64) -> f64,
    (x0, x1): (f64, f64),
    (y0, y1): (f64, f64),
    eps: f64,
    depth: u32,
) -> f64 {
    let inner_eps = eps / (x1 - x0).abs().max(1e-300);
    let mut outer = |x: f64| adaptive_simpson(&mut |y| f(x, y), y0, y1, inner_eps, depth);
    adaptive_simpson(&mut outer, x0, x1, eps, depth)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gauss_legendre_is_exact_for_polynomials_up_to_degree_2n_minus_1() {
        for n in [1, 2, 5, 16, 64] {
            let (x, w) = gauss_legendre(n);
            assert!((w.iter().sum::<f64>() - 1.0).abs() < 1e-13, "n = {n}");
            for k in 0..(2 * n) {
                let q: f64 = x.iter().zip(&w).map(|(x, w)| w * x.powi(k as i32)).sum();
                assert!((q - 1.0 / (k + 1) as f64).abs() < 1e-12, "n = {n}, x^{k}: {q}");
            }
        }
    }

    #[test]
    fn adaptive_simpson_integrates_a_peak() {
        // A narrow Gaussian: ∫ exp(−x²/(2s²)) over ℝ = s √(2π).
        let s = 1e-3;
        let q = adaptive_simpson(&mut |x| (-x * x / (2.0 * s * s)).exp(), -1.0, 1.0, 1e-12, 40);
        let exact = s * (2.0 * std::f64::consts::PI).sqrt();
        assert!((q - exact).abs() < 1e-9, "{q} vs {exact}");
        let q2 = adaptive_simpson_2d(&mut |x, y| x * y * y, (0.0, 2.0), (0.0, 3.0), 1e-10, 20);
        assert!((q2 - 18.0).abs() < 1e-9, "{q2}");
    }
}
