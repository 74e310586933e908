//! UFF dataset 55, "data at nodes": one mode (or one response step) with a
//! value block per node — the [`Uff55`] record as the file holds it.
//!
//! | record | format | contents |
//! |---|---|---|
//! | 1–5 | 80A1 | ID lines |
//! | 6 | 6I10 | model type, analysis type (2 normal mode, 3 complex eigenvalue 1st order, 5 frequency response, 7 complex eigenvalue 2nd order, …), data characteristic (1 scalar, 2 3-DOF translation, 3 6-DOF translation + rotation, …), specific data type (8 displacement, …), data type (2 real, 5 complex; 4/6 are accepted on reading, as older modalflow versions wrote them), values per node |
//! | 7 | 8I10 | number of integers `ni`, number of reals `nr`, then `ni` type-specific integers (load case, mode number, …) |
//! | 8 | 6E13.5 | `nr` type-specific reals: normal mode `f in Hz, modal mass, viscous damping ratio, hysteretic damping ratio`; complex mode `Re λ, Im λ in rad/s, Re A, Im A, Re B, Im B` |
//! | 9 | I10 | node number |
//! | 10 | 6E13.5 | the node's values (complex: `re im` pairs) |
//!
//! Records 9–10 repeat per node until the closing `-1`. Number records are
//! read free-format and may wrap over lines, always as `f64`.
//!
//! The writer follows the dataset definition, which pyuff and other
//! fixed-column readers hold it to: record 6 field 5 is 2 or 5, record 7 is
//! `2 4|6 load_case mode`, and records 8 and 10 are 13-column fields, at
//! most 6 to a line, each node's values on one line (pyuff cuts record 10
//! lines into 13-character fields and expects node and value lines to
//! alternate). Dataset 55 has no wider double-precision layout, so
//! [`NumberText::Standard`] writes E13.5 (6 digits) and
//! [`NumberText::RoundTrip`] E13.6 — the 7 significant digits 13 columns
//! hold (a negative value then fills its field; this reader splits touching
//! fields at the sign). Exact values travel in the CSV export. ID line 5
//! carries the exact frequency and damping ratio as `modalflow f=… zeta=…`,
//! which this reader prefers when it agrees with record 8 to its digits (see
//! [`Uff55::exact_mode`]); other tools read it as free text.

use super::ds58::{NumberText, Ordinate, Precision};
use super::text::{self, Cursor};
use crate::io::error::{IoError, Place};
use num_complex::Complex64;

/// One dataset 55 with every field needed to write it back.
#[derive(Clone, Debug, PartialEq)]
pub struct Uff55 {
    pub id_lines: [String; 5],
    pub model_type: i64,
    /// Record 6 field 2 (2 normal mode, 3/7 complex mode, 5 frequency response).
    pub analysis_type: i64,
    /// Record 6 field 3 (1 scalar, 2 translations, 3 translations + rotations).
    pub data_characteristic: i64,
    pub specific_data_type: i64,
    pub precision: Precision,
    /// Values per node (record 6 field 6).
    pub values_per_node: usize,
    /// Record 7 type-specific integers (for modes: load case, mode number).
    pub integers: Vec<i64>,
    /// Record 8 type-specific reals.
    pub reals: Vec<f64>,
    pub nodes: Vec<i64>,
    /// `values_per_node` values per node, node after node.
    pub values: Ordinate,
}

/// The modal parameters of a mode dataset (analysis types 2, 3 and 7).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Uff55Mode {
    Normal {
        frequency_hz: f64,
        modal_mass: f64,
        viscous_damping_ratio: f64,
        hysteretic_damping_ratio: f64,
    },
    Complex {
        /// Pole λ = −ζω + jω√(1−ζ²) in rad/s.
        eigenvalue: Complex64,
        modal_a: Complex64,
        modal_b: Complex64,
    },
}

impl Uff55 {
    pub fn load_case(&self) -> i64 {
        self.integers.first().copied().unwrap_or(0)
    }

    /// Mode number (record 7, second integer) for mode datasets.
    pub fn mode_number(&self) -> i64 {
        self.integers.get(1).copied().unwrap_or(0)
    }

    /// Modal parameters, if this is a mode dataset.
    pub fn mode(&self) -> Option<Uff55Mode> {
        let r = |i: usize| self.reals.get(i).copied().unwrap_or(0.0);
        match self.analysis_type {
            2 => Some(Uff55Mode::Normal {
                frequency_hz: r(0),
                modal_mass: r(1),
                viscous_damping_ratio: r(2),
                hysteretic_damping_ratio: r(3),
            }),
            3 | 7 => Some(Uff55Mode::Complex {
                eigenvalue: Complex64::new(r(0), r(1)),
                modal_a: Complex64::new(r(2), r(3)),
                modal_b: Complex64::new(r(4), r(5)),
            }),
            _ => None,
        }
    }
}

/// Prefix of ID line 5 with the exact frequency and damping ratio.
pub(crate) const EXACT_KEY: &str = "modalflow f=";

/// ID line 5 for a mode of frequency `f` Hz and damping ratio `zeta`.
pub(crate) fn exact_line(f: f64, zeta: f64) -> String {
    format!("{EXACT_KEY}{f:e} zeta={zeta:e}")
}

impl Uff55 {
    /// Frequency in Hz and damping ratio from the exact ID line 5 that
    /// modalflow writes, when it is present and agrees with record 8 to the
    /// 6 significant digits E13.5 keeps (so a tool that edited record 8 but
    /// kept the ID line is read by record 8).
    pub fn exact_mode(&self, f_record8: f64, zeta_record8: f64) -> Option<(f64, f64)> {
        let rest = self.id_lines[4].trim().strip_prefix(EXACT_KEY)?;
        let (f, z) = rest.split_once(" zeta=")?;
        let (f, z): (f64, f64) = (f.trim().parse().ok()?, z.trim().parse().ok()?);
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-5 * a.abs().max(b.abs()) + 1e-300;
        (f.is_finite() && z.is_finite() && close(f, f_record8) && close(z, zeta_record8))
            .then_some((f, z))
    }
}

/// Largest values-per-node count accepted (tensors have 6 or 9).
const MAX_VALUES_PER_NODE: i64 = 64;
/// Largest record 7/8 count accepted (the UFF types use at most 8).
const MAX_PARAMETERS: i64 = 1000;

/// Parses records 1–10 and the closing `-1`, the cursor after the `55` line.
pub(crate) fn parse(cur: &mut Cursor<'_>) -> Result<Uff55, IoError> {
    let src = cur.source;
    let mut id_lines: [String; 5] = Default::default();
    for (i, id) in id_lines.iter_mut().enumerate() {
        let l = cur.expect_record(&format!("dataset 55 record {} (ID line)", i + 1))?;
        *id = String::from_utf8_lossy(l.text).trim_end().to_string();
    }
    let (r6, place6) = read_record6(cur)?;
    let (precision, complex, values_per_node) = value_layout(&r6, src, place6)?;
    let (integers, n_real) = read_record7(cur)?;
    let mut reals = Vec::new();
    text::read_numbers(cur, n_real, false, "dataset 55 record 8", &mut reals)?;

    let per_node = values_per_node * if complex { 2 } else { 1 };
    let (nodes, flat) = read_nodes(cur, per_node)?;
    let values = if complex {
        Ordinate::Complex(
            flat.chunks_exact(2)
                .map(|c| Complex64::new(c[0], c[1]))
                .collect(),
        )
    } else {
        Ordinate::Real(flat)
    };
    Ok(Uff55 {
        id_lines,
        model_type: r6[0],
        analysis_type: r6[1],
        data_characteristic: r6[2],
        specific_data_type: r6[3],
        precision,
        values_per_node,
        integers,
        reals,
        nodes,
        values,
    })
}

/// Record 6's data type (field 5) as precision and whether values are
/// complex, and its values per node (field 6, 1 to 64); `place6` locates
/// record 6 in `src`.
fn value_layout(
    r6: &[i64; 6],
    src: &str,
    place6: Place,
) -> Result<(Precision, bool, usize), IoError> {
    let precision_complex = match r6[4] {
        2 => (Precision::Single, false),
        4 => (Precision::Double, false),
        5 => (Precision::Single, true),
        6 => (Precision::Double, true),
        t => {
            return Err(IoError::invalid(
                src,
                place6,
                "dataset 55 data type (record 6 field 5)",
                t,
                "expected 2, 4 (real) or 5, 6 (complex)",
            ))
        }
    };
    if !(1..=MAX_VALUES_PER_NODE).contains(&r6[5]) {
        return Err(IoError::invalid(
            src,
            place6,
            "dataset 55 values per node (record 6 field 6)",
            r6[5],
            "expected 1 to 64",
        ));
    }
    let values_per_node = r6[5] as usize;
    let (precision, complex) = precision_complex;
    Ok((precision, complex, values_per_node))
}

/// Records 9 and 10 until the closing `-1`: the node numbers and, flat,
/// the `per_node` numbers after each.
fn read_nodes(cur: &mut Cursor<'_>, per_node: usize) -> Result<(Vec<i64>, Vec<f64>), IoError> {
    let src = cur.source;
    let mut nodes = Vec::new();
    let mut flat = Vec::new();
    loop {
        cur.skip_blank_lines();
        let place = cur.next_place();
        let line = cur.next_line().ok_or_else(|| {
            IoError::truncated(
                src,
                place,
                "expected a node number or the `-1` ending dataset 55",
            )
        })?;
        if line.is_delimiter() {
            break;
        }
        let toks: Vec<&[u8]> = text::tokens(line.text).collect();
        let node = match toks.as_slice() {
            [t] => parse_int(t)
                .ok_or_else(|| IoError::not_numeric(src, line.place(), "node number", t))?,
            _ => {
                return Err(IoError::record_length(
                    src,
                    line.place(),
                    format!(
                        "dataset 55 record 9 holds one node number, found {} fields; \
                         the node's value block has a wrong length",
                        toks.len()
                    ),
                ))
            }
        };
        nodes.push(node);
        text::read_numbers(
            cur,
            per_node,
            false,
            "dataset 55 record 10 (node values)",
            &mut flat,
        )?;
    }
    Ok((nodes, flat))
}

fn parse_int(t: &[u8]) -> Option<i64> {
    std::str::from_utf8(t).ok()?.parse().ok()
}

/// All integers on the next line.
fn line_ints(cur: &mut Cursor<'_>, what: &str) -> Result<(Vec<i64>, Place), IoError> {
    let line = cur.expect_line(what)?;
    if line.is_delimiter() {
        return Err(IoError::truncated(
            cur.source,
            line.place(),
            format!("{what} missing"),
        ));
    }
    let mut out = Vec::new();
    for t in text::tokens(line.text) {
        out.push(
            parse_int(t).ok_or_else(|| IoError::not_numeric(cur.source, line.place(), what, t))?,
        );
    }
    Ok((out, line.place()))
}

/// Record 6: exactly six integers.
fn read_record6(cur: &mut Cursor<'_>) -> Result<([i64; 6], Place), IoError> {
    let what = "dataset 55 record 6";
    let (v, place) = line_ints(cur, what)?;
    let arr: [i64; 6] = v.as_slice().try_into().map_err(|_| {
        IoError::record_length(
            cur.source,
            place,
            format!("{what} needs 6 integers, found {}", v.len()),
        )
    })?;
    Ok((arr, place))
}

/// Record 7: the two counts and `ni` integers, possibly wrapped over lines.
/// Returns the integers and the number of reals of record 8.
fn read_record7(cur: &mut Cursor<'_>) -> Result<(Vec<i64>, usize), IoError> {
    let what = "dataset 55 record 7";
    let (first, place) = line_ints(cur, what)?;
    if first.len() < 2 {
        return Err(IoError::record_length(
            cur.source,
            place,
            format!("{what} needs at least 2 integers"),
        ));
    }
    for (c, name) in first[..2].iter().zip(["integer", "real"]) {
        if !(0..=MAX_PARAMETERS).contains(c) {
            return Err(IoError::invalid(
                cur.source,
                place,
                &format!("{what} number of {name} values"),
                c,
                "expected 0 to 1000",
            ));
        }
    }
    let (n_int, n_real) = (first[0] as usize, first[1] as usize);
    let mut ints = first[2..].to_vec();
    while ints.len() < n_int {
        ints.extend(line_ints(cur, what)?.0);
    }
    if ints.len() > n_int {
        return Err(IoError::record_length(
            cur.source,
            place,
            format!("{what} declares {n_int} integers but holds {}", ints.len()),
        ));
    }
    Ok((ints, n_real))
}

/// Appends one dataset 55 (delimiters included).
pub(crate) fn write(out: &mut Vec<u8>, d: &Uff55, digits: NumberText) {
    out.extend_from_slice(b"    -1\n    55\n");
    for id in &d.id_lines {
        text::push_id_line(out, id);
    }
    // Record 6 field 5 of the dataset definition: 2 real, 5 complex (the
    // precision shows in record 10's layout, not in this code).
    let data_type = match &d.values {
        Ordinate::Real(_) => 2,
        Ordinate::Complex(_) => 5,
    };
    let r6 = [
        d.model_type,
        d.analysis_type,
        d.data_characteristic,
        d.specific_data_type,
        data_type,
        d.values_per_node as i64,
    ];
    push_ints(out, &r6);
    let mut r7 = vec![d.integers.len() as i64, d.reals.len() as i64];
    r7.extend_from_slice(&d.integers);
    push_ints(out, &r7);
    push_reals(out, &d.reals, digits);
    let flat: Vec<f64> = match &d.values {
        Ordinate::Real(v) => v.clone(),
        Ordinate::Complex(v) => v.iter().flat_map(|c| [c.re, c.im]).collect(),
    };
    let per_node = flat.len().checked_div(d.nodes.len()).unwrap_or(0);
    for (k, node) in d.nodes.iter().enumerate() {
        out.extend_from_slice(format!("{node:>10}\n").as_bytes());
        push_reals(
            out,
            flat.get(k * per_node..(k + 1) * per_node).unwrap_or(&[]),
            digits,
        );
    }
    out.extend_from_slice(b"    -1\n");
}

fn push_ints(out: &mut Vec<u8>, v: &[i64]) {
    for (i, x) in v.iter().enumerate() {
        out.extend_from_slice(format!("{x:>10}").as_bytes());
        if (i + 1) % 8 == 0 || i + 1 == v.len() {
            out.push(b'\n');
        }
    }
}

fn push_reals(out: &mut Vec<u8>, v: &[f64], digits: NumberText) {
    let decimals = match digits {
        NumberText::Standard => 5,
        NumberText::RoundTrip => 6,
    };
    for (i, x) in v.iter().enumerate() {
        text::push_e(out, *x, 13, decimals, false);
        if (i + 1) % 6 == 0 || i + 1 == v.len() {
            out.push(b'\n');
        }
    }
}
