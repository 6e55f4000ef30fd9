//! Training's helper threads: persistent sets of them (one per thread count and concurrent
//! caller), each helper running one job at a time, so that the rollout's and the update's
//! shards (thousands of jobs per update, some of a fraction of a millisecond) run on warm
//! threads that pick a job up within a few microseconds. Threads started for each job cost
//! more than the shorter jobs themselves (a fresh allocator heap and fresh matrix-packing
//! buffers each time), and a pool whose idle threads sleep at once (rayon's) took 55–85 µs to
//! wake one, three times per minibatch.
//!
//! An idle helper, and a caller waiting for its helpers, yield the core for [`SPIN`] before
//! they park: training dispatches again well within that, while an idle process (the
//! debugger, a paused sweep) does not keep a core busy. They yield rather than spin on the
//! CPU's pause instruction: on the 2-core machine a thread spinning that way slowed the job on
//! the other core about twice (a rollout shard took 359 µs on the helper against 194 µs on the
//! caller, and `bench train --threads 2` fell from 5.8k to 4.5–5.1k frames/s).

use std::panic::AssertUnwindSafe;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex, OnceLock, PoisonError};
use std::time::{Duration, Instant};

use crate::policy::error::PolicyError;

/// How long an idle helper (or a waiting caller) yields before it parks.
const SPIN: Duration = Duration::from_millis(2);

/// One round of waiting that began at `since`: a yield of the core within [`SPIN`], then a
/// park (with a timeout, so that a wake-up is never lost for good).
fn idle_wait(since: Instant) {
    if since.elapsed() < SPIN {
        std::thread::yield_now();
    } else {
        std::thread::park_timeout(Duration::from_millis(50));
    }
}

/// A job with its borrows erased, as a helper receives it (see [`run_all`] for why the borrows
/// outlive it).
type Task = Box<dyn FnOnce() + Send + 'static>;

/// One helper thread's mailbox.
struct Helper {
    task: Mutex<Option<Task>>,
    /// Set when `task` holds a job, cleared by the helper as it takes it.
    posted: AtomicBool,
    thread: std::thread::Thread,
}

impl Helper {
    fn post(&self, task: Task) {
        *self.task.lock().unwrap_or_else(PoisonError::into_inner) = Some(task);
        self.posted.store(true, Ordering::Release);
        self.thread.unpark();
    }

    /// The helper's loop: wait until a job is posted; run it; repeat.
    fn serve(&self) {
        loop {
            let idle = Instant::now();
            while !self.posted.load(Ordering::Acquire) {
                idle_wait(idle);
            }
            let task = self
                .task
                .lock()
                .unwrap_or_else(PoisonError::into_inner)
                .take();
            self.posted.store(false, Ordering::Release);
            if let Some(task) = task {
                task();
            }
        }
    }
}

thread_local! {
    /// Set on helper threads.
    static IN_HELPER: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

/// The helper sets not in use. A caller takes a set for the length of one dispatch and puts
/// it back, so that two trainers in one process (tests run side by side, a Python program
/// with two threads) never post to the same helper.
static IDLE_SETS: OnceLock<Mutex<Vec<HelperSet>>> = OnceLock::new();

/// A set of helpers, one per job beyond the caller's.
type HelperSet = Vec<Arc<Helper>>;

fn idle_sets() -> std::sync::MutexGuard<'static, Vec<HelperSet>> {
    IDLE_SETS
        .get_or_init(|| Mutex::new(Vec::new()))
        .lock()
        .unwrap_or_else(PoisonError::into_inner)
}

/// An idle set of `n` helpers, or a new one; `None` where the system refuses threads (the
/// jobs then run on scoped threads of their own).
fn take_helpers(n: usize) -> Option<HelperSet> {
    {
        let mut sets = idle_sets();
        if let Some(i) = sets.iter().position(|s| s.len() == n) {
            return Some(sets.swap_remove(i));
        }
    }
    let mut set = Vec::with_capacity(n);
    for i in 0..n {
        let (tx, rx) = std::sync::mpsc::channel::<Arc<Helper>>();
        let handle = std::thread::Builder::new()
            .name(format!("groundscope-train-{n}-{i}"))
            .spawn(move || {
                IN_HELPER.with(|c| c.set(true));
                if let Ok(h) = rx.recv() {
                    h.serve();
                }
            })
            .ok()?;
        let helper = Arc::new(Helper {
            task: Mutex::new(None),
            posted: AtomicBool::new(false),
            thread: handle.thread().clone(),
        });
        tx.send(Arc::clone(&helper)).ok()?;
        set.push(helper);
    }
    Some(set)
}

/// Runs every job, the first on the calling thread and each other on a helper thread of its
/// own (so all run at once), and returns their results in job order (the order that fixes a
/// result; which thread ran a job never does). A job that panics is an error, after every job
/// has ended.
pub(super) fn run_all<T: Send>(
    jobs: Vec<impl FnOnce() -> Result<T, PolicyError> + Send>,
) -> Result<Vec<T>, PolicyError> {
    // A job that dispatches again (none does today) runs its jobs in turn rather than wait on
    // its own helper set.
    if jobs.len() <= 1 || IN_HELPER.with(std::cell::Cell::get) {
        return jobs.into_iter().map(|job| job()).collect();
    }
    let caught = |job: Box<dyn FnOnce() -> Result<T, PolicyError> + Send + '_>| {
        std::panic::catch_unwind(AssertUnwindSafe(job))
            .unwrap_or_else(|_| Err(PolicyError::Input("a training thread panicked".into())))
    };
    let mut slots: Vec<Option<Result<T, PolicyError>>> = jobs.iter().map(|_| None).collect();
    let mut jobs = jobs.into_iter();
    let first = jobs.next();
    let Some((head, rest)) = slots.split_first_mut() else {
        return Ok(Vec::new());
    };
    match take_helpers(rest.len()) {
        Some(set) => {
            let pending = AtomicUsize::new(rest.len());
            let pending = &pending;
            for ((slot, job), helper) in rest.iter_mut().zip(jobs).zip(set.iter()) {
                let caller = std::thread::current();
                let task: Box<dyn FnOnce() + Send + '_> = Box::new(move || {
                    *slot = Some(caught(Box::new(job)));
                    if pending.fetch_sub(1, Ordering::Release) == 1 {
                        caller.unpark();
                    }
                });
                // SAFETY: the task borrows `slot`, `job`'s captures and `pending`, all of which
                // outlive this call: it returns only after `pending` reaches 0, after which a
                // task touches only its own `caller` handle, and nothing between here and that
                // wait can unwind (the jobs' panics are caught inside `caught`).
                #[expect(unsafe_code, reason = "a scoped job on a persistent thread")]
                let task: Task = unsafe { std::mem::transmute(task) };
                helper.post(task);
            }
            *head = first.map(|job| caught(Box::new(job)));
            let waiting = Instant::now();
            while pending.load(Ordering::Acquire) != 0 {
                idle_wait(waiting);
            }
            idle_sets().push(set);
        }
        None => std::thread::scope(|scope| {
            for (slot, job) in rest.iter_mut().zip(jobs) {
                scope.spawn(move || *slot = Some(caught(Box::new(job))));
            }
            *head = first.map(|job| caught(Box::new(job)));
        }),
    }
    slots
        .into_iter()
        .map(|s| s.unwrap_or_else(|| Err(PolicyError::Input("a training job did not run".into()))))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Results come back in job order whatever thread ran them, the helpers are reused (and
    /// woken from their park), jobs borrow the caller's data, a panicking job is an error once
    /// all jobs have ended, not a crash, and two callers at once get helpers of their own.
    #[test]
    fn results_in_job_order_and_panics_are_errors() {
        let data: Vec<usize> = (0..10).collect();
        for n in [1usize, 2, 3, 5] {
            for round in 0..3 {
                let data = &data;
                let jobs: Vec<_> = (0..n).map(|i| move || Ok(data[i] * 10 + round)).collect();
                let got = run_all(jobs).unwrap();
                assert_eq!(got, (0..n).map(|i| i * 10 + round).collect::<Vec<_>>());
                if round == 1 {
                    // Past the spin: the helpers have parked and must be woken.
                    std::thread::sleep(SPIN * 3);
                }
            }
        }
        let ran = AtomicUsize::new(0);
        let jobs: Vec<Box<dyn FnOnce() -> Result<usize, PolicyError> + Send + '_>> = vec![
            Box::new(|| {
                ran.fetch_add(1, Ordering::SeqCst);
                Ok(1)
            }),
            Box::new(|| panic!("boom")),
            Box::new(|| {
                std::thread::sleep(Duration::from_millis(20));
                ran.fetch_add(1, Ordering::SeqCst);
                Ok(3)
            }),
        ];
        let err = run_all(jobs).unwrap_err();
        assert!(err.to_string().contains("panicked"), "{err}");
        assert_eq!(ran.load(Ordering::SeqCst), 2);
        // Two callers at once each get helpers of their own, and both sets are kept.
        let both = std::sync::Barrier::new(2);
        std::thread::scope(|scope| {
            for k in 0..2usize {
                let both = &both;
                scope.spawn(move || {
                    for round in 0..50 {
                        let jobs: Vec<_> = (0..3)
                            .map(|i| {
                                move || {
                                    if round == 0 && i == 0 {
                                        both.wait();
                                    }
                                    Ok(k * 100 + i)
                                }
                            })
                            .collect();
                        assert_eq!(
                            run_all(jobs).unwrap(),
                            vec![k * 100, k * 100 + 1, k * 100 + 2]
                        );
                    }
                });
            }
        });
        assert!(idle_sets().iter().filter(|s| s.len() == 2).count() >= 2);
    }
}
