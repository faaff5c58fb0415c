//! One FMU instance, independent of the FMI version and of the C ABI: the
//! parameters and the input as the importer sets them, the model (and
//! beam) loaded when initialization ends, `doStep` as whole samples of the
//! model with the input held, the outputs, and save and restore of the
//! whole state. Per sample it allocates nothing.

use std::path::{Path, PathBuf};

use thiserror::Error;

use super::variables::{vr, FmuConfig, FmuKind, CONFIG_FILE};
use crate::beam::simulation::{DiscreteBeam, DiscreteBeamFile};
use crate::control::file::{BuiltController, ControllerFile};
use crate::control::{Controller, LoopSample};
use crate::operators::compensator::{Compensator, CompensatorSettings};
use crate::operators::heap::Heap;
use crate::operators::model::HysteresisCreepModel;

/// What went wrong in an FMU call; the C layer logs the message and
/// returns `fmi2Error` / `fmi3Error`.
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum FmuError {
    #[error("{path}: {reason}")]
    Resource { path: String, reason: String },
    #[error("the instantiation token (GUID) '{found}' is not this FMU's '{expected}'")]
    Token { expected: String, found: String },
    #[error("no variable has value reference {0} (or it has another type)")]
    UnknownVariable(u32),
    #[error("variable '{name}' cannot be set {when}")]
    NotSettable { name: String, when: &'static str },
    #[error("{call} is not allowed {when}")]
    WrongState {
        call: &'static str,
        when: &'static str,
    },
    #[error("the communication step {step} s is not a whole multiple (at least 1) of the sample time {sample_time} s")]
    StepSize { step: f64, sample_time: f64 },
    #[error("the step starts at {found} s, but the FMU is at {expected} s")]
    StepStart { expected: f64, found: f64 },
    #[error("{0}")]
    Invalid(String),
}

/// The most samples one `doStep` may hold (about ten seconds of work).
pub const MAX_SAMPLES_PER_STEP: f64 = 1e8;

/// Where an instance is in its life.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mode {
    Instantiated,
    Initialization,
    Step,
    Terminated,
}

/// The live operators, built when initialization ends.
#[derive(Debug, Clone)]
enum Live {
    Compensator(Compensator<f64, Heap>),
    Model(HysteresisCreepModel),
    Plant {
        model: HysteresisCreepModel,
        beam: DiscreteBeam,
    },
    Controller(BuiltController),
}

/// Everything the next outputs depend on: what save and restore copy.
#[derive(Debug, Clone)]
pub struct State {
    live: Option<Live>,
    input: f64,
    /// The controller's second input.
    measurement: f64,
    output: f64,
    effective_voltage: f64,
    saturated: bool,
    fault: bool,
    /// The plant's modal state, interleaved real and imaginary parts.
    modal: Vec<f64>,
    time: f64,
    mode: Mode,
}

/// One instance of an FMU.
#[derive(Debug, Clone)]
pub struct Component {
    config: FmuConfig,
    resources: PathBuf,
    model_file: String,
    beam_file: String,
    u_min: f64,
    u_max: f64,
    sample_time: f64,
    delay: usize,
    state: State,
}

impl Component {
    /// An instance from the FMU's `resources/` folder; `token` is the GUID
    /// or instantiation token the importer read from the description.
    pub fn new(resources: &Path, token: &str) -> Result<Self, FmuError> {
        let path = resources.join(CONFIG_FILE);
        let bad = |reason: String| FmuError::Resource {
            path: path.display().to_string(),
            reason,
        };
        let text = std::fs::read_to_string(&path).map_err(|e| bad(e.to_string()))?;
        let config: FmuConfig = crate::io::parse_json(&text).map_err(bad)?;
        if config.token != token {
            return Err(FmuError::Token {
                expected: config.token,
                found: token.into(),
            });
        }
        let defaults = CompensatorSettings::default();
        let mut c = Self {
            config,
            resources: resources.to_path_buf(),
            model_file: String::new(),
            beam_file: String::new(),
            u_min: defaults.lower_limit,
            u_max: defaults.upper_limit,
            sample_time: f64::NAN,
            delay: 0,
            state: State {
                live: None,
                input: 0.0,
                measurement: 0.0,
                output: 0.0,
                effective_voltage: 0.0,
                saturated: false,
                fault: false,
                modal: Vec::new(),
                time: 0.0,
                mode: Mode::Instantiated,
            },
        };
        c.state.modal = vec![0.0; 2 * c.config.modes];
        // the resources load now: a broken FMU fails at instantiation (a
        // parameter set later drops them, and they load again)
        c.load()?;
        Ok(c)
    }

    pub fn kind(&self) -> FmuKind {
        self.config.kind
    }

    pub fn mode(&self) -> Mode {
        self.state.mode
    }

    /// Back to the state right after instantiation (FMI `Reset`).
    pub fn reset(&mut self) -> Result<(), FmuError> {
        let fresh = Self::new(&self.resources, &self.config.token)?;
        *self = fresh;
        Ok(())
    }

    fn resource_or(&self, given: &str, default: Option<&str>) -> Result<PathBuf, FmuError> {
        if !given.is_empty() {
            return Ok(PathBuf::from(given));
        }
        default
            .map(|d| self.resources.join(d))
            .ok_or_else(|| FmuError::Invalid("this FMU has no beam".into()))
    }

    /// Read the controller file and build the controller.
    fn load_controller(&mut self) -> Result<(), FmuError> {
        let path = self.resource_or(&self.model_file, Some(&self.config.model))?;
        let bad = |reason: String| FmuError::Resource {
            path: path.display().to_string(),
            reason,
        };
        let file: ControllerFile = crate::io::read_json(&path).map_err(|e| bad(e.to_string()))?;
        let controller = file.build().map_err(|e| bad(e.to_string()))?;
        self.sample_time = file.sample_time;
        self.delay = 0;
        self.state.live = Some(Live::Controller(controller));
        Ok(())
    }

    /// Read the model (and beam) files and build the operators.
    fn load(&mut self) -> Result<(), FmuError> {
        if self.config.kind == FmuKind::Controller {
            return self.load_controller();
        }
        let model_path = self.resource_or(&self.model_file, Some(&self.config.model))?;
        let file_error = |e: crate::io::FileError| FmuError::Resource {
            path: model_path.display().to_string(),
            reason: e.to_string(),
        };
        let model = crate::io::read_model(&model_path).map_err(file_error)?;
        self.sample_time = model.sample_time();
        self.delay = model.preview();
        let live = match self.config.kind {
            FmuKind::Compensator => {
                let settings = CompensatorSettings::with_limits(self.u_min, self.u_max);
                Live::Compensator(model.compensator(settings).map_err(|e| {
                    FmuError::Invalid(format!("the compensator of {}: {e}", model_path.display()))
                })?)
            }
            FmuKind::Model => Live::Model(model),
            FmuKind::Controller => unreachable!("loaded by load_controller"),
            FmuKind::Plant => {
                let beam_path = self.resource_or(&self.beam_file, self.config.beam.as_deref())?;
                let beam_error = |reason: String| FmuError::Resource {
                    path: beam_path.display().to_string(),
                    reason,
                };
                let file: DiscreteBeamFile =
                    crate::io::read_json(&beam_path).map_err(|e| beam_error(e.to_string()))?;
                let discrete =
                    DiscreteBeam::from_file(&file).map_err(|e| beam_error(e.to_string()))?;
                let (ts, model_ts) = (discrete.sample_time(), self.sample_time);
                if ts != model_ts {
                    return Err(beam_error(format!(
                        "discretized at {ts} s, but the model's sample time is {model_ts} s"
                    )));
                }
                if discrete.modes() != self.config.modes {
                    return Err(FmuError::Resource {
                        path: beam_path.display().to_string(),
                        reason: format!(
                            "{} modes, but this FMU was packaged with {} modal outputs",
                            discrete.modes(),
                            self.config.modes
                        ),
                    });
                }
                Live::Plant {
                    model,
                    beam: discrete,
                }
            }
        };
        self.state.live = Some(live);
        Ok(())
    }

    /// FMI `EnterInitializationMode`: the files load here if a parameter
    /// changed since instantiation, so that the calculated parameters can
    /// be read during initialization.
    pub fn enter_initialization(&mut self, start_time: f64) -> Result<(), FmuError> {
        if self.state.mode != Mode::Instantiated {
            return Err(self.wrong("EnterInitializationMode"));
        }
        if !start_time.is_finite() {
            return Err(FmuError::Invalid(format!(
                "start time {start_time} is not finite"
            )));
        }
        if self.state.live.is_none() {
            self.load()?;
        }
        self.state.time = start_time;
        self.state.mode = Mode::Initialization;
        Ok(())
    }

    /// FMI `ExitInitializationMode`: load again if a parameter changed.
    pub fn exit_initialization(&mut self) -> Result<(), FmuError> {
        if self.state.mode != Mode::Initialization {
            return Err(self.wrong("ExitInitializationMode"));
        }
        if self.state.live.is_none() {
            self.load()?;
        }
        self.state.mode = Mode::Step;
        Ok(())
    }

    /// FMI `Terminate`.
    pub fn terminate(&mut self) -> Result<(), FmuError> {
        if self.state.mode != Mode::Step && self.state.mode != Mode::Initialization {
            return Err(self.wrong("Terminate"));
        }
        self.state.mode = Mode::Terminated;
        Ok(())
    }

    fn wrong(&self, call: &'static str) -> FmuError {
        FmuError::WrongState {
            call,
            when: match self.state.mode {
                Mode::Instantiated => "before initialization",
                Mode::Initialization => "during initialization",
                Mode::Step => "after initialization",
                Mode::Terminated => "after Terminate",
            },
        }
    }

    /// FMI `DoStep` from `time` over `step` seconds: `step / Ts` samples
    /// with the input held.
    pub fn do_step(&mut self, time: f64, step: f64) -> Result<(), FmuError> {
        if self.state.mode != Mode::Step {
            return Err(self.wrong("DoStep"));
        }
        let ts = self.sample_time;
        let n = (step / ts).round();
        if !(step.is_finite() && n >= 1.0 && (n * ts - step).abs() <= 1e-9 * step) {
            return Err(FmuError::StepSize {
                step,
                sample_time: ts,
            });
        }
        // a step takes time in proportion to its samples: bounded
        if n > MAX_SAMPLES_PER_STEP {
            return Err(FmuError::Invalid(format!(
                "the communication step {step} s holds {n} samples; at most {MAX_SAMPLES_PER_STEP} per step"
            )));
        }
        let scale = self.state.time.abs().max(step);
        if !time.is_finite() || (time - self.state.time).abs() > 1e-9 * scale {
            return Err(FmuError::StepStart {
                expected: self.state.time,
                found: time,
            });
        }
        let s = &mut self.state;
        let (input, measurement) = (s.input, s.measurement);
        let live = s.live.as_mut().expect("loaded in step mode");
        s.saturated = false;
        s.fault = false;
        for _ in 0..n as u64 {
            match live {
                Live::Compensator(c) => {
                    let r = c.compensate(input);
                    s.output = r.u;
                    s.saturated |= r.saturated;
                    s.fault |= r.fault;
                }
                Live::Model(m) => {
                    s.output = m.step(input);
                    s.fault |= !input.is_finite();
                }
                Live::Plant { model, beam } => {
                    let v = model.step(input);
                    beam.step(v);
                    s.effective_voltage = v;
                    s.fault |= !input.is_finite();
                }
                Live::Controller(c) => {
                    let sample = LoopSample {
                        k: (time / ts).round().max(0.0) as usize,
                        t: time,
                        reference: input,
                        measurement,
                    };
                    // the built-in designs never fail; nothing or a
                    // non-finite answer holds the last correction
                    match c.step(&sample) {
                        Ok(Some(v)) if v.is_finite() => s.output = v,
                        _ => s.fault = true,
                    }
                }
            }
        }
        if let Live::Plant { beam, .. } = live {
            s.output = beam.output();
            let (re, im) = beam.modal_state();
            for (j, (r, i)) in re.iter().zip(im).enumerate() {
                s.modal[2 * j] = *r;
                s.modal[2 * j + 1] = *i;
            }
        }
        // the time after n samples, without accumulating rounding
        s.time = time + step;
        Ok(())
    }

    /// Whether the last step held a non-finite input.
    pub fn input_fault(&self) -> bool {
        self.state.fault
    }

    /// The current simulation time (s).
    pub fn time(&self) -> f64 {
        self.state.time
    }

    fn settable_now(&self, name: &str, parameter: bool) -> Result<(), FmuError> {
        let ok = if parameter {
            matches!(self.state.mode, Mode::Instantiated | Mode::Initialization)
        } else {
            self.state.mode != Mode::Terminated
        };
        if ok {
            Ok(())
        } else {
            Err(FmuError::NotSettable {
                name: name.into(),
                when: if parameter {
                    "after initialization (a fixed parameter)"
                } else {
                    "after Terminate"
                },
            })
        }
    }

    /// Set a `Float64` (FMI 2 `Real`). A non-finite input is accepted: the
    /// step holds the previous one and raises `fault`.
    pub fn set_float64(&mut self, vr: u32, value: f64) -> Result<(), FmuError> {
        match (vr, self.config.kind) {
            (vr::INPUT, _) => {
                self.settable_now("the input", false)?;
                self.state.input = value;
            }
            (vr::MEASUREMENT, FmuKind::Controller) => {
                self.settable_now("measurement", false)?;
                self.state.measurement = value;
            }
            (vr::U_MIN | vr::U_MAX, FmuKind::Compensator) => {
                let name = if vr == vr::U_MIN { "u_min" } else { "u_max" };
                self.settable_now(name, true)?;
                // the pair is checked when the compensator is built
                if value.is_nan() {
                    return Err(FmuError::Invalid(format!("{name} is not a number")));
                }
                if vr == vr::U_MIN {
                    self.u_min = value;
                } else {
                    self.u_max = value;
                }
                self.state.live = None;
            }
            _ => return Err(FmuError::UnknownVariable(vr)),
        }
        Ok(())
    }

    /// Get a `Float64` (FMI 2 `Real`).
    pub fn get_float64(&self, vr: u32) -> Result<f64, FmuError> {
        let s = &self.state;
        let modal = vr::MODAL..vr::MODAL + s.modal.len() as u32;
        Ok(match (vr, self.config.kind) {
            (vr::TIME, _) => s.time,
            (vr::INPUT, _) => s.input,
            (vr::OUTPUT, _) => s.output,
            (vr::MEASUREMENT, FmuKind::Controller) => s.measurement,
            (vr::U_MIN, FmuKind::Compensator) => self.u_min,
            (vr::U_MAX, FmuKind::Compensator) => self.u_max,
            (vr::SAMPLE_TIME, _) => self.sample_time,
            (vr::EFFECTIVE_VOLTAGE, FmuKind::Plant) => s.effective_voltage,
            (r, FmuKind::Plant) if modal.contains(&r) => s.modal[(r - vr::MODAL) as usize],
            _ => return Err(FmuError::UnknownVariable(vr)),
        })
    }

    /// Get an `Int32` (FMI 2 `Integer`).
    pub fn get_int32(&self, vr: u32) -> Result<i32, FmuError> {
        match vr {
            vr::DELAY => i32::try_from(self.delay).map_err(|_| FmuError::Invalid("delay".into())),
            _ => Err(FmuError::UnknownVariable(vr)),
        }
    }

    /// Get a `Boolean`.
    pub fn get_boolean(&self, vr: u32) -> Result<bool, FmuError> {
        match (vr, self.config.kind) {
            (vr::SATURATED, FmuKind::Compensator) => Ok(self.state.saturated),
            (vr::FAULT, _) => Ok(self.state.fault),
            _ => Err(FmuError::UnknownVariable(vr)),
        }
    }

    /// Get a `String`.
    pub fn get_string(&self, vr: u32) -> Result<&str, FmuError> {
        match (vr, self.config.kind) {
            (vr::MODEL_FILE, _) => Ok(&self.model_file),
            (vr::BEAM_FILE, FmuKind::Plant) => Ok(&self.beam_file),
            _ => Err(FmuError::UnknownVariable(vr)),
        }
    }

    /// Set a `String` parameter: another model (or beam) file, loaded when
    /// initialization ends (and checked then).
    pub fn set_string(&mut self, vr: u32, value: &str) -> Result<(), FmuError> {
        match (vr, self.config.kind) {
            (vr::MODEL_FILE, _) => {
                self.settable_now("model_file", true)?;
                self.model_file = value.into();
            }
            (vr::BEAM_FILE, FmuKind::Plant) => {
                self.settable_now("beam_file", true)?;
                self.beam_file = value.into();
            }
            _ => return Err(FmuError::UnknownVariable(vr)),
        }
        self.state.live = None;
        Ok(())
    }

    /// A copy of everything the next outputs depend on.
    pub fn save(&self) -> Box<State> {
        Box::new(self.state.clone())
    }

    /// Restore a saved state (of an instance of the same FMU).
    pub fn restore(&mut self, state: &State) {
        self.state.clone_from(state);
    }
}
