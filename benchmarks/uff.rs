//! Parse throughput of the UFF 58 reader on a generated file of 1000 FRFs ×
//! 4000 frequency lines (complex double), written in memory by the crate's
//! own writer as 58b (the `frf` artifact), ASCII 4E20.12 and ASCII 6E13.5.
//!
//! Each row compares `read_uff` against a reference in the same run that does
//! the least work possible on the same bytes: decoding every 8-byte double
//! (binary) or splitting the whole text on whitespace and `str::parse`-ing
//! every token (ASCII), with no record structure or checks. Targets:
//! ≥ 200 MB/s binary, ≥ 50 MB/s ASCII.
//!
//! Run: `cargo bench --bench uff`.

mod timing;

use timing::best;

use modalflow::frf::{Dof, FrfChannel, FrfQuantity, FrfSet, Position};
use modalflow::io::{
    read_frf_artifact, read_uff, uff58_from_frf_sets, write_frf_artifact, write_uff58, NumberText,
    Precision, Storage, Uff58Format,
};
use num_complex::Complex64;

const CHANNELS: usize = 1000;
const LINES: usize = 4000;

fn frf_set() -> FrfSet {
    let f: Vec<f64> = (0..LINES).map(|i| i as f64 * 0.25).collect();
    let channels = (0..CHANNELS)
        .map(|k| {
            let fn_hz = 50.0 + k as f64;
            FrfChannel {
                response: Dof::new(k as u32 + 1, 3),
                reference: Dof::new(1, 3),
                values: f
                    .iter()
                    .map(|&x| {
                        let r = x / fn_hz;
                        Complex64::new(1.0, 0.0) / Complex64::new(1.0 - r * r, 0.04 * r)
                    })
                    .collect(),
                coherence: None,
            }
        })
        .collect();
    FrfSet {
        position: Position::default(),
        quantity: FrfQuantity::Receptance,
        frequencies_hz: f,
        channels,
    }
}

fn reference_binary(bytes: &[u8]) -> f64 {
    bytes
        .chunks_exact(8)
        .map(|c| f64::from_le_bytes(c.try_into().unwrap_or([0; 8])))
        .sum()
}

fn reference_ascii(bytes: &[u8]) -> f64 {
    std::str::from_utf8(bytes)
        .unwrap_or("")
        .split_ascii_whitespace()
        .filter_map(|t| t.parse::<f64>().ok())
        .sum()
}

fn main() {
    let set = frf_set();
    let binary = write_frf_artifact(std::slice::from_ref(&set));
    let datasets = uff58_from_frf_sets(std::slice::from_ref(&set));
    let ascii = Uff58Format {
        storage: Storage::Ascii,
        digits: NumberText::Standard,
    };
    let ascii_double = write_uff58(&datasets, &ascii);
    let single: Vec<_> = datasets
        .iter()
        .cloned()
        .map(|mut d| {
            d.precision = Precision::Single;
            d
        })
        .collect();
    let ascii_single = write_uff58(&single, &ascii);

    println!("UFF 58 parse throughput, {CHANNELS} FRFs x {LINES} lines, best of 3");
    println!(
        "{:<28} {:>9} {:>10} {:>10} {:>14} {:>7}",
        "format", "size MB", "time ms", "MB/s", "reference MB/s", "ratio"
    );
    let rows: [(&str, &[u8], bool); 3] = [
        ("58b LE double (artifact)", &binary, true),
        ("ASCII 4E20.12 double", &ascii_double, false),
        ("ASCII 6E13.5 single", &ascii_single, false),
    ];
    for (name, bytes, is_binary) in rows {
        let n = read_uff(bytes, name)
            .map(|f| f.functions().count())
            .unwrap_or(0);
        assert_eq!(n, CHANNELS, "{name}: all datasets read");
        let mb = bytes.len() as f64 / 1e6;
        let t = best(3, || read_uff(bytes, name)).0;
        let t_ref = if is_binary {
            best(3, || reference_binary(bytes)).0
        } else {
            best(3, || reference_ascii(bytes)).0
        };
        println!(
            "{:<28} {:>9.1} {:>10.1} {:>10.0} {:>14.0} {:>7.2}",
            name,
            mb,
            t * 1e3,
            mb / t,
            mb / t_ref,
            t_ref / t
        );
    }
    let t = best(3, || read_frf_artifact(&binary, "artifact")).0;
    let mb = binary.len() as f64 / 1e6;
    println!(
        "{:<28} {:>9.1} {:>10.1} {:>10.0} {:>14} {:>7}",
        "read_frf_artifact (58b)",
        mb,
        t * 1e3,
        mb / t,
        "-",
        "-"
    );
    println!("targets: >= 200 MB/s binary, >= 50 MB/s ASCII");
}
