//! Robustness of the readers against damaged input: every prefix of small
//! valid files (UFF ASCII, 58b, 55, mixed, CSV), and property tests that flip,
//! insert and delete bytes or feed random bytes. Each case must return
//! without panicking, and every error must carry a location (source name and
//! line/byte where it has one). Kept small so it runs in well under a second
//! in release builds.

use modalflow::frf::{Dof, FrfChannel, FrfQuantity, FrfSet, Position};
use modalflow::io::{
    frf_sets_from_uff, modal_models_from_uff, read_frf_csv, read_modal_csv, read_uff,
    write_frf_artifact, write_frf_csv, write_uff58, FrfImportOptions, IoError, NumberText, Storage,
    Uff58Format,
};
use num_complex::Complex64;
use proptest::prelude::*;
use std::path::Path;
use std::sync::atomic::{AtomicUsize, Ordering};

static EXECUTIONS: AtomicUsize = AtomicUsize::new(0);

fn fixture(name: &str) -> Vec<u8> {
    std::fs::read(
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("tests/fixtures/uff")
            .join(name),
    )
    .unwrap()
}

fn small_set() -> FrfSet {
    let f: Vec<f64> = (0..6).map(|i| 5.0 + i as f64 / 3.0).collect();
    FrfSet {
        position: Position {
            index: 1,
            label: "p".into(),
        },
        quantity: FrfQuantity::Receptance,
        channels: vec![FrfChannel {
            response: Dof::new(3, 2),
            reference: Dof::new(1, -1),
            values: f.iter().map(|x| Complex64::new(1.0 / x, -x)).collect(),
            coherence: Some(vec![0.9; 6]),
        }],
        frequencies_hz: f,
    }
}

/// Valid inputs: fixtures plus freshly written ASCII and binary artifacts.
fn corpus() -> Vec<Vec<u8>> {
    let set = small_set();
    let ascii = Uff58Format {
        storage: Storage::Ascii,
        digits: NumberText::Standard,
    };
    let datasets = modalflow::io::uff58_from_frf_sets(std::slice::from_ref(&set));
    vec![
        fixture("frf_58b_le.uff"),
        fixture("mixed_15_58_164.uff"),
        fixture("modes_55.uff"),
        fixture("frf_crlf.uff"),
        fixture("nodes_2411.uff"),
        write_frf_artifact(std::slice::from_ref(&set)),
        write_uff58(&datasets, &ascii),
    ]
}

/// Runs every reader on `bytes`; errors must name a place.
fn exercise(bytes: &[u8]) {
    EXECUTIONS.fetch_add(1, Ordering::Relaxed);
    let check = |e: &IoError| {
        let at = e
            .location()
            .unwrap_or_else(|| panic!("error without location: {e}"));
        assert_eq!(at.source, "damaged.uff");
    };
    match read_uff(bytes, "damaged.uff") {
        Ok(file) => {
            if let Err(e) = frf_sets_from_uff(&file, "damaged.uff", &FrfImportOptions::default()) {
                check(&e);
            }
            if let Err(e) = modal_models_from_uff(&file, "damaged.uff") {
                check(&e);
            }
        }
        Err(e) => check(&e),
    }
    if let Err(e) = read_frf_csv(bytes, "damaged.uff") {
        check(&e);
    }
}

#[test]
fn every_prefix_of_small_files() {
    let csv = write_frf_csv(&[small_set()]).unwrap();
    let mut truncated_errors = 0;
    for file in corpus().iter().chain([&csv]) {
        for n in 0..file.len() {
            exercise(&file[..n]);
            if read_uff(&file[..n], "damaged.uff").is_err() {
                truncated_errors += 1;
            }
        }
        // The whole file is valid.
        if !file.starts_with(b"#") {
            read_uff(file, "ok.uff").unwrap_or_else(|e| panic!("{e}"));
        }
    }
    assert!(
        truncated_errors > 1000,
        "most prefixes are incomplete: {truncated_errors}"
    );
    eprintln!(
        "prefix executions so far: {}",
        EXECUTIONS.load(Ordering::Relaxed)
    );
}

#[test]
fn modal_csv_prefixes() {
    let modes = b"position,mode,frequency_hz,damping_ratio\n0,1,10.5,0.01\n0,2,20,0.02\n";
    let shapes = b"position,mode,node,direction,real,imag\n0,1,1,+X,0.5,0\n0,2,1,+X,-0.5,0.1\n";
    assert!(read_modal_csv(modes, "m.csv", shapes, "s.csv").is_ok());
    for n in 0..shapes.len() {
        EXECUTIONS.fetch_add(1, Ordering::Relaxed);
        if let Err(e) = read_modal_csv(modes, "m.csv", &shapes[..n], "s.csv") {
            assert!(e.location().is_some(), "{e}");
        }
    }
}

#[derive(Debug, Clone)]
enum Damage {
    Flip(usize, u8),
    Insert(usize, u8),
    Delete(usize),
}

fn damage() -> impl Strategy<Value = (usize, Vec<Damage>)> {
    let one = prop_oneof![
        (any::<usize>(), any::<u8>()).prop_map(|(i, b)| Damage::Flip(i, b)),
        (
            any::<usize>(),
            prop::sample::select(b"-1 \n\r0123456789.Eb+".to_vec())
        )
            .prop_map(|(i, b)| Damage::Insert(i, b)),
        any::<usize>().prop_map(Damage::Delete),
    ];
    (any::<usize>(), prop::collection::vec(one, 1..6))
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 1500, failure_persistence: None, ..ProptestConfig::default() })]

    #[test]
    fn damaged_files_never_panic((which, edits) in damage()) {
        let corpus = corpus();
        let mut bytes = corpus[which % corpus.len()].clone();
        for e in edits {
            match e {
                Damage::Flip(i, b) if !bytes.is_empty() => { let n = bytes.len(); bytes[i % n] ^= b | 1; }
                Damage::Insert(i, b) => { let n = bytes.len() + 1; bytes.insert(i % n, b); }
                Damage::Delete(i) if !bytes.is_empty() => { let n = bytes.len(); bytes.remove(i % n); }
                _ => {}
            }
        }
        exercise(&bytes);
    }

    #[test]
    fn random_bytes_never_panic(bytes in prop::collection::vec(any::<u8>(), 0..400)) {
        exercise(&bytes);
        let mut framed = b"    -1\n    58b     1     2          11".to_vec();
        framed.extend_from_slice(&bytes);
        exercise(&framed);
    }
}

#[test]
fn huge_counts_fail_fast_without_allocating() {
    let set = small_set();
    let ascii = Uff58Format {
        storage: Storage::Ascii,
        digits: NumberText::Standard,
    };
    for fmt in [Uff58Format::default(), ascii] {
        let text = write_uff58(
            &modalflow::io::uff58_from_frf_sets(std::slice::from_ref(&set)),
            &fmt,
        );
        let s = String::from_utf8_lossy(&text).replacen(
            "         6         6",
            "         6 999999999",
            1,
        );
        let e = read_uff(s.as_bytes(), "huge.uff").unwrap_err();
        assert!(
            matches!(e, IoError::Truncated { .. } | IoError::RecordLength { .. }),
            "{e}"
        );
    }
}

/// Binary 58b values are checked as read too: an uneven axis that goes
/// below 0 and a coherence above 1 are errors at the value's byte offset.
#[test]
fn implausible_binary_values_name_their_byte_offset() {
    let mut set = small_set();
    set.frequencies_hz = vec![0.0, 1.0, 2.5, -2.0, 4.0, 5.0];
    let e = read_uff(&write_frf_artifact(std::slice::from_ref(&set)), "neg.uff").unwrap_err();
    assert!(
        matches!(e, IoError::Implausible { .. })
            && e.to_string().starts_with("neg.uff, byte offset ")
            && e.to_string().contains("point 4: frequency -2 is negative"),
        "{e}"
    );
    let mut set = small_set();
    set.channels[0].coherence = Some(vec![0.9, 0.9, 0.9, 0.9, 1.5, 0.9]);
    let e = read_uff(&write_frf_artifact(std::slice::from_ref(&set)), "coh.uff").unwrap_err();
    assert!(
        e.to_string().starts_with("coh.uff, byte offset ")
            && e.to_string()
                .contains("point 5: coherence 1.5 is outside [0, 1]"),
        "{e}"
    );
}
