//! What the adapters read of an imported FMU's `modelDescription.xml`
//! (FMI 2.0 or 3.0, Co-Simulation).

use super::{FmiVersion, ImportError, VariableType};

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
