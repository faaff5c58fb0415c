//! Traces: CSV with one header row, held as text so that input columns pass
//! through a command unchanged.

use std::fs;
use std::path::{Path, PathBuf};

#[cfg(doc)]
use super::SAMPLE_TIME_AGREEMENT;
use super::{format_f64, write_atomic, FileError, TimeAxis};

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
        if let Some((k, name)) = header
            .iter()
            .enumerate()
            .find(|(k, h)| header[..*k].contains(h))
        {
            return Err(FileError::BadValue {
                path: path.to_path_buf(),
                row: 0,
                line: 1,
                column: name.clone(),
                message: format!("column {} repeats the name of an earlier column", k + 1),
            });
        }
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

    /// The time axis of the `t` column ([`TimeAxis::of`]); an error names
    /// the row.
    pub fn time_axis(&self) -> Result<TimeAxis, FileError> {
        let t = self.column("t")?;
        TimeAxis::of(&t).map_err(|e| FileError::BadValue {
            path: self.path.clone(),
            row: e.index + 1,
            line: e.index + 2,
            column: "t".into(),
            message: e.message,
        })
    }

    /// Check the `t` column, if present, against the sample time `ts`: its
    /// mean step must equal `ts` to [`SAMPLE_TIME_AGREEMENT`] relative.
    pub fn check_time_column(&self, ts: f64) -> Result<(), FileError> {
        // one row has no step to check
        if !self.has_column("t") || self.len() < 2 {
            return Ok(());
        }
        self.time_axis()?
            .check_sample_time(ts)
            .map_err(|message| FileError::BadValue {
                path: self.path.clone(),
                row: self.len(),
                line: self.len() + 1,
                column: "t".into(),
                message,
            })
    }

    /// The sample time from the `t` column: its mean step.
    pub fn sample_time_from_t(&self) -> Result<f64, FileError> {
        Ok(self.time_axis()?.sample_time)
    }

    /// Append a numeric column; refuses a name already present and a
    /// non-finite value (naming its row): no command writes one.
    pub fn push_column(&mut self, name: &str, values: &[f64]) -> Result<(), FileError> {
        if let Some(k) = values.iter().position(|v| !v.is_finite()) {
            return Err(FileError::BadValue {
                path: self.path.clone(),
                row: k + 1,
                line: k + 2,
                column: name.to_string(),
                message: format!(
                    "the computed value is {:?}; refusing to write a non-finite number",
                    values[k]
                ),
            });
        }
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
