//! One instance of a loaded FMU: instantiate, initialize, set and get
//! values, `doStep`, save and restore, each call under the FMU's lock and
//! checked, with the instance's last log messages in its errors.

use std::ffi::{c_int, c_void, CString};
use std::sync::{Arc, Mutex};

use super::abi::{calloc, fmi2_logger, fmi3_logger, free, Api, Fmi2Callbacks, Handle};
use super::{Fmu, ImportError};

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
