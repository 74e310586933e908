//! The `import` kind: measured FRFs from the files test software writes
//! (UFF 58/58b, CSV) into the `frf` artifact that `synthesize` also
//! produces, so downstream stages accept either.
//!
//! Positions (model configurations) come from the files: with one file, one
//! position per UFF load case (as the `frf` artifact itself encodes them);
//! with several files (a glob), one position per file in sorted order,
//! labelled by the file name — the usual layout of one measurement run per
//! axis position. Measured coherences (UFF function type 6, CSV `coh:`)
//! are kept with their FRFs; a γ² outside [0, 1] is an error unless
//! `coherence: clamp` (a little outside: clamped, one warning, listed in
//! import.json) or `coherence: ignore` (coherence dropped). UFF units (the
//! axes' labels, dataset 164) are converted to SI and each conversion is
//! listed under `units` in import.json (a file in g/N becomes m/s²/N,
//! × 9.80665); an unknown unit is an error naming the file and the record.
//! The first UFF file's node coordinates (15/2411) and trace lines (82),
//! or those of the file `geometry` names, become the `geometry` output
//! (geometry.json, empty without nodes), which `evaluate` draws mode
//! shapes on.
//!
//! Voltage or uncalibrated FRFs (`V/V`, no scale) import with `calibrated:
//! false` or `units: {response: V, reference: V}`: values as measured, the
//! `frf` artifact marked uncalibrated (see [`crate::io::UnitsOverride`]),
//! so stages that need a physical scale refuse it while frequencies,
//! damping, shapes and MAC work. FRFs read as SI for want of any unit label
//! are a stage warning. `content: modes` reads reference modes instead
//! ([`modes`]).

mod geometry_file;
mod modes;

use super::{
    Artifact, FileRef, InputSpec, Kind, ParamProblem, Range, StageContext, StageError, StageOutputs,
};
use crate::frf::{FrfSet, Position};
use crate::io::{self, CoherencePolicy, DofPattern, FrfImportOptions, Selection, UnitsOverride};
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
    /// What the files hold.
    pub enum Content {
        Frf = "frf",
        Modes = "modes",
    }
}

crate::string_enum! {
    /// What happens to coherence values outside [0, 1].
    pub enum Coherence {
        Check = "check",
        Clamp = "clamp",
        Ignore = "ignore",
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

/// Units of every FRF, instead of the file's labels.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Units {
    /// Response (numerator) unit: m, mm, µm, in, m/s, mm/s, in/s, m/s^2,
    /// mm/s^2, in/s^2, g; V or mV for uncalibrated data.
    pub response: String,
    /// Reference (denominator) unit: N, kN, lbf, kgf; V or mV.
    pub reference: String,
}

impl super::params::TypeName for Units {
    fn type_name() -> String {
        "mapping {response, reference}".into()
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
        /// false for voltage or uncalibrated FRFs (V/V, unknown scale):
        /// values kept as measured and marked uncalibrated; stages needing
        /// a physical scale (FRF amplitude against a model) refuse them
        pub calibrated: bool = true,
        /// units of every FRF instead of the file's labels, {response: g,
        /// reference: N}; V or mV on either side = uncalibrated
        pub units: Option<Units> = None,
        /// what the file holds: frf (measurements) or modes (reference
        /// modes: a modes.csv table or UFF 55 → output `modes`)
        pub content: Content = Content::Frf,
        /// with content modes and a CSV table: the mode_shapes.csv table
        /// (position,mode,node,direction,real,imag); optional
        pub shapes: Option<String> = None,
        /// UFF file with the test geometry (nodes 15/2411, trace lines 82)
        /// when the measurement files hold none (test software often
        /// exports it apart); replaces theirs; optional
        pub geometry: Option<String> = None,
        /// coherence γ² outside [0, 1]: check = an error at the value's
        /// line; clamp = values in [-0.01, 2] become 0 or 1 (one warning,
        /// listed in import.json), beyond that or NaN still an error;
        /// ignore = coherence not read (AutoEMA then estimates noise
        /// without it)
        pub coherence: Coherence = Coherence::Check,
    }
}

impl Params {
    /// How the FRFs' units are read.
    pub fn units_override(&self) -> UnitsOverride {
        match (&self.units, self.calibrated) {
            (Some(u), _) => UnitsOverride::Labels {
                response: u.response.clone(),
                reference: u.reference.clone(),
            },
            (None, false) => UnitsOverride::Uncalibrated,
            (None, true) => UnitsOverride::FromFile,
        }
    }

    /// What the readers accept as coherence.
    pub fn coherence_policy(&self) -> CoherencePolicy {
        match self.coherence {
            Coherence::Check => CoherencePolicy::Check,
            Coherence::Clamp => CoherencePolicy::Clamp,
            Coherence::Ignore => CoherencePolicy::Ignore,
        }
    }
}

/// Problems of the units and content params (beyond each one's type).
fn check_units_and_content(p: &Params) -> Vec<ParamProblem> {
    let mut problems = Vec::new();
    if let Some(u) = &p.units {
        match io::check_override_labels(&u.response, &u.reference) {
            Err(m) => problems.push(ParamProblem::new(
                &["units"],
                m,
                "give the sensors' units, e.g. {response: g, reference: N}",
            )),
            Ok(true) if !p.calibrated => problems.push(ParamProblem::new(
                &["calibrated"],
                "`calibrated: false` contradicts physical `units`",
                "drop `calibrated: false`, or give V / mV units",
            )),
            _ => {}
        }
    }
    if p.content == Content::Modes {
        let frf_only = [
            ("select", p.select.is_some()),
            ("units", p.units.is_some()),
            ("calibrated", !p.calibrated),
            ("coherence", p.coherence != Coherence::Check),
        ];
        for (name, set) in frf_only {
            if set {
                problems.push(ParamProblem::new(
                    &[name],
                    format!("`{name}` applies to FRFs, not to `content: modes`"),
                    "remove it, or import FRFs with `content: frf`",
                ));
            }
        }
    } else if p.shapes.is_some() {
        problems.push(ParamProblem::new(
            &["shapes"],
            "`shapes` belongs to reference modes",
            "set `content: modes`, or remove `shapes`",
        ));
    }
    problems
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
    const FILE_PARAMS: &'static [(&'static str, bool)] =
        &[("path", true), ("shapes", false), ("geometry", false)];

    /// 2: UFF units converted to SI, `units` and `quantity` in import.json.
    /// 3: `calibrated` in import.json, the reader's warnings as stage
    /// warnings, errors name the record's line; `content: modes`.
    fn version(&self) -> u32 {
        3
    }

    fn summary(&self) -> &'static str {
        "read measured FRFs (UFF 58/58b or CSV) into an frf artifact, or reference modes (CSV or UFF 55) into a modes artifact"
    }

    fn inputs(&self) -> Option<&'static [InputSpec]> {
        Some(&[])
    }

    const OUTPUTS: &'static [(&'static str, Artifact)] = &[
        ("frf", Artifact::Frf),
        ("modes", Artifact::Modes),
        ("summary", Artifact::Json),
        ("geometry", Artifact::Json),
    ];

    fn outputs(&self, p: &Params) -> Vec<super::Output> {
        let skip = match p.content {
            Content::Frf => "modes",
            Content::Modes => "frf",
        };
        Self::OUTPUTS
            .iter()
            .filter(|(n, _)| *n != skip)
            .map(|(n, a)| super::Output::new(*n, *a))
            .collect()
    }

    fn files(&self, p: &Params) -> Vec<FileRef> {
        let mut out = vec![FileRef {
            param: "path".into(),
            path: p.path.clone(),
            glob: true,
        }];
        for (param, path) in [("shapes", &p.shapes), ("geometry", &p.geometry)] {
            if let Some(path) = path {
                out.push(FileRef {
                    param: param.into(),
                    path: path.clone(),
                    glob: false,
                });
            }
        }
        out
    }

    fn check(&self, p: &Params) -> Vec<ParamProblem> {
        let mut problems = selection(p).err().unwrap_or_default();
        problems.extend(check_units_and_content(p));
        problems
    }

    fn run(&self, params: &Params, ctx: &StageContext) -> Result<StageOutputs, StageError> {
        if params.content == Content::Modes {
            return modes::run(params, ctx);
        }
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
        let mut calibrated = true;
        let mut geometry = crate::geometry::Geometry::default();
        let policy = params.coherence_policy();
        for (k, (rel, path)) in files.iter().enumerate() {
            let format = params.format.unwrap_or_else(|| by_extension(path));
            let options = FrfImportOptions {
                split_by_load_case: mode != Positions::Single,
                units: params.units_override(),
            };
            let mut log = Log {
                warnings: &mut warnings,
                units: &mut units,
                calibrated: &mut calibrated,
                geometry: &mut geometry,
            };
            let mut file_sets = read_one(path, rel, format, &options, policy, &mut log)?;
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
        if let Some(g) = &params.geometry {
            let (g, w) = geometry_file::read(ctx, g)?;
            geometry = g;
            warnings.extend(w);
        }
        let mut sets = merge_positions(sets)?;
        let clamped = apply_coherence(params.coherence, &mut sets);
        if let Some(c) = &clamped {
            warnings.push(c.warning());
        }
        let sets = io::select_frf_sets(&sets, &sel).map_err(|e| StageError::InvalidParam {
            param: "select".into(),
            message: e.to_string(),
        })?;
        if !calibrated {
            warnings.push(
                "FRFs imported uncalibrated (no physical scale): AutoEMA frequencies, damping, \
                 shapes and MAC work; comparisons of FRF amplitude with a model are refused"
                    .into(),
            );
        }
        let out = ctx.scratch.join("frf.uff");
        std::fs::write(&out, io::write_frf_artifact_scaled(&sets, calibrated))
            .map_err(|e| StageError::io("write frf.uff", e))?;
        let mut summary = serde_json::json!({
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
            "calibrated": calibrated,
            "units": units,
            "warnings": warnings,
        });
        // Only when asked for: a `check` import writes the import.json it
        // always wrote, so cached results of version 3 stay what a rerun gives.
        if params.coherence != Coherence::Check {
            summary["coherence"] = serde_json::json!({
                "policy": params.coherence.as_str(),
                "clamped": clamped,
            });
        }
        let summary_path = write_json(ctx, "import.json", &summary)?;
        let geometry_path = write_json(ctx, "geometry.json", &geometry)?;
        let channels: usize = sets.iter().map(|s| s.channels.len()).sum();
        Ok(StageOutputs {
            warnings,
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

/// Writes `value` as pretty JSON to `name` in the scratch directory.
pub(super) fn write_json(
    ctx: &StageContext,
    name: &str,
    value: &impl Serialize,
) -> Result<std::path::PathBuf, StageError> {
    let path = ctx.scratch.join(name);
    let text = serde_json::to_vec_pretty(value).unwrap_or_default();
    std::fs::write(&path, text).map_err(|e| StageError::io(format!("write {name}"), e))?;
    Ok(path)
}

/// The bytes of the file at `path`, an error naming it as `rel` (the
/// pipeline's spelling) when it cannot be read.
pub(super) fn read_file(path: &Path, rel: &str) -> Result<Vec<u8>, StageError> {
    std::fs::read(path).map_err(|e| StageError::io(format!("cannot read {rel}"), e))
}

pub(super) fn by_extension(path: &Path) -> Format {
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

/// `coherence: clamp | ignore` on the FRF sets as read, before `band` and
/// `select` (so the count is the files' own, as `check` refuses a value
/// anywhere in them): clamped lines summarized for one warning, or every
/// coherence dropped. The readers have already refused what clamping may
/// not excuse, at its line.
fn apply_coherence(policy: Coherence, sets: &mut [FrfSet]) -> Option<io::CoherenceClamps> {
    match policy {
        Coherence::Check => None,
        Coherence::Clamp => io::clamp_coherence(sets),
        Coherence::Ignore => {
            for c in sets.iter_mut().flat_map(|s| s.channels.iter_mut()) {
                c.coherence = None;
            }
            None
        }
    }
}

/// What reading the files tells the summary and the stage's warnings.
struct Log<'a> {
    warnings: &'a mut Vec<String>,
    units: &'a mut Vec<String>,
    /// Cleared when any file's FRFs are uncalibrated.
    calibrated: &'a mut bool,
    /// The test geometry (nodes 15/2411, trace lines 82) of the first
    /// universal file that has one, from the parse that reads its FRFs.
    geometry: &'a mut crate::geometry::Geometry,
}

fn read_one(
    path: &Path,
    rel: &str,
    format: Format,
    options: &FrfImportOptions,
    coherence: CoherencePolicy,
    log: &mut Log<'_>,
) -> Result<Vec<FrfSet>, StageError> {
    let bytes = read_file(path, rel)?;
    let invalid = |e: io::IoError| StageError::InvalidInput {
        input: rel.to_string(),
        message: e.to_string(),
    };
    if format == Format::Csv {
        match &options.units {
            UnitsOverride::FromFile => {}
            UnitsOverride::Labels {
                response,
                reference,
            } if io::check_override_labels(response, reference) == Ok(true) => {
                return Err(StageError::InvalidParam {
                    param: "units".into(),
                    message: format!(
                        "{rel}: CSV FRFs are in SI units already; physical `units` apply to \
                         UFF files only (use V / mV or `calibrated: false` for uncalibrated data)"
                    ),
                });
            }
            _ => *log.calibrated = false,
        }
        return io::read_frf_csv_with(&bytes, rel, coherence).map_err(invalid);
    }
    let file = io::read_uff_with(&bytes, rel, coherence).map_err(invalid)?;
    if log.geometry.nodes.is_empty() {
        *log.geometry = crate::geometry::Geometry::from_uff(&file).unwrap_or_default();
    }
    log.warnings
        .extend(file.warnings.iter().map(|w| format!("{rel}: {w}")));
    let imported = io::frf_sets_from_uff(&file, rel, options).map_err(invalid)?;
    log.warnings
        .extend(imported.warnings.iter().map(|w| format!("{rel}: {w}")));
    log.units
        .extend(imported.notes.iter().map(|n| format!("{rel}: {n}")));
    if imported.unlabelled > 0 {
        log.warnings.push(format!(
            "{rel}: {} FRF(s) have no units label and the file no dataset 164: read as SI {} \
             ({}); if they are not, give `units: {{response: g, reference: N}}` (the sensors' \
             units) or `calibrated: false`",
            imported.unlabelled,
            imported
                .sets
                .first()
                .map_or("m/N", |s| s.quantity.si_unit()),
            imported
                .sets
                .first()
                .map_or("receptance", |s| s.quantity.name()),
        ));
    }
    if !imported.calibrated {
        *log.calibrated = false;
    }
    Ok(imported.sets)
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
