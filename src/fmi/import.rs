//! Load an FMU (FMI 2.0 or 3.0 Co-Simulation, Linux x86-64) and run it:
//! the archive is unpacked into a temporary folder (removed with the
//! [`Fmu`]), the description read, the shared library opened and its
//! functions looked up. [`FmuModel`], [`FmuCompensator`] and
//! [`FmuInverseHysteresis`] adapt an instance to the conformance traits,
//! one sample per `doStep` of one sample time, with save and restore
//! through the FMU's state functions where it has them.
//!
//! This is a small loader of its own rather than the `fmi` crate: that
//! crate's sys layer is generated with bindgen (a libclang at build time)
//! and brings a schema layer besides, for the dozen functions per version
//! that a sampled Co-Simulation run needs.
//!
//! An FMU is native code in this process: one that crashes takes the
//! process with it. Calls into one FMU are serialised (a third-party FMU
//! may keep global state); its instances are otherwise independent.

use std::ffi::{c_char, c_int, c_void, CStr, CString};
use std::io::Read;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};

use crate::io::scratch::ScratchDir;
use thiserror::Error;

use super::variables::{FmiVersion, VariableType};
use crate::operators::traits::{
    ActuatorCompensator, ActuatorModel, Compensated, InverseHysteresis, Operator, SavedState,
};

/// Why an FMU could not be loaded or run.
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum ImportError {
    #[error("{path}: {reason}")]
    Archive { path: String, reason: String },
    #[error("modelDescription.xml: {0}")]
    Description(String),
    #[error("{path}: {reason}")]
    Library { path: String, reason: String },
    #[error("the FMU has no variable '{name}' ({what}); map another name with --fmu-variable {name}=NAME")]
    NoVariable { name: String, what: String },
    #[error("{call} failed with status {status}{log}")]
    Call {
        call: &'static str,
        status: i32,
        log: String,
    },
}

/// One variable as the description declares it.
#[derive(Debug, Clone, PartialEq)]
pub struct ImportedVariable {
    pub name: String,
    pub value_reference: u32,
    /// `None`: a type the adapters do not use (Float32, Int8, …).
    pub ty: Option<VariableType>,
    pub causality: String,
}

/// What the adapters need of `modelDescription.xml`.
#[derive(Debug, Clone, PartialEq)]
pub struct ImportedDescription {
    pub version: FmiVersion,
    pub model_name: String,
    pub model_identifier: String,
    /// GUID (FMI 2) or instantiation token (FMI 3).
    pub token: String,
    pub can_get_and_set_state: bool,
    pub step_size: Option<f64>,
    pub variables: Vec<ImportedVariable>,
}

impl ImportedDescription {
    /// Read a description of either version (Co-Simulation only).
    pub fn parse(xml: &str) -> Result<Self, ImportError> {
        let bad = |s: String| ImportError::Description(s);
        let doc = roxmltree::Document::parse(xml).map_err(|e| bad(e.to_string()))?;
        let root = doc.root_element();
        if root.tag_name().name() != "fmiModelDescription" {
            return Err(bad("the root element is not fmiModelDescription".into()));
        }
        let fmi = root.attribute("fmiVersion").unwrap_or("");
        let version = if fmi == "2.0" {
            FmiVersion::Fmi2
        } else if fmi.starts_with("3.") {
            FmiVersion::Fmi3
        } else {
            return Err(bad(format!(
                "fmiVersion '{fmi}': only FMI 2.0 and 3.0 are supported"
            )));
        };
        let token_attr = match version {
            FmiVersion::Fmi2 => "guid",
            FmiVersion::Fmi3 => "instantiationToken",
        };
        let token = root
            .attribute(token_attr)
            .ok_or_else(|| bad(format!("no {token_attr}")))?
            .to_string();
        let cs = root
            .children()
            .find(|n| n.has_tag_name("CoSimulation"))
            .ok_or_else(|| {
                bad("no CoSimulation element: only Co-Simulation FMUs run here".into())
            })?;
        let model_identifier = cs
            .attribute("modelIdentifier")
            .ok_or_else(|| bad("CoSimulation has no modelIdentifier".into()))?
            .to_string();
        if model_identifier.is_empty()
            || !model_identifier
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || c == '_')
        {
            return Err(bad(format!(
                "modelIdentifier '{model_identifier}' is not a C identifier"
            )));
        }
        let state_attr = match version {
            FmiVersion::Fmi2 => "canGetAndSetFMUstate",
            FmiVersion::Fmi3 => "canGetAndSetFMUState",
        };
        let can_get_and_set_state = cs.attribute(state_attr) == Some("true");
        let step_size = root
            .children()
            .find(|n| n.has_tag_name("DefaultExperiment"))
            .and_then(|n| n.attribute("stepSize"))
            .and_then(|s| s.parse().ok());
        let vars = root
            .children()
            .find(|n| n.has_tag_name("ModelVariables"))
            .ok_or_else(|| bad("no ModelVariables".into()))?;
        let mut variables = Vec::new();
        for v in vars.children().filter(|n| n.is_element()) {
            let (ty_name, node) = match version {
                FmiVersion::Fmi2 => {
                    let t = v
                        .children()
                        .find(|n| n.is_element())
                        .map(|n| n.tag_name().name())
                        .unwrap_or("");
                    (t, v)
                }
                FmiVersion::Fmi3 => (v.tag_name().name(), v),
            };
            let ty = match ty_name {
                "Real" | "Float64" => Some(VariableType::Float64),
                "Integer" | "Int32" => Some(VariableType::Int32),
                "Boolean" => Some(VariableType::Boolean),
                "String" => Some(VariableType::String),
                _ => None,
            };
            let name = node
                .attribute("name")
                .ok_or_else(|| bad("a variable without a name".into()))?;
            let value_reference = node
                .attribute("valueReference")
                .and_then(|s| s.parse().ok())
                .ok_or_else(|| bad(format!("variable '{name}': no valid valueReference")))?;
            variables.push(ImportedVariable {
                name: name.into(),
                value_reference,
                ty,
                causality: node.attribute("causality").unwrap_or("local").into(),
            });
        }
        Ok(Self {
            version,
            model_name: root.attribute("modelName").unwrap_or("").into(),
            model_identifier,
            token,
            can_get_and_set_state,
            step_size,
            variables,
        })
    }

    /// A variable by name.
    pub fn variable(&self, name: &str) -> Option<&ImportedVariable> {
        self.variables.iter().find(|v| v.name == name)
    }
}

// ---- the C side ----------------------------------------------------------

type Handle = *mut c_void;

/// FMI 2's logger is variadic; the message is taken as given (its format
/// arguments, if any, are not expanded): a non-variadic callee reads the
/// fixed arguments correctly on the C calling conventions in use.
type Fmi2Logger =
    unsafe extern "C" fn(*mut c_void, *const c_char, c_int, *const c_char, *const c_char);

#[repr(C)]
struct Fmi2Callbacks {
    logger: Fmi2Logger,
    allocate: unsafe extern "C" fn(usize, usize) -> *mut c_void,
    free: unsafe extern "C" fn(*mut c_void),
    step_finished: Option<unsafe extern "C" fn(*mut c_void, c_int)>,
    environment: *mut c_void,
}

unsafe extern "C" {
    fn calloc(n: usize, size: usize) -> *mut c_void;
    fn free(p: *mut c_void);
}

unsafe extern "C" fn fmi2_logger(
    env: *mut c_void,
    _instance: *const c_char,
    status: c_int,
    category: *const c_char,
    message: *const c_char,
) {
    // SAFETY: `env` is the instance's log, alive while the instance is
    let log = unsafe { &*(env as *const Mutex<Vec<String>>) };
    unsafe { push_log(log, status, category, message) };
}

unsafe extern "C" fn fmi3_logger(
    env: *mut c_void,
    status: c_int,
    category: *const c_char,
    message: *const c_char,
) {
    // SAFETY: as in fmi2_logger
    let log = unsafe { &*(env as *const Mutex<Vec<String>>) };
    unsafe { push_log(log, status, category, message) };
}

/// Keep the last few messages of an instance for its errors.
unsafe fn push_log(
    log: &Mutex<Vec<String>>,
    status: c_int,
    category: *const c_char,
    message: *const c_char,
) {
    let text = |p: *const c_char| {
        if p.is_null() {
            String::new()
        } else {
            // SAFETY: the FMU passes NUL-terminated strings
            unsafe { CStr::from_ptr(p) }.to_string_lossy().into_owned()
        }
    };
    let line = format!("[{} {status}] {}", text(category), text(message));
    if let Ok(mut l) = log.lock() {
        if l.len() >= 16 {
            l.remove(0);
        }
        l.push(line);
    }
}

#[derive(Clone, Copy)]
struct Fmi2Api {
    instantiate: unsafe extern "C" fn(
        *const c_char,
        c_int,
        *const c_char,
        *const c_char,
        *const Fmi2Callbacks,
        c_int,
        c_int,
    ) -> Handle,
    free_instance: unsafe extern "C" fn(Handle),
    setup_experiment: unsafe extern "C" fn(Handle, c_int, f64, f64, c_int, f64) -> c_int,
    enter_initialization: unsafe extern "C" fn(Handle) -> c_int,
    exit_initialization: unsafe extern "C" fn(Handle) -> c_int,
    terminate: unsafe extern "C" fn(Handle) -> c_int,
    set_real: unsafe extern "C" fn(Handle, *const u32, usize, *const f64) -> c_int,
    get_real: unsafe extern "C" fn(Handle, *const u32, usize, *mut f64) -> c_int,
    get_integer: unsafe extern "C" fn(Handle, *const u32, usize, *mut c_int) -> c_int,
    get_boolean: unsafe extern "C" fn(Handle, *const u32, usize, *mut c_int) -> c_int,
    do_step: unsafe extern "C" fn(Handle, f64, f64, c_int) -> c_int,
    get_state: unsafe extern "C" fn(Handle, *mut Handle) -> c_int,
    set_state: unsafe extern "C" fn(Handle, Handle) -> c_int,
    free_state: unsafe extern "C" fn(Handle, *mut Handle) -> c_int,
}

type Fmi3Logger = unsafe extern "C" fn(*mut c_void, c_int, *const c_char, *const c_char);

#[derive(Clone, Copy)]
struct Fmi3Api {
    instantiate: unsafe extern "C" fn(
        *const c_char,
        *const c_char,
        *const c_char,
        bool,
        bool,
        bool,
        bool,
        *const u32,
        usize,
        *mut c_void,
        Fmi3Logger,
        *const c_void,
    ) -> Handle,
    free_instance: unsafe extern "C" fn(Handle),
    enter_initialization: unsafe extern "C" fn(Handle, bool, f64, f64, bool, f64) -> c_int,
    exit_initialization: unsafe extern "C" fn(Handle) -> c_int,
    terminate: unsafe extern "C" fn(Handle) -> c_int,
    set_float64: unsafe extern "C" fn(Handle, *const u32, usize, *const f64, usize) -> c_int,
    get_float64: unsafe extern "C" fn(Handle, *const u32, usize, *mut f64, usize) -> c_int,
    get_int32: unsafe extern "C" fn(Handle, *const u32, usize, *mut i32, usize) -> c_int,
    get_boolean: unsafe extern "C" fn(Handle, *const u32, usize, *mut bool, usize) -> c_int,
    do_step: unsafe extern "C" fn(
        Handle,
        f64,
        f64,
        bool,
        *mut bool,
        *mut bool,
        *mut bool,
        *mut f64,
    ) -> c_int,
    get_state: unsafe extern "C" fn(Handle, *mut Handle) -> c_int,
    set_state: unsafe extern "C" fn(Handle, Handle) -> c_int,
    free_state: unsafe extern "C" fn(Handle, *mut Handle) -> c_int,
}

#[derive(Clone, Copy)]
enum Api {
    V2(Fmi2Api),
    V3(Fmi3Api),
}

/// A loaded FMU.
pub struct Fmu {
    pub description: ImportedDescription,
    /// The archive's name, for messages.
    pub path: PathBuf,
    dir: ScratchDir,
    api: Api,
    /// Keeps the functions of `api` loaded.
    _library: libloading::Library,
    calls: Mutex<()>,
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
                reason: format!("no function {}: {e}", $name),
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
        // the standard folder first; some exporters use the other name
        let folders = match description.version {
            FmiVersion::Fmi2 => ["linux64", "x86_64-linux"],
            FmiVersion::Fmi3 => ["x86_64-linux", "linux64"],
        };
        let file = format!("{}.so", description.model_identifier);
        let Some(lib_path) = folders
            .iter()
            .map(|f| dir.join("binaries").join(f).join(&file))
            .find(|p| p.is_file())
        else {
            return Err(ImportError::Library {
                path: path.display().to_string(),
                reason: format!(
                    "no Linux x86-64 binary binaries/{}/{file}",
                    description.version.linux64_folder()
                ),
            });
        };
        // SAFETY: loading runs the library's initialisers; an FMU is
        // trusted native code by the standard's design
        let library =
            unsafe { libloading::Library::new(&lib_path) }.map_err(|e| ImportError::Library {
                path: lib_path.display().to_string(),
                reason: e.to_string(),
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

/// One instance of a loaded FMU.
pub struct FmuInstance {
    fmu: Arc<Fmu>,
    handle: Handle,
    /// The logger's environment: boxed so that its address is stable.
    log: Box<Mutex<Vec<String>>>,
    /// FMI 2's callbacks, which the FMU may keep a pointer to.
    _callbacks: Box<Fmi2Callbacks>,
    time: f64,
    states: Vec<Handle>,
}

// SAFETY: the handle is only used through `&mut self`, and every call into
// the FMU holds its lock.
unsafe impl Send for FmuInstance {}

impl FmuInstance {
    /// Instantiate (Co-Simulation, logging on).
    pub fn new(fmu: Arc<Fmu>, name: &str) -> Result<Self, ImportError> {
        let log: Box<Mutex<Vec<String>>> = Box::new(Mutex::new(Vec::new()));
        let env = &*log as *const Mutex<Vec<String>> as *mut c_void;
        let cstr = |s: &str| {
            CString::new(s).map_err(|_| ImportError::Description(format!("'{s}' holds a NUL")))
        };
        let name_c = cstr(name)?;
        let token = cstr(&fmu.description.token)?;
        let resources = fmu.resources();
        // FMI 2 keeps a pointer to the callbacks: they live as long as the
        // instance (boxed: a stable address)
        let callbacks = Box::new(Fmi2Callbacks {
            logger: fmi2_logger,
            allocate: calloc,
            free,
            step_finished: None,
            environment: env,
        });
        let handle = {
            let _guard = fmu.calls.lock().unwrap_or_else(|e| e.into_inner());
            match fmu.api {
                Api::V2(api) => {
                    let uri = cstr(&format!("file://{}", resources.display()))?;
                    // SAFETY: arguments as FMI 2.0 specifies (1 = Co-Simulation)
                    unsafe {
                        (api.instantiate)(
                            name_c.as_ptr(),
                            1,
                            token.as_ptr(),
                            uri.as_ptr(),
                            &*callbacks,
                            0,
                            1,
                        )
                    }
                }
                Api::V3(api) => {
                    let path = cstr(&format!("{}/", resources.display()))?;
                    // SAFETY: arguments as FMI 3.0 specifies
                    unsafe {
                        (api.instantiate)(
                            name_c.as_ptr(),
                            token.as_ptr(),
                            path.as_ptr(),
                            false,
                            true,
                            false,
                            false,
                            std::ptr::null(),
                            0,
                            env,
                            fmi3_logger,
                            std::ptr::null(),
                        )
                    }
                }
            }
        };
        let mut instance = Self {
            fmu,
            handle,
            log,
            _callbacks: callbacks,
            time: 0.0,
            states: Vec::new(),
        };
        if handle.is_null() {
            return Err(ImportError::Call {
                call: "Instantiate",
                status: 3,
                log: instance.take_log(),
            });
        }
        Ok(instance)
    }

    fn take_log(&mut self) -> String {
        let l = std::mem::take(&mut *self.log.lock().unwrap_or_else(|e| e.into_inner()));
        if l.is_empty() {
            String::new()
        } else {
            format!(": {}", l.join(" | "))
        }
    }

    fn check(&mut self, call: &'static str, status: c_int) -> Result<(), ImportError> {
        // OK and Warning go on; Discard, Error and Fatal do not
        if status <= 1 {
            Ok(())
        } else {
            Err(ImportError::Call {
                call,
                status,
                log: self.take_log(),
            })
        }
    }

    fn call<R>(&self, f: impl FnOnce(Api) -> R) -> R {
        let _guard = self.fmu.calls.lock().unwrap_or_else(|e| e.into_inner());
        f(self.fmu.api)
    }

    /// Enter and leave initialization at time `start`.
    pub fn initialize(&mut self, start: f64) -> Result<(), ImportError> {
        let h = self.handle;
        let s = self.call(|api| match api {
            // SAFETY (all calls below): a live instance, arguments as specified
            Api::V2(a) => unsafe {
                let s = (a.setup_experiment)(h, 0, 0.0, start, 0, 0.0);
                if s > 1 {
                    return s;
                }
                (a.enter_initialization)(h)
            },
            Api::V3(a) => unsafe { (a.enter_initialization)(h, false, 0.0, start, false, 0.0) },
        });
        self.check("EnterInitializationMode", s)?;
        let s = self.call(|api| match api {
            Api::V2(a) => unsafe { (a.exit_initialization)(h) },
            Api::V3(a) => unsafe { (a.exit_initialization)(h) },
        });
        self.check("ExitInitializationMode", s)?;
        self.time = start;
        Ok(())
    }

    pub fn set_f64(&mut self, vr: u32, value: f64) -> Result<(), ImportError> {
        let h = self.handle;
        let s = self.call(|api| match api {
            Api::V2(a) => unsafe { (a.set_real)(h, &vr, 1, &value) },
            Api::V3(a) => unsafe { (a.set_float64)(h, &vr, 1, &value, 1) },
        });
        self.check("SetReal", s)
    }

    pub fn get_f64(&mut self, vr: u32) -> Result<f64, ImportError> {
        let h = self.handle;
        let mut value = f64::NAN;
        let s = self.call(|api| match api {
            Api::V2(a) => unsafe { (a.get_real)(h, &vr, 1, &mut value) },
            Api::V3(a) => unsafe { (a.get_float64)(h, &vr, 1, &mut value, 1) },
        });
        self.check("GetReal", s)?;
        Ok(value)
    }

    pub fn get_i32(&mut self, vr: u32) -> Result<i32, ImportError> {
        let h = self.handle;
        let mut value = 0i32;
        let s = self.call(|api| match api {
            Api::V2(a) => unsafe { (a.get_integer)(h, &vr, 1, &mut value) },
            Api::V3(a) => unsafe { (a.get_int32)(h, &vr, 1, &mut value, 1) },
        });
        self.check("GetInteger", s)?;
        Ok(value)
    }

    pub fn get_bool(&mut self, vr: u32) -> Result<bool, ImportError> {
        let h = self.handle;
        let mut v2: c_int = 0;
        let mut v3 = false;
        let s = self.call(|api| match api {
            Api::V2(a) => unsafe { (a.get_boolean)(h, &vr, 1, &mut v2) },
            Api::V3(a) => unsafe { (a.get_boolean)(h, &vr, 1, &mut v3, 1) },
        });
        self.check("GetBoolean", s)?;
        Ok(v2 != 0 || v3)
    }

    /// One communication step of `step` seconds from the current time.
    pub fn do_step(&mut self, step: f64) -> Result<(), ImportError> {
        let (h, t) = (self.handle, self.time);
        let s = self.call(|api| match api {
            Api::V2(a) => unsafe { (a.do_step)(h, t, step, 1) },
            Api::V3(a) => unsafe {
                let (mut event, mut terminate, mut early, mut last) = (false, false, false, t);
                (a.do_step)(
                    h,
                    t,
                    step,
                    true,
                    &mut event,
                    &mut terminate,
                    &mut early,
                    &mut last,
                )
            },
        });
        self.check("DoStep", s)?;
        self.time = t + step;
        Ok(())
    }

    /// Save the FMU's state; its index for [`restore`](FmuInstance::restore).
    pub fn save(&mut self) -> Result<usize, ImportError> {
        let h = self.handle;
        let mut state: Handle = std::ptr::null_mut();
        let s = self.call(|api| match api {
            Api::V2(a) => unsafe { (a.get_state)(h, &mut state) },
            Api::V3(a) => unsafe { (a.get_state)(h, &mut state) },
        });
        self.check("GetFMUState", s)?;
        self.states.push(state);
        Ok(self.states.len() - 1)
    }

    /// Restore a state [`save`](FmuInstance::save) returned (and the time).
    pub fn restore(&mut self, index: usize, time: f64) -> Result<(), ImportError> {
        let h = self.handle;
        let state = self.states[index];
        let s = self.call(|api| match api {
            Api::V2(a) => unsafe { (a.set_state)(h, state) },
            Api::V3(a) => unsafe { (a.set_state)(h, state) },
        });
        self.check("SetFMUState", s)?;
        self.time = time;
        Ok(())
    }

    /// The current communication point.
    pub fn time(&self) -> f64 {
        self.time
    }

    /// The messages logged since the last error took them.
    pub fn log(&self) -> Vec<String> {
        self.log.lock().unwrap_or_else(|e| e.into_inner()).clone()
    }
}

impl Drop for FmuInstance {
    fn drop(&mut self) {
        let h = self.handle;
        if h.is_null() {
            return; // Instantiate refused: nothing to free
        }
        let states = std::mem::take(&mut self.states);
        self.call(|api| unsafe {
            match api {
                Api::V2(a) => {
                    for mut s in states {
                        (a.free_state)(h, &mut s);
                    }
                    (a.terminate)(h);
                    (a.free_instance)(h);
                }
                Api::V3(a) => {
                    for mut s in states {
                        (a.free_state)(h, &mut s);
                    }
                    (a.terminate)(h);
                    (a.free_instance)(h);
                }
            }
        });
    }
}

// ---- adapters for the conformance checks ---------------------------------

/// Which conformance kind an FMU is checked as: the variables it needs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ImportKind {
    /// `W` (or `H` alone): `u` in, `y` out.
    Model,
    /// `W⁻¹`: `y_d` in, `u` out, `saturated` (and optionally `fault`,
    /// `u_min`, `u_max`).
    Compensator,
    /// `H⁻¹`: `y` in, `u` out.
    InverseHysteresis,
}

/// The value references the adapters use.
#[derive(Debug, Clone, PartialEq)]
pub struct Bindings {
    pub input: u32,
    pub output: u32,
    pub saturated: Option<u32>,
    pub fault: Option<u32>,
    pub limits: Option<(u32, u32)>,
}

/// Find the variables of `kind` by name; `map` renames (`(ours, the FMU's)`).
pub fn bind(
    description: &ImportedDescription,
    kind: ImportKind,
    map: &[(String, String)],
) -> Result<Bindings, ImportError> {
    let name = |ours: &str| -> String {
        map.iter()
            .find(|(a, _)| a == ours)
            .map(|(_, b)| b.clone())
            .unwrap_or_else(|| ours.to_string())
    };
    let find = |ours: &str, ty: VariableType, what: &str| -> Result<u32, ImportError> {
        let n = name(ours);
        match description.variable(&n) {
            Some(v) if v.ty == Some(ty) => Ok(v.value_reference),
            Some(_) => Err(ImportError::NoVariable {
                name: n,
                what: format!("{what}, of type {ty:?}"),
            }),
            None => Err(ImportError::NoVariable {
                name: n,
                what: what.into(),
            }),
        }
    };
    let optional = |ours: &str, ty: VariableType| -> Option<u32> {
        description
            .variable(&name(ours))
            .filter(|v| v.ty == Some(ty))
            .map(|v| v.value_reference)
    };
    use VariableType::{Boolean, Float64};
    Ok(match kind {
        ImportKind::Model => Bindings {
            input: find("u", Float64, "the input voltage")?,
            output: find("y", Float64, "the output")?,
            saturated: None,
            fault: None,
            limits: None,
        },
        ImportKind::InverseHysteresis => Bindings {
            input: find("y", Float64, "the input of H^-1")?,
            output: find("u", Float64, "the output of H^-1")?,
            saturated: None,
            fault: None,
            limits: None,
        },
        ImportKind::Compensator => Bindings {
            input: find("y_d", Float64, "the target")?,
            output: find("u", Float64, "the compensated voltage")?,
            saturated: Some(find("saturated", Boolean, "the saturation flag")?),
            fault: optional("fault", Boolean),
            limits: optional("u_min", Float64).zip(optional("u_max", Float64)),
        },
    })
}

/// An FMU ready to be instantiated for the checks: the loaded FMU, its
/// bindings and the sample time of one step.
#[derive(Debug, Clone)]
pub struct FmuCandidate {
    pub fmu: Arc<Fmu>,
    pub bindings: Bindings,
    pub sample_time: f64,
    /// The first error any run met (its outputs became NaN).
    pub first_error: Arc<Mutex<Option<ImportError>>>,
    count: Arc<AtomicUsize>,
}

impl FmuCandidate {
    pub fn new(fmu: Arc<Fmu>, bindings: Bindings, sample_time: f64) -> Self {
        Self {
            fmu,
            bindings,
            sample_time,
            first_error: Arc::new(Mutex::new(None)),
            count: Arc::new(AtomicUsize::new(0)),
        }
    }

    /// A fresh initialized instance; `limits` set first where the FMU has
    /// limit parameters.
    pub fn instance(&self, limits: Option<(f64, f64)>) -> Result<FmuInstance, ImportError> {
        let n = self.count.fetch_add(1, Ordering::Relaxed);
        let mut i = FmuInstance::new(self.fmu.clone(), &format!("conform{n}"))?;
        if let (Some((lo, hi)), Some((vlo, vhi))) = (limits, self.bindings.limits) {
            i.set_f64(vlo, lo)?;
            i.set_f64(vhi, hi)?;
        }
        i.initialize(0.0)?;
        Ok(i)
    }

    fn note(&self, e: ImportError) {
        let mut first = self.first_error.lock().unwrap_or_else(|e| e.into_inner());
        if first.is_none() {
            *first = Some(e);
        }
    }

    /// One sample: set the input, one step, read the output (and flags).
    fn sample(&self, i: &mut FmuInstance, x: f64) -> Result<(f64, bool, bool), ImportError> {
        let b = &self.bindings;
        i.set_f64(b.input, x)?;
        i.do_step(self.sample_time)?;
        let out = i.get_f64(b.output)?;
        let saturated = match b.saturated {
            Some(vr) => i.get_bool(vr)?,
            None => false,
        };
        let fault = match b.fault {
            Some(vr) => i.get_bool(vr)?,
            None => false,
        };
        Ok((out, saturated, fault))
    }
}

/// A saved FMU state: its index in the instance and the time.
struct SavedFmuState(usize, f64);

/// The shared body of the adapters.
struct Adapter {
    candidate: FmuCandidate,
    instance: Option<FmuInstance>,
}

impl Adapter {
    fn new(candidate: &FmuCandidate, limits: Option<(f64, f64)>) -> Result<Self, ImportError> {
        let instance = candidate.instance(limits)?;
        Ok(Self {
            candidate: candidate.clone(),
            instance: Some(instance),
        })
    }

    /// NaN outputs after an error (and the error noted): every property
    /// comparing them then fails.
    fn sample(&mut self, x: f64) -> (f64, bool, bool) {
        let Some(i) = self.instance.as_mut() else {
            return (f64::NAN, false, false);
        };
        match self.candidate.sample(i, x) {
            Ok(r) => r,
            Err(e) => {
                self.candidate.note(e);
                self.instance = None;
                (f64::NAN, false, false)
            }
        }
    }

    fn save(&mut self) -> Option<SavedState> {
        if !self.candidate.fmu.description.can_get_and_set_state {
            return None;
        }
        let i = self.instance.as_mut()?;
        let t = i.time();
        match i.save() {
            Ok(k) => Some(SavedState(Box::new(SavedFmuState(k, t)))),
            Err(e) => {
                self.candidate.note(e);
                None
            }
        }
    }

    fn restore(&mut self, state: &SavedState) -> bool {
        let (Some(i), Some(s)) = (
            self.instance.as_mut(),
            state.0.downcast_ref::<SavedFmuState>(),
        ) else {
            return false;
        };
        match i.restore(s.0, s.1) {
            Ok(()) => true,
            Err(e) => {
                self.candidate.note(e);
                false
            }
        }
    }

    fn reset(&mut self, limits: Option<(f64, f64)>) {
        self.instance = None;
        match self.candidate.instance(limits) {
            Ok(i) => self.instance = Some(i),
            Err(e) => self.candidate.note(e),
        }
    }
}

/// An FMU as a single-input single-output operator of kind `$kind`.
macro_rules! fmu_operator {
    ($(#[$doc:meta])* $name:ident: $kind:ident) => {
        $(#[$doc])*
        pub struct $name(Adapter);

        impl $name {
            pub fn new(candidate: &FmuCandidate) -> Result<Self, ImportError> {
                Adapter::new(candidate, None).map(Self)
            }
        }

        impl Operator for $name {
            fn step(&mut self, x: f64) -> f64 {
                self.0.sample(x).0
            }
            fn reset(&mut self) {
                self.0.reset(None);
            }
            fn save_state(&mut self) -> Option<SavedState> {
                self.0.save()
            }
            fn restore_state(&mut self, state: &SavedState) -> bool {
                self.0.restore(state)
            }
        }

        impl $kind for $name {}
    };
}

fmu_operator!(
    /// `W` (or `H`) of an FMU.
    FmuModel: ActuatorModel
);
fmu_operator!(
    /// `H⁻¹` of an FMU.
    FmuInverseHysteresis: InverseHysteresis
);

/// `W⁻¹` of an FMU: per sample, the memory part's inverse (the FMU cannot
/// preview; `compensate_all` previews by `delay`).
pub struct FmuCompensator {
    adapter: Adapter,
    limits: Option<(f64, f64)>,
    delay: usize,
}

impl FmuCompensator {
    /// An instance with `limits` (`None`: the FMU's own).
    pub fn new(
        candidate: &FmuCandidate,
        limits: Option<(f64, f64)>,
        delay: usize,
    ) -> Result<Self, ImportError> {
        Ok(Self {
            adapter: Adapter::new(candidate, limits)?,
            limits,
            delay,
        })
    }
}

impl ActuatorCompensator for FmuCompensator {
    fn compensate(&mut self, target: f64) -> Compensated {
        let (u, saturated, fault) = self.adapter.sample(target);
        Compensated {
            u,
            saturated,
            fault,
        }
    }
    fn reset(&mut self) {
        self.adapter.reset(self.limits);
    }
    fn delay(&self) -> usize {
        self.delay
    }
    fn save_state(&mut self) -> Option<SavedState> {
        self.adapter.save()
    }
    fn restore_state(&mut self, state: &SavedState) -> bool {
        self.adapter.restore(state)
    }
}
