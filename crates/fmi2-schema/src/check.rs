//! Consistency checks in the spirit of `fmpy validate`: every problem is collected.
use std::collections::HashSet;

use crate::{Causality, ModelDescription, Variability, VariableType};

impl ModelDescription {
    /// Every inconsistency found, as one sentence each; empty when the description is sound.
    pub fn problems(&self) -> Vec<String> {
        let mut out = Vec::new();
        if self.fmi_version != "2.0" {
            out.push(format!("fmiVersion is {:?}, expected \"2.0\"", self.fmi_version));
        }
        if self.co_simulation.is_none() && self.model_exchange.is_none() {
            out.push("neither CoSimulation nor ModelExchange is declared".into());
        }
        let units: HashSet<&str> = self.unit_definitions.iter().flat_map(|u| u.units.iter().map(|u| u.name.as_str())).collect();
        let types: HashSet<&str> = self.type_definitions.iter().flat_map(|t| t.simple_types.iter().map(|t| t.name.as_str())).collect();
        let mut names = HashSet::new();
        let mut refs = HashSet::new();
        for v in self.variables() {
            if !names.insert(v.name.as_str()) {
                out.push(format!("variable name {:?} is used twice", v.name));
            }
            let kind = std::mem::discriminant(&v.ty);
            if !refs.insert((kind, v.value_reference)) {
                out.push(format!("{}: value reference {} is used twice for one type", v.name, v.value_reference));
            }
            let has_start = match &v.ty {
                VariableType::Real(r) => {
                    if let Some(u) = &r.unit
                        && !units.contains(u.as_str())
                    {
                        out.push(format!("{}: unit {u:?} is not in UnitDefinitions", v.name));
                    }
                    if let (Some(lo), Some(hi)) = (r.min, r.max)
                        && lo > hi
                    {
                        out.push(format!("{}: min {lo} > max {hi}", v.name));
                    }
                    if let Some(s) = r.start
                        && (r.min.is_some_and(|lo| s < lo) || r.max.is_some_and(|hi| s > hi))
                    {
                        out.push(format!("{}: start {s} is outside [min, max]", v.name));
                    }
                    r.start.is_some()
                }
                VariableType::Integer(i) => i.start.is_some(),
                VariableType::Boolean(b) => b.start.is_some(),
                VariableType::String(s) => s.start.is_some(),
                VariableType::Enumeration(e) => {
                    if !types.contains(e.declared_type.as_str()) {
                        out.push(format!("{}: declaredType {:?} is not in TypeDefinitions", v.name, e.declared_type));
                    }
                    e.start.is_some()
                }
            };
            let needs_start = matches!(v.causality, Causality::Parameter | Causality::Input) || v.variability == Variability::Constant;
            if needs_start && !has_start {
                out.push(format!("{}: a {:?} variable needs a start value", v.name, v.causality));
            }
            if v.causality == Causality::Output && v.variability != Variability::Constant && has_start && v.initial.is_none() {
                out.push(format!("{}: an output with default initial=calculated must not have a start value", v.name));
            }
        }
        let n = self.variables().len() as u32;
        let outputs: Vec<u32> = self.model_structure.outputs.iter().flat_map(|o| o.unknowns.iter().map(|u| u.index)).collect();
        for &i in &outputs {
            if i == 0 || i > n {
                out.push(format!("ModelStructure/Outputs: index {i} is not a variable (1..={n})"));
            }
        }
        for (i, v) in self.variables().iter().enumerate() {
            if v.causality == Causality::Output && !outputs.contains(&(i as u32 + 1)) {
                out.push(format!("{}: output is missing from ModelStructure/Outputs", v.name));
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use crate::ModelDescription;

    #[test]
    fn problems_are_collected_not_stopped_at_the_first() {
        let xml = r#"<fmiModelDescription fmiVersion="1.0" modelName="M" guid="g">
            <ModelVariables>
              <ScalarVariable name="u" valueReference="0" causality="input"><Real unit="V"/></ScalarVariable>
              <ScalarVariable name="u" valueReference="0" causality="output"><Real min="2" max="1"/></ScalarVariable>
            </ModelVariables>
            <ModelStructure/>
        </fmiModelDescription>"#;
        let p = ModelDescription::from_xml(xml).unwrap().problems();
        let text = p.join("\n");
        for needle in ["fmiVersion", "neither CoSimulation", "unit \"V\"", "used twice", "min 2 > max 1", "needs a start", "missing from ModelStructure"] {
            assert!(text.contains(needle), "{needle:?} not reported in:\n{text}");
        }
    }

    #[test]
    fn malformed_xml_is_an_error_not_a_panic() {
        for bad in ["", "<fmiModelDescription", "<a/>", "<fmiModelDescription fmiVersion='2.0'/>"] {
            assert!(ModelDescription::from_xml(bad).is_err(), "{bad:?} accepted");
        }
    }
}
