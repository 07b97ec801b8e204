//! Variables by name and typed values: the one place that picks the get/set function from a
//! variable's type, for every driver of an [`Instance`] (the estimator's plant, `simulate`).
use std::fmt;

use fmi2_schema::{Causality, ScalarVariable, Variability};

use crate::{Fmu, ImportError, Instance, VarKind};

/// A value of an FMI 2.0 variable; an Enumeration's value is its item's Integer.
#[derive(Debug, Clone, PartialEq)]
pub enum Value {
    /// `fmi2Real`.
    Real(f64),
    /// `fmi2Integer` (also Enumeration).
    Integer(i32),
    /// `fmi2Boolean`.
    Boolean(bool),
    /// `fmi2String`.
    String(String),
}

impl Value {
    /// `x` as a value of `kind`: an Integer or Enumeration must be integral and within `i32`, a
    /// Boolean 0 or 1; a String cannot come from a number. `Err` says why.
    ///
    /// ```
    /// use fmi2_import::{Value, VarKind};
    /// assert_eq!(Value::from_number(VarKind::Integer, 2.0), Ok(Value::Integer(2)));
    /// assert!(Value::from_number(VarKind::Integer, 2.5).is_err());
    /// ```
    pub fn from_number(kind: VarKind, x: f64) -> Result<Self, String> {
        match kind {
            VarKind::Real if x.is_finite() => Ok(Self::Real(x)),
            VarKind::Real => Err(format!("{x} is not a finite number")),
            VarKind::Integer | VarKind::Enumeration => {
                if x.fract() == 0.0 && (f64::from(i32::MIN)..=f64::from(i32::MAX)).contains(&x) {
                    Ok(Self::Integer(x as i32))
                } else {
                    Err(format!("{x} is not a 32-bit integer ({kind:?} variable)"))
                }
            }
            VarKind::Boolean if x == 0.0 || x == 1.0 => Ok(Self::Boolean(x == 1.0)),
            VarKind::Boolean => Err(format!("{x} is not a Boolean (0 or 1)")),
            VarKind::String => Err(format!("{x} is a number, but the variable is a String")),
        }
    }

    /// `text` as a value of `kind`: a number for Real, Integer and Enumeration (NaN and
    /// infinities refused), `true`/`false`/`1`/`0` for Boolean, the text itself for String.
    ///
    /// ```
    /// use fmi2_import::{Value, VarKind};
    /// assert_eq!(Value::parse(VarKind::Boolean, "true"), Ok(Value::Boolean(true)));
    /// assert_eq!(Value::parse(VarKind::Real, "1e-3"), Ok(Value::Real(1e-3)));
    /// assert!(Value::parse(VarKind::Real, "NaN").is_err());
    /// ```
    pub fn parse(kind: VarKind, text: &str) -> Result<Self, String> {
        let t = text.trim();
        match kind {
            VarKind::String => Ok(Self::String(text.to_owned())),
            VarKind::Boolean if t.eq_ignore_ascii_case("true") => Ok(Self::Boolean(true)),
            VarKind::Boolean if t.eq_ignore_ascii_case("false") => Ok(Self::Boolean(false)),
            _ => {
                let x = t.parse::<f64>().map_err(|_| format!("{t:?} is not a number"))?;
                Self::from_number(kind, x)
            }
        }
    }

    /// The variable kind that holds this value (Integer for an Enumeration's).
    pub fn kind(&self) -> VarKind {
        match self {
            Self::Real(_) => VarKind::Real,
            Self::Integer(_) => VarKind::Integer,
            Self::Boolean(_) => VarKind::Boolean,
            Self::String(_) => VarKind::String,
        }
    }
}

/// The value as written to a result file: Reals in the shortest form that reads back to the
/// same `f64`, Booleans as `1`/`0`, Strings as they are.
impl fmt::Display for Value {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Real(x) => write!(f, "{x}"),
            Self::Integer(n) => write!(f, "{n}"),
            Self::Boolean(b) => f.write_str(if *b { "1" } else { "0" }),
            Self::String(s) => f.write_str(s),
        }
    }
}

/// A variable resolved by name: what a get or set needs, and what may be set when.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Variable {
    /// The name in the model description.
    pub name: String,
    /// Its value reference.
    pub value_reference: u32,
    /// Its type.
    pub kind: VarKind,
    /// Its causality.
    pub causality: Causality,
    /// Its variability.
    pub variability: Variability,
}

impl Variable {
    fn of(v: &ScalarVariable) -> Self {
        Self { name: v.name.clone(), value_reference: v.value_reference, kind: VarKind::from(&v.ty), causality: v.causality, variability: v.variability }
    }

    /// Whether a master may set it between steps: an input or a tunable parameter.
    pub fn settable_while_stepping(&self) -> bool {
        self.causality == Causality::Input || (self.causality == Causality::Parameter && self.variability == Variability::Tunable)
    }

    pub(crate) fn accepts(&self, value: &Value) -> bool {
        value.kind() == self.kind || (self.kind == VarKind::Enumeration && value.kind() == VarKind::Integer)
    }
}

impl Fmu {
    /// The variable called `name`; the error for an unknown name lists the FMU's variables.
    pub fn resolve(&self, name: &str) -> Result<Variable, ImportError> {
        self.variable(name).map(Variable::of).ok_or_else(|| self.unknown_variable(name))
    }

    /// Every variable with causality `output`, in model-description order.
    pub fn outputs(&self) -> Vec<Variable> {
        self.variables().iter().filter(|v| v.causality == Causality::Output).map(Variable::of).collect()
    }
}

impl Instance {
    /// Sets `var` to `value` with the setter of its type; errors name the variable.
    pub fn set_value(&mut self, var: &Variable, value: &Value) -> Result<(), ImportError> {
        if !var.accepts(value) {
            return Err(ImportError::BadValue { name: var.name.clone(), reason: format!("a {:?} value for a {:?} variable", value.kind(), var.kind) });
        }
        let vr = [var.value_reference];
        let result = match value {
            Value::Real(x) => self.set_real(&vr, &[*x]),
            Value::Integer(n) => self.set_integer(&vr, &[*n]),
            Value::Boolean(b) => self.set_boolean(&vr, &[*b]),
            Value::String(s) => self.set_string(&vr, &[s.as_str()]),
        };
        result.map_err(|source| ImportError::Setting { name: var.name.clone(), source: Box::new(source) })
    }

    /// The values of `vars`, in their order: one get call per type present.
    pub fn get_values(&mut self, vars: &[Variable]) -> Result<Vec<Value>, ImportError> {
        let mut out = vec![Value::Real(f64::NAN); vars.len()];
        let of = |kinds: &[VarKind]| -> (Vec<usize>, Vec<u32>) { vars.iter().enumerate().filter(|(_, v)| kinds.contains(&v.kind)).map(|(i, v)| (i, v.value_reference)).unzip() };
        let (idx, vrs) = of(&[VarKind::Real]);
        if !idx.is_empty() {
            let mut x = vec![0.0; vrs.len()];
            self.get_real(&vrs, &mut x)?;
            idx.iter().zip(x).for_each(|(&i, x)| out[i] = Value::Real(x));
        }
        let (idx, vrs) = of(&[VarKind::Integer, VarKind::Enumeration]);
        if !idx.is_empty() {
            let mut x = vec![0; vrs.len()];
            self.get_integer(&vrs, &mut x)?;
            idx.iter().zip(x).for_each(|(&i, x)| out[i] = Value::Integer(x));
        }
        let (idx, vrs) = of(&[VarKind::Boolean]);
        if !idx.is_empty() {
            let mut x = vec![false; vrs.len()];
            self.get_boolean(&vrs, &mut x)?;
            idx.iter().zip(x).for_each(|(&i, x)| out[i] = Value::Boolean(x));
        }
        let (idx, vrs) = of(&[VarKind::String]);
        if !idx.is_empty() {
            let mut x = vec![String::new(); vrs.len()];
            self.get_string(&vrs, &mut x)?;
            idx.iter().zip(x).for_each(|(&i, x)| out[i] = Value::String(x));
        }
        Ok(out)
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn numbers_become_values_of_the_variable_type_or_a_reason() {
        assert_eq!(Value::from_number(VarKind::Enumeration, -3.0), Ok(Value::Integer(-3)));
        assert_eq!(Value::from_number(VarKind::Boolean, 1.0), Ok(Value::Boolean(true)));
        assert!(Value::from_number(VarKind::Boolean, 0.5).unwrap_err().contains("0 or 1"));
        assert!(Value::from_number(VarKind::Integer, 3e9).unwrap_err().contains("32-bit"));
        assert!(Value::from_number(VarKind::Real, f64::NAN).unwrap_err().contains("finite"));
        assert!(Value::from_number(VarKind::String, 1.0).is_err());
        assert_eq!(Value::parse(VarKind::String, " a b"), Ok(Value::String(" a b".into())));
        assert_eq!(Value::parse(VarKind::Integer, "7"), Ok(Value::Integer(7)));
        assert!(Value::parse(VarKind::Real, "inf").is_err());
        assert!(Value::parse(VarKind::Real, "x").unwrap_err().contains("not a number"));
    }

    #[test]
    fn display_round_trips_reals_and_writes_booleans_as_digits() {
        let x = 0.1 + 0.2;
        assert_eq!(Value::Real(x).to_string().parse::<f64>().unwrap(), x);
        assert_eq!(Value::Boolean(true).to_string(), "1");
        assert_eq!(Value::Integer(-4).to_string(), "-4");
    }
}
