//! Physical validity of measured values, shared by every reader (UFF 58/58b,
//! CSV FRF, CSV modal): a frequency line is finite and ≥ 0 (exactly 0 is a
//! valid DC line) and each line of an axis is strictly greater than the one
//! before; a coherence γ² is a number in [0, 1]. Readers call these as they
//! read, so the error names the file and the line (or byte) of the value.
//! The functions return the problem as text; the reader adds the location.

/// One frequency line after `previous` (the line before it on the same
/// axis, if any): finite, ≥ 0 and strictly greater than `previous`.
pub fn check_frequency(f: f64, previous: Option<f64>) -> Result<(), String> {
    if !f.is_finite() {
        return Err(format!(
            "frequency {f} is not finite; replace NaN/inf values before importing"
        ));
    }
    if f < 0.0 {
        return Err(format!(
            "frequency {f} is negative; measured frequency lines are ≥ 0 (0 itself is allowed), \
             fix the export's frequency axis"
        ));
    }
    match previous {
        Some(p) if f <= p => Err(format!(
            "frequency {f} does not increase (the line before is {p}); frequency lines must be \
             strictly increasing, remove duplicates or sort the lines"
        )),
        _ => Ok(()),
    }
}

/// A whole axis: the index of the first bad line and the problem.
pub fn check_abscissa(frequencies: &[f64]) -> Result<(), (usize, String)> {
    let mut previous = None;
    for (i, &f) in frequencies.iter().enumerate() {
        check_frequency(f, previous).map_err(|m| (i, m))?;
        previous = Some(f);
    }
    Ok(())
}

/// An evenly spaced axis `start + i · step`, `i < points`: start ≥ 0, and,
/// with two points or more, step > 0 and a finite last line that the step
/// still moves.
pub fn check_even_abscissa(start: f64, step: f64, points: usize) -> Result<(), String> {
    check_frequency(start, None).map_err(|m| format!("abscissa minimum: {m}"))?;
    if points < 2 {
        return Ok(());
    }
    if !(step.is_finite() && step > 0.0) {
        return Err(format!(
            "abscissa increment {step} is not positive; frequency lines must be strictly \
             increasing, fix the export's frequency axis"
        ));
    }
    let last = start + (points - 1) as f64 * step;
    if !last.is_finite() || start + step <= start {
        return Err(format!(
            "abscissa minimum {start} and increment {step} give no increasing axis of {points} \
             lines in double precision"
        ));
    }
    Ok(())
}

/// A coherence value γ²: a number in [0, 1] (NaN refused).
pub fn check_coherence(c: f64) -> Result<(), String> {
    if (0.0..=1.0).contains(&c) {
        Ok(())
    } else {
        Err(format!(
            "coherence {c} is outside [0, 1]; γ² is a ratio of spectra between 0 and 1, \
             fix or drop the coherence"
        ))
    }
}

/// A natural frequency of a mode: finite and ≥ 0.
pub fn check_natural_frequency(f: f64) -> Result<(), String> {
    if f.is_finite() && f >= 0.0 {
        Ok(())
    } else {
        Err(format!(
            "natural frequency {f} Hz is not a finite number ≥ 0; fix the modal model"
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frequencies_must_be_non_negative_and_increasing() {
        assert!(check_abscissa(&[0.0, 0.5, 1.0]).is_ok());
        assert!(check_abscissa(&[]).is_ok());
        let (i, m) = check_abscissa(&[1.0, -2.0]).unwrap_err();
        assert_eq!(i, 1);
        assert!(m.contains("negative"), "{m}");
        let (i, m) = check_abscissa(&[1.0, 2.0, 2.0]).unwrap_err();
        assert_eq!(i, 2);
        assert!(m.contains("does not increase"), "{m}");
        assert!(check_abscissa(&[f64::NAN]).is_err());
        assert!(check_frequency(-0.0, None).is_ok());
    }

    #[test]
    fn even_axes_need_a_start_at_or_above_zero_and_a_positive_step() {
        assert!(check_even_abscissa(0.0, 0.25, 100).is_ok());
        assert!(check_even_abscissa(5.0, 0.0, 1).is_ok());
        assert!(check_even_abscissa(-1.0, 0.25, 100).is_err());
        assert!(check_even_abscissa(1.0, 0.0, 2).is_err());
        assert!(check_even_abscissa(1.0, -0.5, 2).is_err());
        assert!(check_even_abscissa(1e20, 1e-10, 2).is_err());
        assert!(check_even_abscissa(0.0, 1e308, 10).is_err());
    }

    #[test]
    fn coherence_is_between_zero_and_one() {
        for c in [0.0, 0.5, 1.0] {
            assert!(check_coherence(c).is_ok());
        }
        for c in [7.0, -1e-12, 1.0 + 1e-12, f64::NAN, f64::INFINITY] {
            assert!(check_coherence(c).is_err(), "{c}");
        }
        assert!(check_natural_frequency(0.0).is_ok());
        assert!(check_natural_frequency(-1.0).is_err());
    }
}
