//! Best-so-far bookkeeping with the MAC reached: every strategy reports, per
//! improvement of its criterion, the evaluation count, the criterion and the
//! mean MAC (over the kept reference modes, an unpaired mode counting 0) of
//! that best point. The MAC column lets runs with different criteria be
//! compared on one scale ("evaluations needed to reach mean MAC 0.99").
//!
//! Batches are recorded in their input order after a parallel evaluation,
//! so the record is the same whatever the thread count.

use std::sync::Mutex;

/// One improvement: after `evaluation` evaluations the best criterion was
/// `objective`, at a point with mean MAC `mean_mac`.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct HistoryRow {
    pub evaluation: usize,
    pub objective: f64,
    pub mean_mac: f64,
}

/// Records (criterion, mean MAC) of every evaluated point in order.
#[derive(Default)]
pub struct Recorder {
    state: Mutex<(usize, Vec<HistoryRow>)>,
}

impl Recorder {
    /// A recorder whose evaluation count starts at `offset` (evaluations of
    /// earlier phases).
    pub fn starting_at(offset: usize) -> Recorder {
        Recorder {
            state: Mutex::new((offset, Vec::new())),
        }
    }

    /// Record a batch of (criterion, mean MAC) in input order.
    pub fn record(&self, values: &[(f64, f64)]) {
        let mut guard = self.state.lock().unwrap_or_else(|e| e.into_inner());
        let (count, rows) = &mut *guard;
        for &(objective, mean_mac) in values {
            *count += 1;
            let improves = rows.last().is_none_or(|r| objective < r.objective);
            if objective.is_finite() && improves {
                rows.push(HistoryRow {
                    evaluation: *count,
                    objective,
                    mean_mac,
                });
            }
        }
    }

    /// The rows recorded so far.
    pub fn rows(&self) -> Vec<HistoryRow> {
        self.state
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .1
            .clone()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn records_improvements_in_order_with_offset() {
        let r = Recorder::starting_at(10);
        r.record(&[(3.0, 0.5), (f64::INFINITY, 0.0), (2.0, 0.7)]);
        r.record(&[(2.5, 0.9), (1.0, 0.95)]);
        let rows = r.rows();
        let got: Vec<(usize, f64, f64)> = rows
            .iter()
            .map(|h| (h.evaluation, h.objective, h.mean_mac))
            .collect();
        assert_eq!(got, vec![(11, 3.0, 0.5), (13, 2.0, 0.7), (15, 1.0, 0.95)]);
    }
}
