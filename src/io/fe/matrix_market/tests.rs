//! Known answers and malformed input of the Matrix Market reader.

use super::*;

const BANNER: &str = "%%MatrixMarket matrix coordinate real symmetric\n";

fn read(body: &str) -> Result<FeMatrix, FeError> {
    read_matrix_market(&format!("{BANNER}{body}"))
}

#[test]
fn symmetric_entries_are_mirrored() {
    let m = read("% exported\n\n2 2 2\n1 1 2.0\n2 1 -1\n").unwrap();
    assert_eq!(m.n, 2);
    assert_eq!(m.entries, vec![(0, 0, 2.0), (1, 0, -1.0), (0, 1, -1.0)]);
    let g = read_matrix_market("%%MatrixMarket matrix coordinate integer general\n2 2 1\n1 2 3\n")
        .unwrap();
    assert_eq!(g.entries, vec![(0, 1, 3.0)]);
}

#[test]
fn absurd_sizes_are_refused_before_allocating() {
    let e = read("1000000000000 1000000000000 1000000000000\n1 1 1\n").unwrap_err();
    assert_eq!(e.line, 2);
    assert!(e.message.contains("room for at most"), "{e}");
    // Few entries, rows beyond any memory limit.
    let e = read("1000000000000000 1000000000000000 1\n1 1 1\n").unwrap_err();
    assert!(e.message.contains("memory limit"), "{e}");
    let e = read("99999999999999999999999 3 1\n").unwrap_err();
    assert!(e.message.contains("three non-negative integers"), "{e}");
    assert!(read("3 4 1\n1 1 1\n").is_err());
}

#[test]
fn out_of_range_and_malformed_entries_name_their_line() {
    let e = read("3 3 2\n1 1 1\n4 1 1\n").unwrap_err();
    assert_eq!(e.line, 4);
    assert!(e.message.contains("row index 4 is outside"), "{e}");
    let e = read("3 3 1\n1 0 1\n").unwrap_err();
    assert!(e.message.contains("column index 0"), "{e}");
    let e = read("3 3 1\n1 1 nan\n").unwrap_err();
    assert!(e.message.contains("not a finite number"), "{e}");
    let e = read("3 3 2\n1 1 1\n\n\n\n\n\n\n").unwrap_err();
    assert!(e.message.contains("after 1 of the 2"), "{e}");
    let e = read("3 3 2\n1 1 1\n").unwrap_err();
    assert!(
        e.message.contains("room for at most 1 entry line(s)"),
        "{e}"
    );
    let e = read("3 3 1\n1 1 1\n2 2 1\n").unwrap_err();
    assert_eq!(e.line, 4);
    let e = read_matrix_market("%%MatrixMarket matrix array real general\n").unwrap_err();
    assert!(e.message.contains("coordinate"), "{e}");
    assert!(read_matrix_market("").is_err());
}

/// The value column against `str::parse` on edge cases: exponents, signs,
/// 17 significant digits, subnormals, the largest double; Fortran `D`
/// exponents; infinities and NaN refused.
#[test]
fn values_parse_as_the_standard_library_does() {
    for v in [
        "0",
        "-0",
        "+2.5",
        "1",
        "-1.5E+3",
        "1e-300",
        "4.9e-324",
        "2.2250738585072014e-308",
        "1.7976931348623157e308",
        "0.30000000000000004",
        "-1234567890.1234567",
        "9007199254740993",
        "1.00000000000000011102230246251565e0",
        ".5",
        "5.",
        "1E5",
        "-7.0e-0",
    ] {
        let m = read(&format!("1 1 1\n1 1 {v}\n")).unwrap();
        let want: f64 = v.parse().unwrap();
        assert_eq!(m.entries[0].2.to_bits(), want.to_bits(), "{v}");
    }
    let m = read("1 1 1\n1 1 1.5D+03\n").unwrap();
    assert_eq!(m.entries[0].2, 1500.0);
    for bad in [
        "inf", "-inf", "nan", "NaN", "infinity", "1e400", "1.5x", "--1", "0x10",
    ] {
        let e = read(&format!("1 1 1\n1 1 {bad}\n")).unwrap_err();
        assert_eq!(e.line, 3, "{bad}");
        assert!(e.message.contains("not a finite number"), "{bad}: {e}");
    }
}

/// Tabs, carriage returns, leading blanks, comments between entries, a
/// `+` index and no final line feed read as a line-by-line reader would.
#[test]
fn white_space_and_comments_between_entries() {
    let m = read("3 3 3\r\n 1\t1  2.0\r\n% note\r\n\r\n+3 1 -1\n2 2 4e0").unwrap();
    assert_eq!(
        m.entries,
        vec![(0, 0, 2.0), (2, 0, -1.0), (0, 2, -1.0), (1, 1, 4.0)]
    );
    let e = read("3 3 1\n1 1 1 % trailing\n").unwrap_err();
    assert_eq!(e.line, 3);
    assert!(e.message.contains("5 fields"), "{e}");
    let e = read("3 3 1\n1    1\n").unwrap_err();
    assert!(e.message.contains("2 fields"), "{e}");
    let e = read("3 3 1\n1x 1 1\n").unwrap_err();
    assert!(
        e.message
            .contains("row index `1x` is not a positive integer"),
        "{e}"
    );
    let e = read("3 3 1\n1 99999999999999999999999 1\n").unwrap_err();
    assert!(e.message.contains("column index `9999"), "{e}");
}

/// A file of many chunks (scanned in parallel) gives the entries of a
/// sequential reading, in file order, and problems at their line.
#[test]
fn many_chunks_read_in_file_order_with_lines_right() {
    let n = 600_000usize;
    let mut body = format!("%%MatrixMarket matrix coordinate real general\n{n} {n} {n}\n");
    let mut given = Vec::with_capacity(n);
    for k in 1..=n {
        let j = (k * 7919) % n + 1;
        body.push_str(&format!("{k} {j} {k}.25e-3\n"));
        given.push((k - 1, j - 1, format!("{k}.25e-3").parse::<f64>().unwrap()));
        if k % 1000 == 0 {
            body.push_str("% a comment every thousand lines\n");
        }
    }
    assert!(body.len() > 2 * (4 << 20), "several chunks");
    assert_eq!(read_matrix_market(&body).unwrap().entries, given);
    // A bad entry far into the file: its line, counting the banner, the
    // size line and the comments.
    let k = 321_123;
    let bad_line = 2 + k + k / 1000;
    let broken: String = body
        .lines()
        .enumerate()
        .map(|(i, l)| match i + 1 == bad_line {
            true => "1 0 1\n".to_string(),
            false => format!("{l}\n"),
        })
        .collect();
    let e = read_matrix_market(&broken).unwrap_err();
    assert_eq!(e.line, bad_line, "{e}");
    assert!(e.message.contains("column index 0"), "{e}");
    // One entry too many at the very end, and one too few.
    let e = read_matrix_market(&format!("{body}1 1 1\n")).unwrap_err();
    assert_eq!(e.line, body.lines().count() + 1, "{e}");
    assert!(e.message.contains("more entries than the 600000"), "{e}");
    let short = body.replacen(&format!("{n} {n} {n}"), &format!("{n} {n} {}", n + 1), 1);
    let e = read_matrix_market(&format!("{short}\n\n")).unwrap_err();
    assert!(e.message.contains("after 600000 of the 600001"), "{e}");
}
