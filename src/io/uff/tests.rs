//! Unit tests of the UFF reader/writer: the write → read round trip over every
//! storage/precision/ordinate/abscissa combination (bitwise for doubles,
//! exact after `f32` rounding for single precision), dataset 55 round trips,
//! and the FRF set conversion rules.

use super::artifact::{read_frf_artifact, write_frf_artifact};
use super::ds58::*;
use super::*;
use crate::frf::{Dof, FrfChannel, FrfQuantity, FrfSet, Position};
use crate::modal::{ModalModel, Mode};
use num_complex::Complex64;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// A value spanning many decades, with sign, from the seeded stream.
fn wild(rng: &mut ChaCha8Rng, single: bool) -> f64 {
    let decades = if single { 30 } else { 250 };
    let m: f64 = rng.random_range(-1.0..1.0);
    let e = rng.random_range(-decades..decades);
    let v = m * 10f64.powi(e);
    if single {
        f64::from(v as f32)
    } else {
        v
    }
}

fn sample(
    rng: &mut ChaCha8Rng,
    precision: Precision,
    complex: bool,
    even: bool,
    n: usize,
) -> Uff58 {
    let single = precision == Precision::Single;
    let ordinate = if complex {
        Ordinate::Complex(
            (0..n)
                .map(|_| Complex64::new(wild(rng, single), wild(rng, single)))
                .collect(),
        )
    } else {
        Ordinate::Real((0..n).map(|_| wild(rng, single)).collect())
    };
    let abscissa = if even {
        Abscissa::Even {
            start: 1.0 / 3.0,
            step: std::f64::consts::PI / 7.0,
        }
    } else {
        let mut x = 0.0;
        Abscissa::Uneven(
            (0..n)
                .map(|_| {
                    x += rng.random_range(0.001..10.0);
                    if single {
                        f64::from(x as f32)
                    } else {
                        x
                    }
                })
                .collect(),
        )
    };
    Uff58 {
        id_lines: [
            "FRF 1+X/2-Z".into(),
            "id2 ümlaut".into(),
            String::new(),
            "x".into(),
            "NONE".into(),
        ],
        function: FunctionType::Frf,
        function_id: 3,
        version: 1,
        load_case: 7,
        response: Entity58 {
            entity: "RSP".into(),
            node: 101,
            direction: 1,
        },
        reference: Entity58 {
            entity: "NONE".into(),
            node: 2,
            direction: -3,
        },
        z_axis_value: 0.125,
        abscissa_axis: AxisInfo {
            data_type: 18,
            label: "Frequency".into(),
            units: "Hz".into(),
            ..Default::default()
        },
        ordinate_axis: AxisInfo {
            data_type: 12,
            length_exp: 1,
            label: "Acc".into(),
            units: "m/s²".into(),
            ..Default::default()
        },
        denominator_axis: AxisInfo {
            data_type: 13,
            force_exp: 1,
            label: "F".into(),
            units: "N".into(),
            ..Default::default()
        },
        z_axis: AxisInfo::default(),
        precision,
        abscissa,
        ordinate,
    }
}

fn bits(d: &Uff58) -> Vec<u64> {
    super::ds58::interleaved_values(d)
        .iter()
        .map(|v| v.to_bits())
        .collect()
}

fn only_function(bytes: &[u8]) -> Uff58 {
    let f = read_uff(bytes, "rt.uff").unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(f.blocks.len(), 1);
    let d = f.functions().next().cloned();
    d.expect("one dataset 58")
}

#[test]
fn round_trip_is_exact_for_every_combination() {
    let mut rng = ChaCha8Rng::seed_from_u64(58);
    let storages = [
        Storage::Ascii,
        Storage::Binary(ByteOrder::Little),
        Storage::Binary(ByteOrder::Big),
    ];
    let mut cases = 0;
    for storage in storages {
        for precision in [Precision::Single, Precision::Double] {
            for complex in [false, true] {
                for even in [false, true] {
                    for n in [0, 1, 7, 13] {
                        if even && n == 0 {
                            continue;
                        }
                        let d = sample(&mut rng, precision, complex, even, n);
                        let fmt = Uff58Format {
                            storage,
                            digits: NumberText::RoundTrip,
                        };
                        let back = only_function(&write_uff58(std::slice::from_ref(&d), &fmt));
                        let what = format!(
                            "{storage:?} {precision:?} complex={complex} even={even} n={n}"
                        );
                        assert_eq!(bits(&back), bits(&d), "{what}");
                        assert_eq!(back, d, "{what}");
                        if let (
                            Abscissa::Even { start, step },
                            Abscissa::Even {
                                start: s2,
                                step: t2,
                            },
                        ) = (&d.abscissa, &back.abscissa)
                        {
                            assert_eq!(
                                (start.to_bits(), step.to_bits()),
                                (s2.to_bits(), t2.to_bits())
                            );
                        }
                        cases += 1;
                    }
                }
            }
        }
    }
    assert_eq!(cases, 3 * 2 * 2 * (4 + 3));
}

#[test]
fn extreme_doubles_survive_ascii() {
    let mut d = sample(
        &mut ChaCha8Rng::seed_from_u64(1),
        Precision::Double,
        false,
        true,
        6,
    );
    d.ordinate = Ordinate::Real(vec![
        f64::MAX,
        f64::MIN_POSITIVE,
        5e-324,
        -0.0,
        -1e-300,
        1.0 / 3.0,
    ]);
    let fmt = Uff58Format {
        storage: Storage::Ascii,
        digits: NumberText::RoundTrip,
    };
    assert_eq!(
        bits(&only_function(&write_uff58(std::slice::from_ref(&d), &fmt))),
        bits(&d)
    );
}

#[test]
fn standard_layout_keeps_thirteen_or_six_digits() {
    let mut rng = ChaCha8Rng::seed_from_u64(2);
    for (precision, rel) in [(Precision::Double, 5e-13), (Precision::Single, 5e-6)] {
        for (complex, even) in [(false, false), (true, false), (false, true), (true, true)] {
            let d = sample(&mut rng, precision, complex, even, 9);
            let fmt = Uff58Format {
                storage: Storage::Ascii,
                digits: NumberText::Standard,
            };
            let text = write_uff58(std::slice::from_ref(&d), &fmt);
            let widest = String::from_utf8_lossy(&text)
                .lines()
                .map(|l| l.chars().count())
                .max()
                .unwrap_or(0);
            assert!(widest <= 80, "line of {widest} characters");
            let back = only_function(&text);
            let (a, b) = (interleaved_values(&d), interleaved_values(&back));
            for (x, y) in a.iter().zip(&b) {
                // Uneven abscissae are E13.5 (6 digits) in every standard layout.
                assert!(
                    (x - y).abs() <= 5e-6 * x.abs().max(rel),
                    "{x} vs {y} ({precision:?})"
                );
            }
        }
    }
}

#[test]
fn binary_header_counts_the_data_bytes() {
    let d = sample(
        &mut ChaCha8Rng::seed_from_u64(3),
        Precision::Single,
        true,
        false,
        10,
    );
    let out = write_uff58(&[d], &Uff58Format::default());
    let head = String::from_utf8_lossy(&out[..100]);
    assert!(
        head.contains("    58b     1     2          11         120     0"),
        "{head}"
    );
}

#[test]
fn wrong_binary_length_is_reported_with_offset() {
    let d = sample(
        &mut ChaCha8Rng::seed_from_u64(4),
        Precision::Double,
        false,
        true,
        10,
    );
    let out = write_uff58(&[d], &Uff58Format::default());
    let e = read_uff(&out[..out.len() - 20], "cut.uff").unwrap_err();
    assert!(matches!(e, crate::io::IoError::Truncated { .. }), "{e}");
    assert!(e.to_string().contains("cut.uff, byte offset"), "{e}");
    let fixed = String::from_utf8_lossy(&out).replace("          80     0", "          72     0");
    let e = read_uff(fixed.as_bytes(), "short.uff").unwrap_err();
    assert!(matches!(e, crate::io::IoError::RecordLength { .. }), "{e}");
}

#[test]
fn unknown_datasets_warn_once_per_number() {
    let text =
        "    -1\n  1858\nunits\n    -1\n    -1\n  2412\n 1\n    -1\n    -1\n  1858\nmore\n    -1\n";
    let f = read_uff(text.as_bytes(), "mixed.uff").unwrap();
    assert!(f.blocks.is_empty());
    assert_eq!(
        f.warnings,
        vec![
            UffWarning::SkippedDatasets {
                dataset: 1858,
                count: 2,
                first: crate::io::Place::Line(1)
            },
            UffWarning::SkippedDatasets {
                dataset: 2412,
                count: 1,
                first: crate::io::Place::Line(5)
            },
        ]
    );
}

fn frf_set(index: u32, label: &str, freqs: Vec<f64>, with_coherence: bool) -> FrfSet {
    let n = freqs.len();
    let ch = |r: Dof, f: Dof, k: f64| FrfChannel {
        response: r,
        reference: f,
        values: (0..n)
            .map(|i| Complex64::new(k / (1.0 + i as f64), -k * i as f64 / 7.0))
            .collect(),
        coherence: with_coherence.then(|| (0..n).map(|i| 1.0 - i as f64 / 1e3).collect()),
    };
    FrfSet {
        position: Position {
            index,
            label: label.into(),
        },
        quantity: FrfQuantity::Accelerance,
        frequencies_hz: freqs,
        channels: vec![
            ch(Dof::new(101, 1), Dof::new(1, -3), 1e-3),
            ch(Dof::new(102, -6), Dof::new(1, -3), 2.5),
        ],
    }
}

#[test]
fn frf_artifact_round_trips_positions_bitwise() {
    let even: Vec<f64> = (0..50).map(|i| 10.0 + i as f64 * 0.25).collect();
    let uneven: Vec<f64> = (0..50)
        .map(|i| (1.0 + i as f64).ln() * 100.0 / 3.0 + 0.1)
        .collect();
    let sets = vec![
        frf_set(0, "wpt=0.250", even.clone(), true),
        frf_set(3, "100% load ", uneven, false),
        frf_set(1, "", even, true),
    ];
    let bytes = write_frf_artifact(&sets);
    let back = read_frf_artifact(&bytes, "frf.uff").unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(back, sets);
    let flat = |s: &[FrfSet]| -> Vec<u64> {
        s.iter()
            .flat_map(|s| {
                let f = s.frequencies_hz.iter().map(|v| v.to_bits());
                let v = s.channels.iter().flat_map(|c| {
                    c.values
                        .iter()
                        .flat_map(|z| [z.re.to_bits(), z.im.to_bits()])
                });
                f.chain(v).collect::<Vec<_>>()
            })
            .collect()
    };
    assert_eq!(flat(&back), flat(&sets));
    // The uniform grid is written even, the logarithmic one uneven.
    let file = read_uff(&bytes, "frf.uff").unwrap();
    let spacing: Vec<bool> = file
        .functions()
        .map(|d| matches!(d.abscissa, Abscissa::Even { .. }))
        .collect();
    assert_eq!(
        spacing,
        vec![true, true, true, true, false, false, true, true, true, true]
    );
    assert_eq!(write_frf_artifact(&back), bytes, "writing is deterministic");
}

#[test]
fn frf_conversion_rejects_mixed_axes_and_duplicates() {
    let mut a = frf_set(0, "", (0..10).map(f64::from).collect(), false);
    let b = frf_set(0, "", (0..10).map(|i| f64::from(i) * 1.5).collect(), false);
    let mut datasets = artifact::uff58_from_frf_sets(&[a.clone()]);
    datasets.extend(artifact::uff58_from_frf_sets(&[b]).into_iter().skip(1));
    let bytes = write_uff58(&datasets, &Uff58Format::default());
    let e = read_frf_artifact(&bytes, "axes.uff").unwrap_err();
    assert!(matches!(e, crate::io::IoError::AxisMismatch { .. }), "{e}");
    assert!(e.to_string().contains("axes.uff, line"), "{e}");
    a.channels.push(a.channels[0].clone());
    let bytes = write_frf_artifact(&[a]);
    let e = read_frf_artifact(&bytes, "dup.uff").unwrap_err();
    assert!(
        matches!(e, crate::io::IoError::DuplicateChannel { .. }),
        "{e}"
    );
}

#[test]
fn no_frf_names_what_was_found() {
    let mut d = sample(
        &mut ChaCha8Rng::seed_from_u64(5),
        Precision::Double,
        false,
        true,
        4,
    );
    d.function = FunctionType::TimeResponse;
    let bytes = write_uff58(&[d], &Uff58Format::default());
    let e = read_frf_artifact(&bytes, "time.uff").unwrap_err();
    assert!(e.to_string().contains("1 of type 1"), "{e}");
}

fn modal(complex: bool) -> ModalModel {
    let dofs = vec![
        Dof::new(1, 1),
        Dof::new(1, 3),
        Dof::new(2, -2),
        Dof::new(7, 5),
    ];
    let modes = (0..3)
        .map(|k| Mode {
            frequency_hz: 12.5 * (k + 1) as f64 + 1.0 / 3.0,
            damping_ratio: 0.01 + 0.003 * k as f64,
            shape: dofs
                .iter()
                .enumerate()
                .map(|(i, _)| {
                    Complex64::new(
                        0.1 * (i + 1) as f64 - 0.25,
                        if complex { 0.02 * i as f64 } else { 0.0 },
                    )
                })
                .collect(),
        })
        .collect();
    ModalModel {
        position: Position {
            index: 2,
            label: "x=0.5".into(),
        },
        dofs,
        modes,
    }
}

#[test]
fn dataset55_round_trips_modal_models() {
    for complex in [false, true] {
        let m = modal(complex);
        let datasets = modal_models::uff55_from_modal_models(
            std::slice::from_ref(&m),
            crate::modal::ShapeScaling::Arbitrary,
        )
        .unwrap();
        let bytes = write_uff55(&datasets, NumberText::RoundTrip);
        let text = String::from_utf8_lossy(&bytes);
        // Record 6 field 5 is 2 (real) or 5 (complex), as dataset 55 defines.
        let r6 = text.lines().nth(7).unwrap();
        let data_type: i64 = r6[40..50].trim().parse().unwrap();
        assert_eq!(data_type, if complex { 5 } else { 2 }, "{r6}");
        let file = read_uff(&bytes, "m.uff").unwrap_or_else(|e| panic!("{e}"));
        for (read, written) in file.data_at_nodes().zip(&datasets) {
            // Records 8 and 10 keep the 7 digits of E13.6.
            assert_eq!(read.nodes, written.nodes);
            let flat = |o: &Ordinate| -> Vec<f64> {
                match o {
                    Ordinate::Real(v) => v.clone(),
                    Ordinate::Complex(v) => v.iter().flat_map(|c| [c.re, c.im]).collect(),
                }
            };
            let pairs = flat(&read.values).into_iter().zip(flat(&written.values));
            for (a, b) in pairs.chain(read.reals.iter().copied().zip(written.reals.clone())) {
                assert!((a - b).abs() <= 5e-7 * b.abs(), "{a} vs {b}");
            }
        }
        let back = modal_models::modal_models_from_uff(&file, "m.uff")
            .unwrap()
            .models;
        assert_eq!(back.len(), 1);
        let b = &back[0];
        assert_eq!(b.position, m.position);
        // Every node gets 6 components (a rotation is present).
        assert_eq!(b.dofs.len(), 3 * 6);
        for (mode, orig) in b.modes.iter().zip(&m.modes) {
            assert!((mode.frequency_hz - orig.frequency_hz).abs() <= 1e-13 * orig.frequency_hz);
            assert!((mode.damping_ratio - orig.damping_ratio).abs() <= 1e-13);
            for (dof, v) in m.dofs.iter().zip(&orig.shape) {
                let plus = Dof::new(dof.node, dof.direction.abs());
                let i = b.dofs.iter().position(|d| *d == plus).unwrap();
                let expect = if dof.direction < 0 { -v } else { *v };
                assert!(
                    (mode.shape[i] - expect).norm() <= 5e-7 * expect.norm(),
                    "{dof}"
                );
            }
        }
    }
}

#[test]
fn function_types_parse_by_name_and_code() {
    assert_eq!(FunctionType::parse("FRF"), Some(FunctionType::Frf));
    assert_eq!(
        FunctionType::parse("auto_spectrum"),
        Some(FunctionType::AutoSpectrum)
    );
    assert_eq!(FunctionType::parse("9"), Some(FunctionType::Psd));
    assert_eq!(FunctionType::parse("27"), Some(FunctionType::Other(27)));
    assert_eq!(FunctionType::parse("frequency"), None);
    for code in 0..28 {
        assert_eq!(FunctionType::from_code(code).code(), code);
    }
}

#[test]
fn dataset_cut_inside_its_header_is_truncated() {
    let e = read_uff(b"    -1\n    58\nID one\nID two\n    -1\n", "cut.uff").unwrap_err();
    assert!(matches!(e, crate::io::IoError::Truncated { .. }), "{e}");
    assert_eq!(
        e.location().map(|l| l.place),
        Some(crate::io::Place::Line(5))
    );
    let e = read_uff(b"    -1\n    58\n", "eof.uff").unwrap_err();
    assert!(
        e.to_string()
            .starts_with("eof.uff, line 3: file ends early"),
        "{e}"
    );
}

#[test]
fn unmatched_coherence_and_other_functions_are_reported() {
    let set = frf_set(0, "", (0..5).map(f64::from).collect(), true);
    let mut datasets = artifact::uff58_from_frf_sets(std::slice::from_ref(&set));
    // Coherence of channel 2 moved to another reference; a time signal added.
    datasets[3].reference.node = 99;
    let mut time = datasets[0].clone();
    time.function = FunctionType::TimeResponse;
    datasets.push(time);
    let file = read_uff(&write_uff58(&datasets, &Uff58Format::default()), "w.uff").unwrap();
    let import = frf_sets::frf_sets_from_uff(&file, "w.uff", &Default::default()).unwrap();
    assert!(import.sets[0].channels[1].coherence.is_none());
    assert_eq!(
        import.warnings,
        vec![
            UffWarning::UnmatchedCoherence {
                channel: "102-RZ/99-Z".into(),
                position: 0
            },
            UffWarning::UnusedFunctions {
                function_type: 1,
                count: 1
            },
        ]
    );
}

#[test]
fn dataset55_states_modal_mass_and_modal_a_of_mass_normalized_shapes() {
    use crate::modal::ShapeScaling;
    for complex in [false, true] {
        let m = modal(complex);
        let known = modal_models::uff55_from_modal_models(
            std::slice::from_ref(&m),
            ShapeScaling::MassNormalized,
        )
        .unwrap();
        let unknown = modal_models::uff55_from_modal_models(
            std::slice::from_ref(&m),
            ShapeScaling::Arbitrary,
        )
        .unwrap();
        for ((d, u), mode) in known.iter().zip(&unknown).zip(&m.modes) {
            match (d.mode().unwrap(), u.mode().unwrap()) {
                (
                    ds55::Uff55Mode::Normal { modal_mass, .. },
                    ds55::Uff55Mode::Normal { modal_mass: m0, .. },
                ) => {
                    assert!(!complex);
                    assert_eq!((modal_mass, m0), (1.0, 0.0));
                }
                (
                    ds55::Uff55Mode::Complex {
                        eigenvalue,
                        modal_a,
                        modal_b,
                    },
                    ds55::Uff55Mode::Complex { modal_a: a0, .. },
                ) => {
                    assert!(complex);
                    // Residue φφᵀ/(A(jω − λ)) + c.c. equals φφᵀ/(ω_r² − ω² + 2jζω_rω).
                    let w = 2.0 * std::f64::consts::PI * mode.frequency_hz;
                    let jw = Complex64::new(0.0, 0.7 * w);
                    let first = 1.0 / (modal_a * (jw - eigenvalue))
                        + 1.0 / (modal_a.conj() * (jw - eigenvalue.conj()));
                    let z = mode.damping_ratio;
                    let second = 1.0 / (w * w + jw * jw + 2.0 * z * w * jw);
                    assert!((first - second).norm() <= 1e-12 * second.norm());
                    assert!((modal_b + eigenvalue * modal_a).norm() <= 1e-9 * modal_b.norm());
                    assert_eq!(a0, Complex64::new(0.0, 0.0));
                }
                _ => panic!("mode kinds differ"),
            }
        }
    }
}
