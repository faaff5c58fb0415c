//! Files of the command-line contract (see `docs/FILES.md`): model files (JSON) and
//! traces (CSV with one header row).
//!
//! Numbers are written in Rust's shortest round-trip form (`{:?}`), so a trace
//! read back is bit-identical. Output files are written to a temporary file in
//! the same directory and renamed into place, so a failure never leaves a
//! partial output file.

use std::fs;
use std::io::Write;
use std::path::{Path, PathBuf};

use thiserror::Error;

mod atomic;
pub mod scratch;
mod time_axis;
#[cfg(feature = "suite")]
mod trace;
pub use time_axis::{TimeAxis, TimeAxisError, MAX_JITTER, SAMPLE_TIME_AGREEMENT};
#[cfg(feature = "suite")]
pub use trace::Trace;

#[cfg(feature = "beam")]
use crate::beam::{BeamError, BeamParameters};
use crate::error::ModelError;
use crate::operators::model::{HysteresisCreepModel, ModelFile};

/// A file that cannot be read or written, or whose content is wrong. Every
/// variant names the file, and where it applies the row, column or field.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum FileError {
    #[error("{path}: {error}")]
    Io {
        path: PathBuf,
        error: std::io::Error,
    },
    #[error("{path}: malformed JSON: {message}")]
    Json { path: PathBuf, message: String },
    #[error("{path}: {error}")]
    Model { path: PathBuf, error: ModelError },
    #[cfg(feature = "beam")]
    #[error("{path}: {error}")]
    Beam { path: PathBuf, error: BeamError },
    #[error("{path}: malformed CSV: {message}")]
    Csv { path: PathBuf, message: String },
    #[error("{path}: has no data rows")]
    NoRows { path: PathBuf },
    #[error("{path}: missing column '{column}' (header has: {header})")]
    MissingColumn {
        path: PathBuf,
        column: String,
        header: String,
    },
    #[error("{path}: column '{column}' is already present")]
    ColumnExists { path: PathBuf, column: String },
    #[error("{path}: column '{column}' has {found} values for {expected} rows")]
    ColumnLength {
        path: PathBuf,
        column: String,
        expected: usize,
        found: usize,
    },
    #[error("{path}: row {row} (line {line}), column '{column}': {message}")]
    BadValue {
        path: PathBuf,
        row: usize,
        line: usize,
        column: String,
        message: String,
    },
}

/// Shortest round-trip text of an `f64` (with an exponent for very small or
/// large magnitudes).
pub fn format_f64(x: f64) -> String {
    format!("{x:?}")
}

/// Read and validate a model file.
pub fn read_model(path: &Path) -> Result<HysteresisCreepModel, FileError> {
    let file = read_model_file(path)?;
    HysteresisCreepModel::from_file(&file).map_err(|error| FileError::Model {
        path: path.to_path_buf(),
        error,
    })
}

/// Read a JSON file into `T`; errors name the file (and serde's line/field).
pub fn read_json<T: serde::de::DeserializeOwned>(path: &Path) -> Result<T, FileError> {
    let text = fs::read_to_string(path).map_err(|error| FileError::Io {
        path: path.to_path_buf(),
        error,
    })?;
    parse_json(&text).map_err(|message| FileError::Json {
        path: path.to_path_buf(),
        message,
    })
}

/// JSON text into `T`; the error names the field it is about (`delay:
/// invalid type …`, `hysteresis.weights[3]: …`) as well as serde's line
/// and column.
pub fn parse_json<T: serde::de::DeserializeOwned>(text: &str) -> Result<T, String> {
    let mut de = serde_json::Deserializer::from_str(text);
    let value = serde_path_to_error::deserialize(&mut de).map_err(|e| {
        let path = e.path().to_string();
        let inner = e.into_inner();
        if path.is_empty() || path == "." {
            inner.to_string()
        } else {
            format!("{path}: {inner}")
        }
    })?;
    de.end().map_err(|e| e.to_string())?;
    Ok(value)
}

/// Read and validate a beam file.
#[cfg(feature = "beam")]
pub fn read_beam(path: &Path) -> Result<BeamParameters, FileError> {
    let beam: BeamParameters = read_json(path)?;
    beam.validate().map_err(|error| FileError::Beam {
        path: path.to_path_buf(),
        error,
    })?;
    Ok(beam)
}

/// Read a model file without building the model.
pub fn read_model_file(path: &Path) -> Result<ModelFile, FileError> {
    read_json(path)
}

/// Write `value` as pretty JSON, atomically.
pub fn write_json<T: serde::Serialize>(path: &Path, value: &T) -> Result<(), FileError> {
    let mut text = serde_json::to_string_pretty(value).map_err(|e| FileError::Json {
        path: path.to_path_buf(),
        message: e.to_string(),
    })?;
    text.push('\n');
    write_atomic(path, text.as_bytes())
}

/// Write `bytes` to `path` atomically ([`write_atomic_with`]).
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), FileError> {
    write_atomic_with(path, |w| w.write_all(bytes))
}

/// Write `path` through `write` so that `path` is always either the old file
/// or the complete new one, and no temporary file stays behind: on Linux
/// the new content goes into an unnamed file in the same directory
/// (`O_TMPFILE`), which vanishes with the process if it is killed, and is
/// only named (then renamed over `path`) once it is complete and synced.
/// Elsewhere, or where the file system has no unnamed files, a named
/// temporary file next to `path` is used instead; it is removed on every
/// error, and one left by a killed process is removed by the next write to
/// the same path.
pub fn write_atomic_with(
    path: &Path,
    write: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
) -> Result<(), FileError> {
    atomic::write(path, write).map_err(|error| FileError::Io {
        path: path.to_path_buf(),
        error,
    })
}

/// For writers that need a path of their own (an image encoder that picks
/// the format by the extension): `write` writes a temporary path next to
/// `path`, with the same extension, which is renamed into place when it
/// succeeds and removed when it fails; one left by a killed process is
/// removed by the next write to the same path.
pub fn write_atomic_via<E>(
    path: &Path,
    write: impl FnOnce(&Path) -> Result<(), E>,
) -> Result<Result<(), E>, FileError> {
    atomic::write_via(path, write).map_err(|error| FileError::Io {
        path: path.to_path_buf(),
        error,
    })
}
