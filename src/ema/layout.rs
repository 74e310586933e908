//! Which FRF matrix the estimator fits: references and responses as
//! measured, or transposed by reciprocity, and what to do with a partial
//! matrix.
//!
//! **Reciprocity.** For a linear, time-invariant structure with symmetric
//! mass, damping and stiffness, H_ij(ω) = H_ji(ω) (Maxwell–Betti; Ewins
//! 2000, "Modal Testing", section 2.3; Heylen et al. 1997, section 3.4):
//! exciting at j and measuring at i gives the FRF of exciting at i and
//! measuring at j. A roving-hammer test (the hammer moved over N points,
//! one to three accelerometers fixed) is therefore the transposed matrix of
//! a roving-accelerometer test with N outputs. PolyMAX (Peeters et al.
//! 2004) fits a right matrix-fraction model H = N D⁻¹ whose denominator is
//! n_ref × n_ref: its poles and participation vectors come from an
//! (n · n_ref)-square companion matrix, so N references cost O((n N)³) per
//! order and each order yields n · N poles, most of them spurious. Fitted
//! as N outputs × few references the same numbers give the same poles and
//! the same shapes (the residues φ_i φ_j are symmetric), at the cost of a
//! roving-accelerometer test, and the shapes are at the reference DOFs.
//!
//! [`Reciprocity::Auto`] transposes when references outnumber responses,
//! [`Reciprocity::Always`] transposes, [`Reciprocity::Never`] fits as
//! measured.
//!
//! **Partial matrices** (some response × reference channels missing):
//! 1. unless `never`, a missing H(r, q) is taken from the measured H(q, r)
//!    by reciprocity (same node and direction code on both sides);
//! 2. the largest complete sub-matrix is kept: the subset of references
//!    (or responses, whichever side is smaller) and the DOFs of the other
//!    side measured for all of them with the most channels; ties keep more
//!    DOFs, then the earlier ones (every subset when the smaller side has
//!    at most [`EXHAUSTIVE`] DOFs, else the DOF missing most channels is
//!    dropped one at a time);
//! 3. when that keeps less than half of the measured channels the data are
//!    refused with the missing channels named, since a fit to a small
//!    remnant would hide the test's intent.
//!
//! The layout ([`Layout`]) states what was done, for the outputs.

use super::{EmaError, FrfData, Weighting};
use crate::frf::{Dof, FrfChannel, FrfSet};
use std::collections::HashMap;

/// Smaller side up to which every subset is tried for the complete sub-matrix.
pub const EXHAUSTIVE: usize = 16;

/// Whether to fit the transposed FRF matrix (module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Reciprocity {
    /// Transpose when references outnumber responses.
    #[default]
    Auto,
    /// Always transpose.
    Always,
    /// Fit as measured.
    Never,
}

/// What was fitted, and how it relates to the measured channels.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Layout {
    /// Distinct references and responses of the set.
    pub measured_references: usize,
    pub measured_responses: usize,
    /// Channels in the set.
    pub measured_channels: usize,
    /// Whether outputs are the measured references (fitted by reciprocity).
    pub transposed: bool,
    /// Outputs × references of the fitted matrix.
    pub fitted_outputs: usize,
    pub fitted_references: usize,
    /// Channels "response/reference" taken from their reciprocal.
    pub filled_by_reciprocity: Vec<String>,
    /// Channels of the full matrix measured neither way.
    pub missing: Vec<String>,
    /// DOFs left out to keep a complete matrix.
    pub dropped_responses: Vec<String>,
    pub dropped_references: Vec<String>,
    /// One sentence: the layout as fitted.
    pub description: String,
}

impl Layout {
    /// Sentences for the warnings: channels filled or dropped.
    pub fn warnings(&self) -> Vec<String> {
        let mut out = Vec::new();
        if !self.filled_by_reciprocity.is_empty() {
            out.push(format!(
                "{} missing channels taken from their reciprocal (H_ij = H_ji): {}",
                self.filled_by_reciprocity.len(),
                list(&self.filled_by_reciprocity)
            ));
        }
        if !self.missing.is_empty() {
            out.push(format!(
                "{} channels of the {} × {} matrix are not measured ({}); the largest complete sub-matrix was fitted, leaving out responses [{}] and references [{}]",
                self.missing.len(),
                self.measured_responses,
                self.measured_references,
                list(&self.missing),
                self.dropped_responses.join(", "),
                self.dropped_references.join(", ")
            ));
        }
        out
    }
}

/// The positions' common description, else each one's prefixed with its
/// position index.
pub fn describe(positions: &[(u32, &Layout)]) -> String {
    match positions.first() {
        Some((_, first))
            if positions
                .iter()
                .all(|(_, l)| l.description == first.description) =>
        {
            first.description.clone()
        }
        _ => positions
            .iter()
            .map(|(p, l)| format!("position {p}: {}", l.description))
            .collect::<Vec<_>>()
            .join("; "),
    }
}

/// `layout.json` of a modes artifact: per position how the shapes' DOFs
/// relate to the test (the measured responses, or the references when
/// transposed).
pub fn to_json(positions: &[(u32, &Layout)]) -> serde_json::Value {
    let each: Vec<serde_json::Value> = positions
        .iter()
        .map(|(p, l)| {
            serde_json::json!({
                "position": p,
                "layout": l.description,
                "transposed": l.transposed,
                "shape_dofs": if l.transposed { "measured references" } else { "measured responses" },
            })
        })
        .collect();
    serde_json::json!({ "layout": describe(positions), "positions": each })
}

/// At most eight items, then a count.
fn list(v: &[String]) -> String {
    let mut s = v.iter().take(8).cloned().collect::<Vec<_>>().join(", ");
    if v.len() > 8 {
        s.push_str(&format!(" and {} more", v.len() - 8));
    }
    s
}

fn plural(n: usize, one: &str, many: &str) -> String {
    format!("{n} {}", if n == 1 { one } else { many })
}

/// Where each channel of the full response × reference matrix comes from
/// (module docs, rule 1).
struct Sources<'s> {
    /// The measured channel of each (response, reference), itself or its
    /// reciprocal.
    source: HashMap<(Dof, Dof), &'s FrfChannel>,
    /// Channels "response/reference" taken from their reciprocal.
    filled: Vec<String>,
    /// Channels measured neither way.
    missing: Vec<String>,
}

/// Every channel of the full matrix of `responses` × `references`, from
/// itself or, unless `Never`, from its reciprocal.
fn channel_sources<'s>(
    set: &'s FrfSet,
    responses: &[Dof],
    references: &[Dof],
    reciprocity: Reciprocity,
) -> Sources<'s> {
    let measured: HashMap<(Dof, Dof), &FrfChannel> = set
        .channels
        .iter()
        .map(|c| ((c.response, c.reference), c))
        .collect();
    // Every channel of the full matrix, from itself or its reciprocal.
    let mut source: HashMap<(Dof, Dof), &FrfChannel> = HashMap::new();
    let (mut filled, mut missing) = (Vec::new(), Vec::new());
    for &r in responses {
        for &q in references {
            let own = measured.get(&(r, q)).copied();
            let recip = (reciprocity != Reciprocity::Never)
                .then(|| measured.get(&(q, r)).copied())
                .flatten();
            match (own, recip) {
                (Some(c), _) => {
                    source.insert((r, q), c);
                }
                (None, Some(c)) => {
                    filled.push(format!("{r}/{q}"));
                    source.insert((r, q), c);
                }
                (None, None) => missing.push(format!("{r}/{q}")),
            }
        }
    }
    Sources {
        source,
        filled,
        missing,
    }
}

/// The channels of the fitted matrix, output-major: H_oi, taken as the
/// measured H_io when `transposed`.
fn fitted_channels<'s>(
    source: &HashMap<(Dof, Dof), &'s FrfChannel>,
    outputs: &[Dof],
    inputs: &[Dof],
    transposed: bool,
) -> Result<Vec<&'s FrfChannel>, EmaError> {
    let mut channels = Vec::with_capacity(outputs.len() * inputs.len());
    for &o in outputs {
        for &i in inputs {
            // Transposed: output o is a measured reference, H_oi = H_io.
            let k = if transposed { (i, o) } else { (o, i) };
            let c = source.get(&k).copied().ok_or_else(|| {
                EmaError::InvalidData(format!("channel {}/{} vanished", k.0, k.1))
            })?;
            channels.push(c);
        }
    }
    Ok(channels)
}

/// The layout's sentence: measured as `references` × `responses` (the
/// kept ones), fitted as the outputs × references of `data`.
fn description(data: &FrfData, references: usize, responses: usize, transposed: bool) -> String {
    let fitted = format!(
        "{} × {}",
        plural(data.n_out(), "output", "outputs"),
        plural(data.n_ref(), "reference", "references")
    );
    let measured_as = format!(
        "{} × {}",
        plural(references, "reference", "references"),
        plural(responses, "response", "responses")
    );
    if transposed {
        format!("transposed by reciprocity ({measured_as} fitted as {fitted})")
    } else {
        format!("as measured ({measured_as} fitted as {fitted})")
    }
}

/// The labels of the DOFs of `all` not in `keep`.
fn dropped(all: &[Dof], keep: &[usize]) -> Vec<String> {
    (0..all.len())
        .filter(|k| !keep.contains(k))
        .map(|k| all[k].to_string())
        .collect()
}

/// The FRF matrix of `set` to fit under `reciprocity` (module docs), with
/// the lines inside `band_hz`.
pub fn frf_data(
    set: &FrfSet,
    band_hz: Option<(f64, f64)>,
    weighting: Weighting,
    reciprocity: Reciprocity,
) -> Result<(FrfData, Layout), EmaError> {
    let (responses, references) = (set.responses(), set.references());
    let Sources {
        source,
        filled,
        missing,
    } = channel_sources(set, &responses, &references, reciprocity);
    let has = |r: usize, q: usize| source.contains_key(&(responses[r], references[q]));
    let (keep_r, keep_q) = complete_submatrix(responses.len(), references.len(), &has);
    let kept = keep_r.len() * keep_q.len();
    if 2 * kept < set.channels.len() || kept == 0 {
        return Err(EmaError::InvalidData(format!(
            "position {}: {} of the {} × {} response × reference channels are missing ({}); the largest complete sub-matrix ({} × {}) keeps only {kept} of the {} measured channels. Measure the missing channels, or select a complete set with the import stage's `select`",
            set.position.index,
            missing.len(),
            responses.len(),
            references.len(),
            list(&missing),
            keep_r.len(),
            keep_q.len(),
            set.channels.len()
        )));
    }
    let transposed = match reciprocity {
        Reciprocity::Auto => keep_q.len() > keep_r.len(),
        Reciprocity::Always => true,
        Reciprocity::Never => false,
    };
    let (rs, qs): (Vec<Dof>, Vec<Dof>) = (
        keep_r.iter().map(|&r| responses[r]).collect(),
        keep_q.iter().map(|&q| references[q]).collect(),
    );
    let (outputs, inputs) = if transposed { (&qs, &rs) } else { (&rs, &qs) };
    let channels = fitted_channels(&source, outputs, inputs, transposed)?;
    let data = FrfData::from_channels(
        &set.frequencies_hz,
        band_hz,
        outputs.clone(),
        inputs.clone(),
        &channels,
        weighting,
    )?;
    let layout = Layout {
        measured_references: references.len(),
        measured_responses: responses.len(),
        measured_channels: set.channels.len(),
        transposed,
        fitted_outputs: data.n_out(),
        fitted_references: data.n_ref(),
        filled_by_reciprocity: filled,
        missing,
        dropped_responses: dropped(&responses, &keep_r),
        dropped_references: dropped(&references, &keep_q),
        description: description(&data, qs.len(), rs.len(), transposed),
    };
    Ok((data, layout))
}

/// Rows and columns of the largest complete sub-matrix of an
/// `n_r × n_q` matrix with entries `has(r, q)` (module docs, rule 2).
pub fn complete_submatrix(
    n_r: usize,
    n_q: usize,
    has: &dyn Fn(usize, usize) -> bool,
) -> (Vec<usize>, Vec<usize>) {
    let all_r: Vec<usize> = (0..n_r).collect();
    let all_q: Vec<usize> = (0..n_q).collect();
    if all_r.iter().all(|&r| all_q.iter().all(|&q| has(r, q))) {
        return (all_r, all_q);
    }
    // Enumerate subsets of the smaller side.
    let swap = n_q > n_r;
    let (n_small, n_big) = if swap { (n_r, n_q) } else { (n_q, n_r) };
    let at = |small: usize, big: usize| {
        if swap {
            has(small, big)
        } else {
            has(big, small)
        }
    };
    let (small, big) = if n_small <= EXHAUSTIVE {
        exhaustive(n_small, n_big, &at)
    } else {
        greedy(n_small, n_big, &at)
    };
    if swap {
        (small, big)
    } else {
        (big, small)
    }
}

/// Every non-empty subset of the small side, with the big-side DOFs
/// complete for it: the most channels, then the most DOFs, then the first.
fn exhaustive(
    n_small: usize,
    n_big: usize,
    at: &dyn Fn(usize, usize) -> bool,
) -> (Vec<usize>, Vec<usize>) {
    let mask_of: Vec<u32> = (0..n_big)
        .map(|b| {
            (0..n_small)
                .filter(|&s| at(s, b))
                .fold(0, |m, s| m | 1 << s)
        })
        .collect();
    let mut best = (0usize, 0usize, 0u32);
    for subset in 1u32..(1 << n_small) {
        let rows = mask_of.iter().filter(|&&m| m & subset == subset).count();
        let cols = subset.count_ones() as usize;
        let key = (rows * cols, rows + cols);
        if key > (best.0, best.1) {
            best = (key.0, key.1, subset);
        }
    }
    let subset = best.2;
    let small: Vec<usize> = (0..n_small).filter(|&s| subset >> s & 1 == 1).collect();
    let big: Vec<usize> = (0..n_big)
        .filter(|&b| mask_of[b] & subset == subset)
        .collect();
    (small, big)
}

/// Drop the DOF missing the most channels (the last among equals) until
/// the rest is complete.
fn greedy(
    n_small: usize,
    n_big: usize,
    at: &dyn Fn(usize, usize) -> bool,
) -> (Vec<usize>, Vec<usize>) {
    let mut small: Vec<usize> = (0..n_small).collect();
    let mut big: Vec<usize> = (0..n_big).collect();
    loop {
        let miss_s: Vec<usize> = small
            .iter()
            .map(|&s| big.iter().filter(|&&b| !at(s, b)).count())
            .collect();
        let miss_b: Vec<usize> = big
            .iter()
            .map(|&b| small.iter().filter(|&&s| !at(s, b)).count())
            .collect();
        let worst_s = (0..small.len()).max_by_key(|&k| (miss_s[k], k));
        let worst_b = (0..big.len()).max_by_key(|&k| (miss_b[k], k));
        match (worst_s, worst_b) {
            (Some(s), Some(b)) if miss_s[s] == 0 && miss_b[b] == 0 => return (small, big),
            (Some(s), Some(b)) => {
                // The larger fraction of the DOF's channels missing:
                // miss_s / |big| against miss_b / |small|.
                if miss_s[s] * small.len() >= miss_b[b] * big.len() {
                    small.remove(s);
                } else {
                    big.remove(b);
                }
            }
            _ => return (small, big),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ema::synthetic::{dof, four_mode_system, lines, modal_superposition};

    /// A roving-hammer test of the 4-mode system: hammer at every DOF,
    /// one accelerometer at DOF 2 (response and reference swapped in the
    /// receptances of a shaker at DOF 2, by symmetry).
    fn roving_hammer() -> FrfSet {
        let mut set =
            modal_superposition(&four_mode_system(), &[2], &lines(20.0, 260.0, 0.5), 0.01, 3);
        for c in &mut set.channels {
            std::mem::swap(&mut c.response, &mut c.reference);
        }
        set
    }

    #[test]
    fn a_roving_hammer_test_is_fitted_transposed_unless_never() {
        let hammer = roving_hammer();
        let (d, l) = frf_data(&hammer, None, Weighting::Uniform, Reciprocity::Auto).unwrap();
        assert!(l.transposed);
        assert_eq!((d.n_out(), d.n_ref()), (5, 1));
        assert_eq!(d.references, vec![dof(2)]);
        assert_eq!(d.responses, (0..5).map(dof).collect::<Vec<_>>());
        assert_eq!(
            l.description,
            "transposed by reciprocity (5 references × 1 response fitted as 5 outputs × 1 reference)"
        );
        // Output o is the hammer at DOF o: the measured channel 3+Z/(o+1)+Z.
        for o in 0..5 {
            let c = hammer.channel(dof(2), dof(o)).unwrap();
            assert_eq!(d.channel(o, 0), &c.values[..]);
        }
        // The shaker test it mirrors gives the same matrix.
        let mut shaker = hammer.clone();
        for c in &mut shaker.channels {
            std::mem::swap(&mut c.response, &mut c.reference);
        }
        let (s, ls) = frf_data(&shaker, None, Weighting::Uniform, Reciprocity::Auto).unwrap();
        assert!(!ls.transposed);
        assert_eq!(s, d);
        assert_eq!(
            ls.description,
            "as measured (1 reference × 5 responses fitted as 5 outputs × 1 reference)"
        );
        // never: as measured, the old matrix.
        let (n, ln) = frf_data(&hammer, None, Weighting::Uniform, Reciprocity::Never).unwrap();
        assert!(!ln.transposed);
        assert_eq!(
            n,
            FrfData::from_set(&hammer, None, Weighting::Uniform).unwrap()
        );
        assert_eq!((n.n_out(), n.n_ref()), (1, 5));
        // always: the shaker test transposed.
        let (a, la) = frf_data(&shaker, None, Weighting::Uniform, Reciprocity::Always).unwrap();
        assert!(la.transposed);
        assert_eq!((a.n_out(), a.n_ref()), (1, 5));
    }

    #[test]
    fn missing_channels_come_from_their_reciprocal_or_leave_the_largest_complete_matrix() {
        let mut set = modal_superposition(
            &four_mode_system(),
            &[0, 3],
            &lines(20.0, 260.0, 0.5),
            0.0,
            1,
        );
        // 1+Z/4+Z has its reciprocal 4+Z/1+Z; 5+Z/4+Z has none.
        set.channels.retain(|c| {
            !((c.response, c.reference) == (dof(0), dof(3))
                || (c.response, c.reference) == (dof(4), dof(3)))
        });
        let (d, l) = frf_data(&set, None, Weighting::Uniform, Reciprocity::Auto).unwrap();
        assert_eq!(l.filled_by_reciprocity, vec!["1+Z/4+Z"]);
        assert_eq!(l.missing, vec!["5+Z/4+Z"]);
        assert_eq!(l.dropped_responses, vec!["5+Z"]);
        assert!(l.dropped_references.is_empty());
        assert_eq!((d.n_out(), d.n_ref()), (4, 2));
        assert_eq!(
            d.channel(0, 1),
            &set.channel(dof(3), dof(0)).unwrap().values[..]
        );
        assert_eq!(l.warnings().len(), 2, "{:?}", l.warnings());
        // never: both missing, two responses dropped (3 × 2 beats 5 × 1).
        let (d, l) = frf_data(&set, None, Weighting::Uniform, Reciprocity::Never).unwrap();
        assert!(l.filled_by_reciprocity.is_empty());
        assert_eq!(l.dropped_responses, vec!["1+Z", "5+Z"]);
        assert_eq!((d.n_out(), d.n_ref()), (3, 2));
        // Every reference at two responses of its own: at most 2 of the
        // 6 measured channels form a complete matrix, so it is refused.
        let mut set = modal_superposition(
            &four_mode_system(),
            &[0, 2, 4],
            &lines(20.0, 260.0, 0.5),
            0.0,
            1,
        );
        let pairs = [(0, 0), (1, 0), (2, 2), (3, 2), (4, 4), (0, 4)];
        set.channels.retain(|c| {
            pairs
                .iter()
                .any(|&(r, q)| (c.response, c.reference) == (dof(r), dof(q)))
        });
        let e = frf_data(&set, None, Weighting::Uniform, Reciprocity::Never).unwrap_err();
        let msg = e.to_string();
        assert!(msg.contains("3+Z/1+Z") && msg.contains("`select`"), "{msg}");
    }

    #[test]
    fn the_largest_complete_submatrix_by_subsets_and_greedily() {
        // 6 × 3 with holes: columns {0, 1} are complete on rows 0–4 (10),
        // column 2 on rows 0–5 (6), all three on rows 0–2 (9).
        let holes = [(3, 2), (4, 2), (5, 0), (5, 1)];
        let has = |r: usize, q: usize| !holes.contains(&(r, q));
        assert_eq!(
            complete_submatrix(6, 3, &has),
            (vec![0, 1, 2, 3, 4], vec![0, 1])
        );
        // Transposed pattern: the same answer from the other side.
        let has_t = |q: usize, r: usize| !holes.contains(&(r, q));
        assert_eq!(
            complete_submatrix(3, 6, &has_t),
            (vec![0, 1], vec![0, 1, 2, 3, 4])
        );
        // Greedy on a large side: one row missing half its columns goes.
        let has = |r: usize, q: usize| !(r == 7 && q.is_multiple_of(2));
        let (cols, rows) = greedy(20, 20, &|s, b| has(b, s));
        assert_eq!(cols.len(), 20);
        assert_eq!(rows, (0..20).filter(|&r| r != 7).collect::<Vec<_>>());
    }
}
