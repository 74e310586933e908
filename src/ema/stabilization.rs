//! Stabilization (Peeters et al. 2004, section 3; seed section 5.2.2): each
//! pole of order n is compared with the poles P of order n − 1 that lie
//! within the frequency tolerance, |f − f'|/f ≤ ε_f (stable in frequency when
//! there is one). It is stable in damping when one of them satisfies
//! |ζ − ζ'|/ζ ≤ ε_ζ, and stable in vector when its participation vector L
//! lies in the span of the participation vectors of those partners (of the
//! damping-stable ones when there are any, else of all of P):
//!
//! 1 − MAC_S(L, span{L' : p' ∈ P}) ≤ ε_MAC,
//!
//! where MAC_S is the MAC between L and its projection on the span — the
//! plain MAC with one partner. At a repeated root PolyMAX returns as many
//! poles as the root has modes, with participation vectors that are an
//! arbitrary basis of the modal subspace and rotate from order to order; a
//! vector-by-vector comparison with the nearest pole calls them unstable,
//! the subspace comparison does not. Poles outside 0 < ζ < ζ_max or outside
//! the band are never stable.
//!
//! The classes of the stabilization diagram follow from the flags
//! ([`PoleClass`]): new (no partner), stable in frequency, in frequency and
//! damping, in frequency and vector, and stable in all three.

use super::hermitian::subspace_mac;
use super::PoleOrder;
use num_complex::Complex64;

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

/// The symbol classes of a stabilization diagram.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum PoleClass {
    /// Outside the band or the damping bounds.
    Unphysical,
    /// No pole of the previous order within the frequency tolerance.
    New,
    /// Stable in frequency only.
    Frequency,
    /// Stable in frequency and damping.
    Damping,
    /// Stable in frequency and participation vector.
    Vector,
    /// Stable in frequency, damping and vector.
    Stable,
}

impl PoleClass {
    /// One-letter code as in commercial stabilization diagrams.
    pub fn code(self) -> &'static str {
        match self {
            PoleClass::Unphysical => "x",
            PoleClass::New => "o",
            PoleClass::Frequency => "f",
            PoleClass::Damping => "d",
            PoleClass::Vector => "v",
            PoleClass::Stable => "s",
        }
    }
}

impl PoleFlags {
    /// Physical and stable in frequency, damping and vector.
    pub fn stable(&self) -> bool {
        self.physical && self.stable_frequency && self.stable_damping && self.stable_vector
    }

    /// The diagram class of these flags.
    pub fn class(&self) -> PoleClass {
        match (
            self.physical,
            self.stable_frequency,
            self.stable_damping,
            self.stable_vector,
        ) {
            (false, ..) => PoleClass::Unphysical,
            (true, false, ..) => PoleClass::New,
            (true, true, true, true) => PoleClass::Stable,
            (true, true, false, true) => PoleClass::Vector,
            (true, true, true, false) => PoleClass::Damping,
            (true, true, false, false) => PoleClass::Frequency,
        }
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
                    if j == 0 || f <= 0.0 {
                        return flags;
                    }
                    let prev = &orders[j - 1].poles;
                    // Poles are sorted by frequency: the partners within ε_f are one run.
                    let lo = prev.partition_point(|q| q.frequency_hz < f * (1.0 - p.frequency_tol));
                    let partners: Vec<&super::Pole> = prev[lo..]
                        .iter()
                        .take_while(|q| q.frequency_hz <= f * (1.0 + p.frequency_tol))
                        .filter(|q| (q.frequency_hz - f).abs() / f <= p.frequency_tol)
                        .collect();
                    if partners.is_empty() {
                        return flags;
                    }
                    flags.stable_frequency = true;
                    let damped: Vec<&super::Pole> = partners
                        .iter()
                        .copied()
                        .filter(|q| z > 0.0 && (q.damping_ratio - z).abs() / z <= p.damping_tol)
                        .collect();
                    flags.stable_damping = !damped.is_empty();
                    let basis: Vec<Vec<Complex64>> = if damped.is_empty() {
                        &partners
                    } else {
                        &damped
                    }
                    .iter()
                    .map(|q| q.participation.clone())
                    .collect();
                    flags.stable_vector =
                        1.0 - subspace_mac(&pole.participation, &basis) <= p.mac_tol;
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

    fn pole(f: f64, z: f64, l: [f64; 2]) -> Pole {
        Pole {
            s: crate::metrics::pole(f, z),
            frequency_hz: f,
            damping_ratio: z,
            participation: vec![Complex64::new(l[0], 0.0), Complex64::new(l[1], 0.0)],
        }
    }

    fn params() -> StabilizationParams {
        StabilizationParams {
            frequency_tol: 0.01,
            damping_tol: 0.05,
            mac_tol: 0.01,
            max_damping: 0.1,
            band_hz: (0.0, 500.0),
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
        let p = params();
        let flags = stabilize(&orders, 2, &p);
        assert_eq!(
            flags[0][0].class(),
            PoleClass::New,
            "first order has nothing to compare with"
        );
        assert!(flags[1][0].stable());
        assert_eq!(flags[1][0].class(), PoleClass::Stable);
        // 150 Hz is 50 % away from its nearest neighbour: a new pole.
        assert!(!flags[1][1].stable_frequency);
        assert_eq!(flags[1][1].class(), PoleClass::New);
        // ζ = 0.3 exceeds ζ_max: not physical.
        assert!(!flags[1][2].physical && !flags[1][2].stable());
        assert_eq!(flags[1][2].class(), PoleClass::Unphysical);
        let tight = StabilizationParams {
            frequency_tol: 1e-4,
            ..p.clone()
        };
        assert!(!stabilize(&orders, 2, &tight)[1][0].stable());
        assert_eq!(stabilize(&orders, 1, &p).len(), 1);
        // Damping off by 10 %: frequency and vector stable only.
        let loose_z = StabilizationParams {
            damping_tol: 0.001,
            ..p
        };
        assert_eq!(
            stabilize(&orders, 2, &loose_z)[1][0].class(),
            PoleClass::Vector
        );
    }

    /// A repeated root: two poles per order at the same frequency with
    /// participation vectors that rotate between orders (here swapped and
    /// mixed). Compared with the subspace of the previous order's partners
    /// both stay vector-stable.
    #[test]
    fn repeated_roots_match_their_own_partner() {
        let orders = vec![
            PoleOrder {
                order: 1,
                poles: vec![
                    pole(99.999, 0.02, [0.0, 1.0]),
                    pole(100.003, 0.02, [1.0, 0.0]),
                ],
            },
            PoleOrder {
                order: 2,
                poles: vec![
                    pole(100.0, 0.02, [1.0, 1.0]),
                    pole(100.002, 0.02, [1.0, -1.0]),
                ],
            },
        ];
        let flags = stabilize(&orders, 2, &params());
        assert!(flags[1][0].stable() && flags[1][1].stable(), "{flags:?}");
        // With the frequency tolerance too tight for the second partner, the
        // 100.0 Hz pole is stable in frequency and damping but not in vector
        // (MAC 0.5 with the one partner left).
        let tight = StabilizationParams {
            frequency_tol: 2e-5,
            ..params()
        };
        assert_eq!(
            stabilize(&orders, 2, &tight)[1][0].class(),
            PoleClass::Damping
        );
    }
}
