//! Datasets with one withheld effect each (and a clean one): the diagnosis, told nothing,
//! names the effect, closes most of the held-out gap, and keeps Cl inside its CI95.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a test: failing loudly is the point
use buck_model::variables::VarId;
use buck_model::{Converter, Mode, Params};
use estimator::data::DataSet;
use estimator::experiment::{Experiment, ModelPlant, run};
use gap::{DiagnoseOptions, diagnose};

const CL: f64 = 4.7e-6;

fn data(conv: Converter) -> DataSet {
    let exp = Experiment { samples: 3001, noise_vout: 2e-3, noise_seed: 11, ..Experiment::default() };
    let mut d = run(&mut ModelPlant::with_converter_in_open_loop(conv), &exp).unwrap();
    d.meta.retain(|k, _| k == "fs" || k == "U"); // nothing that could name the effect
    d
}

fn plant(params: Params, mode: Mode) -> Converter {
    Converter::new(params, mode)
}

fn check(d: &DataSet, expected: &str) {
    let dx = diagnose(d, &Params::default(), &DiagnoseOptions::default()).unwrap();
    let summary: Vec<String> = dx.effects.iter().map(|e| format!("{} {:.1} % sig {}", e.name, e.shrink_percent, e.significant)).collect();
    assert_eq!(dx.verdict, expected, "effects: {summary:?}");
    if expected != "none" {
        let best = dx.effects.iter().find(|e| e.name == expected).unwrap();
        assert!(best.shrink_percent >= 70.0, "{expected}: only {:.1} % of the gap closed ({summary:?})", best.shrink_percent);
        let [lo, hi] = best.cl.ci95;
        assert!(lo <= CL && CL <= hi, "{expected}: Cl {:e} outside [{lo:e}, {hi:e}]", best.cl.estimate);
    }
    assert!(!dx.location.summary.is_empty());
}

#[test]
fn clean_data_gets_verdict_none() {
    check(&data(plant(Params { cl: CL, ..Params::default() }, Mode::Averaged)), "none");
}

#[test]
fn switched_data_is_switching_ripple() {
    check(&data(plant(Params { cl: CL, ..Params::default() }, Mode::Switched)), "switching_ripple");
}

#[test]
fn inductance_off_nominal_is_param_drift() {
    let d = data(plant(Params { cl: CL, l: 3.3e-6 * 1.15, ..Params::default() }, Mode::Averaged));
    check(&d, "param_drift");
    let dx = diagnose(&d, &Params::default(), &DiagnoseOptions::default()).unwrap();
    let drift = dx.effects.iter().find(|e| e.name == "param_drift").unwrap();
    let l = drift.params["L"];
    assert!((l / (3.3e-6 * 1.15) - 1.0).abs() < 0.02, "L estimate {l:e}");
}

#[test]
fn extra_series_resistance_is_switch_resistance() {
    check(&data(plant(Params { cl: CL, rl: 0.1 + 0.02, ..Params::default() }, Mode::Averaged)), "switch_resistance");
}

#[test]
fn late_duty_is_delay() {
    let mut c = plant(Params { cl: CL, ..Params::default() }, Mode::Averaged);
    c.set(VarId::Delay, 1.0).unwrap();
    check(&data(c), "delay");
}

/// On switched data the ripple is always there: an effect fitted on top of the PWM model is
/// found behind it (switch resistance 20 mΩ; a one-period delay).
#[test]
fn effects_are_found_behind_the_switching_ripple() {
    let mut c = plant(Params { cl: CL, ..Params::default() }, Mode::Switched);
    c.set(VarId::SwitchResistance, 0.02).unwrap();
    check(&data(c), "switch_resistance");
    let mut c = plant(Params { cl: CL, ..Params::default() }, Mode::Switched);
    c.set(VarId::Delay, 1.0).unwrap();
    check(&data(c), "delay");
}


/// Circuit effects of the exact (simulator-extracted) period map, behind the switching ripple:
/// a load-capacitor ESR of 20 mΩ and a 1 nH ESL of the main capacitor branch.
#[test]
fn capacitor_parasitics_are_found_behind_the_switching_ripple() {
    let mut c = plant(Params { cl: CL, ..Params::default() }, Mode::Switched);
    c.set(VarId::LoadEsr, 0.02).unwrap();
    check(&data(c), "load_esr");
    let mut c = plant(Params { cl: CL, ..Params::default() }, Mode::Switched);
    c.set(VarId::Esl, 1e-9).unwrap();
    check(&data(c), "esl");
}

/// Cl's interval is tested against the high-pass refit: a right model passes and keeps its own
/// interval; a model that misses a second effect (dead time named, a 30 mΩ load ESR left out)
/// moves Cl outside that interval, and the test catches it and widens the interval over the true Cl.
#[test]
fn cl_interval_is_widened_exactly_when_the_model_misses() {
    let mut c = plant(Params { cl: CL, ..Params::default() }, Mode::Switched);
    c.set(VarId::DeadTime, 40e-9).unwrap();
    let dx = diagnose(&data(c), &Params::default(), &DiagnoseOptions::default()).unwrap();
    let fit = dx.effects.iter().find(|e| e.name == "dead_time").unwrap();
    let test = fit.cl.check.as_ref().unwrap();
    assert!(test.consistent, "right model flagged: {test:?}");
    assert_eq!(fit.cl.ci95, test.model_ci95);

    let mut c = plant(Params { cl: CL, ..Params::default() }, Mode::Switched);
    c.set(VarId::DeadTime, 30e-9).unwrap();
    c.set(VarId::LoadEsr, 0.03).unwrap();
    let dx = diagnose(&data(c), &Params::default(), &DiagnoseOptions::default()).unwrap();
    assert_eq!(dx.verdict, "dead_time");
    let fit = dx.effects.iter().find(|e| e.name == "dead_time").unwrap();
    let test = fit.cl.check.as_ref().unwrap();
    let [lo, hi] = test.model_ci95;
    assert!(!(lo..=hi).contains(&CL), "the model's own interval already holds Cl: {test:?}");
    assert!(!test.consistent && test.hausman > test.limit, "{test:?}");
    let [lo, hi] = fit.cl.ci95;
    assert!(lo <= CL && CL <= hi, "Cl {CL:e} outside the widened [{lo:e}, {hi:e}]");
}

/// A large diode drop in deep DCM (0.77 V, 1.24 A, Cl 45 µF): the diode-free simulator cannot
/// fit the data at all, and a drop started far below its value falls into a valley with Cl at
/// 0.1 µF. The effect is still found, judged against the PWM model, from the better start.
#[test]
fn large_diode_drop_in_deep_dcm_is_found() {
    let cl = 45e-6;
    let mut c = plant(Params { cl, ..Params::default() }, Mode::Switched);
    c.set(VarId::DiodeDrop, 0.77).unwrap();
    let exp = Experiment { samples: 3001, noise_vout: 2e-3, noise_seed: 11, io: 1.24, ..Experiment::default() };
    let mut d = run(&mut ModelPlant::with_converter_in_open_loop(c), &exp).unwrap();
    d.meta.retain(|k, _| k == "fs" || k == "U");
    let dx = diagnose(&d, &Params::default(), &DiagnoseOptions { nominal: gap::Nominal::Switched, ..DiagnoseOptions::default() }).unwrap();
    assert_eq!(dx.verdict, "diode_drop", "not tested: {:?}", dx.not_tested);
    let fit = dx.effects.iter().find(|e| e.name == "diode_drop").unwrap();
    let [lo, hi] = fit.cl.ci95;
    assert!(lo <= cl && cl <= hi, "Cl {:e} outside [{lo:e}, {hi:e}]", fit.cl.estimate);
    assert!((fit.params["diode_drop"] - 0.77).abs() < 0.01, "{:?}", fit.params);
}

/// On clean data each effect that is linear at zero gets the size above which it would have
/// shown: an ESL or a dead time of three times that limit is then found, one of a third is not.
#[test]
fn effects_not_found_are_bounded_and_the_bound_is_a_detection_limit() {
    let switched = DiagnoseOptions { nominal: gap::Nominal::Switched, ..DiagnoseOptions::default() };
    let clean = data(plant(Params { cl: CL, ..Params::default() }, Mode::Switched));
    let dx = diagnose(&clean, &Params::default(), &switched).unwrap();
    assert_eq!(dx.verdict, "none");
    for (name, var, range) in [("esl", VarId::Esl, 5e-9), ("dead_time", VarId::DeadTime, 50e-9)] {
        let fit = dx.effects.iter().find(|e| e.name == name).unwrap();
        let limit = fit.ruled_out_above.unwrap_or_else(|| panic!("{name}: no limit"));
        assert!(limit > 0.0 && limit < range, "{name} limit {limit:e}");
        for (factor, expected) in [(3.0, name), (1.0 / 3.0, "none")] {
            let mut c = plant(Params { cl: CL, ..Params::default() }, Mode::Switched);
            c.set(var, factor * limit).unwrap();
            let dx = diagnose(&data(c), &Params::default(), &switched).unwrap();
            assert_eq!(dx.verdict, expected, "{name} of {:e}, {factor} times the limit {limit:e}", factor * limit);
        }
    }
}
