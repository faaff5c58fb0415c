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
    serde_json::from_str(&text).map_err(|e| FileError::Json {
        path: path.to_path_buf(),
        message: e.to_string(),
    })
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

/// Write into a temporary file next to `path`, then rename it into place.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), FileError> {
    let io = |error| FileError::Io {
        path: path.to_path_buf(),
        error,
    };
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "output".into());
    let tmp = dir.join(format!(".{name}.{}.tmp", std::process::id()));
    let result = (|| {
        let mut f = fs::File::create(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
        fs::rename(&tmp, path)
    })();
    if let Err(e) = result {
        let _ = fs::remove_file(&tmp);
        return Err(io(e));
    }
    Ok(())
}
