//! Import of datasets 58 as [`FrfSet`]s.
//!
//! FRFs (function type 4) become [`FrfChannel`]s; coherences
//! (type 6) with the same response, reference and position attach as
//! [`FrfChannel::coherence`]. Positions come from the load case id (record 6
//! field 4) and, when ID line 4 reads `position=<label>`, the label. All FRFs
//! of one position must share one frequency axis (equal within 1e-9 of the
//! axis span). Units are converted to SI (Hz; m/N, m/s/N, m/s²/N) and the
//! quantity found from the axes' unit labels, dataset 164 and the
//! ordinate's specific data type (record 9: 8 displacement → receptance,
//! 11 velocity → mobility, 12 acceleration → accelerance), as
//! [`units`](super::units) describes; what was converted is listed in
//! [`FrfImport::notes`], and an unknown unit label is an error.
//! The reverse direction and the `frf` artifact are in
//! [`artifact`](super::artifact).

use super::artifact::{unescape_label, LABEL_KEY};
use super::ds58::{Entity58, FunctionType, Ordinate, Uff58};
use super::units::{abscissa_factor, ordinate_units, OrdinateUnits, Units164, UnitsOverride};
use super::{UffDataset, UffFile, UffWarning};
use crate::frf::{Dof, FrfChannel, FrfQuantity, FrfSet, Position};
use crate::io::error::{IoError, Location, Place};
use std::collections::HashMap;

/// How datasets 58 are grouped into positions and their units read.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct FrfImportOptions {
    /// One position per load case id (and label); `false` puts every FRF in
    /// position 0 (for tools that number load cases per measurement run).
    pub split_by_load_case: bool,
    /// Units from the file, given instead, or uncalibrated data.
    pub units: UnitsOverride,
}

impl Default for FrfImportOptions {
    fn default() -> Self {
        FrfImportOptions {
            split_by_load_case: true,
            units: UnitsOverride::FromFile,
        }
    }
}

/// FRF sets read from a file, with what was left out.
#[derive(Clone, Debug, PartialEq)]
pub struct FrfImport {
    pub sets: Vec<FrfSet>,
    pub warnings: Vec<UffWarning>,
    /// Unit conversions to SI and unit assumptions, one line per kind.
    pub notes: Vec<String>,
    /// `false` when the FRFs are uncalibrated (no physical scale): voltage
    /// data imported with [`UnitsOverride`], or modalflow's own mark.
    pub calibrated: bool,
    /// FRFs without any units label or dataset 164, read as SI.
    pub unlabelled: usize,
}

/// Builds FRF sets from the datasets 58 of `file` (`source` names it in errors).
pub fn frf_sets_from_uff(
    file: &UffFile,
    source: &str,
    options: &FrfImportOptions,
) -> Result<FrfImport, IoError> {
    let mut b = Builder {
        units: file.units().cloned(),
        ..Builder::default()
    };
    let mut warnings = Vec::new();
    let mut unused: Vec<(i32, usize)> = Vec::new();
    let mut coherences = Vec::new();
    for block in &file.blocks {
        let UffDataset::Function(d) = &block.dataset else {
            continue;
        };
        let at = Location::new(source, block.at);
        let head = Location::new(source, block.record1);
        match d.function {
            FunctionType::Frf => b.add_frf(d, at, &head, options)?,
            FunctionType::Coherence => coherences.push((d.as_ref(), at, head)),
            other => match unused.iter_mut().find(|(t, _)| *t == other.code()) {
                Some((_, n)) => *n += 1,
                None => unused.push((other.code(), 1)),
            },
        }
    }
    if b.sets.is_empty() {
        let mut found: Vec<String> = unused
            .iter()
            .map(|(t, n)| format!("{n} of type {t}"))
            .collect();
        if !coherences.is_empty() {
            found.push(format!("{} of type 6 (coherence)", coherences.len()));
        }
        return Err(IoError::NoFrf {
            at: Location::new(source, Place::File),
            detail: if found.is_empty() {
                "the file has no dataset 58 of function type 4".to_string()
            } else {
                format!(
                    "datasets 58 found: {}; FRFs have function type 4",
                    found.join(", ")
                )
            },
        });
    }
    for (d, at, head) in coherences {
        b.attach_coherence(d, at, &head, options, &mut warnings)?;
    }
    for (function_type, count) in unused {
        warnings.push(UffWarning::UnusedFunctions {
            function_type,
            count,
        });
    }
    let notes = b
        .notes
        .iter()
        .map(|(what, n)| format!("{n} FRF(s): {what}"))
        .collect();
    Ok(FrfImport {
        sets: b.sets.into_iter().map(|(s, _)| s).collect(),
        warnings,
        notes,
        calibrated: b.uncalibrated == 0,
        unlabelled: b.unlabelled,
    })
}

fn dof(e: &Entity58, what: &str, at: &Location) -> Result<Dof, IoError> {
    let bad = |field: &str, v: i64, exp: &str| IoError::InvalidField {
        at: at.clone(),
        field: format!("{what} {field} (record 6)"),
        value: v.to_string(),
        expected: exp.to_string(),
    };
    let node =
        u32::try_from(e.node).map_err(|_| bad("node", e.node, "a node number 0 to 4294967295"))?;
    let direction = i8::try_from(e.direction)
        .ok()
        .filter(|d| (-6..=6).contains(d))
        .ok_or_else(|| bad("direction", e.direction, "a direction code -6 to 6"))?;
    Ok(Dof::new(node, direction))
}

fn position_of(d: &Uff58, at: &Location, options: &FrfImportOptions) -> Result<Position, IoError> {
    if !options.split_by_load_case {
        return Ok(Position::default());
    }
    let index = u32::try_from(d.load_case).map_err(|_| IoError::InvalidField {
        at: at.clone(),
        field: "load case id (record 6 field 4)".into(),
        value: d.load_case.to_string(),
        expected: "0 to 4294967295 (it numbers the position); or import with \
                   split_by_load_case = false"
            .into(),
    })?;
    let label = d.id_lines[3]
        .strip_prefix(LABEL_KEY)
        .map(unescape_label)
        .unwrap_or_default();
    Ok(Position { index, label })
}

pub(crate) fn channel_name(r: Dof, f: Dof) -> String {
    format!("{r}/{f}")
}

/// Sets under construction, with an index (set, response, reference) →
/// channel so large files convert in linear time.
#[derive(Default)]
struct Builder {
    sets: Vec<(FrfSet, Place)>,
    /// (position index, label) → set.
    positions: HashMap<(u32, String), usize>,
    channels: HashMap<(usize, Dof, Dof), usize>,
    units: Option<Units164>,
    /// Conversion notes with their FRF counts, in first-seen order.
    notes: Vec<(String, usize)>,
    /// FRFs read as uncalibrated, and FRFs read as SI for want of labels.
    uncalibrated: usize,
    unlabelled: usize,
}

impl Builder {
    fn note(&mut self, what: String) {
        match self.notes.iter_mut().find(|(w, _)| *w == what) {
            Some((_, n)) => *n += 1,
            None => self.notes.push((what, 1)),
        }
    }
}

impl Builder {
    /// `at` is the dataset's opening line, `head` its record 1 (errors
    /// about one field name that field's record line).
    fn add_frf(
        &mut self,
        d: &Uff58,
        at: Location,
        head: &Location,
        options: &FrfImportOptions,
    ) -> Result<(), IoError> {
        let response = dof(&d.response, "response", &head.record(6))?;
        let reference = dof(&d.reference, "reference", &head.record(6))?;
        let position = position_of(d, &head.record(6), options)?;
        let units = ordinate_units(d, self.units.as_ref(), head, &options.units)?;
        let quantity = units.quantity;
        let values = match &d.ordinate {
            Ordinate::Complex(v) => v.iter().map(|x| x * units.factor).collect(),
            Ordinate::Real(v) => v.iter().map(|&x| (x * units.factor).into()).collect(),
        };
        let hz = abscissa_factor(d, head)?;
        let mut freqs = d.abscissa_values();
        if hz != 1.0 {
            freqs.iter_mut().for_each(|f| *f *= hz);
        }
        self.note_conversions(d, &units, hz);
        let name = channel_name(response, reference);
        let idx = self.set_of(&position, quantity, &freqs, &at, &name)?;
        let (set, first) = &mut self.sets[idx];
        same_axis(
            &set.frequencies_hz,
            &freqs,
            &at,
            &name,
            position.index,
            *first,
        )?;
        if quantity != set.quantity {
            return Err(IoError::InvalidField {
                at: head.record(9),
                field: format!("FRF {name} ordinate quantity (record 9)"),
                value: format!("{quantity:?}"),
                expected: format!(
                    "{:?} like the first FRF of position {}",
                    set.quantity, position.index
                ),
            });
        }
        if self.channels.contains_key(&(idx, response, reference)) {
            return Err(IoError::DuplicateChannel {
                at,
                channel: name,
                position: position.index,
            });
        }
        self.channels
            .insert((idx, response, reference), set.channels.len());
        set.channels.push(FrfChannel {
            response,
            reference,
            values,
            coherence: None,
        });
        Ok(())
    }

    /// Note the conversions of dataset `d`'s FRF: its frequency axis by
    /// `hz`, its ordinate to SI, uncalibrated data kept as measured, and
    /// data without units read as SI (counting the last two).
    fn note_conversions(&mut self, d: &Uff58, units: &OrdinateUnits, hz: f64) {
        let quantity = units.quantity;
        if hz != 1.0 {
            self.note(format!(
                "frequency axis in {} converted to Hz (× {hz:.6})",
                d.abscissa_axis.units.trim()
            ));
        }
        if let Some(from) = &units.from {
            self.note(format!(
                "{from} converted to SI {} (× {})",
                quantity.si_unit(),
                units.factor
            ));
        }
        if !units.calibrated {
            self.uncalibrated += 1;
            self.note(format!(
                "{}/{} kept as measured: uncalibrated, no physical scale",
                d.ordinate_axis.units.trim(),
                d.denominator_axis.units.trim()
            ));
        }
        if units.assumed_si {
            self.unlabelled += 1;
            self.note(format!(
                "no units label and no dataset 164: read as SI {}",
                quantity.si_unit()
            ));
        }
    }

    /// The index of `position`'s set; its first FRF (`freqs`, read at `at`,
    /// channel `name`) opens it after its axis is checked to increase.
    fn set_of(
        &mut self,
        position: &Position,
        quantity: FrfQuantity,
        freqs: &[f64],
        at: &Location,
        name: &str,
    ) -> Result<usize, IoError> {
        let key = (position.index, position.label.clone());
        Ok(match self.positions.get(&key) {
            Some(&i) => i,
            None => {
                check_increasing(freqs, at, name)?;
                self.sets.push((
                    FrfSet {
                        position: position.clone(),
                        quantity,
                        frequencies_hz: freqs.to_vec(),
                        channels: Vec::new(),
                    },
                    at.place,
                ));
                self.positions.insert(key, self.sets.len() - 1);
                self.sets.len() - 1
            }
        })
    }

    fn attach_coherence(
        &mut self,
        d: &Uff58,
        at: Location,
        head: &Location,
        options: &FrfImportOptions,
        warnings: &mut Vec<UffWarning>,
    ) -> Result<(), IoError> {
        let response = dof(&d.response, "response", &head.record(6))?;
        let reference = dof(&d.reference, "reference", &head.record(6))?;
        let position = position_of(d, &head.record(6), options)?;
        let name = channel_name(response, reference);
        let target = self
            .positions
            .get(&(position.index, position.label.clone()))
            .and_then(|&i| Some((i, *self.channels.get(&(i, response, reference))?)))
            .map(|(i, k)| {
                let (s, first) = &mut self.sets[i];
                (&mut s.channels[k], &s.frequencies_hz, *first)
            });
        let Some((channel, freqs, first)) = target else {
            warnings.push(UffWarning::UnmatchedCoherence {
                channel: name,
                position: position.index,
            });
            return Ok(());
        };
        let hz = abscissa_factor(d, head)?;
        let coherence_axis: Vec<f64> = d.abscissa_values().iter().map(|f| f * hz).collect();
        same_axis(
            freqs,
            &coherence_axis,
            &at,
            &format!("coherence {name}"),
            position.index,
            first,
        )?;
        let values = match &d.ordinate {
            Ordinate::Real(v) => v.clone(),
            Ordinate::Complex(v) if v.iter().all(|c| c.im == 0.0) => {
                v.iter().map(|c| c.re).collect()
            }
            Ordinate::Complex(_) => {
                return Err(IoError::InvalidField {
                    at,
                    field: format!("coherence {name} ordinate"),
                    value: "complex".into(),
                    expected: "real values (coherence is real, 0 to 1)".into(),
                })
            }
        };
        channel.coherence = Some(values);
        Ok(())
    }
}

/// The axis after conversion to Hz (record 12 was checked as read; this
/// catches lines that the conversion or the even-spacing expansion merged).
fn check_increasing(f: &[f64], at: &Location, name: &str) -> Result<(), IoError> {
    crate::io::validity::check_abscissa(f).map_err(|(i, m)| IoError::Implausible {
        at: at.clone(),
        what: format!("frequency axis of FRF {name}, line {}: {m}", i + 1),
    })
}

fn same_axis(
    axis: &[f64],
    other: &[f64],
    at: &Location,
    name: &str,
    position: u32,
    first: Place,
) -> Result<(), IoError> {
    let mismatch = |detail: String| IoError::AxisMismatch {
        at: at.clone(),
        channel: name.to_string(),
        position,
        detail: format!("{detail}; first FRF at {first}"),
    };
    if axis.len() != other.len() {
        return Err(mismatch(format!(
            "{} lines instead of {}",
            other.len(),
            axis.len()
        )));
    }
    let span = match (axis.first(), axis.last()) {
        (Some(a), Some(b)) => (b - a).abs().max(a.abs()).max(b.abs()),
        _ => 0.0,
    };
    let tol = 1e-9 * span;
    match axis
        .iter()
        .zip(other)
        .position(|(a, b)| (a - b).abs() > tol)
    {
        None => Ok(()),
        Some(i) => Err(mismatch(format!(
            "line {} is {} Hz instead of {} Hz",
            i + 1,
            other[i],
            axis[i]
        ))),
    }
}
