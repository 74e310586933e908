//! The probe of a result at the edge of its search box: is the box what
//! limits it ([`AtBound`])?

use super::{identified_modes, tie_tolerance};
use crate::ema::hyperbox::{differing_modes, same_modes, AtBound, FOUND_WITHIN, LOG_SCALE};
use crate::ema::polymax::PoleOrder;
use crate::ema::selection::{
    refine_selection, select_modes, Hyperparameters, Screening, Selection, HYPERPARAMETER_NAMES,
};

/// A bound probed, with the screening's selection beyond it where that was
/// better with other modes ([`settle`] refines it).
pub(super) struct Probe {
    at_bound: AtBound,
    better: Option<Selection>,
}

/// For every free hyperparameter of `x` within 2 % of a bound, the result a
/// quarter of the range beyond it.
pub(super) fn probe_bounds(
    screening: &mut Screening<'_>,
    orders: &[PoleOrder],
    best: &Selection,
    x: &[f64],
    search: &[(f64, f64)],
    free: &[usize],
    point: &dyn Fn(&[f64]) -> Hyperparameters,
) -> Vec<Probe> {
    let mut out = Vec::new();
    for (i, &k) in free.iter().enumerate() {
        let (lo, hi) = search[i];
        let w = hi - lo;
        if w <= 0.0 {
            continue;
        }
        let u = (x[i] - lo) / w;
        let (side, bound_s, beyond_s) = if u <= 0.02 {
            ("lower", lo, lo - 0.25 * w)
        } else if u >= 0.98 {
            ("upper", hi, hi + 0.25 * w)
        } else {
            continue;
        };
        let from = |v: f64| if LOG_SCALE[k] { v.exp() } else { v };
        // Beyond the order range there are no poles; negative weights and
        // fractions are meaningless.
        let feasible = k != 8 && (LOG_SCALE[k] || beyond_s >= 0.0);
        let probe = feasible.then(|| {
            let mut y = x.to_vec();
            y[i] = beyond_s;
            select_modes(screening, orders, &point(&y))
        });
        // The search would have gone beyond the bound where the objective
        // there is better by more than the tie tolerance of
        // [`super::choose`]; only then can the box decide modes. A worse
        // objective beyond is a point the search would not pick; an equal
        // one with other modes is a tie the objective cannot break (the
        // UFSC beam's shaker test: `cluster_distance` widened from 0.05 to
        // 0.15 gave 25 modes instead of 23, two more extras and two
        // published modes lost). A better objective with the same modes is
        // a pole a little better placed (a 3 × 72 roving-hammer test at 5 %
        // noise: the same 12 modes, mean FRAC 0.997425 against 0.997395).
        let tie = tie_tolerance(best.objective);
        let better = probe.as_ref().is_some_and(|s| {
            s.objective > best.objective + tie
                && !same_modes(
                    &identified_modes(orders, s),
                    &identified_modes(orders, best),
                )
        });
        let at_bound = AtBound {
            name: HYPERPARAMETER_NAMES[k].to_string(),
            value: from(x[i]),
            bound: from(bound_s),
            side,
            beyond: feasible.then(|| from(beyond_s)),
            modes_at: best.n_modes(),
            modes_beyond: probe.as_ref().map(Selection::n_modes),
            objective_at: best.objective,
            objective_beyond: probe.as_ref().map(|s| s.objective),
            sensitive: false,
            only_beyond_hz: Vec::new(),
            only_here_hz: Vec::new(),
        };
        out.push(Probe {
            at_bound,
            better: probe.filter(|_| better),
        });
    }
    out
}

/// The bounds with, where the screening beyond one was better with other
/// modes, how that selection refined differs from the refined result
/// `result`. Modes of the result it lacks depend on the box (`sensitive`,
/// [`crate::ema::hyperbox::box_warning`]). That is not "widen the box":
/// where the screening alone had decided (autoema 19), widening it as
/// asked gave a better result at 7 of the vertical mill's 17 such
/// positions (more true modes or fewer extras, nothing worse), a worse one
/// at 4, a mixed one at 5 and the same at 1.
pub(super) fn settle(
    probes: Vec<Probe>,
    screening: &mut Screening<'_>,
    orders: &[PoleOrder],
    result: &Selection,
) -> Vec<AtBound> {
    let here: Vec<f64> = identified_modes(orders, result)
        .iter()
        .map(|m| m.0)
        .collect();
    probes
        .into_iter()
        .map(
            |Probe {
                 mut at_bound,
                 better,
             }| {
                if let Some(s) = better {
                    let refined = refine_selection(screening, orders, &s);
                    let beyond: Vec<f64> = identified_modes(orders, &refined)
                        .iter()
                        .map(|m| m.0)
                        .collect();
                    let (only_here, only_beyond) = differing_modes(&here, &beyond, FOUND_WITHIN);
                    at_bound.sensitive = !only_here.is_empty();
                    at_bound.only_here_hz = only_here;
                    at_bound.only_beyond_hz = only_beyond;
                }
                at_bound
            },
        )
        .collect()
}
