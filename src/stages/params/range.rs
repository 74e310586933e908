//! Value ranges of numeric params: the interval ([`Range`]), the numbers
//! of a value it applies to ([`Numbers`]: each element of a list or
//! mapping), and the check that reports a value outside it.

use super::{Class, ParamProblem};
use std::collections::BTreeMap;
use std::fmt;

/// An allowed interval of a numeric param (each of its numbers, for lists).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Range {
    pub min: Option<f64>,
    pub min_open: bool,
    pub max: Option<f64>,
    pub max_open: bool,
}

impl Range {
    /// `min ≤ x ≤ max`.
    pub const fn closed(min: f64, max: f64) -> Range {
        Range {
            min: Some(min),
            min_open: false,
            max: Some(max),
            max_open: false,
        }
    }
    /// `min < x < max`.
    pub const fn open(min: f64, max: f64) -> Range {
        Range {
            min: Some(min),
            min_open: true,
            max: Some(max),
            max_open: true,
        }
    }
    /// `min < x ≤ max`.
    pub const fn open_closed(min: f64, max: f64) -> Range {
        Range {
            min: Some(min),
            min_open: true,
            max: Some(max),
            max_open: false,
        }
    }
    /// `min ≤ x < max`.
    pub const fn closed_open(min: f64, max: f64) -> Range {
        Range {
            min: Some(min),
            min_open: false,
            max: Some(max),
            max_open: true,
        }
    }
    /// `x ≥ min`.
    pub const fn at_least(min: f64) -> Range {
        Range {
            min: Some(min),
            min_open: false,
            max: None,
            max_open: false,
        }
    }
    /// `x > min`.
    pub const fn above(min: f64) -> Range {
        Range {
            min: Some(min),
            min_open: true,
            max: None,
            max_open: false,
        }
    }

    pub fn contains(&self, x: f64) -> bool {
        let lo = self
            .min
            .is_none_or(|m| if self.min_open { x > m } else { x >= m });
        let hi = self
            .max
            .is_none_or(|m| if self.max_open { x < m } else { x <= m });
        x.is_finite() && lo && hi
    }
}

impl fmt::Display for Range {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match (self.min, self.max) {
            (Some(a), Some(b)) => write!(
                f,
                "{}{a}, {b}{}",
                if self.min_open { '(' } else { '[' },
                if self.max_open { ')' } else { ']' }
            ),
            (Some(a), None) => write!(f, "{} {a}", if self.min_open { ">" } else { "≥" }),
            (None, Some(b)) => write!(f, "{} {b}", if self.max_open { "<" } else { "≤" }),
            (None, None) => write!(f, "any"),
        }
    }
}

/// The numbers of a value that a [`Range`] applies to.
pub trait Numbers {
    fn numbers(&self) -> Vec<f64>;
}

macro_rules! numbers_as_f64 {
    ($($t:ty),*) => {$(
        impl Numbers for $t {
            fn numbers(&self) -> Vec<f64> {
                vec![*self as f64]
            }
        }
    )*};
}
numbers_as_f64!(f64, usize, u64, u32, u8);

impl<T: Numbers> Numbers for Option<T> {
    fn numbers(&self) -> Vec<f64> {
        self.as_ref().map(Numbers::numbers).unwrap_or_default()
    }
}

impl<T: Numbers> Numbers for Vec<T> {
    fn numbers(&self) -> Vec<f64> {
        self.iter().flat_map(Numbers::numbers).collect()
    }
}

impl<A: Numbers, B: Numbers> Numbers for (A, B) {
    fn numbers(&self) -> Vec<f64> {
        let mut out = self.0.numbers();
        out.extend(self.1.numbers());
        out
    }
}

impl<T: Numbers> Numbers for indexmap::IndexMap<String, T> {
    fn numbers(&self) -> Vec<f64> {
        self.values().flat_map(Numbers::numbers).collect()
    }
}

impl<T: Numbers> Numbers for BTreeMap<String, T> {
    fn numbers(&self) -> Vec<f64> {
        self.values().flat_map(Numbers::numbers).collect()
    }
}

/// Every number of `v` within `range`, or the problem (with the kind's
/// own message and help when it gives them).
pub fn check_range(
    name: &str,
    v: &impl Numbers,
    range: Range,
    message: Option<(&str, &str)>,
    out: &mut Vec<ParamProblem>,
) {
    if let Some(bad) = v.numbers().into_iter().find(|x| !range.contains(*x)) {
        let (message, help) = match message {
            Some((m, h)) => (m.to_string(), h.to_string()),
            None => (
                format!("param `{name}` = {bad} is out of range {range}"),
                format!("give `{name}` a value in {range}"),
            ),
        };
        out.push(ParamProblem {
            path: vec![name.to_string()],
            message,
            help: Some(help),
            class: Class::Check,
        });
    }
}
