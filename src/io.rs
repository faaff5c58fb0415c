//! Files of the command-line contract (SPEC section 11): model files (JSON) and
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

use crate::beam::{BeamError, BeamParameters};
use crate::error::ModelError;
use crate::model::{HysteresisCreepModel, ModelFile};

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

/// A CSV trace held as text, so that input columns pass through unchanged.
#[derive(Debug, Clone)]
pub struct Trace {
    path: PathBuf,
    header: Vec<String>,
    rows: Vec<Vec<String>>,
}

impl Trace {
    /// Read a CSV trace with one header row and at least one data row.
    pub fn read(path: &Path) -> Result<Self, FileError> {
        let bytes = fs::read(path).map_err(|error| FileError::Io {
            path: path.to_path_buf(),
            error,
        })?;
        let csv_err = |e: csv::Error| FileError::Csv {
            path: path.to_path_buf(),
            message: e.to_string(),
        };
        let mut reader = csv::ReaderBuilder::new()
            .trim(csv::Trim::All)
            .from_reader(bytes.as_slice());
        let header: Vec<String> = reader
            .headers()
            .map_err(csv_err)?
            .iter()
            .map(str::to_owned)
            .collect();
        let mut rows = Vec::new();
        for record in reader.records() {
            let record = record.map_err(csv_err)?;
            rows.push(record.iter().map(str::to_owned).collect());
        }
        if rows.is_empty() {
            return Err(FileError::NoRows {
                path: path.to_path_buf(),
            });
        }
        Ok(Self {
            path: path.to_path_buf(),
            header,
            rows,
        })
    }

    /// Build a trace in memory from numeric columns.
    pub fn from_columns(path: &Path, columns: &[(&str, &[f64])]) -> Self {
        let n = columns.first().map_or(0, |c| c.1.len());
        let header = columns.iter().map(|c| c.0.to_string()).collect();
        let rows = (0..n)
            .map(|k| columns.iter().map(|c| format_f64(c.1[k])).collect())
            .collect();
        Self {
            path: path.to_path_buf(),
            header,
            rows,
        }
    }

    /// The file this trace came from.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Column names.
    pub fn header(&self) -> &[String] {
        &self.header
    }

    /// Number of data rows.
    pub fn len(&self) -> usize {
        self.rows.len()
    }

    /// Whether the trace has no data rows.
    pub fn is_empty(&self) -> bool {
        self.rows.is_empty()
    }

    /// Whether a column exists.
    pub fn has_column(&self, name: &str) -> bool {
        self.header.iter().any(|h| h == name)
    }

    /// A numeric column; every value must parse and be finite.
    pub fn column(&self, name: &str) -> Result<Vec<f64>, FileError> {
        let idx =
            self.header
                .iter()
                .position(|h| h == name)
                .ok_or_else(|| FileError::MissingColumn {
                    path: self.path.clone(),
                    column: name.to_string(),
                    header: self.header.join(","),
                })?;
        self.rows
            .iter()
            .enumerate()
            .map(|(k, row)| {
                let bad = |message: String| FileError::BadValue {
                    path: self.path.clone(),
                    row: k + 1,
                    line: k + 2,
                    column: name.to_string(),
                    message,
                };
                let text = &row[idx];
                let v: f64 = text
                    .parse()
                    .map_err(|_| bad(format!("'{text}' is not a number")))?;
                if v.is_finite() {
                    Ok(v)
                } else {
                    Err(bad(format!("'{text}' is not a finite number")))
                }
            })
            .collect()
    }

    /// Check the `t` column, if present, against the sample time `ts`: uniform
    /// steps of `ts` to 1e-6 relative.
    pub fn check_time_column(&self, ts: f64) -> Result<(), FileError> {
        if !self.has_column("t") {
            return Ok(());
        }
        let t = self.column("t")?;
        for k in 1..t.len() {
            let dt = t[k] - t[k - 1];
            if (dt - ts).abs() > 1e-6 * ts {
                return Err(FileError::BadValue {
                    path: self.path.clone(),
                    row: k + 1,
                    line: k + 2,
                    column: "t".into(),
                    message: format!("time step {dt:?} s differs from the sample time {ts:?} s"),
                });
            }
        }
        Ok(())
    }

    /// The sample time from the `t` column: `(t_last − t_first)/(N − 1)`,
    /// which must be positive and every step equal to it to 1e-6 relative.
    pub fn sample_time_from_t(&self) -> Result<f64, FileError> {
        let t = self.column("t")?;
        let bad = |k: usize, message: String| FileError::BadValue {
            path: self.path.clone(),
            row: k + 1,
            line: k + 2,
            column: "t".into(),
            message,
        };
        if t.len() < 2 {
            return Err(bad(
                0,
                "at least two samples are needed for a sample time".into(),
            ));
        }
        let ts = (t[t.len() - 1] - t[0]) / (t.len() - 1) as f64;
        if ts.is_nan() || ts <= 0.0 {
            return Err(bad(
                t.len() - 1,
                format!("time does not increase (sample time {ts:?} s)"),
            ));
        }
        self.check_time_column(ts)?;
        Ok(ts)
    }

    /// Append a numeric column; refuses a name already present.
    pub fn push_column(&mut self, name: &str, values: &[f64]) -> Result<(), FileError> {
        self.push_text_column(name, values.iter().map(|&v| format_f64(v)))
    }

    /// Append a column of already formatted values.
    pub fn push_text_column(
        &mut self,
        name: &str,
        values: impl IntoIterator<Item = String>,
    ) -> Result<(), FileError> {
        if self.has_column(name) {
            return Err(FileError::ColumnExists {
                path: self.path.clone(),
                column: name.to_string(),
            });
        }
        self.header.push(name.to_string());
        let mut count = 0;
        for (row, v) in self.rows.iter_mut().zip(values) {
            row.push(v);
            count += 1;
        }
        assert_eq!(count, self.rows.len(), "column length must match the trace");
        Ok(())
    }

    /// Write the trace to `path`, atomically.
    pub fn write(&self, path: &Path) -> Result<(), FileError> {
        let mut out = Vec::with_capacity(self.rows.len() * 16 * self.header.len());
        let mut w = csv::Writer::from_writer(&mut out);
        let csv_err = |e: csv::Error| FileError::Csv {
            path: path.to_path_buf(),
            message: e.to_string(),
        };
        w.write_record(&self.header).map_err(csv_err)?;
        for row in &self.rows {
            w.write_record(row).map_err(csv_err)?;
        }
        w.flush().map_err(|error| FileError::Io {
            path: path.to_path_buf(),
            error,
        })?;
        drop(w);
        write_atomic(path, &out)
    }
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
