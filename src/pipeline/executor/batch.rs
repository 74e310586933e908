//! Stages that share one submission: the matrix expansions of a stage that
//! become ready together (an array, one task each) and the stages of a kind
//! with `group: n` (up to n per job, run in turn). The first stage of a
//! batch waits a short window for the others to join, then submits for all
//! of them; each stage then waits on its own task or record.

use super::error::ExecutorError;
use std::collections::HashMap;
use std::path::PathBuf;
use std::sync::mpsc;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// How long a batch stays open after its last member joined.
const WINDOW: Duration = Duration::from_millis(300);
/// Longest a batch stays open.
const LONGEST: Duration = Duration::from_secs(3);

/// One stage in a batch: its description.
#[derive(Clone, Debug)]
pub struct Member {
    pub stage: String,
    pub key: String,
    pub description: PathBuf,
}

/// A member's placement, or the batch's submission error shared by all.
type Reply<T> = mpsc::Sender<Result<T, Arc<ExecutorError>>>;

/// Submits a batch: one placement per member, in order.
pub type Submit<'a, T> = dyn Fn(&[Member]) -> Result<Vec<T>, ExecutorError> + 'a;

struct Open<T> {
    members: Vec<(Member, Reply<T>)>,
    last_join: Instant,
}

/// Open batches by what must agree among their members.
pub struct Batcher<T> {
    open: Mutex<HashMap<String, Open<T>>>,
}

impl<T> Default for Batcher<T> {
    fn default() -> Self {
        Batcher {
            open: Mutex::new(HashMap::new()),
        }
    }
}

impl<T: Send> Batcher<T> {
    /// Join the batch `key`; the first member waits for the others and
    /// calls `submit` with all of them (in joining order), which returns one
    /// placement per member. Returns this member's placement; a failed
    /// submission is every member's [`ExecutorError::Batch`].
    pub fn join(&self, key: &str, member: Member, submit: &Submit<T>) -> Result<T, ExecutorError> {
        let (tx, rx) = mpsc::channel();
        let leader = {
            let mut open = self.open.lock().unwrap_or_else(|p| p.into_inner());
            match open.get_mut(key) {
                Some(o) => {
                    o.members.push((member, tx));
                    o.last_join = Instant::now();
                    false
                }
                None => {
                    open.insert(
                        key.to_string(),
                        Open {
                            members: vec![(member, tx)],
                            last_join: Instant::now(),
                        },
                    );
                    true
                }
            }
        };
        if leader {
            let start = Instant::now();
            let members = loop {
                std::thread::sleep(WINDOW / 3);
                let mut open = self.open.lock().unwrap_or_else(|p| p.into_inner());
                let quiet = open
                    .get(key)
                    .is_none_or(|o| o.last_join.elapsed() >= WINDOW);
                if quiet || start.elapsed() >= LONGEST {
                    break open.remove(key).map(|o| o.members).unwrap_or_default();
                }
            };
            let (list, replies): (Vec<Member>, Vec<Reply<T>>) = members.into_iter().unzip();
            match submit(&list) {
                Ok(placements) => {
                    for (reply, p) in replies.into_iter().zip(placements) {
                        let _ = reply.send(Ok(p));
                    }
                }
                Err(e) => {
                    let e = Arc::new(e);
                    for reply in replies {
                        let _ = reply.send(Err(Arc::clone(&e)));
                    }
                }
            }
        }
        match rx.recv() {
            Ok(answer) => answer.map_err(ExecutorError::Batch),
            Err(_) => Err(ExecutorError::NoAnswer),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn members_joining_together_share_one_submission() {
        let batcher: Batcher<(usize, usize)> = Batcher::default();
        let calls = Mutex::new(Vec::new());
        std::thread::scope(|s| {
            let handles: Vec<_> = (0..5)
                .map(|i| {
                    let (batcher, calls) = (&batcher, &calls);
                    s.spawn(move || {
                        let m = Member {
                            stage: format!("s{i}"),
                            key: i.to_string(),
                            description: PathBuf::from(format!("{i}.json")),
                        };
                        batcher.join("k", m, &|all| {
                            calls.lock().expect("lock").push(all.len());
                            Ok((0..all.len()).map(|j| (all.len(), j)).collect())
                        })
                    })
                })
                .collect();
            let mut places: Vec<usize> = handles
                .into_iter()
                .map(|h| h.join().expect("thread").expect("placed").1)
                .collect();
            places.sort();
            assert_eq!(places, [0, 1, 2, 3, 4]);
        });
        assert_eq!(*calls.lock().expect("lock"), [5]);
    }
}
