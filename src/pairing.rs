//! Mode pairing (correlation) between a reference and a candidate modal
//! model: which mode of one is the same physical mode as which of the other.
//!
//! Modes correspond by physics, never by number: measured modes are
//! incomplete (AutoEMA misses some), renumbered and may include spurious
//! ones. Pairs are found as one optimal assignment (Hungarian algorithm,
//! [`hungarian`]) with the cost
//!
//! c_ij = (1 − MAC_ij) + NFD_ij / s_f
//!
//! (MAC eq. 2.62, NFD eq. 2.64) over the pairs allowed by a hard frequency
//! window (NFD ≤ `window`) and a MAC floor (MAC ≥ `min_mac`). The frequency
//! term is what MAC alone lacks: with ten sensors, neighbouring modes of a
//! machine tool can look alike (a 108.7 Hz mode with MAC 0.8 against a
//! 102.2 Hz reference mode), and a MAC-only assignment cross-pairs them.
//! `frequency_scale` s_f is the relative frequency difference that costs as
//! much as MAC 0: at the default 0.1 a 1 % shift weighs like a MAC drop of
//! 0.1, so a clearly better shape still wins over a small frequency shift,
//! but a neighbour 6 % away needs a MAC 0.6 better to be taken instead.
//!
//! [`margins`] says how sure each pair is: the increase of the total cost
//! when that pair is forbidden and the rest re-assigned. A margin below
//! [`Pairing::ambiguity`] marks the pair ambiguous (another assignment is
//! nearly as good) — reported, never silently trusted.

use crate::metrics::{mac_matrix, nfd};
use num_complex::Complex64;

/// Settings of the pairing.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Pairing {
    /// Largest relative frequency difference of a pair (NFD, eq. 2.64).
    pub window: f64,
    /// Smallest MAC of a pair (eq. 2.62).
    pub min_mac: f64,
    /// NFD that costs as much as MAC 0 (s_f above).
    pub frequency_scale: f64,
    /// A pair whose margin is below this is ambiguous.
    pub ambiguity: f64,
}

impl Default for Pairing {
    fn default() -> Self {
        Pairing {
            window: 0.2,
            min_mac: 0.0,
            frequency_scale: 0.1,
            ambiguity: 0.1,
        }
    }
}

impl Pairing {
    /// Pairing within `window` with the other settings at their defaults.
    pub fn within(window: f64) -> Self {
        Pairing {
            window,
            ..Pairing::default()
        }
    }

    /// Check the settings; the message names the bad one.
    pub fn check(&self) -> Result<(), String> {
        if !(self.window > 0.0 && self.window.is_finite()) {
            return Err(format!(
                "window {} must be a positive fraction such as 0.2",
                self.window
            ));
        }
        if !(0.0..=1.0).contains(&self.min_mac) {
            return Err(format!("min_mac {} must be in [0, 1]", self.min_mac));
        }
        if !(self.frequency_scale > 0.0 && self.frequency_scale.is_finite()) {
            return Err(format!(
                "frequency_scale {} must be a positive fraction such as 0.1",
                self.frequency_scale
            ));
        }
        if !(self.ambiguity >= 0.0 && self.ambiguity.is_finite()) {
            return Err(format!("ambiguity {} must be ≥ 0", self.ambiguity));
        }
        Ok(())
    }
}

/// A reference mode paired with a candidate mode.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pair {
    pub reference: usize,
    pub candidate: usize,
    pub mac: f64,
    /// Its assignment cost c_ij.
    pub cost: f64,
}

/// The cost matrix of [`pair_modes`]: `None` where a pair is not allowed.
pub fn cost_matrix(
    ref_freqs: &[f64],
    cand_freqs: &[f64],
    macs: &[Vec<f64>],
    settings: &Pairing,
) -> Vec<Vec<Option<f64>>> {
    (0..ref_freqs.len())
        .map(|i| {
            (0..cand_freqs.len())
                .map(|j| {
                    let d = nfd(ref_freqs[i], cand_freqs[j]);
                    let m = macs[i][j];
                    (d <= settings.window && m >= settings.min_mac && d.is_finite())
                        .then(|| (1.0 - m) + d / settings.frequency_scale)
                })
                .collect()
        })
        .collect()
}

/// Pair reference and candidate modes one-to-one with the least total cost
/// (module docs) among allowed pairs; a mode is never claimed twice, and a
/// reference mode with no allowed partner stays unpaired. Pairs are sorted
/// by reference index.
pub fn pair_modes(
    ref_freqs: &[f64],
    ref_shapes: &[Vec<Complex64>],
    cand_freqs: &[f64],
    cand_shapes: &[Vec<Complex64>],
    settings: &Pairing,
) -> Vec<Pair> {
    let macs = mac_matrix(ref_shapes, cand_shapes);
    let costs = cost_matrix(ref_freqs, cand_freqs, &macs, settings);
    assign(&costs)
        .into_iter()
        .map(|(i, j)| Pair {
            reference: i,
            candidate: j,
            mac: macs[i][j],
            cost: costs[i][j].unwrap_or(f64::INFINITY),
        })
        .collect()
}

/// Pair two sets of frequencies one to one within `window` (NFD, eq. 2.64):
/// as many pairs as possible, and among those the least total NFD — the
/// pairing of [`pair_modes`] with every MAC 1. Pairs (index into `a`,
/// index into `b`), sorted by the first.
pub fn pair_frequencies(a: &[f64], b: &[f64], window: f64) -> Vec<(usize, usize)> {
    let macs = vec![vec![1.0; b.len()]; a.len()];
    assign(&cost_matrix(a, b, &macs, &Pairing::within(window)))
}

/// The optimal assignment of allowed pairs, as (row, column) sorted by row.
/// Unpairing a row costs more than any allowed pair, so the number of pairs
/// is maximal first and the cost least among those.
fn assign(costs: &[Vec<Option<f64>>]) -> Vec<(usize, usize)> {
    let worst = costs
        .iter()
        .flatten()
        .flatten()
        .fold(0.0f64, |a, &b| a.max(b));
    let big = 1.0 + (worst + 1.0) * (costs.len() + 1) as f64;
    let dense: Vec<Vec<f64>> = costs
        .iter()
        .map(|row| row.iter().map(|c| c.unwrap_or(big)).collect())
        .collect();
    hungarian(&dense)
        .into_iter()
        .enumerate()
        .filter_map(|(i, j)| j.filter(|&j| costs[i][j].is_some()).map(|j| (i, j)))
        .collect()
}

/// How much worse the best assignment becomes when each pair of `pairs` is
/// forbidden (the others re-assigned): the pair's margin, +∞ when no other
/// assignment keeps as many pairs. `costs` is [`cost_matrix`]'s.
pub fn margins(costs: &[Vec<Option<f64>>], pairs: &[Pair]) -> Vec<f64> {
    let total = |a: &[(usize, usize)]| -> f64 {
        a.iter()
            .map(|&(i, j)| costs[i][j].unwrap_or(f64::INFINITY))
            .sum()
    };
    pairs
        .iter()
        .map(|p| {
            let mut without = costs.to_vec();
            without[p.reference][p.candidate] = None;
            let other = assign(&without);
            if other.len() < pairs.len() {
                f64::INFINITY
            } else {
                total(&other) - pairs.iter().map(|p| p.cost).sum::<f64>()
            }
        })
        .collect()
}

/// Minimum-cost assignment of rows to columns for a rectangular cost matrix
/// (Kuhn–Munkres with potentials, O(n²m)). Returns the column of each row,
/// `None` for rows left over when there are more rows than columns.
pub fn hungarian(cost: &[Vec<f64>]) -> Vec<Option<usize>> {
    let rows = cost.len();
    let cols = cost.first().map_or(0, Vec::len);
    if rows == 0 || cols == 0 {
        return vec![None; rows];
    }
    // Work on the orientation with n ≤ m.
    let transposed = rows > cols;
    let (n, m) = if transposed {
        (cols, rows)
    } else {
        (rows, cols)
    };
    let c = |i: usize, j: usize| if transposed { cost[j][i] } else { cost[i][j] };
    let inf = f64::INFINITY;
    let (mut u, mut v) = (vec![0.0; n + 1], vec![0.0; m + 1]);
    let mut p = vec![0usize; m + 1];
    let mut way = vec![0usize; m + 1];
    for i in 1..=n {
        p[0] = i;
        let mut j0 = 0;
        let mut minv = vec![inf; m + 1];
        let mut used = vec![false; m + 1];
        loop {
            used[j0] = true;
            let i0 = p[j0];
            let mut delta = inf;
            let mut j1 = 0;
            for j in 1..=m {
                if !used[j] {
                    let cur = c(i0 - 1, j - 1) - u[i0] - v[j];
                    if cur < minv[j] {
                        minv[j] = cur;
                        way[j] = j0;
                    }
                    if minv[j] < delta {
                        delta = minv[j];
                        j1 = j;
                    }
                }
            }
            for j in 0..=m {
                if used[j] {
                    u[p[j]] += delta;
                    v[j] -= delta;
                } else {
                    minv[j] -= delta;
                }
            }
            j0 = j1;
            if p[j0] == 0 {
                break;
            }
        }
        loop {
            let j1 = way[j0];
            p[j0] = p[j1];
            j0 = j1;
            if j0 == 0 {
                break;
            }
        }
    }
    let mut out = vec![None; rows];
    for (j, &row) in p.iter().enumerate().skip(1) {
        if row != 0 {
            let (r, col) = if transposed {
                (j - 1, row - 1)
            } else {
                (row - 1, j - 1)
            };
            out[r] = Some(col);
        }
    }
    out
}

#[cfg(test)]
mod tests;
