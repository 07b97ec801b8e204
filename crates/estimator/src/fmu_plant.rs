//! Any FMI 2.0 Co-Simulation FMU as a [`Plant`], with the estimator's signal roles mapped
//! onto the FMU's variable names.
use std::collections::BTreeMap;
use std::path::Path;

use fmi2_import::{Fmu, ImportError, Instance, Value, VarKind, Variable};
use fmi2_schema::VariableType;

use crate::error::EstimatorError;
use crate::experiment::{PeriodSample, Plant};

/// Signal roles of the estimator; each maps to an FMU variable (by default of the same name).
pub const ROLES: [&str; 8] = ["duty", "io", "vin", "vout", "il", "vout_avg", "il_avg", "duty_applied"];
/// Roles the FMU must have.
const REQUIRED: [&str; 2] = ["duty", "vout"];
/// Known circuit values read from the FMU's parameters for the metadata (never `Cl`).
const DESCRIBED: [&str; 6] = ["L", "RL", "C", "Rc", "fs", "rload"];

/// How to drive an FMU.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct FmuOptions {
    /// Role → FMU variable name, for FMUs that name things their own way.
    pub map: BTreeMap<String, String>,
    /// Role → FMU variable name applied only when the FMU has that variable and `map` does not
    /// name the role (e.g. `duty → duty_dither` in closed loop, ignored by other FMUs).
    pub default_map: Vec<(String, String)>,
    /// Start values to set before initialization, by FMU variable name.
    pub set: Vec<(String, f64)>,
    /// Start values applied only when the FMU has a variable of that name and `set` does not
    /// name it (e.g. `mode = 2` selects switched mode in our FMU, ignored by others).
    pub defaults: Vec<(String, f64)>,
    /// Switching frequency \[Hz\] when the FMU has no `fs` parameter (default 330 kHz).
    pub fs: Option<f64>,
}

fn plant_err(e: ImportError) -> EstimatorError {
    EstimatorError::Plant(e.to_string())
}

/// An FMU driven one switching period per `fmi2DoStep`.
pub struct FmuPlant {
    // Declared before `fmu`: the instance is freed before the extracted FMU is deleted.
    instance: Instance,
    fmu: Fmu,
    /// Value reference of each role the FMU has.
    roles: BTreeMap<&'static str, u32>,
    /// Start values set before each run (`--set`, then the defaults).
    settings: Vec<(Variable, Value)>,
    fs: f64,
    periods: u64,
    source: String,
}

impl std::fmt::Debug for FmuPlant {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("FmuPlant").field("source", &self.source).field("fs", &self.fs).finish_non_exhaustive()
    }
}

impl FmuPlant {
    /// Opens and instantiates the FMU at `path`. Errors name unknown variables (listing the
    /// FMU's own) and malformed FMUs.
    pub fn open(path: &Path, opts: &FmuOptions) -> Result<Self, EstimatorError> {
        let fmu = Fmu::open(path).map_err(plant_err)?;
        Self::from_fmu(fmu, path, opts)
    }

    /// Instantiates an FMU already opened from `path` (e.g. after reading its parameters'
    /// start values); errors as for [`FmuPlant::open`].
    pub fn from_fmu(fmu: Fmu, path: &Path, opts: &FmuOptions) -> Result<Self, EstimatorError> {
        for role in opts.map.keys().chain(opts.default_map.iter().map(|(r, _)| r)) {
            if !ROLES.contains(&role.as_str()) {
                return Err(EstimatorError::Config(format!("unknown role `{role}` in --map; roles are {}", ROLES.join(", "))));
            }
        }
        let mut map = opts.map.clone();
        for (role, name) in &opts.default_map {
            if fmu.variable(name).is_some() && !map.contains_key(role) {
                map.insert(role.clone(), name.clone());
            }
        }
        let mut roles = BTreeMap::new();
        for role in ROLES {
            let mapped = map.get(role);
            let name = mapped.map_or(role, String::as_str);
            match fmu.value_reference(name) {
                Ok((vr, VarKind::Real)) => {
                    roles.insert(role, vr);
                }
                Ok((_, kind)) => {
                    return Err(EstimatorError::Config(format!("FMU variable `{name}` (role {role}) is {kind:?}, not Real")));
                }
                // A role named explicitly, or a required one, must exist.
                Err(e) if mapped.is_some() || REQUIRED.contains(&role) => {
                    return Err(EstimatorError::Plant(format!("role `{role}`: {e} (use --map {role}=NAME)")));
                }
                Err(_) => {}
            }
        }
        let mut settings = Vec::new();
        let defaults = opts.defaults.iter().filter(|(n, _)| fmu.variable(n).is_some() && !opts.set.iter().any(|(s, _)| s == n));
        for (name, value) in opts.set.iter().chain(defaults) {
            let var = fmu.resolve(name).map_err(plant_err)?;
            let value = Value::from_number(var.kind, *value).map_err(|e| EstimatorError::Config(format!("--set {name}={value}: {e}")))?;
            settings.push((var, value));
        }
        let fs = match opts.set.iter().find(|(n, _)| n == "fs") {
            Some((_, v)) => *v,
            None => real_start(&fmu, "fs").or(opts.fs).unwrap_or(330e3),
        };
        if !(fs > 0.0 && fs.is_finite()) {
            return Err(EstimatorError::Config(format!("switching frequency {fs} Hz must be positive")));
        }
        let instance = fmu.instantiate("buckid").map_err(plant_err)?;
        let source = format!("{} ({})", path.display(), fmu.model_description().model_name);
        Ok(Self { instance, fmu, roles, settings, fs, periods: 0, source })
    }

    /// Sets the input voltage \[V\] for the periods that follow (for data whose `vin` varies;
    /// [`Plant::start`] sets the first value). A no-op when the FMU has no `vin` role.
    pub fn set_vin(&mut self, vin: f64) -> Result<(), EstimatorError> {
        self.set("vin", vin)
    }

    fn vr(&self, role: &str) -> Option<u32> {
        self.roles.get(role).copied()
    }

    fn set(&mut self, role: &str, value: f64) -> Result<(), EstimatorError> {
        match self.vr(role) {
            Some(vr) => self.instance.set_real(&[vr], &[value]).map_err(plant_err),
            None => Ok(()),
        }
    }

    fn get(&mut self, role: &str) -> Result<Option<f64>, EstimatorError> {
        let Some(vr) = self.vr(role) else { return Ok(None) };
        let mut v = [0.0];
        self.instance.get_real(&[vr], &mut v).map_err(plant_err)?;
        Ok(Some(v[0]))
    }
}

/// Start value of a Real variable in the modelDescription.
fn real_start(fmu: &Fmu, name: &str) -> Option<f64> {
    match &fmu.variable(name)?.ty {
        VariableType::Real(r) => r.start,
        _ => None,
    }
}

impl Plant for FmuPlant {
    fn switching_frequency(&self) -> f64 {
        self.fs
    }

    fn start(&mut self, duty: f64, io: f64, vin: f64) -> Result<(), EstimatorError> {
        // A fresh run every time: reset is cheap and makes repeated experiments independent.
        self.instance.reset().map_err(plant_err)?;
        self.instance.setup_experiment(0.0, None).map_err(plant_err)?;
        for (var, value) in &self.settings {
            self.instance.set_value(var, value).map_err(|e| EstimatorError::Plant(format!("--set {}={value}: {e}", var.name)))?;
        }
        self.set("duty", duty)?;
        self.set("io", io)?;
        self.set("vin", vin)?;
        self.instance.enter_initialization_mode().map_err(plant_err)?;
        self.instance.exit_initialization_mode().map_err(plant_err)?;
        self.periods = 0;
        Ok(())
    }

    fn sample(&mut self) -> Result<PeriodSample, EstimatorError> {
        let vout = self.get("vout")?.unwrap_or(f64::NAN);
        let il = self.get("il")?;
        let average = match (self.get("vout_avg")?, self.get("il_avg")?) {
            (Some(v), Some(i)) => Some((v, i)),
            _ => None,
        };
        let duty_applied = self.get("duty_applied")?;
        Ok(PeriodSample { vout, il, average, duty_applied })
    }

    fn step_period(&mut self, duty: f64, io: f64) -> Result<(), EstimatorError> {
        self.set("duty", duty)?;
        self.set("io", io)?;
        let t = self.periods as f64 / self.fs;
        self.instance.do_step(t, 1.0 / self.fs).map_err(plant_err)?;
        self.periods += 1;
        Ok(())
    }

    fn describe(&self) -> Vec<(String, String)> {
        let mut meta = vec![("source".to_string(), self.source.clone())];
        for name in DESCRIBED {
            let set = self.settings.iter().find_map(|(var, value)| match value {
                Value::Real(x) if var.name == name => Some(*x),
                _ => None,
            });
            // No load resistor (0) is the contract's default: not written.
            if let Some(v) = set.or_else(|| real_start(&self.fmu, name)).filter(|v| name != "rload" || *v != 0.0) {
                meta.push((name.to_string(), format!("{v}")));
            }
        }
        meta
    }
}
