//! The three kinds of FMU and their variables: one table for FMI 2.0 and
//! 3.0 (the description writes it in each version's form), and the
//! configuration the packager writes into `resources/mfcbeam-fmu.json`.

use serde::{Deserialize, Serialize};

#[cfg(feature = "beam")]
use crate::beam::step_response_fit::BeamModelKind;

/// What an FMU contains.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum FmuKind {
    /// The compensator `W⁻¹` (21): `y_d` in; `u`, `saturated`, `fault` out.
    Compensator,
    /// The actuator model `W`: `u` in, `y` out.
    Model,
    /// `W` and the beam: the balanced patch voltage `u` in; the tip
    /// deflection `y`, the effective voltage `v` and the modal state out.
    Plant,
    /// A built-in feedback design of the closed loop: `reference` and
    /// `measurement` in; `correction` and `held` out.
    Controller,
}

impl FmuKind {
    /// The kind's name in file names and `modelIdentifier`s.
    pub fn name(self) -> &'static str {
        match self {
            FmuKind::Compensator => "compensator",
            FmuKind::Model => "model",
            FmuKind::Plant => "plant",
            FmuKind::Controller => "controller",
        }
    }
}

/// FMI 2.0 or 3.0.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum FmiVersion {
    #[serde(rename = "2.0")]
    Fmi2,
    #[serde(rename = "3.0")]
    Fmi3,
}

impl FmiVersion {
    pub fn as_str(self) -> &'static str {
        match self {
            FmiVersion::Fmi2 => "2.0",
            FmiVersion::Fmi3 => "3.0",
        }
    }
}

/// The beam's discretization as the configuration stores it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "kebab-case")]
pub enum BeamDiscretization {
    /// The paper's Ritz model.
    Ritz,
    /// Finite elements reduced to the beam file's `basis_functions` modes.
    Modal { elements: usize },
}

#[cfg(feature = "beam")]
impl From<BeamModelKind> for BeamDiscretization {
    fn from(k: BeamModelKind) -> Self {
        match k {
            BeamModelKind::Ritz => BeamDiscretization::Ritz,
            BeamModelKind::Modal { elements } => BeamDiscretization::Modal { elements },
        }
    }
}

#[cfg(feature = "beam")]
impl From<BeamDiscretization> for BeamModelKind {
    fn from(k: BeamDiscretization) -> Self {
        match k {
            BeamDiscretization::Ritz => BeamModelKind::Ritz,
            BeamDiscretization::Modal { elements } => BeamModelKind::Modal { elements },
        }
    }
}

/// `resources/mfcbeam-fmu.json`: what the packager decided, read by the
/// FMU when it is instantiated.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FmuConfig {
    pub kind: FmuKind,
    pub fmi_version: FmiVersion,
    /// The GUID (FMI 2) or instantiation token (FMI 3) of the description.
    pub token: String,
    /// The model file under `resources/` (the controller's: its controller
    /// file).
    pub model: String,
    /// The plant's discretized beam under `resources/` (a
    /// [`DiscreteBeamFile`](crate::beam::simulation::DiscreteBeamFile)).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub beam: Option<String>,
    /// How the plant's beam was discretized when it was packaged (the
    /// beam file it came from is `resources/beam.json`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub beam_model: Option<BeamDiscretization>,
    /// The plant's number of modes: its modal-state outputs were fixed
    /// when it was packaged, so a beam loaded later must have as many.
    #[serde(default)]
    pub modes: usize,
}

/// The name of the configuration under `resources/`.
pub const CONFIG_FILE: &str = "mfcbeam-fmu.json";

/// The FMI type of a variable.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum VariableType {
    Float64,
    Int32,
    Boolean,
    String,
}

/// A variable's causality (FMI's names).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Causality {
    Independent,
    Input,
    Output,
    Parameter,
    CalculatedParameter,
}

impl Causality {
    pub fn as_str(self) -> &'static str {
        match self {
            Causality::Independent => "independent",
            Causality::Input => "input",
            Causality::Output => "output",
            Causality::Parameter => "parameter",
            Causality::CalculatedParameter => "calculatedParameter",
        }
    }
}

/// One variable of an FMU.
#[derive(Debug, Clone, PartialEq)]
pub struct Variable {
    pub name: String,
    /// Unique over all types (as FMI 3 requires; FMI 2 accepts it too).
    pub value_reference: u32,
    pub ty: VariableType,
    pub causality: Causality,
    pub description: String,
    /// Start value (inputs, outputs, parameters); `None` for calculated
    /// parameters and the independent time.
    pub start: Option<String>,
}

/// Value references, the same in every kind where a variable exists.
pub mod vr {
    pub const TIME: u32 = 0;
    /// `y_d` (compensator) or `u` (model, plant).
    pub const INPUT: u32 = 1;
    /// `u` (compensator), `y` (model: effective voltage; plant: tip deflection).
    pub const OUTPUT: u32 = 2;
    pub const SATURATED: u32 = 3;
    pub const FAULT: u32 = 4;
    pub const U_MIN: u32 = 5;
    pub const U_MAX: u32 = 6;
    pub const SAMPLE_TIME: u32 = 7;
    pub const DELAY: u32 = 8;
    pub const MODEL_FILE: u32 = 9;
    pub const BEAM_FILE: u32 = 10;
    /// The plant's effective voltage `v = W[u]`.
    pub const EFFECTIVE_VOLTAGE: u32 = 11;
    /// The controller's measurement.
    pub const MEASUREMENT: u32 = 12;
    /// Mode `j` (from 0): real part at `MODAL + 2j`, imaginary at `MODAL + 2j + 1`.
    pub const MODAL: u32 = 100;
}

fn var(
    name: &str,
    value_reference: u32,
    ty: VariableType,
    causality: Causality,
    start: Option<&str>,
    description: &str,
) -> Variable {
    Variable {
        name: name.into(),
        value_reference,
        ty,
        causality,
        description: description.into(),
        start: start.map(str::to_string),
    }
}

/// The variables of a kind; `modes` is the plant's number of modes.
/// The independent variable `time` is listed for FMI 3 only.
pub fn variables(kind: FmuKind, modes: usize) -> Vec<Variable> {
    use Causality::*;
    use VariableType::*;
    let mut v = vec![var(
        "time",
        vr::TIME,
        Float64,
        Independent,
        None,
        "simulation time (s)",
    )];
    let sample_time = var(
        "sample_time",
        vr::SAMPLE_TIME,
        Float64,
        CalculatedParameter,
        None,
        "sample time Ts of the model (s): every communication step is a whole multiple of it",
    );
    let delay = var(
        "delay",
        vr::DELAY,
        Int32,
        CalculatedParameter,
        None,
        "dead time d of the model (samples)",
    );
    let model_file = if kind == FmuKind::Controller {
        var(
            "controller_file",
            vr::MODEL_FILE,
            String,
            Parameter,
            Some(""),
            "controller file (JSON) to load instead of the one in resources/ (empty: resources/controller.json)",
        )
    } else {
        var(
            "model_file",
            vr::MODEL_FILE,
            String,
            Parameter,
            Some(""),
            "model file (JSON) to load instead of the one in resources/ (empty: resources/model.json)",
        )
    };
    match kind {
        FmuKind::Compensator => {
            v.push(var("y_d", vr::INPUT, Float64, Input, Some("0"), "target effective voltage y_d (V); with a dead time d, the target wanted d samples later"));
            v.push(var(
                "u",
                vr::OUTPUT,
                Float64,
                Output,
                Some("0"),
                "balanced patch voltage u = W^-1[y_d] (V), clipped to [u_min, u_max]",
            ));
            v.push(var(
                "saturated",
                vr::SATURATED,
                Boolean,
                Output,
                Some("false"),
                "u was clipped to a limit in the last step",
            ));
            v.push(var(
                "fault",
                vr::FAULT,
                Boolean,
                Output,
                Some("false"),
                "y_d was not a finite number in the last step: the previous u is held",
            ));
            v.push(var(
                "u_min",
                vr::U_MIN,
                Float64,
                Parameter,
                Some("-1000"),
                "lower limit of u (V)",
            ));
            v.push(var(
                "u_max",
                vr::U_MAX,
                Float64,
                Parameter,
                Some("1000"),
                "upper limit of u (V)",
            ));
        }
        FmuKind::Model => {
            v.push(var(
                "u",
                vr::INPUT,
                Float64,
                Input,
                Some("0"),
                "balanced patch voltage u (V)",
            ));
            v.push(var(
                "y",
                vr::OUTPUT,
                Float64,
                Output,
                Some("0"),
                "effective voltage y = W[u] (V)",
            ));
            v.push(var(
                "fault",
                vr::FAULT,
                Boolean,
                Output,
                Some("false"),
                "u was not a finite number in the last step: the previous u is held",
            ));
        }
        FmuKind::Controller => {
            v.push(var(
                "reference",
                vr::INPUT,
                Float64,
                Input,
                Some("0"),
                "reference tip deflection y_d (m) at the start of the step",
            ));
            v.push(var(
                "measurement",
                vr::MEASUREMENT,
                Float64,
                Input,
                Some("0"),
                "measured tip deflection (m) at the start of the step, before the correction acts",
            ));
            v.push(var(
                "correction",
                vr::OUTPUT,
                Float64,
                Output,
                Some("0"),
                "correction of the effective voltage (V), added to the feedforward before the compensator",
            ));
            v.push(var(
                "held",
                vr::FAULT,
                Boolean,
                Output,
                Some("false"),
                "an input was not a finite number in the last step: the previous correction is held",
            ));
        }
        FmuKind::Plant => {
            v.push(var(
                "u",
                vr::INPUT,
                Float64,
                Input,
                Some("0"),
                "balanced patch voltage u (V): the patches get u_bar + u and u_bar - u (1)",
            ));
            v.push(var(
                "y",
                vr::OUTPUT,
                Float64,
                Output,
                Some("0"),
                "tip deflection (m) at the end of the step",
            ));
            v.push(var(
                "v",
                vr::EFFECTIVE_VOLTAGE,
                Float64,
                Output,
                Some("0"),
                "effective voltage v = W[u] (V) that drove the beam in the last sample",
            ));
            v.push(var(
                "fault",
                vr::FAULT,
                Boolean,
                Output,
                Some("false"),
                "u was not a finite number in the last step: the previous u is held",
            ));
            v.push(var("beam_file", vr::BEAM_FILE, String, Parameter, Some(""), "discretized beam file (JSON, as resources/discrete_beam.json) to load instead of that one (empty: resources/discrete_beam.json); at the model's sample time, with as many modes"));
            for j in 0..modes {
                let (k, n) = (j as u32, j + 1);
                let part = |name: std::string::String,
                            vr: u32,
                            description: std::string::String| Variable {
                    name,
                    value_reference: vr,
                    ty: Float64,
                    causality: Output,
                    description,
                    start: Some("0".into()),
                };
                v.push(part(
                    format!("z_re_{n}"),
                    vr::MODAL + 2 * k,
                    format!("real part of the complex modal coordinate of mode {n} (the tip deflection is the sum over the modes of Re(c_j z_j))"),
                ));
                v.push(part(
                    format!("z_im_{n}"),
                    vr::MODAL + 2 * k + 1,
                    format!("imaginary part of the complex modal coordinate of mode {n}"),
                ));
            }
        }
    }
    v.extend([sample_time, delay, model_file]);
    v
}
