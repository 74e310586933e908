//! The import's coherence policies on universal files (issue 31): where
//! the reader refuses a coherence γ² and what it accepts for clamping
//! ([`CoherencePolicy`](crate::io::CoherencePolicy)), in ASCII 58 and 58b.

use super::ds58::{ByteOrder, NumberText, Storage, Uff58Format};
use crate::frf::{Dof, FrfChannel, FrfSet};
use crate::io::uff::{artifact::uff58_from_frf_sets, read_uff_with, write_uff58};
use crate::io::{clamp_coherence, frf_sets_from_uff, CoherencePolicy as Policy, IoError, Place};
use num_complex::Complex64;

/// One FRF (5 lines, 0–4 Hz) with coherence `gamma`, as a universal file.
fn file(gamma: [f64; 5], storage: Storage) -> Vec<u8> {
    let set = FrfSet {
        frequencies_hz: (0..5).map(f64::from).collect(),
        channels: vec![FrfChannel {
            response: Dof::new(2, 3),
            reference: Dof::new(1, 3),
            values: vec![Complex64::new(1.0, -1.0); 5],
            coherence: Some(gamma.to_vec()),
        }],
        ..FrfSet::default()
    };
    written(set, storage)
}

/// `set` as a universal file.
fn written(set: FrfSet, storage: Storage) -> Vec<u8> {
    let format = Uff58Format {
        storage,
        digits: NumberText::RoundTrip,
    };
    write_uff58(&uff58_from_frf_sets(&[set]), &format)
}

fn read(bytes: &[u8], policy: Policy) -> Result<Vec<FrfSet>, IoError> {
    let f = read_uff_with(bytes, "c.uff", policy)?;
    Ok(frf_sets_from_uff(&f, "c.uff", &Default::default())?.sets)
}

/// The 1-based line of the coherence dataset's record 12 that holds `text`.
fn line_of(bytes: &[u8], text: &str) -> usize {
    let s = String::from_utf8_lossy(bytes);
    let start = s.find("Coherence ").expect("a coherence dataset");
    let at = start + s[start..].find(text).expect("the value");
    s[..at].lines().count()
}

fn place(e: &IoError) -> Place {
    e.location().expect("a located error").place
}

#[test]
fn check_refuses_coherence_above_one_at_its_line_with_the_fix() {
    let bytes = file([0.5, 1.246, 0.9, 0.8, 0.7], Storage::Ascii);
    let e = read(&bytes, Policy::Check).unwrap_err();
    assert_eq!(place(&e), Place::Line(line_of(&bytes, "1.246")), "{e}");
    let m = e.to_string();
    assert!(m.contains("c.uff, line") && m.contains("point 2"), "{m}");
    assert!(
        m.contains("`coherence: clamp`") && m.contains("`coherence: ignore`"),
        "{m}"
    );
}

#[test]
fn clamp_accepts_a_margin_in_ascii_and_58b_and_clamps_to_zero_one() {
    for storage in [Storage::Ascii, Storage::Binary(ByteOrder::Big)] {
        let bytes = file([1.246, 0.5, -0.004, 2.0, 1.0], storage);
        assert!(read(&bytes, Policy::Check).is_err());
        let mut sets = read(&bytes, Policy::Clamp).unwrap();
        let c = clamp_coherence(&mut sets).unwrap();
        assert_eq!(
            (c.lines, c.frfs, c.largest, c.smallest),
            (3, 1, 2.0, -0.004)
        );
        assert_eq!(c.band_hz, [0.0, 3.0]);
        let gamma = sets[0].channels[0].coherence.as_deref().unwrap();
        assert_eq!(gamma, &[1.0, 0.5, 0.0, 1.0, 1.0][..]);
    }
}

#[test]
fn clamp_still_refuses_values_beyond_the_limit_and_nan() {
    let bytes = file([0.5, 0.6, 2.5, 0.8, 0.7], Storage::Ascii);
    let e = read(&bytes, Policy::Clamp).unwrap_err();
    assert_eq!(place(&e), Place::Line(line_of(&bytes, "2.5")), "{e}");
    assert!(e.to_string().contains("too far from [0, 1]"), "{e}");
    let bytes = file(
        [0.5, 0.6, -0.5, 0.8, 0.7],
        Storage::Binary(ByteOrder::Little),
    );
    let e = read(&bytes, Policy::Clamp).unwrap_err();
    assert!(matches!(place(&e), Place::Byte(_)), "{e}");
    // NaN: refused as any non-finite value, at its byte in 58b.
    let bytes = file(
        [0.5, f64::NAN, 0.9, 0.8, 0.7],
        Storage::Binary(ByteOrder::Little),
    );
    let e = read(&bytes, Policy::Clamp).unwrap_err();
    assert!(matches!(e, IoError::NonFinite { .. }), "{e}");
    assert!(matches!(place(&e), Place::Byte(_)), "{e}");
}

#[test]
fn ignore_does_not_check_coherence_values() {
    let bytes = file([7.0, -3.0, 0.9, 100.0, 0.7], Storage::Ascii);
    assert!(read(&bytes, Policy::Check).is_err());
    assert!(read(&bytes, Policy::Clamp).is_err());
    let sets = read(&bytes, Policy::Ignore).unwrap();
    assert_eq!(sets[0].channels.len(), 1);
}

#[test]
fn ignore_reads_past_a_non_finite_coherence_but_not_a_non_finite_frf() {
    for storage in [Storage::Ascii, Storage::Binary(ByteOrder::Little)] {
        let bytes = file([0.5, f64::NAN, 0.9, f64::INFINITY, 0.7], storage);
        assert!(matches!(
            read(&bytes, Policy::Check).unwrap_err(),
            IoError::NonFinite { .. }
        ));
        let sets = read(&bytes, Policy::Ignore).unwrap();
        assert_eq!(sets[0].channels[0].values.len(), 5);
    }
    // An FRF value is never excused.
    let set = FrfSet {
        frequencies_hz: (0..3).map(f64::from).collect(),
        channels: vec![FrfChannel {
            response: Dof::new(2, 3),
            reference: Dof::new(1, 3),
            values: vec![Complex64::new(1.0, f64::NAN); 3],
            coherence: Some(vec![0.9; 3]),
        }],
        ..FrfSet::default()
    };
    for storage in [Storage::Ascii, Storage::Binary(ByteOrder::Little)] {
        let e = read(&written(set.clone(), storage), Policy::Ignore).unwrap_err();
        assert!(matches!(e, IoError::NonFinite { .. }), "{e}");
    }
}
