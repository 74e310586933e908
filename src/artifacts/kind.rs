//! [`Artifact`]: what a stage's input takes and its output holds, the one
//! list of artifact kinds (each has its schema module beside this one).

/// What an artifact holds, so validation can tell an `frf` input bound to
/// a `modes` output before anything runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Artifact {
    /// UFF 58b file, one data set per position.
    Frf,
    /// Directory with modes.csv and mode_shapes.csv.
    Modes,
    /// model.json of a synthesize stage.
    Model,
    /// parameters.csv (`parameter,value,...`): a truth or an identification.
    Parameters,
    /// evaluate metrics.json.
    Metrics,
    /// identify cost.json.
    Cost,
    /// gsa subproblems.json.
    Subproblems,
    /// gsa significant.csv.
    Significant,
    /// identify identifiability.json.
    Identifiability,
    /// identify correlation.csv.
    Correlation,
    /// a convergence history.csv.
    History,
    /// gsa validation.json.
    Validation,
    /// a CSV table (any columns).
    Table,
    /// a directory of CSV tables.
    Tables,
    /// an SVG figure or a directory of them.
    Figure,
    /// any other JSON file.
    Json,
    /// files of unknown content (a command's outs, an export, a report).
    Any,
}

impl Artifact {
    pub fn as_str(&self) -> &'static str {
        match self {
            Artifact::Frf => "frf",
            Artifact::Modes => "modes",
            Artifact::Model => "model",
            Artifact::Parameters => "parameters",
            Artifact::Metrics => "metrics",
            Artifact::Cost => "cost",
            Artifact::Subproblems => "subproblems",
            Artifact::Significant => "significant",
            Artifact::Identifiability => "identifiability",
            Artifact::Correlation => "correlation",
            Artifact::History => "history",
            Artifact::Validation => "validation",
            Artifact::Table => "table",
            Artifact::Tables => "tables",
            Artifact::Figure => "figure",
            Artifact::Json => "json",
            Artifact::Any => "any",
        }
    }

    /// Whether an input declared as `self` takes an artifact of type `of`.
    /// Unknown content (`Any`) is taken anywhere; CSV-like artifacts are
    /// tables, and every JSON artifact is JSON.
    pub fn accepts(&self, of: Artifact) -> bool {
        use Artifact::*;
        *self == Any
            || of == Any
            || *self == of
            || (*self == Table
                && matches!(of, Parameters | Significant | Correlation | History | Table))
            || (*self == Json
                && matches!(
                    of,
                    Metrics | Cost | Subproblems | Identifiability | Validation | Model
                ))
            || (*self == Figure && of == Figure)
    }
}
