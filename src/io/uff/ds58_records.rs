//! Text records 1–11 of dataset 58 (ID lines, DOF identification, data
//! form, axis characteristics) and the ASCII record 12 writer; the layouts
//! are tabulated in [`ds58`](super::ds58).

use super::ds58::{
    Abscissa, AxisInfo, Entity58, FunctionType, NumberText, Ordinate, Precision, Uff58,
};
use super::text::{self, Columns, Cursor, Line};
use crate::io::error::{IoError, Location, Place};

/// Parses records 1–11. Returns the dataset with empty data, record 7 and
/// the place of record 7 (for data-length errors).
pub(crate) fn parse_header(cur: &mut Cursor<'_>) -> Result<(Uff58, DataForm, Place), IoError> {
    let src = cur.source;
    let mut id_lines: [String; 5] = Default::default();
    for (i, id) in id_lines.iter_mut().enumerate() {
        let l = cur.expect_record(&format!("dataset 58 record {} (ID line)", i + 1))?;
        *id = String::from_utf8_lossy(l.text).trim_end().to_string();
    }
    let r6 = Columns::new(&cur.expect_record("dataset 58 record 6 (DOF identification)")?);
    let function =
        FunctionType::from_code(to_i32(src, r6.place, r6.int(src, 0, 5, "function type")?)?);
    let response = Entity58 {
        entity: r6.text(31, 41),
        node: r6.int(src, 41, 51, "response node")?,
        direction: r6.int(src, 51, 55, "response direction")?,
    };
    let reference = Entity58 {
        entity: r6.text(56, 66),
        node: r6.int(src, 66, 76, "reference node")?,
        direction: r6.int(src, 76, 80, "reference direction")?,
    };
    let (function_id, version) = (
        r6.int(src, 5, 15, "function id")?,
        r6.int(src, 15, 20, "version")?,
    );
    let load_case = r6.int(src, 20, 30, "load case")?;

    let r7 = cur.expect_record("dataset 58 record 7 (data form)")?;
    let form = parse_record7(src, &r7)?;
    let mut axes: [AxisInfo; 4] = Default::default();
    for (i, axis) in axes.iter_mut().enumerate() {
        let l = cur.expect_record(&format!(
            "dataset 58 record {} (axis characteristics)",
            i + 8
        ))?;
        *axis = parse_axis(src, &l)?;
    }

    let [abscissa_axis, ordinate_axis, denominator_axis, z_axis] = axes;
    let d = Uff58 {
        id_lines,
        function,
        function_id,
        version,
        load_case,
        response,
        reference,
        z_axis_value: form.z_axis_value,
        abscissa_axis,
        ordinate_axis,
        denominator_axis,
        z_axis,
        precision: form.precision,
        abscissa: Abscissa::Uneven(Vec::new()),
        ordinate: Ordinate::Real(Vec::new()),
    };
    Ok((d, form, r7.place()))
}

fn to_i32(src: &str, place: Place, v: i64) -> Result<i32, IoError> {
    i32::try_from(v).map_err(|_| IoError::invalid(src, place, "integer field", v, "too large"))
}

/// Record 7 as read.
pub(crate) struct DataForm {
    pub precision: Precision,
    pub complex: bool,
    pub points: usize,
    pub even: bool,
    pub start: f64,
    pub step: f64,
    pub z_axis_value: f64,
}

fn parse_record7(src: &str, line: &Line<'_>) -> Result<DataForm, IoError> {
    let toks: Vec<&[u8]> = text::tokens(line.text).collect();
    let int = |i: usize, field: &str| -> Result<i64, IoError> {
        let t = toks.get(i).copied().unwrap_or(b"0");
        std::str::from_utf8(t)
            .ok()
            .and_then(|s| s.parse::<i64>().ok())
            .ok_or_else(|| IoError::not_numeric(src, line.place(), field, t))
    };
    let real = |i: usize, field: &str| -> Result<f64, IoError> {
        let t = toks.get(i).copied().unwrap_or(b"0");
        let v =
            text::parse_f64(t).ok_or_else(|| IoError::not_numeric(src, line.place(), field, t))?;
        if v.is_finite() {
            Ok(v)
        } else {
            Err(IoError::NonFinite {
                at: Location::new(src, line.place()),
                field: field.to_string(),
                value: v,
            })
        }
    };
    if toks.len() < 3 {
        return Err(IoError::record_length(
            src,
            line.place(),
            format!(
                "dataset 58 record 7 needs at least 3 fields, found {}",
                toks.len()
            ),
        ));
    }
    let (precision, complex) = match int(0, "ordinate data type")? {
        2 => (Precision::Single, false),
        4 => (Precision::Double, false),
        5 => (Precision::Single, true),
        6 => (Precision::Double, true),
        t => return Err(IoError::invalid(
            src,
            line.place(),
            "ordinate data type (record 7 field 1)",
            t,
            "expected 2 (real single), 4 (real double), 5 (complex single) or 6 (complex double)",
        )),
    };
    let points = int(1, "number of points")?;
    let points = usize::try_from(points).map_err(|_| {
        IoError::invalid(
            src,
            line.place(),
            "number of points (record 7 field 2)",
            points,
            "must be ≥ 0",
        )
    })?;
    let even = match int(2, "abscissa spacing")? {
        0 => false,
        1 => true,
        s => {
            return Err(IoError::invalid(
                src,
                line.place(),
                "abscissa spacing (record 7 field 3)",
                s,
                "expected 0 (uneven) or 1 (even)",
            ))
        }
    };
    Ok(DataForm {
        precision,
        complex,
        points,
        even,
        start: real(3, "abscissa minimum")?,
        step: real(4, "abscissa increment")?,
        z_axis_value: real(5, "z-axis value")?,
    })
}

fn parse_axis(src: &str, line: &Line<'_>) -> Result<AxisInfo, IoError> {
    let c = Columns::new(line);
    let small = |v: i64| to_i32(src, c.place, v);
    Ok(AxisInfo {
        data_type: small(c.int(src, 0, 10, "specific data type")?)?,
        length_exp: small(c.int(src, 10, 15, "length units exponent")?)?,
        force_exp: small(c.int(src, 15, 20, "force units exponent")?)?,
        temperature_exp: small(c.int(src, 20, 25, "temperature units exponent")?)?,
        label: c.text(26, 46),
        units: c.text(47, 67),
    })
}

pub(crate) fn write_header(out: &mut Vec<u8>, d: &Uff58, digits: NumberText) {
    for id in &d.id_lines {
        text::push_id_line(out, id);
    }
    let r = &d.response;
    let f = &d.reference;
    out.extend_from_slice(
        format!(
            "{:>5}{:>10}{:>5}{:>10} ",
            d.function.code(),
            d.function_id,
            d.version,
            d.load_case
        )
        .as_bytes(),
    );
    text::push_fixed_str(out, &r.entity, 10);
    out.extend_from_slice(format!("{:>10}{:>4} ", r.node, r.direction).as_bytes());
    text::push_fixed_str(out, &f.entity, 10);
    out.extend_from_slice(format!("{:>10}{:>4}\n", f.node, f.direction).as_bytes());

    let (even, start, step) = match d.abscissa {
        Abscissa::Even { start, step } => (1, start, step),
        Abscissa::Uneven(_) => (0, 0.0, 0.0),
    };
    out.extend_from_slice(
        format!("{:>10}{:>10}{:>10}", d.ordinate_data_type(), d.len(), even).as_bytes(),
    );
    for v in [start, step, d.z_axis_value] {
        push_header_real(out, v, digits);
    }
    out.push(b'\n');
    for axis in [
        &d.abscissa_axis,
        &d.ordinate_axis,
        &d.denominator_axis,
        &d.z_axis,
    ] {
        out.extend_from_slice(
            format!(
                "{:>10}{:>5}{:>5}{:>5} ",
                axis.data_type, axis.length_exp, axis.force_exp, axis.temperature_exp
            )
            .as_bytes(),
        );
        text::push_fixed_str(out, &axis.label, 20);
        out.push(b' ');
        text::push_fixed_str(out, &axis.units, 20);
        out.push(b'\n');
    }
}

/// Record 7 real field: E13.5, or E25.16 in round-trip mode when E13.5 would
/// change the value.
fn push_header_real(out: &mut Vec<u8>, v: f64, digits: NumberText) {
    let mut short = Vec::with_capacity(13);
    text::push_e(&mut short, v, 13, 5, false);
    let exact = text::parse_f64(short.trim_ascii()).map(f64::to_bits) == Some(v.to_bits());
    if digits == NumberText::Standard || exact {
        out.extend_from_slice(&short);
    } else {
        text::push_e(out, v, 25, 16, false);
    }
}

pub(crate) fn push_ascii_data(out: &mut Vec<u8>, values: &[f64], d: &Uff58, digits: NumberText) {
    let single = d.precision == Precision::Single;
    let uneven = matches!(d.abscissa, Abscissa::Uneven(_));
    let complex = matches!(d.ordinate, Ordinate::Complex(_));
    let pattern: &[(usize, usize)] = match (digits, single, uneven, complex) {
        (NumberText::Standard, true, _, _) => &[(13, 5); 6],
        (NumberText::Standard, false, false, _) => &[(20, 12); 4],
        (NumberText::Standard, false, true, false) => &[(13, 5), (20, 12), (13, 5), (20, 12)],
        (NumberText::Standard, false, true, true) => &[(13, 5), (20, 12), (20, 12)],
        (NumberText::RoundTrip, true, _, _) => &[(16, 8); 5],
        (NumberText::RoundTrip, false, _, _) => &[(25, 16); 3],
    };
    for (i, &v) in values.iter().enumerate() {
        let (w, dec) = pattern[i % pattern.len()];
        text::push_e(out, v, w, dec, single);
        if (i + 1) % pattern.len() == 0 || i + 1 == values.len() {
            out.push(b'\n');
        }
    }
}
