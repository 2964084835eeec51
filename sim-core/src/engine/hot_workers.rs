//! Worker threads kept awake between a round's parallel steps.
//!
//! A round alternates parallel steps (perceive and decide, the explored map beside step 3)
//! with sequential ones (step 3, the robot index). Between parallel steps rayon's idle
//! workers go to sleep, and the next step waits for them to wake, which is long against a
//! short round. [`with_hot_workers`] keeps them polling for work instead, at the price of a
//! busy core during the sequential steps.

use std::cell::Cell;
use std::sync::atomic::{AtomicBool, Ordering};

thread_local! {
    /// This thread is polling for work in [`with_hot_workers`] already.
    static POLLING: Cell<bool> = const { Cell::new(false) };
}

/// Jobs the pollers ran, for the tests to see that they took part.
#[cfg(test)]
static POLLED_JOBS: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);

/// Run `f` with the current rayon pool's other workers kept awake: each polls for work
/// (executing any it finds, as an idle worker would after waking) until `f` returns or
/// panics. Results do not change: the same jobs run, only sooner
/// (`hot_workers_run_every_job_take_part_and_stop_after_a_panic`).
///
/// For loops of rounds that have the cores to themselves (benchmarks, headless runs): the
/// polling workers keep their cores busy between parallel steps, which slows anything else
/// that wants them (another run, a viewer). No more workers poll than there are cores
/// besides the caller's; the rest sleep as before.
///
/// ```
/// use rayon::prelude::*;
/// let pool = rayon::ThreadPoolBuilder::new().num_threads(2).build().unwrap();
/// let sum: u64 = pool.install(|| {
///     sim_core::engine::with_hot_workers(|| (0..1000u64).into_par_iter().sum())
/// });
/// assert_eq!(sum, 499_500);
/// ```
pub fn with_hot_workers<R>(f: impl FnOnce() -> R) -> R {
    // At most one core each besides the caller's: on a pool with more threads than cores,
    // pollers would take turns on the cores with the caller's sequential steps.
    let cores = std::thread::available_parallelism().map_or(1, std::num::NonZeroUsize::get);
    let pollers = rayon::current_num_threads().min(cores).saturating_sub(1);
    if pollers == 0 {
        return f();
    }
    let caller = rayon::current_thread_index();
    let stop = AtomicBool::new(false);
    rayon::in_place_scope(|scope| {
        for _ in 0..pollers {
            scope.spawn(|_| poll(&stop, caller));
        }
        // Stops the pollers however `f` ends (the scope waits for them).
        let _stop = StopOnDrop(&stop);
        f()
    })
}

/// Sets the flag when dropped.
struct StopOnDrop<'a>(&'a AtomicBool);

impl Drop for StopOnDrop<'_> {
    fn drop(&mut self) {
        self.0.store(true, Ordering::Release);
    }
}

/// Execute pool work as it appears until `stop`. Returns at once on the thread that runs
/// `f` (`caller`: it would wait here for itself) and on a thread polling already (one
/// poller a thread is enough), so that no thread can end up waiting on work it holds up.
fn poll(stop: &AtomicBool, caller: Option<usize>) {
    if rayon::current_thread_index() == caller || POLLING.with(Cell::get) {
        return;
    }
    POLLING.with(|p| p.set(true));
    while !stop.load(Ordering::Acquire) {
        if rayon::yield_now() == Some(rayon::Yield::Executed) {
            #[cfg(test)]
            POLLED_JOBS.fetch_add(1, Ordering::Relaxed);
        } else {
            std::hint::spin_loop();
        }
    }
    POLLING.with(|p| p.set(false));
}

#[cfg(test)]
mod tests {
    use std::sync::atomic::{AtomicU64, Ordering};
    use std::time::Duration;

    use rayon::prelude::*;

    use super::{POLLED_JOBS, with_hot_workers};

    /// Runs `f` on its own thread and fails if it has not returned within `limit`: a job
    /// lost between the pollers would otherwise hang the test run.
    fn within(limit: Duration, f: impl FnOnce() + Send + 'static) {
        let (done, finished) = std::sync::mpsc::channel();
        let worker = std::thread::spawn(move || {
            f();
            done.send(()).ok();
        });
        match finished.recv_timeout(limit) {
            Ok(()) => worker.join().unwrap(),
            // The sender is gone without a message: `f` panicked; show its panic.
            Err(std::sync::mpsc::RecvTimeoutError::Disconnected) => {
                std::panic::resume_unwind(worker.join().unwrap_err())
            }
            Err(std::sync::mpsc::RecvTimeoutError::Timeout) => panic!("still running after {limit:?}"),
        }
    }

    /// Nested parallel sums, the same with and without hot workers.
    fn nested_sums() -> Vec<u64> {
        let work = |k: u32| -> u64 {
            (0..2000u32)
                .into_par_iter()
                .with_max_len(16)
                .map(|i| {
                    (0..50u32)
                        .into_par_iter()
                        .map(|j| u64::from((i ^ j ^ k) % 7))
                        .sum::<u64>()
                })
                .sum()
        };
        (0..50).map(work).collect()
    }

    /// A panic in `f` reaches the caller after every job ran, the pollers stopped.
    fn a_panic_reaches_the_caller(threads: usize) {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        let ran = AtomicU64::new(0);
        let caught = pool.install(|| {
            std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                with_hot_workers(|| {
                    (0..100u32).into_par_iter().for_each(|_| {
                        ran.fetch_add(1, Ordering::Relaxed);
                    });
                    panic!("stop here");
                })
            }))
        });
        assert!(caught.is_err(), "{threads} threads");
        assert_eq!(ran.load(Ordering::Relaxed), 100);
    }

    /// Nested parallel work inside `with_hot_workers` gives what it gives without it, on
    /// pools of one to four threads (a lost job would hang or change the sums); where a
    /// core is free for one, the poller runs some of the jobs; a panic stops the pollers.
    /// One test, so that no other test's pollers add to the count of polled jobs.
    #[test]
    fn hot_workers_run_every_job_take_part_and_stop_after_a_panic() {
        within(Duration::from_mins(2), || {
            let cores = std::thread::available_parallelism().map_or(1, std::num::NonZeroUsize::get);
            for threads in 1..=4 {
                let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
                let want = pool.install(nested_sums);
                let polled_before = POLLED_JOBS.load(Ordering::Relaxed);
                let got = pool.install(|| with_hot_workers(nested_sums));
                let polled = POLLED_JOBS.load(Ordering::Relaxed) - polled_before;
                assert_eq!(got, want, "{threads} threads");
                // With a core for each, the pool's one other worker is the poller: it takes
                // part. (With more threads than cores, sleeping workers may take every job.)
                if threads == 2 && cores >= 2 {
                    assert!(polled > 0, "{threads} threads: the poller ran no job");
                }
                a_panic_reaches_the_caller(threads);
            }
        });
    }
}
