//! The dispatch loop of [`run`](super::run): stages start on scoped threads
//! in plan order once their upstream finished, at most `--jobs` at once;
//! their outcomes are collected as they arrive, and a failure stops further
//! launches unless `--keep-going`.

use super::{line, skipped, RunError, RunOptions};
use crate::pipeline::execute::{Done, Engine, Outcome, StageReport, Status};
use crate::pipeline::plan::Plan;
use crate::pipeline::progress::{Progress, Reporter};
use crate::pipeline::provenance::StageProvenance;
use std::collections::BTreeMap;
use std::sync::mpsc;
use std::thread::Scope;

#[derive(Clone)]
enum State {
    Pending,
    Running,
    Finished(Option<Done>),
}

/// What a finished stage's thread sends back.
type Message = (usize, Outcome, Progress);

/// What the dispatch loop leaves for `run` to report and record.
pub(super) struct Tally {
    /// Per node, the report of a stage that finished or was skipped.
    pub(super) reports: Vec<Option<StageReport>>,
    /// Provenance of the stages that finished, for the last-run record.
    pub(super) updates: Vec<(String, StageProvenance)>,
    /// Why stages were no longer started (a failure without
    /// `--keep-going`, a cache failure).
    pub(super) stop_reason: Option<String>,
    /// The first cache or file-system failure.
    pub(super) fatal: Option<RunError>,
}

/// The loop's state between launches and arrivals.
struct Dispatch<'p> {
    plan: &'p Plan,
    state: Vec<State>,
    running: usize,
    jobs: usize,
    tally: Tally,
}

/// Run the `wanted` stages of `plan`, independent ones concurrently, and
/// return their reports and provenance; stages downstream of a failure are
/// reported skipped, those never started are left for `run` to report.
pub(super) fn dispatch(
    plan: &Plan,
    engine: &Engine,
    wanted: &[bool],
    reporter: &Reporter,
    opts: &RunOptions,
) -> Tally {
    // Stages not wanted count as finished without a result: nothing
    // wanted depends on them (the wanted set is closed upstream).
    let state: Vec<State> = wanted
        .iter()
        .map(|&w| {
            if w {
                State::Pending
            } else {
                State::Finished(None)
            }
        })
        .collect();
    let mut d = Dispatch {
        plan,
        state,
        running: 0,
        jobs: opts.jobs.max(1),
        tally: Tally {
            reports: vec![None; plan.nodes.len()],
            updates: Vec::new(),
            stop_reason: None,
            fatal: None,
        },
    };
    std::thread::scope(|scope| {
        let (tx, rx) = mpsc::channel::<Message>();
        loop {
            d.skip_after_unfinished_upstream();
            if d.tally.stop_reason.is_none() {
                d.launch_ready(scope, &tx, engine, reporter);
            }
            if d.running == 0 {
                break;
            }
            let Ok((i, outcome, progress)) = rx.recv() else {
                break;
            };
            d.running -= 1;
            d.record(i, outcome, progress, reporter, opts.keep_going);
        }
    });
    d.tally
}

impl Dispatch<'_> {
    /// Report skipped the pending stages that can no longer run.
    fn skip_after_unfinished_upstream(&mut self) {
        let plan = self.plan;
        // Skip stages whose upstream failed or was skipped.
        for &i in &plan.order {
            if !matches!(self.state[i], State::Pending) {
                continue;
            }
            let bad: Vec<&str> = plan.upstream[i]
                .iter()
                .filter(|&&u| matches!(self.state[u], State::Finished(None)))
                .map(|&u| plan.nodes[u].name.as_str())
                .collect();
            if !bad.is_empty() {
                self.state[i] = State::Finished(None);
                self.tally.reports[i] = Some(skipped(
                    plan,
                    i,
                    format!("upstream {} did not finish", bad.join(", ")),
                ));
            }
        }
    }

    /// Start the stages whose upstream all finished, in plan order, each on
    /// its own thread of `scope`, until `jobs` stages run.
    fn launch_ready<'scope>(
        &mut self,
        scope: &'scope Scope<'scope, '_>,
        tx: &mpsc::Sender<Message>,
        engine: &'scope Engine,
        reporter: &Reporter,
    ) {
        let plan = self.plan;
        // Launch ready stages in plan order.
        for &i in &plan.order {
            if self.running >= self.jobs {
                break;
            }
            let ready = matches!(self.state[i], State::Pending)
                && plan.upstream[i]
                    .iter()
                    .all(|&u| matches!(self.state[u], State::Finished(Some(_))));
            if !ready {
                continue;
            }
            self.state[i] = State::Running;
            self.running += 1;
            // Every ancestor (not only the inputs' stages): a
            // kind may read their warnings (`upstream_warnings`).
            let upstream: BTreeMap<usize, Done> = plan
                .ancestors(i)
                .into_iter()
                .filter_map(|u| match &self.state[u] {
                    State::Finished(Some(d)) => Some((u, d.clone())),
                    _ => None,
                })
                .collect();
            let progress = reporter.stage(&plan.nodes[i].name);
            let tx = tx.clone();
            scope.spawn(move || {
                let lookup = |u: usize| upstream.get(&u).cloned();
                let outcome = engine.execute(i, &lookup, &progress);
                let _ = tx.send((i, outcome, progress));
            });
        }
    }

    /// Take in the outcome of stage `i`: print its line and warnings, stop
    /// further launches after a failure (unless `keep_going`) or a cache
    /// failure, and keep its report, provenance and result.
    fn record(
        &mut self,
        i: usize,
        outcome: Outcome,
        progress: Progress,
        reporter: &Reporter,
        keep_going: bool,
    ) {
        let tally = &mut self.tally;
        for w in &outcome.warnings {
            reporter.line(&format!("warning: {w}"));
        }
        reporter.done(progress, &line(&outcome.report));
        if outcome.report.status == Status::Failed && !keep_going && tally.stop_reason.is_none() {
            tally.stop_reason = Some(format!(
                "not started: {} failed (use --keep-going to run independent stages)",
                outcome.report.name
            ));
        }
        if let Some(e) = outcome.fatal {
            tally.stop_reason.get_or_insert_with(|| {
                format!("not started: {} hit a cache failure", outcome.report.name)
            });
            tally.fatal.get_or_insert(e);
        }
        if let Some(p) = outcome.provenance {
            tally.updates.push((self.plan.nodes[i].name.clone(), p));
        }
        self.state[i] = State::Finished(outcome.done);
        tally.reports[i] = Some(outcome.report);
    }
}
