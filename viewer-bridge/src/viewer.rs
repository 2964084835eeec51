//! Where a recording goes: an `.rrd` file, a running viewer over gRPC, or a spawned viewer.

use std::net::{SocketAddr, TcpStream, ToSocketAddrs};
use std::path::PathBuf;
use std::time::Duration;

use anyhow::{Context, Result, bail};

/// The application id every Smart Teams recording carries (recordings of one application
/// share blueprints in the viewer).
pub const APPLICATION_ID: &str = "smartteams";

/// The port a spawned viewer listens on unless `--spawn=PORT` says otherwise.
pub const DEFAULT_VIEWER_PORT: u16 = rerun::DEFAULT_SERVER_PORT;

/// The URL `--connect` uses without a value: a viewer on this machine, default port.
pub const DEFAULT_CONNECT_URL: &str = rerun::DEFAULT_CONNECT_URL;

/// One destination for the recording.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum ViewerTarget {
    /// Write an `.rrd` file.
    Rrd(PathBuf),
    /// Stream to a running viewer (`rerun+http://host:port/proxy`).
    Connect(String),
    /// Start a local viewer (the `rerun` executable on `PATH`) listening on `port` and
    /// stream to it; a viewer already listening there is used instead.
    Spawn {
        /// The viewer's port ([`DEFAULT_VIEWER_PORT`] unless asked otherwise).
        port: u16,
    },
}

impl std::fmt::Display for ViewerTarget {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ViewerTarget::Rrd(p) => write!(f, "{}", p.display()),
            ViewerTarget::Connect(url) => write!(f, "{url}"),
            ViewerTarget::Spawn { port } => write!(f, "a spawned viewer on port {port}"),
        }
    }
}

/// Turn what a user typed after `--connect` into a proxy URL: a full
/// `rerun+http(s)://…/proxy` URL is kept, `host:port` or `host` is expanded; any other
/// scheme is refused.
pub fn connect_url(arg: &str) -> Result<String> {
    let url = if arg.contains("://") {
        arg.to_owned()
    } else if arg.contains(':') {
        format!("rerun+http://{arg}/proxy")
    } else {
        format!("rerun+http://{arg}:{}/proxy", rerun::DEFAULT_SERVER_PORT)
    };
    let scheme_ok = ["rerun+http://", "rerun+https://", "rerun://"]
        .iter()
        .any(|s| url.starts_with(s));
    if !scheme_ok || authority(&url).is_none_or(str::is_empty) {
        bail!("--connect={arg}: not a Rerun viewer address (expected HOST, HOST:PORT or rerun+http://HOST:PORT/proxy)");
    }
    if let Some(port) = authority(&url).and_then(port_of)
        && port.parse::<u16>().is_err()
    {
        bail!("--connect={arg}: '{port}' is not a port (expected HOST:PORT, PORT from 0 to 65535)");
    }
    Ok(url)
}

/// The port part of `host:port` (`[v6]:port` too), if it has one.
fn port_of(authority: &str) -> Option<&str> {
    let host_end = if authority.starts_with('[') {
        authority.find(']')?
    } else {
        0
    };
    authority[host_end..].rsplit_once(':').map(|(_, port)| port)
}

/// `host:port` of a proxy URL.
fn authority(url: &str) -> Option<&str> {
    let rest = url.split_once("://")?.1;
    Some(rest.split('/').next().unwrap_or(rest))
}

/// How Rerun groups rows into chunks for an `.rrd` file: nobody watches a file while it is
/// written, so rows gather for up to 10 s (Rerun's default is 200 ms, 8 ms for a live
/// viewer). Every chunk carries its own schema, and per-robot known regions logged every 20
/// rounds would otherwise each be a chunk of their own, making the file larger and slower
/// to encode. Being explicit, it is not overridden by `RERUN_FLUSH_*` variables.
pub(crate) fn file_batching() -> rerun::log::ChunkBatcherConfig {
    rerun::log::ChunkBatcherConfig {
        flush_tick: Duration::from_secs(10),
        ..rerun::log::ChunkBatcherConfig::DEFAULT
    }
}

/// How Rerun groups rows into chunks for a live viewer: Rerun's default (rows wait at most
/// 200 ms, or until 2 MiB have gathered) rather than the SDK's low-latency setting for gRPC
/// (8 ms), which makes a chunk of nearly every row of a fast run and costs more to encode and
/// send than the rows themselves. The charts' values wait as long
/// ([`crate::rerun_observer::RerunObserver`]'s metrics window). Being explicit, it is not
/// overridden by `RERUN_FLUSH_*` variables.
pub(crate) fn live_batching() -> rerun::log::ChunkBatcherConfig {
    rerun::log::ChunkBatcherConfig::DEFAULT
}

/// Open a recording stream to `target`, with `blueprint` as its default layout.
///
/// `--connect` checks first that something listens at the address: the SDK would otherwise
/// retry for ever while buffering, and a run would stall on the full buffer.
pub fn open(
    name: &str,
    target: &ViewerTarget,
    blueprint: rerun::blueprint::Blueprint,
) -> Result<(rerun::RecordingStream, Option<ViewerLink>)> {
    crate::priority::logging_priority().map_err(anyhow::Error::msg)?;
    let builder = rerun::RecordingStreamBuilder::new(APPLICATION_ID)
        .recording_name(name)
        .with_blueprint(blueprint);
    // Rerun's threads (batching, encoding, writing) inherit the priority of the thread that
    // opens the stream: a low one, so that they take the cores the rounds leave idle.
    let (rec, link) = std::thread::scope(|s| {
        s.spawn(|| {
            crate::priority::lower_priority();
            open_stream(builder, target)
        })
        .join()
        .unwrap_or_else(|p| std::panic::resume_unwind(p))
    })?;
    // Wall-clock times would make two recordings of the same run differ; rounds are the time.
    rec.set_log_time_enabled(false);
    rec.set_log_tick_enabled(false);
    Ok((rec, link))
}

/// The stream of `builder` to `target`, with its link to the viewer if it is live.
fn open_stream(
    builder: rerun::RecordingStreamBuilder,
    target: &ViewerTarget,
) -> Result<(rerun::RecordingStream, Option<ViewerLink>)> {
    let stream = match target {
        ViewerTarget::Rrd(path) => {
            // Rerun's own error repeats itself three times over; say it once.
            if let Some(message) = crate::missing_folder("recording", path) {
                bail!(message);
            }
            if path.is_dir() {
                bail!("cannot write the recording {}: it is a folder", path.display());
            }
            let rec = builder
                .batcher_config(file_batching())
                .save(path)
                .with_context(|| format!("cannot write the recording {}", path.display()))?;
            (rec, None)
        }
        ViewerTarget::Connect(url) => {
            let Some(auth) = authority(url) else {
                bail!("not a Rerun proxy URL: {url} (expected rerun+http://HOST:PORT/proxy)");
            };
            let addrs: Vec<SocketAddr> = auth.to_socket_addrs().into_iter().flatten().collect();
            let reachable = addrs
                .iter()
                .any(|a| TcpStream::connect_timeout(a, Duration::from_secs(2)).is_ok());
            if !reachable {
                bail!("no Rerun viewer listens at {url}: start one (`rerun`) or use --spawn / --rrd");
            }
            let (rec, link) = connect(builder, url, all_loopback(&addrs))?;
            check_receiver(&rec, url)?;
            (rec, Some(link))
        }
        ViewerTarget::Spawn { port } => {
            let spawned = rerun::spawn(&rerun::SpawnOptions {
                port: *port,
                ..rerun::SpawnOptions::default()
            })
            .context("cannot start the Rerun viewer (is `rerun` on PATH? `pip install rerun-sdk==0.36.3`)")?;
            let url = format!("rerun+http://127.0.0.1:{}/proxy", spawned.port);
            let (rec, link) = connect(builder, &url, true)?;
            // Something else may be listening on the port (a viewer there is used instead).
            check_receiver(&rec, &url)?;
            (rec, Some(link))
        }
    };
    Ok(stream)
}

/// The live stream to the viewer at `url`, and its link; `local`: the viewer is on this
/// machine, and is sent the chunks as they are (Rerun LZ4-compresses every gRPC stream,
/// which costs CPU on both ends; loopback has bandwidth to spare). Other hosts get Rerun's
/// compressed stream.
fn connect(
    builder: rerun::RecordingStreamBuilder,
    url: &str,
    local: bool,
) -> Result<(rerun::RecordingStream, ViewerLink)> {
    let cannot = || format!("cannot connect to {url}");
    let rerun::external::re_uri::RedapUri::Proxy(uri) = url.parse().with_context(cannot)? else {
        bail!("not a Rerun proxy URL: {url} (expected rerun+http://HOST:PORT/proxy)");
    };
    let rec = builder
        .batcher_config(live_batching())
        .buffered()
        .with_context(cannot)?;
    let sink = ViewerSink::new(uri, local);
    // Rerun 0.36 ends a stream whose flush gave up waiting once that flush's turn comes, and
    // handing the stream its sink flushes it (giving up after 5 s of connecting): the
    // viewer is given the time to accept the connection first.
    sink.wait_connected(url)?;
    let link = ViewerLink(std::sync::Arc::downgrade(&sink.0));
    rec.set_sink(Box::new(sink));
    Ok((rec, link))
}

/// How long a viewer may take to accept the connection (a spawned one starts first).
const CONNECT_WAIT: Duration = Duration::from_secs(30);

/// Whether a host that resolved to `addrs` is this machine: each is a loopback address
/// (a name that resolved to none is not).
fn all_loopback(addrs: &[SocketAddr]) -> bool {
    !addrs.is_empty() && addrs.iter().all(|a| a.ip().is_loopback())
}

/// Rerun's gRPC sink ([`rerun::sink::GrpcSink`]), compressed or not, whose client a
/// [`ViewerLink`] can ask about the connection.
struct ViewerSink(std::sync::Arc<rerun::external::re_grpc_client::write::Client>);

impl ViewerSink {
    /// A sink to `uri`, uncompressed if `local`.
    fn new(uri: rerun::external::re_uri::ProxyUri, local: bool) -> Self {
        use rerun::external::re_grpc_client::write::{Client, Options};
        use rerun::external::re_log_encoding::rrd::Compression;
        let options = Options {
            compression: if local { Compression::Off } else { Compression::LZ4 },
            ..Options::default()
        };
        Self(std::sync::Arc::new(Client::new(uri, options)))
    }

    /// Wait until the connection to the viewer at `url` is made, at most [`CONNECT_WAIT`]. A
    /// server that refuses the stream may have ended it already: [`check_receiver`] says so.
    fn wait_connected(&self, url: &str) -> Result<()> {
        use rerun::external::re_grpc_client::write::ClientConnectionState;
        let started = std::time::Instant::now();
        while let ClientConnectionState::Connecting { .. } = self.0.status() {
            if started.elapsed() > CONNECT_WAIT {
                bail!(
                    "the viewer at {url} did not accept the connection within {} s",
                    CONNECT_WAIT.as_secs()
                );
            }
            std::thread::sleep(Duration::from_millis(10));
        }
        Ok(())
    }
}

/// A live stream's link to its viewer: whether the viewer still takes the stream. It does
/// not keep the connection open.
#[derive(Clone)]
pub struct ViewerLink(std::sync::Weak<rerun::external::re_grpc_client::write::Client>);

impl std::fmt::Debug for ViewerLink {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_tuple("ViewerLink").field(&self.lost()).finish()
    }
}

impl ViewerLink {
    /// Why the viewer no longer takes the stream (it quit, or the connection was reset), or
    /// `None` while it does, is still being reached, or the stream has ended. Costs a read
    /// of the state Rerun's client keeps of its connection.
    pub fn lost(&self) -> Option<String> {
        use rerun::external::re_grpc_client::write::ClientConnectionState;
        match self.0.upgrade()?.status() {
            ClientConnectionState::Disconnected(Err(failure)) => Some(failure.to_string()),
            ClientConnectionState::Disconnected(Ok(())) => Some("the viewer ended the connection".to_owned()),
            ClientConnectionState::Connecting { .. } | ClientConnectionState::Connected => None,
        }
    }
}

impl rerun::sink::LogSink for ViewerSink {
    fn send(&self, mut msg: rerun::log::LogMsg) {
        stamp_arrival(&mut msg);
        self.0.send_blocking(msg);
    }

    fn flush_blocking(&self, timeout: Duration) -> Result<(), rerun::sink::SinkFlushError> {
        use rerun::external::re_grpc_client::write::GrpcFlushError;
        self.0.flush_blocking(timeout).map_err(|err| match err {
            GrpcFlushError::Timeout { .. } => rerun::sink::SinkFlushError::Timeout,
            err => rerun::sink::SinkFlushError::failed(err.to_string()),
        })
    }
}

/// Stamp `msg` with the time it reached the sink, as Rerun's own gRPC sink does: the
/// viewer's ingestion statistics show that stage of a chunk's latency. Messages without
/// data are left as they are.
fn stamp_arrival(msg: &mut rerun::log::LogMsg) {
    if let Some(key) = re_sorbet::TimestampLocation::GrpcSink.metadata_key() {
        msg.insert_arrow_record_batch_metadata(key.to_owned(), re_sorbet::timestamp_metadata::now_timestamp());
    }
}

/// Fail if the server at `url` refuses the stream, as `rerun server` (a data server, not a
/// viewer's proxy) does: the SDK would otherwise drop every round and say so only at the
/// end. The refusal comes back a moment after the first messages, so the stream is flushed
/// twice, [`REFUSAL_WAIT`] apart (at most a second each). A receiver slow to take the first
/// messages is not an error here: the end of the run copes with it.
fn check_receiver(rec: &rerun::RecordingStream, url: &str) -> Result<()> {
    for wait in [Duration::ZERO, REFUSAL_WAIT] {
        std::thread::sleep(wait);
        if let Err(rerun::sink::SinkFlushError::Failed { message }) = rec.flush_with_timeout(Duration::from_secs(1)) {
            bail!(
                "{url} refused the stream: it is not a viewer (`rerun server` is a data server); \
                 stream to a viewer (`rerun`) or a headless receiver (`rerun --serve-grpc`) ({message})"
            );
        }
    }
    Ok(())
}

/// How long [`check_receiver`] gives a server to refuse a stream (a loopback server answers
/// within milliseconds).
const REFUSAL_WAIT: Duration = Duration::from_millis(100);

#[cfg(test)]
mod tests {
    use super::*;

    /// A chunk sent live carries the time it reached the sink, under Rerun's key for it.
    #[test]
    fn a_sent_chunk_is_stamped_with_its_arrival_for_the_viewers_latency_figures() {
        let (rec, storage) = rerun::RecordingStreamBuilder::new("stamp").memory().unwrap();
        rec.log("p", &rerun::Points2D::new([(1.0, 2.0)])).unwrap();
        rec.flush_blocking().unwrap();
        let before = std::time::SystemTime::now();
        let mut msg = storage
            .take()
            .into_iter()
            .find(|m| matches!(m, rerun::log::LogMsg::ArrowMsg(..)))
            .expect("a chunk was logged");
        stamp_arrival(&mut msg);
        let rerun::log::LogMsg::ArrowMsg(_, arrow) = &msg else {
            unreachable!()
        };
        let stamp = arrow
            .batch
            .schema_ref()
            .metadata()
            .get("rerun:timestamp_sdk_grpc_sink")
            .expect("stamped");
        let at = re_sorbet::timestamp_metadata::parse_timestamp(stamp).expect("Rerun's format");
        assert!(at >= before && at <= std::time::SystemTime::now(), "{stamp}");
    }

    #[test]
    fn connect_urls() {
        assert_eq!(
            connect_url("10.0.0.2:9000").unwrap(),
            "rerun+http://10.0.0.2:9000/proxy"
        );
        assert_eq!(connect_url("viewer").unwrap(), "rerun+http://viewer:9876/proxy");
        assert_eq!(connect_url(DEFAULT_CONNECT_URL).unwrap(), DEFAULT_CONNECT_URL);
        for bad in ["foo://bar", "http://host:9876/proxy", "rerun+http:///proxy"] {
            let err = connect_url(bad).unwrap_err().to_string();
            assert!(err.contains(bad) && err.contains("expected"), "{bad}: {err}");
        }
        assert_eq!(authority(DEFAULT_CONNECT_URL), Some("127.0.0.1:9876"));
        assert_eq!(connect_url("[::1]:9000").unwrap(), "rerun+http://[::1]:9000/proxy");
        for (bad, port) in [("notahost:xyz", "xyz"), ("host:70000", "70000"), ("[::1]:p", "p")] {
            let err = connect_url(bad).unwrap_err().to_string();
            assert!(err.contains(&format!("'{port}' is not a port")), "{bad}: {err}");
        }
    }

    #[test]
    fn only_addresses_of_this_machine_are_loopback() {
        let resolved = |host: &str| -> Vec<SocketAddr> { host.to_socket_addrs().unwrap().collect() };
        for local in ["127.0.0.1:9876", "127.0.0.2:1", "localhost:9876", "[::1]:9000"] {
            assert!(all_loopback(&resolved(local)), "{local}");
        }
        for remote in ["10.0.0.2:9000", "192.168.1.20:9876", "[2001:db8::1]:9876"] {
            assert!(!all_loopback(&resolved(remote)), "{remote}");
        }
        assert!(!all_loopback(&[]), "a name that resolved to nothing");
    }
}
