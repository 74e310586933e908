//! Unit tests of the autoema stage's parameter handling.

use super::*;
use crate::ema::{whitening::NoiseModel, Reciprocity, Weighting};
use crate::stages::{ParamSet, Stage};

fn params(yaml: &str) -> Params {
    Params::parse(&serde_yaml_ng::from_str(yaml).unwrap()).unwrap()
}

#[test]
fn settings_parse_order_ranges_and_reject_bad_values() {
    let s = settings(&params(
        "{max_order: 30, iterations: 5, fixed: {mac_weight: 0.5}, seed: 9}",
    ));
    assert_eq!(s.ema.max_order, Some((30, 30)));
    assert_eq!((s.ema.evaluations, s.ema.design), (5, 0), "no seed");
    assert_eq!(s.reciprocity, Reciprocity::Auto);
    assert_eq!(s.ema.fixed.get("mac_weight"), Some(&0.5));
    let s = settings(&params(
        "{max_order: [10, 50], band: [5, 400], weighting: coherence, reciprocity: never}",
    ));
    assert_eq!(s.reciprocity, Reciprocity::Never);
    assert_eq!(s.ema.max_order, Some((10, 50)));
    assert_eq!(s.band, Some((5.0, 400.0)));
    assert_eq!(s.weighting, Weighting::Coherence);
    // The coherence is the noise model: no whitening on top of it.
    assert_eq!(s.ema.noise, NoiseModel::White);
    assert_eq!(settings(&params("{}")).ema.noise, NoiseModel::Auto);
    let forced = settings(&params("{noise: profile}"));
    assert_eq!(forced.ema.noise, NoiseModel::Profile);
    let coherent = settings(&params("{noise: profile, weighting: coherence}"));
    assert_eq!(coherent.ema.noise, NoiseModel::White);
    for bad in [
        "{max_order: [50, 10]}",
        "{max_order: 2.5}",
        "{max_order: 401}",
        "{band: [400]}",
        "{penalty: -1}",
        "{significance: 0}",
        "{bounds: {max_order: [1, 2]}}",
        "{bounds: {max_damping: [0.3, 0.1]}}",
        "{fixed: {max_damp: 0.1}}",
        "{iterations: 0}",
        "{reciprocity: sometimes}",
    ] {
        let problems = AutoEma
            .parse(&serde_yaml_ng::from_str(bad).unwrap())
            .err()
            .unwrap_or_else(|| panic!("{bad} accepted"));
        for p in &problems {
            assert!(
                !p.path.is_empty() && p.help.is_some(),
                "{bad}: {}",
                p.message
            );
        }
    }
}
