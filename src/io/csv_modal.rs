//! The CSV modal tables `modes.csv` and `mode_shapes.csv` (format in the
//! [`io`](crate::io) module docs) to and from [`ModalModel`]s.
//!
//! One shape is written everywhere: `position,position_label,mode,
//! frequency_hz,damping_ratio` and `position,mode,node,direction,real,imag`.
//! The reader also takes hand-written tables: without the position columns
//! (one position, 0), without `damping_ratio` or with empty damping cells
//! (damping not given: NaN in memory, an empty cell when written), and
//! without any shapes (an empty `mode_shapes.csv`: modes with no DOFs).

use crate::frf::{Dof, Position};
use crate::io::csv_table::{csv_err, fmt_f64, from_csv_error, int_cell, real_cell, Table};
use crate::io::dof_text::parse_direction;
use crate::io::error::{IoError, Place};
use crate::io::validity::check_natural_frequency;
use crate::modal::{ModalModel, Mode};
use num_complex::Complex64;
use std::collections::HashMap;

/// The columns of `modes.csv` as every writer writes them.
pub const MODES_HEADER: [&str; 5] = [
    "position",
    "position_label",
    "mode",
    "frequency_hz",
    "damping_ratio",
];
/// The columns of `mode_shapes.csv` as every writer writes them.
pub const SHAPES_HEADER: [&str; 6] = ["position", "mode", "node", "direction", "real", "imag"];

/// The two tables of a modal model export.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ModalCsv {
    pub modes: Vec<u8>,
    pub mode_shapes: Vec<u8>,
}

/// Reads `modes.csv` and `mode_shapes.csv` into one model per position.
pub fn read_modal_csv(
    modes_csv: &[u8],
    modes_source: &str,
    shapes_csv: &[u8],
    shapes_source: &str,
) -> Result<Vec<ModalModel>, IoError> {
    let ModesTable {
        mut models,
        model_of,
        slots,
    } = read_modes(modes_csv, modes_source)?;
    if !shapes_csv.trim_ascii().is_empty() {
        read_shapes(
            &mut models,
            &Lookup {
                model_of: &model_of,
                slots: &slots,
            },
            shapes_csv,
            shapes_source,
        )?;
    }
    Ok(models
        .into_iter()
        .map(|(mut m, numbers)| {
            let mut order: Vec<usize> = (0..m.modes.len()).collect();
            order.sort_by_key(|&i| numbers[i]);
            m.modes = order.iter().map(|&i| m.modes[i].clone()).collect();
            m
        })
        .collect())
}

/// The modes table as read: per model, its modes in file order (no shapes
/// yet) with their mode numbers, and the lookups into them.
struct ModesTable {
    models: Vec<(ModalModel, Vec<u32>)>,
    model_of: HashMap<u32, usize>,
    slots: HashMap<(usize, u32), usize>,
}

/// The columns of `modes.csv` found in its header.
struct ModeColumns {
    position: Option<usize>,
    label: Option<usize>,
    mode: usize,
    frequency: usize,
    damping: Option<usize>,
}

/// Read `modes.csv` (`src` names it in errors): one model per position, a
/// position with two labels or a mode number listed twice is an error.
fn read_modes(bytes: &[u8], src: &str) -> Result<ModesTable, IoError> {
    let known = MODES_HEADER;
    let (t, mut rdr) = Table::open(bytes, src, &known, &known[2..4])?;
    let cols = ModeColumns {
        position: t.col("position"),
        label: t.col("position_label"),
        mode: t.col("mode").unwrap_or(0),
        frequency: t.col("frequency_hz").unwrap_or(0),
        damping: t.col("damping_ratio"),
    };
    // Per model: the mode numbers next to the modes, sorted at the end.
    let mut models: Vec<(ModalModel, Vec<u32>)> = Vec::new();
    // Lookups by hash, so the time is linear in the rows: position → model,
    // (model, mode number) → mode slot.
    let mut model_of: HashMap<u32, usize> = HashMap::new();
    let mut slots: HashMap<(usize, u32), usize> = HashMap::new();
    for rec in rdr.records() {
        let rec = rec.map_err(|e| from_csv_error(src, &e))?;
        let line = rec.position().map(|p| p.line() as usize).unwrap_or(0);
        let (index, label, number, mode) = mode_row(&rec, &cols, src, line)?;
        let m = match model_of.get(&index) {
            Some(&m) => m,
            None => {
                let position = Position {
                    index,
                    label: label.clone(),
                };
                models.push((
                    ModalModel {
                        position,
                        dofs: Vec::new(),
                        modes: Vec::new(),
                    },
                    Vec::new(),
                ));
                model_of.insert(index, models.len() - 1);
                models.len() - 1
            }
        };
        let (model, numbers) = &mut models[m];
        if model.position.label != label {
            return Err(csv_err(
                src,
                line,
                format!("position {index} has two labels"),
            ));
        }
        if slots.insert((m, number), numbers.len()).is_some() {
            return Err(csv_err(
                src,
                line,
                format!("mode {number} of position {index} appears twice"),
            ));
        }
        numbers.push(number);
        model.modes.push(mode);
    }
    Ok(ModesTable {
        models,
        model_of,
        slots,
    })
}

/// One row of `modes.csv` at `line`: position index, position label, mode
/// number and the mode without its shape (damping NaN when not given).
fn mode_row(
    rec: &csv::StringRecord,
    cols: &ModeColumns,
    src: &str,
    line: usize,
) -> Result<(u32, String, u32, Mode), IoError> {
    let cell = |i: usize| rec.get(i).unwrap_or("");
    let index = match cols.position {
        Some(i) => int_cell::<u32>(src, line, "position", cell(i))?,
        None => 0,
    };
    let label = cols.label.map(|i| cell(i).to_string()).unwrap_or_default();
    let number = int_cell::<u32>(src, line, "mode", cell(cols.mode))?;
    let frequency_hz = real_cell(src, line, "frequency_hz", cell(cols.frequency))?;
    check_natural_frequency(frequency_hz)
        .map_err(|m| IoError::implausible(src, Place::Line(line), format!("frequency_hz: {m}")))?;
    let damping_ratio = match cols.damping.map(cell).filter(|c| !c.trim().is_empty()) {
        Some(c) => real_cell(src, line, "damping_ratio", c)?,
        None => f64::NAN,
    };
    let mode = Mode {
        frequency_hz,
        damping_ratio,
        shape: Vec::new(),
    };
    Ok((index, label, number, mode))
}

/// The modes table's hash lookups: position → model, (model, mode
/// number) → mode slot.
struct Lookup<'a> {
    model_of: &'a HashMap<u32, usize>,
    slots: &'a HashMap<(usize, u32), usize>,
}

/// The columns of `mode_shapes.csv` found in its header.
struct ShapeColumns {
    position: Option<usize>,
    mode: usize,
    node: usize,
    direction: usize,
    real: usize,
    imag: Option<usize>,
}

/// One row of `mode_shapes.csv`.
struct ShapeRow {
    index: u32,
    number: u32,
    node: u32,
    direction: i8,
    re: f64,
    im: f64,
}

/// Read `mode_shapes.csv` (`src` names it in errors) into the shapes of the
/// modes read from `modes.csv`: each row must name a mode of that table,
/// and every mode of a position needs a value at every DOF of it.
fn read_shapes(
    models: &mut [(ModalModel, Vec<u32>)],
    lookup: &Lookup<'_>,
    bytes: &[u8],
    src: &str,
) -> Result<(), IoError> {
    let known = SHAPES_HEADER;
    let (t, mut rdr) = Table::open(bytes, src, &known, &["mode", "node", "direction", "real"])?;
    let c = |n: &str| t.col(n).unwrap_or(0);
    let cols = ShapeColumns {
        position: t.col("position"),
        mode: c("mode"),
        node: c("node"),
        direction: c("direction"),
        real: c("real"),
        imag: t.col("imag"),
    };
    // Per model: (mode slot, DOF slot) → value and the line where each DOF first appears.
    let mut values: Vec<Vec<Vec<Option<Complex64>>>> = models
        .iter()
        .map(|(m, _)| vec![Vec::new(); m.modes.len()])
        .collect();
    let mut first_lines: Vec<Vec<usize>> = vec![Vec::new(); models.len()];
    // Per model: DOF → its slot (first-appearance order).
    let mut dof_slot: Vec<HashMap<Dof, usize>> = vec![HashMap::new(); models.len()];
    for rec in rdr.records() {
        let rec = rec.map_err(|e| from_csv_error(src, &e))?;
        let line = rec.position().map(|p| p.line() as usize).unwrap_or(0);
        let ShapeRow {
            index,
            number,
            node,
            direction,
            re,
            im,
        } = shape_row(&rec, &cols, src, line)?;
        let m = lookup.model_of.get(&index).copied().ok_or_else(|| {
            csv_err(
                src,
                line,
                format!("position {index} is not in the modes table"),
            )
        })?;
        let Some((model, _)) = models.get_mut(m) else {
            continue;
        };
        let k = lookup.slots.get(&(m, number)).copied().ok_or_else(|| {
            csv_err(
                src,
                line,
                format!("mode {number} of position {index} is not in the modes table"),
            )
        })?;
        let dof = Dof::new(node, direction);
        let d = match dof_slot[m].get(&dof) {
            Some(&d) => d,
            None => {
                dof_slot[m].insert(dof, model.dofs.len());
                model.dofs.push(dof);
                first_lines[m].push(line);
                model.dofs.len() - 1
            }
        };
        let slot = &mut values[m][k];
        if slot.len() <= d {
            slot.resize(d + 1, None);
        }
        if slot[d].is_some() {
            return Err(csv_err(
                src,
                line,
                format!("mode {number} of position {index} lists DOF {dof} twice"),
            ));
        }
        slot[d] = Some(Complex64::new(re, im));
    }
    fill_shapes(models, &values, &first_lines, src)
}

/// One row of `mode_shapes.csv` at `line`, its cells parsed (imag 0 when
/// not given).
fn shape_row(
    rec: &csv::StringRecord,
    cols: &ShapeColumns,
    src: &str,
    line: usize,
) -> Result<ShapeRow, IoError> {
    let cell = |i: usize| rec.get(i).unwrap_or("");
    let index = match cols.position {
        Some(i) => int_cell::<u32>(src, line, "position", cell(i))?,
        None => 0,
    };
    let number = int_cell::<u32>(src, line, "mode", cell(cols.mode))?;
    let node = int_cell::<u32>(src, line, "node", cell(cols.node))?;
    let direction = parse_direction(cell(cols.direction)).ok_or_else(|| {
        csv_err(
            src,
            line,
            format!(
                "direction {:?}: use +X … -RZ, S or a code -6 to 6",
                cell(cols.direction)
            ),
        )
    })?;
    let re = real_cell(src, line, "real", cell(cols.real))?;
    let im = match cols.imag.map(cell).filter(|s| !s.is_empty()) {
        Some(s) => real_cell(src, line, "imag", s)?,
        None => 0.0,
    };
    Ok(ShapeRow {
        index,
        number,
        node,
        direction,
        re,
        im,
    })
}

/// Give every mode its shape over its model's DOFs from `values` (per
/// model, mode slot and DOF slot); a DOF without a value for some mode is
/// an error at the line that first listed it (`first_lines`).
fn fill_shapes(
    models: &mut [(ModalModel, Vec<u32>)],
    values: &[Vec<Vec<Option<Complex64>>>],
    first_lines: &[Vec<usize>],
    src: &str,
) -> Result<(), IoError> {
    for (m, (model, numbers)) in models.iter_mut().enumerate() {
        for (k, mode) in model.modes.iter_mut().enumerate() {
            let row = &values[m][k];
            let mut shape = Vec::with_capacity(model.dofs.len());
            for (d, dof) in model.dofs.iter().enumerate() {
                let v = row.get(d).copied().flatten().ok_or_else(|| {
                    csv_err(
                        src,
                        first_lines[m][d],
                        format!(
                            "DOF {dof} (first listed here) has no row for mode {} of position {}; \
                             every mode needs the same DOFs",
                            numbers[k], model.position.index
                        ),
                    )
                })?;
                shape.push(v);
            }
            mode.shape = shape;
        }
    }
    Ok(())
}

/// Writes modal models as `modes.csv` and `mode_shapes.csv`, always with
/// the position columns (module docs); a damping ratio not given (NaN) is an
/// empty cell.
pub fn write_modal_csv(models: &[ModalModel]) -> Result<ModalCsv, IoError> {
    let err = |e: csv::Error| IoError::Unwritable {
        what: format!("CSV: {e}"),
    };
    let mut modes = csv::Writer::from_writer(Vec::new());
    let mut shapes = csv::Writer::from_writer(Vec::new());
    modes.write_record(MODES_HEADER).map_err(err)?;
    shapes.write_record(SHAPES_HEADER).map_err(err)?;
    for m in models {
        let position = m.position.index.to_string();
        for (k, mode) in m.modes.iter().enumerate() {
            let damping = if mode.damping_ratio.is_nan() {
                String::new()
            } else {
                fmt_f64(mode.damping_ratio)
            };
            let number = (k + 1).to_string();
            modes
                .write_record([
                    position.as_str(),
                    &m.position.label,
                    &number,
                    &fmt_f64(mode.frequency_hz),
                    &damping,
                ])
                .map_err(err)?;
            for (dof, v) in m.dofs.iter().zip(&mode.shape) {
                shapes
                    .write_record([
                        position.clone(),
                        number.clone(),
                        dof.node.to_string(),
                        dof.direction_label(),
                        fmt_f64(v.re),
                        fmt_f64(v.im),
                    ])
                    .map_err(err)?;
            }
        }
    }
    let into = |w: csv::Writer<Vec<u8>>| {
        w.into_inner().map_err(|e| IoError::Unwritable {
            what: format!("CSV: {}", e.error()),
        })
    };
    Ok(ModalCsv {
        modes: into(modes)?,
        mode_shapes: into(shapes)?,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn model(index: u32, label: &str) -> ModalModel {
        let dofs = vec![Dof::new(1, 1), Dof::new(2, -3), Dof::new(9, 0)];
        let modes = (0..3)
            .map(|k| Mode {
                frequency_hz: 10.0 / 3.0 * (k + 1) as f64,
                damping_ratio: 0.01 * (k + 1) as f64,
                shape: (0..3)
                    .map(|i| Complex64::new(0.1 * i as f64 - k as f64, 1e-20 * i as f64))
                    .collect(),
            })
            .collect();
        ModalModel {
            position: Position {
                index,
                label: label.into(),
            },
            dofs,
            modes,
        }
    }

    #[test]
    fn round_trip_with_and_without_positions() {
        for models in [vec![model(0, "")], vec![model(0, "a"), model(3, "b,c")]] {
            let csv = write_modal_csv(&models).unwrap();
            let back =
                read_modal_csv(&csv.modes, "modes.csv", &csv.mode_shapes, "shapes.csv").unwrap();
            assert_eq!(back, models);
        }
        // One shape for every writer: the position columns are always there.
        let single = write_modal_csv(&[model(0, "")]).unwrap();
        assert!(single
            .modes
            .starts_with(b"position,position_label,mode,frequency_hz,damping_ratio\n0,,1,"));
        assert!(single
            .mode_shapes
            .starts_with(b"position,mode,node,direction,real,imag\n0,1,1,+X,"));
    }

    #[test]
    fn damping_and_shapes_are_optional() {
        let modes = b"mode,frequency_hz\n1,10\n2,20\n";
        let m = read_modal_csv(modes, "m.csv", b"", "s.csv").unwrap();
        assert_eq!(m[0].modes.len(), 2);
        assert!(m[0].modes[1].damping_ratio.is_nan() && m[0].dofs.is_empty());
        let modes = b"mode,frequency_hz,damping_ratio\n1,10,\n2,20,0.02\n";
        let m = read_modal_csv(modes, "m.csv", b"\n", "s.csv").unwrap();
        assert!(m[0].modes[0].damping_ratio.is_nan());
        assert_eq!(m[0].modes[1].damping_ratio, 0.02);
        let csv = write_modal_csv(&m).unwrap();
        assert!(csv.modes.starts_with(
            b"position,position_label,mode,frequency_hz,damping_ratio\n0,,1,10,\n0,,2,20,0.02\n"
        ));
        let back = read_modal_csv(&csv.modes, "m.csv", &csv.mode_shapes, "s.csv").unwrap();
        assert!(back[0].modes[0].damping_ratio.is_nan());
        assert_eq!(back[0].modes[1], m[0].modes[1]);
    }

    #[test]
    fn modes_sort_by_number_and_codes_are_accepted() {
        let modes = b"mode,frequency_hz,damping_ratio\n2,20,0.02\n1,10,0.01\n";
        let shapes = b"mode,node,direction,real\n1,5,3,0.5\n2,5,+Z,-0.5\n";
        let m = read_modal_csv(modes, "m.csv", shapes, "s.csv").unwrap();
        assert_eq!(m[0].modes[0].frequency_hz, 10.0);
        assert_eq!(m[0].dofs, vec![Dof::new(5, 3)]);
        assert_eq!(m[0].modes[1].shape, vec![Complex64::new(-0.5, 0.0)]);
    }

    #[test]
    fn incomplete_shapes_are_errors() {
        let modes = b"mode,frequency_hz,damping_ratio\n1,10,0.01\n2,20,0.02\n";
        let shapes = b"mode,node,direction,real,imag\n1,5,+Z,0.5,0\n2,6,+Z,0.5,0\n";
        let e = read_modal_csv(modes, "m.csv", shapes, "s.csv").unwrap_err();
        assert!(
            e.to_string()
                .starts_with("s.csv, line 3: DOF 6+Z (first listed here) has no row for mode 1"),
            "{e}"
        );
        let shapes = b"mode,node,direction,real,imag\n3,5,+Z,0.5,0\n";
        let e = read_modal_csv(modes, "m.csv", shapes, "s.csv").unwrap_err();
        assert!(
            e.to_string()
                .contains("mode 3 of position 0 is not in the modes table"),
            "{e}"
        );
        let dup = b"mode,frequency_hz,damping_ratio\n1,10,0.01\n1,20,0.02\n";
        let e = read_modal_csv(dup, "m.csv", b"mode,node,direction,real\n", "s.csv").unwrap_err();
        assert!(e.to_string().contains("m.csv, line 3"), "{e}");
        let e = read_modal_csv(
            modes,
            "m.csv",
            b"mode,node,direction,real\n1,5,+Q,1\n",
            "s.csv",
        )
        .unwrap_err();
        assert!(e.to_string().contains("direction \"+Q\""), "{e}");
        let negative = b"mode,frequency_hz,damping_ratio\n1,10,0.01\n2,-20,0.02\n";
        let e = read_modal_csv(negative, "m.csv", shapes, "s.csv").unwrap_err();
        assert!(
            matches!(e, IoError::Implausible { .. })
                && e.to_string()
                    .starts_with("m.csv, line 3: frequency_hz: natural frequency -20"),
            "{e}"
        );
    }
}
