//! The identify kind's tables: parameters.csv with identifiability and
//! uncertainty, correlation.csv (every reference mode: its nominal partner,
//! why it is used or not, its partner at the result), identifiability.json
//! and history.csv.

use crate::identify::updating::Update;
use crate::identify::ModalObjective;
use crate::stages::StageError;
use std::fmt::Write as _;
use std::path::Path;

/// z of a two-sided 95 % interval.
const Z95: f64 = 1.959_963_984_540_054;

pub fn write(path: &Path, text: &str) -> Result<(), StageError> {
    std::fs::write(path, text)
        .map_err(|e| StageError::io(format!("cannot write {}", path.display()), e))
}

/// A CSV cell for an optional number.
fn cell(v: Option<f64>) -> String {
    v.filter(|v| v.is_finite())
        .map_or(String::new(), |v| format!("{v:?}"))
}

/// parameters.csv: `parameter,value,lower,upper,initial,identified,
/// identifiable,std_error,ci_low,ci_high`. `std_error` is relative (of
/// ln p); the interval is p·exp(∓1.96 σ) — both only for parameters the
/// data determine.
pub fn parameters_csv(o: &ModalObjective, u: &Update) -> String {
    let mut csv = String::from(
        "parameter,value,lower,upper,initial,identified,identifiable,std_error,ci_low,ci_high\n",
    );
    for (i, p) in o.parameters().iter().enumerate() {
        let (v, x0) = (u.x[i], u.start[i]);
        let analysis = u
            .identified
            .iter()
            .position(|&k| k == i)
            .map(|j| &u.identifiability.parameters[j]);
        let identifiable = analysis.map_or(String::new(), |a| a.identifiable.to_string());
        let se = analysis.and_then(|a| a.std_error);
        let ci = se.map(|s| (v * (-Z95 * s).exp(), v * (Z95 * s).exp()));
        let _ = writeln!(
            csv,
            "{},{v:?},{:?},{:?},{x0:?},{},{identifiable},{},{},{}",
            p.name,
            p.lower,
            p.upper,
            analysis.is_some(),
            cell(se),
            cell(ci.map(|c| c.0)),
            cell(ci.map(|c| c.1)),
        );
    }
    csv
}

/// correlation.csv: one row per reference mode.
pub fn correlation_csv(o: &ModalObjective, u: &Update) -> String {
    let mut csv = String::from(
        "position,reference_mode,reference_hz,used,reason,nominal_mode,nominal_hz,visibility,mac_start,margin_start,model_mode,model_hz,mac,margin\n",
    );
    for (p, slot) in u.correspondence.slots.iter().enumerate() {
        for r in 0..o.modes_at(p) {
            let nominal = slot.partner[r].map(|k| &slot.nominal[k]);
            let end = &u.pairs[p][r];
            let reason = o.exclusion(p, r).unwrap_or("").replace(',', ";");
            let _ = writeln!(
                csv,
                "{},{},{:?},{},{reason},{},{},{},{},{},{},{},{},{}",
                slot.position,
                r + 1,
                o.reference_frequency(p, r),
                o.exclusion(p, r).is_none(),
                nominal.map_or(String::new(), |n| format!(
                    "p{}.mode{}",
                    slot.position, n.number
                )),
                cell(nominal.map(|n| n.frequency_hz)),
                cell(nominal.map(|n| n.visibility)),
                cell(nominal.map(|n| n.mac)),
                cell(nominal.map(|n| n.margin)),
                end.matched
                    .map_or(String::new(), |m| (m.model_mode + 1).to_string()),
                cell(end.matched.map(|m| m.frequency_hz)),
                cell(end.matched.map(|m| m.mac)),
                cell(end.matched.map(|_| end.margin)),
            );
        }
    }
    csv
}

/// identifiability.json: the analysis with each undetermined combination
/// written out.
pub fn identifiability_json(u: &Update) -> String {
    let mut v = serde_json::to_value(&u.identifiability).unwrap_or_default();
    let combos: Vec<String> = u
        .identifiability
        .undetermined
        .iter()
        .map(|c| c.describe())
        .collect();
    if let Some(m) = v.as_object_mut() {
        m.insert("undetermined_text".into(), serde_json::json!(combos));
    }
    serde_json::to_string_pretty(&v).unwrap_or_default() + "\n"
}

/// history.csv: `evaluation,best_objective,mean_mac`.
pub fn history_csv(u: &Update) -> String {
    let mut csv = String::from("evaluation,best_objective,mean_mac\n");
    for h in &u.history {
        let _ = writeln!(csv, "{},{:?},{:?}", h.evaluation, h.objective, h.mean_mac);
    }
    csv
}
