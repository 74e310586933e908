//! Waiting on every job of a run with one status query per poll interval.
//!
//! Each stage thread waits on its own job (or array task) and checks the
//! cache for its committed record, which says the job succeeded (cheap: a
//! file on the shared file system, so success never waits for the
//! scheduler). Whether a job is still pending or ended without a result is
//! the scheduler's answer, and that is asked once per interval for all of
//! the run's jobs together: the waiter whose turn it is queries
//! (`sacct -j a,b,c`, see [`Queries`]) and wakes the others with the
//! answer. The interval starts at `first` and grows by half each time up
//! to `poll`, as Snakemake's Slurm plugin asks once for all jobs.

use super::queue::{Ended, Queries, TaskState};
use crate::stages::Progress;
use std::collections::{BTreeMap, HashMap};
use std::sync::{Condvar, Mutex, MutexGuard};
use std::time::{Duration, Instant, SystemTime};

/// How long a job the scheduler has never shown may stay unknown (sacct
/// lags behind submission on busy clusters) before it counts as vanished.
const UNSEEN_GRACE: Duration = Duration::from_secs(120);
/// How long a completed job's result may take to become visible here
/// (attribute caching of a network file system).
const VISIBLE_GRACE: Duration = Duration::from_secs(30);
/// Longest wait between two looks at the cache for a waiter's record.
const RECORD_CHECK: Duration = Duration::from_secs(2);

/// One job (or one task of an array) a stage waits on.
#[derive(Clone, Debug)]
pub struct Watch {
    pub id: String,
    /// The array tasks that are this stage's; `None`: every task of the job.
    pub tasks: Option<Vec<usize>>,
    /// When it was submitted (an adopted job may be old).
    pub submitted: SystemTime,
}

struct Shared {
    /// Job id → number of waiters.
    watched: BTreeMap<String, usize>,
    /// The last answer per job id, with the query's generation.
    latest: HashMap<String, (u64, Vec<TaskState>)>,
    /// Queries made so far.
    generation: u64,
    next_query: Instant,
    interval: Duration,
    querying: bool,
    queries: Queries,
}

/// The run's status poller, shared by its stage threads.
pub struct Monitor {
    shared: Mutex<Shared>,
    wake: Condvar,
    max: Duration,
}

impl Monitor {
    /// Queries start `first` apart and back off to `max`.
    pub fn new(first: Duration, max: Duration) -> Monitor {
        Monitor {
            shared: Mutex::new(Shared {
                watched: BTreeMap::new(),
                latest: HashMap::new(),
                generation: 0,
                next_query: Instant::now() + first,
                interval: first,
                querying: false,
                queries: Queries::default(),
            }),
            wake: Condvar::new(),
            max,
        }
    }

    fn lock(&self) -> MutexGuard<'_, Shared> {
        self.shared.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// Whether job states come from accounting (`sacct`).
    pub fn accounting(&self) -> bool {
        self.lock().queries.accounting()
    }

    /// Wait until `ready()` (the result is in the cache) or the scheduler
    /// reports the watched tasks ended without it.
    pub fn wait(
        &self,
        watch: &Watch,
        ready: &dyn Fn() -> bool,
        progress: &dyn Progress,
    ) -> Result<(), Ended> {
        let registered = {
            let mut s = self.lock();
            *s.watched.entry(watch.id.clone()).or_insert(0) += 1;
            s.generation
        };
        let result = self.wait_registered(watch, registered, ready, progress);
        let mut s = self.lock();
        if let Some(n) = s.watched.get_mut(&watch.id) {
            *n -= 1;
            if *n == 0 {
                s.watched.remove(&watch.id);
                s.latest.remove(&watch.id);
            }
        }
        result
    }

    fn wait_registered(
        &self,
        watch: &Watch,
        registered: u64,
        ready: &dyn Fn() -> bool,
        progress: &dyn Progress,
    ) -> Result<(), Ended> {
        let mut seen = false;
        let mut look = Duration::from_millis(200);
        let mut answered = registered;
        loop {
            if ready() {
                return Ok(());
            }
            let mut s = self.lock();
            if s.generation > answered {
                answered = s.generation;
                let mine: Option<Vec<TaskState>> = s.latest.get(&watch.id).map(|(_, all)| {
                    all.iter()
                        .filter(|t| match &watch.tasks {
                            Some(tasks) => tasks.iter().any(|&i| t.covers(i)),
                            None => true,
                        })
                        .cloned()
                        .collect()
                });
                match mine.filter(|m| !m.is_empty()) {
                    Some(states) => {
                        seen = true;
                        if states.iter().all(TaskState::terminal) {
                            drop(s);
                            let completed = states.iter().all(|t| t.state == "COMPLETED");
                            let grace = if completed {
                                VISIBLE_GRACE
                            } else {
                                Duration::ZERO
                            };
                            return settle(ready, grace).ok_or(Ended::Terminal(states));
                        }
                        progress.set_message(super::queue::summary(&watch.id, &states));
                    }
                    None => {
                        let age = watch.submitted.elapsed().unwrap_or_default();
                        if seen || age > UNSEEN_GRACE {
                            drop(s);
                            return settle(ready, VISIBLE_GRACE).ok_or(Ended::Vanished);
                        }
                    }
                }
            }
            let now = Instant::now();
            if !s.querying && now >= s.next_query {
                s.querying = true;
                let ids: Vec<String> = s.watched.keys().cloned().collect();
                let mut queries = std::mem::take(&mut s.queries);
                drop(s);
                let answer = queries.query(&ids);
                let mut s = self.lock();
                s.queries = queries;
                s.querying = false;
                s.generation += 1;
                let generation = s.generation;
                if let Some(states) = answer {
                    let mut by_job: HashMap<String, Vec<TaskState>> = HashMap::new();
                    for t in states {
                        by_job.entry(t.job().to_string()).or_default().push(t);
                    }
                    for id in ids {
                        match by_job.remove(&id) {
                            Some(v) => s.latest.insert(id, (generation, v)),
                            None => s.latest.remove(&id),
                        };
                    }
                }
                s.interval = s.interval.mul_f64(1.5).min(self.max);
                s.next_query = Instant::now() + s.interval;
                self.wake.notify_all();
                continue;
            }
            let until_query = s.next_query.saturating_duration_since(now);
            let timeout = look.min(until_query.max(Duration::from_millis(10)));
            let _unused = self
                .wake
                .wait_timeout(s, timeout)
                .unwrap_or_else(|p| p.into_inner());
            look = look.mul_f64(1.5).min(RECORD_CHECK);
        }
    }
}

/// `Some(())` once `ready()` holds within `grace`.
fn settle(ready: &dyn Fn() -> bool, grace: Duration) -> Option<()> {
    let start = Instant::now();
    loop {
        if ready() {
            return Some(());
        }
        if start.elapsed() >= grace {
            return None;
        }
        std::thread::sleep(Duration::from_millis(500));
    }
}
