//! `modes`: a directory with `modes.csv` (`position,position_label,mode,
//! frequency_hz,damping_ratio`; an empty damping cell: not given) and
//! `mode_shapes.csv` (`position,mode,node,direction,real,imag`), and, when
//! the estimate states it, `uncertainty.csv` (`position,mode,
//! frequency_std_rel,damping_std_rel`: relative standard deviations per
//! mode, see [`ModeSpread`]), and, when the shapes are known to be
//! mass-normalized (computed modes), `scaling.json`
//! (`{"scaling": "mass_normalized"}`, see [`ShapeScaling`]); without it the
//! scale is arbitrary.

use super::{write_file, ArtifactError};
use crate::io;
use crate::modal::{ModalModel, ShapeScaling};
use std::path::Path;

/// The directory name of a `modes` output.
pub const DIR: &str = "modes";

fn write(path: &Path, bytes: &[u8]) -> Result<(), ArtifactError> {
    write_file(path, bytes)
}

/// Write a `modes` artifact directory.
pub fn write_modes(dir: &Path, models: &[ModalModel]) -> Result<(), ArtifactError> {
    std::fs::create_dir_all(dir)
        .map_err(|e| ArtifactError::io(format!("cannot create {}", dir.display()), e))?;
    let csv = io::write_modal_csv(models).map_err(|e| ArtifactError::Encode {
        what: "a modes artifact".into(),
        message: e.to_string(),
    })?;
    write(&dir.join("modes.csv"), &csv.modes)?;
    write(&dir.join("mode_shapes.csv"), &csv.mode_shapes)
}

const SCALING_FILE: &str = "scaling.json";

/// Write a `modes` artifact directory of mass-normalized (computed) modes:
/// the tables and `scaling.json`.
pub fn write_mass_normalized_modes(dir: &Path, models: &[ModalModel]) -> Result<(), ArtifactError> {
    write_modes(dir, models)?;
    write(
        &dir.join(SCALING_FILE),
        b"{\"scaling\": \"mass_normalized\"}\n",
    )
}

/// How the shapes of the `modes` artifact in `dir` are scaled: stated by
/// `scaling.json`, else arbitrary. An unreadable or unknown statement is
/// an error naming the input.
pub fn read_shape_scaling(dir: &Path, input: &str) -> Result<ShapeScaling, ArtifactError> {
    let text = match std::fs::read_to_string(dir.join(SCALING_FILE)) {
        Ok(t) => t,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(ShapeScaling::Arbitrary),
        Err(e) => return Err(ArtifactError::io(format!("cannot read input `{input}`"), e)),
    };
    let v: serde_json::Value = serde_json::from_str(&text).map_err(|e| ArtifactError::Invalid {
        input: input.into(),
        message: format!("{SCALING_FILE}: {e}"),
    })?;
    match v["scaling"].as_str() {
        Some("mass_normalized") => Ok(ShapeScaling::MassNormalized),
        Some("arbitrary") => Ok(ShapeScaling::Arbitrary),
        other => Err(ArtifactError::Invalid {
            input: input.into(),
            message: format!(
                "{SCALING_FILE}: scaling {other:?} is not `mass_normalized` or `arbitrary`"
            ),
        }),
    }
}

/// Read the `modes` artifact bound to input `input`.
pub fn read_modes(dir: &Path, input: &str) -> Result<Vec<ModalModel>, ArtifactError> {
    let read = |name: &str| {
        std::fs::read(dir.join(name)).map_err(|e| {
            ArtifactError::invalid(
                input,
                format!("not a modes artifact (no {name}: {e}); bind a `modes` output"),
            )
        })
    };
    let (modes, shapes) = (read("modes.csv")?, read("mode_shapes.csv")?);
    io::read_modal_csv(&modes, "modes.csv", &shapes, "mode_shapes.csv").map_err(|e| {
        ArtifactError::Invalid {
            input: input.to_string(),
            message: e.to_string(),
        }
    })
}

/// Read a `modes` artifact whose every mode must state its damping ratio
/// (`kind` uses it): imported reference modes may leave it out.
pub fn read_damped_modes(
    dir: &Path,
    input: &str,
    kind: &str,
) -> Result<Vec<ModalModel>, ArtifactError> {
    let models = read_modes(dir, input)?;
    let missing: Vec<String> = models
        .iter()
        .flat_map(|m| {
            m.modes
                .iter()
                .enumerate()
                .filter(|(_, x)| x.damping_ratio.is_nan())
                .map(move |(k, _)| format!("position {} mode {}", m.position.index, k + 1))
        })
        .collect();
    if let Some(first) = missing.first() {
        return Err(ArtifactError::Invalid {
            input: input.to_string(),
            message: format!(
                "{} mode(s) without a damping ratio (first: {first}); {kind} fits the damping \
                 of every reference mode: give damping_ratio in the imported table, or compare \
                 these modes with `evaluate` (which skips NDD for them)",
                missing.len()
            ),
        });
    }
    Ok(models)
}

/// The stated uncertainty of one identified mode (`uncertainty.csv` of a
/// `modes` artifact): relative standard deviations of its frequency and
/// damping ratio, e.g. an AutoEMA stable column's spread.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ModeSpread {
    pub position: u32,
    /// 1-based, as in modes.csv.
    pub mode: usize,
    pub frequency: f64,
    pub damping: f64,
}

const SPREAD_FILE: &str = "uncertainty.csv";
const SPREAD_HEADER: &str = "position,mode,frequency_std_rel,damping_std_rel";
/// The header before columns said `_rel` (read the same way).
const SPREAD_HEADER_V1: &str = "position,mode,frequency_spread,damping_spread";

/// Write `uncertainty.csv` into a `modes` artifact directory.
pub fn write_mode_spread(dir: &Path, spread: &[ModeSpread]) -> Result<(), ArtifactError> {
    use std::fmt::Write as _;
    let mut out = format!("{SPREAD_HEADER}\n");
    for s in spread {
        let _ = writeln!(
            out,
            "{},{},{},{}",
            s.position, s.mode, s.frequency, s.damping
        );
    }
    write(&dir.join(SPREAD_FILE), out.as_bytes())
}

/// Read `uncertainty.csv` of the `modes` artifact bound to `input`: `None`
/// when the artifact states no uncertainty; an error naming the line when
/// the file is malformed or a value is not a finite number ≥ 0.
pub fn read_mode_spread(dir: &Path, input: &str) -> Result<Option<Vec<ModeSpread>>, ArtifactError> {
    let path = dir.join(SPREAD_FILE);
    let text = match std::fs::read_to_string(&path) {
        Ok(t) => t,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => {
            return Err(ArtifactError::io(
                format!("cannot read {}", path.display()),
                e,
            ))
        }
    };
    let bad = |line: usize, why: String| ArtifactError::Invalid {
        input: input.to_string(),
        message: format!("{SPREAD_FILE} line {line}: {why} (expected `{SPREAD_HEADER}`)"),
    };
    let mut lines = text.lines();
    if !matches!(
        lines.next().map(str::trim),
        Some(SPREAD_HEADER | SPREAD_HEADER_V1)
    ) {
        return Err(bad(1, "unexpected header".into()));
    }
    let mut out = Vec::new();
    for (i, line) in lines.enumerate().filter(|(_, l)| !l.trim().is_empty()) {
        let f: Vec<&str> = line.split(',').map(str::trim).collect();
        if f.len() != 4 {
            return Err(bad(i + 2, format!("{} fields, not 4", f.len())));
        }
        let number = |k: usize| -> Result<f64, ArtifactError> {
            f[k].parse::<f64>()
                .ok()
                .filter(|v| v.is_finite() && *v >= 0.0)
                .ok_or_else(|| bad(i + 2, format!("`{}` is not a finite number ≥ 0", f[k])))
        };
        let (position, mode) = (number(0)?, number(1)?);
        if position.fract() != 0.0 || mode.fract() != 0.0 || mode < 1.0 {
            return Err(bad(
                i + 2,
                "position and mode must be whole numbers, mode ≥ 1".into(),
            ));
        }
        out.push(ModeSpread {
            position: position as u32,
            mode: mode as usize,
            frequency: number(2)?,
            damping: number(3)?,
        });
    }
    Ok(Some(out))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mode_spread_round_trips_and_is_optional() {
        let dir = tempfile::tempdir().unwrap();
        assert_eq!(read_mode_spread(dir.path(), "reference").unwrap(), None);
        let spread = [
            ModeSpread {
                position: 0,
                mode: 1,
                frequency: 2e-4,
                damping: 0.01,
            },
            ModeSpread {
                position: 3,
                mode: 2,
                frequency: 0.041,
                damping: 0.3,
            },
        ];
        write_mode_spread(dir.path(), &spread).unwrap();
        let back = read_mode_spread(dir.path(), "reference").unwrap().unwrap();
        assert_eq!(back, spread);
    }

    #[test]
    fn malformed_mode_spread_names_the_line() {
        let dir = tempfile::tempdir().unwrap();
        for (body, needle) in [
            (
                "position,mode,frequency_std_rel,damping_std_rel\n0,1,NaN,0\n",
                "line 2",
            ),
            (
                "position,mode,frequency_spread,damping_spread\n0,1,0.1\n",
                "3 fields",
            ),
            (
                "position,mode,frequency_spread,damping_spread\n0,0,0.1,0\n",
                "mode ≥ 1",
            ),
            ("pos,mode\n", "header"),
        ] {
            std::fs::write(dir.path().join(SPREAD_FILE), body).unwrap();
            let e = read_mode_spread(dir.path(), "reference")
                .unwrap_err()
                .to_string();
            assert!(e.contains(needle) && e.contains("reference"), "{e}");
        }
    }
}
