//! The nominal model given as an FMU (`diagnose --fmu`): its parameter start values name the
//! circuit and the nominal model, and the FMU itself is run on the data's inputs ("the FMU as
//! given") so its own held-out error can be set beside the diagnosis.
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use estimator::data::DataSet;
use estimator::experiment::Plant;
use estimator::fmu_plant::{FmuOptions, FmuPlant};
use fmi2_import::Fmu;
use fmi2_import::schema::{Causality, VariableType};
use gap::Nominal;

/// Circuit values read from the FMU's start values when it has variables of these names.
const CIRCUIT: [&str; 6] = ["L", "RL", "C", "Rc", "fs", "rload"];

/// An opened FMU and what its model description says about the nominal model.
pub struct NominalFmu {
    fmu: Fmu,
    path: PathBuf,
    /// Start values of the circuit variables it has, by name.
    pub circuit: BTreeMap<&'static str, f64>,
    /// Start value of `mode`, when it has one.
    pub mode: Option<f64>,
    /// It has a Real `Cl` parameter (set to the diagnosis's Cl before it is run).
    pub has_cl: bool,
}

/// The FMU's run on the data: its held-out simulation and error.
#[derive(Debug, Clone)]
pub struct FmuRun {
    /// `vout` at each period start of the held-out part \[V\].
    pub simulated: Vec<f64>,
    /// Held-out NRMSE.
    pub nrmse: f64,
    /// Cl it was run with, when it has a `Cl` parameter \[F\].
    pub cl: Option<f64>,
}

/// Start value of a numeric variable (Real, Integer, Enumeration or Boolean).
fn start(fmu: &Fmu, name: &str) -> Option<f64> {
    match &fmu.variable(name)?.ty {
        VariableType::Real(r) => r.start,
        VariableType::Integer(i) => i.start.map(f64::from),
        VariableType::Enumeration(e) => e.start.map(f64::from),
        VariableType::Boolean(b) => b.start.map(|b| if b { 1.0 } else { 0.0 }),
        VariableType::String(_) => None,
    }
}

impl NominalFmu {
    /// Extracts the FMU at `path` and reads its model description (the binary is loaded only
    /// by [`NominalFmu::run`]).
    pub fn open(path: &Path) -> Result<Self> {
        if !path.exists() {
            bail!("FMU {} does not exist", path.display());
        }
        let fmu = Fmu::open(path).with_context(|| format!("opening FMU {}", path.display()))?;
        let circuit = CIRCUIT.iter().filter_map(|&name| Some((name, start(&fmu, name)?))).collect();
        let mode = start(&fmu, "mode");
        let has_cl = fmu.variable("Cl").is_some_and(|v| matches!(v.ty, VariableType::Real(_)) && v.causality == Causality::Parameter);
        Ok(Self { fmu, path: path.to_path_buf(), circuit, mode, has_cl })
    }

    /// The FMU's model name.
    pub fn model_name(&self) -> &str {
        &self.fmu.model_description().model_name
    }

    /// The nominal model its `mode` start value selects (1 averaged, 2 switched); `Err` with
    /// the value when it is neither.
    pub fn nominal(&self) -> Option<Result<Nominal, f64>> {
        self.mode.map(|m| {
            if m == 1.0 {
                Ok(Nominal::Averaged)
            } else if m == 2.0 {
                Ok(Nominal::Switched)
            } else {
                Err(m)
            }
        })
    }

    /// Drives the FMU with the data's duty, io and vin one switching period per step, from
    /// the operating point of the first inputs, and compares its period-start `vout` with the
    /// measured one on samples `start..`. `cl` is set when the FMU has a `Cl` parameter.
    pub fn run(self, data: &DataSet, start: usize, cl: f64, map: BTreeMap<String, String>) -> Result<FmuRun> {
        let cl = self.has_cl.then_some(cl);
        let set = cl.map(|cl| vec![("Cl".to_string(), cl)]).unwrap_or_default();
        let opts = FmuOptions { map, set, fs: Some(1.0 / data.sample_period()), ..FmuOptions::default() };
        let mut plant = FmuPlant::from_fmu(self.fmu, &self.path, &opts).with_context(|| format!("instantiating FMU {}", self.path.display()))?;
        let n = data.len();
        if start >= n {
            bail!("no held-out samples to run the FMU on");
        }
        let mut vout = Vec::with_capacity(n);
        plant.start(data.duty[0], data.io[0], data.vin[0])?;
        for k in 0..n {
            vout.push(plant.sample()?.vout);
            if k + 1 < n {
                if k > 0 && data.vin[k] != data.vin[k - 1] {
                    plant.set_vin(data.vin[k])?;
                }
                plant.step_period(data.duty[k], data.io[k]).with_context(|| format!("FMU step of period {k}"))?;
            }
        }
        let simulated = vout.split_off(start);
        if simulated.iter().any(|v| !v.is_finite()) {
            bail!("the FMU's vout is not finite on the held-out part");
        }
        let nrmse = held_out_nrmse(&data.vout[start..], &simulated);
        Ok(FmuRun { simulated, nrmse, cl })
    }
}

/// `‖y − ŷ‖ / ‖y − ȳ‖`, the gap's NRMSE (1 − fit %/100 of the held-out simulation).
pub fn held_out_nrmse(measured: &[f64], simulated: &[f64]) -> f64 {
    estimator::validate::nrmse(measured, simulated)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nrmse_is_one_for_the_mean_and_zero_for_a_perfect_fit() {
        let y = [1.0, 2.0, 3.0, 6.0];
        assert!(held_out_nrmse(&y, &y).abs() < 1e-15);
        assert!((held_out_nrmse(&y, &[3.0; 4]) - 1.0).abs() < 1e-15);
        // Residual (0.5, −0.5, 0.5, −0.5): ‖r‖ = 1, ‖y − ȳ‖ = √14.
        let yhat = [0.5, 2.5, 2.5, 6.5];
        assert!((held_out_nrmse(&y, &yhat) - 1.0 / 14f64.sqrt()).abs() < 1e-12);
    }
}
