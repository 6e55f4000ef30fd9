//! Training's helper threads: one persistent pool per thread count, so that the rollout's and
//! the update's shards (thousands of short jobs per update) run on warm threads instead of
//! threads started for each job, whose start, fresh allocator heap and fresh matrix-packing
//! buffers cost more than the shorter jobs themselves.

use std::panic::AssertUnwindSafe;
use std::sync::{Arc, Mutex, OnceLock};

use crate::policy::error::PolicyError;

/// A pool and its number of helper threads.
type Pool = (usize, Arc<rayon::ThreadPool>);

/// The pools made so far (one per thread count a process uses).
static POOLS: OnceLock<Mutex<Vec<Pool>>> = OnceLock::new();

/// The pool of `helpers` threads, made on first use; `None` where the system refuses threads
/// (the jobs then run on scoped threads of their own, as before the pool).
fn pool(helpers: usize) -> Option<Arc<rayon::ThreadPool>> {
    let pools = POOLS.get_or_init(|| Mutex::new(Vec::new()));
    let mut pools = pools
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    if let Some((_, p)) = pools.iter().find(|(n, _)| *n == helpers) {
        return Some(Arc::clone(p));
    }
    let p = rayon::ThreadPoolBuilder::new()
        .num_threads(helpers)
        .thread_name(|i| format!("groundscope-train-{i}"))
        .build()
        .ok()?;
    let p = Arc::new(p);
    pools.push((helpers, Arc::clone(&p)));
    Some(p)
}

/// Runs every job, the first on the calling thread and each other on a helper thread of its
/// own, and returns their results in job order (the order that fixes a result; which thread
/// ran a job never does). A job that panics is an error, after every job has ended.
pub(super) fn run_all<T: Send>(
    jobs: Vec<impl FnOnce() -> Result<T, PolicyError> + Send>,
) -> Result<Vec<T>, PolicyError> {
    if jobs.len() <= 1 {
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
    match pool(rest.len()) {
        Some(pool) => pool.in_place_scope(|scope| {
            for (slot, job) in rest.iter_mut().zip(jobs) {
                scope.spawn(move |_| *slot = Some(caught(Box::new(job))));
            }
            *head = first.map(|job| caught(Box::new(job)));
        }),
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

    /// Results come back in job order whatever thread ran them, the pool is reused, and a
    /// panicking job is an error once all jobs have ended, not a crash.
    #[test]
    fn results_in_job_order_and_panics_are_errors() {
        for n in [1usize, 2, 3, 5] {
            for _ in 0..3 {
                let jobs: Vec<_> = (0..n).map(|i| move || Ok(i * 10)).collect();
                let got = run_all(jobs).unwrap();
                assert_eq!(got, (0..n).map(|i| i * 10).collect::<Vec<_>>());
            }
        }
        let ran = std::sync::atomic::AtomicUsize::new(0);
        let jobs: Vec<Box<dyn FnOnce() -> Result<usize, PolicyError> + Send + '_>> = vec![
            Box::new(|| {
                ran.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
                Ok(1)
            }),
            Box::new(|| panic!("boom")),
            Box::new(|| {
                ran.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
                Ok(3)
            }),
        ];
        let err = run_all(jobs).unwrap_err();
        assert!(err.to_string().contains("panicked"), "{err}");
        assert_eq!(ran.load(std::sync::atomic::Ordering::SeqCst), 2);
        let pools = POOLS.get().unwrap().lock().unwrap();
        assert_eq!(pools.iter().filter(|(h, _)| *h == 1).count(), 1);
    }
}
