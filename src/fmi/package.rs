//! The `.fmu` archive: `modelDescription.xml`, the shared library under
//! `binaries/<platform>/<modelIdentifier>.so` (the standard layout, so that
//! other platforms can be added beside it), and under `resources/` the
//! configuration, the model file and, for the plant, the beam file.

use std::io::Write;
use std::path::{Path, PathBuf};

use sha2::{Digest, Sha256};
use thiserror::Error;

use super::description::{model_description, model_identifier, DescriptionInfo};
use super::variables::{BeamDiscretization, FmiVersion, FmuConfig, FmuKind, CONFIG_FILE};
use crate::beam::parameters::BeamParameters;
use crate::beam::simulation::DiscreteBeam;
use crate::beam::step_response_fit::{modal_model, BeamModelKind};
use crate::control::file::ControllerFile;
use crate::operators::model::{HysteresisCreepModel, ModelFile};

/// Why an FMU could not be built.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum PackageError {
    #[error("{path}: {reason}")]
    Library { path: String, reason: String },
    #[error("the model: {0}")]
    Model(String),
    #[error("the beam: {0}")]
    Beam(String),
    #[error("the plant needs a beam file")]
    NoBeam,
    #[error("writing the archive: {0}")]
    Archive(String),
}

/// What to package.
#[derive(Debug, Clone)]
pub struct FmuPackage {
    pub kind: FmuKind,
    pub version: FmiVersion,
    pub model: ModelFile,
    /// The plant's beam.
    pub beam: Option<BeamParameters>,
    pub beam_model: BeamModelKind,
    /// The controller's design (the controller; `model` is then unused).
    pub controller: Option<ControllerFile>,
    /// The `mfcbeam-fmu` shared library (`libmfcbeam_fmu.so`).
    pub library: PathBuf,
}

/// The shared library's file name as cargo builds it on this platform.
pub const LIBRARY_FILE: &str = "libmfcbeam_fmu.so";

/// Where the library is by default: beside the running program (cargo
/// puts the binary and the library of one build in the same folder).
pub fn default_library() -> Option<PathBuf> {
    let exe = std::env::current_exe().ok()?;
    let dir = exe.parent()?;
    [dir.join(LIBRARY_FILE), dir.join("..").join(LIBRARY_FILE)]
        .into_iter()
        .find(|p| p.is_file())
}

/// A GUID-shaped digest of everything the FMU holds, so that a description
/// and resources from different builds do not meet unnoticed.
fn token(parts: &[&[u8]]) -> String {
    let mut h = Sha256::new();
    for p in parts {
        h.update((p.len() as u64).to_le_bytes());
        h.update(p);
    }
    let d = h.finalize();
    let x: String = d[..16].iter().map(|b| format!("{b:02x}")).collect();
    format!(
        "{{{}-{}-{}-{}-{}}}",
        &x[..8],
        &x[8..12],
        &x[12..16],
        &x[16..20],
        &x[20..32]
    )
}

impl FmuPackage {
    /// The archive's bytes.
    pub fn build(&self) -> Result<Vec<u8>, PackageError> {
        let controller = match (self.kind, &self.controller) {
            (FmuKind::Controller, None) => {
                return Err(PackageError::Model(
                    "a controller FMU needs its design".into(),
                ))
            }
            (FmuKind::Controller, Some(c)) => {
                c.build().map_err(|e| PackageError::Model(e.to_string()))?;
                Some(c)
            }
            _ => None,
        };
        let model = HysteresisCreepModel::from_file(&self.model)
            .map_err(|e| PackageError::Model(e.to_string()))?;
        let library = std::fs::read(&self.library).map_err(|e| PackageError::Library {
            path: self.library.display().to_string(),
            reason: format!(
                "{e} (build it with `cargo build --release -p mfcbeam-fmu`, or give --library)"
            ),
        })?;
        let model_json = match controller {
            Some(c) => serde_json::to_vec_pretty(c),
            None => serde_json::to_vec_pretty(&self.model),
        }
        .map_err(|e| PackageError::Model(e.to_string()))?;
        let (model_name, sample_time, delay) = match controller {
            Some(c) => ("controller.json", c.sample_time, 0),
            None => ("model.json", model.sample_time(), model.preview()),
        };
        let (beam_json, modes) = match (self.kind, &self.beam) {
            (FmuKind::Plant, None) => return Err(PackageError::NoBeam),
            (FmuKind::Plant, Some(beam)) => {
                beam.validate()
                    .map_err(|e| PackageError::Beam(e.to_string()))?;
                let modal = modal_model(beam, self.beam_model)
                    .map_err(|e| PackageError::Beam(e.to_string()))?;
                let discrete = DiscreteBeam::new(&modal, model.sample_time())
                    .map_err(|e| PackageError::Beam(e.to_string()))?;
                let json = serde_json::to_vec_pretty(beam)
                    .map_err(|e| PackageError::Beam(e.to_string()))?;
                (Some(json), discrete.modes())
            }
            _ => (None, 0),
        };
        let discretization = BeamDiscretization::from(self.beam_model);
        let token = token(&[
            self.kind.name().as_bytes(),
            self.version.as_str().as_bytes(),
            &model_json,
            beam_json.as_deref().unwrap_or(&[]),
            format!("{discretization:?}").as_bytes(),
            &library,
        ]);
        let config = FmuConfig {
            kind: self.kind,
            fmi_version: self.version,
            token,
            model: model_name.into(),
            beam: beam_json.as_ref().map(|_| "beam.json".into()),
            beam_model: beam_json.as_ref().map(|_| discretization),
            modes,
        };
        let info = DescriptionInfo {
            sample_time,
            delay,
            description: match self.kind {
                FmuKind::Compensator => "The hysteresis and creep compensator W^-1 of a piezoelectric actuator (Prandtl-Ishlinskii hysteresis and creep, analytic inverse), from mfcbeam.",
                FmuKind::Model => "The actuator model W = S[H + C] + offset (Prandtl-Ishlinskii hysteresis and creep), from mfcbeam.",
                FmuKind::Plant => "The MFC-patch-driven cantilever: the actuator model W and the beam's modal model (exact zero-order-hold discretization), from mfcbeam.",
                FmuKind::Controller => "A feedback controller of the two-degrees-of-freedom loop around the compensated flatness-based feedforward of an MFC-patch-driven cantilever: from the reference and the measured tip deflection to a correction of the effective voltage, from mfcbeam.",
            }
            .into(),
            generation_tool: format!("mfcbeam {}", env!("CARGO_PKG_VERSION")),
        };
        let xml = model_description(&config, &info);
        let config_json =
            serde_json::to_vec_pretty(&config).map_err(|e| PackageError::Model(e.to_string()))?;

        let mut zip = zip::ZipWriter::new(std::io::Cursor::new(Vec::new()));
        let options = zip::write::SimpleFileOptions::default()
            .compression_method(zip::CompressionMethod::Deflated)
            .unix_permissions(0o644);
        let id = model_identifier(&config);
        let mut entries: Vec<(String, &[u8])> = vec![
            ("modelDescription.xml".into(), xml.as_bytes()),
            (
                format!("binaries/{}/{id}.so", self.version.linux64_folder()),
                &library,
            ),
            (format!("resources/{CONFIG_FILE}"), &config_json),
            (format!("resources/{model_name}"), &model_json),
        ];
        if let Some(b) = &beam_json {
            entries.push(("resources/beam.json".into(), b));
        }
        let archive = |e: &dyn std::fmt::Display| PackageError::Archive(e.to_string());
        for (name, bytes) in entries {
            zip.start_file(name, options).map_err(|e| archive(&e))?;
            zip.write_all(bytes).map_err(|e| archive(&e))?;
        }
        Ok(zip.finish().map_err(|e| archive(&e))?.into_inner())
    }

    /// Build and write the archive atomically to `path`.
    pub fn write(&self, path: &Path) -> Result<(), PackageError> {
        let bytes = self.build()?;
        crate::io::write_atomic(path, &bytes).map_err(|e| PackageError::Archive(e.to_string()))
    }
}
