//! Typed stage params, parsed once.
//!
//! Each kind declares its params with [`params!`](crate::params): one line
//! per param gives its name, Rust type, default, range and doc, and the
//! macro makes of it the typed struct, the parser and the description that
//! `modalflow kinds` and the README print. Nothing else defines a param.
//!
//! Parsing ([`ParamSet::parse`]) deserializes every key on its own with
//! serde (nested settings are serde structs with `deny_unknown_fields`, and
//! serde's path inside a value is kept), so one run finds every unknown key,
//! wrong type, missing param and value out of range of a stage
//! ([`ParamProblem`]s located by their path below `params`); the engine then
//! locates them in the file. A whole-struct `#[derive(Deserialize)]` with
//! `deny_unknown_fields` would stop at the first problem, which is why the
//! top level is per key. The kind's own cross-field checks
//! ([`super::Kind::check`]) run on the typed value.

pub mod limits;
pub mod model_facts;
pub mod model_files;
mod range;

pub use range::{check_range, Numbers, Range};
use serde_yaml_ng::{Mapping, Value};
use std::collections::BTreeMap;

/// What is wrong with a param; the engine words the message around it
/// (with the stage and kind names, which a kind does not know).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Class {
    /// A key the kind does not take (`path` is the key).
    Unknown,
    /// A required param that is not given (`path` is the param).
    Missing,
    /// A value that does not deserialize into the param's type.
    Invalid,
    /// A value out of range, or a check across params (the default).
    #[default]
    Check,
}

/// A param problem, located by its path below `params` (e.g.
/// `["frequency", "step"]`).
#[derive(Debug, Clone, PartialEq)]
pub struct ParamProblem {
    pub path: Vec<String>,
    pub message: String,
    pub help: Option<String>,
    pub class: Class,
}

impl ParamProblem {
    /// A problem at `path` with a hint on how to fix it.
    pub fn new(path: &[&str], message: impl Into<String>, help: impl Into<String>) -> Self {
        ParamProblem {
            path: path.iter().map(|s| s.to_string()).collect(),
            message: message.into(),
            help: Some(help.into()).filter(|h: &String| !h.is_empty()),
            class: Class::Check,
        }
    }

    /// The same problem one level deeper, below param `field` (for the
    /// checks of a nested settings mapping).
    pub fn under(mut self, field: &str) -> Self {
        self.path.insert(0, field.to_string());
        self
    }
}

/// How a param's type reads in `modalflow kinds` and the README.
pub trait TypeName {
    fn type_name() -> String;
}

macro_rules! type_names {
    ($($t:ty => $name:expr),* $(,)?) => {$(
        impl TypeName for $t {
            fn type_name() -> String {
                $name.into()
            }
        }
    )*};
}
type_names!(
    bool => "boolean",
    usize => "integer",
    u64 => "integer",
    u32 => "integer",
    u8 => "integer",
    f64 => "number",
    String => "string",
    Value => "any value",
);

impl<T: TypeName> TypeName for Option<T> {
    fn type_name() -> String {
        T::type_name()
    }
}

impl<T: TypeName> TypeName for Vec<T> {
    fn type_name() -> String {
        format!("list of {}", T::type_name())
    }
}

impl<A: TypeName, B: TypeName> TypeName for (A, B) {
    fn type_name() -> String {
        format!("[{}, {}]", A::type_name(), B::type_name())
    }
}

impl<T: TypeName> TypeName for indexmap::IndexMap<String, T> {
    fn type_name() -> String {
        format!("mapping of name → {}", T::type_name())
    }
}

impl<T: TypeName> TypeName for BTreeMap<String, T> {
    fn type_name() -> String {
        format!("mapping of name → {}", T::type_name())
    }
}

/// The description of one param, made by [`params!`](crate::params).
#[derive(Clone, Debug, serde::Serialize)]
pub struct Field {
    pub name: &'static str,
    #[serde(rename = "type")]
    pub ty: String,
    pub required: bool,
    /// The default as YAML-ish text (`40`, `uniform`); `None` when the
    /// param is required or absent means "not given".
    #[serde(skip_serializing_if = "Option::is_none")]
    pub default: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub range: Option<String>,
    pub doc: String,
}

/// A kind's typed params: parsed from the YAML mapping with every problem
/// reported, and described field by field.
pub trait ParamSet: Sized {
    fn parse(params: &Mapping) -> Result<Self, Vec<ParamProblem>>;
    fn fields() -> Vec<Field>;
}

/// A default value as text for the listing (`None` for an absent option).
pub fn default_text<T: serde::Serialize>(v: &T) -> Option<String> {
    match serde_json::to_value(v).ok()? {
        serde_json::Value::Null => None,
        serde_json::Value::String(s) => Some(s),
        other => Some(other.to_string()),
    }
}

/// The text of a mapping key.
pub fn key_text(k: &Value) -> String {
    match k {
        Value::String(s) => s.clone(),
        Value::Number(n) => n.to_string(),
        Value::Bool(b) => b.to_string(),
        _ => "<complex key>".into(),
    }
}

/// One param's value deserialized as `T`, or the problem with it, located
/// by serde's path inside the value (e.g. `impact_test.averages`).
pub fn value<T: serde::de::DeserializeOwned + TypeName>(
    name: &str,
    v: &Value,
) -> Result<T, ParamProblem> {
    serde_path_to_error::deserialize(v.clone()).map_err(|e| {
        let mut path = vec![name.to_string()];
        path.extend(e.path().iter().filter_map(|seg| match seg {
            serde_path_to_error::Segment::Seq { index } => Some(index.to_string()),
            serde_path_to_error::Segment::Map { key } => Some(key.clone()),
            serde_path_to_error::Segment::Enum { variant } => Some(variant.clone()),
            serde_path_to_error::Segment::Unknown => None,
        }));
        let text = e.inner().to_string();
        // serde names a nested unknown field; point at it.
        if let Some(field) = text
            .strip_prefix("unknown field `")
            .and_then(|r| r.split('`').next())
        {
            if path.last().map(String::as_str) != Some(field) {
                path.push(field.to_string());
            }
        }
        // A wrong type or name of the whole param: say what it must be.
        let found = text
            .strip_prefix("invalid type: ")
            .or_else(|| text.strip_prefix("unknown variant "))
            .filter(|_| path.len() == 1)
            .map(|f| f.split(", expected").next().unwrap_or(f));
        let message = match found {
            Some(found) => format!("must be {} (found {found})", with_article(&T::type_name())),
            None => format!("is invalid: {text}"),
        };
        ParamProblem {
            path,
            message,
            help: Some(format!("`{name}` is {}", with_article(&T::type_name()))),
            class: Class::Invalid,
        }
    })
}

/// `string` → `a string`, `integer` → `an integer`; descriptions that read
/// as a phrase already (`one of: …`, `[a, b]`, `` `truth` | … ``) stay.
fn with_article(t: &str) -> String {
    match t.chars().next() {
        Some(c) if !c.is_ascii_alphabetic() || t.starts_with("one of") => t.to_string(),
        Some('a' | 'e' | 'i' | 'o' | 'u') => format!("an {t}"),
        _ => format!("a {t}"),
    }
}

/// A key the kind does not take.
pub fn unknown(key: &str, kind_fields: &[&str]) -> ParamProblem {
    let mut help = format!("accepts: {}", kind_fields.join(", "));
    if let Some(c) = closest(key, kind_fields.iter().copied()) {
        help = format!("did you mean `{c}`? {help}");
    }
    ParamProblem {
        path: vec![key.to_string()],
        message: format!("unknown param `{key}`"),
        help: Some(help),
        class: Class::Unknown,
    }
}

/// A required param that is not given.
pub fn missing(name: &str, doc: &str) -> ParamProblem {
    ParamProblem {
        path: vec![name.to_string()],
        message: format!("missing param `{name}`"),
        help: Some(format!("`{name}`: {doc}")),
        class: Class::Missing,
    }
}

/// Declare a kind's params: the struct, its parser and its description.
///
/// ```ignore
/// params! {
///     /// The `autoema` kind's params.
///     pub struct Params {
///         /// Bayesian-optimization evaluations per position
///         pub iterations: usize = 40; range Range::closed(1.0, 10_000.0),
///         /// the model file
///         pub model: String,
///     }
/// }
/// ```
/// A param without `= default` is required; one with a `range` is checked
/// against it (every number in it, for lists and mappings), optionally with
/// its own message: `; range R => "message", "help"`; one with `; check f`
/// is checked by `f(&value) -> Vec<ParamProblem>` (paths below the param).
/// All of these run for every param, whatever is wrong with the others, so
/// one parse finds every problem; checks across params ([`super::Kind::check`])
/// run once every param is good.
#[macro_export]
macro_rules! params {
    (
        $(#[$smeta:meta])*
        $vis:vis struct $name:ident {
            $(
                $(#[doc = $doc:literal])+
                $fvis:vis $field:ident : $ty:ty $(= $default:expr)?
                    $(; range $range:expr $(=> $msg:literal, $help:literal)?)?
                    $(; check $check:path)? ,
            )*
        }
    ) => {
        $(#[$smeta])*
        #[derive(Debug)]
        $vis struct $name {
            $( $(#[doc = $doc])+ $fvis $field: $ty, )*
            /// The params written in the file (the rest took their defaults).
            given: Vec<&'static str>,
        }

        impl $name {
            /// Whether param `name` was written in the file.
            #[allow(dead_code)]
            pub fn given(&self, name: &str) -> bool {
                self.given.contains(&name)
            }
        }

        impl $crate::stages::params::ParamSet for $name {
            fn parse(
                map: &serde_yaml_ng::Mapping,
            ) -> Result<Self, Vec<$crate::stages::params::ParamProblem>> {
                use $crate::stages::params as p;
                const NAMES: &[&str] = &[$(stringify!($field)),*];
                let mut problems = Vec::new();
                $( let mut $field: Option<$ty> = None; )*
                for (k, v) in map {
                    let key = p::key_text(k);
                    match key.as_str() {
                        $(
                            stringify!($field) => match p::value::<$ty>(stringify!($field), v) {
                                Ok(x) => $field = Some(x),
                                Err(e) => problems.push(e),
                            },
                        )*
                        _ => problems.push(p::unknown(&key, NAMES)),
                    }
                }
                $(
                    let given = map.contains_key(stringify!($field));
                    let $field: Option<$ty> = $field.or_else(|| $crate::params!(@default $($default)?));
                    if $field.is_none() && !given {
                        problems.push(p::missing(
                            stringify!($field),
                            concat!($($doc),+).trim(),
                        ));
                    }
                    $( if let Some(x) = &$field {
                        p::check_range(
                            stringify!($field),
                            x,
                            $range,
                            $crate::params!(@message $($msg, $help)?),
                            &mut problems,
                        );
                    } )?
                    $( if let Some(x) = &$field {
                        problems.extend(
                            $check(x).into_iter().map(|p| p.under(stringify!($field))),
                        );
                    } )?
                )*
                if !problems.is_empty() {
                    return Err(problems);
                }
                $( let Some($field) = $field else { return Err(problems) }; )*
                let given = NAMES
                    .iter()
                    .copied()
                    .filter(|n| map.contains_key(*n))
                    .collect();
                Ok($name { $($field,)* given })
            }

            fn fields() -> Vec<$crate::stages::params::Field> {
                use $crate::stages::params as p;
                vec![$(
                    p::Field {
                        name: stringify!($field),
                        ty: <$ty as p::TypeName>::type_name(),
                        required: $crate::params!(@required $($default)?),
                        default: $crate::params!(@default $($default)?)
                            .and_then(|d: $ty| p::default_text(&d)),
                        range: $crate::params!(@range $($range)?),
                        doc: concat!($($doc),+).trim().to_string(),
                    },
                )*]
            }
        }
    };
    (@default) => { None };
    (@default $d:expr) => { Some($d) };
    (@required) => { true };
    (@required $d:expr) => { false };
    (@message) => { None };
    (@message $m:literal, $h:literal) => { Some(($m, $h)) };
    (@range) => { None };
    (@range $r:expr) => { Some(($r).to_string()) };
}

/// A string enum param: the Rust enum, its serde names and its type name.
#[macro_export]
macro_rules! string_enum {
    (
        $(#[$meta:meta])*
        $vis:vis enum $name:ident { $( $(#[doc = $doc:literal])* $variant:ident = $text:literal ),+ $(,)? }
    ) => {
        $(#[$meta])*
        #[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
        $vis enum $name {
            $( $(#[doc = $doc])* #[serde(rename = $text)] $variant ),+
        }

        impl $name {
            /// The name as written in pipeline files.
            pub fn as_str(&self) -> &'static str {
                match self { $( $name::$variant => $text ),+ }
            }
        }

        impl $crate::stages::params::TypeName for $name {
            fn type_name() -> String {
                format!("one of: {}", [$($text),+].join(", "))
            }
        }
    };
}

impl TypeName for crate::parameter::Scale {
    fn type_name() -> String {
        let names: Vec<&str> = Self::ALL.iter().map(|s| s.as_str()).collect();
        format!("one of: {}", names.join(", "))
    }
}

/// Closest candidate to `word` by edit distance, for "did you mean" hints.
pub fn closest<'a>(word: &str, candidates: impl IntoIterator<Item = &'a str>) -> Option<&'a str> {
    candidates
        .into_iter()
        .map(|c| (levenshtein(word, c), c))
        .filter(|(d, c)| *d <= 2.max(c.len() / 3))
        .min_by_key(|(d, _)| *d)
        .map(|(_, c)| c)
}

fn levenshtein(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut prev: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut cur = vec![i + 1; b.len() + 1];
        for (j, cb) in b.iter().enumerate() {
            let sub = prev[j] + usize::from(ca != *cb);
            cur[j + 1] = sub.min(prev[j + 1] + 1).min(cur[j] + 1);
        }
        prev = cur;
    }
    prev[b.len()]
}

#[cfg(test)]
mod tests {
    use super::*;

    crate::string_enum! {
        enum Mode { Fast = "fast", Slow = "slow" }
    }

    crate::params! {
        /// A test kind's params.
        struct TestParams {
            /// the model file
            model: String,
            /// iterations per position
            iterations: usize = 40; range Range::closed(1.0, 100.0),
            /// how fast
            mode: Mode = Mode::Fast,
            /// an optional level
            level: Option<f64> = None; range Range::above(0.0),
        }
    }

    fn map(yaml: &str) -> Mapping {
        serde_yaml_ng::from_str(yaml).unwrap()
    }

    #[test]
    fn parses_defaults_and_given_values() {
        let p = TestParams::parse(&map("{model: m.yaml, mode: slow}")).unwrap();
        assert_eq!((p.model.as_str(), p.iterations), ("m.yaml", 40));
        assert_eq!((p.mode, p.level), (Mode::Slow, None));
        let p = TestParams::parse(&map("{model: m.yaml, level: 0.5, iterations: 3}")).unwrap();
        assert_eq!((p.iterations, p.level), (3, Some(0.5)));
    }

    #[test]
    fn reports_every_problem_at_once() {
        let problems =
            TestParams::parse(&map("{iterations: 0, mode: medium, levle: 1, level: -1}"))
                .unwrap_err();
        let messages: Vec<&str> = problems.iter().map(|p| p.message.as_str()).collect();
        assert_eq!(problems.len(), 5, "{messages:?}");
        assert!(messages.iter().any(|m| m.contains("unknown param `levle`")));
        assert!(problems.iter().any(|p| p
            .help
            .as_deref()
            .unwrap_or("")
            .contains("did you mean `level`")));
        assert!(messages.iter().any(|m| m.contains("missing param `model`")));
        assert!(messages.iter().any(|m| m.contains("`iterations` = 0")));
        assert!(problems
            .iter()
            .any(|p| p.path == ["mode"] && p.class == Class::Invalid));
        assert!(messages.iter().any(|m| m.contains("`level` = -1")));
    }

    #[test]
    fn fields_describe_types_defaults_and_ranges() {
        let f = TestParams::fields();
        let names: Vec<&str> = f.iter().map(|x| x.name).collect();
        assert_eq!(names, ["model", "iterations", "mode", "level"]);
        assert!(f[0].required && f[0].default.is_none());
        assert_eq!(f[1].default.as_deref(), Some("40"));
        assert_eq!(f[1].range.as_deref(), Some("[1, 100]"));
        assert_eq!(f[2].ty, "one of: fast, slow");
        assert_eq!(Mode::Slow.as_str(), "slow");
        assert_eq!(f[2].default.as_deref(), Some("fast"));
        assert_eq!(f[3].range.as_deref(), Some("> 0"));
        assert!(!f[3].required && f[3].default.is_none());
    }

    #[test]
    fn ranges_print_and_contain() {
        assert!(Range::open(0.0, 0.5).contains(0.1));
        assert!(!Range::open(0.0, 0.5).contains(0.0));
        assert!(!Range::at_least(1.0).contains(f64::NAN));
        assert_eq!(Range::open_closed(0.0, 1.0).to_string(), "(0, 1]");
    }
}
