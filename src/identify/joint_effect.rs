//! The joint effect of a structural group: what the data do determine of
//! parameters the model sees only together (issue 26, identify 31).
//!
//! Two springs on one line of action (the test bench's rear guide shoes
//! laterally, the vertical mill's mounts) enter the system matrices only
//! through their sum S = Σ p_i: their split is a structural null direction
//! and gets no interval ([`super::identifiability`]), but S is determined,
//! and a researcher comparing the update with a drawing or a catalogue
//! wants it with its uncertainty.
//!
//! **When the sum is the determined quantity.** d ln S = Σ w_i d ln p_i with
//! w_i = p_i/S. S is determined exactly when w is orthogonal to every
//! structural null direction: for parallel springs the null direction in
//! ln p is (p₂, −p₁)/‖·‖, and p₁p₂ − p₂p₁ = 0. A group whose members are
//! not one kind (a stiffness beside a damper), or whose sum leans into the
//! null space by more than [`LEAN`] (springs off one line of action, a
//! lever), gets no joint value: what it determines is then not a sum.
//!
//! **Its uncertainty, by a change of coordinates.** Within each such group
//! an orthonormal basis of its members' coordinates starts with
//! ŵ = w/‖w‖, and the first coordinate is scaled by 1/‖w‖, so that it moves
//! as ln S does: its Jacobian column is J w/‖w‖². The other coordinates of
//! the group span the rest (the null direction among them), and every
//! other parameter keeps its column. [`super::identifiability::analyze`]
//! and [`super::consider::consider`] on these columns are the same
//! analysis in the new coordinates: with T the change of coordinates, the
//! covariance forms used there become T⁻¹ C T⁻ᵀ (the pseudo-inverse too,
//! since the scaled coordinate is orthogonal to the null space), and the
//! jackknife's leave-one-block-out shifts become T⁻¹ δ_b. So the first
//! coordinate's standard error is ln S's, with the data variance, the
//! batch-means sandwich on its own effective number of blocks, the fixed
//! parameters' spread and the rule for "determined" of any identified
//! parameter.

use super::consider::Consider;
use super::identifiability::{interval, null_space, Identifiability};
use crate::dynamics::ParameterKind;
use crate::numbers::sig;
use serde::{Deserialize, Serialize};

/// A sum whose unit gradient has a component of more than this norm in
/// the structural null space is not what the group determines (the null
/// directions found from finite differences are accurate to ~10⁻⁵; springs
/// a milliradian off one line of action lean by ~10⁻³).
pub(crate) const LEAN: f64 = 1e-3;

/// The determined sum of a structural group.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct JointEffect {
    /// What is determined, e.g. `me1.k_x + me2.k_x`.
    pub quantity: String,
    /// The sum at the result (the members' unit).
    pub value: f64,
    /// Relative standard error of the sum (of ln S), the fixed parameters
    /// taken as exact; none when the data do not determine it to
    /// `max_std_error`.
    pub std_error: Option<f64>,
    /// The same with the fixed parameters' spread carried in (consider
    /// covariance); the interval's.
    pub std_error_with_fixed: Option<f64>,
    /// 95 % interval S·exp(∓1.96 σ), within the sum of the bounds.
    pub ci_low: Option<f64>,
    pub ci_high: Option<f64>,
}

impl JointEffect {
    /// `me1.k_x + me2.k_x = 1.00387e8 (95 %: 1.00341e8 to 1.00432e8)`: with
    /// the digits that show the interval's half-width to two (at least 4).
    pub fn describe(&self) -> String {
        match (self.ci_low, self.ci_high) {
            (Some(l), Some(h)) => {
                let ratio = 2.0 * self.value.abs() / (h - l);
                let digits = if ratio.is_finite() && ratio > 0.0 {
                    (ratio.log10().ceil() as i64 + 2).clamp(4, 10) as usize
                } else {
                    4
                };
                format!(
                    "{} = {} (95 %: {} to {})",
                    self.quantity,
                    sig(self.value, digits),
                    sig(l, digits),
                    sig(h, digits)
                )
            }
            _ => format!(
                "{} = {}, not determined by the data",
                self.quantity,
                sig(self.value, 4)
            ),
        }
    }
}

/// One identified parameter as the sums need it.
#[derive(Clone, Debug)]
pub struct Member {
    pub name: String,
    pub value: f64,
    pub lower: f64,
    pub upper: f64,
    pub kind: ParameterKind,
}

/// One group's sum: which combination of the analysis it belongs to, its
/// members (indices into the identified parameters), the orthonormal basis
/// over them (first ŵ) and ‖w‖.
#[derive(Debug)]
struct GroupSum {
    combination: usize,
    members: Vec<usize>,
    basis: Vec<Vec<f64>>,
    norm: f64,
    value: f64,
    bounds: (f64, f64),
    quantity: String,
}

/// The coordinates in which each determined sum is one coordinate (module
/// docs); none when no structural group has one.
#[derive(Debug)]
pub struct SumCoordinates {
    groups: Vec<GroupSum>,
}

impl SumCoordinates {
    /// The sums of the structural groups of `analysis`, done on Jacobian
    /// `columns` (one per parameter of `members`, in order), where the sum
    /// is what they determine.
    pub fn of(
        analysis: &Identifiability,
        columns: &[Vec<f64>],
        members: &[Member],
    ) -> Option<SumCoordinates> {
        let null = null_space(columns);
        let groups: Vec<GroupSum> = analysis
            .undetermined
            .iter()
            .enumerate()
            .filter(|(_, c)| c.singular_value == 0.0)
            .filter_map(|(k, c)| {
                let idx: Option<Vec<usize>> = c
                    .parameters
                    .iter()
                    .map(|(name, _)| members.iter().position(|m| &m.name == name))
                    .collect();
                group_sum(k, &idx?, members, &null)
            })
            .collect();
        (!groups.is_empty()).then_some(SumCoordinates { groups })
    }

    /// `columns` in these coordinates: each group's members' columns
    /// replaced by J ŵ/‖w‖ (at the first member's place) and J b for the
    /// basis' other vectors b.
    pub fn rotate(&self, columns: &[Vec<f64>]) -> Vec<Vec<f64>> {
        let mut out = columns.to_vec();
        for g in &self.groups {
            for (j, b) in g.basis.iter().enumerate() {
                let scale = if j == 0 { 1.0 / g.norm } else { 1.0 };
                let col = &mut out[g.members[j]];
                col.iter_mut().for_each(|v| *v = 0.0);
                for (&i, &w) in g.members.iter().zip(b) {
                    col.iter_mut()
                        .zip(&columns[i])
                        .for_each(|(v, c)| *v += scale * w * c);
                }
            }
        }
        out
    }

    /// Each group's [`JointEffect`] into `analysis`, from the analysis
    /// (`rotated`) and the consider analysis (`considered`) of the rotated
    /// columns.
    pub fn attach(
        &self,
        analysis: &mut Identifiability,
        rotated: &Identifiability,
        considered: Option<&Consider>,
    ) {
        for g in &self.groups {
            let a = g.members[0];
            let se = rotated.parameters[a].std_error.filter(|s| s.is_finite());
            let with_fixed = match considered {
                Some(c) => se.and(Some(c.std_error[a]).filter(|s| s.is_finite())),
                None => se,
            };
            let ci = with_fixed.map(|s| interval(g.value, s, g.bounds));
            analysis.undetermined[g.combination].joint = Some(JointEffect {
                quantity: g.quantity.clone(),
                value: g.value,
                std_error: se,
                std_error_with_fixed: with_fixed,
                ci_low: ci.map(|c| c.0),
                ci_high: ci.map(|c| c.1),
            });
        }
    }
}

/// The sum of the parameters `idx` (combination `k`) when it is what they
/// determine: one kind, positive values, w orthogonal to the `null` space
/// within [`LEAN`].
fn group_sum(k: usize, idx: &[usize], members: &[Member], null: &[Vec<f64>]) -> Option<GroupSum> {
    let first = members.get(*idx.first()?)?;
    let one_kind = idx.iter().all(|&i| members[i].kind == first.kind);
    if idx.len() < 2 || !one_kind || idx.iter().any(|&i| members[i].value <= 0.0) {
        return None;
    }
    let value: f64 = idx.iter().map(|&i| members[i].value).sum();
    let w: Vec<f64> = idx.iter().map(|&i| members[i].value / value).collect();
    let norm = w.iter().map(|v| v * v).sum::<f64>().sqrt();
    let unit: Vec<f64> = w.iter().map(|v| v / norm).collect();
    let lean2: f64 = null
        .iter()
        .map(|n| {
            let d: f64 = idx.iter().zip(&unit).map(|(&i, u)| n[i] * u).sum();
            d * d
        })
        .sum();
    if lean2 > LEAN * LEAN {
        return None;
    }
    Some(GroupSum {
        combination: k,
        members: idx.to_vec(),
        basis: orthonormal_from(unit, idx.len()),
        norm,
        value,
        bounds: (
            idx.iter().map(|&i| members[i].lower).sum(),
            idx.iter().map(|&i| members[i].upper).sum(),
        ),
        quantity: idx
            .iter()
            .map(|&i| members[i].name.as_str())
            .collect::<Vec<_>>()
            .join(" + "),
    })
}

/// An orthonormal basis of ℝᵍ whose first vector is the unit vector
/// `first`: Gram–Schmidt over `first` and the coordinate axes, dropping
/// the axis that is (nearly) in the span of those before it.
fn orthonormal_from(first: Vec<f64>, g: usize) -> Vec<Vec<f64>> {
    let mut basis = vec![first];
    for axis in 0..g {
        if basis.len() == g {
            break;
        }
        let mut v: Vec<f64> = (0..g).map(|i| if i == axis { 1.0 } else { 0.0 }).collect();
        for _ in 0..2 {
            // Twice: classical Gram–Schmidt loses orthogonality once.
            for b in &basis {
                let c: f64 = b.iter().zip(&v).map(|(x, y)| x * y).sum();
                v.iter_mut().zip(b).for_each(|(x, y)| *x -= c * y);
            }
        }
        let n = v.iter().map(|x| x * x).sum::<f64>().sqrt();
        if n > 1e-8 {
            basis.push(v.into_iter().map(|x| x / n).collect());
        }
    }
    basis
}

#[cfg(test)]
mod tests;
