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

/// How long the run waits for its logging before it asks whether the logging is starved.
pub const STARVED_AFTER: Duration = Duration::from_secs(2);

/// Tells a recording starved of the CPU: the run has waited [`STARVED_AFTER`] or more for its
/// logging threads while the process used less than a quarter of one core, and another of
/// its threads is ready to run now. Logging that merely has much to do keeps a core busy;
/// logging held up by a slow disk or network is asleep, not ready to run. Says so once.
/// Linux only (CPU time and thread states come from `/proc`); elsewhere it never does.
#[derive(Debug, Default)]
pub struct StarvationWatch {
    warned: bool,
}

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

    /// Whether, [`STARVED_AFTER`] or more into the wait, the process has used less than a
    /// quarter of a core while another of its threads is ready to run.
    fn starved(&self) -> bool {
        let wall = self.since.elapsed();
        let Some(cpu) = self
            .cpu
            .zip(process_cpu_time())
            .map(|(before, now)| now.saturating_sub(before))
        else {
            return false;
        };
        wall >= STARVED_AFTER && cpu * 4 < wall && another_thread_runnable()
    }
}

impl StarvationWatch {
    /// Warn (once) if `wait` shows the logging starved; returns whether it does.
    pub fn check(&mut self, wait: &LoggingWait) -> bool {
        let starved = wait.starved();
        if starved && !self.warned {
            self.warned = true;
            eprintln!(
                "warning: the recording has fallen behind: other programs keep every core busy and logging runs at the \
                 lowest priority, so the run waits for it ({LOGGING_PRIORITY_VAR}=normal logs at normal priority)"
            );
        }
        starved
    }
}

/// The CPU time this process has used, from `/proc/self/stat` (`None` where there is none).
fn process_cpu_time() -> Option<Duration> {
    std::fs::read_to_string("/proc/self/stat")
        .ok()
        .and_then(|s| cpu_time_of_stat(&s))
}

/// Whether a thread of this process other than the calling one is running or ready to run
/// (state `R` in `/proc/self/task/*/stat`). A thread waiting for a core is `R`; one waiting
/// for a disk, the network or a lock is not.
fn another_thread_runnable() -> bool {
    let me = std::fs::read_to_string("/proc/thread-self/stat").ok();
    let me = me.as_deref().and_then(|s| s.split_whitespace().next());
    let Ok(tasks) = std::fs::read_dir("/proc/self/task") else {
        return false;
    };
    tasks.flatten().any(|task| {
        let name = task.file_name();
        Some(name.to_string_lossy().as_ref()) != me
            && std::fs::read_to_string(task.path().join("stat")).is_ok_and(|s| state_of_stat(&s) == Some('R'))
    })
}

/// The state letter of a `/proc/PID/stat` line: the first field after the command name (in
/// parentheses, which may hold spaces and parentheses).
fn state_of_stat(stat: &str) -> Option<char> {
    stat[stat.rfind(')')? + 1..].split_whitespace().next()?.chars().next()
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

    /// The state is the first field after the name's last parenthesis.
    #[test]
    fn the_state_follows_the_name() {
        let line = "4242 (rerun (x) y) S 1 4242 4242 0 -1 4194560 1234 0 0 0 250 37 0 0 20 0 11 0 100 0 0";
        assert_eq!(state_of_stat(line), Some('S'));
        assert_eq!(state_of_stat("4242 (a) R) R 1"), Some('R'));
        assert_eq!(state_of_stat("4242 (a"), None);
    }

    /// A wait shorter than [`STARVED_AFTER`] is never starved, whatever the CPU time.
    #[test]
    fn a_short_wait_is_not_starved() {
        let mut watch = StarvationWatch::default();
        assert!(!watch.check(&LoggingWait::begin()));
        assert!(!watch.warned);
    }
}
