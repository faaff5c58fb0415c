//! `modelDescription.xml` of an FMU, for FMI 2.0 and 3.0 Co-Simulation,
//! from the variable table of [`super::variables`]. The outputs declare
//! no dependencies: none depends on an input at the same communication
//! point.

use super::variables::{variables, Causality, FmiVersion, FmuConfig, VariableType};

/// XML-escape an attribute value.
fn escape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&apos;"),
            c => out.push(c),
        }
    }
    out
}

/// The `modelIdentifier` (and shared-library name) of an FMU of `config`.
pub fn model_identifier(config: &FmuConfig) -> String {
    format!("mfcbeam_{}", config.kind.name())
}

/// What the description says of the FMU, besides the variables.
#[derive(Debug, Clone, PartialEq)]
pub struct DescriptionInfo {
    pub sample_time: f64,
    pub delay: usize,
    pub description: String,
    pub generation_tool: String,
}

/// The model description of an FMU of `config`.
pub fn model_description(config: &FmuConfig, info: &DescriptionInfo) -> String {
    let vars = variables(config.kind, config.modes);
    let id = model_identifier(config);
    let ts = format!("{:?}", info.sample_time);
    let timing = format!(
        "Sampled at Ts = {ts} s; every communication step is a whole multiple of Ts, the input held over it. \
         Outputs after a step answer the input set before it (one communication step later than a sampled trace); \
         no output depends on an input at the same communication point. The model's dead time is d = {} samples \
         (parameter 'delay'): an FMU cannot preview, so give the compensator the target wanted d samples later.",
        info.delay
    );
    let description = escape(&format!("{} {timing}", info.description));
    let mut x = String::from("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n");
    match config.fmi_version {
        FmiVersion::Fmi2 => {
            x += &format!(
                "<fmiModelDescription fmiVersion=\"2.0\" modelName=\"{id}\" guid=\"{}\" description=\"{description}\" \
                 generationTool=\"{}\" variableNamingConvention=\"flat\" numberOfEventIndicators=\"0\">\n",
                escape(&config.token),
                escape(&info.generation_tool)
            );
            x += &format!(
                "  <CoSimulation modelIdentifier=\"{id}\" canHandleVariableCommunicationStepSize=\"true\" \
                 canGetAndSetFMUstate=\"true\" canSerializeFMUstate=\"false\" canNotUseMemoryManagementFunctions=\"true\" \
                 canInterpolateInputs=\"false\" canRunAsynchronuously=\"false\" canBeInstantiatedOnlyOncePerProcess=\"false\"/>\n"
            );
            x += &format!("  <DefaultExperiment startTime=\"0\" stepSize=\"{ts}\"/>\n");
            x += "  <ModelVariables>\n";
            let mut outputs = Vec::new();
            let mut initial = Vec::new();
            for v in vars
                .iter()
                .filter(|v| v.causality != Causality::Independent)
            {
                let (variability, initial_attr) = match v.causality {
                    Causality::Input => ("discrete", ""),
                    Causality::Output => ("discrete", " initial=\"exact\""),
                    Causality::Parameter => ("fixed", " initial=\"exact\""),
                    Causality::CalculatedParameter => ("fixed", " initial=\"calculated\""),
                    Causality::Independent => unreachable!(),
                };
                x += &format!(
                    "    <ScalarVariable name=\"{}\" valueReference=\"{}\" description=\"{}\" causality=\"{}\" variability=\"{variability}\"{initial_attr}>\n",
                    escape(&v.name),
                    v.value_reference,
                    escape(&v.description),
                    v.causality.as_str()
                );
                let ty = match v.ty {
                    VariableType::Float64 => "Real",
                    VariableType::Int32 => "Integer",
                    VariableType::Boolean => "Boolean",
                    VariableType::String => "String",
                };
                match &v.start {
                    Some(s) => x += &format!("      <{ty} start=\"{}\"/>\n", escape(s)),
                    None => x += &format!("      <{ty}/>\n"),
                }
                x += "    </ScalarVariable>\n";
            }
            x += "  </ModelVariables>\n";
            // 1-based indices into ModelVariables
            let listed: Vec<_> = vars
                .iter()
                .filter(|v| v.causality != Causality::Independent)
                .collect();
            for (i, v) in listed.iter().enumerate() {
                match v.causality {
                    Causality::Output => outputs.push(i + 1),
                    Causality::CalculatedParameter => initial.push(i + 1),
                    _ => {}
                }
            }
            x += "  <ModelStructure>\n    <Outputs>\n";
            for i in &outputs {
                x += &format!("      <Unknown index=\"{i}\" dependencies=\"\"/>\n");
            }
            x += "    </Outputs>\n    <InitialUnknowns>\n";
            for i in &initial {
                x += &format!("      <Unknown index=\"{i}\" dependencies=\"\"/>\n");
            }
            x += "    </InitialUnknowns>\n  </ModelStructure>\n</fmiModelDescription>\n";
        }
        FmiVersion::Fmi3 => {
            x += &format!(
                "<fmiModelDescription fmiVersion=\"3.0\" modelName=\"{id}\" instantiationToken=\"{}\" description=\"{description}\" \
                 generationTool=\"{}\" variableNamingConvention=\"flat\">\n",
                escape(&config.token),
                escape(&info.generation_tool)
            );
            x += &format!(
                "  <CoSimulation modelIdentifier=\"{id}\" canHandleVariableCommunicationStepSize=\"true\" \
                 canGetAndSetFMUState=\"true\" canSerializeFMUState=\"false\" fixedInternalStepSize=\"{ts}\" \
                 canReturnEarlyAfterIntermediateUpdate=\"false\" hasEventMode=\"false\" providesIntermediateUpdate=\"false\"/>\n"
            );
            x += &format!("  <DefaultExperiment startTime=\"0\" stepSize=\"{ts}\"/>\n");
            x += "  <ModelVariables>\n";
            for v in &vars {
                let ty = match v.ty {
                    VariableType::Float64 => "Float64",
                    VariableType::Int32 => "Int32",
                    VariableType::Boolean => "Boolean",
                    VariableType::String => "String",
                };
                let (variability, initial_attr) = match v.causality {
                    Causality::Independent => ("continuous", ""),
                    Causality::Input => ("discrete", ""),
                    Causality::Output => ("discrete", " initial=\"exact\""),
                    Causality::Parameter => ("fixed", " initial=\"exact\""),
                    Causality::CalculatedParameter => ("fixed", " initial=\"calculated\""),
                };
                let head = format!(
                    "    <{ty} name=\"{}\" valueReference=\"{}\" description=\"{}\" causality=\"{}\" variability=\"{variability}\"{initial_attr}",
                    escape(&v.name),
                    v.value_reference,
                    escape(&v.description),
                    v.causality.as_str()
                );
                x += &match (&v.start, v.ty) {
                    (Some(s), VariableType::String) => {
                        format!(
                            "{head}>\n      <Start value=\"{}\"/>\n    </{ty}>\n",
                            escape(s)
                        )
                    }
                    (Some(s), _) => format!("{head} start=\"{}\"/>\n", escape(s)),
                    (None, _) => format!("{head}/>\n"),
                };
            }
            x += "  </ModelVariables>\n  <ModelStructure>\n";
            for v in vars.iter().filter(|v| v.causality == Causality::Output) {
                x += &format!(
                    "    <Output valueReference=\"{}\" dependencies=\"\"/>\n",
                    v.value_reference
                );
            }
            for v in vars
                .iter()
                .filter(|v| v.causality == Causality::CalculatedParameter)
            {
                x += &format!(
                    "    <InitialUnknown valueReference=\"{}\" dependencies=\"\"/>\n",
                    v.value_reference
                );
            }
            x += "  </ModelStructure>\n</fmiModelDescription>\n";
        }
    }
    x
}
