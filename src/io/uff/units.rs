//! Units of universal files: dataset 164 (the file's unit system) and the
//! units of a dataset 58's axes (records 8–10: unit exponents and labels),
//! turned into the factor that brings an FRF to SI and the quantity it is.
//!
//! Dataset 164 (I-DEAS "units"): record 1 `I10,20A1,I10` units code,
//! description, temperature mode; record 2 `3D25.17` length, force and
//! temperature factors; record 3 `D25.17` temperature offset. "To convert
//! from universal file units to SI divide by the factor": a value with
//! length exponent l and force exponent f (records 8–11 fields 2–3) is
//! `value / (L^l · F^f)` in SI.
//!
//! An FRF's ordinate is `numerator / denominator` (records 9 and 10). Its
//! factor to SI is found, in this order, from
//! 1. the units labels, when they name units this module knows: a response
//!    in m, mm, µm, in, ft (displacement), m/s, mm/s, in/s (velocity), m/s²,
//!    mm/s², in/s², g = 9.80665 m/s² (acceleration), over N, kN, lbf, kgf;
//!    the numerator label may hold the whole ratio (`g/N`, `(m/s^2)/N`);
//! 2. else dataset 164 with the exponents of records 9 and 10;
//! 3. else SI is assumed, and said so.
//!
//! A label that names no known unit is an error naming the file, the dataset
//! and the record: reading it as SI would be silently wrong.
//!
//! **Uncalibrated data** (`V/V`, a label naming no physical unit) import only
//! when the caller says so ([`UnitsOverride`]): the values are kept as
//! measured and the FRF is marked uncalibrated. modalflow's own `frf`
//! artifact marks such FRFs with the numerator units label
//! [`UNCALIBRATED_LABEL`], so the mark travels with the data.

use super::ds58::{AxisInfo, Uff58};
use super::text::{self, Cursor};
use crate::frf::FrfQuantity;
use crate::io::error::{IoError, Location};

/// Standard gravity, m/s² (ISO 80000-3).
pub const STANDARD_GRAVITY: f64 = 9.80665;
/// One pound-force in newtons (avoirdupois pound × standard gravity).
const POUND_FORCE: f64 = 4.448_221_615_260_5;
const INCH: f64 = 0.0254;

/// Dataset 164: the file's unit system.
#[derive(Clone, Debug, PartialEq)]
pub struct Units164 {
    pub code: i64,
    pub description: String,
    /// Factors to divide by for SI: length, force, temperature.
    pub length: f64,
    pub force: f64,
    pub temperature: f64,
    pub temperature_offset: f64,
}

/// Parses records 1–3 of dataset 164 and the closing `-1`.
pub(crate) fn parse164(cur: &mut Cursor<'_>) -> Result<Units164, IoError> {
    let r1 = cur.expect_record("dataset 164 record 1 (units code, description)")?;
    let t = String::from_utf8_lossy(r1.text).into_owned();
    let code = t.get(..10).unwrap_or(&t).trim().parse().unwrap_or(0);
    let description = t.get(10..30).unwrap_or("").trim().to_string();
    let mut v = Vec::new();
    text::read_numbers(
        cur,
        4,
        false,
        "dataset 164 records 2–3 (unit factors)",
        &mut v,
    )?;
    let at = cur.next_place();
    if v[..3].iter().any(|f| *f <= 0.0) {
        return Err(IoError::invalid(
            cur.source,
            at,
            "dataset 164 unit factors (record 2)",
            format!("{} {} {}", v[0], v[1], v[2]),
            "positive factors (1 for SI)",
        ));
    }
    cur.expect_delimiter("164")?;
    Ok(Units164 {
        code,
        description,
        length: v[0],
        force: v[1],
        temperature: v[2],
        temperature_offset: v[3],
    })
}

/// The numerator units label that marks an uncalibrated FRF (no physical
/// scale) in modalflow's `frf` artifact.
pub const UNCALIBRATED_LABEL: &str = "uncalibrated";

/// How the FRFs' scale is read: from the file (default), from unit labels
/// given instead of the file's, or as uncalibrated data kept as measured.
#[derive(Clone, Debug, PartialEq, Eq, Default)]
pub enum UnitsOverride {
    #[default]
    FromFile,
    /// The response (numerator) and reference (denominator) units of every
    /// FRF, replacing the file's labels and dataset 164. A voltage unit
    /// (`V`, `mV`) on either side makes the data uncalibrated.
    Labels { response: String, reference: String },
    /// Keep the values as measured whatever the labels say; uncalibrated.
    Uncalibrated,
}

/// A voltage unit: a transducer's output before calibration.
fn voltage_unit(s: &str) -> bool {
    matches!(
        s.trim().to_ascii_lowercase().as_str(),
        "v" | "mv" | "volt" | "volts"
    )
}

/// Checks override labels as a pipeline gives them: `Ok(true)` when they
/// are physical units (calibrated), `Ok(false)` when either is a voltage,
/// else the problem in words.
pub fn check_override_labels(response: &str, reference: &str) -> Result<bool, String> {
    let r_volt = voltage_unit(response);
    let f_volt = voltage_unit(reference);
    if !r_volt && response_unit(response).is_none() {
        return Err(format!(
            "response unit {response:?} is not known: use m, mm, µm, in, m/s, mm/s, in/s,              m/s^2, mm/s^2, in/s^2, g, or V / mV for uncalibrated data"
        ));
    }
    if !f_volt && force_unit(reference).is_none() {
        return Err(format!(
            "reference unit {reference:?} is not known: use N, kN, lbf, kgf, or V / mV for              uncalibrated data"
        ));
    }
    Ok(!(r_volt || f_volt))
}

/// What a response unit measures and its factor to SI.
fn response_unit(s: &str) -> Option<(FrfQuantity, f64)> {
    use FrfQuantity::*;
    let s = s.replace(['(', ')', ' '], "");
    let s = s
        .replace("**", "^")
        .replace('²', "^2")
        .replace("s2", "s^2")
        .replace("sec", "s");
    Some(match s.to_ascii_lowercase().as_str() {
        "m" => (Receptance, 1.0),
        "mm" => (Receptance, 1e-3),
        "cm" => (Receptance, 1e-2),
        "um" | "µm" | "micron" => (Receptance, 1e-6),
        "in" | "inch" => (Receptance, INCH),
        "ft" => (Receptance, 0.3048),
        "m/s" => (Mobility, 1.0),
        "mm/s" => (Mobility, 1e-3),
        "in/s" | "ips" => (Mobility, INCH),
        "m/s^2" => (Accelerance, 1.0),
        "mm/s^2" => (Accelerance, 1e-3),
        "in/s^2" => (Accelerance, INCH),
        "ft/s^2" => (Accelerance, 0.3048),
        "g" | "gn" => (Accelerance, STANDARD_GRAVITY),
        _ => return None,
    })
}

/// Factor of a force unit to N.
fn force_unit(s: &str) -> Option<f64> {
    Some(match s.trim().to_ascii_lowercase().as_str() {
        "n" => 1.0,
        "kn" => 1e3,
        "mn" => 1e-3,
        "lbf" | "lb" => POUND_FORCE,
        "kgf" => STANDARD_GRAVITY,
        _ => return None,
    })
}

/// A label that states nothing.
fn blank(label: &str) -> bool {
    let l = label.trim();
    l.is_empty() || l.eq_ignore_ascii_case("none") || l == "-"
}

/// An FRF's ordinate in SI: multiply the values by `factor`.
#[derive(Clone, Debug, PartialEq)]
pub struct OrdinateUnits {
    pub quantity: FrfQuantity,
    pub factor: f64,
    /// How the factor was found, for the import summary: the file's units
    /// (`g/N`) or `None` when the file states SI or nothing.
    pub from: Option<String>,
    /// The file states no units at all (read as SI).
    pub assumed_si: bool,
    /// `false` for uncalibrated data: the values have no physical scale.
    pub calibrated: bool,
}

fn uncalibrated(by_type: Option<FrfQuantity>) -> OrdinateUnits {
    OrdinateUnits {
        quantity: by_type.unwrap_or_default(),
        factor: 1.0,
        from: None,
        assumed_si: false,
        calibrated: false,
    }
}

/// The SI factor and quantity of a dataset 58 FRF (module docs). `at` is
/// the dataset's record 1; errors name the line of the record at fault.
pub fn ordinate_units(
    d: &Uff58,
    units: Option<&Units164>,
    at: &Location,
    given: &UnitsOverride,
) -> Result<OrdinateUnits, IoError> {
    let by_type = match d.ordinate_axis.data_type {
        8 => Some(FrfQuantity::Receptance),
        11 => Some(FrfQuantity::Mobility),
        12 => Some(FrfQuantity::Accelerance),
        _ => None,
    };
    let (num, den) = match given {
        UnitsOverride::Uncalibrated => return Ok(uncalibrated(by_type)),
        UnitsOverride::Labels {
            response,
            reference,
        } => {
            if voltage_unit(response) || voltage_unit(reference) {
                return Ok(uncalibrated(by_type));
            }
            return labelled(response, reference, at);
        }
        UnitsOverride::FromFile => (
            d.ordinate_axis.units.trim(),
            d.denominator_axis.units.trim(),
        ),
    };
    if num.eq_ignore_ascii_case(UNCALIBRATED_LABEL) {
        return Ok(uncalibrated(by_type));
    }
    let unknown = |record: u8, label: &str, what: &str| IoError::InvalidField {
        at: at.record(usize::from(record)),
        field: format!("units label of the {what} (dataset 58 record {record})"),
        value: format!("{label:?}"),
        expected: "a known unit: m, mm, µm, in (displacement), m/s, mm/s, in/s (velocity), \
                   m/s^2, mm/s^2, in/s^2, g (acceleration), over N, kN, lbf, kgf; \
                   or NONE with a dataset 164 unit system; for voltage or uncalibrated \
                   data import with `calibrated: false` (or give the sensors' units, \
                   `units: {response: g, reference: N}`)"
            .into(),
    };
    // The numerator label may hold the whole ratio (`g/N`).
    let (num, den) = match num.rsplit_once('/') {
        Some((a, b)) if force_unit(b).is_some() => (a.trim(), b.trim()),
        _ => (num, den),
    };
    let response = if blank(num) {
        None
    } else {
        Some(response_unit(num).ok_or_else(|| unknown(9, num, "ordinate numerator"))?)
    };
    let force = if blank(den) {
        None
    } else {
        Some(force_unit(den).ok_or_else(|| unknown(10, den, "ordinate denominator"))?)
    };
    if let (Some((q, _)), Some(t)) = (response, by_type) {
        if q != t {
            return Err(IoError::InvalidField {
                at: at.record(9),
                field: "ordinate specific data type (record 9 field 1)".into(),
                value: format!("{} ({t:?})", d.ordinate_axis.data_type),
                expected: format!("a type matching the units label {num:?} ({q:?})"),
            });
        }
    }
    let quantity = response.map(|r| r.0).or(by_type).unwrap_or_default();
    let by_164 = |axis: &AxisInfo, u: &Units164| {
        u.length.powi(axis.length_exp) * u.force.powi(axis.force_exp)
    };
    let stated = response.is_some() || force.is_some();
    let factor = match (response, force, units) {
        (None, None, Some(u)) => by_164(&d.denominator_axis, u) / by_164(&d.ordinate_axis, u),
        _ => response.map_or(1.0, |r| r.1) / force.unwrap_or(1.0),
    };
    let from = if stated && factor != 1.0 {
        Some(format!(
            "{}/{}",
            if blank(num) { "m" } else { num },
            if blank(den) { "N" } else { den }
        ))
    } else if !stated && factor != 1.0 {
        units.map(|u| format!("dataset 164 `{}`", u.description))
    } else {
        None
    };
    Ok(OrdinateUnits {
        quantity,
        factor,
        from,
        assumed_si: !stated && units.is_none(),
        calibrated: true,
    })
}

/// The factor of physical units given in the pipeline (checked by
/// [`check_override_labels`]; an unknown one is still an error here).
fn labelled(response: &str, reference: &str, at: &Location) -> Result<OrdinateUnits, IoError> {
    let bad = |label: &str| IoError::InvalidField {
        at: at.clone(),
        field: "`units` param of the import".into(),
        value: format!("{label:?}"),
        expected: "a known unit (see `modalflow kinds import`)".into(),
    };
    let (quantity, r) = response_unit(response).ok_or_else(|| bad(response))?;
    let f = force_unit(reference).ok_or_else(|| bad(reference))?;
    let factor = r / f;
    Ok(OrdinateUnits {
        quantity,
        factor,
        from: Some(format!("{response}/{reference} (the `units` param)")),
        assumed_si: false,
        calibrated: true,
    })
}

/// The SI factor of a dataset 58's abscissa: Hz (or no label) 1, kHz 1000,
/// rad/s 1/2π; anything else is an error naming record 8's line (`at` is
/// the dataset's record 1).
pub fn abscissa_factor(d: &Uff58, at: &Location) -> Result<f64, IoError> {
    let label = d.abscissa_axis.units.trim();
    if blank(label) {
        return Ok(1.0);
    }
    match label.to_ascii_lowercase().as_str() {
        "hz" | "1/s" | "cps" => Ok(1.0),
        "khz" => Ok(1e3),
        "rad/s" => Ok(1.0 / (2.0 * std::f64::consts::PI)),
        _ => Err(IoError::InvalidField {
            at: at.record(8),
            field: "units label of the abscissa (dataset 58 record 8)".into(),
            value: format!("{label:?}"),
            expected: "a frequency: Hz, kHz or rad/s".into(),
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::error::Place;

    fn frf(num: &str, den: &str, ty: i32) -> Uff58 {
        let mut d = crate::io::uff::artifact::uff58_from_frf_sets(&[crate::frf::FrfSet {
            channels: vec![crate::frf::FrfChannel {
                response: crate::frf::Dof::new(1, 3),
                reference: crate::frf::Dof::new(1, 3),
                values: vec![1.0.into()],
                coherence: None,
            }],
            frequencies_hz: vec![1.0],
            ..Default::default()
        }])
        .remove(0);
        d.ordinate_axis.units = num.into();
        d.ordinate_axis.data_type = ty;
        d.denominator_axis.units = den.into();
        d
    }

    fn at() -> Location {
        Location::new("test.uff", Place::Line(3))
    }

    #[test]
    fn labels_give_quantity_and_factor() {
        let cases = [
            ("m", "N", 8, FrfQuantity::Receptance, 1.0),
            ("g", "N", 12, FrfQuantity::Accelerance, STANDARD_GRAVITY),
            ("g/N", "NONE", 0, FrfQuantity::Accelerance, STANDARD_GRAVITY),
            ("(m/s^2)/N", "", 12, FrfQuantity::Accelerance, 1.0),
            (
                "m/s**2",
                "lbf",
                12,
                FrfQuantity::Accelerance,
                1.0 / POUND_FORCE,
            ),
            ("mm/s", "N", 0, FrfQuantity::Mobility, 1e-3),
            ("in", "lbf", 8, FrfQuantity::Receptance, INCH / POUND_FORCE),
        ];
        for (num, den, ty, q, f) in cases {
            let u =
                ordinate_units(&frf(num, den, ty), None, &at(), &UnitsOverride::FromFile).unwrap();
            assert_eq!(u.quantity, q, "{num}/{den}");
            assert!(
                (u.factor - f).abs() <= 1e-15 * f,
                "{num}/{den}: {}",
                u.factor
            );
            assert!(!u.assumed_si);
        }
    }

    #[test]
    fn dataset_164_scales_unlabelled_axes_and_silence_is_si() {
        let u164 = Units164 {
            code: 5,
            description: "mm (milli newton)".into(),
            length: 1000.0,
            force: 1000.0,
            temperature: 1.0,
            temperature_offset: 273.15,
        };
        // Receptance in mm/mN: length exponent 1 over force exponent 1 → 1.
        let mut d = frf("NONE", "NONE", 8);
        d.ordinate_axis.length_exp = 1;
        d.denominator_axis.force_exp = 1;
        let u = ordinate_units(&d, Some(&u164), &at(), &UnitsOverride::FromFile).unwrap();
        assert_eq!(u.factor, 1.0);
        d.denominator_axis.force_exp = 0;
        let u = ordinate_units(&d, Some(&u164), &at(), &UnitsOverride::FromFile).unwrap();
        assert_eq!(u.factor, 1e-3);
        assert!(u.from.unwrap().contains("164"));
        let u = ordinate_units(&d, None, &at(), &UnitsOverride::FromFile).unwrap();
        assert!(u.assumed_si && u.factor == 1.0);
    }

    #[test]
    fn voltage_data_import_only_when_told_and_are_marked_uncalibrated() {
        let d = frf("V", "V", 0);
        let e = ordinate_units(&d, None, &at(), &UnitsOverride::FromFile).unwrap_err();
        assert!(e.to_string().contains("calibrated: false"), "{e}");
        // Record 9 of a dataset whose record 1 is line 3 is line 11.
        assert!(e.to_string().contains("line 11"), "{e}");
        for given in [
            UnitsOverride::Uncalibrated,
            UnitsOverride::Labels {
                response: "V".into(),
                reference: "V".into(),
            },
        ] {
            let u = ordinate_units(&d, None, &at(), &given).unwrap();
            assert!(
                !u.calibrated && u.factor == 1.0 && !u.assumed_si,
                "{given:?}"
            );
        }
        let marked = frf(UNCALIBRATED_LABEL, "NONE", 12);
        let u = ordinate_units(&marked, None, &at(), &UnitsOverride::FromFile).unwrap();
        assert!(!u.calibrated && u.quantity == FrfQuantity::Accelerance);
        // Physical units given in the pipeline replace the file's labels.
        let given = UnitsOverride::Labels {
            response: "g".into(),
            reference: "N".into(),
        };
        let u = ordinate_units(&frf("NONE", "NONE", 0), None, &at(), &given).unwrap();
        assert!(u.calibrated && u.factor == STANDARD_GRAVITY);
        assert_eq!(u.quantity, FrfQuantity::Accelerance);
        assert_eq!(check_override_labels("mV", "N"), Ok(false));
        assert_eq!(check_override_labels("mm/s", "lbf"), Ok(true));
        assert!(check_override_labels("furlong", "N").is_err());
        assert!(check_override_labels("g", "stone").is_err());
    }

    #[test]
    fn unknown_or_contradicting_units_are_errors_naming_the_record() {
        let e = ordinate_units(
            &frf("furlong", "N", 8),
            None,
            &at(),
            &UnitsOverride::FromFile,
        )
        .unwrap_err();
        let text = e.to_string();
        assert!(
            text.contains("test.uff") && text.contains("record 9"),
            "{text}"
        );
        assert!(text.contains("furlong"), "{text}");
        let e = ordinate_units(
            &frf("g", "stone", 12),
            None,
            &at(),
            &UnitsOverride::FromFile,
        )
        .unwrap_err();
        assert!(e.to_string().contains("record 10"), "{e}");
        let e =
            ordinate_units(&frf("g", "N", 8), None, &at(), &UnitsOverride::FromFile).unwrap_err();
        assert!(e.to_string().contains("record 9 field 1"), "{e}");
        let mut d = frf("m", "N", 8);
        d.abscissa_axis.units = "RPM".into();
        assert!(abscissa_factor(&d, &at())
            .unwrap_err()
            .to_string()
            .contains("record 8"));
        d.abscissa_axis.units = "rad/s".into();
        let f = abscissa_factor(&d, &at()).unwrap();
        assert!((f * 2.0 * std::f64::consts::PI - 1.0).abs() < 1e-15);
    }
}
