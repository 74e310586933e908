//! Numbers as a report shows them (style guide rule 7): significant digits,
//! scientific notation for very small and very large magnitudes, p-values,
//! and powers of ten with superscript exponents for log-axis ticks.

/// `v` to `digits` significant digits (defined below the report, in
/// [`crate::numbers`], because model files written by the core use it too).
pub use crate::numbers::sig;

/// A p-value: 2 significant digits, scientific below 10⁻³, and `< 1e-16`
/// below what a double resolves next to 1.
pub fn p_value(p: f64) -> String {
    if !p.is_finite() {
        "–".into()
    } else if p < 1e-16 {
        "< 1e-16".into()
    } else if p < 1e-3 {
        format!("{p:.1e}")
    } else {
        sig(p, 2)
    }
}

/// `10ⁿ` with a superscript exponent.
pub fn power_of_ten(n: i32) -> String {
    const SUP: [char; 10] = ['⁰', '¹', '²', '³', '⁴', '⁵', '⁶', '⁷', '⁸', '⁹'];
    let mut s = String::from("10");
    if n < 0 {
        s.push('⁻');
    }
    for c in n.unsigned_abs().to_string().chars() {
        s.push(SUP[c.to_digit(10).unwrap_or(0) as usize]);
    }
    s
}

/// A linear tick label: as many decimals as the tick step needs.
pub fn tick(v: f64, step: f64) -> String {
    if !v.is_finite() {
        return "–".into();
    }
    if v == 0.0 {
        return "0".into();
    }
    if v.abs() >= 1e5 || v.abs() < 1e-3 {
        return sig(v, 3);
    }
    let decimals = if step >= 1.0 {
        0
    } else {
        (-step.log10().floor()) as usize
    };
    format!("{v:.decimals$}")
}

/// A table cell: numbers with a fraction to 4 significant digits (p-value
/// columns with [`p_value`]), anything else as it is.
pub fn cell(text: &str, is_p_value: bool) -> String {
    match text.trim().parse::<f64>() {
        Ok(v) if is_p_value => p_value(v),
        Ok(v) if v.is_finite() && v != v.trunc() => sig(v, 4),
        Ok(v) if v.is_finite() && v.abs() >= 1e9 => sig(v, 4),
        _ => text.to_string(),
    }
}

/// `text` with every float written to more than 6 significant digits
/// (`1.5000000000000005e6`, `0.30000000000000004`) rewritten to 4
/// (`1.5e6`, `0.3`); integers, short numbers and anything that is not one
/// number (`0.1.0`) stay as they are. A net under messages built elsewhere.
pub fn tidy(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    let mut token = String::new();
    let flush = |token: &mut String, out: &mut String| {
        out.push_str(&tidy_token(token));
        token.clear();
    };
    let mut prev: Option<char> = None;
    for c in text.chars() {
        let continues = c.is_ascii_digit()
            || (!token.is_empty() && matches!(c, '.' | 'e' | 'E'))
            || (matches!(c, '-' | '+') && matches!(prev, Some('e' | 'E')) && !token.is_empty());
        if continues {
            token.push(c);
        } else {
            flush(&mut token, &mut out);
            out.push(c);
        }
        prev = Some(c);
    }
    flush(&mut token, &mut out);
    out
}

fn tidy_token(token: &str) -> String {
    // A sentence's full stop (or a stray exponent letter) is not part of it.
    let body = token.trim_end_matches(['.', 'e', 'E']);
    let tail = &token[body.len()..];
    let mantissa = body.split(['e', 'E']).next().unwrap_or_default();
    let digits = mantissa
        .chars()
        .filter(char::is_ascii_digit)
        .skip_while(|c| *c == '0')
        .count();
    let float = mantissa.contains('.') || body.contains(['e', 'E']);
    match body.parse::<f64>() {
        Ok(v) if float && digits > 6 => format!("{}{tail}", sig(v, 4)),
        _ => token.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn significant_digits_and_p_values() {
        assert_eq!(sig(2_406_012.0, 4), "2.406e6");
        assert_eq!(sig(46.505_1, 4), "46.51");
        assert_eq!(sig(0.005_684_9, 4), "0.005685");
        assert_eq!(sig(3.953e-5, 4), "3.953e-5");
        assert_eq!(sig(0.0, 4), "0");
        assert_eq!(sig(f64::NAN, 4), "–");
        assert_eq!(p_value(3.688e-27), "< 1e-16");
        assert_eq!(p_value(4.1e-13), "4.1e-13");
        assert_eq!(p_value(0.000_91), "9.1e-4");
        assert_eq!(p_value(0.5712), "0.57");
        assert_eq!(
            cell("0.0000000000000000000000000036880356654730204", true),
            "< 1e-16"
        );
        assert_eq!(cell("12.345678", false), "12.35");
        assert_eq!(cell("p0.mode1", false), "p0.mode1");
        assert_eq!(cell("42", false), "42");
    }

    #[test]
    fn ticks_and_powers() {
        assert_eq!(power_of_ten(-32), "10⁻³²");
        assert_eq!(power_of_ten(5), "10⁵");
        assert_eq!(tick(0.25, 0.05), "0.25");
        assert_eq!(tick(150.0, 50.0), "150");
        assert_eq!(tick(-180.0, 90.0), "-180");
        assert_eq!(tick(2.0e6, 5e5), "2e6");
    }

    #[test]
    fn tidy_rewrites_long_floats_only() {
        assert_eq!(
            tidy("k1.k_x = 1.5000000000000005e6 at its bound."),
            "k1.k_x = 1.5e6 at its bound."
        );
        assert_eq!(
            tidy("ratio 0.30000000000000004, 20000 evaluations"),
            "ratio 0.3, 20000 evaluations"
        );
        assert_eq!(
            tidy("v0.1.0, mode 3 at 45.12 Hz"),
            "v0.1.0, mode 3 at 45.12 Hz"
        );
        assert_eq!(tidy("x = 123.45678901."), "x = 123.5.");
    }
}
