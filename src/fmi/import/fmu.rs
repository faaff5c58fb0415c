//! A loaded FMU: its archive unpacked into a temporary folder (removed
//! with it, bounded in size), its description read and its library opened
//! with the functions of its FMI version looked up.

use std::io::Read;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

use crate::io::scratch::ScratchDir;

use super::abi::{Api, Fmi2Api, Fmi3Api};
use super::{FmiVersion, ImportError, ImportedDescription};
use crate::fmi::Platform;

/// The loader's message with its reason: libloading keeps what `dlopen`
/// or `dlsym` said in the error's source.
pub(crate) fn loader_error(e: &libloading::Error) -> String {
    let mut text = e.to_string();
    let mut source = std::error::Error::source(e);
    while let Some(s) = source {
        let more = s.to_string();
        if !text.contains(&more) {
            text = format!("{text}: {more}");
        }
        source = s.source();
    }
    text
}

/// A loaded FMU.
pub struct Fmu {
    pub description: ImportedDescription,
    /// The archive's name, for messages.
    pub path: PathBuf,
    pub(super) dir: ScratchDir,
    pub(super) api: Api,
    /// Keeps the functions of `api` loaded.
    _library: libloading::Library,
    pub(super) calls: Mutex<()>,
}

impl std::fmt::Debug for Fmu {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Fmu")
            .field("path", &self.path)
            .field("description", &self.description)
            .finish()
    }
}

/// The most an archive may unpack to (on disk, in the temporary
/// directory): an FMU of this project is a few megabytes, one with every
/// platform's binaries some tens.
pub const MAX_UNPACKED: u64 = 256 << 20;

/// The largest `modelDescription.xml` read: one with thousands of variables
/// is a few megabytes.
pub const MAX_DESCRIPTION: u64 = 16 << 20;

fn unpack(path: &Path, dir: &Path) -> Result<(), ImportError> {
    let bad = |reason: String| ImportError::Archive {
        path: path.display().to_string(),
        reason,
    };
    let file = std::fs::File::open(path).map_err(|e| bad(e.to_string()))?;
    let mut zip = zip::ZipArchive::new(file).map_err(|e| bad(format!("not a zip archive: {e}")))?;
    let mut total = 0u64;
    for i in 0..zip.len() {
        let mut entry = zip.by_index(i).map_err(|e| bad(e.to_string()))?;
        let Some(name) = entry.enclosed_name() else {
            return Err(bad(format!("entry {i} leaves the archive's folder")));
        };
        let target = dir.join(name);
        if entry.is_dir() {
            std::fs::create_dir_all(&target).map_err(|e| bad(e.to_string()))?;
            continue;
        }
        if let Some(parent) = target.parent() {
            std::fs::create_dir_all(parent).map_err(|e| bad(e.to_string()))?;
        }
        let mut out = std::fs::File::create(&target).map_err(|e| bad(e.to_string()))?;
        // the size in the header may lie: count what really comes out
        let room = MAX_UNPACKED - total;
        let n = std::io::copy(&mut (&mut entry).take(room + 1), &mut out)
            .map_err(|e| bad(e.to_string()))?;
        total += n;
        if total > MAX_UNPACKED {
            return Err(bad(format!("unpacks to more than {MAX_UNPACKED} bytes")));
        }
    }
    Ok(())
}

macro_rules! symbol {
    ($lib:expr, $path:expr, $name:literal) => {{
        // SAFETY: the type is the FMI standard's for this name
        let s = unsafe { $lib.get(concat!($name, "\0").as_bytes()) }.map_err(|e| {
            ImportError::Library {
                path: $path.display().to_string(),
                reason: format!("no function {}: {}", $name, loader_error(&e)),
            }
        })?;
        *s
    }};
}

impl Fmu {
    /// Unpack and load the FMU at `path`.
    pub fn load(path: &Path) -> Result<Arc<Self>, ImportError> {
        // removed with the Fmu, on a termination signal, or by the next
        // import after a kill
        let dir = ScratchDir::new("mfcbeam-fmu").map_err(|e| ImportError::Archive {
            path: std::env::temp_dir().display().to_string(),
            reason: e.to_string(),
        })?;
        Self::load_into(path, dir).map(Arc::new)
    }

    fn load_into(path: &Path, scratch: ScratchDir) -> Result<Self, ImportError> {
        let dir = scratch.path();
        unpack(path, dir)?;
        let xml_path = dir.join("modelDescription.xml");
        let unreadable = |reason: String| ImportError::Archive {
            path: path.display().to_string(),
            reason: format!("modelDescription.xml: {reason}"),
        };
        // parsed into a tree of some times its size: bounded first
        let size = std::fs::metadata(&xml_path)
            .map_err(|e| unreadable(e.to_string()))?
            .len();
        if size > MAX_DESCRIPTION {
            return Err(unreadable(format!(
                "{size} bytes, more than the {MAX_DESCRIPTION} read"
            )));
        }
        let xml = std::fs::read_to_string(&xml_path).map_err(|e| unreadable(e.to_string()))?;
        let description = ImportedDescription::parse(&xml)?;
        let lib_path = host_library(path, dir, &description)?;
        // SAFETY: loading runs the library's initialisers; an FMU is
        // trusted native code by the standard's design
        let library =
            unsafe { libloading::Library::new(&lib_path) }.map_err(|e| ImportError::Library {
                path: lib_path.display().to_string(),
                reason: loader_error(&e),
            })?;
        let p = &lib_path;
        let api = match description.version {
            FmiVersion::Fmi2 => Api::V2(Fmi2Api {
                instantiate: symbol!(library, p, "fmi2Instantiate"),
                free_instance: symbol!(library, p, "fmi2FreeInstance"),
                setup_experiment: symbol!(library, p, "fmi2SetupExperiment"),
                enter_initialization: symbol!(library, p, "fmi2EnterInitializationMode"),
                exit_initialization: symbol!(library, p, "fmi2ExitInitializationMode"),
                terminate: symbol!(library, p, "fmi2Terminate"),
                set_real: symbol!(library, p, "fmi2SetReal"),
                get_real: symbol!(library, p, "fmi2GetReal"),
                get_integer: symbol!(library, p, "fmi2GetInteger"),
                get_boolean: symbol!(library, p, "fmi2GetBoolean"),
                do_step: symbol!(library, p, "fmi2DoStep"),
                get_state: symbol!(library, p, "fmi2GetFMUstate"),
                set_state: symbol!(library, p, "fmi2SetFMUstate"),
                free_state: symbol!(library, p, "fmi2FreeFMUstate"),
            }),
            FmiVersion::Fmi3 => Api::V3(Fmi3Api {
                instantiate: symbol!(library, p, "fmi3InstantiateCoSimulation"),
                free_instance: symbol!(library, p, "fmi3FreeInstance"),
                enter_initialization: symbol!(library, p, "fmi3EnterInitializationMode"),
                exit_initialization: symbol!(library, p, "fmi3ExitInitializationMode"),
                terminate: symbol!(library, p, "fmi3Terminate"),
                set_float64: symbol!(library, p, "fmi3SetFloat64"),
                get_float64: symbol!(library, p, "fmi3GetFloat64"),
                get_int32: symbol!(library, p, "fmi3GetInt32"),
                get_boolean: symbol!(library, p, "fmi3GetBoolean"),
                do_step: symbol!(library, p, "fmi3DoStep"),
                get_state: symbol!(library, p, "fmi3GetFMUState"),
                set_state: symbol!(library, p, "fmi3SetFMUState"),
                free_state: symbol!(library, p, "fmi3FreeFMUState"),
            }),
        };
        Ok(Self {
            description,
            path: path.to_path_buf(),
            dir: scratch,
            api,
            _library: library,
            calls: Mutex::new(()),
        })
    }

    /// The unpacked `resources/` folder.
    pub fn resources(&self) -> PathBuf {
        self.dir.path().join("resources")
    }
}

/// This machine's binary in the unpacked FMU `dir`, checked to be a
/// library for this platform before it is loaded: a missing one names the
/// platforms the FMU holds, a foreign or broken one says what it is.
fn host_library(
    fmu: &Path,
    dir: &Path,
    description: &ImportedDescription,
) -> Result<PathBuf, ImportError> {
    let error = |path: &Path, reason: String| ImportError::Library {
        path: path.display().to_string(),
        reason,
    };
    let Some(host) = Platform::host() else {
        return Err(error(
            fmu,
            "this machine is none of the FMU platforms".into(),
        ));
    };
    let binaries = dir.join("binaries");
    let file = format!("{}{}", description.model_identifier, host.extension());
    // the version's folder first; some exporters use the other version's
    let mut folders = vec![host.folder(description.version)];
    for v in [FmiVersion::Fmi2, FmiVersion::Fmi3] {
        if !folders.contains(&host.folder(v)) {
            folders.push(host.folder(v));
        }
    }
    let Some(lib_path) = folders
        .iter()
        .map(|f| binaries.join(f).join(&file))
        .find(|p| p.is_file())
    else {
        let mut held: Vec<String> = std::fs::read_dir(&binaries)
            .map(|entries| {
                entries
                    .filter_map(|e| e.ok())
                    .filter(|e| e.path().is_dir())
                    .map(|e| e.file_name().to_string_lossy().into_owned())
                    .collect()
            })
            .unwrap_or_default();
        held.sort();
        let holds = if held.is_empty() {
            "it holds no binaries".to_string()
        } else {
            format!("it holds binaries/{}", held.join(", binaries/"))
        };
        return Err(error(
            fmu,
            format!(
                "no binary for this machine ({host}): binaries/{}/{file} is missing; {holds}",
                host.folder(description.version)
            ),
        ));
    };
    // the whole file: its headers' offsets are checked against its length
    let bytes = std::fs::read(&lib_path).map_err(|e| error(&lib_path, e.to_string()))?;
    match crate::fmi::platform::check_library(&bytes) {
        Ok(p) if p == host => Ok(lib_path),
        Ok(p) => Err(error(
            &lib_path,
            format!("a library for {p}, not for this machine ({host})"),
        )),
        Err(what) => Err(error(
            &lib_path,
            format!("{what}, not a library for {host}"),
        )),
    }
}
