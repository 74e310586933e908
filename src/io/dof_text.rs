//! Text form of DOFs and FRF channels used by the CSV formats and selections:
//! `101+X`, `7-RZ`, `12S` (scalar) and `101+X/1-Z` (response/reference).
//! The printed form is [`Dof`]'s `Display`; parsing is its inverse and also
//! accepts lower case.

use crate::frf::Dof;

const AXES: [&str; 6] = ["X", "Y", "Z", "RX", "RY", "RZ"];

/// Parses `<node><sign><axis>` or `<node>S`; `None` if malformed.
pub fn parse_dof(s: &str) -> Option<Dof> {
    let s = s.trim();
    let digits = s.bytes().take_while(u8::is_ascii_digit).count();
    let node: u32 = s.get(..digits)?.parse().ok()?;
    let rest = s.get(digits..)?.to_ascii_uppercase();
    if rest == "S" {
        return Some(Dof::new(node, 0));
    }
    let (sign, axis) = match rest.as_bytes().first()? {
        b'+' => (1, &rest[1..]),
        b'-' => (-1, &rest[1..]),
        _ => return None,
    };
    let code = AXES.iter().position(|a| *a == axis)? as i8 + 1;
    Some(Dof::new(node, sign * code))
}

/// Parses a direction alone: `+X`, `-RZ`, `S`, or an integer code `-3`.
pub fn parse_direction(s: &str) -> Option<i8> {
    let s = s.trim();
    if let Ok(code) = s.parse::<i8>() {
        return (-6..=6).contains(&code).then_some(code);
    }
    parse_dof(&format!("0{s}")).map(|d| d.direction)
}

/// Parses `<response>/<reference>`.
pub fn parse_channel(s: &str) -> Option<(Dof, Dof)> {
    let (r, f) = s.split_once('/')?;
    Some((parse_dof(r)?, parse_dof(f)?))
}

/// Formats `<response>/<reference>`, e.g. `101+X/1-Z`.
pub fn format_channel(response: Dof, reference: Dof) -> String {
    format!("{response}/{reference}")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dof_text_round_trips_every_direction() {
        for dir in -6..=6i8 {
            let d = Dof::new(4711, dir);
            assert_eq!(parse_dof(&d.to_string()), Some(d), "{d}");
        }
        assert_eq!(parse_dof("101+x"), Some(Dof::new(101, 1)));
        assert_eq!(
            parse_channel("101+X/1-Z"),
            Some((Dof::new(101, 1), Dof::new(1, -3)))
        );
        for bad in ["", "+X", "101", "101X", "101+Q", "101+X/", "x1+X"] {
            assert!(parse_dof(bad).is_none() || bad.contains('/'), "{bad}");
        }
        assert_eq!(parse_channel("101+X/"), None);
    }

    #[test]
    fn directions_parse_from_labels_and_codes() {
        assert_eq!(parse_direction("-RZ"), Some(-6));
        assert_eq!(parse_direction("3"), Some(3));
        assert_eq!(parse_direction("S"), Some(0));
        assert_eq!(parse_direction("7"), None);
    }
}
