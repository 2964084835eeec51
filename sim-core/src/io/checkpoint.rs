//! Checkpoint files: a run's whole state written every K rounds, atomically, so that a run
//! killed at any moment resumes from its last checkpoint to the bitwise-same final state
//! and the same complete metrics CSV as a run that was never stopped.
//!
//! A checkpoint holds how the run was set up (the config text as parsed, the `--map`,
//! `--seed` and `--rounds` overrides, a CRC-32 of the map file, which must be unchanged
//! on resume, and the files the run writes), the metrics rows so far, and the simulation's
//! state
//! ([`Simulation::write_state`]). The file:
//!
//! | bytes | what |
//! |---|---|
//! | 16 | magic `SMARTTEAMS CKPT\n` |
//! | 4 | format version, little-endian ([`CHECKPOINT_FORMAT`]) |
//! | 2 + n | length and text of the Smart Teams version that wrote it |
//! | 8 | body length, little-endian |
//! | body | CBOR header (set-up, round, metrics), then the CBOR state |
//! | 4 | CRC-32 of everything before it |
//!
//! A file from another format or version, cut short, or changed by one bit is refused
//! with an error that names it and says why.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::agent::StrategyRegistry;
use crate::engine::Simulation;
use crate::io::config::SimConfig;
use crate::io::observer::{Observer, ObserverError};
use crate::world::{RoundMetrics, RoundReport};
use crate::write_atomically;
use crate::{Error, Result};

/// The checkpoint format this build writes and reads. Raised whenever what a checkpoint
/// holds changes meaning, so that an older file is refused by name instead of misread.
/// 4: the exploration milestones are part of a run's state.
pub const CHECKPOINT_FORMAT: u32 = 4;

const MAGIC: &[u8; 16] = b"SMARTTEAMS CKPT\n";

/// The Smart Teams version checkpoints are stamped with: a file from another version is
/// refused (the state of a strategy may mean something else there).
const VERSION: &str = env!("CARGO_PKG_VERSION");

/// How a run was set up: what a resume needs to set it up again.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct RunSource {
    /// The config file, absolute (relative paths inside it resolve against its folder), so
    /// that a resume from another folder finds the map. Checkpoints of earlier versions may
    /// hold a path relative to the folder the run started in.
    pub config_path: PathBuf,
    /// The config text as the run parsed it.
    pub config_text: String,
    /// The `--map` argument, absolute, if the map did not come from the config.
    pub map_argument: Option<PathBuf>,
    /// Seed (after overrides).
    pub seed: u64,
    /// Rounds (after overrides).
    pub rounds: u64,
    /// CRC-32 of the map file (of its content, before its own checksum).
    pub map_crc32: u32,
    /// What the run writes besides its checkpoints, so that a resume writes the same
    /// without being told again (empty for a run that did not say).
    #[serde(default)]
    pub outputs: RunOutputs,
}

/// What a run writes besides its checkpoints, as the command that started it asked. Paths
/// are absolute, so that a resume from another folder writes to the same files.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct RunOutputs {
    /// The per-round metrics CSV.
    pub metrics: Option<PathBuf>,
    /// The per-robot statistics CSV.
    pub robot_stats: Option<PathBuf>,
    /// Where the recording goes, in the words of the front end that started the run (the
    /// simulation does not record); `None`: it did not say.
    pub recording: Option<String>,
    /// How much the recording holds, in the same front end's words; `None`: it did not say.
    pub logging: Option<String>,
    /// Whether the run wrote the config's `<outputs>` where it was asked for nothing else
    /// (`smartteams run` does; a Python run does not); a resume does as its run did.
    /// Checkpoints of earlier versions do not say: as `smartteams run`.
    #[serde(default = "wrote_config_outputs")]
    pub config_outputs: bool,
}

/// [`RunOutputs::config_outputs`] of checkpoints that do not say.
fn wrote_config_outputs() -> bool {
    true
}

impl RunSource {
    /// The set-up of a run of `config` (reads the map file for its checksum).
    pub fn of(config: &SimConfig) -> Result<Self> {
        Ok(Self {
            config_path: crate::absolute(&config.path),
            config_text: config.text().to_owned(),
            map_argument: config.map_argument().map(crate::absolute),
            seed: config.seed,
            rounds: config.rounds,
            map_crc32: map_crc32(config.map_path())?,
            outputs: RunOutputs::default(),
        })
    }

    /// The config this run was set up from, overrides applied.
    pub fn config(&self) -> Result<SimConfig> {
        let mut config = SimConfig::parse(&self.config_text, &self.config_path)?;
        if let Some(map) = &self.map_argument {
            config = config.with_map_argument(map.clone());
        }
        config.seed = self.seed;
        config.rounds = self.rounds;
        Ok(config)
    }
}

/// CRC-32 of a map file's bytes before its last four. Not of the whole file: a map file
/// ends with the CRC-32 of what precedes it, and the CRC-32 of any such file is one and the
/// same constant (the CRC residue), so it would tell no two maps apart.
fn map_crc32(path: &Path) -> Result<u32> {
    let bytes = std::fs::read(path).map_err(|cause| Error::Io {
        path: path.to_path_buf(),
        cause,
    })?;
    Ok(crc32fast::hash(&bytes[..bytes.len().saturating_sub(4)]))
}

/// What a checkpoint says besides the state.
#[derive(Clone, Debug, Serialize, Deserialize)]
struct Header {
    source: RunSource,
    round: u64,
    every_rounds: u64,
    metrics: Vec<RoundMetrics>,
}

/// A checkpoint read from a file and checked (format, version, checksum, header); the
/// state itself is decoded and checked against the scenario by [`resume`](Self::resume).
#[derive(Debug)]
pub struct Checkpoint {
    path: PathBuf,
    header: Header,
    state: Vec<u8>,
}

impl Checkpoint {
    /// Read and check a checkpoint file.
    pub fn read(path: &Path) -> Result<Self> {
        let bytes = std::fs::read(path).map_err(|cause| Error::Io {
            path: path.to_path_buf(),
            cause,
        })?;
        Self::from_bytes(&bytes, path)
    }

    /// Check and split a checkpoint's bytes (`path` names it in errors).
    pub fn from_bytes(bytes: &[u8], path: &Path) -> Result<Self> {
        let refuse = |problem: String| Error::Checkpoint {
            path: path.to_path_buf(),
            problem,
        };
        if bytes.len() < MAGIC.len() || &bytes[..MAGIC.len()] != MAGIC {
            return Err(refuse(
                "not a Smart Teams checkpoint (it does not start with the checkpoint magic)".into(),
            ));
        }
        let mut at = MAGIC.len();
        let mut take = |n: usize, what: &str| -> Result<&[u8]> {
            let piece = bytes
                .get(at..at.saturating_add(n))
                .ok_or_else(|| refuse(format!("cut short at byte {at}, in the {what}")))?;
            at += n;
            Ok(piece)
        };
        let format = u32::from_le_bytes(take(4, "format version")?.try_into().unwrap_or_default());
        let version_len = u16::from_le_bytes(take(2, "version")?.try_into().unwrap_or_default());
        let version = String::from_utf8_lossy(take(usize::from(version_len), "version")?).into_owned();
        if format != CHECKPOINT_FORMAT || version != VERSION {
            return Err(refuse(format!(
                "written by Smart Teams {version} (checkpoint format {format}); this is Smart Teams \
                 {VERSION}, which reads format {CHECKPOINT_FORMAT} only: resume it with the version \
                 that wrote it, or start the run again"
            )));
        }
        let body_len = u64::from_le_bytes(take(8, "body length")?.try_into().unwrap_or_default());
        let body_at = at;
        let expected = u64::try_from(body_at)
            .unwrap_or(u64::MAX)
            .saturating_add(body_len)
            .saturating_add(4);
        if u64::try_from(bytes.len()).unwrap_or(u64::MAX) != expected {
            return Err(refuse(format!(
                "{} bytes long where its header announces {expected}: cut short or extended",
                bytes.len()
            )));
        }
        let crc_at = bytes.len() - 4;
        let stored = u32::from_le_bytes(bytes[crc_at..].try_into().unwrap_or_default());
        let actual = crc32fast::hash(&bytes[..crc_at]);
        if stored != actual {
            return Err(refuse(format!(
                "corrupt: checksum {actual:08x} where the file says {stored:08x} (it was damaged after it was written)"
            )));
        }
        let mut body = &bytes[body_at..crc_at];
        let header: Header =
            ciborium::from_reader(&mut body).map_err(|e| refuse(format!("its header does not decode: {e}")))?;
        if header.round > header.source.rounds || header.every_rounds == 0 {
            return Err(refuse(format!(
                "its header is inconsistent: round {} of {}, every {} rounds",
                header.round, header.source.rounds, header.every_rounds
            )));
        }
        if u64::try_from(header.metrics.len()).ok() != Some(header.round) {
            return Err(refuse(format!(
                "it holds {} metrics rows for {} rounds",
                header.metrics.len(),
                header.round
            )));
        }
        Ok(Self {
            path: path.to_path_buf(),
            header,
            state: body.to_vec(),
        })
    }

    /// How the run was set up.
    pub fn source(&self) -> &RunSource {
        &self.header.source
    }
    /// Rounds played when it was written.
    pub fn round(&self) -> u64 {
        self.header.round
    }
    /// How often the run wrote checkpoints (rounds).
    pub fn every_rounds(&self) -> u64 {
        self.header.every_rounds
    }
    /// The metrics of every round played so far, in order.
    pub fn metrics(&self) -> &[RoundMetrics] {
        &self.header.metrics
    }
    /// The simulation's state as written (CBOR, see [`Simulation::write_state`]): two runs
    /// that reached the same state hold the same bytes.
    pub fn state(&self) -> &[u8] {
        &self.state
    }

    /// Set the run up again from `config` (normally [`RunSource::config`]) and continue it
    /// from this checkpoint. Fails if the map file changed since, or the state does not fit.
    pub fn resume(&self, config: &SimConfig, registry: &StrategyRegistry) -> Result<Simulation> {
        let crc = map_crc32(config.map_path())?;
        if crc != self.header.source.map_crc32 {
            return Err(self.refuse(format!(
                "the map file {} changed since the checkpoint was written (CRC-32 {crc:08x}, was {:08x})",
                config.map_path().display(),
                self.header.source.map_crc32
            )));
        }
        let mut sim = Simulation::new(config.scenario(registry)?)?;
        self.restore(&mut sim)?;
        Ok(sim)
    }

    /// Put this checkpoint's state into `sim`, a simulation of the same scenario. On an
    /// error `sim` may be partly restored and should be dropped.
    pub fn restore(&self, sim: &mut Simulation) -> Result<()> {
        sim.read_state(&self.state).map_err(|e| self.refuse(e.to_string()))?;
        if sim.round() != self.header.round {
            return Err(self.refuse(format!(
                "its state is at round {} and its header at round {}",
                sim.round(),
                self.header.round
            )));
        }
        Ok(())
    }

    fn refuse(&self, problem: String) -> Error {
        Error::Checkpoint {
            path: self.path.clone(),
            problem,
        }
    }
}

/// Write a checkpoint of `sim` to `path` atomically: the bytes go to a temporary file
/// beside it, which then replaces `path` in one rename, so a run killed at any moment
/// leaves either the previous checkpoint or this one, whole.
pub fn write_checkpoint(
    path: &Path,
    source: &RunSource,
    every_rounds: u64,
    metrics: &[RoundMetrics],
    sim: &Simulation,
) -> Result<()> {
    let header = Header {
        source: source.clone(),
        round: sim.round(),
        every_rounds,
        metrics: metrics.to_vec(),
    };
    let mut body = Vec::new();
    ciborium::into_writer(&header, &mut body)
        .map_err(|e| Error::Malformed(format!("cannot encode the checkpoint header: {e}")))?;
    sim.write_state(&mut body)?;
    let mut out = Vec::with_capacity(body.len() + 64);
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(&CHECKPOINT_FORMAT.to_le_bytes());
    out.extend_from_slice(&u16::try_from(VERSION.len()).unwrap_or(0).to_le_bytes());
    out.extend_from_slice(VERSION.as_bytes());
    out.extend_from_slice(&(body.len() as u64).to_le_bytes());
    out.extend_from_slice(&body);
    drop(body);
    let crc = crc32fast::hash(&out);
    out.extend_from_slice(&crc.to_le_bytes());
    write_atomically(path, &out)
}

/// The observer that writes a checkpoint every `every_rounds` rounds (the round count a
/// multiple of it), keeping the metrics of every round for the next checkpoint.
pub struct CheckpointWriter {
    path: PathBuf,
    every_rounds: u64,
    source: RunSource,
    metrics: Vec<RoundMetrics>,
    written: u64,
}

impl CheckpointWriter {
    /// Checkpoints of a run set up from `source`, to `path`, every `every_rounds` rounds
    /// (at least 1); `metrics` are the rows of the rounds already played (empty for a new
    /// run, [`Checkpoint::metrics`] for a resumed one).
    pub fn new(path: PathBuf, every_rounds: u64, source: RunSource, metrics: Vec<RoundMetrics>) -> Self {
        Self {
            path,
            every_rounds: every_rounds.max(1),
            source,
            metrics,
            written: 0,
        }
    }

    /// Checkpoints written so far.
    pub fn written(&self) -> u64 {
        self.written
    }

    /// Write a checkpoint of `sim` now, whatever the round (a run stopped early keeps what
    /// it played), unless the last one written holds this round already.
    pub fn write_now(&mut self, sim: &Simulation) -> Result<()> {
        let round = sim.round();
        if round == 0 || (self.written > 0 && round.is_multiple_of(self.every_rounds)) {
            return Ok(());
        }
        write_checkpoint(&self.path, &self.source, self.every_rounds, &self.metrics, sim)?;
        self.written += 1;
        Ok(())
    }
}

impl Observer for CheckpointWriter {
    fn on_start(&mut self, sim: &Simulation) -> Result<(), ObserverError> {
        // Refused before the first round, not at the first checkpoint.
        sim.check_checkpointable()?;
        Ok(())
    }

    fn on_round(&mut self, sim: &Simulation, report: &RoundReport) -> Result<(), ObserverError> {
        self.metrics.push(report.metrics);
        if report.round.is_multiple_of(self.every_rounds) {
            write_checkpoint(&self.path, &self.source, self.every_rounds, &self.metrics, sim)?;
            self.written += 1;
        }
        Ok(())
    }
}
