//! A shared library as a candidate: the step ABI. Three functions, named
//! by a prefix (`mfcbeam_candidate` unless given), in `f64` or `f32`:
//!
//! ```c
//! void  *PREFIX_create(const char *model_file, double lower_limit, double upper_limit);
//! double PREFIX_step(void *candidate, double input);   /* or float, float */
//! void   PREFIX_free(void *candidate);
//! int    PREFIX_saturated(const void *candidate);      /* optional */
//! ```
//!
//! `create` gets the model file to implement, or `NULL` when the caller
//! checks a fixed implementation (its parameters compiled in), and the
//! saturation limits of a compensator (infinite for the other kinds); it
//! returns `NULL` to refuse. `step` is one sample: `u = W⁻¹[y_d]`,
//! `y = W[u]` or `u = H⁻¹[y]`. A compensator's saturation flag is
//! `saturated` after the step where the library has it, else whether `u`
//! is at a limit. The library is loaded in the host process only.

use std::ffi::{c_char, c_int, c_void, CString};

use super::protocol::Precision;
use crate::fmi::import::loader_error;

type Create = unsafe extern "C" fn(*const c_char, f64, f64) -> *mut c_void;
type Step64 = unsafe extern "C" fn(*mut c_void, f64) -> f64;
type Step32 = unsafe extern "C" fn(*mut c_void, f32) -> f32;
type Free = unsafe extern "C" fn(*mut c_void);
type Saturated = unsafe extern "C" fn(*const c_void) -> c_int;

/// The prefix of the functions unless another is given.
pub const DEFAULT_SYMBOL_PREFIX: &str = "mfcbeam_candidate";

#[derive(Clone, Copy)]
enum StepFn {
    F64(Step64),
    F32(Step32),
}

/// A loaded step library.
pub struct StepLibrary {
    create: Create,
    step: StepFn,
    free: Free,
    saturated: Option<Saturated>,
    /// Keeps the functions loaded.
    _library: libloading::Library,
}

impl StepLibrary {
    /// Open `path` and look up the functions `PREFIX_create`, `_step` and
    /// `_free` (and `_saturated` if it is there).
    pub fn open(path: &str, prefix: &str, precision: Precision) -> Result<Self, String> {
        if prefix.is_empty()
            || !prefix
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || c == '_')
        {
            return Err(format!(
                "the symbol prefix '{prefix}' is not a C identifier"
            ));
        }
        // SAFETY: loading runs the library's initialisers: the host process
        // is there to contain whatever they do
        let library = unsafe { libloading::Library::new(path) }.map_err(|e| loader_error(&e))?;
        let name = |f: &str| format!("{prefix}_{f}\0");
        let missing = |f: &str, e: libloading::Error| {
            format!(
                "no function {prefix}_{f} (the step ABI: {prefix}_create, {prefix}_step, {prefix}_free): {}",
                loader_error(&e)
            )
        };
        // SAFETY (each lookup): the types are the step ABI's, documented above
        let create: Create = *unsafe { library.get::<Create>(name("create").as_bytes()) }
            .map_err(|e| missing("create", e))?;
        let step = match precision {
            Precision::F64 => StepFn::F64(
                *unsafe { library.get::<Step64>(name("step").as_bytes()) }
                    .map_err(|e| missing("step", e))?,
            ),
            Precision::F32 => StepFn::F32(
                *unsafe { library.get::<Step32>(name("step").as_bytes()) }
                    .map_err(|e| missing("step", e))?,
            ),
        };
        let free: Free = *unsafe { library.get::<Free>(name("free").as_bytes()) }
            .map_err(|e| missing("free", e))?;
        let saturated = unsafe { library.get::<Saturated>(name("saturated").as_bytes()) }
            .ok()
            .map(|s| *s);
        Ok(Self {
            create,
            step,
            free,
            saturated,
            _library: library,
        })
    }

    /// A new instance for `model_file` (`None`: a fixed implementation)
    /// with `limits` (infinite: none).
    pub fn create(
        &self,
        model_file: Option<&str>,
        limits: (f64, f64),
    ) -> Result<StepInstance, String> {
        let file = model_file
            .map(|f| CString::new(f).map_err(|_| format!("'{f}' holds a NUL")))
            .transpose()?;
        let ptr = file.as_ref().map_or(std::ptr::null(), |f| f.as_ptr());
        // SAFETY: a NUL-terminated path or NULL, and two numbers, as the ABI says
        let handle = unsafe { (self.create)(ptr, limits.0, limits.1) };
        if handle.is_null() {
            return Err("create returned NULL (the library refuses this model)".into());
        }
        Ok(StepInstance {
            step: self.step,
            free: self.free,
            saturated: self.saturated,
            handle,
            limits,
        })
    }
}

/// One instance of a step library, freed when dropped; it must be dropped
/// before its library (the host keeps its instances in a field declared
/// before the library's).
pub struct StepInstance {
    step: StepFn,
    free: Free,
    saturated: Option<Saturated>,
    handle: *mut c_void,
    limits: (f64, f64),
}

impl StepInstance {
    /// One sample: the output and the saturation flag.
    #[inline]
    pub fn step(&mut self, x: f64) -> (f64, bool) {
        // SAFETY: the handle is the library's own, alive until drop
        let y = unsafe {
            match self.step {
                StepFn::F64(f) => f(self.handle, x),
                StepFn::F32(f) => f64::from(f(self.handle, x as f32)),
            }
        };
        let saturated = match self.saturated {
            // SAFETY: as above
            Some(f) => unsafe { f(self.handle) != 0 },
            None => y <= self.limits.0 || y >= self.limits.1,
        };
        (y, saturated)
    }
}

impl Drop for StepInstance {
    fn drop(&mut self) {
        // SAFETY: created by this library's create, freed once
        unsafe { (self.free)(self.handle) };
    }
}
