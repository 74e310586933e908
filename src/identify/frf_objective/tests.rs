use super::*;
use crate::identify::black_box::tests::{model, truth};
use crate::identify::frf_refinement::tests::measured;

/// The chain with its dampers at `damping` times the truth's, and its
/// FRFs with 1 % noise (`seed`).
pub(super) fn light_chain(damping: f64, seed: u64) -> (PreparedModel, Vec<f64>, FrfSet) {
    let prepared = PreparedModel::new(&model()).unwrap();
    let mut light = truth();
    light[4..].iter_mut().for_each(|c| *c *= damping);
    let set = measured(&prepared, &light, 0.01, seed);
    (prepared, light, set)
}

/// The FRF reference of the one set `set` on 10–400 Hz under `noise`.
pub(super) fn one_set(prepared: &PreparedModel, set: &FrfSet, noise: FrfNoise) -> FrfReference {
    FrfReference::new(
        prepared,
        std::slice::from_ref(set),
        None,
        (10.0, 400.0),
        noise,
    )
    .unwrap()
}

#[test]
fn frequency_drift_bounds_a_lightly_damped_peaks_misfit_and_leaves_the_noise() {
    // Dampers at 2 % of the truth's: peaks narrower than the 0.5 Hz
    // lines, as a ball screw's.
    let (prepared, light, set) = light_chain(0.02, 4);
    let band = (10.0, 400.0);
    let reference = |drift: f64| {
        let noise = FrfNoise {
            drift,
            ..FrfNoise::default()
        };
        FrfReference::new(&prepared, std::slice::from_ref(&set), None, band, noise).unwrap()
    };
    let (plain, drifting) = (reference(0.0), reference(1e-4));
    assert!(drifting
        .noise_model()
        .ends_with("a frequency drift of 1e-4 (relative) at each line"));
    // At the truth the drift term changes little: the noise is the
    // channel's almost everywhere.
    let (a, b) = (
        plain.fit(&prepared, &light).unwrap(),
        drifting.fit(&prepared, &light).unwrap(),
    );
    assert!((0.85..1.2).contains(&a.rms), "{a:?}");
    assert!(b.rms <= a.rms && b.rms > 0.95 * a.rms, "{a:?} {b:?}");
    // A stiffness 0.05 % off moves the first modes by 1–2.5 δ: without
    // the term the spikes make it 10σ off, with it it is at the noise.
    let mut near = light.clone();
    near[0] *= 1.0005;
    let (a, b) = (
        plain.fit(&prepared, &near).unwrap(),
        drifting.fit(&prepared, &near).unwrap(),
    );
    assert!(a.rms > 8.0, "{a:?}");
    assert!(b.rms < 1.1, "{b:?}");
    // 5 % off, the measured spikes stand where the model has no peak
    // and no drift term: far above the noise either way.
    let mut far = light.clone();
    far[0] *= 1.05;
    let b = drifting.fit(&prepared, &far).unwrap();
    assert!(b.rms > 8.0, "{b:?}");
}

/// The worst window finds a misplaced resonance the overall RMS
/// dilutes, and stays near 1 at the truth.
#[test]
fn the_local_misfit_sits_on_a_misplaced_peak() {
    let (prepared, light, set) = light_chain(0.05, 7);
    let r = FrfReference::new(
        &prepared,
        std::slice::from_ref(&set),
        None,
        (10.0, 400.0),
        FrfNoise::default(),
    )
    .unwrap();
    let at = r.fit(&prepared, &light).unwrap();
    let l = at.local.unwrap();
    assert!(l.rms < 1.8 && l.rms > at.rms, "{at:?}");
    // One stiffness 0.3 % off: a few lines at each peak, tens of σ.
    let mut near = light.clone();
    near[0] *= 1.003;
    let off = r.fit(&prepared, &near).unwrap();
    let l = off.local.unwrap();
    assert!(l.rms > 4.0 * off.rms && l.rms > 10.0, "{off:?}");
    let sol = prepared
        .evaluate_modes(0, &near, ModeSelection::Below(400.0))
        .unwrap();
    let nearest = sol
        .eigenvalues
        .iter()
        .map(|w2| (w2.sqrt() / std::f64::consts::TAU - l.frequency_hz).abs())
        .fold(f64::INFINITY, f64::min);
    assert!(nearest < 2.0, "{l:?} is {nearest} Hz from the nearest mode");
}

/// An impact test without an exponential window, of the chain with its
/// dampers at 1/40 of the truth's (ζ 0.03–0.05 %: e^{−ζωT} 0.2–0.5 at the
/// record's end, T = 4 s): the estimate is the FRF of the truncated
/// impulse responses. Modelled as such (`truncation`, the hit's centre
/// 10.5 ms into the record), the truth fits at the noise; as the plain
/// superposition, the same truth is 9.3σ off.
#[test]
fn an_impact_tests_truncated_record_is_modelled() {
    use crate::dynamics::measurement::{simulate_impact_test, ImpactTestParams};
    let prepared = PreparedModel::new(&model()).unwrap();
    let mut light = truth();
    light[4..].iter_mut().for_each(|c| *c /= 40.0);
    let sol = prepared
        .evaluate_modes(0, &light, ModeSelection::Below(800.0))
        .unwrap();
    let modal = prepared.modal_model(&sol).unwrap();
    let sensors: Vec<_> = prepared.sensors.iter().map(|s| s.1).collect();
    let params = ImpactTestParams {
        band_hz: Some((10.0, 400.0)),
        response_noise: 0.002,
        force_noise: 0.01,
        ..ImpactTestParams::default()
    };
    let set =
        simulate_impact_test(&modal, prepared.excitations[0].1, &sensors, &params, 3).unwrap();
    let fit = |truncated: bool| {
        let noise = FrfNoise {
            averages: Some(params.averages),
            truncation: truncated.then_some(params.hit_centre_s()),
            ..FrfNoise::default()
        };
        let r = one_set(&prepared, &set, noise);
        (r.fit(&prepared, &light).unwrap(), r.noise_model())
    };
    let ((cut, said), (plain, _)) = (fit(true), fit(false));
    assert!(cut.rms < 1.2, "{cut:?}");
    assert!(plain.rms > 5.0 * cut.rms, "{plain:?} vs {cut:?}");
    assert!(said.contains("record of 4 s"), "{said}");
}

/// Truncation needs the record length, which only a DFT's evenly spaced
/// lines give.
#[test]
fn truncation_refuses_unevenly_spaced_lines() {
    let prepared = PreparedModel::new(&model()).unwrap();
    let mut set = measured(&prepared, &truth(), 0.01, 1);
    set.frequencies_hz[5] += 0.1;
    let noise = FrfNoise {
        truncation: Some(0.0),
        ..FrfNoise::default()
    };
    let e = FrfReference::new(&prepared, &[set], None, (10.0, 400.0), noise)
        .err()
        .expect("refused");
    assert!(e.to_string().contains("frf_truncated"), "{e}");
    // A hit after the record's end (0.5 Hz lines: T = 2 s) is refused too.
    let late = FrfNoise {
        truncation: Some(2.0),
        ..FrfNoise::default()
    };
    let set = measured(&prepared, &truth(), 0.01, 1);
    let e = FrfReference::new(&prepared, &[set], None, (10.0, 400.0), late)
        .err()
        .expect("refused");
    assert!(e.to_string().contains("record of 2 s"), "{e}");
}

/// The window of a [`LocalMisfit`]: four lines either side of its centre
/// line, cut at the band's edges; no window at a position without FRFs.
#[test]
fn the_local_window_spans_its_nine_lines() {
    let (prepared, _, set) = light_chain(1.0, 1);
    let r = one_set(&prepared, &set, FrfNoise::default());
    let lines: Vec<f64> = set
        .frequencies_hz
        .iter()
        .copied()
        .filter(|f| (10.0..=400.0).contains(f))
        .collect();
    let p = set.position.index;
    assert_eq!(r.window_hz(p, lines[20]), Some((lines[16], lines[24])));
    assert_eq!(r.window_hz(p, lines[1]), Some((lines[0], lines[5])));
    let last = lines.len() - 1;
    assert_eq!(
        r.window_hz(p, lines[last]),
        Some((lines[last - 4], lines[last]))
    );
    assert_eq!(r.window_hz(p + 1, lines[20]), None);
}
