//! Hierarchical clustering of stable poles into modes (seed section 5.2.2;
//! Neu et al. 2017, "Fully automated operational modal analysis using
//! multi-stage clustering", MSSP 84, doi:10.1016/j.ymssp.2016.07.031):
//! average linkage (kodama) on the distance
//!
//! d(p, q) = |f_p − f_q|/max(f_p, f_q) + w_ζ |ζ_p − ζ_q|/max(ζ_p, ζ_q)
//!           + w_MAC (1 − MAC(L_p, L_q)),
//!
//! cut at a threshold; a cluster is a mode candidate when it holds poles of
//! at least a given fraction of the model orders, and of no fewer than
//! [`MIN_COLUMN`] orders (a stable column, whatever the fraction), and its
//! frequencies stay within the threshold of their median. Each mode is represented by the member nearest
//! the cluster median (frequency and damping).

use super::PoleOrder;
use crate::metrics::mac;

/// The fewest model orders a cluster must span to be a mode candidate.
pub const MIN_COLUMN: usize = 5;

/// Clustering hyperparameters (three of the eight of PUB5, plus the order count).
#[derive(Clone, Debug, PartialEq)]
pub struct ClusterParams {
    /// Cut height of the dendrogram.
    pub distance_threshold: f64,
    /// Minimum share of the considered orders a cluster must hold poles of.
    pub min_fraction: f64,
    /// Weight w_ζ of the damping term of the distance.
    pub damping_weight: f64,
    /// Weight w_MAC of the participation-vector term.
    pub mac_weight: f64,
    /// Number of model orders considered (for `min_fraction`).
    pub n_orders: usize,
}

/// A validated cluster of poles, `(order index, pole index)` pairs.
#[derive(Clone, Debug, PartialEq)]
pub struct Cluster {
    pub members: Vec<(usize, usize)>,
    /// The member nearest the cluster median.
    pub representative: (usize, usize),
}

/// Cluster the `candidates` (stable poles) of `orders`; validated clusters
/// sorted by the frequency of their representative.
pub fn cluster_poles(
    orders: &[PoleOrder],
    candidates: &[(usize, usize)],
    p: &ClusterParams,
) -> Vec<Cluster> {
    let n = candidates.len();
    if n == 0 {
        return Vec::new();
    }
    let pole = |k: usize| &orders[candidates[k].0].poles[candidates[k].1];
    let mut condensed = Vec::with_capacity(n * (n - 1) / 2);
    for a in 0..n {
        let pa = pole(a);
        for b in a + 1..n {
            let pb = pole(b);
            let df =
                (pa.frequency_hz - pb.frequency_hz).abs() / pa.frequency_hz.max(pb.frequency_hz);
            let zmax = pa.damping_ratio.max(pb.damping_ratio);
            let dz = if zmax > 0.0 {
                (pa.damping_ratio - pb.damping_ratio).abs() / zmax
            } else {
                0.0
            };
            let dm = 1.0 - mac(&pa.participation, &pb.participation);
            condensed.push(df + p.damping_weight * dz + p.mac_weight * dm);
        }
    }
    // Union-find over the dendrogram steps below the cut.
    let mut parent: Vec<usize> = (0..n).collect();
    fn root(parent: &mut [usize], mut i: usize) -> usize {
        while parent[i] != i {
            parent[i] = parent[parent[i]];
            i = parent[i];
        }
        i
    }
    if n > 1 {
        let dendrogram = kodama::linkage(&mut condensed, n, kodama::Method::Average);
        let mut rep: Vec<usize> = (0..n).collect();
        for step in dendrogram.steps() {
            let (a, b) = (rep[step.cluster1], rep[step.cluster2]);
            if step.dissimilarity <= p.distance_threshold {
                let (ra, rb) = (root(&mut parent, a), root(&mut parent, b));
                parent[ra.max(rb)] = ra.min(rb);
            }
            rep.push(a);
        }
    }
    let mut groups: Vec<Vec<usize>> = Vec::new();
    let mut group_of = vec![usize::MAX; n];
    for k in 0..n {
        let r = root(&mut parent, k);
        if group_of[r] == usize::MAX {
            group_of[r] = groups.len();
            groups.push(Vec::new());
        }
        groups[group_of[r]].push(k);
    }
    let min_orders = ((p.min_fraction * p.n_orders as f64).ceil() as usize)
        .max(MIN_COLUMN.min(p.n_orders.max(1)));
    let mut clusters: Vec<(f64, Cluster)> = groups
        .into_iter()
        .filter_map(|g| {
            let mut orders_in: Vec<usize> = g.iter().map(|&k| candidates[k].0).collect();
            orders_in.sort_unstable();
            orders_in.dedup();
            if orders_in.len() < min_orders {
                return None;
            }
            let f_med = median(g.iter().map(|&k| pole(k).frequency_hz).collect());
            let z_med = median(g.iter().map(|&k| pole(k).damping_ratio).collect());
            let spread = g
                .iter()
                .map(|&k| (pole(k).frequency_hz - f_med).abs() / f_med)
                .fold(0.0, f64::max);
            if spread > p.distance_threshold {
                return None;
            }
            let score = |k: usize| {
                (pole(k).frequency_hz - f_med).abs() / f_med
                    + (pole(k).damping_ratio - z_med).abs() / z_med.max(1e-12)
            };
            let best = g
                .iter()
                .copied()
                .min_by(|&a, &b| score(a).total_cmp(&score(b)).then(a.cmp(&b)))?;
            Some((
                pole(best).frequency_hz,
                Cluster {
                    members: g.iter().map(|&k| candidates[k]).collect(),
                    representative: candidates[best],
                },
            ))
        })
        .collect();
    clusters.sort_by(|a, b| a.0.total_cmp(&b.0));
    clusters.into_iter().map(|(_, c)| c).collect()
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ema::Pole;
    use num_complex::Complex64;

    #[test]
    fn separates_two_modes_and_drops_a_sparse_cluster() {
        let mk = |f: f64, z: f64| Pole {
            s: crate::metrics::pole(f, z),
            frequency_hz: f,
            damping_ratio: z,
            participation: vec![Complex64::new(1.0, 0.0)],
        };
        // 10 orders, each with poles near 50 and 80 Hz; one stray pole at 65 Hz.
        let orders: Vec<PoleOrder> = (0..10)
            .map(|j| {
                let e = 1e-4 * j as f64;
                let mut poles = vec![mk(50.0 * (1.0 + e), 0.02), mk(80.0 * (1.0 - e), 0.01)];
                if j == 5 {
                    poles.insert(1, mk(65.0, 0.05));
                }
                PoleOrder {
                    order: j + 1,
                    poles,
                }
            })
            .collect();
        let candidates: Vec<(usize, usize)> = orders
            .iter()
            .enumerate()
            .flat_map(|(j, o)| (0..o.poles.len()).map(move |k| (j, k)))
            .collect();
        let p = ClusterParams {
            distance_threshold: 0.01,
            min_fraction: 0.5,
            damping_weight: 0.1,
            mac_weight: 1.0,
            n_orders: 10,
        };
        let c = cluster_poles(&orders, &candidates, &p);
        assert_eq!(c.len(), 2);
        assert_eq!(c[0].members.len(), 10);
        let rep =
            |cl: &Cluster| orders[cl.representative.0].poles[cl.representative.1].frequency_hz;
        assert!((rep(&c[0]) - 50.0).abs() < 0.05 && (rep(&c[1]) - 80.0).abs() < 0.05);
        // A huge cut merges everything into one cluster whose spread is too wide.
        let wide = ClusterParams {
            distance_threshold: 10.0,
            ..p.clone()
        };
        assert_eq!(cluster_poles(&orders, &candidates, &wide).len(), 1);
        let strict = ClusterParams {
            min_fraction: 1.0,
            n_orders: 11,
            ..p
        };
        assert!(cluster_poles(&orders, &candidates, &strict).is_empty());
    }
}
