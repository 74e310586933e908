//! The artifact formats stages exchange, read and written in one place so
//! every kind agrees on them:
//!
//! - `frf`: a UFF 58b file (see [`crate::io::write_frf_artifact`]), one data
//!   set per position;
//! - `modes`: a directory with `modes.csv` (`position,mode,frequency_hz,
//!   damping_ratio`) and `mode_shapes.csv` (`position,mode,node,direction,
//!   real,imag`).

use super::StageError;
use crate::frf::FrfSet;
use crate::io;
use crate::modal::ModalModel;
use std::path::Path;

pub const FRF_FILE: &str = "frf.uff";
pub const MODES_DIR: &str = "modes";

fn write(path: &Path, bytes: &[u8]) -> Result<(), StageError> {
    std::fs::write(path, bytes)
        .map_err(|e| StageError::io(format!("cannot write {}", path.display()), e))
}

/// Write an `frf` artifact.
pub fn write_frf(path: &Path, sets: &[FrfSet]) -> Result<(), StageError> {
    write(path, &io::write_frf_artifact(sets))
}

/// Read the `frf` artifact bound to input `input`.
pub fn read_frf(path: &Path, input: &str) -> Result<Vec<FrfSet>, StageError> {
    let bytes = std::fs::read(path)
        .map_err(|e| StageError::io(format!("cannot read input `{input}`"), e))?;
    io::read_frf_artifact(&bytes, input).map_err(|e| StageError::InvalidInput {
        input: input.to_string(),
        message: e.to_string(),
    })
}

/// Write a `modes` artifact directory.
pub fn write_modes(dir: &Path, models: &[ModalModel]) -> Result<(), StageError> {
    std::fs::create_dir_all(dir)
        .map_err(|e| StageError::io(format!("cannot create {}", dir.display()), e))?;
    let csv = io::write_modal_csv(models).map_err(|e| StageError::Failed(e.to_string()))?;
    write(&dir.join("modes.csv"), &csv.modes)?;
    write(&dir.join("mode_shapes.csv"), &csv.mode_shapes)
}

/// Read the `modes` artifact bound to input `input`.
pub fn read_modes(dir: &Path, input: &str) -> Result<Vec<ModalModel>, StageError> {
    let read = |name: &str| {
        std::fs::read(dir.join(name)).map_err(|e| StageError::InvalidInput {
            input: input.to_string(),
            message: format!("not a modes artifact (no {name}: {e}); bind a `modes` output"),
        })
    };
    let (modes, shapes) = (read("modes.csv")?, read("mode_shapes.csv")?);
    io::read_modal_csv(&modes, "modes.csv", &shapes, "mode_shapes.csv").map_err(|e| {
        StageError::InvalidInput {
            input: input.to_string(),
            message: e.to_string(),
        }
    })
}
