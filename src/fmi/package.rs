//! The `.fmu` archive: `modelDescription.xml`, the shared library of each
//! platform under `binaries/<folder>/<modelIdentifier>.<so|dll|dylib>`
//! ([`Platform::folder`]), and under `resources/` the configuration, the
//! model file and, for the plant, the beam file and its discretization.
//! The description is the same for every platform.

use std::io::Write;
use std::path::{Path, PathBuf};

use sha2::{Digest, Sha256};
use thiserror::Error;

use super::description::{model_description, model_identifier, DescriptionInfo};
use super::platform::Platform;
use super::variables::{BeamDiscretization, FmiVersion, FmuConfig, FmuKind, CONFIG_FILE};
use crate::beam::parameters::BeamParameters;
use crate::beam::simulation::DiscreteBeam;
use crate::beam::step_response_fit::{modal_model, BeamModelKind};
use crate::control::file::ControllerFile;
use crate::operators::model::{HysteresisCreepModel, ModelFile};

/// The plant's discretized beam under `resources/`, what its instances
/// load (`resources/beam.json`, the beam it came from, is for the reader).
pub const DISCRETE_BEAM_FILE: &str = "discrete_beam.json";

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
    /// The `mfcbeam-fmu` shared library of each platform, at least one
    /// ([`ReleaseFolder::find`] finds a release folder's).
    pub libraries: Vec<(Platform, PathBuf)>,
}

/// The FMU library's crate name (`cargo build --release -p mfcbeam-fmu`).
pub const LIBRARY_NAME: &str = "mfcbeam_fmu";

/// A cargo target folder to take the libraries from: the cross builds
/// under `<target>/<rust target>/release/`, and this machine's platform
/// from `profile` (`<target>/release/`, or the folder of the running
/// program).
#[derive(Debug, Clone, PartialEq)]
pub struct ReleaseFolder {
    pub target: PathBuf,
    pub profile: PathBuf,
}

impl ReleaseFolder {
    /// The release builds of the target folder `target`.
    pub fn new(target: &Path) -> Self {
        Self {
            target: target.to_path_buf(),
            profile: target.join("release"),
        }
    }

    /// The target folder this program was built into: it runs from
    /// `<target>/<profile>/`, where cargo put the host's library beside it.
    pub fn of_this_program() -> Option<Self> {
        let exe = std::env::current_exe().ok()?;
        let profile = exe.parent()?.to_path_buf();
        let target = profile.parent()?.to_path_buf();
        Some(Self { target, profile })
    }

    /// Where `platform`'s library would be, first match first.
    pub fn candidates(&self, platform: Platform) -> Vec<PathBuf> {
        let file = platform.library_file(LIBRARY_NAME);
        let mut paths = Vec::new();
        if Platform::host() == Some(platform) {
            paths.push(self.profile.join(&file));
        }
        paths.push(
            self.target
                .join(platform.rust_target())
                .join("release")
                .join(&file),
        );
        paths
    }

    /// The libraries of `platforms` found here, and the platforms that
    /// have none.
    pub fn find(&self, platforms: &[Platform]) -> (Vec<(Platform, PathBuf)>, Vec<Platform>) {
        let mut found = Vec::new();
        let mut missing = Vec::new();
        for &p in platforms {
            match self.candidates(p).into_iter().find(|c| c.is_file()) {
                Some(path) => found.push((p, path)),
                None => missing.push(p),
            }
        }
        (found, missing)
    }
}

/// How to build a platform's library on a Linux machine with its toolchain
/// (`docs/guide/deploy.md`).
pub fn build_command(platform: Platform) -> String {
    match Platform::host() {
        Some(h) if h == platform => "cargo build --release -p mfcbeam-fmu".into(),
        _ => format!(
            "cargo build --release -p mfcbeam-fmu --target {}",
            platform.rust_target()
        ),
    }
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
    /// The platforms it holds, in the archive's order.
    pub fn platforms(&self) -> Vec<Platform> {
        let mut p: Vec<_> = self.libraries.iter().map(|(p, _)| *p).collect();
        p.sort();
        p
    }

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
        if self.libraries.is_empty() {
            return Err(PackageError::Library {
                path: "--platforms".into(),
                reason: "no platform's library to pack".into(),
            });
        }
        let mut libraries: Vec<(Platform, Vec<u8>)> = Vec::new();
        for (platform, path) in &self.libraries {
            let bad = |reason: String| PackageError::Library {
                path: path.display().to_string(),
                reason,
            };
            if libraries.iter().any(|(p, _)| p == platform) {
                return Err(bad(format!("a second library for {platform}")));
            }
            let bytes = std::fs::read(path).map_err(|e| {
                bad(format!(
                    "{e} (build it with `{}`)",
                    build_command(*platform)
                ))
            })?;
            match super::platform::check_library(&bytes) {
                Ok(p) if p == *platform => {}
                Ok(p) => return Err(bad(format!("a library for {p}, not for {platform}"))),
                Err(what) => return Err(bad(format!("{what}, not a library for {platform}"))),
            }
            libraries.push((*platform, bytes));
        }
        libraries.sort_by_key(|(p, _)| *p);
        let model_json = match controller {
            Some(c) => serde_json::to_vec_pretty(c),
            None => serde_json::to_vec_pretty(&self.model),
        }
        .map_err(|e| PackageError::Model(e.to_string()))?;
        let (model_name, sample_time, delay) = match controller {
            Some(c) => ("controller.json", c.sample_time, 0),
            None => ("model.json", model.sample_time(), model.preview()),
        };
        let (beam_json, discrete_json, modes) = match (self.kind, &self.beam) {
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
                let discrete_json = serde_json::to_vec_pretty(&discrete.file())
                    .map_err(|e| PackageError::Beam(e.to_string()))?;
                (Some(json), Some(discrete_json), discrete.modes())
            }
            _ => (None, None, 0),
        };
        let discretization = BeamDiscretization::from(self.beam_model);
        let kind_name = self.kind.name();
        let discretization_name = format!("{discretization:?}");
        let mut parts: Vec<&[u8]> = vec![
            kind_name.as_bytes(),
            self.version.as_str().as_bytes(),
            &model_json,
            beam_json.as_deref().unwrap_or(&[]),
            discrete_json.as_deref().unwrap_or(&[]),
            discretization_name.as_bytes(),
        ];
        for (platform, bytes) in &libraries {
            parts.push(platform.name().as_bytes());
            parts.push(bytes);
        }
        let token = token(&parts);
        let config = FmuConfig {
            kind: self.kind,
            fmi_version: self.version,
            token,
            model: model_name.into(),
            beam: discrete_json.as_ref().map(|_| DISCRETE_BEAM_FILE.into()),
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
        let mut entries: Vec<(String, &[u8])> =
            vec![("modelDescription.xml".into(), xml.as_bytes())];
        for (platform, bytes) in &libraries {
            let folder = platform.folder(self.version);
            entries.push((
                format!("binaries/{folder}/{id}{}", platform.extension()),
                bytes,
            ));
        }
        entries.push((format!("resources/{CONFIG_FILE}"), &config_json));
        entries.push((format!("resources/{model_name}"), &model_json));
        if let (Some(b), Some(d)) = (&beam_json, &discrete_json) {
            entries.push(("resources/beam.json".into(), b));
            entries.push((format!("resources/{DISCRETE_BEAM_FILE}"), d));
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
