//! An FMU as the controller of the closed loop ([`crate::control`]): any
//! FMI 2.0 or 3.0 Co-Simulation FMU with two `Float64` (`Real`) inputs for
//! the reference and the measurement and one output for the correction,
//! found by name (`reference`, `measurement`, `correction` unless renamed).
//!
//! Per sample `k`: set the inputs to `y_d,k` and `m_k`, one communication
//! step of `T_s` from `t_k`, read the output: that is `Δ_k`. A Boolean
//! output `held` that is true makes it nothing (held and flagged). This is the
//! convention of every mfcbeam FMU (`fmi` module docs, "Timing"): the
//! output after the step from `t_k` answers the inputs set before it.

use std::sync::Arc;

use super::import::{Fmu, FmuInstance, ImportError};
use super::variables::VariableType;
use crate::control::{ControlError, Controller, LoopSample};

/// The names the controller's variables have in the FMU.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ControllerVariables {
    pub reference: String,
    pub measurement: String,
    pub correction: String,
}

impl Default for ControllerVariables {
    fn default() -> Self {
        Self {
            reference: "reference".into(),
            measurement: "measurement".into(),
            correction: "correction".into(),
        }
    }
}

/// A controller FMU, instantiated and initialized at `t = 0`.
pub struct FmuController {
    name: String,
    instance: FmuInstance,
    reference: u32,
    measurement: u32,
    correction: u32,
    /// A Boolean output `held`, if the FMU has one: true means it held
    /// its last correction, and the loop flags the sample.
    held: Option<u32>,
    sample_time: f64,
}

impl FmuController {
    /// Bind the variables by name and start an instance.
    pub fn new(
        fmu: Arc<Fmu>,
        names: &ControllerVariables,
        sample_time: f64,
    ) -> Result<Self, ImportError> {
        let find = |name: &str, causality: &str| -> Result<u32, ImportError> {
            let v = fmu.description.variable(name).ok_or_else(|| {
                ImportError::Description(format!(
                    "no variable '{name}' (the controller needs inputs reference and \
                     measurement and an output correction; rename with --fmu-variable)"
                ))
            })?;
            if v.ty != Some(VariableType::Float64) || v.causality != causality {
                return Err(ImportError::Description(format!(
                    "'{name}' must be a Float64 (Real) {causality}, found {:?} {}",
                    v.ty, v.causality
                )));
            }
            Ok(v.value_reference)
        };
        let reference = find(&names.reference, "input")?;
        let measurement = find(&names.measurement, "input")?;
        let correction = find(&names.correction, "output")?;
        let held = fmu
            .description
            .variable("held")
            .filter(|v| v.ty == Some(VariableType::Boolean) && v.causality == "output")
            .map(|v| v.value_reference);
        let name = fmu
            .path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_else(|| "FMU".into());
        let mut instance = FmuInstance::new(fmu, "controller")?;
        instance.initialize(0.0)?;
        Ok(Self {
            name,
            instance,
            reference,
            measurement,
            correction,
            held,
            sample_time,
        })
    }
}

impl Controller for FmuController {
    fn name(&self) -> String {
        self.name.clone()
    }

    fn step(&mut self, s: &LoopSample) -> Result<Option<f64>, ControlError> {
        let fail = |e: ImportError| ControlError::Controller {
            name: self.name.clone(),
            reason: format!("at sample {}: {e}", s.k),
        };
        let i = &mut self.instance;
        let result = i
            .set_f64(self.reference, s.reference)
            .and_then(|_| i.set_f64(self.measurement, s.measurement))
            .and_then(|_| i.do_step(self.sample_time))
            .and_then(|_| i.get_f64(self.correction));
        let correction = result.map_err(fail)?;
        let held = match self.held {
            Some(vr) => i.get_bool(vr).map_err(fail)?,
            None => false,
        };
        Ok(if held { None } else { Some(correction) })
    }
}
