//! The `modelDescription.xml` of the FMU, derived from the variable table of `buck-model`.
use buck_model::variables::{self, Causality, Type, VARIABLES, Variability};
use fmi2_schema as md;

/// `modelIdentifier` and the shared library's file stem.
pub const MODEL_IDENTIFIER: &str = "BuckConverter";

/// Log categories the FMU accepts in `fmi2SetDebugLogging`.
pub const LOG_CATEGORIES: &[(&str, &str)] =
    &[("logStatusError", "Errors: rejected values and calls (always logged)"), ("logStatusWarning", "Warnings"), ("logCalls", "Every FMI call (only with debug logging on)")];

/// The complete model description.
pub fn model_description() -> md::ModelDescription {
    let variables: Vec<md::ScalarVariable> = VARIABLES.iter().map(scalar_variable).collect();
    let outputs: Vec<md::Unknown> = VARIABLES.iter().enumerate().filter(|(_, v)| v.causality == Causality::Output).map(|(i, _)| md::Unknown { index: i as u32 + 1, dependencies: None }).collect();
    // Outputs are functions of the state only (no direct feed-through); during
    // initialization they depend on the start values, so InitialUnknowns keep the default.
    let no_feedthrough: Vec<md::Unknown> = outputs.iter().map(|u| md::Unknown { dependencies: Some(String::new()), ..u.clone() }).collect();
    md::ModelDescription {
        fmi_version: "2.0".into(),
        model_name: MODEL_IDENTIFIER.into(),
        guid: variables::guid(),
        description: Some(
            "Buck DC-DC converter (BMR450 thesis power stage): L with RL, C with ESR Rc, load capacitor Cl, \
             constant load current and an optional load resistor; exact averaged or switched PWM"
                .into(),
        ),
        generation_tool: Some(format!("buckid {}", env!("CARGO_PKG_VERSION"))),
        variable_naming_convention: Some("flat".into()),
        number_of_event_indicators: None,
        model_exchange: None,
        co_simulation: Some(md::CoSimulation {
            model_identifier: MODEL_IDENTIFIER.into(),
            needs_execution_tool: Some(false),
            can_handle_variable_communication_step_size: Some(true),
            can_interpolate_inputs: Some(false),
            max_output_derivative_order: Some(0),
            can_be_instantiated_only_once_per_process: Some(false),
            can_not_use_memory_management_functions: Some(true),
            can_get_and_set_fmu_state: Some(true),
            can_serialize_fmu_state: Some(true),
            provides_directional_derivative: Some(false),
        }),
        unit_definitions: Some(md::UnitDefinitions {
            units: variables::UNITS.iter().map(|(name, [kg, m, s, a])| md::Unit { name: (*name).into(), base_unit: Some(md::BaseUnit { kg: *kg, m: *m, s: *s, a: *a }) }).collect(),
        }),
        type_definitions: None,
        log_categories: Some(md::LogCategories { categories: LOG_CATEGORIES.iter().map(|(name, desc)| md::Category { name: (*name).into(), description: Some((*desc).into()) }).collect() }),
        default_experiment: Some(md::DefaultExperiment { start_time: Some(0.0), stop_time: Some(0.01), tolerance: None, step_size: Some(1.0 / 330e3) }),
        model_variables: md::ModelVariables { variables },
        model_structure: md::ModelStructure { outputs: Some(md::Unknowns { unknowns: no_feedthrough }), derivatives: None, initial_unknowns: Some(md::Unknowns { unknowns: outputs }) },
    }
}

fn scalar_variable(v: &variables::Variable) -> md::ScalarVariable {
    let finite = |x: f64| x.is_finite().then_some(x);
    let ty = match v.ty {
        Type::Real { unit, min, max, start } => md::VariableType::Real(md::RealType { declared_type: None, unit: Some(unit.into()), min: finite(min), max: finite(max), start }),
        Type::Integer { min, max, start } => md::VariableType::Integer(md::IntegerType { min: Some(min), max: Some(max), start: Some(start) }),
        Type::Boolean { start } => md::VariableType::Boolean(md::BooleanType { start: Some(start) }),
    };
    md::ScalarVariable {
        name: v.name.into(),
        value_reference: v.vr(),
        description: Some(v.description.into()),
        causality: match v.causality {
            Causality::Parameter => md::Causality::Parameter,
            Causality::Input => md::Causality::Input,
            Causality::Output => md::Causality::Output,
        },
        variability: match v.variability {
            Variability::Fixed => md::Variability::Fixed,
            Variability::Continuous => md::Variability::Continuous,
        },
        initial: None,
        ty,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn committed() -> String {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../modelDescription/modelDescription.xml");
        std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{path}: {e}"))
    }

    /// Fails when the variable table changed but `cargo xtask model-description` was not run.
    #[test]
    fn committed_model_description_is_up_to_date() {
        assert!(committed() == model_description().to_xml().unwrap(), "modelDescription/modelDescription.xml is stale: run `cargo xtask model-description`");
    }

    /// Reading the committed XML back gives the same description (names, references, types,
    /// ranges, start values, structure) as the table.
    #[test]
    fn committed_model_description_reads_back_as_the_table() {
        let read = md::ModelDescription::from_xml(&committed()).unwrap();
        let table = model_description();
        for (a, b) in read.variables().iter().zip(table.variables()) {
            assert_eq!(a, b, "variable {} differs: run `cargo xtask model-description`", b.name);
        }
        assert_eq!(read.variables().len(), table.variables().len(), "variable count differs");
        assert!(read == table, "header, units or structure differ: run `cargo xtask model-description`");
        assert_eq!(read.problems(), Vec::<String>::new());
        for v in VARIABLES {
            assert_eq!(read.variable(v.name).map(|s| s.value_reference), Some(v.vr()), "{}", v.name);
        }
    }
}
