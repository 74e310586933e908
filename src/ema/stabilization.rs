//! Stabilization (Peeters et al. 2004, section 3; seed section 5.2.2): each
//! pole of order n is compared with the nearest pole (in frequency) of order
//! n − 1. It is stable in frequency, damping and vector when the relative
//! frequency difference, the relative damping difference and 1 − MAC of the
//! participation vectors stay below their tolerances; poles outside
//! 0 < ζ < ζ_max or outside the band are never stable.

use super::PoleOrder;
use crate::metrics::mac;

/// Classification hyperparameters (four of the eight of PUB5).
#[derive(Clone, Debug, PartialEq)]
pub struct StabilizationParams {
    /// Relative frequency tolerance |f − f'|/f.
    pub frequency_tol: f64,
    /// Relative damping tolerance |ζ − ζ'|/ζ.
    pub damping_tol: f64,
    /// Tolerance on 1 − MAC of the participation vectors.
    pub mac_tol: f64,
    /// Upper damping bound ζ_max.
    pub max_damping: f64,
    /// Frequency band [Hz] in which poles are physical.
    pub band_hz: (f64, f64),
}

/// The stabilization flags of one pole.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct PoleFlags {
    /// Inside the band with 0 < ζ < ζ_max.
    pub physical: bool,
    pub stable_frequency: bool,
    pub stable_damping: bool,
    pub stable_vector: bool,
}

impl PoleFlags {
    /// Physical and stable in frequency, damping and vector.
    pub fn stable(&self) -> bool {
        self.physical && self.stable_frequency && self.stable_damping && self.stable_vector
    }
}

/// Flags for every pole of `orders[..n_orders]` (per order, per pole).
pub fn stabilize(
    orders: &[PoleOrder],
    n_orders: usize,
    p: &StabilizationParams,
) -> Vec<Vec<PoleFlags>> {
    let n_orders = n_orders.min(orders.len());
    (0..n_orders)
        .map(|j| {
            orders[j]
                .poles
                .iter()
                .map(|pole| {
                    let f = pole.frequency_hz;
                    let z = pole.damping_ratio;
                    let physical =
                        z > 0.0 && z < p.max_damping && f >= p.band_hz.0 && f <= p.band_hz.1;
                    let mut flags = PoleFlags {
                        physical,
                        ..PoleFlags::default()
                    };
                    if j == 0 {
                        return flags;
                    }
                    let prev = &orders[j - 1].poles;
                    // Poles are sorted by frequency: the nearest is next to the insertion point.
                    let at = prev.partition_point(|q| q.frequency_hz < f);
                    let nearest = [at.wrapping_sub(1), at]
                        .into_iter()
                        .filter(|&k| k < prev.len())
                        .min_by(|&a, &b| {
                            (prev[a].frequency_hz - f)
                                .abs()
                                .total_cmp(&(prev[b].frequency_hz - f).abs())
                        });
                    if let Some(k) = nearest {
                        let q = &prev[k];
                        flags.stable_frequency = (q.frequency_hz - f).abs() / f <= p.frequency_tol;
                        flags.stable_damping =
                            z > 0.0 && (q.damping_ratio - z).abs() / z <= p.damping_tol;
                        flags.stable_vector =
                            1.0 - mac(&pole.participation, &q.participation) <= p.mac_tol;
                    }
                    flags
                })
                .collect()
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ema::Pole;
    use num_complex::Complex64;

    fn pole(f: f64, z: f64, l: [f64; 2]) -> Pole {
        Pole {
            s: crate::metrics::pole(f, z),
            frequency_hz: f,
            damping_ratio: z,
            participation: vec![Complex64::new(l[0], 0.0), Complex64::new(l[1], 0.0)],
        }
    }

    #[test]
    fn flags_follow_the_tolerances() {
        let orders = vec![
            PoleOrder {
                order: 1,
                poles: vec![pole(100.0, 0.02, [1.0, 0.0])],
            },
            PoleOrder {
                order: 2,
                poles: vec![
                    pole(100.05, 0.0201, [1.0, 0.01]),
                    pole(150.0, 0.02, [1.0, 0.0]),
                    pole(300.0, 0.3, [0.0, 1.0]),
                ],
            },
        ];
        let p = StabilizationParams {
            frequency_tol: 0.01,
            damping_tol: 0.05,
            mac_tol: 0.01,
            max_damping: 0.1,
            band_hz: (0.0, 500.0),
        };
        let flags = stabilize(&orders, 2, &p);
        assert!(
            !flags[0][0].stable(),
            "first order has nothing to compare with"
        );
        assert!(flags[1][0].stable());
        // 150 Hz is 50 % away from its nearest neighbour: unstable in frequency.
        assert!(!flags[1][1].stable_frequency && flags[1][1].stable_damping);
        // ζ = 0.3 exceeds ζ_max: not physical.
        assert!(!flags[1][2].physical && !flags[1][2].stable());
        let tight = StabilizationParams {
            frequency_tol: 1e-4,
            ..p.clone()
        };
        assert!(!stabilize(&orders, 2, &tight)[1][0].stable());
        assert_eq!(stabilize(&orders, 1, &p).len(), 1);
    }
}
