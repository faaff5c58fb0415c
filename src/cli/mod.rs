//! The `mfcbeam` command line: [`args`] defines the arguments, [`commands`]
//! carries them out (the larger commands in files of their own:
//! [`identify`], [`conform`], [`hosted`], [`fmu`], [`control`], [`bench`]). Errors end the program with exit code 2 and one line on
//! stderr naming the file, row or field.

pub mod args;
pub mod bench;
pub mod commands;
pub mod conform;
pub mod control;
pub mod fmu;
pub mod hosted;
pub mod identify;

pub use args::Cli;
pub use commands::run;

use anyhow::{bail, Result};
use mfcbeam::io::Trace;

/// An exit code without an error message: the command has printed its
/// report (`conform` exits 1 when a property fails).
#[derive(Debug)]
pub struct Exit(pub i32);

impl std::fmt::Display for Exit {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "exit code {}", self.0)
    }
}

impl std::error::Error for Exit {}

/// The sample time of a trace: `--sample-time` if given (checked against the
/// `t` column, if any), else from the `t` column, else `fallback` (an error
/// when there is none).
pub(crate) fn trace_sample_time(
    trace: &Trace,
    flag: Option<f64>,
    fallback: Option<f64>,
) -> Result<f64> {
    match flag {
        Some(ts) => {
            if !(ts.is_finite() && ts > 0.0) {
                bail!("--sample-time: must be a finite number > 0, found {ts}");
            }
            trace.check_time_column(ts)?;
            Ok(ts)
        }
        None if trace.has_column("t") => Ok(trace.sample_time_from_t()?),
        None => match fallback {
            Some(ts) => Ok(ts),
            // names the missing column
            None => Ok(trace.sample_time_from_t()?),
        },
    }
}
