//! Errors in a pipeline file, located and rendered with a source excerpt.
//!
//! Every validation problem becomes a [`Diagnostic`]: what is wrong, where
//! (file:line:column), the offending line with a caret, and how to fix it.
//! Validation collects all of them before anything runs, so one edit cycle
//! fixes every problem in a file.

use std::fmt;
use std::path::{Path, PathBuf};

/// A 1-based line/column position in a source file.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct Location {
    pub line: usize,
    pub column: usize,
}

/// One located problem in a pipeline file.
#[derive(Clone, Debug)]
pub struct Diagnostic {
    pub file: PathBuf,
    pub location: Option<Location>,
    pub message: String,
    pub help: Option<String>,
    /// The source line and a caret, prepared when the diagnostic is created so
    /// the diagnostic can be displayed without the source at hand.
    excerpt: Option<String>,
}

impl Diagnostic {
    pub fn new(file: &Path, source: &str, location: Option<Location>, message: String) -> Self {
        let excerpt = location.and_then(|loc| excerpt(source, loc));
        Diagnostic {
            file: file.to_path_buf(),
            location,
            message,
            help: None,
            excerpt,
        }
    }

    pub fn with_help(mut self, help: impl Into<String>) -> Self {
        self.help = Some(help.into());
        self
    }
}

fn excerpt(source: &str, loc: Location) -> Option<String> {
    let text = source.lines().nth(loc.line.checked_sub(1)?)?;
    let gutter = loc.line.to_string().len();
    let caret_pad: String = text
        .chars()
        .take(loc.column.saturating_sub(1))
        .map(|c| if c == '\t' { '\t' } else { ' ' })
        .collect();
    let token_len = text
        .chars()
        .skip(loc.column.saturating_sub(1))
        .take_while(|c| !c.is_whitespace() && !matches!(c, ',' | '}' | ']' | ':'))
        .count()
        .max(1);
    Some(format!(
        "{blank:gutter$} |\n{line:>gutter$} | {text}\n{blank:gutter$} | {caret_pad}{carets}",
        blank = "",
        line = loc.line,
        carets = "^".repeat(token_len),
    ))
}

impl fmt::Display for Diagnostic {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "{}", self.message)?;
        match self.location {
            Some(loc) => writeln!(
                f,
                "  --> {}:{}:{}",
                self.file.display(),
                loc.line,
                loc.column
            )?,
            None => writeln!(f, "  --> {}", self.file.display())?,
        }
        if let Some(ex) = &self.excerpt {
            for line in ex.lines() {
                writeln!(f, "  {line}")?;
            }
        }
        if let Some(help) = &self.help {
            writeln!(f, "  = help: {help}")?;
        }
        Ok(())
    }
}

/// All problems found in one pipeline file.
#[derive(Debug)]
pub struct Diagnostics(pub Vec<Diagnostic>);

impl fmt::Display for Diagnostics {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let n = self.0.len();
        writeln!(
            f,
            "{} problem{} in pipeline file",
            n,
            if n == 1 { "" } else { "s" }
        )?;
        for (i, d) in self.0.iter().enumerate() {
            write!(f, "\n[{}] {d}", i + 1)?;
        }
        Ok(())
    }
}

impl std::error::Error for Diagnostics {}

pub use crate::stages::params::closest;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn excerpt_points_at_column() {
        let src = "a: 1\nkind: synthesise\n";
        let d = Diagnostic::new(
            Path::new("p.yaml"),
            src,
            Some(Location { line: 2, column: 7 }),
            "unknown kind".into(),
        );
        let text = d.to_string();
        assert!(text.contains("p.yaml:2:7"), "{text}");
        assert!(text.contains("2 | kind: synthesise"), "{text}");
        assert!(text.contains("|       ^^^^^^^^^^"), "{text}");
    }

    #[test]
    fn closest_suggests_near_words_only() {
        assert_eq!(
            closest("synthesise", ["synthesize", "command"]),
            Some("synthesize")
        );
        assert_eq!(closest("zzz", ["synthesize", "command"]), None);
    }
}
