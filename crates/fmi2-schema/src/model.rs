use serde::{Deserialize, Serialize};

use crate::SchemaError;

/// Root element `fmiModelDescription`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
#[serde(rename = "fmiModelDescription")]
pub struct ModelDescription {
    /// Always `2.0` for this crate.
    #[serde(rename = "@fmiVersion")]
    pub fmi_version: String,
    /// Model name.
    #[serde(rename = "@modelName")]
    pub model_name: String,
    /// Fingerprint the binary checks at instantiation.
    #[serde(rename = "@guid")]
    pub guid: String,
    /// Free text.
    #[serde(rename = "@description", default, skip_serializing_if = "Option::is_none")]
    pub description: Option<String>,
    /// Who made the FMU.
    #[serde(rename = "@generationTool", default, skip_serializing_if = "Option::is_none")]
    pub generation_tool: Option<String>,
    /// `flat` or `structured`.
    #[serde(rename = "@variableNamingConvention", default, skip_serializing_if = "Option::is_none")]
    pub variable_naming_convention: Option<String>,
    /// Event indicators (Model Exchange only).
    #[serde(rename = "@numberOfEventIndicators", default, skip_serializing_if = "Option::is_none")]
    pub number_of_event_indicators: Option<u32>,
    /// Present when the FMU offers Model Exchange.
    #[serde(rename = "ModelExchange", default, skip_serializing_if = "Option::is_none")]
    pub model_exchange: Option<ModelExchange>,
    /// Present when the FMU offers Co-Simulation.
    #[serde(rename = "CoSimulation", default, skip_serializing_if = "Option::is_none")]
    pub co_simulation: Option<CoSimulation>,
    /// Units used by variables.
    #[serde(rename = "UnitDefinitions", default, skip_serializing_if = "Option::is_none")]
    pub unit_definitions: Option<UnitDefinitions>,
    /// Declared types (enumerations, …).
    #[serde(rename = "TypeDefinitions", default, skip_serializing_if = "Option::is_none")]
    pub type_definitions: Option<TypeDefinitions>,
    /// Categories accepted by `fmi2SetDebugLogging`.
    #[serde(rename = "LogCategories", default, skip_serializing_if = "Option::is_none")]
    pub log_categories: Option<LogCategories>,
    /// Suggested experiment.
    #[serde(rename = "DefaultExperiment", default, skip_serializing_if = "Option::is_none")]
    pub default_experiment: Option<DefaultExperiment>,
    /// The variables, in index order (index = position + 1).
    #[serde(rename = "ModelVariables")]
    pub model_variables: ModelVariables,
    /// Outputs and their dependencies.
    #[serde(rename = "ModelStructure")]
    pub model_structure: ModelStructure,
}

/// `ModelExchange` element (only its identifier matters to this project).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
pub struct ModelExchange {
    /// Name of the shared library without extension.
    #[serde(rename = "@modelIdentifier")]
    pub model_identifier: String,
}

/// `CoSimulation` element with its capability flags.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
pub struct CoSimulation {
    /// Name of the shared library without extension.
    #[serde(rename = "@modelIdentifier")]
    pub model_identifier: String,
    /// The FMU needs an external tool.
    #[serde(rename = "@needsExecutionTool", default, skip_serializing_if = "Option::is_none")]
    pub needs_execution_tool: Option<bool>,
    /// Communication steps may vary in length.
    #[serde(rename = "@canHandleVariableCommunicationStepSize", default, skip_serializing_if = "Option::is_none")]
    pub can_handle_variable_communication_step_size: Option<bool>,
    /// Input derivatives are used.
    #[serde(rename = "@canInterpolateInputs", default, skip_serializing_if = "Option::is_none")]
    pub can_interpolate_inputs: Option<bool>,
    /// Highest output derivative order offered.
    #[serde(rename = "@maxOutputDerivativeOrder", default, skip_serializing_if = "Option::is_none")]
    pub max_output_derivative_order: Option<u32>,
    /// Only one instance per process.
    #[serde(rename = "@canBeInstantiatedOnlyOncePerProcess", default, skip_serializing_if = "Option::is_none")]
    pub can_be_instantiated_only_once_per_process: Option<bool>,
    /// The FMU does not use the host's allocator.
    #[serde(rename = "@canNotUseMemoryManagementFunctions", default, skip_serializing_if = "Option::is_none")]
    pub can_not_use_memory_management_functions: Option<bool>,
    /// `fmi2GetFMUstate`/`fmi2SetFMUstate` work.
    #[serde(rename = "@canGetAndSetFMUstate", default, skip_serializing_if = "Option::is_none")]
    pub can_get_and_set_fmu_state: Option<bool>,
    /// FMU states can be serialized.
    #[serde(rename = "@canSerializeFMUstate", default, skip_serializing_if = "Option::is_none")]
    pub can_serialize_fmu_state: Option<bool>,
    /// `fmi2GetDirectionalDerivative` works.
    #[serde(rename = "@providesDirectionalDerivative", default, skip_serializing_if = "Option::is_none")]
    pub provides_directional_derivative: Option<bool>,
}

/// `UnitDefinitions`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
pub struct UnitDefinitions {
    /// Units.
    #[serde(rename = "Unit", default)]
    pub units: Vec<Unit>,
}

/// One unit with its SI base-unit exponents.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
pub struct Unit {
    /// Unit name as referenced by variables.
    #[serde(rename = "@name")]
    pub name: String,
    /// SI exponents.
    #[serde(rename = "BaseUnit", default, skip_serializing_if = "Option::is_none")]
    pub base_unit: Option<BaseUnit>,
}

/// Exponents of the SI base units (absent = 0).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
#[allow(missing_docs)]
pub struct BaseUnit {
    #[serde(rename = "@kg", default, skip_serializing_if = "is_zero")]
    pub kg: i32,
    #[serde(rename = "@m", default, skip_serializing_if = "is_zero")]
    pub m: i32,
    #[serde(rename = "@s", default, skip_serializing_if = "is_zero")]
    pub s: i32,
    #[serde(rename = "@A", default, skip_serializing_if = "is_zero")]
    pub a: i32,
}

fn is_zero(x: &i32) -> bool {
    *x == 0
}

/// `TypeDefinitions`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
pub struct TypeDefinitions {
    /// Declared types.
    #[serde(rename = "SimpleType", default)]
    pub simple_types: Vec<SimpleType>,
}

/// A declared type; only enumerations are typed here.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
pub struct SimpleType {
    /// Type name referenced by `declaredType`.
    #[serde(rename = "@name")]
    pub name: String,
    /// Free text.
    #[serde(rename = "@description", default, skip_serializing_if = "Option::is_none")]
    pub description: Option<String>,
    /// Items, when the type is an enumeration.
    #[serde(rename = "Enumeration", default, skip_serializing_if = "Option::is_none")]
    pub enumeration: Option<EnumerationType>,
}

/// Items of an enumeration type.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
pub struct EnumerationType {
    /// Items.
    #[serde(rename = "Item", default)]
    pub items: Vec<Item>,
}

/// One enumeration item.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
pub struct Item {
    /// Item name.
    #[serde(rename = "@name")]
    pub name: String,
    /// Integer value.
    #[serde(rename = "@value")]
    pub value: i32,
    /// Free text.
    #[serde(rename = "@description", default, skip_serializing_if = "Option::is_none")]
    pub description: Option<String>,
}

/// `LogCategories`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
pub struct LogCategories {
    /// Categories.
    #[serde(rename = "Category", default)]
    pub categories: Vec<Category>,
}

/// One log category.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
pub struct Category {
    /// Name passed to the logger.
    #[serde(rename = "@name")]
    pub name: String,
    /// Free text.
    #[serde(rename = "@description", default, skip_serializing_if = "Option::is_none")]
    pub description: Option<String>,
}

/// `DefaultExperiment`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
#[allow(missing_docs)]
pub struct DefaultExperiment {
    #[serde(rename = "@startTime", default, skip_serializing_if = "Option::is_none")]
    pub start_time: Option<f64>,
    #[serde(rename = "@stopTime", default, skip_serializing_if = "Option::is_none")]
    pub stop_time: Option<f64>,
    #[serde(rename = "@tolerance", default, skip_serializing_if = "Option::is_none")]
    pub tolerance: Option<f64>,
    #[serde(rename = "@stepSize", default, skip_serializing_if = "Option::is_none")]
    pub step_size: Option<f64>,
}

/// `ModelVariables`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
pub struct ModelVariables {
    /// Variables in index order.
    #[serde(rename = "ScalarVariable", default)]
    pub variables: Vec<ScalarVariable>,
}

/// One `ScalarVariable`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ScalarVariable {
    /// Unique name.
    #[serde(rename = "@name")]
    pub name: String,
    /// Handle used by get/set calls.
    #[serde(rename = "@valueReference")]
    pub value_reference: u32,
    /// Free text.
    #[serde(rename = "@description", default, skip_serializing_if = "Option::is_none")]
    pub description: Option<String>,
    /// Role of the variable (default `local`).
    #[serde(rename = "@causality", default)]
    pub causality: Causality,
    /// When it may change (default `continuous`).
    #[serde(rename = "@variability", default)]
    pub variability: Variability,
    /// How the start value is meant.
    #[serde(rename = "@initial", default, skip_serializing_if = "Option::is_none")]
    pub initial: Option<Initial>,
    /// Type element with its attributes.
    #[serde(rename = "$value")]
    pub ty: VariableType,
}

/// FMI 2.0 causality.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "camelCase")]
#[allow(missing_docs)]
pub enum Causality {
    Parameter,
    CalculatedParameter,
    Input,
    Output,
    #[default]
    Local,
    Independent,
}

/// FMI 2.0 variability.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "camelCase")]
#[allow(missing_docs)]
pub enum Variability {
    Constant,
    Fixed,
    Tunable,
    Discrete,
    #[default]
    Continuous,
}

/// FMI 2.0 `initial` attribute.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
#[allow(missing_docs)]
pub enum Initial {
    Exact,
    Approx,
    Calculated,
}

/// The type element of a variable.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[allow(missing_docs)]
pub enum VariableType {
    Real(RealType),
    Integer(IntegerType),
    Boolean(BooleanType),
    String(StringType),
    Enumeration(EnumerationVariable),
}

/// `Real` attributes.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
#[allow(missing_docs)]
pub struct RealType {
    #[serde(rename = "@declaredType", default, skip_serializing_if = "Option::is_none")]
    pub declared_type: Option<String>,
    #[serde(rename = "@unit", default, skip_serializing_if = "Option::is_none")]
    pub unit: Option<String>,
    #[serde(rename = "@min", default, skip_serializing_if = "Option::is_none")]
    pub min: Option<f64>,
    #[serde(rename = "@max", default, skip_serializing_if = "Option::is_none")]
    pub max: Option<f64>,
    #[serde(rename = "@start", default, skip_serializing_if = "Option::is_none")]
    pub start: Option<f64>,
}

/// `Integer` attributes.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
#[allow(missing_docs)]
pub struct IntegerType {
    #[serde(rename = "@min", default, skip_serializing_if = "Option::is_none")]
    pub min: Option<i32>,
    #[serde(rename = "@max", default, skip_serializing_if = "Option::is_none")]
    pub max: Option<i32>,
    #[serde(rename = "@start", default, skip_serializing_if = "Option::is_none")]
    pub start: Option<i32>,
}

/// `Boolean` attributes.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
#[allow(missing_docs)]
pub struct BooleanType {
    #[serde(rename = "@start", default, skip_serializing_if = "Option::is_none")]
    pub start: Option<bool>,
}

/// `String` attributes.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
#[allow(missing_docs)]
pub struct StringType {
    #[serde(rename = "@start", default, skip_serializing_if = "Option::is_none")]
    pub start: Option<String>,
}

/// `Enumeration` attributes of a variable.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
#[allow(missing_docs)]
pub struct EnumerationVariable {
    #[serde(rename = "@declaredType")]
    pub declared_type: String,
    #[serde(rename = "@start", default, skip_serializing_if = "Option::is_none")]
    pub start: Option<i32>,
}

/// `ModelStructure`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
pub struct ModelStructure {
    /// Outputs.
    #[serde(rename = "Outputs", default, skip_serializing_if = "Option::is_none")]
    pub outputs: Option<Unknowns>,
    /// State derivatives (Model Exchange).
    #[serde(rename = "Derivatives", default, skip_serializing_if = "Option::is_none")]
    pub derivatives: Option<Unknowns>,
    /// Unknowns computed during initialization.
    #[serde(rename = "InitialUnknowns", default, skip_serializing_if = "Option::is_none")]
    pub initial_unknowns: Option<Unknowns>,
}

/// A list of `Unknown` elements.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
pub struct Unknowns {
    /// Unknowns.
    #[serde(rename = "Unknown", default)]
    pub unknowns: Vec<Unknown>,
}

/// One unknown, by 1-based variable index.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
pub struct Unknown {
    /// 1-based index into `ModelVariables`.
    #[serde(rename = "@index")]
    pub index: u32,
    /// Space-separated indices it depends on (absent = all).
    #[serde(rename = "@dependencies", default, skip_serializing_if = "Option::is_none")]
    pub dependencies: Option<String>,
}

/// The root element's `fmiVersion` attribute, read without the FMI 2.0 structure: tells an
/// FMI 1.0 or 3.0 file (which [`ModelDescription::from_xml`] cannot read) from a broken 2.0 one.
///
/// ```
/// let v = fmi2_schema::fmi_version_of(r#"<fmiModelDescription fmiVersion="3.0"><ModelVariables/></fmiModelDescription>"#);
/// assert_eq!(v.as_deref(), Some("3.0"));
/// ```
pub fn fmi_version_of(xml: &str) -> Option<String> {
    #[derive(Deserialize)]
    struct Root {
        #[serde(rename = "@fmiVersion")]
        fmi_version: String,
    }
    guarded(|| quick_xml::de::from_str::<Root>(xml).map_err(SchemaError::from)).ok().map(|r| r.fmi_version)
}

/// Runs a quick-xml deserialization, turning a panic inside the parser into an error: a
/// hostile modelDescription.xml must not take the importer's process down (found by fuzzing:
/// `fuzz/regressions/model_description/quick-xml-doctype-in-text-panic.xml`).
fn guarded<T>(parse: impl FnOnce() -> Result<T, SchemaError> + std::panic::UnwindSafe) -> Result<T, SchemaError> {
    std::panic::catch_unwind(parse).unwrap_or_else(|panic| {
        let what = panic.downcast_ref::<&str>().map(|s| (*s).to_owned()).or_else(|| panic.downcast_ref::<String>().cloned()).unwrap_or_else(|| "panic".to_owned());
        Err(SchemaError::ParserPanic(what))
    })
}

impl ModelDescription {
    /// Parses a `modelDescription.xml` document.
    pub fn from_xml(xml: &str) -> Result<Self, SchemaError> {
        guarded(|| Ok(quick_xml::de::from_str(xml)?))
    }

    /// Writes the document with an XML declaration and two-space indentation.
    pub fn to_xml(&self) -> Result<String, SchemaError> {
        let mut body = String::new();
        let mut ser = quick_xml::se::Serializer::new(&mut body);
        ser.indent(' ', 2);
        self.serialize(ser)?;
        Ok(format!("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n{body}\n"))
    }

    /// The variables in index order.
    pub fn variables(&self) -> &[ScalarVariable] {
        &self.model_variables.variables
    }

    /// Looks a variable up by name.
    pub fn variable(&self, name: &str) -> Option<&ScalarVariable> {
        self.variables().iter().find(|v| v.name == name)
    }
}
