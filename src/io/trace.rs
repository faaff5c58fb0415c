//! Traces: CSV with one header row, held as text so that input columns pass
//! through a command unchanged.

use std::fs;
use std::path::{Path, PathBuf};

#[cfg(doc)]
use super::SAMPLE_TIME_AGREEMENT;
use super::{format_f64, write_atomic_with, FileError, TimeAxis};

/// A CSV trace: input columns held as their text, so that they pass
/// through a command unchanged, computed columns as numbers. Memory is a
/// small multiple of the file's size: a text column keeps its cells'
/// bytes one after another and one end offset per cell, whatever the cell's
/// length (no allocation per cell or row).
#[derive(Debug, Clone)]
pub struct Trace {
    path: PathBuf,
    header: Vec<String>,
    rows: usize,
    columns: Vec<Column>,
}

#[derive(Debug, Clone)]
enum Column {
    /// As read: the cells' text, one after another, and where each ends.
    Text { text: String, ends: Vec<usize> },
    /// Computed: finite numbers, written in the shortest round-trip form.
    Numbers(Vec<f64>),
}

impl Column {
    fn cell(&self, k: usize) -> std::borrow::Cow<'_, str> {
        match self {
            Column::Text { text, ends } => {
                let start = if k == 0 { 0 } else { ends[k - 1] };
                std::borrow::Cow::Borrowed(&text[start..ends[k]])
            }
            Column::Numbers(v) => std::borrow::Cow::Owned(format_f64(v[k])),
        }
    }
}

impl Trace {
    /// Read a CSV trace with one header row and at least one data row.
    pub fn read(path: &Path) -> Result<Self, FileError> {
        let bytes = fs::read(path).map_err(|error| FileError::Io {
            path: path.to_path_buf(),
            error,
        })?;
        Self::parse(path, &bytes)
    }

    /// A trace from the bytes of a CSV file; `path` names it in errors.
    pub fn parse(path: &Path, bytes: &[u8]) -> Result<Self, FileError> {
        let csv_err = |e: csv::Error| FileError::Csv {
            path: path.to_path_buf(),
            message: e.to_string(),
        };
        let mut reader = csv::ReaderBuilder::new()
            .trim(csv::Trim::All)
            .from_reader(bytes);
        let header: Vec<String> = reader
            .headers()
            .map_err(csv_err)?
            .iter()
            .map(str::to_owned)
            .collect();
        // a set, not a scan per column: a file of 100 000 columns is read
        // in linear time
        let mut seen = std::collections::HashSet::with_capacity(header.len());
        if let Some((k, name)) = header
            .iter()
            .enumerate()
            .find(|(_, h)| !seen.insert(h.as_str()))
        {
            return Err(FileError::BadValue {
                path: path.to_path_buf(),
                row: 0,
                line: 1,
                column: quoted(name),
                message: format!("column {} repeats the name of an earlier column", k + 1),
            });
        }
        let mut texts = vec![(String::new(), Vec::new()); header.len()];
        let mut rows = 0;
        let mut record = csv::StringRecord::new();
        // the reader refuses a row whose number of fields differs from the header's
        while reader.read_record(&mut record).map_err(csv_err)? {
            for ((text, ends), field) in texts.iter_mut().zip(record.iter()) {
                text.push_str(field);
                ends.push(text.len());
            }
            rows += 1;
        }
        if rows == 0 {
            return Err(FileError::NoRows {
                path: path.to_path_buf(),
            });
        }
        Ok(Self {
            path: path.to_path_buf(),
            header,
            rows,
            columns: texts
                .into_iter()
                .map(|(text, ends)| Column::Text { text, ends })
                .collect(),
        })
    }

    /// [`Trace::from_columns`] taking the columns over instead of copying
    /// them (a long generated trace is held once).
    pub fn from_owned_columns(path: &Path, columns: Vec<(&str, Vec<f64>)>) -> Self {
        let rows = columns.first().map_or(0, |c| c.1.len());
        assert!(
            columns.iter().all(|c| c.1.len() == rows),
            "columns of one trace must have one length"
        );
        let header = columns.iter().map(|c| c.0.to_string()).collect();
        Self {
            path: path.to_path_buf(),
            header,
            rows,
            columns: columns.into_iter().map(|c| Column::Numbers(c.1)).collect(),
        }
    }

    /// Build a trace in memory from numeric columns of one length.
    pub fn from_columns(path: &Path, columns: &[(&str, &[f64])]) -> Self {
        Self::from_owned_columns(path, columns.iter().map(|c| (c.0, c.1.to_vec())).collect())
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
        self.rows
    }

    /// Whether the trace has no data rows.
    pub fn is_empty(&self) -> bool {
        self.rows == 0
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
                    header: header_text(&self.header),
                })?;
        let column = &self.columns[idx];
        if let Column::Numbers(v) = column {
            return Ok(v.clone());
        }
        (0..self.rows)
            .map(|k| {
                let bad = |message: String| FileError::BadValue {
                    path: self.path.clone(),
                    row: k + 1,
                    line: k + 2,
                    column: name.to_string(),
                    message,
                };
                let text = column.cell(k);
                let v: f64 = text
                    .parse()
                    .map_err(|_| bad(format!("'{}' is not a number", quoted(&text))))?;
                if v.is_finite() {
                    Ok(v)
                } else {
                    Err(bad(format!("'{}' is not a finite number", quoted(&text))))
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
        self.push_owned_column(name, values.to_vec())
    }

    /// [`Trace::push_column`] taking the values over instead of copying them.
    pub fn push_owned_column(&mut self, name: &str, values: Vec<f64>) -> Result<(), FileError> {
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
        self.check_new_column(name, values.len())?;
        self.header.push(name.to_string());
        self.columns.push(Column::Numbers(values));
        Ok(())
    }

    /// Append a column of already formatted values.
    pub fn push_text_column(
        &mut self,
        name: &str,
        values: impl IntoIterator<Item = String>,
    ) -> Result<(), FileError> {
        let (mut text, mut ends) = (String::new(), Vec::with_capacity(self.rows));
        for v in values.into_iter().take(self.rows + 1) {
            text.push_str(&v);
            ends.push(text.len());
        }
        self.check_new_column(name, ends.len())?;
        self.header.push(name.to_string());
        self.columns.push(Column::Text { text, ends });
        Ok(())
    }

    /// A new column's name must be new and its length the trace's.
    fn check_new_column(&self, name: &str, len: usize) -> Result<(), FileError> {
        if self.has_column(name) {
            return Err(FileError::ColumnExists {
                path: self.path.clone(),
                column: name.to_string(),
            });
        }
        if len != self.rows {
            return Err(FileError::ColumnLength {
                path: self.path.clone(),
                column: name.to_string(),
                expected: self.rows,
                found: len,
            });
        }
        Ok(())
    }

    /// Write the trace to `path`, atomically, row by row (no copy of the
    /// whole text in memory).
    pub fn write(&self, path: &Path) -> Result<(), FileError> {
        write_atomic_with(path, |out| {
            let mut w = csv::Writer::from_writer(out);
            w.write_record(&self.header)?;
            for k in 0..self.rows {
                for c in &self.columns {
                    w.write_field(c.cell(k).as_bytes())?;
                }
                w.write_record(None::<&[u8]>)?;
            }
            w.flush()
        })
    }
}

/// The header for a message: at most 20 names, each shortened.
fn header_text(header: &[String]) -> String {
    let mut text: Vec<String> = header.iter().take(20).map(|h| quoted(h)).collect();
    if header.len() > 20 {
        text.push(format!("… {} columns in all", header.len()));
    }
    text.join(",")
}

/// At most 40 characters of a cell, for a message of one short line.
fn quoted(text: &str) -> String {
    match text.char_indices().nth(40) {
        Some((cut, _)) => format!("{}…", &text[..cut]),
        None => text.to_string(),
    }
}
