//! The final steps for the selection the search chose (seed section
//! 5.2.2, with the model selection of issue 14): multiplicities on the
//! evidence of every computed order ([`crate::ema::roots`]), poles
//! refined on the FRFs ([`crate::ema::refine`]), roots that fail the
//! nested likelihood-ratio test, leave the band or stand on a short stable
//! column dropped, and validation again.

use super::{band_hz, stabilization_params, stable_poles, Screening, Selection};
use crate::ema::lsfd::lsfd_roots;
use crate::ema::noise::peak_at;
use crate::ema::polymax::{Pole, PoleOrder};
use crate::ema::projection::FitOutcome;
use crate::ema::refine::{nested_statistic, refine_sweep};
use crate::ema::residual::{self, search_reach, ResidualPeak};
use crate::ema::roots::{multiplicity_over_all_orders, Root};
use crate::ema::significance::{chi2_isf, holds_peak, Acceptance, Reason, Rejection, Validated};
use crate::ema::stabilization::stabilize;
use num_complex::Complex64;

/// Fraction of the median stable column of the peak-holding roots below
/// which a root kept for significance alone is dropped ([`short_columns`]).
const SHORT_COLUMN: f64 = 0.3;
/// Damping ratio from which a root's column height is not judged.
const SHORT_COLUMN_MAX_DAMPING: f64 = 0.02;

/// The final steps for the chosen selection: multiplicities on the
/// evidence of every computed order
/// ([`crate::ema::roots::multiplicity_over_all_orders`]), poles refined on the
/// FRFs ([`crate::ema::refine`], two sweeps with a global refit between), and
/// validation again.
pub fn refine_selection(
    screening: &mut Screening<'_>,
    orders: &[PoleOrder],
    s: &Selection,
) -> Selection {
    let mut roots = s.roots.clone();
    set_multiplicities(screening, orders, s, &mut roots);
    for _sweep in 0..2 {
        refine_roots(screening, orders, &mut roots);
    }
    let mut rejected = s.rejected.clone();
    drop_not_nested_significant(screening, orders, &mut roots, &mut rejected);
    drop_outside_band(screening, orders, &mut roots, &mut rejected);
    revalidated(screening, orders, s, roots, rejected)
}

/// The refined selection `s` without the roots `drop` (index into
/// `s.roots`, and why), validated again.
pub fn without_roots(
    screening: &mut Screening<'_>,
    orders: &[PoleOrder],
    s: &Selection,
    drop: &[(usize, Reason)],
) -> Selection {
    let mut rejected = s.rejected.clone();
    let mut roots = Vec::new();
    for (k, root) in s.roots.iter().enumerate() {
        match drop.iter().find(|(j, _)| *j == k) {
            Some((_, reason)) => rejected.push(rejection(orders, root, reason.clone())),
            None => roots.push(root.clone()),
        }
    }
    revalidated(screening, orders, s, roots, rejected)
}

/// `roots` validated, as a selection at the hyperparameters of `s`.
fn revalidated(
    screening: &mut Screening<'_>,
    orders: &[PoleOrder],
    s: &Selection,
    roots: Vec<Root>,
    mut rejected: Vec<Rejection>,
) -> Selection {
    let validated = validate_without_short_columns(screening, orders, roots, &mut rejected);
    let mean_frac = validated.fit.mean_frac();
    let n_modes: usize = validated.roots.iter().map(|r| r.multiplicity).sum();
    rejected.extend(validated.rejected);
    Selection {
        hyperparameters: s.hyperparameters.clone(),
        flags: s.flags.clone(),
        clusters: s.clusters.clone(),
        objective: mean_frac - screening.params.penalty * n_modes as f64,
        roots: validated.roots,
        accepted: validated.accepted,
        rejected,
        mean_frac,
    }
}

/// Sets each root's multiplicity on the evidence of every computed order,
/// not only those up to the selection's `max_order`
/// ([`multiplicity_over_all_orders`]).
fn set_multiplicities(
    screening: &Screening<'_>,
    orders: &[PoleOrder],
    s: &Selection,
    roots: &mut [Root],
) {
    let data = screening.data;
    // Multiplicities on the evidence of every computed order.
    let h = &s.hyperparameters;
    let flags = stabilize(orders, orders.len(), &stabilization_params(h, data));
    let stable = stable_poles(&flags);
    let freqs = &data.frequencies_hz;
    let step = freqs
        .windows(2)
        .map(|w| w[1] - w[0])
        .fold(f64::INFINITY, f64::min);
    let cmif_peak = |m: usize, f: f64, hw: f64| {
        screening
            .cmif
            .get(m - 1)
            .is_some_and(|c| peak_at(c, freqs, f, hw.max(step)))
    };
    let m: Vec<usize> = (0..roots.len())
        .map(|k| multiplicity_over_all_orders(orders, roots, k, &stable, data.n_ref(), &cmif_peak))
        .collect();
    for (r, m) in roots.iter_mut().zip(m) {
        r.multiplicity = m;
    }
}

/// The rejection of `root` for `reason`, at its pole.
fn rejection(orders: &[PoleOrder], root: &Root, reason: Reason) -> Rejection {
    let p = root.pole(orders);
    Rejection {
        frequency_hz: p.frequency_hz,
        damping_ratio: p.damping_ratio,
        n_orders: root.n_orders,
        reason,
    }
}

/// Drops, one at a time and refining the others after each, the root
/// whose nested likelihood-ratio statistic falls furthest below its
/// threshold ([`weakest_nested`]), recording it in `rejected`.
fn drop_not_nested_significant(
    screening: &mut Screening<'_>,
    orders: &[PoleOrder],
    roots: &mut Vec<Root>,
    rejected: &mut Vec<Rejection>,
) {
    while let Some((k, reason)) = weakest_nested(screening, orders, roots) {
        rejected.push(rejection(orders, &roots[k], reason));
        roots.remove(k);
        refine_roots(screening, orders, roots);
    }
}

/// Drops the roots whose refined pole left the data's band, recording
/// them in `rejected`.
fn drop_outside_band(
    screening: &Screening<'_>,
    orders: &[PoleOrder],
    roots: &mut Vec<Root>,
    rejected: &mut Vec<Rejection>,
) {
    // A pole the refinement moved out of the band describes no peak of
    // these data (mimo UFSC beam: 1002.6 Hz from a 5–800 Hz band).
    let (lo, hi) = band_hz(screening.data);
    roots.retain(|r| {
        let p = r.pole(orders);
        let inside = (lo..=hi).contains(&p.frequency_hz);
        if !inside {
            rejected.push(rejection(
                orders,
                r,
                Reason::OutsideBand { band_hz: (lo, hi) },
            ));
        }
        inside
    });
}

/// Validates `roots`, dropping the [`short_columns`] and validating again
/// until none is left; the validation's rejections before the last, and
/// the short columns, go to `rejected`. A short column that holds a data
/// peak of its own ([`unfitted_data_peak`]) is kept, accepted as
/// [`Acceptance::DataPeak`].
fn validate_without_short_columns(
    screening: &mut Screening<'_>,
    orders: &[PoleOrder],
    mut roots: Vec<Root>,
    rejected: &mut Vec<Rejection>,
) -> Validated {
    // Poles (s) of the short columns kept for their data peak, with it.
    let mut kept: Vec<(Complex64, ResidualPeak)> = Vec::new();
    loop {
        let mut validated = screening.validate(orders, roots);
        let held = |kept: &[(Complex64, ResidualPeak)], r: &Root| {
            kept.iter()
                .find(|(s, _)| *s == r.pole(orders).s)
                .map(|(_, p)| p.clone())
        };
        let short: Vec<(usize, usize)> =
            short_columns(orders, &validated.roots, &validated.accepted)
                .into_iter()
                .filter(|&(k, _)| held(&kept, &validated.roots[k]).is_none())
                .collect();
        // What the fit of every root leaves unexplained: one fit per round,
        // whichever short column asks.
        let unexplained = if short.is_empty() {
            Vec::new()
        } else {
            let all: Vec<&Root> = validated.roots.iter().collect();
            missing_modes(screening, orders, &all)
        };
        let mut unjudged = Vec::new();
        for &(k, median) in &short {
            match unfitted_data_peak(screening, orders, &validated.roots, k, &unexplained) {
                Some(peak) => kept.push((validated.roots[k].pole(orders).s, peak)),
                None => unjudged.push((k, median)),
            }
        }
        if unjudged.is_empty() {
            for (r, a) in validated.roots.iter().zip(validated.accepted.iter_mut()) {
                if let (Some(peak), Acceptance::Significance { score }) = (held(&kept, r), &a) {
                    *a = Acceptance::DataPeak {
                        peak_hz: peak.frequency_hz,
                        ratio: peak.ratio,
                        score: *score,
                    };
                }
            }
            return validated;
        }
        rejected.extend(validated.rejected);
        roots = Vec::with_capacity(validated.roots.len());
        for (k, r) in validated.roots.into_iter().enumerate() {
            match unjudged.iter().find(|(j, _)| *j == k) {
                Some(&(_, median)) => rejected.push(rejection(
                    orders,
                    &r,
                    Reason::ShortColumn {
                        peak_median_orders: median,
                    },
                )),
                None => roots.push(r),
            }
        }
    }
}

/// The data peak that root `k` explains and no other root does: a
/// missing-mode residual peak ([`ResidualPeak::missing_mode`]: the data
/// peak, the fit does not, ≥ [`crate::ema::residual::VISIBLE`]× the noise)
/// of the fit of the other roots within the reach in which the check
/// looks for a residual's data peak ([`search_reach`]) of the root, where
/// the fit of all roots leaves none (`unexplained`: its missing-mode
/// peaks, [`missing_modes`]). A root on a short column with such a peak
/// is a mode the data show: dropping it would leave the very peak the
/// final check then warns about (vertical mill, impact tests: a 174.1 Hz
/// root at ζ 0.13 % on 8 of 40 orders, one of a 0.5 % close pair, was
/// dropped, then "the data peak at 174.00 Hz … 20.5× above the noise").
fn unfitted_data_peak(
    screening: &Screening<'_>,
    orders: &[PoleOrder],
    roots: &[Root],
    k: usize,
    unexplained: &[ResidualPeak],
) -> Option<ResidualPeak> {
    let f = roots[k].pole(orders).frequency_hz;
    let reach = search_reach(f, screening.data.line_spacing_hz());
    let near = |q: &ResidualPeak| (q.frequency_hz - f).abs() <= reach;
    if unexplained.iter().any(near) {
        return None;
    }
    let others: Vec<&Root> = (0..roots.len())
        .filter(|&j| j != k)
        .map(|j| &roots[j])
        .collect();
    missing_modes(screening, orders, &others)
        .into_iter()
        .filter(near)
        .max_by(|a, b| a.ratio.total_cmp(&b.ratio))
}

/// The missing-mode residual peaks ([`ResidualPeak::missing_mode`]) of the
/// LSFD fit of `roots` (the final fit's check, [`residual::check`], on
/// these roots); none when the fit fails.
fn missing_modes(
    screening: &Screening<'_>,
    orders: &[PoleOrder],
    roots: &[&Root],
) -> Vec<ResidualPeak> {
    let lambdas: Vec<Complex64> = roots.iter().map(|r| r.pole(orders).s).collect();
    let mult: Vec<usize> = roots.iter().map(|r| r.multiplicity).collect();
    let Ok(fit) = lsfd_roots(screening.data, &lambdas, &mult) else {
        return Vec::new();
    };
    let modes: Vec<(f64, f64)> = roots
        .iter()
        .map(|r| {
            let p = r.pole(orders);
            (p.frequency_hz, p.damping_ratio)
        })
        .collect();
    let (_, peaks) = residual::check(screening.data, &screening.noise, &fit.reconstructed, &modes);
    peaks
        .into_iter()
        .filter(ResidualPeak::missing_mode)
        .collect()
}

/// A root kept only for its significance (no CMIF peak of its own) needs a
/// stable column at least [`SHORT_COLUMN`] times the median column of the
/// roots that hold a peak: cluster size is the model-order evidence of a
/// physical pole, and automated EMA discards clusters far smaller than the
/// typical physical one (Magalhães, Cunha & Caetano 2009,
/// doi:10.1016/j.ymssp.2008.05.003; Reynders, Houbrechts & De Roeck 2012,
/// doi:10.1016/j.ymssp.2011.11.008). The significance test measures a
/// root against the random noise only; on measured data a short column
/// beside strong modes soaks up systematic error instead (mass loading of
/// a roving accelerometer, the UFSC beam shaker test: 264.1 Hz beside
/// 266.3 Hz, 14 of a median 56 orders; tool holder H11: 3236 Hz, 6 of
/// 29). Only lightly damped roots (ζ < [`SHORT_COLUMN_MAX_DAMPING`])
/// are judged so: a heavily damped pole scatters across orders by a good
/// part of its half-power band 2ζf and leaves the stabilization tolerances
/// at many orders, so its column is short though it is physical (the
/// synthetic high-damping family, ζ 5–8 %, loses true modes on this rule:
/// 13 instead of 18 successes of 20 at 5 % noise). Returns (index, median)
/// of every such root.
fn short_columns(
    orders: &[PoleOrder],
    roots: &[Root],
    accepted: &[Acceptance],
) -> Vec<(usize, usize)> {
    let mut peak: Vec<usize> = roots
        .iter()
        .zip(accepted)
        .filter(|(_, a)| matches!(a, Acceptance::CmifPeak { .. }))
        .map(|(r, _)| r.n_orders)
        .collect();
    if peak.is_empty() {
        return Vec::new();
    }
    peak.sort_unstable();
    let median = peak[peak.len() / 2];
    roots
        .iter()
        .zip(accepted)
        .enumerate()
        .filter(|(_, (r, a))| {
            matches!(a, Acceptance::Significance { .. })
                && r.pole(orders).damping_ratio < SHORT_COLUMN_MAX_DAMPING
                && (r.n_orders as f64) < SHORT_COLUMN * median as f64
        })
        .map(|(k, _)| (k, median))
        .collect()
}

/// One refinement sweep of the roots' poles ([`refine_sweep`]), roots kept
/// sorted by frequency.
fn refine_roots(screening: &mut Screening<'_>, orders: &[PoleOrder], roots: &mut [Root]) {
    let lambdas: Vec<Complex64> = roots.iter().map(|r| r.pole(orders).s).collect();
    let FitOutcome::Fit(fit) = screening.projector.fit(&lambdas) else {
        return;
    };
    let new = refine_sweep(screening.data, &screening.noise, &lambdas, &fit);
    for (r, l) in roots.iter_mut().zip(new) {
        if l != r.pole(orders).s && r.column_holds(orders, l.norm() / (2.0 * std::f64::consts::PI))
        {
            let w = l.norm();
            r.refined = Some(Pole {
                s: l,
                frequency_hz: w / (2.0 * std::f64::consts::PI),
                damping_ratio: -l.re / w,
                participation: r.representative_pole(orders).participation.clone(),
            });
        }
    }
    roots.sort_by(|a, b| {
        a.pole(orders)
            .frequency_hz
            .total_cmp(&b.pole(orders).frequency_hz)
    });
}

/// The root whose nested likelihood-ratio statistic falls furthest below
/// its threshold χ²_dof(1 − α/(2 n_r)), if any falls below.
fn weakest_nested(
    screening: &mut Screening<'_>,
    orders: &[PoleOrder],
    roots: &[Root],
) -> Option<(usize, Reason)> {
    let lambdas: Vec<Complex64> = roots.iter().map(|r| r.pole(orders).s).collect();
    let FitOutcome::Fit(fit) = screening.projector.fit(&lambdas) else {
        return None;
    };
    let n = roots.len().max(1) as f64;
    let holds = holds_peak(&screening.evidence, orders, roots, &fit, &screening.noise);
    (0..roots.len())
        .filter(|&k| !holds[k])
        .filter_map(|k| {
            let (t, dof) = nested_statistic(screening.data, &screening.noise, &lambdas, &fit, k)?;
            let threshold = chi2_isf(dof, screening.params.alpha / (2.0 * n));
            (t < threshold).then_some((
                k,
                t / threshold,
                Reason::NotSignificantNested { t, threshold },
            ))
        })
        .min_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)))
        .map(|(k, _, r)| (k, r))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::metrics::pole as pole_of;

    /// One root per (frequency, damping, column height), each on its own
    /// order-1 pole list entry.
    fn roots(spec: &[(f64, f64, usize)]) -> (Vec<PoleOrder>, Vec<Root>) {
        let poles = spec
            .iter()
            .map(|&(f, z, _)| Pole {
                s: pole_of(f, z),
                frequency_hz: f,
                damping_ratio: z,
                participation: vec![Complex64::new(1.0, 0.0)],
            })
            .collect();
        let orders = vec![PoleOrder { order: 1, poles }];
        let roots = spec
            .iter()
            .enumerate()
            .map(|(k, &(_, _, n))| Root {
                members: vec![(0, k)],
                representative: (0, k),
                multiplicity: 1,
                n_orders: n,
                refined: None,
            })
            .collect();
        (orders, roots)
    }

    #[test]
    fn short_columns_are_judged_on_lightly_damped_significance_roots_only() {
        // Peak roots on 40, 50, 60 orders (median 50, limit 0.3 · 50 = 15);
        // significance roots on 14 orders at ζ 0.5 % (dropped) and 5 %
        // (heavily damped: kept), on 15 orders at ζ 0.5 % (kept), and a
        // peak root on 5 orders (its own peak: kept).
        let (orders, roots) = roots(&[
            (100.0, 0.005, 40),
            (200.0, 0.005, 50),
            (300.0, 0.005, 60),
            (350.0, 0.005, 5),
            (400.0, 0.005, 14),
            (500.0, 0.05, 14),
            (600.0, 0.005, 15),
        ]);
        let peak = |f| Acceptance::CmifPeak {
            peak_hz: f,
            score: 10.0,
        };
        let sig = Acceptance::Significance { score: 10.0 };
        let accepted = vec![
            peak(100.0),
            peak(200.0),
            peak(300.0),
            peak(350.0),
            sig.clone(),
            sig.clone(),
            sig,
        ];
        // Median of 5, 40, 50, 60 (upper middle): 50.
        assert_eq!(short_columns(&orders, &roots, &accepted), vec![(4, 50)]);
        // No peak root: nothing to compare with, nothing dropped.
        let none = vec![Acceptance::Significance { score: 10.0 }; roots.len()];
        assert!(short_columns(&orders, &roots, &none).is_empty());
    }

    #[test]
    fn a_short_column_is_kept_only_where_the_fit_without_it_misses_a_data_peak() {
        use crate::ema::frf_data::Weighting;
        use crate::ema::selection::SelectionParams;
        use crate::ema::synthetic::{lines, modal_superposition, SyntheticMode};
        use crate::ema::FrfData;
        // A close pair 0.7 % apart (4 lines) at ζ 0.1 % beside two separate
        // modes, 0.1 % noise, one reference.
        let m = |f, z, s: [f64; 4]| SyntheticMode {
            frequency_hz: f,
            damping_ratio: z,
            shape: s.to_vec(),
        };
        let modes = [
            m(60.0, 0.01, [0.3, 0.5, 0.7, 0.8]),
            m(140.0, 0.001, [0.8, 0.6, -0.1, 0.3]),
            m(141.0, 0.001, [0.2, -0.5, 0.9, -0.6]),
            m(210.0, 0.01, [0.5, -0.8, 0.6, -0.4]),
        ];
        let set = modal_superposition(&modes, &[0], &lines(40.0, 240.0, 0.25), 1e-3, 7);
        let data = FrfData::from_set(&set, None, Weighting::Uniform).unwrap();
        let screening = Screening::new(&data, SelectionParams::default());
        // The true poles, and a spurious one at 175 Hz between the modes.
        let (orders, roots) = roots(&[
            (60.0, 0.01, 40),
            (140.0, 0.001, 40),
            (141.0, 0.001, 5),
            (175.0, 0.001, 5),
            (210.0, 0.01, 40),
        ]);
        let all: Vec<&Root> = roots.iter().collect();
        let unexplained = missing_modes(&screening, &orders, &all);
        let peak = unfitted_data_peak(&screening, &orders, &roots, 2, &unexplained)
            .expect("without the second of the pair its peak is unexplained");
        assert!(
            (peak.frequency_hz - 141.0).abs() <= search_reach(141.0, 0.25),
            "{peak:?}"
        );
        assert!(peak.ratio >= crate::ema::residual::VISIBLE, "{peak:?}");
        assert_eq!(
            unfitted_data_peak(&screening, &orders, &roots, 3, &unexplained),
            None,
            "the spurious root explains no data peak"
        );
    }
}
