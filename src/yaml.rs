//! Limits on YAML text before a parser sees it. The YAML parsers in use
//! take time quadratic in the nesting depth of flow collections before
//! they reach their recursion limit (10⁵ levels of `[` — 200 kB — cost
//! over a minute), so the depth is measured first, in one linear pass,
//! and a file nested deeper than any pipeline or model file needs is
//! refused with its line.

/// Deepest nesting of flow collections (`[`, `{`) accepted. Pipeline and
/// model files nest a handful of levels; serde's own limit is 128.
pub const MAX_FLOW_DEPTH: usize = 64;

/// Where a YAML text nests flow collections deeper than [`MAX_FLOW_DEPTH`].
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error(
    "nesting deeper than {MAX_FLOW_DEPTH} levels of `[` or `{{` at line {line}; \
     no pipeline or model file needs that (is the file generated wrongly?)"
)]
pub struct TooDeep {
    /// 1-based line of the bracket that went too deep.
    pub line: usize,
    pub column: usize,
}

/// Check the flow nesting depth of `text` in one pass. Quoted scalars and
/// comments are skipped, so brackets inside strings do not count. The
/// count is an upper bound on the parser's depth (plain scalars containing
/// brackets, which YAML allows in block context, count too), which is the
/// safe side.
pub fn check_depth(text: &str) -> Result<(), TooDeep> {
    let (mut depth, mut line, mut column) = (0usize, 1usize, 0usize);
    let mut quote: Option<char> = None;
    let mut comment = false;
    // Last character seen, and the last non-blank one of the line outside
    // quotes: a quote opens a scalar only where YAML starts one (line start,
    // after `[ { , : - ?`), as the parser decides; a quote elsewhere (`it's`,
    // `[a 'b`) is text and the brackets after it count.
    let (mut prev, mut last_sig) = ('\n', '\n');
    let mut chars = text.chars().peekable();
    while let Some(c) = chars.next() {
        column += 1;
        if c == '\n' {
            line += 1;
            column = 0;
            comment = false;
            prev = c;
            if quote.is_none() {
                last_sig = c;
            }
            continue;
        }
        if comment {
            continue;
        }
        match quote {
            Some('\'') if c == '\'' => {
                // `''` is an escaped quote inside a single-quoted scalar.
                if chars.peek() == Some(&'\'') {
                    chars.next();
                    column += 1;
                } else {
                    quote = None;
                }
            }
            Some('"') if c == '\\' => {
                chars.next();
                column += 1;
            }
            Some('"') if c == '"' => quote = None,
            Some(_) => {}
            None => match c {
                '#' if prev.is_whitespace() => comment = true,
                '\'' | '"' if matches!(last_sig, '\n' | '[' | '{' | ',' | ':' | '-' | '?') => {
                    quote = Some(c)
                }
                '[' | '{' => {
                    depth += 1;
                    if depth > MAX_FLOW_DEPTH {
                        return Err(TooDeep { line, column });
                    }
                }
                ']' | '}' => depth = depth.saturating_sub(1),
                _ => {}
            },
        }
        if !c.is_whitespace() {
            last_sig = c;
        }
        prev = c;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn deep_flow_nesting_is_refused_with_its_line() {
        let deep = format!("a: 1\nb: {}{}\n", "[".repeat(65), "]".repeat(65));
        assert_eq!(
            check_depth(&deep),
            Err(TooDeep {
                line: 2,
                column: 68
            })
        );
        let ok = format!("b: {}{}\n", "[".repeat(64), "]".repeat(64));
        assert!(check_depth(&ok).is_ok());
        // Brackets in quoted scalars and comments do not count.
        let quoted = format!(
            "a: '{}'\nb: \"{}\\\"\"\n# {}\n",
            "[".repeat(100),
            "{".repeat(100),
            "[".repeat(100)
        );
        assert!(check_depth(&quoted).is_ok());
        // A quote inside a flow plain scalar is text: the brackets after it count.
        let sneaky = format!("a: [x 'y, {}{}\n", "[".repeat(70), "]".repeat(70));
        assert!(check_depth(&sneaky).is_err());
        // Closing brackets inside a quoted scalar do not lower the count.
        let mut closes = String::from("a: ");
        for _ in 0..70 {
            closes.push_str("[ \"]\", ");
        }
        assert!(check_depth(&closes).is_err());
        // A million levels are refused at once, not parsed.
        assert!(check_depth(&"[".repeat(1_000_000)).is_err());
    }
}
