//! The `import` kind: measured FRFs from the files test software writes
//! (UFF 58/58b, CSV) into the `frf` artifact that `synthesize` also
//! produces, so downstream stages accept either.
//!
//! Positions (model configurations) come from the files: with one file, one
//! position per UFF load case (as the `frf` artifact itself encodes them);
//! with several files (a glob), one position per file in sorted order,
//! labelled by the file name — the usual layout of one measurement run per
//! axis position. Measured coherences (UFF function type 6) are kept with
//! their FRFs. UFF units (the axes' labels, dataset 164) are converted to SI
//! and each conversion is listed under `units` in import.json (a file in g/N
//! becomes m/s²/N, × 9.80665); an unknown unit is an error naming the file
//! and the record. The first UFF file's node coordinates (15/2411) and
//! trace lines (82) become the `geometry` output (geometry.json, empty
//! without nodes), which `evaluate` draws mode shapes on.

use super::{
    Artifact, FileRef, InputSpec, Kind, ParamProblem, Range, StageContext, StageError, StageOutputs,
};
use crate::frf::{FrfSet, Position};
use crate::io::{self, DofPattern, FrfImportOptions, Selection};
use serde::{Deserialize, Serialize};
use std::path::Path;

pub struct Import;

crate::string_enum! {
    /// File formats `import` reads.
    pub enum Format {
        Uff = "uff",
        Csv = "csv",
    }
}

crate::string_enum! {
    /// How imported FRFs form positions.
    pub enum Positions {
        Auto = "auto",
        LoadCase = "load_case",
        File = "file",
        Single = "single",
    }
}

/// Channels to keep.
#[derive(Clone, Debug, Default, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Select {
    #[serde(default)]
    responses: Vec<String>,
    #[serde(default)]
    references: Vec<String>,
    #[serde(default)]
    function: Option<String>,
}

impl super::params::TypeName for Select {
    fn type_name() -> String {
        "mapping {responses, references, function}".into()
    }
}

crate::params! {
    /// The `import` kind's params.
    pub struct Params {
        /// measurement file or glob (`data/run*.uff`), relative to the
        /// pipeline file
        pub path: String,
        /// file format (default by extension: .csv is csv, anything else uff)
        pub format: Option<Format> = None,
        /// channels to keep: {responses: [101+X, 7Z, '*+Z'], references:
        /// [1-Z], function: frf}
        pub select: Option<Select> = None,
        /// frequency band [low, high] in Hz (inclusive)
        pub band: Option<(f64, f64)> = None; range Range::at_least(0.0),
        /// how positions are formed: per UFF load case, per file, or one;
        /// auto = per file for several files, else per load case
        pub positions: Positions = Positions::Auto,
    }
}

fn selection(p: &Params) -> Result<Selection, Vec<ParamProblem>> {
    let mut problems = Vec::new();
    let mut sel = Selection {
        band_hz: p.band,
        ..Selection::default()
    };
    if let Some((lo, hi)) = p.band {
        if lo >= hi {
            problems.push(ParamProblem::new(
                &["band"],
                format!("band [{lo}, {hi}] is empty"),
                "give [low, high] in Hz with 0 <= low < high",
            ));
        }
    }
    if let Some(s) = &p.select {
        let mut parse = |list: &[String], field: &str| -> Vec<DofPattern> {
            let mut out = Vec::new();
            for (i, t) in list.iter().enumerate() {
                match DofPattern::parse(t) {
                    Ok(d) => out.push(d),
                    Err(e) => problems.push(ParamProblem::new(
                        &["select", field, &i.to_string()],
                        e.to_string(),
                        "patterns: 101+X (exact), 101X (either sign), 101 (any direction), *+Z, *",
                    )),
                }
            }
            out
        };
        sel.responses = parse(&s.responses, "responses");
        sel.references = parse(&s.references, "references");
        if let Some(f) = &s.function {
            if !f.eq_ignore_ascii_case("frf") {
                problems.push(ParamProblem::new(
                    &["select", "function"],
                    format!("function type `{f}` cannot form an FRF artifact"),
                    "only `frf` (UFF type 4) is imported; coherences come along with their FRFs",
                ));
            }
        }
    }
    if problems.is_empty() {
        Ok(sel)
    } else {
        Err(problems)
    }
}

impl Kind for Import {
    type Params = Params;
    const NAME: &'static str = "import";

    /// 2: UFF units converted to SI, `units` and `quantity` in import.json.
    fn version(&self) -> u32 {
        2
    }

    fn summary(&self) -> &'static str {
        "read measured FRFs (UFF 58/58b or CSV) into an frf artifact"
    }

    fn inputs(&self) -> Option<&'static [InputSpec]> {
        Some(&[])
    }

    const OUTPUTS: &'static [(&'static str, Artifact)] = &[
        ("frf", Artifact::Frf),
        ("summary", Artifact::Json),
        ("geometry", Artifact::Json),
    ];

    fn files(&self, p: &Params) -> Vec<FileRef> {
        vec![FileRef {
            param: "path".into(),
            path: p.path.clone(),
            glob: true,
        }]
    }

    fn check(&self, p: &Params) -> Vec<ParamProblem> {
        selection(p).err().unwrap_or_default()
    }

    fn run(&self, params: &Params, ctx: &StageContext) -> Result<StageOutputs, StageError> {
        let sel = selection(params).map_err(|p| {
            StageError::Failed(
                p.into_iter()
                    .map(|p| p.message)
                    .collect::<Vec<_>>()
                    .join("; "),
            )
        })?;
        let files = super::expand_glob(ctx.pipeline_dir, &params.path).map_err(|message| {
            StageError::InvalidParam {
                param: "path".into(),
                message,
            }
        })?;
        let mode = params.positions;
        let per_file = mode == Positions::File || (mode == Positions::Auto && files.len() > 1);
        ctx.progress.set_length(files.len() as u64);
        let mut sets: Vec<FrfSet> = Vec::new();
        let mut warnings = Vec::new();
        let mut units = Vec::new();
        let mut geometry = crate::geometry::Geometry::default();
        for (k, (rel, path)) in files.iter().enumerate() {
            let format = params.format.unwrap_or_else(|| by_extension(path));
            let split = mode != Positions::Single;
            let mut file_sets = read_one(path, rel, format, split, &mut warnings, &mut units)?;
            if geometry.nodes.is_empty() && format == Format::Uff {
                geometry = read_geometry(path, rel)?;
            }
            if per_file {
                for s in &mut file_sets {
                    s.position = Position {
                        index: k as u32,
                        label: file_label(rel),
                    };
                }
            }
            sets.extend(file_sets);
            ctx.progress.inc(1);
        }
        let sets = merge_positions(sets)?;
        let sets = io::select_frf_sets(&sets, &sel).map_err(|e| StageError::InvalidParam {
            param: "select".into(),
            message: e.to_string(),
        })?;
        let out = ctx.scratch.join("frf.uff");
        std::fs::write(&out, io::write_frf_artifact(&sets))
            .map_err(|e| StageError::io("write frf.uff", e))?;
        let summary = serde_json::json!({
            "files": files.iter().map(|(r, _)| r).collect::<Vec<_>>(),
            "positions": sets.iter().map(|s| serde_json::json!({
                "index": s.position.index,
                "label": s.position.label,
                "channels": s.channels.len(),
                "lines": s.frequencies_hz.len(),
                "band_hz": [s.frequencies_hz.first(), s.frequencies_hz.last()],
                "coherence": s.channels.iter().any(|c| c.coherence.is_some()),
            })).collect::<Vec<_>>(),
            "quantity": sets.first().map(|s| s.quantity.name()),
            "units": units,
            "warnings": warnings,
        });
        let summary_path = ctx.scratch.join("import.json");
        let text = serde_json::to_vec_pretty(&summary).unwrap_or_default();
        std::fs::write(&summary_path, text).map_err(|e| StageError::io("write import.json", e))?;
        let geometry_path = ctx.scratch.join("geometry.json");
        let text = serde_json::to_vec_pretty(&geometry).unwrap_or_default();
        std::fs::write(&geometry_path, text)
            .map_err(|e| StageError::io("write geometry.json", e))?;
        let channels: usize = sets.iter().map(|s| s.channels.len()).sum();
        Ok(StageOutputs {
            warnings: Vec::new(),
            files: vec![
                ("frf".into(), out),
                ("summary".into(), summary_path),
                ("geometry".into(), geometry_path),
            ],
            counters: [
                ("channels".to_string(), channels as u64),
                ("positions".to_string(), sets.len() as u64),
            ]
            .into(),
        })
    }
}

fn by_extension(path: &Path) -> Format {
    match path.extension().and_then(|e| e.to_str()) {
        Some(e) if e.eq_ignore_ascii_case("csv") => Format::Csv,
        _ => Format::Uff,
    }
}

fn file_label(rel: &str) -> String {
    Path::new(rel)
        .file_stem()
        .map_or_else(|| rel.to_string(), |s| s.to_string_lossy().into_owned())
}

fn read_one(
    path: &Path,
    rel: &str,
    format: Format,
    split: bool,
    warnings: &mut Vec<String>,
    units: &mut Vec<String>,
) -> Result<Vec<FrfSet>, StageError> {
    let bytes = std::fs::read(path).map_err(|e| StageError::io(format!("cannot read {rel}"), e))?;
    let invalid = |e: io::IoError| StageError::InvalidInput {
        input: rel.to_string(),
        message: e.to_string(),
    };
    if format == Format::Csv {
        return io::read_frf_csv(&bytes, rel).map_err(invalid);
    }
    let file = io::read_uff(&bytes, rel).map_err(invalid)?;
    warnings.extend(file.warnings.iter().map(|w| format!("{rel}: {w}")));
    let imported = io::frf_sets_from_uff(
        &file,
        rel,
        &FrfImportOptions {
            split_by_load_case: split,
        },
    )
    .map_err(invalid)?;
    warnings.extend(imported.warnings.iter().map(|w| format!("{rel}: {w}")));
    units.extend(imported.notes.iter().map(|n| format!("{rel}: {n}")));
    Ok(imported.sets)
}

/// The test geometry of a universal file (nodes 15/2411, trace lines 82);
/// empty when it has none.
fn read_geometry(path: &Path, rel: &str) -> Result<crate::geometry::Geometry, StageError> {
    let bytes = std::fs::read(path).map_err(|e| StageError::io(format!("cannot read {rel}"), e))?;
    let file = io::read_uff(&bytes, rel).map_err(|e| StageError::InvalidInput {
        input: rel.to_string(),
        message: e.to_string(),
    })?;
    Ok(crate::geometry::Geometry::from_uff(&file).unwrap_or_default())
}

/// One set per position, ordered by position index. Sets of one position
/// (from several files or load cases) must share frequency axis and quantity.
fn merge_positions(mut sets: Vec<FrfSet>) -> Result<Vec<FrfSet>, StageError> {
    sets.sort_by_key(|s| s.position.index);
    let mut out: Vec<FrfSet> = Vec::new();
    for s in sets {
        match out.last_mut() {
            Some(last) if last.position.index == s.position.index => {
                if last.frequencies_hz != s.frequencies_hz || last.quantity != s.quantity {
                    return Err(StageError::Failed(format!(
                        "position {} ({}) gets FRFs with different frequency axes or quantities; import them as separate positions (`positions: file`) or restrict `band`",
                        s.position.index, s.position.label
                    )));
                }
                for c in s.channels {
                    if last.channel(c.response, c.reference).is_some() {
                        return Err(StageError::Failed(format!(
                            "position {}: channel {}/{} appears twice; select one with `select`",
                            s.position.index, c.response, c.reference
                        )));
                    }
                    last.channels.push(c);
                }
            }
            _ => out.push(s),
        }
    }
    Ok(out)
}
