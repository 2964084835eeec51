//! The priority of the threads that log a run, and telling when it starves a recording.
//!
//! Logging runs at the lowest priority by default, so that it takes only the cores the rounds
//! leave idle. While other programs keep every core busy it then gets none, and the run waits
//! for its recording: [`StarvationWatch`] says so once, naming [`LOGGING_PRIORITY_VAR`].

use std::time::{Duration, Instant};

/// The environment variable that sets the logging threads' priority: `idle` (the default,
/// see [`lower_priority`]) or `normal`, for a machine whose cores other programs keep busy.
pub const LOGGING_PRIORITY_VAR: &str = "SMARTTEAMS_LOGGING_PRIORITY";

/// Whether the logging threads run at the lowest priority ([`LOGGING_PRIORITY_VAR`] unset or
/// `idle`) or at normal priority (`normal`); an error names the variable and its values.
pub fn logging_priority() -> Result<LoggingPriority, String> {
    let Some(value) = std::env::var_os(LOGGING_PRIORITY_VAR) else {
        return Ok(LoggingPriority::Idle);
    };
    match value.to_str() {
        Some(v) if v.eq_ignore_ascii_case("idle") => Ok(LoggingPriority::Idle),
        Some(v) if v.eq_ignore_ascii_case("normal") => Ok(LoggingPriority::Normal),
        _ => Err(format!(
            "{LOGGING_PRIORITY_VAR}={}: expected `idle` or `normal`",
            value.to_string_lossy()
        )),
    }
}

/// The priority of the threads that log a run (see [`logging_priority`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LoggingPriority {
    /// The lowest: logging takes only the cores the rounds leave idle, and waits while other
    /// programs keep every core busy.
    Idle,
    /// The threads' own, as other programs' threads have.
    Normal,
}

/// Lower the calling thread's scheduling priority to the least, unless
/// [`LOGGING_PRIORITY_VAR`] says `normal`: logging runs beside the rounds without taking
/// their cores. On Linux that is `SCHED_IDLE`, which a waking round thread preempts at once
/// (a nice-19 thread keeps the core to the end of its slice, about a millisecond, while the
/// round waits for the thread it holds up); elsewhere the lowest priority. Where neither is
/// allowed, nothing. Irreversible for a process without `CAP_SYS_NICE`.
pub fn lower_priority() {
    if logging_priority() == Ok(LoggingPriority::Normal) {
        return;
    }
    #[cfg(target_os = "linux")]
    let idle = thread_priority::set_thread_priority_and_policy(
        thread_priority::thread_native_id(),
        thread_priority::ThreadPriority::Min,
        thread_priority::ThreadSchedulePolicy::Normal(thread_priority::NormalThreadSchedulePolicy::Idle),
    );
    #[cfg(not(target_os = "linux"))]
    let idle: Result<(), ()> = Err(());
    if idle.is_err() {
        let _ = thread_priority::set_current_thread_priority(thread_priority::ThreadPriority::Min);
    }
}

/// How long the run may wait for its logging, in all, before it asks whether the logging is
/// starved.
pub const STARVED_AFTER: Duration = Duration::from_secs(2);

/// How often a wait past [`STARVED_AFTER`] asks again whether the logging is starved: its
/// first check only notes the threads' run-queue waits, and a wait may starve after it.
const RECHECK_EVERY: Duration = Duration::from_millis(250);

/// Waits shorter than this are not counted: the process's CPU time comes in ticks of 10 ms,
/// too coarse to tell how a shorter wait was spent, and a starved logging makes long waits.
const COUNTED_FROM: Duration = Duration::from_millis(10);

/// Tells a recording starved of the CPU: the run's waits for its logging (opening the
/// stream, handing it rounds, closing it) add up to [`STARVED_AFTER`] or more, the process
/// used less than a quarter of one core in them (or the same holds of the wait going on
/// alone), and since the wait was first checked its threads have waited for a core, ready
/// to run, for at least half the time. Logging that merely has much to do keeps a core
/// busy; logging held up by a slow or full disk, a network or a stuck writer sleeps, and
/// does not wait for a core. Says so once. Linux only (CPU time and the run queue's waits
/// come from `/proc`); elsewhere it never does.
///
/// Adding the waits up matters for a short run: its recording's work falls into a few
/// waits, each of which may stay under [`STARVED_AFTER`] while together they double the run.
/// The run queue's waits are read only from a wait's first check on: reading every thread's
/// counter costs a file a thread, too much for every hand-off that blocks.
#[derive(Debug, Default)]
pub struct StarvationWatch {
    warned: bool,
    /// Wall and CPU time of the counted waits that have ended.
    waited: Duration,
    waited_cpu: Duration,
    /// The threads' run-queue waits at the first check of the wait going on.
    queued_at_first_check: Option<QueueSample>,
}

/// Each thread's time spent ready to run but waiting for a core, read at `at` during the
/// wait that began at `wait_since`.
#[derive(Debug)]
struct QueueSample {
    wait_since: Instant,
    at: Instant,
    threads: Vec<ThreadQueued>,
}

/// A thread's id and its time in the run queue so far (`run_delay` of its schedstat).
type ThreadQueued = (u32, Duration);

/// A wait of the run for its logging, begun at `since` with the process's CPU time `cpu`.
#[derive(Clone, Copy, Debug)]
pub struct LoggingWait {
    since: Instant,
    cpu: Option<Duration>,
}

impl LoggingWait {
    /// A wait beginning now.
    pub fn begin() -> Self {
        Self {
            since: Instant::now(),
            cpu: process_cpu_time(),
        }
    }

    /// Wall and CPU time since the wait began (`None` without the process's CPU time).
    fn so_far(&self) -> Option<(Duration, Duration)> {
        let (before, now) = self.cpu.zip(process_cpu_time())?;
        Some((self.since.elapsed(), now.saturating_sub(before)))
    }
}

impl StarvationWatch {
    /// How long `wait` may go on before the next [`StarvationWatch::check`]: until the waits
    /// add up to [`STARVED_AFTER`], then 250 ms at a time.
    pub fn next_check(&self, wait: &LoggingWait) -> Duration {
        let left = STARVED_AFTER.saturating_sub(self.waited + wait.since.elapsed());
        if left.is_zero() { RECHECK_EVERY } else { left }
    }

    /// Wait through `within` until it returns what was awaited, checking for starvation
    /// each time it returns `None`. `within` waits at most the time it is given
    /// ([`StarvationWatch::next_check`]) and returns `None` when that time ran out. Does not
    /// [`end`](StarvationWatch::end) `wait`, which may go on through other waits.
    pub fn wait_through<T>(&mut self, wait: &LoggingWait, mut within: impl FnMut(Duration) -> Option<T>) -> T {
        loop {
            if let Some(out) = within(self.next_check(wait)) {
                return out;
            }
            self.check(wait);
        }
    }

    /// Warn (once) if the waits so far, `wait` included, show the logging starved, or
    /// `wait` alone does (a long run whose logging starves midway, after waits in which it
    /// kept a core busy); returns whether they do.
    pub fn check(&mut self, wait: &LoggingWait) -> bool {
        self.check_with(wait, threads_queued)
    }

    /// [`check`](Self::check), reading the threads' run-queue waits with `threads_queued`.
    fn check_with(&mut self, wait: &LoggingWait, threads_queued: impl FnOnce() -> Option<Vec<ThreadQueued>>) -> bool {
        let idle = |wall: Duration, cpu: Duration| wall >= STARVED_AFTER && cpu * 4 < wall;
        let idle_in_waits = wait
            .so_far()
            .is_some_and(|(wall, cpu)| idle(wall, cpu) || idle(self.waited + wall, self.waited_cpu + cpu));
        let starved = idle_in_waits && threads_queued().is_some_and(|now| self.kept_waiting_for_a_core(wait, now));
        if starved && !self.warned {
            self.warned = true;
            eprintln!(
                "warning: the recording has fallen behind: other programs keep every core busy and logging runs at the \
                 lowest priority, so the run waits for it ({LOGGING_PRIORITY_VAR}=normal logs at normal priority)"
            );
        }
        starved
    }

    /// Whether the threads, `now`, have waited for a core for at least half the time since
    /// `wait` was first checked. The first check only notes their waits so far. A thread
    /// begun since counts its whole wait; one ended since counts nothing.
    fn kept_waiting_for_a_core(&mut self, wait: &LoggingWait, now: Vec<ThreadQueued>) -> bool {
        let Some(first) = self
            .queued_at_first_check
            .as_ref()
            .filter(|q| q.wait_since == wait.since)
        else {
            self.queued_at_first_check = Some(QueueSample {
                wait_since: wait.since,
                at: Instant::now(),
                threads: now,
            });
            return false;
        };
        let queued: Duration = now
            .iter()
            .map(|&(id, total)| {
                let before = first.threads.iter().find(|t| t.0 == id).map_or(Duration::ZERO, |t| t.1);
                total.saturating_sub(before)
            })
            .sum();
        !queued.is_zero() && queued * 2 >= first.at.elapsed()
    }

    /// Count `wait`, which has ended, if it lasted 10 ms or more (one tick of CPU time).
    pub fn end(&mut self, wait: &LoggingWait) {
        if wait.since.elapsed() < COUNTED_FROM {
            return;
        }
        if let Some((wall, cpu)) = wait.so_far() {
            self.waited += wall;
            self.waited_cpu += cpu;
        }
    }
}

/// The CPU time this process has used, from `/proc/self/stat` (`None` where there is none).
fn process_cpu_time() -> Option<Duration> {
    std::fs::read_to_string("/proc/self/stat")
        .ok()
        .and_then(|s| cpu_time_of_stat(&s))
}

/// Each thread of this process with its time spent ready to run but waiting for a core so
/// far (`/proc/self/task/*/schedstat`: time on a core, time waiting in the run queue, slices,
/// in nanoseconds); `None` where there is no such file.
fn threads_queued() -> Option<Vec<ThreadQueued>> {
    let tasks = std::fs::read_dir("/proc/self/task").ok()?;
    let threads: Vec<ThreadQueued> = tasks
        .flatten()
        .filter_map(|task| {
            let id = task.file_name().to_str()?.parse().ok()?;
            let schedstat = std::fs::read_to_string(task.path().join("schedstat")).ok()?;
            Some((id, queued_of_schedstat(&schedstat)?))
        })
        .collect();
    (!threads.is_empty()).then_some(threads)
}

/// The run-queue wait of a `schedstat` line: its second field, in nanoseconds.
fn queued_of_schedstat(schedstat: &str) -> Option<Duration> {
    let ns = schedstat.split_whitespace().nth(1)?.parse().ok()?;
    Some(Duration::from_nanos(ns))
}

/// User plus system time of a `/proc/PID/stat` line, in the kernel's clock ticks of 1/100 s
/// (`USER_HZ`, 100 on every Linux architecture). The command name, in parentheses, may hold
/// spaces and parentheses: fields are counted after its last `)`.
fn cpu_time_of_stat(stat: &str) -> Option<Duration> {
    let rest = &stat[stat.rfind(')')? + 1..];
    // After the name: state (field 3) first, so utime (14) and stime (15) are the 12th and 13th.
    let mut fields = rest.split_whitespace().skip(11);
    let utime: u64 = fields.next()?.parse().ok()?;
    let stime: u64 = fields.next()?.parse().ok()?;
    Some(Duration::from_millis((utime + stime) * 10))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Fields 14 and 15 of a stat line whose command name holds spaces and a parenthesis:
    /// 250 + 37 ticks of 10 ms.
    #[test]
    fn cpu_time_is_user_plus_system_ticks_after_the_name() {
        let line = "4242 (rerun (x) y) S 1 4242 4242 0 -1 4194560 1234 0 0 0 250 37 0 0 20 0 11 0 100 0 0";
        assert_eq!(cpu_time_of_stat(line), Some(Duration::from_millis(2870)));
        assert_eq!(cpu_time_of_stat("4242 (x) S 1"), None);
    }

    /// The run-queue wait is a schedstat line's second field, in nanoseconds.
    #[test]
    fn the_run_queue_wait_is_the_second_schedstat_field() {
        assert_eq!(queued_of_schedstat("383977 250 1\n"), Some(Duration::from_nanos(250)));
        assert_eq!(queued_of_schedstat("383977"), None);
    }

    /// This process's threads, the calling one among them, have run-queue counters.
    #[cfg(target_os = "linux")]
    #[test]
    fn every_thread_has_a_run_queue_wait() {
        let threads = threads_queued().expect("/proc/self/task/*/schedstat");
        let me: u32 = std::fs::read_link("/proc/thread-self")
            .ok()
            .and_then(|p| p.file_name()?.to_str()?.parse().ok())
            .expect("/proc/thread-self names the calling thread");
        assert!(threads.iter().any(|t| t.0 == me), "{threads:?}");
    }

    /// A wait shorter than [`STARVED_AFTER`] is never starved, whatever the CPU time.
    #[test]
    fn a_short_wait_is_not_starved() {
        let mut watch = StarvationWatch::default();
        assert!(!watch.check(&LoggingWait::begin()));
        assert!(!watch.warned);
    }

    /// A wait begun `ago`, the process's CPU time taken now (none of it spent in the wait).
    fn idle_wait_begun(ago: Duration) -> LoggingWait {
        LoggingWait {
            since: Instant::now()
                .checked_sub(ago)
                .expect("the monotonic clock is past `ago`"),
            cpu: process_cpu_time(),
        }
    }

    /// A reading of the run queue's waits: one thread (id 7) has waited `ms` so far.
    fn queued_ms(ms: u64) -> impl FnOnce() -> Option<Vec<ThreadQueued>> {
        move || Some(vec![(7, Duration::from_millis(ms))])
    }

    /// Waits add up: after an idle wait of 1.5 s, the next check of a new wait comes 0.5 s
    /// into it, and a new idle wait of 0.6 s whose thread then waits for a core is starved,
    /// though neither wait alone reaches [`STARVED_AFTER`]. The first check of a wait only
    /// notes the run queue's waits. Past the limit, checks come [`RECHECK_EVERY`] apart.
    #[test]
    fn waits_add_up_to_the_starvation_limit() {
        let mut watch = StarvationWatch::default();
        watch.end(&idle_wait_begun(Duration::from_millis(1500)));
        let left = watch.next_check(&LoggingWait::begin());
        assert!(
            left <= Duration::from_millis(500) && left > Duration::from_millis(400),
            "{left:?}"
        );
        assert!(!watch.check_with(&idle_wait_begun(Duration::from_millis(100)), queued_ms(900)));
        let wait = idle_wait_begun(Duration::from_millis(600));
        assert!(!watch.check_with(&wait, queued_ms(10)));
        assert!(watch.check_with(&wait, queued_ms(1000)));
        assert!(watch.warned);
        assert_eq!(watch.next_check(&wait), RECHECK_EVERY);
    }

    /// An idle wait whose threads sleep (a stuck or slow writer), waiting for no core, is not
    /// starved however long it lasts.
    #[test]
    fn an_idle_wait_whose_threads_sleep_is_not_starved() {
        let mut watch = StarvationWatch::default();
        let wait = idle_wait_begun(Duration::from_secs(30));
        assert!(!watch.check_with(&wait, queued_ms(5)));
        std::thread::sleep(Duration::from_millis(20));
        assert!(!watch.check_with(&wait, queued_ms(5)));
        assert!(!watch.warned);
    }

    /// Since a wait's first check, a thread begun meanwhile counts its whole run-queue wait,
    /// one ended meanwhile counts nothing, and the queued time must reach half the time gone.
    #[test]
    fn run_queue_waits_count_per_thread_since_the_first_check() {
        let ms = Duration::from_millis;
        let mut watch = StarvationWatch::default();
        let wait = idle_wait_begun(Duration::from_secs(3));
        assert!(!watch.kept_waiting_for_a_core(&wait, vec![(1, ms(100)), (2, ms(50))]));
        assert!(watch.kept_waiting_for_a_core(&wait, vec![(1, ms(100)), (3, ms(30))]));
        assert!(!watch.kept_waiting_for_a_core(&wait, vec![(1, ms(100))]));
        std::thread::sleep(ms(100));
        assert!(!watch.kept_waiting_for_a_core(&wait, vec![(1, ms(120))]));
        assert!(watch.kept_waiting_for_a_core(&wait, vec![(1, ms(600))]));
        // A new wait starts over.
        let next = idle_wait_begun(Duration::from_secs(3));
        assert!(!watch.kept_waiting_for_a_core(&next, vec![(1, ms(900))]));
    }

    /// A wait past [`STARVED_AFTER`] is checked every [`RECHECK_EVERY`] until it ends, here
    /// after three tries; `wait_through` returns what the wait gave.
    #[test]
    fn a_wait_is_checked_again_until_it_ends() {
        let mut watch = StarvationWatch {
            waited: Duration::from_secs(3),
            ..StarvationWatch::default()
        };
        let wait = LoggingWait::begin();
        let mut timeouts = Vec::new();
        let given = watch.wait_through(&wait, |timeout| {
            timeouts.push(timeout);
            (timeouts.len() == 3).then_some(42)
        });
        assert_eq!(given, 42);
        assert_eq!(timeouts, [RECHECK_EVERY; 3]);
    }

    /// A wait of [`STARVED_AFTER`] in which the process was idle is starved on its own, even
    /// after earlier waits in which the logging kept a core busy (their CPU time counted
    /// as their wall time).
    #[test]
    fn an_idle_wait_is_starved_after_busy_ones() {
        let mut watch = StarvationWatch {
            waited: Duration::from_mins(1),
            waited_cpu: Duration::from_mins(1),
            ..StarvationWatch::default()
        };
        assert!(!watch.check_with(&idle_wait_begun(Duration::from_millis(1900)), queued_ms(0)));
        let wait = idle_wait_begun(STARVED_AFTER);
        assert!(!watch.check_with(&wait, queued_ms(0)));
        assert!(watch.check_with(&wait, queued_ms(500)));
    }

    /// A wait shorter than [`COUNTED_FROM`] is not counted.
    #[test]
    fn a_wait_shorter_than_a_cpu_tick_is_not_counted() {
        let mut watch = StarvationWatch::default();
        watch.end(&LoggingWait::begin());
        assert_eq!(watch.waited, Duration::ZERO);
        watch.end(&idle_wait_begun(Duration::from_millis(300)));
        assert!(watch.waited >= Duration::from_millis(300), "{:?}", watch.waited);
    }
}
