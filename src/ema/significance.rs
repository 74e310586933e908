//! Which roots are modes: duplicates removed by their own rule, then
//! backward elimination of roots the data do not support, then the number of
//! modes a repeated root holds — each decision recorded with its reason.
//!
//! **Noise.** σ_c² of channel c is the larger of the data's noise floor
//! ([`super::noise::noise_variance`]) and the residual variance of the
//! current fit, 2 RSS_c/(2 n_f − n_col) (model error counts as noise, so a
//! pole fitting it is not called significant).
//!
//! **Significance** of root k with the fit of all remaining roots
//! ([`super::projection`]): per channel t_c = 2 ΔRSS_{c,k}/σ_c², χ²(2)
//! under "no mode here" for a fixed pole; two more degrees of freedom
//! for the pole chosen from the data give
//!
//! T_sum = Σ_c t_c  vs  χ²_{2 n_ch + 2}(1 − α/(2 n_r)),
//! T_max = max_c t_c  vs  χ²_4(1 − α/(2 n_r n_ch)),
//!
//! (Bonferroni over the n_r roots and the two statistics; T_sum finds global
//! modes seen weakly everywhere, T_max local modes seen strongly at a few
//! sensors). While the least significant root, by max(T_sum/thr, T_max/thr),
//! fails both, it is removed and the rest refitted. A root that keeps a
//! prominent CMIF peak of its own ([`super::peak_evidence`]) is exempt: the
//! peak, tested against the noise floor, is the evidence, while this test,
//! counting the misfit of strong peaks as noise everywhere, is blind to a
//! weak mode between strong ones (real data: the 118.9 Hz mode of the UFSC
//! beam).
//!
//! **Shared peaks.** Before the elimination, roots on another root's CMIF
//! peak without a peak of their own are removed ([`super::peak_evidence`]).
//!
//! **Duplicates** are two roots on no two different CMIF peaks within each other's half-power band,
//! |f_a − f_b| ≤ max(ζ_a f_a, ζ_b f_b), whose participation vectors
//! (with ≥ 2 references) and shapes both have MAC ≥ 0.9: one mode seen twice.
//! The root with the shorter stable column is dropped. Numerically coincident
//! poles (dependent LSFD columns) are duplicates by definition.
//!
//! **Multiplicity** of a root with m ≥ 2: the residue matrix R (outputs ×
//! references), whitened by its standard deviation σ_c² · (G⁻¹_aa + G⁻¹_bb)/2,
//! holds as many modes as singular values s_k with s_k² above four times the
//! noise edge (√n_out + √n_ref)² (Marchenko–Pastur; Edelman 1988). The
//! whitening is separable (a_o·b_i, [`separable_scale`]) so that a simple
//! mode's rank-1 residue stays rank 1, and the edge that of the noise left
//! over, channel by channel ([`noise_edge`]).

use super::hermitian::left_singular;
use super::peak_evidence::{PeakEvidence, RootPeak};
use super::projection::{FitOutcome, GramFit, Projector};
use super::roots::Root;
use super::PoleOrder;
use crate::metrics::mac;
use num_complex::Complex64;
use statrs::distribution::{ChiSquared, ContinuousCDF};

/// MAC above which two shapes or participation vectors are the same.
const SAME_SHAPE: f64 = 0.9;

/// Why a root is not reported as it came from clustering.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
#[serde(tag = "reason", rename_all = "snake_case")]
pub enum Reason {
    /// The same mode as the kept root at `of_hz`.
    Duplicate { of_hz: f64 },
    /// Its contribution to the fit is within what the noise explains.
    NotSignificant {
        t_sum: f64,
        threshold_sum: f64,
        t_max: f64,
        threshold_max: f64,
    },
    /// With its group's other poles refitted without it, the fit is as good
    /// within the noise ([`super::refine::nested_statistic`]).
    NotSignificantNested { t: f64, threshold: f64 },
    /// Fewer independent modes than the participation vectors suggested.
    MultiplicityReduced { from: usize, to: usize },
    /// On the CMIF peak of the stronger root at `of_hz` with no peak of its
    /// own ([`super::peak_evidence`]): a pole split off that mode.
    SamePeak { of_hz: f64 },
    /// Wider than [`crate::ema::search::CONSENSUS_MIN_LINES`] line
    /// spacings, significant by less than
    /// [`crate::ema::search::CONSENSUS_MAX_SCORE`] and held (within 1 %) by
    /// none of the `of` next-best selections of the search (screened): a
    /// mode of one hyperparameter point only.
    NoConsensus { of: usize },
    /// Kept for significance alone, by a `score` below the variance
    /// `inflation` of its ΔRSS by the residual's serial correlation around
    /// it ([`super::serial_correlation`]), and held by `support` of the `of`
    /// next-best selections, fewer than half: a root fitted to smooth model
    /// error.
    SerialCorrelation {
        score: f64,
        inflation: f64,
        support: usize,
        of: usize,
    },
    /// Refined to a frequency outside the analysed band.
    OutsideBand { band_hz: (f64, f64) },
    /// Lightly damped (ζ < 2 %) and kept for significance alone, on a stable
    /// column shorter than 0.3 of the median column (`peak_median_orders`)
    /// of the roots that hold a CMIF peak ([`super::selection`]).
    ShortColumn { peak_median_orders: usize },
    /// A stable column (≥ 5 orders) that holds poles of fewer than
    /// `min_orders` model orders (`min_cluster_fraction` of the orders
    /// considered): no mode candidate ([`super::clustering`]).
    SparseColumn { min_orders: usize },
    /// A stable column whose poles lie up to `spread` (relative frequency)
    /// from its median, beyond the cut `cluster_distance`: no mode
    /// candidate at this cut ([`super::clustering`]).
    WideColumn { spread: f64, cluster_distance: f64 },
}

/// One decision about a root.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Rejection {
    pub frequency_hz: f64,
    pub damping_ratio: f64,
    /// Height of its stable column (model orders).
    pub n_orders: usize,
    #[serde(flatten)]
    pub reason: Reason,
}

/// Why a root was kept.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
#[serde(tag = "accepted_by", rename_all = "snake_case")]
pub enum Acceptance {
    /// It keeps a prominent peak of the first CMIF curve at `peak_hz`
    /// ([`super::peak_evidence`]); `score` is its significance score
    /// max(T_sum/threshold, T_max/threshold) all the same.
    CmifPeak { peak_hz: f64, score: f64 },
    /// Its contribution to the fit stands above the noise (score ≥ 1);
    /// a root between peaks or sharing one with a second CMIF curve peak.
    Significance { score: f64 },
    /// Significant on a short stable column, and kept because the fit
    /// without it leaves the data peak at `peak_hz` unexplained, `ratio`×
    /// above the noise ([`super::residual::ResidualPeak::missing_mode`]).
    DataPeak {
        peak_hz: f64,
        ratio: f64,
        score: f64,
    },
}

impl Acceptance {
    /// Its significance score max(T_sum/threshold, T_max/threshold),
    /// whatever kept the root.
    pub fn score(&self) -> f64 {
        match self {
            Acceptance::CmifPeak { score, .. }
            | Acceptance::Significance { score }
            | Acceptance::DataPeak { score, .. } => *score,
        }
    }
}

/// The roots kept, their fit and what was removed.
#[derive(Clone, Debug)]
pub struct Validated {
    pub roots: Vec<Root>,
    /// Why each root was kept.
    pub accepted: Vec<Acceptance>,
    pub fit: GramFit,
    pub rejected: Vec<Rejection>,
}

/// Upper-tail quantile of χ²_k: x with P(X > x) = q, by bisection on the
/// survival function (accurate for tiny q, unlike 1 − cdf).
pub fn chi2_isf(k: f64, q: f64) -> f64 {
    let Ok(d) = ChiSquared::new(k) else {
        return f64::INFINITY;
    };
    let mut hi = k.max(1.0);
    while d.sf(hi) > q && hi < 1e12 {
        hi *= 2.0;
    }
    let mut lo = 0.0;
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if d.sf(mid) > q {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// Context of one validation.
pub struct Validation<'p, 'd> {
    pub projector: &'p mut Projector<'d>,
    pub orders: &'p [PoleOrder],
    /// Noise floor per channel.
    pub noise: &'p [f64],
    pub n_out: usize,
    pub n_ref: usize,
    pub n_lines: usize,
    /// Family-wise false-alarm probability α.
    pub alpha: f64,
    /// The CMIF peaks roots must earn a place on.
    pub evidence: &'p PeakEvidence,
}

impl Validation<'_, '_> {
    fn record(&self, r: &Root, reason: Reason) -> Rejection {
        let p = r.pole(self.orders);
        Rejection {
            frequency_hz: p.frequency_hz,
            damping_ratio: p.damping_ratio,
            n_orders: r.n_orders,
            reason,
        }
    }

    /// Fit, dropping numerically coincident roots (the shorter column goes).
    fn fit(&mut self, roots: &mut Vec<Root>, rejected: &mut Vec<Rejection>) -> GramFit {
        loop {
            let lambdas: Vec<Complex64> = roots.iter().map(|r| r.pole(self.orders).s).collect();
            match self.projector.fit(&lambdas) {
                FitOutcome::Fit(f) => return f,
                FitOutcome::Dependent(k) => {
                    let j = (0..roots.len())
                        .filter(|&j| j != k)
                        .min_by(|&a, &b| {
                            (lambdas[a] - lambdas[k])
                                .norm()
                                .total_cmp(&(lambdas[b] - lambdas[k]).norm())
                        })
                        .unwrap_or(k);
                    let drop = match roots[j].n_orders.cmp(&roots[k].n_orders) {
                        std::cmp::Ordering::Greater => k,
                        std::cmp::Ordering::Less => j,
                        std::cmp::Ordering::Equal => j.max(k),
                    };
                    let keep = if drop == k { j } else { k };
                    let of_hz = roots[keep].pole(self.orders).frequency_hz;
                    rejected.push(self.record(&roots[drop], Reason::Duplicate { of_hz }));
                    roots.remove(drop);
                }
            }
        }
    }

    /// Dominant shape of root k from its residues.
    fn shape(&self, fit: &GramFit, k: usize) -> Vec<Complex64> {
        let r: Vec<Complex64> = (0..self.n_out * self.n_ref)
            .map(|c| fit.residue(k, c))
            .collect();
        let (_, u) = left_singular(&r, self.n_out, self.n_ref);
        u.into_iter().next().unwrap_or_default()
    }

    /// One pass of the duplicate rule; true when a root was dropped.
    fn drop_duplicate(
        &self,
        roots: &mut Vec<Root>,
        fit: &GramFit,
        rejected: &mut Vec<Rejection>,
    ) -> bool {
        for a in 0..roots.len().saturating_sub(1) {
            let b = a + 1;
            let (pa, pb) = (roots[a].pole(self.orders), roots[b].pole(self.orders));
            let band = (pa.damping_ratio * pa.frequency_hz).max(pb.damping_ratio * pb.frequency_hz);
            if (pa.frequency_hz - pb.frequency_hz).abs() > band
                || roots[a].multiplicity > 1
                || roots[b].multiplicity > 1
            {
                continue;
            }
            if self.evidence.separate(
                (pa.frequency_hz, pa.damping_ratio),
                (pb.frequency_hz, pb.damping_ratio),
            ) {
                continue;
            }
            let same_participation =
                self.n_ref < 2 || mac(&pa.participation, &pb.participation) >= SAME_SHAPE;
            if !same_participation || mac(&self.shape(fit, a), &self.shape(fit, b)) < SAME_SHAPE {
                continue;
            }
            let (drop, keep) = if roots[b].n_orders > roots[a].n_orders {
                (a, b)
            } else {
                (b, a)
            };
            let of_hz = roots[keep].pole(self.orders).frequency_hz;
            rejected.push(self.record(&roots[drop], Reason::Duplicate { of_hz }));
            roots.remove(drop);
            return true;
        }
        false
    }

    /// Drops the weakest root that shares its CMIF peak with the root
    /// keeping it and has no peak of its own; true when one was dropped.
    fn drop_shared_peak(
        &self,
        roots: &mut Vec<Root>,
        fit: &GramFit,
        rejected: &mut Vec<Rejection>,
    ) -> bool {
        let peaks = root_peaks(self.orders, roots, fit, &self.sigma2(fit));
        let Some(&(drop, keep)) = self.evidence.shared_peak_losers(&peaks).first() else {
            return false;
        };
        let of_hz = peaks[keep].frequency_hz;
        rejected.push(self.record(&roots[drop], Reason::SamePeak { of_hz }));
        roots.remove(drop);
        true
    }

    /// Effective noise variance per channel for a fit.
    fn sigma2(&self, fit: &GramFit) -> Vec<f64> {
        let dof = (2 * self.n_lines).saturating_sub(fit.n_col).max(1) as f64;
        fit.rss
            .iter()
            .zip(self.noise)
            .map(|(rss, n)| n.max(2.0 * rss / dof))
            .collect()
    }

    /// The significance statistics of root k: (T_sum/thr, T_max/thr, raw values).
    fn significance(&self, fit: &GramFit, k: usize, n_roots: usize, s2: &[f64]) -> (f64, Reason) {
        let n_ch = s2.len();
        let t: Vec<f64> = fit
            .delta_rss(k)
            .iter()
            .zip(s2)
            .map(|(d, s)| 2.0 * d / s)
            .collect();
        let t_sum: f64 = t.iter().sum();
        let t_max = t.iter().cloned().fold(0.0, f64::max);
        let nr = n_roots.max(1) as f64;
        let threshold_sum = chi2_isf(2.0 * n_ch as f64 + 2.0, self.alpha / (2.0 * nr));
        let threshold_max = chi2_isf(4.0, self.alpha / (2.0 * nr * n_ch as f64));
        let score = (t_sum / threshold_sum).max(t_max / threshold_max);
        (
            score,
            Reason::NotSignificant {
                t_sum,
                threshold_sum,
                t_max,
                threshold_max,
            },
        )
    }

    /// Modes at a root of multiplicity m by the whitened residue singular values.
    fn multiplicity(&self, fit: &GramFit, k: usize, m: usize, s2: &[f64]) -> usize {
        let v = fit.residue_variance_factor(k);
        let sd: Vec<f64> = s2.iter().map(|s| (s * v).max(1e-300).sqrt()).collect();
        let scale = separable_scale(&sd, self.n_out, self.n_ref);
        let r: Vec<Complex64> = (0..self.n_out * self.n_ref)
            .map(|c| fit.residue(k, c) / scale[c])
            .collect();
        let (s, _) = left_singular(&r, self.n_out, self.n_ref);
        let rest: Vec<f64> = sd.iter().zip(&scale).map(|(s, a)| s / a).collect();
        let edge = noise_edge(&rest, self.n_out, self.n_ref);
        s.iter()
            .take(m)
            .filter(|&&x| x * x >= 4.0 * edge)
            .count()
            .max(1)
    }

    /// The significance score of every root of `fit` (≥ 1: significant),
    /// max(T_sum/threshold, T_max/threshold).
    pub fn scores(&self, fit: &GramFit, n_roots: usize) -> Vec<f64> {
        let s2 = self.sigma2(fit);
        (0..n_roots)
            .map(|k| self.significance(fit, k, n_roots, &s2).0)
            .collect()
    }

    /// Duplicates, backward elimination and multiplicities for `roots`.
    pub fn run(&mut self, mut roots: Vec<Root>) -> Validated {
        let mut rejected = Vec::new();
        let mut fit = self.fit(&mut roots, &mut rejected);
        while self.drop_duplicate(&mut roots, &fit, &mut rejected) {
            fit = self.fit(&mut roots, &mut rejected);
        }
        while self.drop_shared_peak(&mut roots, &fit, &mut rejected) {
            fit = self.fit(&mut roots, &mut rejected);
        }
        loop {
            let s2 = self.sigma2(&fit);
            let n = roots.len();
            let holds = holds_peak(self.evidence, self.orders, &roots, &fit, &s2);
            let weakest = (0..n)
                .filter(|&k| !holds[k])
                .map(|k| (k, self.significance(&fit, k, n, &s2)))
                .min_by(|a, b| a.1 .0.total_cmp(&b.1 .0).then(a.0.cmp(&b.0)));
            match weakest {
                Some((k, (score, reason))) if score < 1.0 => {
                    rejected.push(self.record(&roots[k], reason));
                    roots.remove(k);
                    fit = self.fit(&mut roots, &mut rejected);
                }
                _ => break,
            }
        }
        let s2 = self.sigma2(&fit);
        let reduced: Vec<(usize, usize)> = roots
            .iter()
            .enumerate()
            .filter(|(_, r)| r.multiplicity > 1)
            .map(|(k, r)| (k, self.multiplicity(&fit, k, r.multiplicity, &s2)))
            .collect();
        for (k, to) in reduced {
            let from = roots[k].multiplicity;
            if to < from {
                rejected.push(self.record(&roots[k], Reason::MultiplicityReduced { from, to }));
                roots[k].multiplicity = to;
            }
        }
        let accepted = self.acceptance(&roots, &fit);
        Validated {
            roots,
            accepted,
            fit,
            rejected,
        }
    }

    /// Why each root of the final fit is kept.
    fn acceptance(&self, roots: &[Root], fit: &GramFit) -> Vec<Acceptance> {
        let s2 = self.sigma2(fit);
        let peaks = root_peaks(self.orders, roots, fit, &s2);
        let keepers = self.evidence.keepers(&peaks);
        (0..roots.len())
            .map(|k| {
                let score = self.significance(fit, k, roots.len(), &s2).0;
                match keepers[k] {
                    Some(j) if j == k => {
                        let p = &peaks[k];
                        let peak_hz = self
                            .evidence
                            .peak_of(p.frequency_hz, p.damping_ratio)
                            .map_or(p.frequency_hz, |i| self.evidence.peaks_hz[i]);
                        Acceptance::CmifPeak { peak_hz, score }
                    }
                    _ => Acceptance::Significance { score },
                }
            })
            .collect()
    }
}

/// The separable part a_o·b_i of per-channel standard deviations `sd`
/// (outputs × references): the additive two-way fit of their logarithms.
///
/// Scaling the residue matrix R = φ φ_refᵀ/(2jω_d) of a simple mode by a
/// separable matrix keeps its rank 1; scaling each channel by its own σ_c
/// does not (σ_c is set by whichever mode dominates that channel's misfit),
/// and a strong mode then shows a second singular value of several percent
/// of the first — a "repeated root" at every strong peak under noise ∝ |H|
/// (the `wide_band` family of [`super::families`]).
fn separable_scale(sd: &[f64], n_out: usize, n_ref: usize) -> Vec<f64> {
    let log: Vec<f64> = sd.iter().map(|s| s.ln()).collect();
    let all = log.iter().sum::<f64>() / log.len().max(1) as f64;
    let row: Vec<f64> = (0..n_out)
        .map(|o| log[o * n_ref..(o + 1) * n_ref].iter().sum::<f64>() / n_ref as f64)
        .collect();
    let col: Vec<f64> = (0..n_ref)
        .map(|i| (0..n_out).map(|o| log[o * n_ref + i]).sum::<f64>() / n_out as f64)
        .collect();
    (0..n_out * n_ref)
        .map(|c| (row[c / n_ref] + col[c % n_ref] - all).exp())
        .collect()
}

/// The squared noise edge of an outputs × references matrix whose entries
/// have standard deviations `sd`: (largest row norm + largest column norm)²
/// of `sd` (Bandeira & van Handel 2016, the expected norm of a matrix of
/// independent entries up to a log term); for unit entries the
/// Marchenko–Pastur edge (√n_out + √n_ref)².
fn noise_edge(sd: &[f64], n_out: usize, n_ref: usize) -> f64 {
    let row = (0..n_out)
        .map(|o| {
            sd[o * n_ref..(o + 1) * n_ref]
                .iter()
                .map(|s| s * s)
                .sum::<f64>()
                .sqrt()
        })
        .fold(0.0, f64::max);
    let col = (0..n_ref)
        .map(|i| {
            (0..n_out)
                .map(|o| sd[o * n_ref + i].powi(2))
                .sum::<f64>()
                .sqrt()
        })
        .fold(0.0, f64::max);
    (row + col).powi(2)
}

/// What [`PeakEvidence`] needs of every root of a fit: frequency, damping,
/// multiplicity and Σ_c ΔRSS_c/σ_c².
pub fn root_peaks(
    orders: &[PoleOrder],
    roots: &[Root],
    fit: &GramFit,
    s2: &[f64],
) -> Vec<RootPeak> {
    roots
        .iter()
        .enumerate()
        .map(|(k, r)| {
            let p = r.pole(orders);
            RootPeak {
                frequency_hz: p.frequency_hz,
                damping_ratio: p.damping_ratio,
                strength: fit.delta_rss(k).iter().zip(s2).map(|(d, s)| d / s).sum(),
                multiplicity: r.multiplicity,
            }
        })
        .collect()
}

/// Whether each root keeps a prominent CMIF peak of its own: such a root is
/// not removed as insignificant (module docs).
pub fn holds_peak(
    evidence: &PeakEvidence,
    orders: &[PoleOrder],
    roots: &[Root],
    fit: &GramFit,
    s2: &[f64],
) -> Vec<bool> {
    let peaks = root_peaks(orders, roots, fit, s2);
    evidence
        .keepers(&peaks)
        .into_iter()
        .enumerate()
        .map(|(k, keeper)| keeper == Some(k))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn separable_scaling_keeps_a_simple_mode_rank_one() {
        let (n_out, n_ref) = (6, 2);
        let phi = [0.9, -0.4, 0.7, 0.2, -1.0, 0.5];
        let r: Vec<Complex64> = (0..n_out * n_ref)
            .map(|c| Complex64::new(0.0, -phi[c / n_ref] * phi[[0, 4][c % n_ref]]))
            .collect();
        // Separable standard deviations are reproduced.
        let (a, b) = ([1.0, 3.0, 0.5, 2.0, 8.0, 1.5], [1.0, 4.0]);
        let sep: Vec<f64> = (0..n_out * n_ref)
            .map(|c| a[c / n_ref] * b[c % n_ref])
            .collect();
        let scale = separable_scale(&sep, n_out, n_ref);
        assert!(scale
            .iter()
            .zip(&sep)
            .all(|(x, y)| (x / y - 1.0).abs() < 1e-12));
        // Unit noise: the Marchenko–Pastur edge.
        let mp = (6f64.sqrt() + 2f64.sqrt()).powi(2);
        assert!((noise_edge(&[1.0; 12], n_out, n_ref) - mp).abs() < 1e-12);
        // Channels of unequal, non-separable noise: divided channel by
        // channel the rank-1 residue shows a second singular value of 12 %;
        // divided separably it stays rank 1, and the edge grows with the
        // noise left over.
        let sd: Vec<f64> = sep
            .iter()
            .enumerate()
            .map(|(c, s)| s * [1.0, 30.0, 2.0, 0.5][c % 4])
            .collect();
        let ratio = |w: &[Complex64]| {
            let (s, _) = left_singular(w, n_out, n_ref);
            s[1] / s[0]
        };
        let per_channel: Vec<Complex64> = r.iter().zip(&sd).map(|(x, s)| x / s).collect();
        assert!(ratio(&per_channel) > 0.1, "{}", ratio(&per_channel));
        let scale = separable_scale(&sd, n_out, n_ref);
        let separable: Vec<Complex64> = r.iter().zip(&scale).map(|(x, s)| x / s).collect();
        assert!(ratio(&separable) < 1e-6, "{}", ratio(&separable));
        let rest: Vec<f64> = sd.iter().zip(&scale).map(|(s, a)| s / a).collect();
        assert!(noise_edge(&rest, n_out, n_ref) > mp);
    }

    #[test]
    fn chi2_upper_quantiles_match_closed_forms() {
        // χ²_2: P(X > x) = exp(−x/2); χ²_4: exp(−x/2)(1 + x/2).
        for q in [1e-2, 1e-6, 1e-12] {
            let x = chi2_isf(2.0, q);
            assert!((x - (-2.0 * f64::ln(q))).abs() < 1e-8 * x, "{q}: {x}");
            let x = chi2_isf(4.0, q);
            let sf = (-x / 2.0).exp() * (1.0 + x / 2.0);
            assert!((sf / q - 1.0).abs() < 1e-8, "{q}: {sf}");
        }
        // Large dof: near k + z √(2k).
        let x = chi2_isf(1202.0, 1e-3);
        assert!(x > 1202.0 + 3.0 * 49.0 && x < 1202.0 + 3.3 * 49.0, "{x}");
    }
}
