//! One answer on a flat optimum: the modes of the chosen selection checked
//! against the search's next-best selections ([`consensus`]).
//!
//! The search's objective is flat near its optimum: selections a little
//! apart in the hyperparameters fit the FRFs almost equally well and hold
//! mostly the same modes. A mode that none of them holds is a mode of one
//! hyperparameter point. On the vertical mill's family (40 AutoEMA stages,
//! 80 positions with known truths, autoema 20) the chosen selections held
//! 59 such modes (checked against the 6 next-best, refined): 40 of the 52
//! spurious modes of all 871, and 19 true ones. Wider than three line
//! spacings (2ζf/Δf > 3) they split 38 spurious to 9 true; the true ones
//! below are lightly damped modes one or two lines wide, whose short and
//! scattered stable columns (the damping of a peak that narrow moves with
//! the model order) stand or fall with each point's stabilization
//! tolerances, so they are not judged.
//!
//! A mode whose significance score is 50 or more (T 50× its threshold) is
//! not judged either: at 5 % noise the next-best selections of the
//! synthetic families miss strong true modes (ζ 3–6 %, scores 70–1752)
//! more often, and dropping them cost the damping, large and beyond-band
//! families four successes of 45.
//!
//! **Model error.** A mode kept for its significance alone (no CMIF peak
//! of its own) must also stand against the serial correlation of the
//! residual around it ([`crate::ema::serial_correlation`]): when its score
//! is below the variance inflation I of its ΔRSS and fewer than half of the
//! next-best selections hold it, it is a root laid over smooth model error
//! and is dropped (`serial_correlation`). Passing either test keeps it:
//! weak true modes of measured FRFs sit in correlated residuals too
//! (vibration-toolbox case 1: 162.4 Hz, score 1.2 against I ≈ 8, held by 10
//! of 12), and held by few neighbours are also the true modes a point's
//! tolerances decide (above). Measured at autoema 22:
//! `benchmarks/real_sets` the same 83 of 108 reference modes found with
//! 58 instead of 65 extras (tool holder driving point 8 → 3), the vertical
//! mill's 40 stages 812 instead of 815 of 1030 with 18 instead of 25 extras
//! (10 drops: 6 spurious, 4 true — a heavily damped close pair at
//! 173/175 Hz held by 5 of 12), the polymax families unchanged (white noise
//! leaves I = 1).
//!
//! The other selections are screened, not refined: refining them cost
//! 1.5× the CPU of the whole analysis on the 51k-line beam for the same
//! verdicts on the real sets. With the 12 next-best screened, the mill's
//! 40 stages find 815 instead of 817 of 1030 true modes with 25 instead
//! of 54 extras (without the score limit: 805 and 15).

use super::identified_modes;
use crate::ema::adequacy::bandwidth_lines;
use crate::ema::hyperbox::{differing_modes, FOUND_WITHIN};
use crate::ema::polymax::PoleOrder;
use crate::ema::selection::{select_modes, without_roots, Hyperparameters, Screening, Selection};
use crate::ema::significance::{Acceptance, Reason};

/// Half-power bandwidth 2ζf, in line spacings, above which a mode must be
/// held by one of the next-best selections ([`consensus`]).
pub const CONSENSUS_MIN_LINES: f64 = 3.0;

/// Significance score (T/threshold, [`Acceptance`]) from which a mode
/// stands on the data alone, held by other selections or not.
pub const CONSENSUS_MAX_SCORE: f64 = 50.0;

/// The chosen selection checked against the others.
pub(super) struct Consensus {
    pub selection: Selection,
    /// Per root of `selection`: how many of the `of` selections hold it.
    pub support: Vec<usize>,
    pub of: usize,
    /// Per root of `selection`: the variance inflation of its ΔRSS by the
    /// residual's serial correlation ([`Screening::serial_inflation`]).
    pub inflation: Vec<f64>,
}

/// Each root of `best` (the chosen point's refined selection) counted in
/// the (screened) selections of the `k` next-best distinct points of the
/// search (`objectives`, `xs`; `chosen` excluded), one within 1 %
/// ([`FOUND_WITHIN`]) holding it. Roots none holds and wider than
/// [`CONSENSUS_MIN_LINES`] are dropped (`no_consensus`), so are roots kept
/// for significance alone that fewer than half hold and whose score is
/// below their serial inflation (`serial_correlation`, module docs); the
/// rest are validated again.
#[allow(clippy::too_many_arguments)]
pub(super) fn consensus(
    screening: &mut Screening<'_>,
    orders: &[PoleOrder],
    objectives: &[f64],
    xs: &[Vec<f64>],
    chosen: usize,
    k: usize,
    point: &dyn Fn(&[f64]) -> Hyperparameters,
    best: Selection,
    step_hz: f64,
) -> Consensus {
    let mut next: Vec<usize> = (0..xs.len()).filter(|&i| i != chosen).collect();
    next.sort_by(|&a, &b| objectives[b].total_cmp(&objectives[a]).then(a.cmp(&b)));
    let mut points: Vec<&Vec<f64>> = Vec::new();
    for i in next {
        if points.len() == k {
            break;
        }
        if xs[i] != xs[chosen] && !points.contains(&&xs[i]) {
            points.push(&xs[i]);
        }
    }
    let others: Vec<Vec<f64>> = points
        .iter()
        .map(|x| frequencies(orders, &select_modes(screening, orders, &point(x))))
        .collect();
    let support = |s: &Selection| -> Vec<usize> {
        frequencies(orders, s)
            .iter()
            .map(|&f| {
                others
                    .iter()
                    .filter(|g| differing_modes(&[f], g, FOUND_WITHIN).0.is_empty())
                    .count()
            })
            .collect()
    };
    let of = others.len();
    let counts = support(&best);
    let inflation = screening.serial_inflation(orders, &best, step_hz);
    let drop: Vec<(usize, Reason)> = identified_modes(orders, &best)
        .iter()
        .zip(&counts)
        .enumerate()
        .filter_map(|(k, (&(f, zeta), &n))| {
            let accepted = best.accepted.get(k);
            let score = accepted.map_or(0.0, Acceptance::score);
            let alone = matches!(accepted, Some(Acceptance::Significance { .. }));
            if of > 0
                && n == 0
                && bandwidth_lines(f, zeta, step_hz) > CONSENSUS_MIN_LINES
                && score < CONSENSUS_MAX_SCORE
            {
                return Some((k, Reason::NoConsensus { of }));
            }
            // Model error: not reproduced by most neighbours, and not
            // significant once the residual's serial correlation is counted.
            (alone && 2 * n < of && score < inflation[k]).then_some((
                k,
                Reason::SerialCorrelation {
                    score,
                    inflation: inflation[k],
                    support: n,
                    of,
                },
            ))
        })
        .collect();
    if drop.is_empty() {
        return Consensus {
            selection: best,
            support: counts,
            of,
            inflation,
        };
    }
    let selection = without_roots(screening, orders, &best, &drop);
    Consensus {
        support: support(&selection),
        inflation: screening.serial_inflation(orders, &selection, step_hz),
        selection,
        of,
    }
}

/// The frequencies (Hz) of a selection's roots.
fn frequencies(orders: &[PoleOrder], s: &Selection) -> Vec<f64> {
    identified_modes(orders, s).iter().map(|m| m.0).collect()
}
