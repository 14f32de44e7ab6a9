//! Directional albedo tables of the microfacet lobes, for their multiple-scattering
//! compensation and for layering one lobe under another.
//!
//! ```text
//! E(μ)  = ∫ f(ωo, ωi) |cos θi| dωi        directional albedo, ωo at cos θo = μ
//! Ē     = 2 ∫₀¹ E(μ) μ dμ                  hemispherical average
//! ```
//!
//! * **GGX reflection** with Schlick's `F = F₀(1 − s) + F₉₀ s`, `s = (1 − o·h)⁵`, is linear in
//!   `F₀` and `F₉₀`: `E = F₀ A(μ, r) + F₉₀ B(μ, r)`, so two tables over `(μ, roughness)` serve
//!   every colour; `A + B` is the albedo with `F = 1`.
//! * **GGX glass** (reflection plus refraction, [`super::glass`]) depends on the relative index
//!   `η` too: one table over `(μ, roughness)` per `η` of a grid on `[1, 3]`, for light arriving
//!   from the less dense side and from the denser one, interpolated linearly in `η`. The
//!   transmitted part is counted in energy (radiance × `(η_o/η_i)²`, see [`super::glass`]).
//! * **Sheen** ([`super::sheen`]): the Charlie lobe's albedo over `(μ, sheen roughness)`.
//!
//! Each table is computed by fixed quadrature, nothing random (`quadrature::computed`): the
//! microfacet albedos integrate `F·G₂/G₁` over the unit square warped to the visible normals
//! (`E = ∫ D_o(h) F G₂/G₁ dh`, smooth in the warp's variables at any roughness) with a
//! Gauss–Legendre product rule, the sheen albedo integrates `f cos θi` over `(cos θi, φ)`.
//! Lookups interpolate bilinearly over `(μ, roughness)`; `Ē` is the exact average of that
//! interpolant (piecewise linear in `μ`), so a lobe built as `(1 − E(μo))(1 − E(μi))/(1 − Ē)`
//! reflects exactly `1 − E(μo)` of what the table says.
//!
//! **Shipped, not built per process.** The quadrature costs tenths of a second of CPU (release
//! build, one thread: GGX about 0.15 s, the two glass slices of one index about as much, sheen
//! a little less), which a render would pay at its first microfacet lobe: most of a small
//! render's time, and again in every tile process of a farm. The tables' values are computed
//! once and stored in `albedo_tables.bin` (the 35 tables of 32 × 32 little-endian `f32`, in the
//! order of `quadrature::computed`, compiled for the tests; the averages are recomputed from
//! them at load), read at first use (a `OnceLock`). The test
//! `shipped_tables_are_the_quadrature` computes every table again and compares; after a change
//! to a lobe or to the quadrature, write the file again with `make albedo-tables`
//! (`cargo test --release --lib -- --ignored write_albedo_tables`).

use std::sync::OnceLock;

/// Nodes over `μ = cos θo ∈ [0, 1]` and over roughness `∈ [0, 1]`.
pub const N_MU: usize = 32;
pub const N_ROUGH: usize = 32;
/// `η` nodes of the glass tables: `1 + 2k/(N_ETA − 1)`, `k = 0 … N_ETA − 1`.
pub const N_ETA: usize = 16;
/// The largest relative index the glass tables cover; beyond it the last node is used.
pub const MAX_ETA: f32 = 3.0;

/// A table over `(μ, roughness)` with the hemispherical average per roughness node.
#[derive(Debug)]
pub struct Table {
    values: Vec<f32>,
    averages: Vec<f32>,
}

impl Table {
    /// The table of `values` at the nodes (`N_ROUGH` rows of `N_MU`), with its averages.
    fn from_values(values: Vec<f32>) -> Table {
        // Ē = 2∫ E μ dμ of the piecewise linear interpolant, segment by segment.
        let h = 1.0 / (N_MU - 1) as f64;
        let averages = (0..N_ROUGH)
            .map(|j| {
                let row = &values[j * N_MU..(j + 1) * N_MU];
                let sum: f64 = (0..N_MU - 1)
                    .map(|i| {
                        let (ma, mb) = (i as f64 * h, (i + 1) as f64 * h);
                        let (ea, eb) = (row[i] as f64, row[i + 1] as f64);
                        h * (ea * (2.0 * ma + mb) + eb * (ma + 2.0 * mb)) / 6.0
                    })
                    .sum();
                (2.0 * sum) as f32
            })
            .collect();
        Table { values, averages }
    }

    /// Linear interpolation weights of `x ∈ [0, 1]` over `n` nodes.
    #[inline]
    fn locate(x: f32, n: usize) -> (usize, f32) {
        let t = x.clamp(0.0, 1.0) * (n - 1) as f32;
        let i = (t as usize).min(n - 2);
        (i, t - i as f32)
    }

    /// `E(μ, roughness)`, bilinear.
    #[inline]
    pub fn lookup(&self, mu: f32, roughness: f32) -> f32 {
        let (i, fi) = Self::locate(mu, N_MU);
        let (j, fj) = Self::locate(roughness, N_ROUGH);
        let v = |j: usize, i: usize| self.values[j * N_MU + i];
        let lo = v(j, i) + fi * (v(j, i + 1) - v(j, i));
        let hi = v(j + 1, i) + fi * (v(j + 1, i + 1) - v(j + 1, i));
        lo + fj * (hi - lo)
    }

    /// `Ē(roughness)`, linear between nodes (the exact average of the bilinear `E`).
    #[inline]
    pub fn average(&self, roughness: f32) -> f32 {
        let (j, fj) = Self::locate(roughness, N_ROUGH);
        self.averages[j] + fj * (self.averages[j + 1] - self.averages[j])
    }
}

/// The GGX reflection tables `A` (weight of `F₀`) and `B` (weight of `F₉₀`).
#[derive(Debug)]
pub struct GgxAlbedo {
    pub a: Table,
    pub b: Table,
}

/// The GGX reflection tables (read at first use).
pub fn ggx() -> &'static GgxAlbedo {
    static TABLES: OnceLock<GgxAlbedo> = OnceLock::new();
    TABLES.get_or_init(|| GgxAlbedo { a: shipped(GGX_A), b: shipped(GGX_B) })
}

/// The glass albedo at one relative index: the two neighbouring `η` slices and the weight
/// between them.
#[derive(Clone, Copy, Debug)]
pub struct GlassAlbedo {
    lo: &'static Table,
    hi: &'static Table,
    t: f32,
}

impl GlassAlbedo {
    /// `E(μ, roughness)`.
    #[inline]
    pub fn lookup(&self, mu: f32, roughness: f32) -> f32 {
        let a = self.lo.lookup(mu, roughness);
        a + self.t * (self.hi.lookup(mu, roughness) - a)
    }

    /// `Ē(roughness)`.
    #[inline]
    pub fn average(&self, roughness: f32) -> f32 {
        let a = self.lo.average(roughness);
        a + self.t * (self.hi.average(roughness) - a)
    }
}

/// The glass albedo for light arriving from the side where the relative index of the other
/// side is `eta` (`> 1`: entering the denser medium).
pub fn glass(eta: f32) -> GlassAlbedo {
    static SLICES: [[OnceLock<Table>; N_ETA]; 2] = [const { [const { OnceLock::new() }; N_ETA] }; 2];
    let denser = eta < 1.0;
    let ratio = if denser { 1.0 / eta } else { eta };
    let x = ((ratio - 1.0) / (MAX_ETA - 1.0)).clamp(0.0, 1.0) * (N_ETA - 1) as f32;
    let k = (x as usize).min(N_ETA - 2);
    let slice = |k: usize| -> &'static Table {
        SLICES[denser as usize][k].get_or_init(|| shipped(GLASS + denser as usize * N_ETA + k))
    };
    GlassAlbedo { lo: slice(k), hi: slice(k + 1), t: x - k as f32 }
}

/// The sheen albedo table over `(μ, sheen roughness)` (read at first use).
pub fn sheen() -> &'static Table {
    static TABLE: OnceLock<Table> = OnceLock::new();
    TABLE.get_or_init(|| shipped(SHEEN))
}

/// The shipped tables' indices (module docs): GGX `A`, `B`, the glass slices (from the less
/// dense side, `η` nodes 0 … N_ETA − 1, then from the denser side), sheen.
const GGX_A: usize = 0;
const GGX_B: usize = 1;
const GLASS: usize = 2;
const SHEEN: usize = GLASS + 2 * N_ETA;
/// How many tables are shipped.
pub(crate) const N_TABLES: usize = SHEEN + 1;

/// The shipped values (module docs).
const SHIPPED: &[u8] = include_bytes!("albedo_tables.bin");
const _: () = assert!(SHIPPED.len() == N_TABLES * N_MU * N_ROUGH * 4, "albedo_tables.bin is not the tables' size");

/// Table `index` as shipped.
fn shipped(index: usize) -> Table {
    let size = N_MU * N_ROUGH * 4;
    let bytes = &SHIPPED[index * size..(index + 1) * size];
    Table::from_values(bytes.chunks_exact(4).map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]])).collect())
}

/// The tables by quadrature (module docs): compiled for the tests, which compare the shipped
/// tables with them and write them.
#[cfg(test)]
pub(crate) mod quadrature {
    use super::super::ggx::Ggx;
    use super::super::{fresnel, glass, sheen};
    use super::{GGX_A, GGX_B, GLASS, MAX_ETA, N_ETA, N_MU, N_ROUGH, SHEEN, Table};
    use crate::math::{Vec2, Vec3};
    use crate::sampling::quadrature::gauss_legendre;

    /// The smallest `μ` integrated (at grazing the albedo is continuous, `μ = 0` itself is singular).
    const MU_MIN: f32 = 1e-3;

    /// The glass tables are integrated from this roughness up (smoother glass is a delta interface).
    const GLASS_MIN_ROUGHNESS: f32 = 0.02;

    /// Fills a table with `f(μ, roughness)` at the nodes.
    pub(super) fn build(f: impl Fn(f32, f32) -> f64) -> Table {
        let mut values = vec![0.0; N_MU * N_ROUGH];
        for j in 0..N_ROUGH {
            let r = j as f32 / (N_ROUGH - 1) as f32;
            for i in 0..N_MU {
                let mu = (i as f32 / (N_MU - 1) as f32).max(MU_MIN);
                values[j * N_MU + i] = f(mu, r) as f32;
            }
        }
        Table::from_values(values)
    }

    /// `∫ over the visible normals of wo` of `g(h)`, by the `n × n` Gauss–Legendre rule.
    pub(super) fn integrate_visible(
        ggx: Ggx,
        wo: Vec3,
        rule: &(Vec<f64>, Vec<f64>),
        mut g: impl FnMut(Vec3) -> f64,
    ) -> f64 {
        let (x, w) = rule;
        let mut sum = 0.0;
        for (xa, wa) in x.iter().zip(w) {
            for (xb, wb) in x.iter().zip(w) {
                let h = ggx.sample_visible(wo, Vec2::new(*xa as f32, *xb as f32));
                sum += wa * wb * g(h);
            }
        }
        sum
    }

    /// The direction at `cos θ = mu` in the `xz` plane.
    #[inline]
    pub(super) fn at(mu: f32) -> Vec3 {
        Vec3::new((1.0 - mu * mu).max(0.0).sqrt(), 0.0, mu)
    }

    /// The GGX reflection table `A` (`which` = 0) or `B` (1), by quadrature.
    fn ggx_part(which: usize) -> Table {
        let rule = gauss_legendre(48);
        // The albedo for F = F₀ (which = 0: weight 1 − s) or F = F₉₀ (which = 1: weight s).
        build(|mu: f32, r: f32| -> f64 {
            if r == 0.0 {
                // The smooth limit: a mirror with Schlick's F at θo.
                let s = fresnel::schlick_weight(mu) as f64;
                return if which == 0 { 1.0 - s } else { s };
            }
            let ggx = Ggx::from_roughness(r);
            let wo = at(mu);
            let g1 = ggx.g1(wo) as f64;
            integrate_visible(ggx, wo, &rule, |h| {
                let wi = 2.0 * wo.dot(h) * h - wo;
                if wi.z <= 0.0 {
                    return 0.0;
                }
                let w = ggx.g2(wo, wi) as f64 / g1;
                let s = fresnel::schlick_weight(wo.dot(h)) as f64;
                if which == 0 { w * (1.0 - s) } else { w * s }
            })
        })
    }

    /// The glass table at `η` node `k`, for light from the denser side or not, by quadrature.
    fn glass_slice(denser: bool, k: usize) -> Table {
        let node = 1.0 + (MAX_ETA - 1.0) * k as f32 / (N_ETA - 1) as f32;
        let eta = if denser { 1.0 / node } else { node };
        let rule = gauss_legendre(32);
        build(|mu, r| {
            let ggx = Ggx::from_roughness(r.max(GLASS_MIN_ROUGHNESS));
            let wo = at(mu);
            let g1 = ggx.g1(wo) as f64;
            integrate_visible(ggx, wo, &rule, |h| glass::single_scattering_weight(ggx, eta, wo, h) as f64 / g1)
        })
    }

    /// The sheen table, by quadrature.
    fn sheen_table() -> Table {
        let (x, w) = gauss_legendre(64);
        build(|mu, r| {
            let lobe = sheen::Sheen::new(Vec3::ONE, r);
            let wo = at(mu);
            let mut sum = 0.0;
            // φ over [0, π] (the lobe is symmetric about the plane of wo), doubled.
            for (xc, wc) in x.iter().zip(&w) {
                let ci = *xc as f32;
                let si = (1.0 - ci * ci).max(0.0).sqrt();
                for (xp, wp) in x.iter().zip(&w) {
                    let phi = std::f32::consts::PI * *xp as f32;
                    let wi = Vec3::new(si * phi.cos(), si * phi.sin(), ci);
                    sum += wc * wp * (lobe.value(wo, wi) * ci) as f64;
                }
            }
            sum * 2.0 * std::f64::consts::PI
        })
    }

    /// Table `index` (in the shipped order) computed by quadrature.
    pub(crate) fn computed(index: usize) -> Table {
        match index {
            GGX_A | GGX_B => ggx_part(index - GGX_A),
            SHEEN => sheen_table(),
            _ => {
                let k = index - GLASS;
                glass_slice(k >= N_ETA, k % N_ETA)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every table as `quadrature::computed` gives it, in the shipped order.
    fn computed_tables() -> Vec<Table> {
        use rayon::prelude::*;
        (0..N_TABLES).into_par_iter().map(quadrature::computed).collect()
    }

    /// Writes `albedo_tables.bin` again (module docs).
    #[test]
    #[ignore = "writes src/bsdf/albedo_tables.bin (make albedo-tables): after a change to a lobe or the quadrature"]
    fn write_albedo_tables() {
        let bytes: Vec<u8> =
            computed_tables().iter().flat_map(|t| t.values.iter().flat_map(|v| v.to_le_bytes())).collect();
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/src/bsdf/albedo_tables.bin");
        std::fs::write(path, bytes).unwrap();
    }

    /// The shipped tables, as `shipped` reads them, are what the quadrature gives (to the last
    /// bit on the machine that wrote them; within 1e-6 where another libm rounds a sine
    /// differently), values and averages.
    #[test]
    fn shipped_tables_are_the_quadrature() {
        let t = std::time::Instant::now();
        let fresh = computed_tables();
        println!("all {N_TABLES} tables by quadrature: {:?}", t.elapsed());
        let (mut worst, mut differ, mut count) = (0.0f32, 0, 0);
        for (index, computed) in fresh.iter().enumerate() {
            let shipped = super::shipped(index);
            let pairs =
                shipped.values.iter().zip(&computed.values).chain(shipped.averages.iter().zip(&computed.averages));
            for (i, (&a, &b)) in pairs.enumerate() {
                assert!(a.is_finite(), "shipped table {index}, value {i} is {a}");
                differ += usize::from(a.to_bits() != b.to_bits());
                worst = worst.max((a - b).abs());
                count += 1;
            }
        }
        println!("{differ} of {count} values and averages differ in their bits, by at most {worst:e}");
        assert!(worst <= 1e-6, "albedo_tables.bin is stale (largest difference {worst:e}): see the module docs");
    }

    #[test]
    fn tables_build() {
        let t = std::time::Instant::now();
        let g = ggx();
        let t_ggx = t.elapsed();
        let t = std::time::Instant::now();
        let _ = glass(1.5);
        let t_glass = t.elapsed();
        let t = std::time::Instant::now();
        let s = sheen();
        let t_sheen = t.elapsed();
        println!("tables read: GGX {t_ggx:?}, glass (two η slices) {t_glass:?}, sheen {t_sheen:?}");
        // Sanity: a smooth white mirror reflects everything; rough GGX loses energy at grazing.
        assert!((g.a.lookup(0.7, 0.0) + g.b.lookup(0.7, 0.0) - 1.0).abs() < 1e-6);
        let e = g.a.lookup(0.2, 1.0) + g.b.lookup(0.2, 1.0);
        assert!(e < 0.8 && e > 0.3, "{e}");
        assert!(s.lookup(0.5, 0.5) > 0.0 && s.lookup(0.5, 0.5) < 1.0);
    }
}

#[cfg(test)]
mod glass_table_tests {
    use super::*;

    /// The glass table at a point between nodes against the quadrature done directly there
    /// (figures from an independent numpy quadrature: E(0.15, r = 0.25, η = 1.5) = 0.9525,
    /// from inside 0.9167).
    #[test]
    fn glass_table_matches_direct_quadrature() {
        let rule = crate::sampling::quadrature::gauss_legendre(32);
        for (eta, want) in [(1.5f32, 0.9525f32), (1.0 / 1.5, 0.9167)] {
            let ggx = super::super::ggx::Ggx::from_roughness(0.25);
            let wo = quadrature::at(0.15);
            let g1 = ggx.g1(wo) as f64;
            let direct = quadrature::integrate_visible(ggx, wo, &rule, |h| {
                super::super::glass::single_scattering_weight(ggx, eta, wo, h) as f64 / g1
            });
            let t = glass(eta);
            println!("η {eta}: table {} direct {direct} numpy {want}, Ē {}", t.lookup(0.15, 0.25), t.average(0.25));
            assert!((direct as f32 - want).abs() < 2e-3);
            assert!((t.lookup(0.15, 0.25) - want).abs() < 5e-3, "table {}", t.lookup(0.15, 0.25));
        }
    }
}
