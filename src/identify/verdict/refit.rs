//! Whether a refit's values can be believed (issue 26): a refit of fixed
//! parameters the score test implicated that fits materially better is
//! evidence that the screening left out what the data see only when the
//! values it needs are plausible ones.
//!
//! The screening sampled each parameter uniformly over its bounds (in ln p
//! for `scale: log`), and the consider analysis assumes the same of a
//! parameter held fixed (or the `fixed_spread` σ of ln p about its file
//! value, when given; [`super::super::consider`]). A refitted value is
//! **implausible** when it lies outside the central 95 % of that spread:
//!
//! - in the outer [`EDGE`] of its range at either end: the bound holds it,
//!   not the data (a refit that leans on a bound buys its gain with a value
//!   the model file calls barely possible);
//! - with `fixed_spread` σ, more than 1.96 σ from its file value in ln p.
//!
//! A material gain from such values does not tell the screening apart from a
//! local minimum: from a wrong basin, the refitted parameters compensate the
//! identified ones' error as readily as they correct their own (the vertical
//! mill's seed 12: `cpl.k_ry` refitted to its bound while the truth moved
//! none of the couplings, the identified `nut.k_rz` at 4.4× its truth).
//! The verdict's cause is then [`super::Cause::ScreeningOrLocalMinimum`].

use super::nan_if_null;
use crate::identify::identifiability::Z95;
use crate::numbers::sig;
use serde::{Deserialize, Serialize};

/// Share of a parameter's range at each end in which a refitted value is
/// held by the bound (outside the central 95 % of the uniform the screening
/// sampled).
pub const EDGE: f64 = 0.025;

/// Why a refitted value is not plausible.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Implausible {
    /// In the lowest [`EDGE`] of its range.
    AtLowerBound,
    /// In the highest [`EDGE`] of its range.
    AtUpperBound,
    /// Farther from its file value than 1.96 × the `fixed_spread` assumed
    /// for it while it was fixed.
    BeyondSpread,
}

/// A refitted fixed parameter at the update's result, judged for plausibility.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RefitValue {
    pub parameter: String,
    /// Its value over its file value (JSON null when the file value is 0).
    #[serde(deserialize_with = "nan_if_null")]
    pub ratio: f64,
    /// Where it ends in its range: 0 at the lower bound, 1 at the upper (in
    /// ln p for `scale: log`), the coordinate the screening sampled.
    pub position: f64,
    /// The data determine it at the result (identifiability).
    pub determined: bool,
    /// Why its value is not believed (absent: it is plausible).
    #[serde(default)]
    pub implausible: Option<Implausible>,
}

impl RefitValue {
    /// Judge a refitted value: `ratio` to its file value, `position` in its
    /// range (unit coordinate), `determined` by the data; `spread` the
    /// `fixed_spread` (σ of ln p) assumed for fixed parameters, `None` for
    /// uniform over the bounds (module docs).
    pub fn judge(
        parameter: String,
        ratio: f64,
        position: f64,
        determined: bool,
        spread: Option<f64>,
    ) -> RefitValue {
        let implausible = at_edge(position).or_else(|| {
            spread
                .is_some_and(|s| s > 0.0 && ratio.ln().abs() > Z95 * s)
                .then_some(Implausible::BeyondSpread)
        });
        RefitValue {
            parameter,
            ratio,
            position,
            determined,
            implausible,
        }
    }

    /// "cpl.k_ry 4.00× its file value, at its upper bound".
    fn describe(&self) -> String {
        let why = match self.implausible {
            Some(Implausible::AtLowerBound) => ", at its lower bound",
            Some(Implausible::AtUpperBound) => ", at its upper bound",
            Some(Implausible::BeyondSpread) => ", beyond the `fixed_spread` assumed for it",
            None if self.determined => "",
            None => ", not determined by the data",
        };
        format!(
            "{} {}× its file value{why}",
            self.parameter,
            sig(self.ratio, 3)
        )
    }
}

/// Which bound holds a value at `position` in its range (0 at the lower
/// bound, 1 at the upper, the screening's unit coordinate): within [`EDGE`]
/// of either end, else `None`. The one test of "held by its bound", for
/// refitted values and the score test's suggested changes alike.
pub fn at_edge(position: f64) -> Option<Implausible> {
    if position <= EDGE {
        Some(Implausible::AtLowerBound)
    } else if position >= 1.0 - EDGE {
        Some(Implausible::AtUpperBound)
    } else {
        None
    }
}

/// True when any of `values` is implausible.
pub fn any_implausible(values: &[RefitValue]) -> bool {
    values.iter().any(|v| v.implausible.is_some())
}

/// The warning for refitted values that are not believed (empty when all are
/// plausible).
pub(super) fn warning(values: &[RefitValue]) -> Option<String> {
    if !any_implausible(values) {
        return None;
    }
    Some(format!(
        "the refit's values are not identified truths: {} — a value held by its bound (or beyond the spread assumed for it) says what the refit needed, not what the structure has, and the refitted values' intervals in parameters.csv hold only in that basin",
        values
            .iter()
            .map(RefitValue::describe)
            .collect::<Vec<_>>()
            .join("; ")
    ))
}

/// The cause line of [`super::Cause::ScreeningOrLocalMinimum`] after a
/// refit: why its gain does not confirm the screening — the implausible
/// values it needs, else `off_minimum` (the verdict's words for a fit that
/// is no minimum); `budget`: the refit stopped at the budget.
pub(super) fn cause_line(values: &[RefitValue], budget: bool, off_minimum: &str) -> String {
    let names: Vec<&str> = values.iter().map(|v| v.parameter.as_str()).collect();
    let doubted: Vec<String> = values
        .iter()
        .filter(|v| v.implausible.is_some())
        .map(RefitValue::describe)
        .collect();
    let why = if doubted.is_empty() {
        format!("at a fit that {off_minimum}: its gain")
    } else {
        format!(
            "needs {}: a value the bound or the assumed spread holds, not the data, so the gain",
            doubted.join("; ")
        )
    };
    format!(
        "cause: the screening or a local minimum, not told apart — the refit of {} (held fixed by the screening) fitted materially better, but {why} may be the refitted parameters compensating a wrong basin of the identified ones as well as what the screening left out; the outputs hold the refit's result (it fits better), but its refitted values and their intervals are not identified truths{} — search from other starts (`restarts`, a larger budget) or check these parameters' file values{}",
        names.join(", "),
        if budget {
            " (the refit also stopped at the budget)"
        } else {
            ""
        },
        if doubted.is_empty() { "" } else { " and bounds" }
    )
}
