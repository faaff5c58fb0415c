//! `mfcbeam fmu`: package an FMU.

use std::path::Path;

use anyhow::{bail, Context, Result};

use mfcbeam::fmi::package::{build_command, FmuPackage, ReleaseFolder};
use mfcbeam::fmi::Platform;
use mfcbeam::fmi::{FmiVersion, FmuKind};
use mfcbeam::io::{read_beam, read_model_file};

use super::args::{FmuArgs, FmuKindArg};

pub fn fmu(a: &FmuArgs) -> Result<()> {
    let model = match (&a.model, a.kind) {
        (Some(_), FmuKindArg::Controller) => {
            bail!("--model: a controller FMU holds no model (its design is for the benchmark's)")
        }
        (Some(m), _) => read_model_file(m)?,
        (None, _) => mfcbeam::operators::nominal::nominal_model_file(),
    };
    let beam = match (&a.beam, a.kind) {
        (Some(b), FmuKindArg::Plant | FmuKindArg::Controller) => Some(read_beam(b)?),
        (Some(_), _) => bail!("--beam: only the plant and the controller have a beam"),
        (None, _) => None,
    };
    if a.controller.is_some() && a.kind != FmuKindArg::Controller {
        bail!("--controller: only with --kind controller");
    }
    let controller = match a.controller.as_deref() {
        None => None,
        Some(id) => {
            use mfcbeam::control::{Benchmark, BuiltinController};
            let kind = match BuiltinController::from_id(id) {
                Some(k) if k != BuiltinController::Open => k,
                _ => bail!("--controller '{id}': not one of pid, lq"),
            };
            let bench = match &beam {
                None => Benchmark::nominal()?,
                Some(b) => {
                    let kind = super::args::BeamModelArgs::kind_of(a.beam_model, a.elements);
                    let modal =
                        mfcbeam::beam::step_response_fit::modal_model(b, kind).context("--beam")?;
                    Benchmark::new(mfcbeam::operators::nominal::nominal_model(), modal)?
                }
            };
            Some(bench.controller_file(kind)?)
        }
    };
    let beam = if a.kind == FmuKindArg::Controller {
        None
    } else {
        beam
    };
    let libraries = libraries(a)?;
    let package = FmuPackage {
        kind: match a.kind {
            FmuKindArg::Compensator => FmuKind::Compensator,
            FmuKindArg::Model => FmuKind::Model,
            FmuKindArg::Plant => FmuKind::Plant,
            FmuKindArg::Controller => FmuKind::Controller,
        },
        version: if a.fmi == "2" {
            FmiVersion::Fmi2
        } else {
            FmiVersion::Fmi3
        },
        model,
        beam,
        beam_model: super::args::BeamModelArgs::kind_of(a.beam_model, a.elements),
        controller,
        libraries,
    };
    package
        .write(&a.output)
        .with_context(|| format!("--output {}", a.output.display()))?;
    let platforms: Vec<_> = package.platforms().iter().map(|p| p.name()).collect();
    eprintln!(
        "wrote {} (FMI {}, {}; platforms {})",
        a.output.display(),
        package.version.as_str(),
        package.kind.name(),
        platforms.join(", ")
    );
    Ok(())
}

/// The libraries to pack: those given, each platform read from its
/// header, or those of the release folder.
fn libraries(a: &FmuArgs) -> Result<Vec<(Platform, std::path::PathBuf)>> {
    if !a.library.is_empty() {
        let mut found = Vec::new();
        for path in &a.library {
            let bytes =
                std::fs::read(path).with_context(|| format!("--library {}", path.display()))?;
            let platform = Platform::of_library(&bytes)
                .map_err(|what| anyhow::anyhow!("--library {}: {what}", path.display()))?;
            found.push((platform, path.clone()));
        }
        return Ok(found);
    }
    let folder = match &a.release_folder {
        Some(dir) => ReleaseFolder::new(dir),
        None => ReleaseFolder::of_this_program()
            .context("--release-folder: cannot tell where this program runs from; give it")?,
    };
    let chosen = !a.platforms.is_empty();
    let wanted: Vec<Platform> = if !chosen || a.platforms.iter().any(|p| p == "all") {
        Platform::ALL.to_vec()
    } else {
        a.platforms
            .iter()
            .map(|name| {
                Platform::from_name(name).with_context(|| {
                    let names: Vec<_> = Platform::ALL.iter().map(|p| p.name()).collect();
                    format!("--platforms: '{name}' is none of {}", names.join(", "))
                })
            })
            .collect::<Result<_>>()?
    };
    let (mut found, mut missing) = folder.find(&wanted);
    // the platforms asked for are built where the folder is a checkout's
    if chosen && !missing.is_empty() {
        if let Some(source) = source_tree(&folder.target) {
            for &p in &missing {
                build_library(&source, &folder.target, p)?;
            }
            (found, missing) = folder.find(&wanted);
        }
    }
    let how = |p: &Platform| format!("{p} (`{}`)", build_command(*p));
    if chosen && !missing.is_empty() {
        let list: Vec<_> = missing.iter().map(how).collect();
        bail!(
            "--platforms: no library in {} for {}",
            folder.target.display(),
            list.join(", ")
        );
    }
    if found.is_empty() {
        bail!(
            "--release-folder: no mfcbeam-fmu library in {}; build it with `{}`",
            folder.target.display(),
            Platform::host().map_or("cargo build --release -p mfcbeam-fmu".into(), build_command)
        );
    }
    // macOS libraries are built on a Mac: not finding them is expected
    let missing: Vec<_> = missing
        .into_iter()
        .filter(|p| Platform::BUILT_HERE.contains(p))
        .collect();
    if !missing.is_empty() {
        let list: Vec<_> = missing.iter().map(|p| p.name()).collect();
        eprintln!(
            "not packed, no library in {}: {} (--platforms names the ones required)",
            folder.target.display(),
            list.join(", ")
        );
    }
    Ok(found)
}

/// The mfcbeam checkout whose cargo target folder `target` is, if it is
/// one (the FMU library's crate beside it).
fn source_tree(target: &Path) -> Option<std::path::PathBuf> {
    let source = target.canonicalize().ok()?.parent()?.to_path_buf();
    (source.join("Cargo.toml").is_file() && source.join("fmu").join("Cargo.toml").is_file())
        .then_some(source)
}

/// Build `platform`'s FMU library from the checkout `source` into
/// `target` with the cargo on the path; its first error in one line if
/// that fails (no toolchain, no target, no linker).
fn build_library(source: &Path, target: &Path, platform: Platform) -> Result<()> {
    let command = build_command(platform);
    eprintln!("building the {platform} library: {command}");
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    let mut cmd = std::process::Command::new(cargo);
    cmd.args(["build", "--release", "-p", "mfcbeam-fmu", "--target-dir"])
        .arg(target)
        .current_dir(source);
    if Platform::host() != Some(platform) {
        cmd.args(["--target", platform.rust_target()]);
    }
    let out = cmd
        .output()
        .with_context(|| format!("--platforms: {platform}: running `{command}`"))?;
    if !out.status.success() {
        let stderr = String::from_utf8_lossy(&out.stderr);
        let first = stderr
            .lines()
            .find(|l| l.trim_start().starts_with("error"))
            .or_else(|| stderr.lines().last())
            .unwrap_or("no message")
            .trim();
        bail!("--platforms: {platform}: `{command}` failed: {first}");
    }
    Ok(())
}
