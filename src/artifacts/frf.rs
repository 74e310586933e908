//! `frf`: a UFF 58b file (`frf.uff`, see [`crate::io::write_frf_artifact`]),
//! one data set per position and channel pair. Uncalibrated FRFs (imported
//! as voltage or with `calibrated: false`) carry a mark, so a kind that
//! needs a physical scale refuses them ([`read_calibrated`]).

use super::{write_file, ArtifactError};
use crate::frf::FrfSet;
use crate::io;
use std::path::Path;

pub const FILE: &str = "frf.uff";

/// Write an `frf` artifact.
pub fn write(path: &Path, sets: &[FrfSet]) -> Result<(), ArtifactError> {
    write_file(path, io::write_frf_artifact(sets))
}

/// Write an `frf` artifact, marked uncalibrated when `calibrated` is false
/// ([`io::write_frf_artifact_scaled`]).
pub fn write_scaled(path: &Path, sets: &[FrfSet], calibrated: bool) -> Result<(), ArtifactError> {
    write_file(path, io::write_frf_artifact_scaled(sets, calibrated))
}

/// Read the `frf` artifact bound to input `input`.
pub fn read(path: &Path, input: &str) -> Result<Vec<FrfSet>, ArtifactError> {
    Ok(read_scaled(path, input)?.0)
}

/// Read the `frf` artifact bound to input `input` and whether its FRFs are
/// calibrated (`false`: imported as voltage or uncalibrated data).
pub fn read_scaled(path: &Path, input: &str) -> Result<(Vec<FrfSet>, bool), ArtifactError> {
    let bytes = std::fs::read(path)
        .map_err(|e| ArtifactError::io(format!("cannot read input `{input}`"), e))?;
    io::read_frf_artifact_scaled(&bytes, input)
        .map_err(|e| ArtifactError::invalid(input, e.to_string()))
}

/// The refusal of uncalibrated FRFs where `need` (what the stage `kind`
/// does with them) requires a physical scale.
pub fn uncalibrated_refused(kind: &str, input: &str, need: &str) -> ArtifactError {
    ArtifactError::invalid(
        input,
        format!(
            "the FRFs are uncalibrated (imported with `calibrated: false` or voltage `units`), \
             but {kind}'s {need} needs FRFs in physical units (m/N, m/s/N or m/s²/N); \
             re-import them with the sensors' units (`units: {{response: g, reference: N}}`), \
             or compare modes only (frequencies, damping, shapes and MAC need no scale)"
        ),
    )
}

/// Read an `frf` artifact that must have a physical scale: uncalibrated
/// FRFs are refused naming the stage kind and what needs the scale.
pub fn read_calibrated(
    path: &Path,
    input: &str,
    kind: &str,
    need: &str,
) -> Result<Vec<FrfSet>, ArtifactError> {
    match read_scaled(path, input)? {
        (sets, true) => Ok(sets),
        (_, false) => Err(uncalibrated_refused(kind, input, need)),
    }
}
