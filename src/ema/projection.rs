//! LSFD by normal equations on cached projections, for scoring many pole
//! sets of one FRF matrix cheaply (the Bayesian-optimization steps).
//!
//! The LSFD model of a channel c (see [`super::lsfd`]) is linear in real
//! coefficients x over complex basis columns b_k(ω): per pole λ the pair
//! p + q and j(p − q) with p = 1/(jω − λ), q = 1/(jω − λ*), then −1/ω² and 1
//! for the lower and upper residuals. With s_{k,c} = Σ_f H_c(ω_f)* b_k(ω_f)
//! and the Gram matrix G_{kl} = Re Σ_f b_k* b_l (real),
//!
//! G x_c = Re s_c,   RSS_c = ‖H_c‖² − x_cᵀ Re s_c,
//! FRAC_c = |x_cᵀ s_c|² / (‖H_c‖² · x_cᵀ G x_c)   (eq. 2.66),
//!
//! and dropping the columns S of one pole raises RSS_c by
//! ΔRSS_{c,S} = x_{c,S}ᵀ [(G⁻¹)_{SS}]⁻¹ x_{c,S} (partitioned inverse). The
//! projections s of a pole touch every line of every channel once and are
//! cached by pole, as are the Gram entries of pole pairs; a new pole set then
//! costs O(k² n_ch + k³) instead of a pass over the data.
//!
//! A pole's columns over the lines are kept only while they fit in
//! [`COLUMN_BUDGET`] bytes (least recently used go first) and recomputed when
//! a new Gram entry needs them; what every later fit reads — the
//! projections s and the entries against the residual columns — is kept for
//! every pole. On the 51,201-line beam the columns of every pole a search
//! visits had taken 446 MB.
//!
//! Columns are scaled to unit norm before the Cholesky factorization; a
//! pivot below 10⁻¹⁰ (a column within 10⁻⁵ rad of the span of the previous
//! ones: numerically coincident poles) drops that pole and is reported.

use super::FrfData;
use num_complex::Complex64;
use rayon::prelude::*;
use std::collections::HashMap;
use std::f64::consts::PI;

/// Pivot below which a scaled column counts as dependent.
const DEPENDENT_PIVOT: f64 = 1e-10;

/// Bytes of pole columns kept between fits (at least [`MIN_KEPT`] poles').
pub const COLUMN_BUDGET: usize = 48 << 20;
/// Poles whose columns are kept, whatever the budget.
const MIN_KEPT: usize = 16;

/// What every fit reads of one pole: per column (p + q, j(p − q)) its
/// projections s on the channels and its Gram entries with the two residual
/// columns.
struct PoleProjection {
    s: [Vec<Complex64>; 2],
    residual_gram: [[f64; 2]; 2],
}

/// The planar (re, im) columns p + q and j(p − q) of one pole, with the
/// tick of their last use.
struct Planar {
    cols: [(Vec<f64>, Vec<f64>); 2],
    used: u64,
}

/// A basis column over the lines (planar) and its projections on the channels.
struct Column {
    re: Vec<f64>,
    im: Vec<f64>,
    /// s_c = Σ_f H_c* b for every channel.
    s: Vec<Complex64>,
}

type Key = (u64, u64);

fn key(l: Complex64) -> Key {
    (l.re.to_bits(), l.im.to_bits())
}

/// Cached projections of one FRF matrix.
pub struct Projector<'a> {
    data: &'a FrfData,
    n_ch: usize,
    /// Channel-major planar copies of H.
    hr: Vec<f64>,
    hi: Vec<f64>,
    h2: Vec<f64>,
    omega: Vec<f64>,
    residuals: [Column; 2],
    /// Gram entries of the residual columns, [lower, upper]².
    residual_gram: [[f64; 2]; 2],
    poles: HashMap<Key, PoleProjection>,
    /// The columns of recently used poles (bounded, [`COLUMN_BUDGET`]).
    planar: HashMap<Key, Planar>,
    /// How many poles' columns are kept.
    cap: usize,
    tick: u64,
    gram: HashMap<(Key, Key), [f64; 4]>,
}

/// Σ a·b with four accumulators (vectorizes; fixed order, so deterministic).
fn dot(a: &[f64], b: &[f64]) -> f64 {
    let mut acc = [0.0f64; 4];
    let (ca, cb) = (a.chunks_exact(4), b.chunks_exact(4));
    let (ra, rb) = (ca.remainder(), cb.remainder());
    for (x, y) in ca.zip(cb) {
        for k in 0..4 {
            acc[k] += x[k] * y[k];
        }
    }
    let tail: f64 = ra.iter().zip(rb).map(|(x, y)| x * y).sum();
    (acc[0] + acc[1]) + (acc[2] + acc[3]) + tail
}

/// The least-squares solution for one pole set.
#[derive(Clone, Debug)]
pub struct GramFit {
    /// Number of columns: 2 per pole, then the two residuals.
    pub n_col: usize,
    /// Coefficients, x[c · n_col + k].
    pub x: Vec<f64>,
    /// (G⁻¹) in unscaled units, row-major n_col × n_col.
    pub ginv: Vec<f64>,
    /// Residual sum of squares per channel.
    pub rss: Vec<f64>,
    /// FRAC per channel.
    pub frac: Vec<f64>,
}

impl GramFit {
    /// Mean FRAC over the channels.
    pub fn mean_frac(&self) -> f64 {
        self.frac.iter().sum::<f64>() / self.frac.len().max(1) as f64
    }

    /// Complex residue of pole `k` at channel `c` (the coefficient of p).
    pub fn residue(&self, k: usize, c: usize) -> Complex64 {
        Complex64::new(
            self.x[c * self.n_col + 2 * k],
            self.x[c * self.n_col + 2 * k + 1],
        )
    }

    /// ΔRSS_{c} of dropping pole `k`, for every channel.
    pub fn delta_rss(&self, k: usize) -> Vec<f64> {
        let n = self.n_col;
        let (a, b) = (2 * k, 2 * k + 1);
        let (g11, g12, g22) = (
            self.ginv[a * n + a],
            self.ginv[a * n + b],
            self.ginv[b * n + b],
        );
        let det = g11 * g22 - g12 * g12;
        if det <= 0.0 || !det.is_finite() {
            return vec![0.0; self.rss.len()];
        }
        // [(G⁻¹)_SS]⁻¹ = [g22, −g12; −g12, g11] / det.
        (0..self.rss.len())
            .map(|c| {
                let (u, v) = (self.x[c * n + a], self.x[c * n + b]);
                ((g22 * u * u - 2.0 * g12 * u * v + g11 * v * v) / det).max(0.0)
            })
            .collect()
    }

    /// Variance factor of pole `k`'s complex residue: Var(R) = σ²/2 · (G⁻¹_aa + G⁻¹_bb).
    pub fn residue_variance_factor(&self, k: usize) -> f64 {
        let n = self.n_col;
        0.5 * (self.ginv[2 * k * n + 2 * k] + self.ginv[(2 * k + 1) * n + 2 * k + 1])
    }
}

/// Outcome of [`Projector::fit`]: the fit, or the index of a pole whose
/// columns are numerically dependent on the earlier ones.
pub enum FitOutcome {
    Fit(GramFit),
    Dependent(usize),
}

impl<'a> Projector<'a> {
    pub fn new(data: &'a FrfData) -> Projector<'a> {
        let nf = data.n_lines();
        let n_ch = data.n_out() * data.n_ref();
        let hr: Vec<f64> = data.h.iter().map(|v| v.re).collect();
        let hi: Vec<f64> = data.h.iter().map(|v| v.im).collect();
        let h2 = (0..n_ch)
            .map(|c| {
                dot(&hr[c * nf..(c + 1) * nf], &hr[c * nf..(c + 1) * nf])
                    + dot(&hi[c * nf..(c + 1) * nf], &hi[c * nf..(c + 1) * nf])
            })
            .collect();
        let omega: Vec<f64> = data.frequencies_hz.iter().map(|f| 2.0 * PI * f).collect();
        let mut p = Projector {
            data,
            n_ch,
            hr,
            hi,
            h2,
            omega,
            residuals: [empty(), empty()],
            residual_gram: [[0.0; 2]; 2],
            poles: HashMap::new(),
            planar: HashMap::new(),
            cap: (COLUMN_BUDGET / (32 * nf.max(1))).max(MIN_KEPT),
            tick: 0,
            gram: HashMap::new(),
        };
        let lower: Vec<f64> = p.omega.iter().map(|w| -1.0 / (w * w)).collect();
        let upper = vec![1.0; nf];
        let zero = vec![0.0; nf];
        p.residuals = [p.column(lower, zero.clone()), p.column(upper, zero)];
        for a in 0..2 {
            for b in 0..2 {
                let (ca, cb) = (&p.residuals[a], &p.residuals[b]);
                p.residual_gram[a][b] = dot(&ca.re, &cb.re) + dot(&ca.im, &cb.im);
            }
        }
        p
    }

    /// ‖H_c‖² per channel.
    pub fn h_norm2(&self) -> &[f64] {
        &self.h2
    }

    /// The column b(ω) with planar parts `re`, `im`, whitened like the data
    /// (u·b, [`super::whitening`]), and its projections.
    fn column(&self, mut re: Vec<f64>, mut im: Vec<f64>) -> Column {
        self.whiten(&mut re, &mut im);
        let s = self.projections(&re, &im);
        Column { re, im, s }
    }

    fn whiten(&self, re: &mut [f64], im: &mut [f64]) {
        for ((r, i), u) in re.iter_mut().zip(im.iter_mut()).zip(&self.data.line_weight) {
            *r *= u;
            *i *= u;
        }
    }

    /// s_c = Σ_f H_c* b for every channel.
    fn projections(&self, re: &[f64], im: &[f64]) -> Vec<Complex64> {
        let nf = self.data.n_lines();
        (0..self.n_ch)
            .into_par_iter()
            .map(|c| {
                let (hr, hi) = (
                    &self.hr[c * nf..(c + 1) * nf],
                    &self.hi[c * nf..(c + 1) * nf],
                );
                Complex64::new(dot(hr, re) + dot(hi, im), dot(hr, im) - dot(hi, re))
            })
            .collect()
    }

    /// The whitened planar columns p + q and j(p − q) of pole λ.
    fn planar_columns(&self, l: Complex64) -> [(Vec<f64>, Vec<f64>); 2] {
        let nf = self.data.n_lines();
        let (mut ar, mut ai, mut br, mut bi) =
            (vec![0.0; nf], vec![0.0; nf], vec![0.0; nf], vec![0.0; nf]);
        for (f, &w) in self.omega.iter().enumerate() {
            let jw = Complex64::new(0.0, w);
            let p = 1.0 / (jw - l);
            let q = 1.0 / (jw - l.conj());
            let a = p + q;
            let b = Complex64::new(0.0, 1.0) * (p - q);
            (ar[f], ai[f], br[f], bi[f]) = (a.re, a.im, b.re, b.im);
        }
        self.whiten(&mut ar, &mut ai);
        self.whiten(&mut br, &mut bi);
        [(ar, ai), (br, bi)]
    }

    /// The projections and residual Gram entries of pole λ, computed once.
    fn ensure(&mut self, l: Complex64) {
        if self.poles.contains_key(&key(l)) {
            return;
        }
        self.keep_planar(l, None);
        let cols = &self.planar[&key(l)].cols;
        let proj = PoleProjection {
            s: [
                self.projections(&cols[0].0, &cols[0].1),
                self.projections(&cols[1].0, &cols[1].1),
            ],
            residual_gram: std::array::from_fn(|i| {
                std::array::from_fn(|j| {
                    let r = &self.residuals[j];
                    dot(&cols[i].0, &r.re) + dot(&cols[i].1, &r.im)
                })
            }),
        };
        self.poles.insert(key(l), proj);
    }

    /// Makes the planar columns of λ present (recomputed if they were
    /// dropped) and most recently used, dropping the least recently used
    /// others (never `also`) beyond the budget.
    fn keep_planar(&mut self, l: Complex64, also: Option<Complex64>) {
        self.tick += 1;
        let tick = self.tick;
        if let Some(p) = self.planar.get_mut(&key(l)) {
            p.used = tick;
            return;
        }
        let cols = self.planar_columns(l);
        while self.planar.len() >= self.cap {
            let keep = also.map(key);
            let Some(oldest) = self
                .planar
                .iter()
                .filter(|(k, _)| Some(**k) != keep)
                .min_by_key(|(_, p)| p.used)
                .map(|(k, _)| *k)
            else {
                break;
            };
            self.planar.remove(&oldest);
        }
        self.planar.insert(key(l), Planar { cols, used: tick });
    }

    /// Gram entries of the column pairs of poles `a` and `b`.
    fn pole_gram(&mut self, a: Complex64, b: Complex64) -> [f64; 4] {
        let k = (key(a), key(b));
        if let Some(g) = self.gram.get(&k) {
            return *g;
        }
        self.keep_planar(a, None);
        self.keep_planar(b, Some(a));
        let (ca, cb) = (&self.planar[&key(a)].cols, &self.planar[&key(b)].cols);
        let mut g = [0.0; 4];
        for i in 0..2 {
            for j in 0..2 {
                g[i * 2 + j] = dot(&ca[i].0, &cb[j].0) + dot(&ca[i].1, &cb[j].1);
            }
        }
        self.gram.insert(k, g);
        g
    }

    /// The residuals H_c − Σ_k x_{c,k} b_k of `fit`, the fit of the poles
    /// `lambdas` in that order, on the `channels`, over every line and in
    /// the analysed (whitened) units.
    pub fn residuals(
        &mut self,
        lambdas: &[Complex64],
        fit: &GramFit,
        channels: &[usize],
    ) -> Vec<Vec<Complex64>> {
        let nf = self.data.n_lines();
        let n = fit.n_col;
        let mut r: Vec<Vec<Complex64>> = channels
            .iter()
            .map(|&c| {
                (c * nf..(c + 1) * nf)
                    .map(|i| Complex64::new(self.hr[i], self.hi[i]))
                    .collect()
            })
            .collect();
        let mut subtract = |re: &[f64], im: &[f64], col: usize| {
            for (rc, &c) in r.iter_mut().zip(channels) {
                let x = fit.x[c * n + col];
                for ((v, a), b) in rc.iter_mut().zip(re).zip(im) {
                    *v -= Complex64::new(a * x, b * x);
                }
            }
        };
        for (a, &l) in lambdas.iter().enumerate() {
            self.keep_planar(l, None);
            for (i, (re, im)) in self.planar[&key(l)].cols.iter().enumerate() {
                subtract(re, im, 2 * a + i);
            }
        }
        for (i, col) in self.residuals.iter().enumerate() {
            subtract(&col.re, &col.im, 2 * lambdas.len() + i);
        }
        r
    }

    /// Least squares for the poles `lambdas` (positive imaginary parts).
    pub fn fit(&mut self, lambdas: &[Complex64]) -> FitOutcome {
        for &l in lambdas {
            self.ensure(l);
        }
        let np = lambdas.len();
        let n = 2 * np + 2;
        let mut g = vec![0.0; n * n];
        for a in 0..np {
            for b in a..np {
                let e = self.pole_gram(lambdas[a], lambdas[b]);
                for i in 0..2 {
                    for j in 0..2 {
                        g[(2 * a + i) * n + 2 * b + j] = e[i * 2 + j];
                        g[(2 * b + j) * n + 2 * a + i] = e[i * 2 + j];
                    }
                }
            }
        }
        // Entries against the residual columns: cached per pole, and
        // between the residuals themselves.
        for a in 0..n {
            for b in a.max(2 * np)..n {
                let v = if a < 2 * np {
                    self.poles[&key(lambdas[a / 2])].residual_gram[a % 2][b - 2 * np]
                } else {
                    self.residual_gram[a - 2 * np][b - 2 * np]
                };
                g[a * n + b] = v;
                g[b * n + a] = v;
            }
        }
        let cols: Vec<&Vec<Complex64>> = lambdas
            .iter()
            .flat_map(|l| self.poles[&key(*l)].s.iter())
            .chain(self.residuals.iter().map(|r| &r.s))
            .collect();
        let scale: Vec<f64> = (0..n)
            .map(|k| 1.0 / g[k * n + k].max(1e-300).sqrt())
            .collect();
        let mut l = vec![0.0; n * n];
        for a in 0..n {
            for b in 0..n {
                l[a * n + b] = g[a * n + b] * scale[a] * scale[b];
            }
        }
        if let Some(col) = cholesky_pivot_check(&mut l, n) {
            if np > 0 {
                // A dependent residual column is blamed on the last pole.
                return FitOutcome::Dependent((col / 2).min(np - 1));
            }
            return FitOutcome::Fit(GramFit {
                n_col: n,
                x: vec![0.0; n * self.n_ch],
                ginv: vec![0.0; n * n],
                rss: self.h2.clone(),
                frac: vec![0.0; self.n_ch],
            });
        }
        // (D G D)⁻¹ = L⁻ᵀ L⁻¹, then G⁻¹ = D (DGD)⁻¹ D.
        let linv = lower_inverse(&l, n);
        let mut ginv = vec![0.0; n * n];
        for a in 0..n {
            for b in 0..=a {
                let v: f64 = (a.max(b)..n)
                    .map(|k| linv[k * n + a] * linv[k * n + b])
                    .sum();
                ginv[a * n + b] = v * scale[a] * scale[b];
                ginv[b * n + a] = ginv[a * n + b];
            }
        }
        let per: Vec<(Vec<f64>, f64, f64)> = (0..self.n_ch)
            .into_par_iter()
            .map(|c| {
                let r: Vec<f64> = cols.iter().map(|k| k[c].re).collect();
                let x: Vec<f64> = (0..n)
                    .map(|a| (0..n).map(|b| ginv[a * n + b] * r[b]).sum())
                    .collect();
                let xr: f64 = x.iter().zip(&r).map(|(u, v)| u * v).sum();
                let xs: Complex64 = x.iter().zip(&cols).map(|(u, k)| k[c] * *u).sum();
                let h2 = self.h2[c];
                let rss = (h2 - xr).max(0.0);
                let frac = if h2 > 0.0 && xr > 0.0 {
                    (xs.norm_sqr() / (h2 * xr)).min(1.0)
                } else {
                    0.0
                };
                (x, rss, frac)
            })
            .collect();
        let mut x = Vec::with_capacity(n * self.n_ch);
        let (mut rss, mut frac) = (Vec::with_capacity(self.n_ch), Vec::with_capacity(self.n_ch));
        for (xc, r, f) in per {
            x.extend(xc);
            rss.push(r);
            frac.push(f);
        }
        FitOutcome::Fit(GramFit {
            n_col: n,
            x,
            ginv,
            rss,
            frac,
        })
    }
}

fn empty() -> Column {
    Column {
        re: Vec::new(),
        im: Vec::new(),
        s: Vec::new(),
    }
}

/// Cholesky in place (lower, row-major) of a unit-diagonal matrix; returns
/// the first column whose pivot falls below [`DEPENDENT_PIVOT`].
fn cholesky_pivot_check(a: &mut [f64], n: usize) -> Option<usize> {
    for j in 0..n {
        let mut d = a[j * n + j];
        for k in 0..j {
            d -= a[j * n + k] * a[j * n + k];
        }
        if d.is_nan() || d <= DEPENDENT_PIVOT {
            return Some(j);
        }
        let d = d.sqrt();
        a[j * n + j] = d;
        for i in j + 1..n {
            let mut s = a[i * n + j];
            for k in 0..j {
                s -= a[i * n + k] * a[j * n + k];
            }
            a[i * n + j] = s / d;
        }
        for k in j + 1..n {
            a[j * n + k] = 0.0;
        }
    }
    None
}

/// Inverse of a lower-triangular matrix (row-major).
fn lower_inverse(l: &[f64], n: usize) -> Vec<f64> {
    let mut inv = vec![0.0; n * n];
    for j in 0..n {
        inv[j * n + j] = 1.0 / l[j * n + j];
        for i in j + 1..n {
            let s: f64 = (j..i).map(|k| l[i * n + k] * inv[k * n + j]).sum();
            inv[i * n + j] = -s / l[i * n + i];
        }
    }
    inv
}

#[cfg(test)]
mod tests;
