//! Worker threads kept awake between a round's parallel steps.
//!
//! A round alternates parallel steps (perceive and decide, the explored map beside step 3)
//! with sequential ones (step 3, the robot index). Between parallel steps rayon's idle
//! workers go to sleep, and the next step waits for them to wake, which is long against a
//! short round. [`with_hot_workers`] keeps them polling for work instead, at the price of a
//! busy core during the sequential steps. A [`CoreLoan`] lets another thread (a recording's
//! logging thread) have the pollers' cores while it has work.

use std::cell::Cell;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Condvar, Mutex, PoisonError};

thread_local! {
    /// This thread is polling for work in [`with_hot_workers`] already.
    static POLLING: Cell<bool> = const { Cell::new(false) };
}

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
    with_hot_workers_lending(&CoreLoan::default(), f)
}

/// [`with_hot_workers`] whose pollers sleep while `loan` is lent
/// ([`CoreLoan::lend`]): the caller then runs the parallel steps' jobs alone (rayon's
/// `join` runs what nobody took), and the borrower has the pollers' cores without waiting
/// for the scheduler to take them from busy pollers. Results do not change
/// (`lent_pollers_run_no_job_and_come_back_when_given_back`).
///
/// ```
/// use rayon::prelude::*;
/// use sim_core::engine::{CoreLoan, with_hot_workers_lending};
/// let pool = rayon::ThreadPoolBuilder::new().num_threads(2).build().unwrap();
/// let loan = CoreLoan::default();
/// loan.lend();
/// let sum: u64 = pool.install(|| with_hot_workers_lending(&loan, || (0..1000u64).into_par_iter().sum()));
/// assert_eq!(sum, 499_500);
/// ```
pub fn with_hot_workers_lending<R>(loan: &CoreLoan, f: impl FnOnce() -> R) -> R {
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
            scope.spawn(|_| poll(&stop, loan, caller));
        }
        // Stops the pollers however `f` ends (the scope waits for them).
        let _stop = StopOnDrop { stop: &stop, loan };
        f()
    })
}

/// The cores of [`with_hot_workers_lending`]'s pollers, lent to another thread while it has
/// work: [`lend`](Self::lend) when work is handed to that thread, [`give_back`](Self::give_back)
/// when it has none left. Not lent when made.
#[derive(Debug, Default)]
pub struct CoreLoan {
    lent: AtomicBool,
    /// Held while the flag is cleared or a poller decides to sleep, so no wake-up is missed.
    lock: Mutex<()>,
    given_back: Condvar,
    /// Jobs the pollers ran, for the tests to see whether they took part.
    #[cfg(test)]
    polled_jobs: std::sync::atomic::AtomicU64,
}

impl CoreLoan {
    /// Lend the pollers' cores: each poller goes to sleep once it has finished the job it
    /// runs. O(1).
    pub fn lend(&self) {
        self.lent.store(true, Ordering::Release);
    }

    /// Take the cores back: sleeping pollers wake and poll again.
    pub fn give_back(&self) {
        if self.lent.swap(false, Ordering::AcqRel) {
            self.wake_all();
        }
    }

    /// Whether the cores are lent.
    pub fn is_lent(&self) -> bool {
        self.lent.load(Ordering::Acquire)
    }

    /// Sleep while the cores are lent and `stop` is not set.
    fn sleep_while_lent(&self, stop: &AtomicBool) {
        let guard = self.lock.lock().unwrap_or_else(PoisonError::into_inner);
        let _guard = self
            .given_back
            .wait_while(guard, |()| self.is_lent() && !stop.load(Ordering::Acquire))
            .unwrap_or_else(PoisonError::into_inner);
    }

    fn wake_all(&self) {
        let _guard = self.lock.lock().unwrap_or_else(PoisonError::into_inner);
        self.given_back.notify_all();
    }
}

/// Stops the pollers when dropped, waking those asleep on the loan.
struct StopOnDrop<'a> {
    stop: &'a AtomicBool,
    loan: &'a CoreLoan,
}

impl Drop for StopOnDrop<'_> {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Release);
        self.loan.wake_all();
    }
}

/// Execute pool work as it appears until `stop`. Returns at once on the thread that runs
/// `f` (`caller`: it would wait here for itself) and on a thread polling already (one
/// poller a thread is enough), so that no thread can end up waiting on work it holds up.
fn poll(stop: &AtomicBool, loan: &CoreLoan, caller: Option<usize>) {
    if rayon::current_thread_index() == caller || POLLING.with(Cell::get) {
        return;
    }
    POLLING.with(|p| p.set(true));
    while !stop.load(Ordering::Acquire) {
        if loan.is_lent() {
            loan.sleep_while_lent(stop);
        } else if rayon::yield_now() == Some(rayon::Yield::Executed) {
            #[cfg(test)]
            loan.polled_jobs.fetch_add(1, Ordering::Relaxed);
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

    use super::{CoreLoan, with_hot_workers, with_hot_workers_lending};

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

    fn cores() -> usize {
        std::thread::available_parallelism().map_or(1, std::num::NonZeroUsize::get)
    }

    /// Nested parallel work inside `with_hot_workers` gives what it gives without it, on
    /// pools of one to four threads (a lost job would hang or change the sums); where a
    /// core is free for one, the poller runs some of the jobs; a panic stops the pollers.
    #[test]
    fn hot_workers_run_every_job_take_part_and_stop_after_a_panic() {
        within(Duration::from_mins(2), || {
            for threads in 1..=4 {
                let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
                let want = pool.install(nested_sums);
                let loan = CoreLoan::default();
                let got = pool.install(|| with_hot_workers_lending(&loan, nested_sums));
                let polled = loan.polled_jobs.load(Ordering::Relaxed);
                assert_eq!(got, want, "{threads} threads");
                // With a core for each, the pool's one other worker is the poller: it takes
                // part. (With more threads than cores, sleeping workers may take every job.)
                if threads == 2 && cores() >= 2 {
                    assert!(polled > 0, "{threads} threads: the poller ran no job");
                }
                a_panic_reaches_the_caller(threads);
            }
        });
    }

    /// While the loan is lent the poller sleeps: the caller runs every job, with the same
    /// sums; given back, the poller takes part again; a loan never given back does not keep
    /// the pollers from stopping.
    #[test]
    fn lent_pollers_run_no_job_and_come_back_when_given_back() {
        within(Duration::from_mins(2), || {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(2).build().unwrap();
            let want = pool.install(nested_sums);
            let loan = CoreLoan::default();
            loan.lend();
            let (lent, polled_while_lent, given_back) = pool.install(|| {
                with_hot_workers_lending(&loan, || {
                    let lent = nested_sums();
                    let polled = loan.polled_jobs.load(Ordering::Relaxed);
                    loan.give_back();
                    (lent, polled, nested_sums())
                })
            });
            assert_eq!(lent, want);
            assert_eq!(polled_while_lent, 0, "a poller ran jobs on lent cores");
            assert_eq!(given_back, want);
            if cores() >= 2 {
                assert!(
                    loan.polled_jobs.load(Ordering::Relaxed) > 0,
                    "the poller never came back"
                );
            }
            loan.lend();
            assert_eq!(pool.install(|| with_hot_workers_lending(&loan, nested_sums)), want);
        });
    }
}
