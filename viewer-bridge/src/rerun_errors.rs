//! Rerun's reports of recording files it failed to write. Rerun makes them through `tracing`,
//! which nobody reads unless a subscriber is set: its file writer stops at the first failed
//! write (a full disk, say) without a word, and a flush of the stream may then wait for
//! ever. [`watch`] keeps those reports, and a recording asks [`file_write_failure`] for its
//! own.

use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Mutex, PoisonError};

/// Rerun's reports of failed file writes, in order.
static FAILURES: Mutex<Vec<String>> = Mutex::new(Vec::new());

/// Whether [`FAILURES`] holds any: a recording asks every round, without the lock.
static ANY_FAILURE: AtomicBool = AtomicBool::new(false);

/// The module whose events report a file writer's failure (`re_log::error!` in Rerun's
/// file sink: "Failed to write log stream to PATH: …").
const FILE_SINK_TARGET: &str = "re_log_encoding::rrd::file_sink";

/// Keep Rerun's reports of failed file writes from now on, as this process's `tracing`
/// subscriber. A process that has a subscriber already keeps its own, and its recordings
/// cannot tell a failed writer; returns whether this one was set. Every other event and
/// span is turned away where it is made, at no cost.
pub fn watch() -> bool {
    tracing::subscriber::set_global_default(FileWriteFailures).is_ok()
}

/// Rerun's report that writing the recording `path` failed: the reason, as "No space left
/// on device (os error 28)". `None` if no report names it, or [`watch`] was not called.
pub fn file_write_failure(path: &Path) -> Option<String> {
    if !ANY_FAILURE.load(Ordering::Acquire) {
        return None;
    }
    let named = format!(" {}: ", path.display());
    let failures = FAILURES.lock().unwrap_or_else(PoisonError::into_inner);
    let report = failures.iter().find(|r| r.contains(&named))?;
    // Rerun nests its errors ("…: Failed to encode LogMsg: Failed to write: REASON"): the
    // last part is the reason.
    Some(report.rsplit(": ").next().unwrap_or(report).to_owned())
}

/// Keep `report`, a file writer's failure.
fn keep(report: String) {
    FAILURES.lock().unwrap_or_else(PoisonError::into_inner).push(report);
    ANY_FAILURE.store(true, Ordering::Release);
}

/// The subscriber of [`watch`]: errors of [`FILE_SINK_TARGET`] only.
struct FileWriteFailures;

impl FileWriteFailures {
    fn wanted(metadata: &tracing::Metadata<'_>) -> bool {
        metadata.is_event() && *metadata.level() == tracing::Level::ERROR && metadata.target() == FILE_SINK_TARGET
    }
}

impl tracing::Subscriber for FileWriteFailures {
    fn register_callsite(&self, metadata: &'static tracing::Metadata<'static>) -> tracing::subscriber::Interest {
        if Self::wanted(metadata) {
            tracing::subscriber::Interest::always()
        } else {
            tracing::subscriber::Interest::never()
        }
    }

    fn enabled(&self, metadata: &tracing::Metadata<'_>) -> bool {
        Self::wanted(metadata)
    }

    fn max_level_hint(&self) -> Option<tracing::level_filters::LevelFilter> {
        Some(tracing::level_filters::LevelFilter::ERROR)
    }

    // No span is ever enabled (see `enabled`); one made anyway gets an id and is not kept.
    fn new_span(&self, _span: &tracing::span::Attributes<'_>) -> tracing::span::Id {
        tracing::span::Id::from_u64(1)
    }

    fn record(&self, _span: &tracing::span::Id, _values: &tracing::span::Record<'_>) {}

    fn record_follows_from(&self, _span: &tracing::span::Id, _follows: &tracing::span::Id) {}

    fn event(&self, event: &tracing::Event<'_>) {
        if Self::wanted(event.metadata()) {
            let mut message = Message::default();
            event.record(&mut message);
            keep(message.0);
        }
    }

    fn enter(&self, _span: &tracing::span::Id) {}

    fn exit(&self, _span: &tracing::span::Id) {}
}

/// An event's `message` field, as text.
#[derive(Default)]
struct Message(String);

impl tracing::field::Visit for Message {
    fn record_str(&mut self, field: &tracing::field::Field, value: &str) {
        if field.name() == "message" {
            value.clone_into(&mut self.0);
        }
    }

    fn record_debug(&mut self, field: &tracing::field::Field, value: &dyn std::fmt::Debug) {
        if field.name() == "message" {
            self.0 = format!("{value:?}");
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A failure reported for one file is that file's, its reason the report's last part;
    /// another file has none.
    #[test]
    fn a_report_names_its_file_and_gives_the_reason() {
        keep(
            "Failed to write log stream to /data/run 7.rrd: Failed to encode LogMsg: Failed to write: No space left \
             on device (os error 28)"
                .to_owned(),
        );
        assert_eq!(
            file_write_failure(Path::new("/data/run 7.rrd")).as_deref(),
            Some("No space left on device (os error 28)")
        );
        assert_eq!(file_write_failure(Path::new("/data/run 8.rrd")), None);
        assert_eq!(file_write_failure(Path::new("/data/run")), None);
    }

    /// Only errors of Rerun's file sink are wanted.
    #[test]
    fn only_the_file_sinks_errors_are_kept() {
        let subscriber = FileWriteFailures;
        tracing::subscriber::with_default(subscriber, || {
            tracing::error!(target: "re_log_encoding::rrd::file_sink", "Failed to write log stream to /x/a.rrd: full");
            tracing::error!(target: "re_sdk::recording_stream", "Failed to write log stream to /x/b.rrd: full");
            tracing::warn!(target: "re_log_encoding::rrd::file_sink", "Failed to write log stream to /x/c.rrd: full");
        });
        assert_eq!(file_write_failure(Path::new("/x/a.rrd")).as_deref(), Some("full"));
        assert_eq!(file_write_failure(Path::new("/x/b.rrd")), None);
        assert_eq!(file_write_failure(Path::new("/x/c.rrd")), None);
    }
}
