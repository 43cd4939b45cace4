//! The one work pool: items handed to `jobs` scoped threads in order, each
//! result kept with its item's position; after a failure no new item
//! starts. Used by `simulate` (one session per item), `power` (one
//! study per item), the log check (one file per item) and the
//! discrimination analysis (one track's fit and intervals per item).

use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

/// Runs `work` on every item on `jobs` threads (the caller's among them;
/// at least 1). Returns the results in item order; after the first error,
/// items not yet started are skipped (so the list may be shorter than
/// `items`, and holds every error that happened).
pub fn run<T: Sync, R: Send, E: Send>(
    items: &[T],
    jobs: usize,
    work: impl Fn(&T) -> Result<R, E> + Sync,
) -> Vec<Result<R, E>> {
    let (next, failed) = (AtomicUsize::new(0), AtomicBool::new(false));
    let results: Mutex<Vec<(usize, Result<R, E>)>> = Mutex::default();
    let worker = || {
        while !failed.load(Ordering::Relaxed) {
            let i = next.fetch_add(1, Ordering::Relaxed);
            let Some(item) = items.get(i) else {
                break;
            };
            let result = work(item);
            failed.fetch_or(result.is_err(), Ordering::Relaxed);
            results
                .lock()
                .unwrap_or_else(std::sync::PoisonError::into_inner)
                .push((i, result));
        }
    };
    std::thread::scope(|scope| {
        for _ in 1..jobs.clamp(1, items.len().max(1)) {
            scope.spawn(worker);
        }
        worker();
    });
    let mut list = results
        .into_inner()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    list.sort_by_key(|(i, _)| *i);
    list.into_iter().map(|(_, r)| r).collect()
}
