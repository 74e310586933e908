//! Choosing the measurement channels an analysis uses: response and
//! reference DOF patterns, UFF function types and a frequency band in Hz.
//! The `import` stage applies a [`Selection`] to FRF sets
//! ([`select_frf_sets`]) or to raw datasets 58 ([`select_functions`]).
//!
//! DOF patterns: `101+X` (exactly that DOF), `101X` (either sign), `101`
//! (any direction of node 101), `*+Z` / `*Z` (any node), `*` (anything).

use crate::frf::{Dof, FrfSet};
use crate::io::dof_text::parse_dof;
use crate::io::error::IoError;
use crate::io::uff::ds58::{Abscissa, FunctionType, Ordinate, Uff58};

/// A filter on DOFs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DofPattern {
    /// `None`: any node.
    pub node: Option<u32>,
    /// `None`: any direction.
    pub direction: Option<i8>,
    /// Match the direction with either sign.
    pub either_sign: bool,
}

impl DofPattern {
    /// Parses the pattern syntax of the module docs.
    pub fn parse(s: &str) -> Result<Self, IoError> {
        let bad = || IoError::Selection {
            what: format!("DOF pattern {s:?}: write 101+X, 101X, 101, *+Z or *"),
        };
        let t = s.trim();
        let (node, rest) = match t.strip_prefix('*') {
            Some(rest) => (None, rest.to_string()),
            None => {
                let digits = t.bytes().take_while(u8::is_ascii_digit).count();
                let node: u32 = t[..digits].parse().map_err(|_| bad())?;
                (Some(node), t[digits..].to_string())
            }
        };
        if rest.is_empty() {
            return Ok(DofPattern {
                node,
                direction: None,
                either_sign: false,
            });
        }
        let signed = rest.starts_with('+') || rest.starts_with('-');
        let text = if signed {
            format!("0{rest}")
        } else {
            format!("0+{rest}")
        };
        let d = parse_dof(&text).ok_or_else(bad)?;
        Ok(DofPattern {
            node,
            direction: Some(d.direction),
            either_sign: !signed && d.direction != 0,
        })
    }

    /// Whether `node`/`direction` (raw UFF record 6 values) match.
    pub fn matches_raw(&self, node: i64, direction: i64) -> bool {
        let node_ok = self.node.is_none_or(|n| i64::from(n) == node);
        let dir_ok = match self.direction {
            None => true,
            Some(d) if self.either_sign => i64::from(d).abs() == direction.abs(),
            Some(d) => i64::from(d) == direction,
        };
        node_ok && dir_ok
    }

    pub fn matches(&self, dof: Dof) -> bool {
        self.matches_raw(i64::from(dof.node), i64::from(dof.direction))
    }
}

/// What to keep. Empty lists keep everything.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct Selection {
    pub responses: Vec<DofPattern>,
    pub references: Vec<DofPattern>,
    /// Only for [`select_functions`]; FRF sets hold FRFs only.
    pub function_types: Vec<FunctionType>,
    /// Inclusive band `[low, high]` in Hz.
    pub band_hz: Option<(f64, f64)>,
}

impl Selection {
    fn check(&self) -> Result<(), IoError> {
        if let Some((lo, hi)) = self.band_hz {
            if !(lo.is_finite() && hi.is_finite() && lo <= hi) {
                return Err(IoError::Selection {
                    what: format!("band [{lo}, {hi}] Hz: give finite limits with low ≤ high"),
                });
            }
        }
        Ok(())
    }

    fn keeps_raw(&self, rsp: (i64, i64), rf: (i64, i64)) -> bool {
        let any = |p: &[DofPattern], (n, d): (i64, i64)| {
            p.is_empty() || p.iter().any(|x| x.matches_raw(n, d))
        };
        any(&self.responses, rsp) && any(&self.references, rf)
    }

    /// Indices of `f` inside the band.
    fn band(&self, f: &[f64]) -> std::ops::Range<usize> {
        match self.band_hz {
            None => 0..f.len(),
            Some((lo, hi)) => {
                let a = f.iter().position(|&x| x >= lo).unwrap_or(f.len());
                let b = f.iter().rposition(|&x| x <= hi).map_or(0, |i| i + 1);
                a..b.max(a)
            }
        }
    }
}

fn nothing(what: &str) -> IoError {
    IoError::Selection {
        what: format!("selects no {what}; check the DOF patterns, function types and band"),
    }
}

/// Keeps the matching channels and frequency lines; drops emptied sets.
pub fn select_frf_sets(sets: &[FrfSet], selection: &Selection) -> Result<Vec<FrfSet>, IoError> {
    selection.check()?;
    let mut out = Vec::new();
    for s in sets {
        let r = selection.band(&s.frequencies_hz);
        if r.is_empty() {
            continue;
        }
        let channels: Vec<_> = s
            .channels
            .iter()
            .filter(|c| selection.keeps_raw(raw(c.response), raw(c.reference)))
            .map(|c| {
                let mut c = c.clone();
                c.values = c.values.get(r.clone()).unwrap_or(&[]).to_vec();
                c.coherence = c
                    .coherence
                    .map(|v| v.get(r.clone()).unwrap_or(&[]).to_vec());
                c
            })
            .collect();
        if channels.is_empty() {
            continue;
        }
        out.push(FrfSet {
            position: s.position.clone(),
            quantity: s.quantity,
            frequencies_hz: s.frequencies_hz[r].to_vec(),
            channels,
        });
    }
    if out.is_empty() {
        return Err(nothing("FRF"));
    }
    Ok(out)
}

fn raw(d: Dof) -> (i64, i64) {
    (i64::from(d.node), i64::from(d.direction))
}

/// Keeps the matching datasets 58, cut to the band (a cut even abscissa
/// becomes uneven so every kept abscissa value stays bit-identical).
pub fn select_functions(functions: &[Uff58], selection: &Selection) -> Result<Vec<Uff58>, IoError> {
    selection.check()?;
    let mut out = Vec::new();
    for d in functions {
        let type_ok =
            selection.function_types.is_empty() || selection.function_types.contains(&d.function);
        let dof_ok = selection.keeps_raw(
            (d.response.node, d.response.direction),
            (d.reference.node, d.reference.direction),
        );
        if !(type_ok && dof_ok) {
            continue;
        }
        if selection.band_hz.is_none() {
            out.push(d.clone());
            continue;
        }
        let x = d.abscissa_values();
        let r = selection.band(&x);
        if r.is_empty() {
            continue;
        }
        let mut c = d.clone();
        if r != (0..d.len()) {
            c.abscissa = Abscissa::Uneven(x[r.clone()].to_vec());
            c.ordinate = match &d.ordinate {
                Ordinate::Real(v) => Ordinate::Real(v.get(r).unwrap_or(&[]).to_vec()),
                Ordinate::Complex(v) => Ordinate::Complex(v.get(r).unwrap_or(&[]).to_vec()),
            };
        }
        out.push(c);
    }
    if out.is_empty() {
        return Err(nothing("dataset 58"));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frf::{FrfChannel, FrfQuantity, Position};
    use num_complex::Complex64;

    fn set() -> FrfSet {
        let f: Vec<f64> = (0..11).map(|i| i as f64 * 10.0).collect();
        let ch = |r: Dof| FrfChannel {
            response: r,
            reference: Dof::new(1, -3),
            values: f.iter().map(|&x| Complex64::new(x, -x)).collect(),
            coherence: Some(f.iter().map(|x| x / 100.0).collect()),
        };
        FrfSet {
            position: Position::default(),
            quantity: FrfQuantity::Receptance,
            channels: vec![
                ch(Dof::new(101, 1)),
                ch(Dof::new(101, -2)),
                ch(Dof::new(102, 3)),
            ],
            frequencies_hz: f,
        }
    }

    #[test]
    fn patterns_parse_and_match() {
        let p = DofPattern::parse("101X").unwrap();
        assert!(
            p.matches(Dof::new(101, -1))
                && p.matches(Dof::new(101, 1))
                && !p.matches(Dof::new(101, 2))
        );
        let p = DofPattern::parse("101-Y").unwrap();
        assert!(p.matches(Dof::new(101, -2)) && !p.matches(Dof::new(101, 2)));
        let p = DofPattern::parse("*+Z").unwrap();
        assert!(p.matches(Dof::new(7, 3)) && !p.matches(Dof::new(7, -3)));
        assert!(DofPattern::parse("*").unwrap().matches(Dof::new(1, 0)));
        assert!(DofPattern::parse("101").unwrap().matches(Dof::new(101, -6)));
        assert!(DofPattern::parse("x1").is_err() && DofPattern::parse("101+Q").is_err());
    }

    #[test]
    fn selects_channels_and_band_inclusively() {
        let sel = Selection {
            responses: vec![DofPattern::parse("101").unwrap()],
            band_hz: Some((20.0, 50.0)),
            ..Default::default()
        };
        let out = select_frf_sets(&[set()], &sel).unwrap();
        assert_eq!(out[0].frequencies_hz, vec![20.0, 30.0, 40.0, 50.0]);
        assert_eq!(out[0].channels.len(), 2);
        assert_eq!(out[0].channels[1].values[0], Complex64::new(20.0, -20.0));
        assert_eq!(out[0].channels[1].coherence.as_ref().unwrap().len(), 4);
    }

    #[test]
    fn empty_or_bad_selections_are_errors() {
        let none = Selection {
            band_hz: Some((500.0, 600.0)),
            ..Default::default()
        };
        assert!(matches!(
            select_frf_sets(&[set()], &none),
            Err(IoError::Selection { .. })
        ));
        let bad = Selection {
            band_hz: Some((50.0, 20.0)),
            ..Default::default()
        };
        assert!(select_frf_sets(&[set()], &bad).is_err());
        let refs = Selection {
            references: vec![DofPattern::parse("1+Z").unwrap()],
            ..Default::default()
        };
        assert!(select_frf_sets(&[set()], &refs).is_err());
    }

    #[test]
    fn function_selection_filters_type_and_crops_exactly() {
        let sets = [set()];
        let mut funcs = crate::io::uff::artifact::uff58_from_frf_sets(&sets);
        assert!(matches!(funcs[0].abscissa, Abscissa::Even { .. }));
        let sel = Selection {
            function_types: vec![FunctionType::Coherence],
            band_hz: Some((15.0, 35.0)),
            ..Default::default()
        };
        let out = select_functions(&funcs, &sel).unwrap();
        assert_eq!(out.len(), 3);
        assert_eq!(out[0].abscissa, Abscissa::Uneven(vec![20.0, 30.0]));
        assert_eq!(out[0].ordinate, Ordinate::Real(vec![0.2, 0.3]));
        funcs.truncate(1);
        let frf_only = Selection {
            function_types: vec![FunctionType::Coherence],
            ..Default::default()
        };
        assert!(select_functions(&funcs, &frf_only).is_err());
    }
}
