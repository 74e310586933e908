//! Resource bounds checked at validation: size-like params (impact-test
//! records and averages, FRF band lines, Sobol samples × outputs, model
//! DOF × modes) are turned into an estimate of the memory (and, where
//! memory stays small but the work does not, of the samples to simulate)
//! before anything runs, so a typo such as `block_size: 1099511627776`
//! becomes a located error instead of an allocation abort.
//!
//! The memory limit is `--max-memory` (or `MODALFLOW_MAX_MEMORY`), by
//! default half of the machine's RAM (`MemTotal` in `/proc/meminfo`;
//! 8 GiB where that cannot be read). It never enters a cache key.

use std::sync::atomic::{AtomicU64, Ordering};

/// 0: not set, use [`default_memory_limit`].
static LIMIT: AtomicU64 = AtomicU64::new(0);

/// Most samples one impact-test simulation may draw and transform
/// (averages × block size × channels, plus the modal responses at the
/// oversampled rate): about 2·10¹⁰, minutes of work. More is almost
/// certainly a typo; split such a study instead.
pub const MAX_SIMULATED_SAMPLES: f64 = 1.7e10;

/// Set the memory limit for this process (the `--max-memory` flag).
pub fn set_memory_limit(bytes: u64) {
    LIMIT.store(bytes.max(1), Ordering::Relaxed);
}

/// The memory limit in bytes.
pub fn memory_limit() -> u64 {
    match LIMIT.load(Ordering::Relaxed) {
        0 => default_memory_limit(),
        n => n,
    }
}

/// Half the machine's RAM: room for the operating system, other programs
/// and the estimates' slack.
pub fn default_memory_limit() -> u64 {
    let total = std::fs::read_to_string("/proc/meminfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find_map(|l| l.strip_prefix("MemTotal:"))
                .and_then(|v| v.trim().trim_end_matches("kB").trim().parse::<u64>().ok())
        })
        .map(|kb| kb.saturating_mul(1024));
    total.map_or(8 << 30, |t| t / 2)
}

/// A size such as `512M`, `4G`, `4GiB`, `1.5T` or plain bytes.
pub fn parse_size(text: &str) -> Result<u64, String> {
    let t = text.trim();
    let split = t
        .find(|c: char| !(c.is_ascii_digit() || c == '.'))
        .unwrap_or(t.len());
    let (number, unit) = t.split_at(split);
    let value: f64 = number
        .parse()
        .map_err(|_| format!("`{text}` is not a size (e.g. 512M, 4G)"))?;
    let factor: f64 = match unit.trim().to_ascii_uppercase().as_str() {
        "" | "B" => 1.0,
        "K" | "KB" | "KIB" => 1024.0,
        "M" | "MB" | "MIB" => 1024.0 * 1024.0,
        "G" | "GB" | "GIB" => 1024.0 * 1024.0 * 1024.0,
        "T" | "TB" | "TIB" => 1024.0f64.powi(4),
        _ => {
            return Err(format!(
                "`{text}`: unknown unit `{unit}` (use K, M, G or T)"
            ))
        }
    };
    let bytes = value * factor;
    if !(bytes.is_finite() && bytes >= 1.0 && bytes < u64::MAX as f64) {
        return Err(format!("`{text}` is not a usable size"));
    }
    Ok(bytes as u64)
}

/// Bytes as text with a binary unit (`1.5 GiB`).
pub fn human(bytes: f64) -> String {
    let units = ["B", "KiB", "MiB", "GiB", "TiB", "PiB", "EiB"];
    let mut v = bytes;
    let mut u = 0;
    while v >= 1024.0 && u + 1 < units.len() {
        v /= 1024.0;
        u += 1;
    }
    if u == 0 {
        format!("{v:.0} B")
    } else {
        format!("{v:.1} {}", units[u])
    }
}

/// An estimate above a limit: what it needs and how to bring it down.
/// Plain text, so this module depends on nothing above it; stages turn it
/// into a located param problem (`stages::params::limits`).
#[derive(Clone, Debug, PartialEq)]
pub struct Excess {
    pub message: String,
    pub help: String,
}

/// The excess of an estimate of `bytes` for `what` above the memory limit,
/// `path` naming the param to reduce.
pub fn memory_excess(path: &[&str], what: &str, bytes: f64) -> Option<Excess> {
    let limit = memory_limit();
    if bytes <= limit as f64 {
        return None;
    }
    Some(Excess {
        message: format!(
            "`{}` needs an estimated {} of memory ({what}), more than the limit of {}",
            path.join("."),
            human(bytes),
            human(limit as f64)
        ),
        help: format!(
            "reduce `{}`, or raise the limit with --max-memory (default: half the machine's RAM)",
            path.join(".")
        ),
    })
}

/// The excess of `samples` simulated samples (for `what`) above
/// [`MAX_SIMULATED_SAMPLES`], `path` naming the param to reduce.
pub fn work_excess(path: &[&str], what: &str, samples: f64) -> Option<Excess> {
    (samples > MAX_SIMULATED_SAMPLES).then(|| Excess {
        message: format!(
            "`{}` asks for an estimated {samples:.2e} samples to simulate ({what}), more than \
             the limit of {MAX_SIMULATED_SAMPLES:.1e} (hours of work)",
            path.join(".")
        ),
        help: format!("reduce `{}`", path.join(".")),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_parse_with_binary_units() {
        assert_eq!(parse_size("512M").unwrap(), 512 << 20);
        assert_eq!(parse_size("4GiB").unwrap(), 4 << 30);
        assert_eq!(parse_size("1000").unwrap(), 1000);
        assert!(parse_size("lots").is_err());
        assert!(parse_size("4X").is_err());
        assert!(parse_size("0").is_err());
        assert_eq!(human(1536.0), "1.5 KiB");
        assert!(default_memory_limit() > 0);
    }
}
