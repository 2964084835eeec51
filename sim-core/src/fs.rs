//! Files written whole or not at all.

use std::io::Write;
use std::path::{Path, PathBuf};

use crate::{Error, Result};

/// `path` made absolute against the working folder (as given if that cannot be read), so
/// that it names the same file from any folder later.
pub fn absolute(path: &Path) -> PathBuf {
    std::path::absolute(path).unwrap_or_else(|_| path.to_path_buf())
}

/// Write `bytes` to `path` atomically and durably: to `<path>.tmp` (which the next write
/// replaces, should a killed process leave one), flushed to disk, then renamed over `path`.
/// A reader, a resumed run or a resumed sweep sees the old file or the new one, whole. Map
/// files, checkpoints and sweep parts are all written so.
pub fn write_atomically(path: &Path, bytes: &[u8]) -> Result<()> {
    let mut tmp = path.as_os_str().to_owned();
    tmp.push(".tmp");
    let tmp = PathBuf::from(tmp);
    let io = |at: &Path| {
        let at = at.to_path_buf();
        move |cause| Error::Io { path: at, cause }
    };
    // Errors name the file asked for: the temporary one is ours, not the user's.
    let mut file = std::fs::File::create(&tmp).map_err(io(path))?;
    file.write_all(bytes).and_then(|()| file.sync_all()).map_err(io(path))?;
    drop(file);
    std::fs::rename(&tmp, path).map_err(io(path))
}
