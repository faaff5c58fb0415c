//! `mfcbeam reproduce`: every scenario on the nominal models, its trace and
//! figure, and the paper's claims as numbers (each scenario measures its own,
//! see [`crate::suite::scenarios::Scenario::claims`]).

use std::path::Path;

use thiserror::Error;

use crate::io::{write_atomic, FileError};
use crate::suite::golden::csv_bytes;
use crate::suite::plots::write_figure;
use crate::suite::scenarios::{run_all, Claim, ScenarioContext, ScenarioError, Traces, SCENARIOS};

/// What can stop a reproduction.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum ReproduceError {
    #[error(transparent)]
    Scenario(#[from] ScenarioError),
    #[error(transparent)]
    File(#[from] FileError),
    #[error("{path}: {message}")]
    Figure { path: String, message: String },
}

/// The claims of every scenario, measured on full-rate traces.
pub fn claims(traces: &Traces) -> Vec<Claim> {
    SCENARIOS
        .iter()
        .filter_map(|s| traces.get(s.id).map(|t| s.claims(t, traces)))
        .flatten()
        .collect()
}

/// Run everything, write traces to `out/traces` (stored decimation) and
/// figures to `out/plots`; return the claims.
pub fn reproduce(out: &Path) -> Result<Vec<Claim>, ReproduceError> {
    let ctx = ScenarioContext::nominal();
    let traces_dir = out.join("traces");
    let plots_dir = out.join("plots");
    for d in [&traces_dir, &plots_dir] {
        std::fs::create_dir_all(d).map_err(|error| FileError::Io {
            path: d.clone(),
            error,
        })?;
    }
    let full = run_all(&ctx)?;
    for s in SCENARIOS {
        let bytes = csv_bytes(&full[s.id].decimated(s.decimation));
        write_atomic(&traces_dir.join(format!("{}.csv", s.id)), &bytes)?;
        if let Some(fig) = s.figure(&full[s.id], &full) {
            let stem = plots_dir.join(s.id);
            write_figure(&fig, &stem).map_err(|message| ReproduceError::Figure {
                path: stem.display().to_string(),
                message,
            })?;
        }
    }
    Ok(claims(&full))
}
