//! UFF dataset 58, "function at nodal DOF": the [`Uff58`] record as a file
//! holds it, and its text records 1–11 and ASCII data record 12.
//!
//! Layout (SDRC I-DEAS universal file format, dataset 58 description as
//! published by the Structural Dynamics Research Lab, University of
//! Cincinnati; cross-checked with pyuff's `pyuff/datasets/dataset_58.py` and
//! files written by Simcenter TestLab, HBM catman and others):
//!
//! | record | format | contents |
//! |---|---|---|
//! | 1–5 | 80A1 | ID lines (description, run, date, free text) |
//! | 6 | 2(I5,I10),2(1X,10A1,I10,I4) | function type, function id, version, load case; response entity, node, direction; reference entity, node, direction |
//! | 7 | 3I10,3E13.5 | ordinate data type (2 real single, 4 real double, 5 complex single, 6 complex double), number of points, abscissa spacing (1 even, 0 uneven), abscissa minimum, increment, z-axis value |
//! | 8–11 | I10,3I5,2(1X,20A1) | abscissa, ordinate numerator, ordinate denominator, z axis: specific data type, length/force/temperature unit exponents, axis label, units label |
//! | 12 | see below | data: even abscissa `y…` or `re im…`; uneven `x y…` or `x re im…` |
//!
//! Record 12 in the reader is free-format (any widths, `E` or `D` exponents,
//! a short last line). The writer offers the standard layouts
//! ([`NumberText::Standard`]: 6E13.5 for single precision; 4E20.12,
//! 2(E13.5,E20.12) or E13.5,2E20.12 for double) and a round-trip layout
//! ([`NumberText::RoundTrip`]: 9 significant digits in E16.8 for single, 17 in
//! E25.16 for double, so values read back bit for bit). Even abscissae are
//! rebuilt as `x_i = minimum + i · increment` in `f64`.

use super::ds58_binary::{self, BinaryHeader};
use super::ds58_records::{self, DataForm};
use super::text::{self, Cursor};
use crate::io::error::{IoError, Place};
use crate::io::limits::BYTES_PER_UFF_VALUE;
use crate::io::validity::{
    check_coherence_with, check_even_abscissa, check_frequency, CoherencePolicy,
};
use num_complex::Complex64;

/// Record 6 field 1: what kind of function the dataset holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum FunctionType {
    General,
    TimeResponse,
    AutoSpectrum,
    CrossSpectrum,
    Frf,
    Transmissibility,
    Coherence,
    AutoCorrelation,
    CrossCorrelation,
    Psd,
    Esd,
    Spectrum,
    /// Any other code of the UFF table (11, 13–27), kept for round trips.
    Other(i32),
}

impl FunctionType {
    pub fn from_code(code: i32) -> Self {
        use FunctionType::*;
        match code {
            0 => General,
            1 => TimeResponse,
            2 => AutoSpectrum,
            3 => CrossSpectrum,
            4 => Frf,
            5 => Transmissibility,
            6 => Coherence,
            7 => AutoCorrelation,
            8 => CrossCorrelation,
            9 => Psd,
            10 => Esd,
            12 => Spectrum,
            c => Other(c),
        }
    }

    /// Parses a name (`frf`, `time`, `auto_spectrum`, `cross_spectrum`,
    /// `coherence`, `psd`, …, case-insensitive) or a numeric code.
    pub fn parse(s: &str) -> Option<Self> {
        use FunctionType::*;
        let s = s.trim().to_ascii_lowercase();
        if let Ok(code) = s.parse::<i32>() {
            return Some(Self::from_code(code));
        }
        Some(match s.as_str() {
            "general" => General,
            "time" | "time_response" => TimeResponse,
            "auto_spectrum" => AutoSpectrum,
            "cross_spectrum" => CrossSpectrum,
            "frf" => Frf,
            "transmissibility" => Transmissibility,
            "coherence" => Coherence,
            "auto_correlation" => AutoCorrelation,
            "cross_correlation" => CrossCorrelation,
            "psd" => Psd,
            "esd" => Esd,
            "spectrum" => Spectrum,
            _ => return None,
        })
    }

    pub fn code(self) -> i32 {
        use FunctionType::*;
        match self {
            General => 0,
            TimeResponse => 1,
            AutoSpectrum => 2,
            CrossSpectrum => 3,
            Frf => 4,
            Transmissibility => 5,
            Coherence => 6,
            AutoCorrelation => 7,
            CrossCorrelation => 8,
            Psd => 9,
            Esd => 10,
            Spectrum => 12,
            Other(c) => c,
        }
    }
}

/// Floating-point precision of record 12 (record 7 ordinate data type).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub enum Precision {
    Single,
    #[default]
    Double,
}

/// Byte order of 58b binary data (binary header field 3: 1 little, 2 big).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub enum ByteOrder {
    #[default]
    Little,
    Big,
}

/// Records 8–11: data characteristics of one axis.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct AxisInfo {
    /// Specific data type (UFF table: 0 unknown, 8 displacement, 11 velocity,
    /// 12 acceleration, 13 excitation force, 17 time, 18 frequency, …).
    pub data_type: i32,
    pub length_exp: i32,
    pub force_exp: i32,
    pub temperature_exp: i32,
    /// Axis label, at most 20 characters in the file.
    pub label: String,
    /// Units label, at most 20 characters in the file.
    pub units: String,
}

/// Response or reference DOF of record 6.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct Entity58 {
    /// Entity name, at most 10 characters in the file.
    pub entity: String,
    pub node: i64,
    /// Direction code: 0 scalar, ±1 X … ±6 RZ.
    pub direction: i64,
}

/// The abscissa of record 12.
#[derive(Clone, Debug, PartialEq)]
pub enum Abscissa {
    /// Even spacing: `x_i = start + i · step` (record 7 fields 4 and 5).
    Even { start: f64, step: f64 },
    /// Uneven spacing: one abscissa value per point, stored in record 12.
    Uneven(Vec<f64>),
}

/// The ordinate values of record 12.
#[derive(Clone, Debug, PartialEq)]
pub enum Ordinate {
    Real(Vec<f64>),
    Complex(Vec<Complex64>),
}

impl Ordinate {
    pub fn len(&self) -> usize {
        match self {
            Ordinate::Real(v) => v.len(),
            Ordinate::Complex(v) => v.len(),
        }
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// One dataset 58 with every header field needed to write it back.
#[derive(Clone, Debug, PartialEq)]
pub struct Uff58 {
    /// Records 1–5.
    pub id_lines: [String; 5],
    pub function: FunctionType,
    pub function_id: i64,
    pub version: i64,
    pub load_case: i64,
    pub response: Entity58,
    pub reference: Entity58,
    pub z_axis_value: f64,
    pub abscissa_axis: AxisInfo,
    pub ordinate_axis: AxisInfo,
    pub denominator_axis: AxisInfo,
    pub z_axis: AxisInfo,
    pub precision: Precision,
    pub abscissa: Abscissa,
    pub ordinate: Ordinate,
}

impl Uff58 {
    /// Number of points (record 7 field 2).
    pub fn len(&self) -> usize {
        self.ordinate.len()
    }

    pub fn is_empty(&self) -> bool {
        self.ordinate.is_empty()
    }

    /// Record 7 field 1: 2, 4, 5 or 6.
    pub fn ordinate_data_type(&self) -> i32 {
        match (&self.ordinate, self.precision) {
            (Ordinate::Real(_), Precision::Single) => 2,
            (Ordinate::Real(_), Precision::Double) => 4,
            (Ordinate::Complex(_), Precision::Single) => 5,
            (Ordinate::Complex(_), Precision::Double) => 6,
        }
    }

    /// Abscissa value of every point (even spacing expanded).
    pub fn abscissa_values(&self) -> Vec<f64> {
        match &self.abscissa {
            Abscissa::Even { start, step } => {
                (0..self.len()).map(|i| start + i as f64 * step).collect()
            }
            Abscissa::Uneven(x) => x.clone(),
        }
    }
}

/// How record 12 numbers (and record 7's abscissa fields) are written.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum NumberText {
    /// The widths of the UFF description (6E13.5, 4E20.12, …), readable by
    /// fixed-column readers; double values keep 13 significant digits.
    Standard,
    /// Enough digits that every value reads back bit for bit; record 7 fields
    /// widen to E25.16 only where E13.5 would not be exact.
    #[default]
    RoundTrip,
}

/// ASCII dataset 58 or binary 58b.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Storage {
    Ascii,
    Binary(ByteOrder),
}

/// Output format for [`write_uff58`](super::write_uff58).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Uff58Format {
    pub storage: Storage,
    pub digits: NumberText,
}

impl Default for Uff58Format {
    /// The `frf` artifact format: 58b, little-endian, round-trip record 7.
    fn default() -> Self {
        Uff58Format {
            storage: Storage::Binary(ByteOrder::Little),
            digits: NumberText::RoundTrip,
        }
    }
}

/// Number of values per point in record 12.
pub(crate) fn values_per_point(complex: bool, even: bool) -> usize {
    match (complex, even) {
        (false, true) => 1,
        (false, false) | (true, true) => 2,
        (true, false) => 3,
    }
}

/// Parses records 1–12 and the closing `-1`, the cursor standing after the
/// dataset number line. FRFs and coherences (the functions the import
/// uses, whose abscissa is frequency) are checked as they are read: a
/// negative or non-increasing frequency line and, for coherences, a value
/// that `coherence` does not accept (outside [0, 1] by default) are errors
/// at the value's line (58b: byte offset).
pub(crate) fn parse(
    cur: &mut Cursor<'_>,
    binary: Option<BinaryHeader>,
    coherence: CoherencePolicy,
) -> Result<(Uff58, Option<ds58_binary::ByteCountMismatch>), IoError> {
    let src = cur.source;
    let (mut d, form, r7) = ds58_records::parse_header(cur)?;
    let n = form.points;
    let vpp = values_per_point(form.complex, form.even);
    let n_values = n.checked_mul(vpp).ok_or_else(|| too_many(src, r7, n))?;
    let mut check = PointCheck::new(d.function, &form, coherence, binary.is_some());
    if check.frequency && form.even {
        check_even_abscissa(form.start, form.step, n).map_err(|m| {
            IoError::implausible(
                src,
                r7,
                format!("dataset 58 record 7 ({}): {m}", check.kind),
            )
        })?;
    }
    let memory = |n_values: usize| {
        IoError::check_memory(
            src,
            r7,
            || format!("record 7's {n} points ({n_values} values)"),
            n_values as f64 * BYTES_PER_UFF_VALUE,
        )
    };
    let mut mismatch = None;
    let values = match binary {
        Some(h) => {
            let start = cur.offset();
            let (v, m) = ds58_binary::read_data(cur, &h, n_values, form.precision, &memory)?;
            mismatch = m;
            let size = match form.precision {
                Precision::Single => 4,
                Precision::Double => 8,
            };
            for (i, &x) in v.iter().enumerate() {
                check.value(src, i, x, Place::Byte(start + i * size))?;
            }
            v
        }
        None => {
            if n_values > cur.remaining() / 2 + 1 {
                return Err(IoError::truncated(
                    src,
                    r7,
                    format!(
                        "record 7 declares {n} points ({n_values} values) but only {} bytes follow",
                        cur.remaining()
                    ),
                ));
            }
            memory(n_values)?;
            let mut v = Vec::new();
            let single = form.precision == Precision::Single;
            text::read_numbers_checked(
                cur,
                n_values,
                single,
                "dataset 58 record 12 (data)",
                &mut v,
                &mut |i, x, place| check.value(src, i, x, place),
            )?;
            v
        }
    };
    cur.expect_delimiter("58")?;

    (d.abscissa, d.ordinate) = split_values(values, &form);
    Ok((d, mismatch))
}

/// The physical checks of record 12 values of an FRF or a coherence, by
/// their position in the record (uneven abscissae interleaved).
struct PointCheck {
    /// "FRF" or "coherence"; empty for functions that are not checked.
    kind: &'static str,
    /// The abscissa is frequency (FRF, coherence).
    frequency: bool,
    /// Uneven: every point carries its frequency as its first value.
    uneven: bool,
    /// How a coherence value is checked; `None` for other functions.
    coherence: Option<CoherencePolicy>,
    /// Values may be anything: a coherence the import drops (`ignore`).
    dropped: bool,
    /// 58b: a non-finite value is named by its index, not its line.
    binary: bool,
    per_point: usize,
    previous: Option<f64>,
}

impl PointCheck {
    fn new(function: FunctionType, form: &DataForm, policy: CoherencePolicy, binary: bool) -> Self {
        let (kind, frequency, coherence) = match function {
            FunctionType::Frf => ("FRF", true, None),
            FunctionType::Coherence => ("coherence", true, Some(policy)),
            _ => ("", false, None),
        };
        PointCheck {
            kind,
            frequency,
            uneven: !form.even,
            coherence,
            dropped: function == FunctionType::Coherence && policy == CoherencePolicy::Ignore,
            binary,
            per_point: values_per_point(form.complex, form.even),
            previous: None,
        }
    }

    /// Value `i` of record 12 (0-based), read at `place`: finite (unless
    /// the dataset is dropped), and for an FRF or coherence physical.
    fn value(&mut self, src: &str, i: usize, x: f64, place: Place) -> Result<(), IoError> {
        if !x.is_finite() && !self.dropped {
            let field = if self.binary {
                format!("dataset 58b record 12 value {}", i + 1)
            } else {
                "dataset 58 record 12 (data)".into()
            };
            return text::finite(src, place, &field, x);
        }
        if !self.frequency {
            return Ok(());
        }
        let (point, k) = (i / self.per_point + 1, i % self.per_point);
        let bad = |m: String| {
            IoError::implausible(
                src,
                place,
                format!("dataset 58 record 12 ({}), point {point}: {m}", self.kind),
            )
        };
        if self.uneven && k == 0 {
            check_frequency(x, self.previous).map_err(bad)?;
            self.previous = Some(x);
        }
        // The real part of the ordinate: right after an uneven abscissa.
        if let Some(policy) = self.coherence {
            if k == usize::from(self.uneven) {
                check_coherence_with(x, policy).map_err(bad)?;
            }
        }
        Ok(())
    }
}

fn too_many(src: &str, place: Place, n: usize) -> IoError {
    IoError::invalid(
        src,
        place,
        "number of points",
        n,
        "the count overflows memory sizes",
    )
}

fn split_values(values: Vec<f64>, form: &DataForm) -> (Abscissa, Ordinate) {
    let cplx = |re: f64, im: f64| Complex64::new(re, im);
    match (form.complex, form.even) {
        (false, true) => (
            Abscissa::Even {
                start: form.start,
                step: form.step,
            },
            Ordinate::Real(values),
        ),
        (true, true) => (
            Abscissa::Even {
                start: form.start,
                step: form.step,
            },
            Ordinate::Complex(values.chunks_exact(2).map(|c| cplx(c[0], c[1])).collect()),
        ),
        (false, false) => (
            Abscissa::Uneven(values.chunks_exact(2).map(|c| c[0]).collect()),
            Ordinate::Real(values.chunks_exact(2).map(|c| c[1]).collect()),
        ),
        (true, false) => (
            Abscissa::Uneven(values.chunks_exact(3).map(|c| c[0]).collect()),
            Ordinate::Complex(values.chunks_exact(3).map(|c| cplx(c[1], c[2])).collect()),
        ),
    }
}

/// Record 12 values in file order (abscissa interleaved when uneven).
pub(crate) fn interleaved_values(d: &Uff58) -> Vec<f64> {
    let n = d.len();
    let x = match &d.abscissa {
        Abscissa::Uneven(x) => Some(x),
        Abscissa::Even { .. } => None,
    };
    let mut out = Vec::with_capacity(n * 3);
    for i in 0..n {
        if let Some(x) = x {
            out.push(x.get(i).copied().unwrap_or(0.0));
        }
        match &d.ordinate {
            Ordinate::Real(v) => out.push(v[i]),
            Ordinate::Complex(v) => out.extend([v[i].re, v[i].im]),
        }
    }
    out
}

/// Appends one dataset 58 (delimiters included).
pub(crate) fn write(out: &mut Vec<u8>, d: &Uff58, format: &Uff58Format) {
    let values = interleaved_values(d);
    let single = d.precision == Precision::Single;
    out.extend_from_slice(b"    -1\n");
    match format.storage {
        Storage::Ascii => out.extend_from_slice(b"    58\n"),
        Storage::Binary(order) => {
            let n_bytes = values.len() * if single { 4 } else { 8 };
            ds58_binary::push_binary_header(out, order, n_bytes);
        }
    }
    ds58_records::write_header(out, d, format.digits);
    match format.storage {
        Storage::Binary(order) => ds58_binary::push_data(out, &values, order, d.precision),
        Storage::Ascii => ds58_records::push_ascii_data(out, &values, d, format.digits),
    }
    out.extend_from_slice(b"    -1\n");
}
