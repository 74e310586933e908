//! Which reference mode is which mode of the model at its start values
//! ("nominal" modes), and which of them the sensors can see.
//!
//! GSA outputs (`p0.mode7.mac`) and `exclude_modes` name modes of the
//! nominal model — the model the screening ran on — because a measurement's
//! own numbering is arbitrary: AutoEMA finds 7–9 of 11 modes per position,
//! and a missed mode renumbers every mode above it. Here the nominal modes
//! are paired with the reference ([`crate::pairing`]: frequency and MAC, one
//! assignment), so a GSA subproblem lands on its physical mode or is dropped
//! with a reason, never silently shifted to a neighbour.
//!
//! **Observability.** A mode the sensors barely see (a local mode of an
//! unmeasured part: the ball screw's bending between its bearings) has a
//! shape at the sensors that is mostly noise, and a MAC that flips with tiny
//! parameter changes and traps a local optimizer. The criterion is the
//! sensor amplitude of the mass-normalized shape relative to the modes
//! around it,
//!
//! v_r = ‖S φ_r‖ / median_k ‖S φ_k‖   (k over the model modes in the band),
//!
//! scale-free and blind to the reference's noise. Two thresholds
//! ([`Observability`]): a mode with v_r below `modes` is left out; one below
//! `shapes` is compared by its frequency alone — the frequency of a weakly
//! seen mode is still estimated from the whole band of its peak, where its
//! shape at the sensors is a few noisy residues and its model MAC flips.
//! Either way the reason is written down. On the test bench the screw modes
//! have v = 0.05–0.22 and every global mode v ≥ 0.46; on the vertical mill
//! the sharp pairs at 54 and 174 Hz have v = 0.05–0.16.

use super::objective::{ModalObjective, SlotPairing};
use super::IdentifyError;
use crate::metrics::nfd;
use serde::Serialize;

/// How a reference mode left out because its partner barely moves the
/// sensors is worded ([`Correspondence::exclude_unobservable`]); the FRF
/// verdict's window note ([`super::local_misfit`]) keys on it.
pub(super) const NOT_OBSERVABLE: &str = "not observable";

/// How a mode's sensor amplitude v (module docs) decides its use: left out
/// below `modes`, compared by frequency alone below `shapes`, fully above
/// both.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Observability {
    pub modes: f64,
    pub shapes: f64,
}

impl Observability {
    /// Every mode in full, however weakly the sensors see it.
    pub fn all() -> Self {
        Observability {
            modes: 0.0,
            shapes: 0.0,
        }
    }
}

/// How a reference mode compared by its frequency alone is worded
/// ([`Correspondence::exclude_unobservable`]).
pub(super) const SHAPE_NOT_OBSERVABLE: &str = "frequency only, shape not observable";

/// A mode of the nominal model at one position.
#[derive(Clone, Debug, Serialize)]
pub struct NominalMode {
    /// 1-based number, ascending frequency (the GSA's `mode<r>`).
    pub number: usize,
    pub frequency_hz: f64,
    /// Sensor amplitude relative to the median (module docs).
    pub visibility: f64,
    /// The reference mode paired with it (index into the reference's modes).
    pub reference: Option<usize>,
    pub mac: f64,
    /// Increase of the pairing cost if this pair were forbidden.
    pub margin: f64,
}

/// The nominal modes of one position and their partners.
#[derive(Clone, Debug, Serialize)]
pub struct SlotCorrespondence {
    pub position: u32,
    pub nominal: Vec<NominalMode>,
    /// Per reference mode, the index of its nominal partner.
    pub partner: Vec<Option<usize>>,
}

/// GSA mode names of a screening: `p<position>.mode<r>` with the frequency
/// the screening saw (its reference's modes).
#[derive(Clone, Debug, PartialEq, serde::Deserialize, Serialize)]
pub struct NamedMode {
    pub name: String,
    pub frequency_hz: f64,
}

/// The correspondence of all positions.
#[derive(Clone, Debug, Serialize)]
pub struct Correspondence {
    pub slots: Vec<SlotCorrespondence>,
    /// Settings used.
    pub observability: Observability,
}

impl Correspondence {
    /// Pair the model's modes at `x0` with the reference of `o`, per slot.
    pub fn new(
        o: &ModalObjective,
        x0: &[f64],
        observability: Observability,
    ) -> Result<Correspondence, IdentifyError> {
        let models = o.model_modes(x0)?;
        let usable = o.usable();
        let mut slots = Vec::new();
        for (p, model) in models.iter().enumerate() {
            let n_ref = o.modes_at(p);
            // Modes already left out (duplicates) take no partner.
            let SlotPairing {
                idx,
                rf,
                mf,
                model_shapes: ms,
                pairs,
                margins: margin,
            } = o.pair_with_margins(p, model, &usable);
            // The band the reference covers, widened by the pairing window.
            let lo = rf.iter().copied().fold(f64::INFINITY, f64::min) * (1.0 - o.pairing.window);
            let hi = rf.iter().copied().fold(0.0, f64::max) * (1.0 + o.pairing.window);
            let amp: Vec<f64> = ms
                .iter()
                .map(|s| s.iter().map(|v| v.norm_sqr()).sum::<f64>().sqrt())
                .collect();
            let mut in_band: Vec<f64> = (0..mf.len())
                .filter(|&k| mf[k] >= lo && mf[k] <= hi)
                .map(|k| amp[k])
                .collect();
            in_band.sort_by(f64::total_cmp);
            let median = in_band.get(in_band.len() / 2).copied().unwrap_or(0.0);
            let mut nominal: Vec<NominalMode> = (0..mf.len())
                .map(|k| NominalMode {
                    number: k + 1,
                    frequency_hz: mf[k],
                    visibility: if median > 0.0 { amp[k] / median } else { 0.0 },
                    reference: None,
                    mac: 0.0,
                    margin: f64::INFINITY,
                })
                .collect();
            let mut partner = vec![None; n_ref];
            for (pair, m) in pairs.iter().zip(margin) {
                let r = idx[pair.reference];
                nominal[pair.candidate].reference = Some(r);
                nominal[pair.candidate].mac = pair.mac;
                nominal[pair.candidate].margin = m;
                partner[r] = Some(pair.candidate);
            }
            slots.push(SlotCorrespondence {
                position: o.position(p).index,
                nominal,
                partner,
            });
        }
        Ok(Correspondence {
            slots,
            observability,
        })
    }

    /// The nominal mode named `p<position>.mode<r>`: by the screening's
    /// frequency when `named` lists it (the nominal mode nearest to it,
    /// within 2 %), else by number. `Err` says why there is none.
    pub fn nominal_mode(
        &self,
        position: u32,
        number: usize,
        named: &[NamedMode],
    ) -> Result<(usize, usize), String> {
        let slot = self
            .slots
            .iter()
            .position(|s| s.position == position)
            .ok_or_else(|| {
                format!(
                    "position {position} is not in the reference or not selected by `positions`"
                )
            })?;
        let s = &self.slots[slot];
        let name = format!("p{position}.mode{number}");
        let index = match named.iter().find(|m| m.name == name) {
            Some(m) => s
                .nominal
                .iter()
                .enumerate()
                .min_by(|a, b| {
                    nfd(a.1.frequency_hz, m.frequency_hz)
                        .total_cmp(&nfd(b.1.frequency_hz, m.frequency_hz))
                })
                .filter(|(_, n)| nfd(n.frequency_hz, m.frequency_hz) <= 0.02)
                .map(|(k, _)| k)
                .ok_or_else(|| {
                    format!(
                        "the screening's {name} ({:.2} Hz) has no mode of this model within 2 % at its start values",
                        m.frequency_hz
                    )
                })?,
            None if number >= 1 && number <= s.nominal.len() => number - 1,
            None => {
                return Err(format!(
                    "the model has {} modes at position {position}, no mode {number}",
                    s.nominal.len()
                ))
            }
        };
        Ok((slot, index))
    }

    /// The reference mode paired with the nominal mode named
    /// `p<position>.mode<r>` (see [`Self::nominal_mode`]): (slot, reference
    /// mode index), or why there is none.
    pub fn reference_mode(
        &self,
        position: u32,
        number: usize,
        named: &[NamedMode],
    ) -> Result<(usize, usize), String> {
        let (slot, k) = self.nominal_mode(position, number, named)?;
        let n = &self.slots[slot].nominal[k];
        n.reference.map(|r| (slot, r)).ok_or_else(|| {
            format!(
                "p{position}.mode{number} ({:.2} Hz in the model) pairs with no reference mode",
                n.frequency_hz
            )
        })
    }

    /// Exclude from `o` the second of any two reference modes of one
    /// position that are one mode estimated twice: frequencies within 1 %
    /// and MAC ≥ 0.9 at the shared DOFs (an EMA that split one mode into two
    /// clusters). Two true modes that close are orthogonal in the mass
    /// metric, and sensors that still see them alike cannot tell them apart
    /// either; of the pair, the one with the more complex shape (the worse
    /// estimate, [`super::objective::Uncertainty`]) is left out. Returns how
    /// many.
    pub fn exclude_duplicates(o: &mut ModalObjective) -> usize {
        let mut count = 0;
        for p in 0..o.positions() {
            let n = o.modes_at(p);
            for a in 0..n {
                for b in (a + 1)..n {
                    if o.exclusion(p, a).is_some() || o.exclusion(p, b).is_some() {
                        continue;
                    }
                    let (fa, fb) = (o.reference_frequency(p, a), o.reference_frequency(p, b));
                    let m = crate::metrics::mac(o.reference_shape(p, a), o.reference_shape(p, b));
                    if nfd(fa, fb) > 0.01 || m < 0.9 {
                        continue;
                    }
                    let (ca, cb) = (
                        super::objective::complexity(o.reference_shape(p, a)),
                        super::objective::complexity(o.reference_shape(p, b)),
                    );
                    let (keep, drop) = if cb < ca { (b, a) } else { (a, b) };
                    o.exclude(
                        p,
                        drop,
                        format!(
                            "a duplicate of reference mode {} ({:.2} Hz, MAC {m:.3} between them): one mode estimated twice",
                            keep + 1,
                            o.reference_frequency(p, keep)
                        ),
                    );
                    count += 1;
                }
            }
        }
        count
    }

    /// Exclude from `o` every reference mode whose nominal partner the
    /// sensors barely see, and compare by frequency alone those they see
    /// weakly ([`Observability`]); returns how many were excluded.
    pub fn exclude_unobservable(&self, o: &mut ModalObjective) -> usize {
        let Observability { modes, shapes } = self.observability;
        let mut count = 0;
        for (p, s) in self.slots.iter().enumerate() {
            for n in &s.nominal {
                let Some(r) = n.reference.filter(|_| n.visibility < modes.max(shapes)) else {
                    continue;
                };
                let seen = format!(
                    "its model mode p{}.mode{} ({:.1} Hz) moves the sensors {:.2}× as much as the median mode",
                    s.position, n.number, n.frequency_hz, n.visibility
                );
                if n.visibility < modes {
                    o.exclude(
                        p,
                        r,
                        format!("{NOT_OBSERVABLE}: {seen} (threshold {modes})"),
                    );
                    count += 1;
                } else {
                    o.compare_frequency_only(
                        p,
                        r,
                        format!("{SHAPE_NOT_OBSERVABLE}: {seen} (shape threshold {shapes})"),
                    );
                }
            }
        }
        count
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::identify::black_box::tests::objective;
    use crate::identify::objective::ModeUse;

    /// Below `modes` a mode leaves, below `shapes` its frequency alone
    /// counts, above both it is compared in full; each says why.
    #[test]
    fn two_thresholds_split_the_modes_by_how_well_the_sensors_see_them() {
        let mut o = objective();
        let all = Correspondence::new(&o, &o.nominal(), Observability::all()).unwrap();
        let slot = &all.slots[0];
        let mut seen: Vec<(f64, usize)> = slot
            .nominal
            .iter()
            .filter_map(|n| n.reference.map(|r| (n.visibility, r)))
            .collect();
        seen.sort_by(|a, b| a.0.total_cmp(&b.0));
        assert_eq!(seen.len(), 3, "{seen:?}");
        assert!(seen[0].0 < seen[1].0 && seen[1].0 < seen[2].0, "{seen:?}");
        let between = |a: f64, b: f64| 0.5 * (a + b);
        let thresholds = Observability {
            modes: between(seen[0].0, seen[1].0),
            shapes: between(seen[1].0, seen[2].0),
        };
        let c = Correspondence::new(&o, &o.nominal(), thresholds).unwrap();
        assert_eq!(c.exclude_unobservable(&mut o), 1);
        let (low, mid, high) = (seen[0].1, seen[1].1, seen[2].1);
        assert!(o.exclusion(0, low).unwrap().starts_with(NOT_OBSERVABLE));
        let ModeUse::FrequencyOnly(why) = o.mode_use(0, mid) else {
            panic!("{:?}", o.mode_use(0, mid));
        };
        assert!(
            why.starts_with(SHAPE_NOT_OBSERVABLE) && why.contains("shape threshold"),
            "{why}"
        );
        assert_eq!(o.mode_use(0, high), &ModeUse::Full);
    }
}
