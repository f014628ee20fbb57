//! Deterministic data parallelism on the machine's cores, without a thread pool crate.
//!
//! [`for_each_mut`] hands out chunks of a slice to scoped threads (one per core, at most [`MAX_THREADS`]); each
//! element is visited exactly once by a call that sees only its index and the element, so the result is the same
//! as a sequential loop whatever the thread timing — only the wall time changes. [`join`] runs two independent
//! closures side by side. A panic in a worker is re-raised in the caller once every worker has stopped.

use std::sync::{Mutex, PoisonError};

/// Upper limit on the threads one call uses.
pub const MAX_THREADS: usize = 8;

/// Threads worth using for `items` independent pieces of work: the available cores (at most [`MAX_THREADS`]), and
/// never more than there are items.
pub fn threads_for(items: usize) -> usize {
    let cores = std::thread::available_parallelism().map_or(1, std::num::NonZeroUsize::get);
    cores.min(MAX_THREADS).min(items).max(1)
}

/// Call `f(i, &mut items[i])` for every `i`, spread over the cores. `f` must not depend on the order of the
/// calls (it gets shared state only through `&`), which makes the outcome independent of the scheduling.
pub fn for_each_mut<T: Send>(items: &mut [T], f: impl Fn(usize, &mut T) + Sync) {
    let threads = threads_for(items.len());
    if threads <= 1 {
        for (i, t) in items.iter_mut().enumerate() {
            f(i, t);
        }
        return;
    }
    // Small chunks balance uneven items (one huge shape among many small ones); the lock is taken once a chunk.
    let chunk = (items.len() / (threads * 16)).max(1);
    let queue = Mutex::new(items.chunks_mut(chunk).enumerate());
    let work = || {
        loop {
            let next = queue.lock().unwrap_or_else(PoisonError::into_inner).next();
            let Some((c, slice)) = next else { break };
            for (k, t) in slice.iter_mut().enumerate() {
                f(c * chunk + k, t);
            }
        }
    };
    std::thread::scope(|s| {
        for _ in 1..threads {
            s.spawn(work);
        }
        work();
    });
}

/// Run `a` and `b` at the same time (`b` on a scoped thread when there is a second core) and return both results.
pub fn join<A: Send, B: Send>(a: impl FnOnce() -> A + Send, b: impl FnOnce() -> B + Send) -> (A, B) {
    if threads_for(2) < 2 {
        let ra = a();
        return (ra, b());
    }
    std::thread::scope(|s| {
        let hb = s.spawn(b);
        let ra = a();
        let rb = match hb.join() {
            Ok(v) => v,
            Err(panic) => std::panic::resume_unwind(panic),
        };
        (ra, rb)
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::atomic::{AtomicUsize, Ordering};

    #[test]
    fn every_element_is_visited_once_with_its_own_index() {
        for n in [0usize, 1, 2, 3, 31, 1000] {
            let mut v: Vec<(usize, usize)> = (0..n).map(|i| (i, 0)).collect();
            let calls = AtomicUsize::new(0);
            for_each_mut(&mut v, |i, t| {
                calls.fetch_add(1, Ordering::Relaxed);
                t.1 = i * i + 1;
            });
            assert_eq!(calls.load(Ordering::Relaxed), n);
            assert!(v.iter().all(|&(i, r)| r == i * i + 1), "n = {n}");
        }
    }

    #[test]
    fn join_returns_both_results_in_place() {
        let data: Vec<u64> = (1..=100).collect();
        let (a, b) = join(|| data.iter().sum::<u64>(), || data.iter().map(|x| x * x).sum::<u64>());
        // 100·101/2 and 100·101·201/6.
        assert_eq!((a, b), (5050, 338_350));
    }

    #[test]
    fn a_panicking_worker_reaches_the_caller() {
        let r = std::panic::catch_unwind(|| {
            let mut v = vec![0u8; 64];
            for_each_mut(&mut v, |i, _| assert!(i != 40, "boom"));
        });
        assert!(r.is_err());
    }
}
