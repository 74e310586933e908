//! From clusters of stable poles to roots: one pole for LSFD per root, and
//! the number of modes the root holds (its multiplicity).
//!
//! 1. **Coincident clusters merge.** Clusters whose median poles lie within
//!    κ = 0.5 of the smaller decay rate, |λ_a − λ_b| ≤ κ · min(|Re λ_a|,
//!    |Re λ_b|), describe one root as far as the FRFs can tell (their peaks
//!    overlap to a fraction of a half-power bandwidth): a mode split by a
//!    tight cut, or the modes of a repeated root split by their participation
//!    vectors. Stable poles left out of every valid cluster (a small cluster
//!    of a repeated root's second poles, whose participation vectors rotate
//!    from order to order) join the root whose median they coincide with.
//! 2. **Multiplicity.** With n_ref references, PolyMAX puts up to n_ref poles
//!    at a root of multiplicity m, with participation vectors spanning an
//!    m-dimensional subspace (Peeters et al. 2004). The multiplicity is
//!    m = min(m_count, m_rank): m_count is the largest m such that at least
//!    [`MIN_COLUMN`] orders hold m or more of the group's poles (every mode a
//!    stable column of its own), m_rank the number of singular values of
//!    the stacked unit participation vectors above 0.3 of the largest.
//! 3. **Close or repeated.** With m ≥ 2 the poles of the orders that hold
//!    exactly m are sorted by frequency into m sub-groups; if the sub-group
//!    medians are apart by more than κ · |Re λ| each sub-group is a root of
//!    its own (close modes), otherwise the group is one root of
//!    multiplicity m (a repeated root: one pole, a residue matrix of rank m).
//!
//! Each root is represented by the member nearest the median frequency and
//! damping of its poles.

use super::clustering::{Cluster, MIN_COLUMN};
use super::hermitian::hermitian_eigen;
use super::PoleOrder;
use crate::metrics::pole as pole_of;
use num_complex::Complex64;

/// Coincidence radius in units of the decay rate |Re λ|.
pub const COINCIDENT: f64 = 0.5;
/// Relative singular value above which participation vectors count as independent.
const INDEPENDENT: f64 = 0.3;

/// A root: the poles that describe it and the number of modes it holds.
#[derive(Clone, Debug, PartialEq)]
pub struct Root {
    /// `(order index, pole index)` of every member pole.
    pub members: Vec<(usize, usize)>,
    /// The member nearest the median (frequency and damping).
    pub representative: (usize, usize),
    /// Number of modes at this root (1 for a simple mode).
    pub multiplicity: usize,
    /// Number of distinct model orders among the members (the stable column's height).
    pub n_orders: usize,
    /// The pole after refinement on the FRFs ([`super::refine`]), if any.
    pub refined: Option<super::Pole>,
}

impl Root {
    /// The root's pole: refined if it was, else the representative.
    pub fn pole<'a>(&'a self, orders: &'a [PoleOrder]) -> &'a super::Pole {
        self.refined
            .as_ref()
            .unwrap_or(&orders[self.representative.0].poles[self.representative.1])
    }

    /// The PolyMAX pole that represents the root's stable column.
    pub fn representative_pole<'a>(&self, orders: &'a [PoleOrder]) -> &'a super::Pole {
        &orders[self.representative.0].poles[self.representative.1]
    }

    /// Whether a refined frequency (Hz) stays within the stable column's
    /// frequency range (its members' minimum to maximum, at least ±0.2 %
    /// about the representative). The refinement polishes a pole
    /// within what the model orders leave open; a pole that walks out of its
    /// column over the sweeps has absorbed something else (a dropped
    /// neighbour, the band edge): measured tool holder H11, 1330.6 Hz column
    /// (1317.7–1333.5 Hz) walked to 1231 Hz at ζ 8.2 %, 1933.8 Hz to 1909.8 Hz.
    pub fn column_holds(&self, orders: &[PoleOrder], frequency_hz: f64) -> bool {
        let f_rep = self.representative_pole(orders).frequency_hz;
        let (lo, hi) = self.members.iter().fold(
            (f_rep * (1.0 - 0.002), f_rep * (1.0 + 0.002)),
            |(lo, hi), &(j, k)| {
                let f = orders[j].poles[k].frequency_hz;
                (lo.min(f), hi.max(f))
            },
        );
        (lo..=hi).contains(&frequency_hz)
    }

    /// How far the stable column's poles scatter around the root's pole:
    /// the robust standard deviation 1.4826 · median |x_m − x_r| / x_r of
    /// the members' frequencies and damping ratios about the reported
    /// pole's (0 for a single member). It is the estimate's own measure of
    /// its uncertainty: a well-determined mode's column agrees to a few
    /// 0.1 ‰ at every order; a column that gathered poles of two modes, or
    /// a pole the FRF refinement moved away from its column, scatters by
    /// percents. The median keeps one stray low-order pole from counting.
    pub fn spread(&self, orders: &[PoleOrder]) -> (f64, f64) {
        let p = self.pole(orders);
        let mad = |x: &dyn Fn(&super::Pole) -> f64, centre: f64| {
            if self.members.len() < 2 || centre <= 0.0 {
                return 0.0;
            }
            let dev: Vec<f64> = self
                .members
                .iter()
                .map(|&(j, k)| (x(&orders[j].poles[k]) - centre).abs())
                .collect();
            1.4826 * median(dev) / centre
        };
        (
            mad(&|q| q.frequency_hz, p.frequency_hz),
            mad(&|q| q.damping_ratio, p.damping_ratio),
        )
    }
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n == 0 {
        return 0.0;
    }
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// Median pole of a set of members.
fn median_pole(orders: &[PoleOrder], members: &[(usize, usize)]) -> (f64, f64) {
    let p = |m: &(usize, usize)| &orders[m.0].poles[m.1];
    (
        median(members.iter().map(|m| p(m).frequency_hz).collect()),
        median(members.iter().map(|m| p(m).damping_ratio).collect()),
    )
}

fn coincident(a: (f64, f64), b: (f64, f64)) -> bool {
    let (la, lb) = (pole_of(a.0, a.1), pole_of(b.0, b.1));
    (la - lb).norm() <= COINCIDENT * la.re.abs().min(lb.re.abs())
}

fn representative(orders: &[PoleOrder], members: &[(usize, usize)]) -> (usize, usize) {
    let (f, z) = median_pole(orders, members);
    let score = |m: &(usize, usize)| {
        let p = &orders[m.0].poles[m.1];
        (p.frequency_hz - f).abs() / f.max(1e-300) + (p.damping_ratio - z).abs() / z.max(1e-12)
    };
    members
        .iter()
        .copied()
        .min_by(|a, b| score(a).total_cmp(&score(b)).then(a.cmp(b)))
        .unwrap_or((0, 0))
}

fn distinct_orders(members: &[(usize, usize)]) -> usize {
    let mut o: Vec<usize> = members.iter().map(|m| m.0).collect();
    o.sort_unstable();
    o.dedup();
    o.len()
}

fn root(orders: &[PoleOrder], members: Vec<(usize, usize)>, multiplicity: usize) -> Root {
    Root {
        representative: representative(orders, &members),
        n_orders: distinct_orders(&members),
        multiplicity,
        members,
        refined: None,
    }
}

/// Number of independent participation vectors among the members.
fn participation_rank(orders: &[PoleOrder], members: &[(usize, usize)], n_ref: usize) -> usize {
    let mut g = vec![Complex64::new(0.0, 0.0); n_ref * n_ref];
    for m in members {
        let l = &orders[m.0].poles[m.1].participation;
        let norm2: f64 = l.iter().map(Complex64::norm_sqr).sum();
        if norm2 == 0.0 || l.len() != n_ref {
            continue;
        }
        for i in 0..n_ref {
            for j in 0..n_ref {
                g[i * n_ref + j] += l[i].conj() * l[j] / norm2;
            }
        }
    }
    let (values, _) = hermitian_eigen(&g, n_ref);
    let top = values.first().copied().unwrap_or(0.0).max(0.0).sqrt();
    values
        .iter()
        .filter(|&&v| top > 0.0 && v.max(0.0).sqrt() >= INDEPENDENT * top)
        .count()
        .max(1)
}

/// The largest m such that at least [`MIN_COLUMN`] orders hold m or more members.
fn count_per_order(members: &[(usize, usize)]) -> usize {
    let mut per: std::collections::BTreeMap<usize, usize> = std::collections::BTreeMap::new();
    for m in members {
        *per.entry(m.0).or_default() += 1;
    }
    let mut counts: Vec<usize> = per.into_values().collect();
    counts.sort_unstable_by(|a, b| b.cmp(a));
    counts.get(MIN_COLUMN - 1).copied().unwrap_or(1).max(1)
}

/// Modes at a root with these member poles: min(m_count, m_rank, n_ref).
pub fn multiplicity(orders: &[PoleOrder], members: &[(usize, usize)], n_ref: usize) -> usize {
    count_per_order(members)
        .min(participation_rank(orders, members, n_ref))
        .min(n_ref)
        .max(1)
}

/// The multiplicity of `root` on the evidence of all `candidates` (stable
/// poles of every computed order) that coincide with its median pole; never
/// below its present multiplicity. The model order the search chose can
/// stop short of the orders where a repeated root's second pole settles,
/// and FRAC cannot tell one pole with a rank-2 residue from two modes, so
/// the count uses every order. Weaker pole evidence — m coincident stable
/// poles in only two orders, with m independent participation vectors —
/// counts when the m-th CMIF curve peaks at the root (`cmif_peak(m, f, hw)`,
/// hw the half-power half-width) and no other root lies within 4 hw to
/// explain that peak.
pub fn multiplicity_over_all_orders(
    orders: &[PoleOrder],
    roots: &[Root],
    k: usize,
    candidates: &[(usize, usize)],
    n_ref: usize,
    cmif_peak: &dyn Fn(usize, f64, f64) -> bool,
) -> usize {
    let root = &roots[k];
    let (f, z) = median_pole(orders, &root.members);
    let l = pole_of(f, z);
    let near: Vec<(usize, usize)> = candidates
        .iter()
        .copied()
        .filter(|c| {
            let s = orders[c.0].poles[c.1].s;
            (s - l).norm() <= COINCIDENT * s.re.abs().min(l.re.abs())
        })
        .collect();
    let strict = multiplicity(orders, &near, n_ref);
    let hw = z * f;
    let alone = roots
        .iter()
        .enumerate()
        .all(|(j, r)| j == k || (r.pole(orders).frequency_hz - f).abs() > 4.0 * hw);
    let mut per: std::collections::BTreeMap<usize, usize> = std::collections::BTreeMap::new();
    for m in &near {
        *per.entry(m.0).or_default() += 1;
    }
    let rank = participation_rank(orders, &near, n_ref).min(n_ref);
    let weak = (2..=rank)
        .take_while(|&m| {
            let orders_m = per.values().filter(|&&c| c >= m).count();
            alone && orders_m >= 2 && (orders_m >= 3 || cmif_peak(m, f, hw))
        })
        .last()
        .unwrap_or(1);
    root.multiplicity.max(strict).max(weak)
}

/// Roots of the validated `clusters`, sorted by frequency; `candidates`
/// are all stable poles (those outside the clusters may join a root).
pub fn roots_from_clusters(
    orders: &[PoleOrder],
    clusters: &[Cluster],
    candidates: &[(usize, usize)],
    n_ref: usize,
) -> Vec<Root> {
    let mut medians: Vec<((f64, f64), usize)> = clusters
        .iter()
        .enumerate()
        .map(|(k, c)| (median_pole(orders, &c.members), k))
        .collect();
    medians.sort_by(|a, b| a.0 .0.total_cmp(&b.0 .0).then(a.1.cmp(&b.1)));
    // Step 1: chains of coincident neighbours.
    let mut groups: Vec<Vec<usize>> = Vec::new();
    let mut last: Option<(f64, f64)> = None;
    for &(m, k) in &medians {
        match (groups.last_mut(), last) {
            (Some(g), Some(prev)) if coincident(prev, m) => g.push(k),
            _ => groups.push(vec![k]),
        }
        last = Some(m);
    }
    let mut members_of: Vec<Vec<(usize, usize)>> = groups
        .iter()
        .map(|g| {
            g.iter()
                .flat_map(|&k| clusters[k].members.iter().copied())
                .collect()
        })
        .collect();
    adopt_strays(orders, &mut members_of, candidates);
    let mut roots = Vec::new();
    for members in members_of {
        let m = multiplicity(orders, &members, n_ref);
        if m == 1 {
            roots.push(root(orders, members, 1));
            continue;
        }
        match split_close(orders, &members, m) {
            Some(parts) => roots.extend(parts.into_iter().map(|p| root(orders, p, 1))),
            None => roots.push(root(orders, members, m)),
        }
    }
    roots.sort_by(|a, b| {
        a.pole(orders)
            .frequency_hz
            .total_cmp(&b.pole(orders).frequency_hz)
            .then(a.representative.cmp(&b.representative))
    });
    roots
}

/// Stable poles outside every group join the group whose median pole they
/// coincide with (the nearest one).
fn adopt_strays(
    orders: &[PoleOrder],
    groups: &mut [Vec<(usize, usize)>],
    candidates: &[(usize, usize)],
) {
    let taken: std::collections::BTreeSet<(usize, usize)> =
        groups.iter().flatten().copied().collect();
    let medians: Vec<Complex64> = groups
        .iter()
        .map(|g| {
            let (f, z) = median_pole(orders, g);
            pole_of(f, z)
        })
        .collect();
    for &c in candidates.iter().filter(|c| !taken.contains(c)) {
        let l = orders[c.0].poles[c.1].s;
        let near = (0..groups.len())
            .filter(|&g| {
                (medians[g] - l).norm() <= COINCIDENT * medians[g].re.abs().min(l.re.abs())
            })
            .min_by(|&a, &b| (medians[a] - l).norm().total_cmp(&(medians[b] - l).norm()));
        if let Some(g) = near {
            groups[g].push(c);
        }
    }
}

/// Step 3: the m sub-groups of a group when their medians are distinct roots.
fn split_close(
    orders: &[PoleOrder],
    members: &[(usize, usize)],
    m: usize,
) -> Option<Vec<Vec<(usize, usize)>>> {
    let mut by_order: std::collections::BTreeMap<usize, Vec<(usize, usize)>> =
        std::collections::BTreeMap::new();
    for &p in members {
        by_order.entry(p.0).or_default().push(p);
    }
    let mut sub: Vec<Vec<(usize, usize)>> = vec![Vec::new(); m];
    for ps in by_order.values().filter(|ps| ps.len() == m) {
        let mut ps = ps.clone();
        ps.sort_by(|a, b| {
            orders[a.0].poles[a.1]
                .frequency_hz
                .total_cmp(&orders[b.0].poles[b.1].frequency_hz)
        });
        for (k, p) in ps.into_iter().enumerate() {
            sub[k].push(p);
        }
    }
    if sub.iter().any(Vec::is_empty) {
        return None;
    }
    let meds: Vec<(f64, f64)> = sub.iter().map(|s| median_pole(orders, s)).collect();
    if meds.windows(2).any(|w| coincident(w[0], w[1])) {
        return None;
    }
    // Poles of the other orders join the nearest sub-group median.
    for ps in by_order.values().filter(|ps| ps.len() != m) {
        for &p in ps {
            let pole = &orders[p.0].poles[p.1];
            let l = pole.s;
            let k = (0..m)
                .min_by(|&a, &b| {
                    let da = (pole_of(meds[a].0, meds[a].1) - l).norm();
                    let db = (pole_of(meds[b].0, meds[b].1) - l).norm();
                    da.total_cmp(&db)
                })
                .unwrap_or(0);
            sub[k].push(p);
        }
    }
    Some(sub)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ema::Pole;

    fn pole(f: f64, z: f64, l: [f64; 2]) -> Pole {
        Pole {
            s: pole_of(f, z),
            frequency_hz: f,
            damping_ratio: z,
            participation: vec![Complex64::new(l[0], 0.0), Complex64::new(l[1], 0.0)],
        }
    }

    fn all(orders: &[PoleOrder]) -> Cluster {
        let members: Vec<(usize, usize)> = orders
            .iter()
            .enumerate()
            .flat_map(|(j, o)| (0..o.poles.len()).map(move |k| (j, k)))
            .collect();
        Cluster {
            representative: members[0],
            members,
        }
    }

    /// Ten orders, each with the poles `per_order(j)`.
    fn orders(per_order: impl Fn(usize) -> Vec<Pole>) -> Vec<PoleOrder> {
        (0..10)
            .map(|j| PoleOrder {
                order: j + 1,
                poles: per_order(j),
            })
            .collect()
    }

    /// A stable column: one pole per order from `poles`, and the root of
    /// all of them, represented by the third.
    fn column(poles: impl Iterator<Item = Pole>) -> (Vec<PoleOrder>, Root) {
        let o: Vec<PoleOrder> = poles
            .enumerate()
            .map(|(j, p)| PoleOrder {
                order: j + 1,
                poles: vec![p],
            })
            .collect();
        let root = Root {
            members: (0..o.len()).map(|j| (j, 0)).collect(),
            representative: (2, 0),
            multiplicity: 1,
            n_orders: o.len(),
            refined: None,
        };
        (o, root)
    }

    #[test]
    fn spread_is_the_robust_deviation_about_the_reported_pole() {
        // Members at 100 + {−2, −1, 0, 1, 2, 40} Hz: the median absolute
        // deviation about 100 Hz is 1.5 Hz (the stray 140 Hz pole does not
        // count), so the spread is 1.4826 · 1.5 / 100.
        let offsets = [-2.0, -1.0, 0.0, 1.0, 2.0, 40.0];
        let (o, mut root) = column(
            offsets
                .iter()
                .map(|d| pole(100.0 + d, 0.02 * (1.0 + d / 100.0), [1.0, 0.0])),
        );
        let (f, z) = root.spread(&o);
        assert!((f - 1.4826 * 1.5 / 100.0).abs() < 1e-12, "{f}");
        assert!((z - 1.4826 * 0.015).abs() < 1e-9, "{z}");
        // A refined pole 3 Hz off its column: the spread says so.
        root.refined = Some(pole(103.0, 0.02, [1.0, 0.0]));
        let (f, _) = root.spread(&o);
        assert!((f - 1.4826 * 3.5 / 103.0).abs() < 1e-12, "{f}");
        // One member: no spread to speak of.
        root.members.truncate(1);
        assert_eq!(root.spread(&o), (0.0, 0.0));
    }

    #[test]
    fn a_refined_pole_must_stay_in_its_column() {
        // Members at 98, 99, 100, 101 Hz, representative 100 Hz: the column
        // holds 98–101 Hz, ends included, and nothing outside.
        let (o, mut root) = column(
            [98.0, 99.0, 100.0, 101.0]
                .iter()
                .map(|&f| pole(f, 0.01, [1.0, 0.0])),
        );
        for (f, holds) in [(97.99, false), (98.0, true), (100.7, true), (101.01, false)] {
            assert_eq!(root.column_holds(&o, f), holds, "{f}");
        }
        // One member: ±0.2 % about it (100 ± 0.2 Hz).
        root.members = vec![(2, 0)];
        for (f, holds) in [
            (99.79, false),
            (99.81, true),
            (100.19, true),
            (100.21, false),
        ] {
            assert_eq!(root.column_holds(&o, f), holds, "{f}");
        }
    }

    #[test]
    fn a_simple_mode_is_one_root_of_multiplicity_one() {
        let o = orders(|j| {
            vec![pole(
                100.0 + 0.001 * j as f64,
                0.01,
                [1.0, 0.5 + 0.001 * j as f64],
            )]
        });
        let r = roots_from_clusters(&o, &[all(&o)], &[], 2);
        assert_eq!(r.len(), 1);
        assert_eq!((r[0].multiplicity, r[0].n_orders), (1, 10));
    }

    #[test]
    fn a_repeated_root_keeps_two_modes_and_close_modes_split() {
        // Two poles per order at 100 Hz (within 0.02 % of each other, ζ = 1 %:
        // coincident) with participation vectors rotating through the plane.
        let o = orders(|j| {
            let a = 0.3 * j as f64;
            vec![
                pole(100.0, 0.01, [a.cos(), a.sin()]),
                pole(100.02, 0.01, [-a.sin(), a.cos()]),
            ]
        });
        let r = roots_from_clusters(&o, &[all(&o)], &[], 2);
        assert_eq!(r.len(), 1, "{r:?}");
        assert_eq!(r[0].multiplicity, 2);
        // The same, 1 % apart with ζ = 0.5 %: two close modes.
        let o = orders(|_| {
            vec![
                pole(100.0, 0.005, [1.0, 0.2]),
                pole(101.0, 0.005, [0.1, 1.0]),
            ]
        });
        let r = roots_from_clusters(&o, &[all(&o)], &[], 2);
        assert_eq!(r.len(), 2, "{r:?}");
        assert!(r.iter().all(|x| x.multiplicity == 1 && x.n_orders == 10));
        assert!((r[1].pole(&o).frequency_hz - 101.0).abs() < 1e-12);
        // Two poles per order but one participation direction (a mode and
        // its duplicate): one root of multiplicity one.
        let o = orders(|_| {
            vec![
                pole(100.0, 0.01, [1.0, 0.2]),
                pole(100.05, 0.0101, [1.0, 0.21]),
            ]
        });
        let r = roots_from_clusters(&o, &[all(&o)], &[], 2);
        assert_eq!((r.len(), r[0].multiplicity), (1, 1));
        // One reference: never more than one mode per root.
        let r = roots_from_clusters(&o, &[all(&o)], &[], 1);
        assert_eq!(r[0].multiplicity, 1);
    }

    #[test]
    fn coincident_clusters_merge() {
        let o = orders(|_| {
            vec![
                pole(100.0, 0.01, [1.0, 0.0]),
                pole(100.1, 0.01, [0.0, 1.0]),
                pole(120.0, 0.01, [1.0, 1.0]),
            ]
        });
        let c = |k: usize| Cluster {
            members: (0..10).map(|j| (j, k)).collect(),
            representative: (0, k),
        };
        let r = roots_from_clusters(&o, &[c(0), c(1), c(2)], &[], 2);
        assert_eq!(r.len(), 2, "{r:?}");
        assert_eq!(r[0].multiplicity, 2);
        assert_eq!(r[0].members.len(), 20);
        assert_eq!(r[1].multiplicity, 1);
        // The 100.1 Hz poles as strays (not in a valid cluster) join the 100 Hz root.
        let strays: Vec<(usize, usize)> = (0..10).map(|j| (j, 1)).collect();
        let r = roots_from_clusters(&o, &[c(0), c(2)], &strays, 2);
        assert_eq!((r.len(), r[0].multiplicity, r[0].members.len()), (2, 2, 20));
    }
}
