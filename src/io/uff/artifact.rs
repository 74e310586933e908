//! The `frf` artifact and UFF export of FRF sets: [`FrfSet`]s → datasets 58
//! and back.
//!
//! The artifact is UFF 58b, little-endian IEEE double, complex ordinates,
//! one dataset per FRF followed by its coherence (type 6, real) if any. Per
//! dataset: record 6 load case = `Position.index`; ID line 1 =
//! `FRF <response>/<reference>` (or `Coherence …`); ID line 2 = `modalflow`;
//! ID line 4 = `position=<label>` with `%`, control characters and a trailing
//! space percent-escaped (`%25`, `%0A`, `%20`); records 8–10 = frequency in Hz,
//! the response quantity (8 displacement in m, 11 velocity in m/s,
//! 12 acceleration in m/s²) and force in N. The abscissa is even when
//! `f_i = f_0 + i·Δf` reproduces every line bit for bit and `f_0`, `Δf` are
//! exact in E13.5, else uneven (doubles in the data block), so a write →
//! read round trip is bitwise exact. Sets without channels are not written.
//! No dates or host names are written: equal sets give equal bytes.

use super::ds58::{
    Abscissa, AxisInfo, Entity58, FunctionType, NumberText, Ordinate, Precision, Uff58, Uff58Format,
};
use super::frf_sets::{channel_name, frf_sets_from_uff, FrfImportOptions};
use super::units::UNCALIBRATED_LABEL;
use super::{read_uff, text};
use crate::frf::{Dof, FrfQuantity, FrfSet};
use crate::io::error::IoError;

/// Prefix of ID line 4 that carries a position label.
pub(crate) const LABEL_KEY: &str = "position=";

/// Escapes a position label for ID line 4 (see module docs).
pub(crate) fn escape_label(label: &str) -> String {
    let n = label.chars().count();
    let mut out = String::new();
    for (i, c) in label.chars().enumerate() {
        if c == '%' || c.is_control() || (c == ' ' && i + 1 == n) {
            let mut buf = [0u8; 4];
            for b in c.encode_utf8(&mut buf).bytes() {
                out.push_str(&format!("%{b:02X}"));
            }
        } else {
            out.push(c);
        }
    }
    out
}

pub(crate) fn unescape_label(s: &str) -> String {
    let b = s.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        let hex = b
            .get(i + 1..i + 3)
            .and_then(|h| std::str::from_utf8(h).ok());
        match (b[i], hex.and_then(|h| u8::from_str_radix(h, 16).ok())) {
            (b'%', Some(v)) => {
                out.push(v);
                i += 3;
            }
            (c, _) => {
                out.push(c);
                i += 1;
            }
        }
    }
    String::from_utf8_lossy(&out).into_owned()
}

/// `(f_0, Δf)` when the grid is exactly `f_0 + i·Δf` with both exact in E13.5.
fn even_grid(f: &[f64]) -> Option<(f64, f64)> {
    let start = *f.first()?;
    let step = if f.len() > 1 { f[1] - f[0] } else { 0.0 };
    let e13_exact = |v: f64| {
        let mut s = Vec::new();
        text::push_e(&mut s, v, 13, 5, false);
        text::parse_f64(s.trim_ascii()).map(f64::to_bits) == Some(v.to_bits())
    };
    let on_grid = f
        .iter()
        .enumerate()
        .all(|(i, &x)| (start + i as f64 * step).to_bits() == x.to_bits());
    (e13_exact(start) && e13_exact(step) && on_grid).then_some((start, step))
}

fn axis(data_type: i32, length_exp: i32, force_exp: i32, label: &str, units: &str) -> AxisInfo {
    AxisInfo {
        data_type,
        length_exp,
        force_exp,
        temperature_exp: 0,
        label: label.into(),
        units: units.into(),
    }
}

/// Datasets 58 for FRF sets in the artifact layout (module docs).
pub fn uff58_from_frf_sets(sets: &[FrfSet]) -> Vec<Uff58> {
    let mut out = Vec::new();
    for set in sets {
        let abscissa = match even_grid(&set.frequencies_hz) {
            Some((start, step)) => Abscissa::Even { start, step },
            None => Abscissa::Uneven(set.frequencies_hz.clone()),
        };
        let (spec, label, units) = match set.quantity {
            FrfQuantity::Receptance => (8, "Displacement", "m"),
            FrfQuantity::Mobility => (11, "Velocity", "m/s"),
            FrfQuantity::Accelerance => (12, "Acceleration", "m/s^2"),
        };
        let pos_line = format!("{LABEL_KEY}{}", escape_label(&set.position.label));
        for ch in &set.channels {
            let entity = |d: Dof| Entity58 {
                entity: "NONE".into(),
                node: i64::from(d.node),
                direction: i64::from(d.direction),
            };
            let name = channel_name(ch.response, ch.reference);
            let base = Uff58 {
                id_lines: [
                    format!("FRF {name}"),
                    "modalflow".into(),
                    "NONE".into(),
                    pos_line.clone(),
                    "NONE".into(),
                ],
                function: FunctionType::Frf,
                function_id: 0,
                version: 0,
                load_case: i64::from(set.position.index),
                response: entity(ch.response),
                reference: entity(ch.reference),
                z_axis_value: 0.0,
                abscissa_axis: axis(18, 0, 0, "Frequency", "Hz"),
                ordinate_axis: axis(spec, 1, 0, label, units),
                denominator_axis: axis(13, 0, 1, "Force", "N"),
                z_axis: axis(0, 0, 0, "NONE", "NONE"),
                precision: Precision::Double,
                abscissa: abscissa.clone(),
                ordinate: Ordinate::Complex(ch.values.clone()),
            };
            if let Some(coh) = &ch.coherence {
                let mut c = base.clone();
                c.id_lines[0] = format!("Coherence {name}");
                c.function = FunctionType::Coherence;
                c.ordinate_axis = axis(0, 0, 0, "Coherence", "NONE");
                c.denominator_axis = axis(0, 0, 0, "NONE", "NONE");
                c.ordinate = Ordinate::Real(coh.clone());
                out.push(base);
                out.push(c);
            } else {
                out.push(base);
            }
        }
    }
    out
}

/// Serializes FRF sets as the `frf` artifact (UFF 58b, see module docs).
pub fn write_frf_artifact(sets: &[FrfSet]) -> Vec<u8> {
    write_frf_artifact_scaled(sets, true)
}

/// Like [`write_frf_artifact`]; uncalibrated FRFs (`calibrated == false`)
/// carry [`UNCALIBRATED_LABEL`] as their numerator units label (and `NONE`
/// below), so every reader of the artifact knows they have no physical scale.
pub fn write_frf_artifact_scaled(sets: &[FrfSet], calibrated: bool) -> Vec<u8> {
    let format = Uff58Format {
        digits: NumberText::RoundTrip,
        ..Uff58Format::default()
    };
    let mut datasets = uff58_from_frf_sets(sets);
    if !calibrated {
        for d in datasets
            .iter_mut()
            .filter(|d| d.function == FunctionType::Frf)
        {
            d.ordinate_axis.units = UNCALIBRATED_LABEL.into();
            d.denominator_axis.units = "NONE".into();
        }
    }
    super::write_uff58(&datasets, &format)
}

/// Reads an `frf` artifact (or any UFF 58 file holding FRFs); `name` is used
/// in errors.
pub fn read_frf_artifact(bytes: &[u8], name: &str) -> Result<Vec<FrfSet>, IoError> {
    Ok(read_frf_artifact_scaled(bytes, name)?.0)
}

/// Reads an `frf` artifact and whether its FRFs are calibrated (`false`
/// for the mark [`write_frf_artifact_scaled`] writes).
pub fn read_frf_artifact_scaled(bytes: &[u8], name: &str) -> Result<(Vec<FrfSet>, bool), IoError> {
    let file = read_uff(bytes, name)?;
    let import = frf_sets_from_uff(&file, name, &FrfImportOptions::default())?;
    Ok((import.sets, import.calibrated))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn labels_escape_and_unescape() {
        for l in ["", "wpt=0.250", "100% load ", "a\nb", "x=é "] {
            let e = escape_label(l);
            assert!(!e.ends_with(' ') && !e.contains('\n'));
            assert_eq!(unescape_label(&e), l);
        }
    }

    #[test]
    fn uncalibrated_mark_round_trips() {
        let set = FrfSet {
            channels: vec![crate::frf::FrfChannel {
                response: Dof::new(1, 3),
                reference: Dof::new(2, -3),
                values: vec![num_complex::Complex64::new(0.5, -2.0); 3],
                coherence: Some(vec![0.9; 3]),
            }],
            frequencies_hz: vec![1.0, 2.0, 3.0],
            ..Default::default()
        };
        for calibrated in [true, false] {
            let bytes = write_frf_artifact_scaled(std::slice::from_ref(&set), calibrated);
            let (back, c) = read_frf_artifact_scaled(&bytes, "frf.uff").unwrap();
            assert_eq!(c, calibrated);
            assert_eq!(back, vec![set.clone()], "values kept bit for bit");
        }
    }

    #[test]
    fn even_grid_needs_exact_reconstruction() {
        let f: Vec<f64> = (0..100).map(|i| i as f64 * 0.25).collect();
        assert_eq!(even_grid(&f), Some((0.0, 0.25)));
        let f: Vec<f64> = (0..100).map(|i| i as f64 / 3.0).collect();
        assert_eq!(even_grid(&f), None);
        assert_eq!(even_grid(&[]), None);
    }
}
