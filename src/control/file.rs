//! A controller file: a built-in design with its gains, as the controller
//! FMU carries it (`resources/controller.json`, `docs/FILES.md`).
//!
//! ```json
//! {"sample_time": 0.0002, "pid": {"kp": …, "ki": …, "kd": …, "tf": …}}
//! {"sample_time": 0.0002, "state_feedback": {"modes": 4, "a": […], …}}
//! ```

use serde::{Deserialize, Serialize};

use super::pid::{Pid, PidGains};
use super::state_feedback::{StateFeedback, StateFeedbackDesign};
use super::{ControlError, Controller, LoopSample};

/// Which design, with its gains.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ControllerDesign {
    Pid(PidGains),
    StateFeedback(StateFeedbackDesign),
}

/// A controller file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ControllerFile {
    /// `T_s` (s).
    pub sample_time: f64,
    #[serde(flatten)]
    pub design: ControllerDesign,
}

/// A built-in controller, ready to run.
#[derive(Debug, Clone, PartialEq)]
pub enum BuiltController {
    Pid(Pid),
    StateFeedback(StateFeedback),
}

impl ControllerFile {
    /// The controller at rest; an error names the field that is wrong.
    pub fn build(&self) -> Result<BuiltController, ControlError> {
        let ts = self.sample_time;
        if !(ts.is_finite() && ts > 0.0) {
            return Err(ControlError::Invalid {
                field: "sample_time",
                reason: format!("must be a finite number > 0, found {ts}"),
            });
        }
        Ok(match &self.design {
            ControllerDesign::Pid(g) => BuiltController::Pid(Pid::new(*g, ts)?),
            ControllerDesign::StateFeedback(d) => {
                BuiltController::StateFeedback(StateFeedback::new(d.clone())?)
            }
        })
    }
}

impl Controller for BuiltController {
    fn name(&self) -> String {
        match self {
            Self::Pid(c) => c.name(),
            Self::StateFeedback(c) => c.name(),
        }
    }

    fn step(&mut self, sample: &LoopSample) -> Result<Option<f64>, ControlError> {
        match self {
            Self::Pid(c) => c.step(sample),
            Self::StateFeedback(c) => c.step(sample),
        }
    }
}

impl BuiltController {
    /// Whether every number of its state is finite.
    pub fn state_is_finite(&self) -> bool {
        match self {
            Self::Pid(c) => {
                let (i, d, e) = c.state();
                i.is_finite() && d.is_finite() && e.is_none_or(f64::is_finite)
            }
            Self::StateFeedback(c) => c.estimate().iter().all(|x| x.is_finite()),
        }
    }
}
