//! Piecewise-constant distributions in one and two dimensions, sampled by inverting their
//! cumulative sums (pbrt-v4's `PiecewiseConstant1D` / `PiecewiseConstant2D`).
//!
//! ```text
//! 1-D, n cells over [0, 1):   f_i ≥ 0,  I = Σ f_i / n,  p(x) = f_⌊x·n⌋ / I
//!                             CDF_k = Σ_{i<k} f_i / (n·I),  x = (k + (u − CDF_k)/(CDF_{k+1} − CDF_k)) / n
//! 2-D, nu × nv cells:         p(u, v) = p_v(v) · p_u(u | v) = f(u, v) / I,
//!                             the marginal over rows p_v from each row's integral I_v,
//!                             then that row's conditional 1-D distribution p_u(· | v)
//! ```
//!
//! The sample's density is computed from the same numbers the lookup uses (`f_i / I`), so the
//! density [`Distribution1D::sample`] reports equals [`Distribution1D::pdf`] of the point it
//! returned. A distribution whose values are all 0 (or not finite) is treated as uniform, so
//! sampling it never divides by 0; [`Distribution1D::integral`] still reports 0, and a light
//! with nothing to emit is left out before it is sampled. The cumulative sums are built in
//! f64 (an 8192-cell row of very different values keeps its small cells) and stored in f32.
//!
//! The same CDF also chooses among discrete items with [`Distribution1D::sample_discrete`]
//! (the light chosen by power).

/// A piecewise-constant density over `[0, 1)` (or `n` discrete items), see the module docs.
#[derive(Clone, Debug, PartialEq)]
pub struct Distribution1D {
    func: Vec<f32>,
    /// `cdf[0] = 0 … cdf[n] = 1`.
    cdf: Vec<f32>,
    /// `Σ f_i / n` (0 when every value is 0).
    integral: f64,
}

impl Distribution1D {
    /// The distribution of the values `func` (negative or non-finite values count as 0); at
    /// least one value.
    pub fn new(func: &[f32]) -> Distribution1D {
        assert!(!func.is_empty(), "a distribution needs at least one cell");
        let n = func.len();
        let clean: Vec<f32> = func.iter().map(|&f| if f.is_finite() && f > 0.0 { f } else { 0.0 }).collect();
        let total: f64 = clean.iter().map(|&f| f as f64).sum();
        let (func, integral) =
            if total > 0.0 && total.is_finite() { (clean, total / n as f64) } else { (vec![1.0; n], 0.0) };
        let sum: f64 = func.iter().map(|&f| f as f64).sum();
        let mut cdf = Vec::with_capacity(n + 1);
        let mut acc = 0.0f64;
        cdf.push(0.0);
        for &f in &func {
            acc += f as f64;
            cdf.push((acc / sum) as f32);
        }
        cdf[n] = 1.0;
        Distribution1D { func, cdf, integral }
    }

    /// Number of cells.
    pub fn len(&self) -> usize {
        self.func.len()
    }

    /// Whether it has no cells (never: [`Distribution1D::new`] needs one).
    pub fn is_empty(&self) -> bool {
        self.func.is_empty()
    }

    /// `Σ f_i / n`: the integral of the function over `[0, 1)` (0 for an all-zero function).
    pub fn integral(&self) -> f64 {
        self.integral
    }

    /// The normaliser of the densities: the integral, or the uniform fallback's 1.
    fn norm(&self) -> f64 {
        if self.integral > 0.0 { self.integral } else { 1.0 }
    }

    /// The cell `u ∈ [0, 1)` falls in by the CDF.
    fn cell(&self, u: f32) -> usize {
        // The last k with cdf[k] ≤ u, skipping cells of zero width.
        let k = self.cdf.partition_point(|&c| c <= u).saturating_sub(1);
        let mut k = k.min(self.len() - 1);
        while self.cdf[k + 1] <= self.cdf[k] && k + 1 < self.len() {
            k += 1;
        }
        while self.cdf[k + 1] <= self.cdf[k] && k > 0 {
            k -= 1;
        }
        k
    }

    /// A point `x ∈ [0, 1)` drawn for `u ∈ [0, 1)`, its density `p(x)` and its cell.
    pub fn sample(&self, u: f32) -> (f32, f32, usize) {
        let k = self.cell(u);
        let (c0, c1) = (self.cdf[k], self.cdf[k + 1]);
        let du = if c1 > c0 { ((u - c0) / (c1 - c0)).clamp(0.0, 1.0) } else { 0.5 };
        let x = self.inside(k, (k as f32 + du) / self.len() as f32);
        (x, self.pdf_cell(k), k)
    }

    /// `x` moved by the least amount into cell `k` as [`Distribution1D::pdf`] finds cells, so
    /// that the density reported for a sample is the density of the point returned.
    fn inside(&self, k: usize, mut x: f32) -> f32 {
        let n = self.len();
        let cell = |x: f32| ((x * n as f32) as usize).min(n - 1);
        x = x.clamp(0.0, 1.0f32.next_down());
        for _ in 0..64 {
            match cell(x).cmp(&k) {
                std::cmp::Ordering::Less => x = x.next_up(),
                std::cmp::Ordering::Greater => x = x.next_down(),
                std::cmp::Ordering::Equal => break,
            }
        }
        x
    }

    /// The density `p(x)` of the point `x ∈ [0, 1)`.
    pub fn pdf(&self, x: f32) -> f32 {
        if !(0.0..1.0).contains(&x) {
            return 0.0;
        }
        self.pdf_cell(((x * self.len() as f32) as usize).min(self.len() - 1))
    }

    /// The density in cell `k`: `f_k / I`.
    pub fn pdf_cell(&self, k: usize) -> f32 {
        (self.func[k] as f64 / self.norm()) as f32
    }

    /// An item chosen for `u ∈ [0, 1)` with probability `f_k / Σ f`, that probability, and
    /// `u` rescaled to `[0, 1)` inside the item's share (to be used again).
    pub fn sample_discrete(&self, u: f32) -> (usize, f32, f32) {
        let k = self.cell(u);
        let (c0, c1) = (self.cdf[k], self.cdf[k + 1]);
        let remapped = if c1 > c0 { ((u - c0) / (c1 - c0)).clamp(0.0, 1.0 - f32::EPSILON / 2.0) } else { 0.5 };
        (k, self.probability(k), remapped)
    }

    /// The probability of item `k` in [`Distribution1D::sample_discrete`].
    pub fn probability(&self, k: usize) -> f32 {
        (self.func[k] as f64 / (self.norm() * self.len() as f64)) as f32
    }
}

/// A piecewise-constant density over `[0, 1)²`, `nu × nv` cells, row `v` the outer choice
/// (see the module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct Distribution2D {
    /// One per row: the density along `u` in that row.
    conditional: Vec<Distribution1D>,
    /// Over the rows, of their integrals.
    marginal: Distribution1D,
}

impl Distribution2D {
    /// The distribution of `func`, `nu` values per row, row-major (`nu·nv` values).
    pub fn new(func: &[f32], nu: usize, nv: usize) -> Distribution2D {
        assert!(nu > 0 && nv > 0 && func.len() == nu * nv, "{} values for {nu} × {nv}", func.len());
        let conditional: Vec<Distribution1D> = func.chunks_exact(nu).map(Distribution1D::new).collect();
        let rows: Vec<f32> = conditional.iter().map(|c| c.integral() as f32).collect();
        let marginal = Distribution1D::new(&rows);
        Distribution2D { conditional, marginal }
    }

    /// The integral of the function over `[0, 1)²` (0 for an all-zero function).
    pub fn integral(&self) -> f64 {
        self.marginal.integral()
    }

    /// A point of `[0, 1)²` drawn for `u`, and its density.
    pub fn sample(&self, u: [f32; 2]) -> ([f32; 2], f32) {
        let (v, pv, row) = self.marginal.sample(u[1]);
        let (x, pu, _) = self.conditional[row].sample(u[0]);
        ([x, v], pv * pu)
    }

    /// The density of the point `(u, v)`.
    pub fn pdf(&self, p: [f32; 2]) -> f32 {
        let pv = self.marginal.pdf(p[1]);
        if pv == 0.0 {
            return 0.0;
        }
        let row = ((p[1] * self.marginal.len() as f32) as usize).min(self.marginal.len() - 1);
        pv * self.conditional[row].pdf(p[0])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_dimension_follows_its_values() {
        let d = Distribution1D::new(&[1.0, 0.0, 3.0, 0.0]);
        assert_eq!(d.integral(), 1.0);
        // Cells of zero value are never sampled; the density is f/I.
        for i in 0..1000 {
            let u = (i as f32 + 0.5) / 1000.0;
            let (x, pdf, k) = d.sample(u);
            assert!(k == 0 || k == 2, "{u} → cell {k}");
            assert_eq!(pdf, d.pdf(x));
            assert!((0.0..1.0).contains(&x));
        }
        assert_eq!(d.pdf(0.1), 1.0);
        assert_eq!(d.pdf(0.6), 3.0);
        assert_eq!(d.pdf(0.3), 0.0);
        // A quarter of u lands in the first cell.
        assert!(d.sample(0.2).2 == 0 && d.sample(0.3).2 == 2);
        let (k, p, r) = d.sample_discrete(0.625);
        assert_eq!((k, p), (2, 0.75));
        assert!((r - 0.5).abs() < 1e-6);
    }

    #[test]
    fn all_zero_is_uniform_with_zero_integral() {
        let d = Distribution1D::new(&[0.0, f32::NAN, -1.0]);
        assert_eq!(d.integral(), 0.0);
        assert_eq!(d.pdf(0.5), 1.0);
        assert_eq!(d.sample_discrete(0.5).1, 1.0 / 3.0);
    }

    #[test]
    fn two_dimensions_sample_their_density() {
        // A 3 × 2 function: the sample's density is f/I at the point, and the share of samples
        // per cell is f·(cell area)/I.
        let f = [1.0, 2.0, 0.0, 4.0, 0.0, 5.0];
        let d = Distribution2D::new(&f, 3, 2);
        assert!((d.integral() - 12.0 / 6.0).abs() < 1e-12);
        let n = 300;
        let mut counts = [0usize; 6];
        for i in 0..n {
            for j in 0..n {
                let u = [(i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32];
                let (p, pdf) = d.sample(u);
                assert_eq!(pdf, d.pdf(p));
                let cell = (p[1] * 2.0) as usize * 3 + (p[0] * 3.0) as usize;
                assert!((pdf - f[cell] / 2.0).abs() < 1e-6);
                counts[cell] += 1;
            }
        }
        for (c, fc) in counts.iter().zip(f) {
            let share = *c as f32 / (n * n) as f32;
            assert!((share - fc / 12.0).abs() < 2e-3, "{share} vs {}", fc / 12.0);
        }
    }
}
