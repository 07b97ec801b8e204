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
    data_at(conv, Experiment::default().io)
}

/// 3001 PRBS periods at the load current `io` \[A\], σ = 2 mV on vout.
fn data_at(conv: Converter, io: f64) -> DataSet {
    let exp = Experiment { samples: 3001, noise_vout: 2e-3, noise_seed: 11, io, ..Experiment::default() };
    let mut d = run(&mut ModelPlant::with_converter_in_open_loop(conv), &exp).unwrap();
    d.meta.retain(|k, _| k == "fs" || k == "U"); // nothing that could name the effect
    d
}

/// The final CI95 of Cl holds `truth` (the message says why when not).
fn assert_final_cl_holds(dx: &gap::Diagnosis, truth: f64) {
    let (cl, [lo, hi], test) = dx.final_cl();
    assert!(lo <= truth && truth <= hi, "Cl {cl:e} outside the final [{lo:e}, {hi:e}] ({test})");
}

/// Diagnoses `d` against the design's nominal values and the switched nominal model.
fn diagnose_switched(d: &DataSet) -> gap::Diagnosis {
    diagnose(d, &Params::default(), &DiagnoseOptions { nominal: gap::Nominal::Switched, ..DiagnoseOptions::default() }).unwrap()
}

fn plant(params: Params, mode: Mode) -> Converter {
    Converter::new(params, mode)
}

/// Diagnoses `d` against the averaged nominal and checks the forward selection holds the
/// effects `expected` (in any order: the better explanation goes first; empty: `none`), the last
/// step closes ≥ 70 % of the gap, and the final CI95 holds Cl.
fn check(d: &DataSet, expected: &[&str]) {
    let dx = diagnose(d, &Params::default(), &DiagnoseOptions::default()).unwrap();
    let summary: Vec<String> = dx.effects.iter().map(|e| format!("{} {:.1} % {}", e.name, e.shrink_percent, e.standing())).collect();
    let mut selected: Vec<&str> = dx.selected.iter().map(|e| e.name).collect();
    assert_eq!(dx.verdict, selected.first().copied().unwrap_or("none"));
    selected.sort_unstable();
    let mut expected = expected.to_vec();
    expected.sort_unstable();
    assert_eq!(selected, expected, "effects: {summary:?}; {}", dx.selection_ended);
    if let Some(last) = dx.selected.last() {
        assert!(last.shrink_percent >= 70.0, "{expected:?}: only {:.1} % of the gap closed ({summary:?})", last.shrink_percent);
        let (cl, [lo, hi], _) = dx.final_cl();
        assert!(lo <= CL && CL <= hi, "{expected:?}: Cl {cl:e} outside [{lo:e}, {hi:e}]");
    }
    assert!(!dx.location.summary.is_empty());
}

#[test]
fn clean_data_gets_verdict_none() {
    check(&data(plant(Params { cl: CL, ..Params::default() }, Mode::Averaged)), &[]);
}

#[test]
fn switched_data_is_switching_ripple() {
    check(&data(plant(Params { cl: CL, ..Params::default() }, Mode::Switched)), &["switching_ripple"]);
}

#[test]
fn inductance_off_nominal_is_param_drift() {
    let d = data(plant(Params { cl: CL, l: 3.3e-6 * 1.15, ..Params::default() }, Mode::Averaged));
    check(&d, &["param_drift"]);
    let dx = diagnose(&d, &Params::default(), &DiagnoseOptions::default()).unwrap();
    let drift = dx.effects.iter().find(|e| e.name == "param_drift").unwrap();
    let l = drift.params["L"];
    assert!((l / (3.3e-6 * 1.15) - 1.0).abs() < 0.02, "L estimate {l:e}");
}

#[test]
fn extra_series_resistance_is_switch_resistance() {
    check(&data(plant(Params { cl: CL, rl: 0.1 + 0.02, ..Params::default() }, Mode::Averaged)), &["switch_resistance"]);
}

#[test]
fn late_duty_is_delay() {
    let mut c = plant(Params { cl: CL, ..Params::default() }, Mode::Averaged);
    c.set(VarId::Delay, 1.0).unwrap();
    check(&data(c), &["delay"]);
}

/// A file whose outputs were read a period late (each row's at its period's end, not its
/// start): a one-row slip between the duty and the readings, which nothing in the circuit
/// explains, is named `delay` = −1 first; the load ESR behind it is then found and Cl holds,
/// as on the same record read at the period starts.
#[test]
fn readings_a_period_late_are_a_negative_delay() {
    let mut c = plant(Params { cl: CL, ..Params::default() }, Mode::Switched);
    c.set(VarId::LoadEsr, 0.02).unwrap();
    let on_time = data(c);
    let mut late = on_time.clone();
    late.vout = on_time.vout[1..].to_vec();
    late.il = on_time.il.as_ref().map(|il| il[1..].to_vec());
    late.vout_avg = None;
    late.il_avg = None;
    let late = late.slice(0..on_time.len() - 1);
    let dx = diagnose_switched(&late);
    let names: Vec<&str> = dx.selected.iter().map(|e| e.name).collect();
    assert_eq!(names, ["delay", "load_esr"], "{}", dx.selection_ended);
    assert_eq!(dx.selected[0].params["delay"], -1.0);
    assert_final_cl_holds(&dx, CL);
}

/// On switched data the ripple is always there: against the averaged nominal it is one finding
/// and the other effect a second (switch resistance 20 mΩ; a one-period delay).
#[test]
fn effects_are_found_behind_the_switching_ripple() {
    let mut c = plant(Params { cl: CL, ..Params::default() }, Mode::Switched);
    c.set(VarId::SwitchResistance, 0.02).unwrap();
    check(&data(c), &["switching_ripple", "switch_resistance"]);
    let mut c = plant(Params { cl: CL, ..Params::default() }, Mode::Switched);
    c.set(VarId::Delay, 1.0).unwrap();
    check(&data(c), &["switching_ripple", "delay"]);
}

/// Circuit effects behind the switching ripple: a load-capacitor ESR of 20 mΩ is found. A 1 nH
/// ESL of the main capacitor branch is significant against the switched nominal, but the gap
/// it leaves is within the sampling spread of the 2 mV noise: immaterial, so `none`.
#[test]
fn capacitor_parasitics_are_found_behind_the_switching_ripple() {
    let mut c = plant(Params { cl: CL, ..Params::default() }, Mode::Switched);
    c.set(VarId::LoadEsr, 0.02).unwrap();
    check(&data(c), &["switching_ripple", "load_esr"]);
    let mut c = plant(Params { cl: CL, ..Params::default() }, Mode::Switched);
    c.set(VarId::Esl, 1e-9).unwrap();
    let dx = diagnose_switched(&data(c));
    let esl = dx.effects.iter().find(|e| e.name == "esl").unwrap();
    assert!(esl.significant && !esl.material, "{esl:?}");
    assert!((esl.params["esl"] / 1e-9 - 1.0).abs() < 0.2, "{:?}", esl.params);
    assert_eq!(dx.verdict, "none");
}

/// Cl's interval is tested against the high-pass refit: a right model passes, and its interval
/// spans both fits' (each right under the model, held to the effects' models' fidelity: a dead
/// time's, through Cl's leverage on L and C), holds the true Cl and stays within ±2 %. A model
/// that misses a second effect (dead time named, a 30 mΩ load ESR left out) would move Cl
/// outside its interval: the forward selection adds the second effect, and the final model's
/// interval, tested, holds the true Cl.
#[test]
fn cl_interval_of_the_final_model_is_tested_and_holds() {
    let switched = DiagnoseOptions { nominal: gap::Nominal::Switched, ..DiagnoseOptions::default() };
    let mut c = plant(Params { cl: CL, ..Params::default() }, Mode::Switched);
    c.set(VarId::DeadTime, 40e-9).unwrap();
    let dx = diagnose(&data(c), &Params::default(), &switched).unwrap();
    let fit = dx.selected.last().unwrap();
    assert_eq!(fit.name, "dead_time");
    let test = fit.cl.check.as_ref().unwrap();
    assert!(test.consistent, "right model flagged: {test:?}");
    let hull = [test.model_ci95[0].min(test.high_pass_ci95[0]), test.model_ci95[1].max(test.high_pass_ci95[1])];
    let fidelity = dx.cl_fidelity;
    // A dead time's form approximates a device: L and C held to its fidelity, through Cl's
    // leverage on them.
    assert_eq!(dx.cl_circuit_fidelity, gap::CIRCUIT_FIDELITY_WITH_DEVICES);
    let lean = dx.cl_leverage.as_ref().unwrap().iter().filter(|(x, _)| ["L", "C"].contains(&x.as_str())).map(|(_, k)| k.abs()).fold(0.0, f64::max);
    assert_eq!(fidelity, gap::CL_FIDELITY_WITH_EFFECTS.max((gap::CIRCUIT_FIDELITY_WITH_DEVICES * lean).exp_m1()));
    assert_eq!(fit.cl.ci95, [hull[0].min(fit.cl.estimate / (1.0 + fidelity)), hull[1].max(fit.cl.estimate * (1.0 + fidelity))]);
    let [lo, hi] = fit.cl.ci95;
    assert!(lo <= CL && CL <= hi && hi / lo < 1.04, "right model's interval {hull:?} for {CL:e}");

    let mut c = plant(Params { cl: CL, ..Params::default() }, Mode::Switched);
    c.set(VarId::DeadTime, 30e-9).unwrap();
    c.set(VarId::LoadEsr, 0.03).unwrap();
    let dx = diagnose(&data(c), &Params::default(), &switched).unwrap();
    let names: Vec<&str> = dx.selected.iter().map(|e| e.name).collect();
    assert_eq!(names, ["dead_time", "load_esr"]);
    // The single-effect fit alone misses Cl; the sequence's final model does not.
    let alone = dx.effects.iter().find(|e| e.name == "dead_time").unwrap();
    let [lo, hi] = alone.cl.ci95;
    assert!(!(lo..=hi).contains(&CL), "the one-effect model already holds Cl: {:?}", alone.cl);
    assert_final_cl_holds(&dx, CL);
    let esr = dx.selected[1].params["load_esr"];
    assert!((esr / 0.03 - 1.0).abs() < 0.2, "load ESR {esr:e}");
}

/// Cl's interval holds the nominal values exact; its leverage on them says what they are worth:
/// given C 1 % above the truth (within the tolerance, so the same model is fitted), the final
/// Cl moves by the leverage on C the diagnosis reported, within a fifth.
#[test]
fn cls_leverage_on_c_is_what_a_nominal_c_one_percent_off_does() {
    let switched = DiagnoseOptions { nominal: gap::Nominal::Switched, ..DiagnoseOptions::default() };
    let mut c = plant(Params { cl: CL, ..Params::default() }, Mode::Switched);
    c.set(VarId::DeadTime, 40e-9).unwrap();
    let d = data(c);
    let dx = diagnose(&d, &Params::default(), &switched).unwrap();
    let lever = dx.cl_leverage.as_ref().unwrap();
    assert!(lever.keys().eq(["C", "L", "Rc"]), "{lever:?}");
    let off = diagnose(&d, &Params { c: 1.01 * Params::default().c, ..Params::default() }, &switched).unwrap();
    let names = |dx: &gap::Diagnosis| dx.selected.iter().map(|e| e.name).collect::<Vec<_>>();
    assert_eq!(names(&off), names(&dx));
    let moved = (off.final_cl().0 / dx.final_cl().0).ln() / 1.01_f64.ln();
    assert!((moved / lever["C"] - 1.0).abs() < 0.2, "Cl moved {moved:+.2} % per % of C, the leverage said {:+.2}", lever["C"]);
}

/// Real converters carry several effects at once: a diode drop and a series resistance
/// together, found in turn, each with an identified value near the truth.
#[test]
fn two_effects_at_once_are_both_selected() {
    let mut c = plant(Params { cl: CL, ..Params::default() }, Mode::Switched);
    c.set(VarId::DiodeDrop, 0.5).unwrap();
    c.set(VarId::SwitchResistance, 0.03).unwrap();
    let d = data_at(c, 3.0);
    let dx = diagnose_switched(&d);
    let names: Vec<&str> = dx.selected.iter().map(|e| e.name).collect();
    assert_eq!(names, ["diode_drop", "switch_resistance"], "{}", dx.selection_ended);
    let vf = dx.selected[0].params["diode_drop"];
    assert!((vf - 0.5).abs() < 0.02, "diode drop {vf}");
    let r = dx.selected[1].params["switch_resistance"];
    assert!((r - 0.03).abs() < 0.005, "switch resistance {r}");
    assert!(dx.selected[1].closed_percent.unwrap() > 95.0);
    assert_final_cl_holds(&dx, CL);
}

/// A real diode's drop grows with its current (a datasheet's threshold voltage and slope
/// resistance): 0.35 V + 60 mΩ·il at 2 A. The constant drop is found first, its slope
/// resistance on top, near its value, and Cl's interval holds. A constant-drop diode gets no
/// slope resistance (`large_diode_drop_in_deep_dcm_is_found`, `two_effects_at_once_are_both_selected`).
#[test]
fn a_diode_with_a_slope_resistance_is_found() {
    let mut c = plant(Params { cl: CL, ..Params::default() }, Mode::Switched);
    c.set(VarId::DiodeDrop, 0.35).unwrap();
    c.set(VarId::DiodeResistance, 0.06).unwrap();
    let d = data_at(c, 2.0);
    let dx = diagnose_switched(&d);
    let names: Vec<&str> = dx.selected.iter().map(|e| e.name).collect();
    assert_eq!(names, ["diode_drop", "diode_resistance"], "{}", dx.selection_ended);
    let rd = dx.selected[1].params["diode_resistance"];
    assert!((rd / 0.06 - 1.0).abs() < 0.2, "slope resistance {rd}");
    let vf = dx.selected[0].params["diode_drop"];
    assert!((vf - 0.35).abs() < 0.02, "diode drop {vf}");
    assert_final_cl_holds(&dx, CL);
}

/// Dead time where the switch node's capacitance decides how far the node swings: 40 ns and
/// 1 nF at 1.2 A, where the valley current is near zero (each slew takes 5–50 ns, some of them
/// cut short by the turn-on). The dead time is found first, the capacitance on top, near its
/// value, and Cl's interval holds.
#[test]
fn a_dead_time_with_a_switch_node_capacitance_is_found() {
    let c = plant(Params { cl: CL, dead_time: 40e-9, switch_node_capacitance: 1e-9, ..Params::default() }, Mode::Switched);
    let dx = diagnose_switched(&data_at(c, 1.2));
    let names: Vec<&str> = dx.selected.iter().map(|e| e.name).collect();
    assert_eq!(names, ["dead_time", "switch_node_capacitance"], "{}", dx.selection_ended);
    let csw = dx.selected[1].params["switch_node_capacitance"];
    assert!((csw / 1e-9 - 1.0).abs() < 0.2, "switch-node capacitance {csw:e}");
    let td = dx.selected[0].params["dead_time"];
    assert!((td / 40e-9 - 1.0).abs() < 0.05, "dead time {td:e}");
    assert_final_cl_holds(&dx, CL);
}

/// A 24 V synchronous buck at 200 kHz (10 µH, 220 µF), not the thesis's: dead time 50 ns and
/// 15 mΩ switches at 2 A, recorded from a running PRBS experiment (2000 periods in), so the
/// lightly damped LC (80 periods per e-fold) starts the record amperes away from any DC point.
/// - With il > 0 at both edges a body diode's slope resistance `Rd` drops `2·td·fs·Rd·il` on
///   average, the switches' resistance at fifty times the ohms: the selection had named a
///   0.76 Ω body diode for the switches (on the independent harness too).
/// - A fit that could only move the initial voltage followed the start's ringing with a wrong
///   dead time and Cl (17.9 mV left against 2 mV of noise; from the truth, the same).
///
/// Both effects are named near their values, and Cl's interval holds.
#[test]
fn a_lab_buck_recorded_mid_experiment_gets_its_switches_and_dead_time() {
    let nominal = Params { l: 10e-6, rl: 0.03, c: 220e-6, rc: 0.02, fs: 200e3, ..Params::default() };
    let truth = Params { cl: 22e-6, dead_time: 50e-9, switch_resistance: 0.015, ..nominal };
    let exp = Experiment { samples: 3001, warmup: 2000, noise_vout: 2e-3, noise_seed: 14, io: 2.0, vin: 24.0, ..Experiment::default() };
    let mut d = run(&mut ModelPlant::with_converter_in_open_loop(plant(truth, Mode::Switched)), &exp).unwrap();
    d.meta.retain(|k, _| k == "fs" || k == "U");
    let dx = diagnose(&d, &nominal, &DiagnoseOptions { nominal: gap::Nominal::Switched, ..DiagnoseOptions::default() }).unwrap();
    let names: Vec<&str> = dx.selected.iter().map(|e| e.name).collect();
    assert!(names.contains(&"dead_time") && names.contains(&"switch_resistance"), "{names:?}: {}", dx.selection_ended);
    assert!(!names.contains(&"diode_resistance"), "{names:?}: {}", dx.selection_ended);
    let value = |name: &str, key: &str| dx.selected.iter().find(|e| e.name == name).and_then(|e| e.params.get(key).copied());
    let ohms = value("switch_resistance", "switch_resistance").or(value("switch_resistance", "series_resistance")).unwrap();
    assert!((ohms / 0.015 - 1.0).abs() < 0.05, "switches {ohms:e} Ω");
    let td = value("dead_time", "dead_time").unwrap();
    assert!((td / 50e-9 - 1.0).abs() < 0.05, "dead time {td:e} s");
    assert_final_cl_holds(&dx, 22e-6);
}

/// A capacitor whose ESR drifted 17 % low and 33 mΩ switches at 0.6 A, Cl 4.5 µF (a harness set
/// the bench drew): greedy selection takes stand-ins first (C drifted, then a load ESR for the
/// ESR), on which the true drift only displaces the load ESR. The swap puts the ESR's drift in
/// the stand-in's place; both effects end up named near their values, and Cl's interval holds.
#[test]
fn a_drifted_esr_replaces_its_stand_in() {
    let cl = 4.5e-6;
    let c = plant(Params { cl, rc: 0.083, switch_resistance: 0.033, ..Params::default() }, Mode::Switched);
    let dx = diagnose_switched(&data_at(c, 0.6));
    let labels: Vec<String> = dx.selected.iter().map(|e| e.label()).collect();
    assert!(labels.contains(&"param_drift (Rc)".to_string()) && labels.contains(&"switch_resistance".to_string()), "{labels:?}: {}", dx.selection_ended);
    assert!(!labels.contains(&"load_esr".to_string()), "{labels:?}: {}", dx.selection_ended);
    let rc = dx.selected.iter().find_map(|e| e.params.get("Rc")).unwrap();
    assert!((rc / 0.083 - 1.0).abs() < 0.02, "Rc {rc}");
    assert_final_cl_holds(&dx, cl);
}

/// A converter as real ones come, five effects at once: dead time (30 ns, 400 pF on the switch
/// node), 15 mΩ switches, an inductor 12 % low and a capacitor's ESR 40 % low, read 91 ns late.
/// Greedy selection fills its four steps with stand-ins and still misses; the joint refit names
/// every effect near its value and Cl's interval holds.
#[test]
fn five_effects_at_once_are_named_by_the_joint_refit() {
    let cl = 10e-6;
    let p = Params { cl, dead_time: 30e-9, switch_node_capacitance: 400e-12, switch_resistance: 0.015, l: 2.9e-6, rc: 0.06, ..Params::default() };
    let dx = diagnose_switched(&read_late(p, 3));
    let labels: Vec<String> = dx.selected.iter().map(|e| e.label()).collect();
    for effect in ["dead_time", "switch_resistance", "param_drift (L)", "param_drift (Rc)", "sample_delay"] {
        assert!(labels.iter().any(|l| l == effect), "{effect} not in {labels:?}: {}", dx.selection_ended);
    }
    let value = |key: &str| dx.selected.iter().find_map(|e| e.params.get(key).copied()).unwrap();
    for (key, truth, tolerance) in [("dead_time", 30e-9, 0.05), ("L", 2.9e-6, 0.01), ("Rc", 0.06, 0.02), ("sample_delay", 3e-2 / 330e3, 0.1)] {
        assert!((value(key) / truth - 1.0).abs() < tolerance, "{key} {:e} for {truth:e}", value(key));
    }
    assert_final_cl_holds(&dx, cl);
}

/// The same on a bench: dead time (40 ns, 400 pF), 7 mΩ switches, L 15 % high and C 20 % low,
/// read 91 ns late through a divider 0.5 % high. The joint refit names the circuit's effects and
/// the divider's gain, each near its value, and Cl's interval holds.
#[test]
fn a_divider_gain_error_is_named_beside_the_circuits_effects() {
    let cl = 47e-6;
    let p = Params { cl, dead_time: 40e-9, switch_node_capacitance: 400e-12, switch_resistance: 0.007, l: 3.8e-6, c: 80e-6, ..Params::default() };
    let d = through_probes(read_late(p, 3), (0.005, 0.0), (0.0, 0.0));
    let dx = diagnose_switched(&d);
    let labels: Vec<String> = dx.selected.iter().map(|e| e.label()).collect();
    for effect in ["dead_time", "param_drift (L)", "param_drift (C)", "sensor_gain"] {
        assert!(labels.iter().any(|l| l == effect), "{effect} not in {labels:?}: {}", dx.selection_ended);
    }
    let value = |key: &str| dx.selected.iter().find_map(|e| e.params.get(key).copied()).unwrap();
    for (key, truth, tolerance) in [("dead_time", 40e-9, 0.05), ("L", 3.8e-6, 0.02), ("C", 80e-6, 0.03), ("vout_gain_error", 0.005, 0.15)] {
        assert!((value(key) / truth - 1.0).abs() < tolerance, "{key} {:e} for {truth:e}", value(key));
    }
    assert_final_cl_holds(&dx, cl);
}

/// A half bridge with unequal switches (40 mΩ high side, 12 mΩ low side) at 3 A: the
/// switches' resistance first, then the low side's own, near its ratio, and Cl's interval holds.
#[test]
fn unequal_switches_are_found() {
    let c = plant(Params { cl: CL, switch_resistance: 0.04, low_side_ratio: 0.3, ..Params::default() }, Mode::Switched);
    let dx = diagnose_switched(&data_at(c, 3.0));
    let names: Vec<&str> = dx.selected.iter().map(|e| e.name).collect();
    assert_eq!(names, ["switch_resistance", "unequal_switches"], "{}", dx.selection_ended);
    let ratio = dx.selected[1].params["low_side_ratio"];
    assert!((ratio / 0.3 - 1.0).abs() < 0.15, "low-side ratio {ratio}");
    let r = dx.selected[0].params["switch_resistance"];
    assert!((r / 0.04 - 1.0).abs() < 0.1, "switch resistance {r}");
    assert_final_cl_holds(&dx, CL);
}

/// A diode buck whose inductor has 40 mΩ more than its nominal (in series all period, the diode's
/// off-time too): the second step is an extra series resistance (`series_resistance`), not the
/// high side's nor the diode's alone. (That form used to fail on every switched stack: its
/// fit was read as the switches' own resistance.) The nominal, missing the diode's drop by
/// far more than the noise, has fitted a Cl that says nothing, and says so.
#[test]
fn a_series_resistance_behind_a_diode_is_in_series_all_period() {
    let c = plant(Params { cl: CL, rl: 0.14, diode_drop: 0.4, ..Params::default() }, Mode::Switched);
    let d = data_at(c, 2.0);
    let dx = diagnose_switched(&d);
    let nominal_cl = dx.gap_before.cl_not_identified().unwrap_or_default();
    assert!(nominal_cl.starts_with("not identified: the nominal model misses vout by"), "{nominal_cl:?}");
    let names: Vec<&str> = dx.selected.iter().map(|e| e.name).collect();
    assert_eq!(names, ["diode_drop", "switch_resistance"], "{}", dx.selection_ended);
    let r = dx.selected[1].params.get("series_resistance").copied();
    assert!(r.is_some_and(|r| (r - 0.04).abs() < 0.004), "{:?}", dx.selected[1].params);
    assert_final_cl_holds(&dx, CL);
}

/// A finding must be material: on clean switched data with an inductance 0.1 % off nominal the
/// gap hides in the noise (`none`), and with little noise a 0.5 % drift that is plainly
/// significant is reported within the 1 % tolerance, with its size, not as an effect.
#[test]
fn immaterial_or_tolerated_mismatch_is_none() {
    let switched = DiagnoseOptions { nominal: gap::Nominal::Switched, ..DiagnoseOptions::default() };
    let d = data(plant(Params { cl: CL, l: 3.3e-6 * 1.001, ..Params::default() }, Mode::Switched));
    let dx = diagnose(&d, &Params::default(), &switched).unwrap();
    assert_eq!(dx.verdict, "none", "{:?}", dx.effects.iter().map(|e| (e.name, e.standing())).collect::<Vec<_>>());
    assert_eq!(dx.gap_before.cl_not_identified(), None, "the nominal's Cl is a value here");

    let c = plant(Params { cl: CL, l: 3.3e-6 * 1.005, ..Params::default() }, Mode::Switched);
    let exp = Experiment { samples: 3001, noise_vout: 0.1e-3, noise_seed: 11, ..Experiment::default() };
    let mut d = run(&mut ModelPlant::with_converter_in_open_loop(c), &exp).unwrap();
    d.meta.retain(|k, _| k == "fs" || k == "U");
    let dx = diagnose(&d, &Params::default(), &switched).unwrap();
    let drift = dx.effects.iter().find(|e| e.name == "param_drift").unwrap();
    assert!(drift.significant && drift.within_tolerance && !drift.finding, "{drift:?}");
    assert!((drift.drift_percent.unwrap() - 0.5).abs() < 0.1, "{:?}", drift.drift_percent);
    assert_eq!(dx.verdict, "none");
    // A tighter tolerance makes the same drift a finding.
    let dx = diagnose(&d, &Params::default(), &DiagnoseOptions { tolerance: 0.001, ..switched }).unwrap();
    assert_eq!(dx.verdict, "param_drift");
}

/// A resistance in series with L is a drift of the path's RL: 0.5 mΩ beside its 100 mΩ at
/// 10 A, plainly significant under 0.1 mV of noise, is reported within the 1 % tolerance with
/// its share of RL, not named; a tighter tolerance names it.
#[test]
fn a_series_resistance_within_the_tolerance_of_rl_is_none() {
    let switched = DiagnoseOptions { nominal: gap::Nominal::Switched, ..DiagnoseOptions::default() };
    let c = plant(Params { cl: CL, rl: 0.1005, ..Params::default() }, Mode::Switched);
    let exp = Experiment { samples: 3001, noise_vout: 0.1e-3, noise_seed: 11, io: 10.0, ..Experiment::default() };
    let mut d = run(&mut ModelPlant::with_converter_in_open_loop(c), &exp).unwrap();
    d.meta.retain(|k, _| k == "fs" || k == "U");
    let dx = diagnose(&d, &Params::default(), &switched).unwrap();
    let resistance = dx.effects.iter().find(|e| e.name == "switch_resistance").unwrap();
    assert!(resistance.significant && resistance.within_tolerance && !resistance.finding, "{resistance:?}");
    assert!(resistance.of_rl_percent.is_some_and(|r| (r - 0.5).abs() < 0.1), "{:?}", resistance.of_rl_percent);
    assert_eq!(dx.verdict, "none", "{}", dx.selection_ended);
    assert!(dx.selection_ended.contains("switch_resistance +0.5"), "{}", dx.selection_ended);
    let dx = diagnose(&d, &Params::default(), &DiagnoseOptions { tolerance: 0.001, ..switched }).unwrap();
    assert_eq!(dx.verdict, "switch_resistance", "{}", dx.selection_ended);
}

/// A large series resistance at a heavy load (40 mΩ at 10 A, Cl 0.47 µF), where the nominal
/// fit runs Cl to the bottom of its range: the candidate starts from a grid over Cl and the
/// resistance, not from that fit, and finds both.
#[test]
fn global_starts_find_a_large_series_resistance() {
    let cl = 0.47e-6;
    let c = plant(Params { cl, rl: 0.14, ..Params::default() }, Mode::Switched);
    let d = data_at(c, 10.0);
    let dx = diagnose_switched(&d);
    assert_eq!(dx.verdict, "switch_resistance");
    let r = dx.selected[0].params["switch_resistance"];
    assert!((r - 0.04).abs() < 0.002, "switch resistance {r}");
    assert_final_cl_holds(&dx, cl);
}

/// A large diode drop in deep DCM (0.77 V, 1.24 A, Cl 45 µF): the diode-free simulator cannot
/// fit the data at all, and a drop started far below its value falls into a valley with Cl at
/// 0.1 µF. The effect is still found, judged against the PWM model, from the better start.
#[test]
fn large_diode_drop_in_deep_dcm_is_found() {
    let cl = 45e-6;
    let mut c = plant(Params { cl, ..Params::default() }, Mode::Switched);
    c.set(VarId::DiodeDrop, 0.77).unwrap();
    let d = data_at(c, 1.24);
    let dx = diagnose_switched(&d);
    assert_eq!(dx.verdict, "diode_drop", "not tested: {:?}", dx.not_tested);
    assert!(dx.selected.iter().all(|e| e.name != "diode_resistance"), "a constant drop has no slope resistance: {}", dx.selection_ended);
    let fit = &dx.selected[0];
    let (_, [lo, hi], _) = dx.final_cl();
    assert!(lo <= cl && cl <= hi, "Cl {:e} outside [{lo:e}, {hi:e}]", fit.cl.estimate);
    assert!((fit.params["diode_drop"] - 0.77).abs() < 0.01, "{:?}", fit.params);
    // Half the ripple at 0.4 is about 1.4 A: at 1.24 A the diode blocks in most periods.
    assert!(dx.dcm_share.is_some_and(|s| s > 0.5), "{:?}", dx.regime());
    // Deep DCM: the regime names what the fits leave out there, the switch node's ring.
    assert!(dx.regime().is_some_and(|r| r.contains("switch node rings")), "{:?}", dx.regime());
}

/// On clean data each effect that is linear at zero gets the size above which it would have
/// shown: an ESL or a dead time of three times that limit is then significant, one of a third
/// is not (and the verdict stays `none`).
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
        for (factor, detected) in [(3.0, true), (1.0 / 3.0, false)] {
            let mut c = plant(Params { cl: CL, ..Params::default() }, Mode::Switched);
            c.set(var, factor * limit).unwrap();
            let dx = diagnose(&data(c), &Params::default(), &switched).unwrap();
            let fit = dx.effects.iter().find(|e| e.name == name).unwrap();
            assert_eq!(fit.significant, detected, "{name} of {:e}, {factor} times the limit {limit:e}", factor * limit);
            if !detected {
                assert_eq!(dx.verdict, "none");
            }
        }
    }
}

/// Data of the converter with circuit values `p`, both channels acquired `late` substeps of 100
/// after each period start, read off a converter stepped in hundredths of a period (not the
/// simulator's own two-step reading), with 2 mV of noise on vout and 5 mA on il.
fn read_late(p: Params, late: usize) -> DataSet {
    read_at(p, |_| late)
}

/// `p`'s record and its converter started at the record's first inputs, with the noise its
/// readings take (2 mV on vout, 5 mA on il, seeded), for [`read_at`] and [`read_filtered`].
fn reader(p: Params) -> (DataSet, Converter, impl FnMut() -> (f64, f64)) {
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};
    let d = data(plant(p, Mode::Switched));
    let mut c = plant(p, Mode::Switched);
    c.set(VarId::Duty, d.duty[0]).unwrap();
    c.set(VarId::Io, d.io[0]).unwrap();
    c.initialize();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
    let (noise_vout, noise_il) = (Normal::new(0.0, 2e-3).unwrap(), Normal::new(0.0, 5e-3).unwrap());
    (d, c, move || (noise_vout.sample(&mut rng), noise_il.sample(&mut rng)))
}

/// [`read_late`] with each period's reading `late(duty)` substeps of 100 after its start (an
/// ADC triggered from the PWM).
fn read_at(p: Params, late: impl Fn(f64) -> usize) -> DataSet {
    let substeps = 100;
    let period = 1.0 / p.fs;
    let (mut d, mut c, mut noise) = reader(p);
    let mut il = vec![0.0; d.len()];
    for ((duty, vout), il) in d.duty.iter().zip(d.vout.iter_mut()).zip(il.iter_mut()) {
        c.set(VarId::Duty, *duty).unwrap();
        let late = late(*duty);
        for s in 0..substeps {
            if s == late {
                let (nv, ni) = noise();
                (*vout, *il) = (c.outputs().vout + nv, c.state().il + ni);
            }
            c.step(period / substeps as f64).unwrap();
        }
    }
    d.il = Some(il);
    d
}

/// The selected late reading's instant is within `tolerance` (relative) of `truth` \[s\].
fn assert_instant(dx: &gap::Diagnosis, truth: f64, tolerance: f64) {
    let late = dx.selected.iter().find(|e| e.name == "sample_delay").unwrap_or_else(|| panic!("no sample_delay: {}", dx.selection_ended));
    let delay = late.params["sample_delay"];
    assert!((delay / truth - 1.0).abs() < tolerance, "sample delay {delay:e} vs {truth:e}");
}

/// Data acquired 30 substeps of 100 (0.91 µs) after each period start: the late sample reads
/// vout partway along the ripple, which the nominal model can only follow with a wrong Cl.
/// `sample_delay` is found at the instant and Cl lands in its interval.
#[test]
fn late_sampling_is_sample_delay() {
    let cl = 2.2e-6;
    let late = 30;
    let d = read_late(Params { cl, ..Params::default() }, late);
    let period = 1.0 / Params::default().fs;
    let substeps = 100;
    let dx = diagnose_switched(&d);
    let names: Vec<&str> = dx.selected.iter().map(|e| e.name).collect();
    assert_eq!(names, ["sample_delay"], "{}", dx.selection_ended);
    assert_instant(&dx, late as f64 * period / substeps as f64, 0.03);
    assert_final_cl_holds(&dx, cl);
    // The nominal fit alone misses Cl by far more than its interval.
    assert!((dx.gap_before.cl / cl - 1.0).abs() > 0.05, "nominal Cl {:e}", dx.gap_before.cl);
}

/// A controller that samples clear of the switching edges reads in the middle of the off-time:
/// here 0.8 of the period, past either duty's falling edge (0.4 and 0.6 of it). The instant is
/// found within 1 % and Cl lands in its interval. With the instant capped at half the period,
/// this data was not named `sample_delay`.
#[test]
fn a_reading_in_the_off_time_is_sample_delay() {
    let cl = 4.7e-6;
    let late = 80;
    let d = read_late(Params { cl, ..Params::default() }, late);
    let dx = diagnose_switched(&d);
    let names: Vec<&str> = dx.selected.iter().map(|e| e.name).collect();
    assert_eq!(names, ["sample_delay"], "{}", dx.selection_ended);
    assert_instant(&dx, late as f64 / 100.0 / Params::default().fs, 0.01);
    assert_final_cl_holds(&dx, cl);
}

/// A controller that triggers its ADC from the PWM reads at an instant that moves with the duty:
/// in the middle of the on-time (average current mode) or of the off-time (by half the on-time's
/// change), or 150 ns after the turn-off edge (by all of it). `sample_delay` is found with that
/// lock, the instant at half duty within 2 % of the period, and Cl lands in its interval. With a
/// fixed instant only, mid-on was named a 67 mV `sensor_offset` with Cl not identified, and
/// mid-off a fixed late reading, an offset and an ESL, with Cl a confident 1.45 [1.36, 1.47] µF.
#[test]
fn a_reading_locked_to_the_pwm_is_found_with_its_lock() {
    let cl = 4.7e-6;
    let period = 1.0 / Params::default().fs;
    /// A trigger scheme: its name, the reading's substep of 100 at a duty, the share, and the
    /// instant at half duty in periods.
    type Scheme = (&'static str, fn(f64) -> usize, f64, f64);
    let schemes: [Scheme; 3] = [
        ("mid-on", |duty| (50.0 * duty).round() as usize, 0.5, 0.25),
        ("mid-off", |duty| 50 + (50.0 * duty).round() as usize, 0.5, 0.75),
        ("after the turn-off", |duty| 5 + (100.0 * duty).round() as usize, 1.0, 0.55),
    ];
    for (name, late, share, at_half_duty) in schemes {
        let dx = diagnose_switched(&read_at(Params { cl, ..Params::default() }, late));
        let late = dx.selected.iter().find(|e| e.name == "sample_delay").unwrap_or_else(|| panic!("{name}: no sample_delay: {}", dx.selection_ended));
        assert_eq!(late.params.get("sample_duty_share"), Some(&share), "{name}: {:?}", late.params);
        let fitted = late.params["sample_delay"] / period;
        assert!((fitted - at_half_duty).abs() < 0.02, "{name}: sample delay {fitted} T for {at_half_duty} T");
        assert_final_cl_holds(&dx, cl);
    }
}

/// `p`'s converter read `late` steps of 1000 into each period through an RC low-pass of time
/// constant `tau` (an anti-alias filter before a controller's ADC), il directly, with the noise
/// of [`read_at`]: the filter integrated on 1000 steps a period, exactly for a line through each.
fn read_filtered(p: Params, tau: f64, late: usize) -> DataSet {
    let substeps = 1000;
    let h = 1.0 / p.fs / substeps as f64;
    let (mut d, mut c, mut noise) = reader(p);
    let mut il = vec![0.0; d.len()];
    let (decay, mut filtered) = ((-h / tau).exp(), c.outputs().vout);
    for ((duty, vout), il) in d.duty.iter().zip(d.vout.iter_mut()).zip(il.iter_mut()) {
        c.set(VarId::Duty, *duty).unwrap();
        for s in 0..substeps {
            if s == late {
                let (nv, ni) = noise();
                (*vout, *il) = (filtered + nv, c.state().il + ni);
            }
            let v0 = c.outputs().vout;
            c.step(h).unwrap();
            let v1 = c.outputs().vout;
            let lag = (v1 - v0) / h * tau;
            filtered = v1 - lag + (filtered - v0 + lag) * decay;
        }
    }
    d.il = Some(il);
    d
}

/// A controller's ADC behind an RC anti-alias filter, its corner at a tenth and at half the
/// switching frequency (τ = 0.1 and 0.32 of the period): `sensor_filter` alone is selected, its
/// τ within 2 %, and Cl lands in its interval. Without the effect, the third generator's
/// thesis stage read through such filters was diagnosed as C −5 to −13 % and Rc +11 to +38 %
/// with a sensor offset, Cl a confident 58.8 [58.3, 59.4] and 72 [69, 74] µF for 51.9.
#[test]
fn a_reading_through_an_anti_alias_filter_is_sensor_filter() {
    let cl = 10e-6;
    let period = 1.0 / Params::default().fs;
    for share in [0.1, 1.0 / std::f64::consts::PI] {
        let dx = diagnose_switched(&read_filtered(Params { cl, ..Params::default() }, share * period, 0));
        let names: Vec<&str> = dx.selected.iter().map(|e| e.name).collect();
        assert_eq!(names, ["sensor_filter"], "τ = {share} T: {}", dx.selection_ended);
        let tau = dx.selected[0].params["vout_filter"] / period;
        assert!((tau / share - 1.0).abs() < 0.02, "τ {tau} T for {share} T");
        assert_final_cl_holds(&dx, cl);
    }
}

/// An ADC that samples late behind a filter (0.095 of the period behind 0.2 and 0.5 of it, 0.4
/// behind 0.2): il shows the instant, vout lags by more. The filter read late is found alone,
/// with the instant il pins, each within 3 %, and Cl lands in its interval. Before, the third
/// generator's thesis stage read so, with Rc +5 %, was named the drift and an inductor's
/// saturation, Cl 5.6 [4.9, 7.5] µF for 2.21 µF; and where an inductance drift stood in for the
/// lags first, rebuilding the model without it lost the instant, so it stayed, Cl not identified.
#[test]
fn a_late_reading_through_an_anti_alias_filter_is_found_with_its_instant() {
    let cl = 4.7e-6;
    let period = 1.0 / Params::default().fs;
    for (late, tau) in [(95, 0.2), (95, 0.5), (400, 0.2)] {
        let dx = diagnose_switched(&read_filtered(Params { cl, ..Params::default() }, tau * period, late));
        let labels: Vec<String> = dx.selected.iter().map(|e| e.label()).collect();
        assert_eq!(labels, ["sensor_filter (read late)"], "{late}/1000 T late, τ {tau} T: {}", dx.selection_ended);
        let param = |name: &str| dx.selected[0].params[name];
        assert!((param("vout_filter") / (tau * period) - 1.0).abs() < 0.03, "τ {:e} s for {tau} T", param("vout_filter"));
        let instant = late as f64 / 1000.0;
        assert!((param("sample_delay") / (instant * period) - 1.0).abs() < 0.03, "instant {:e} s for {instant} T", param("sample_delay"));
        assert_final_cl_holds(&dx, cl);
    }
}

/// Dead time, the switches' resistance, the node's charge and an ADC at 0.75 of the period, on
/// this simulator's own converter: the instant within 1 % beside the dead time, and Cl in its
/// interval. (On ngspice's circuits the first step takes a stand-in here, and the paths from
/// the other first steps find the instant: `tests/python/test_probes.py`.)
#[test]
fn a_reading_in_the_off_time_is_found_behind_a_dead_time() {
    let cl = 10e-6;
    let d = read_late(Params { cl, dead_time: 30e-9, switch_resistance: 10e-3, switch_node_capacitance: 800e-12, ..Params::default() }, 75);
    let dx = diagnose_switched(&d);
    let names: Vec<&str> = dx.selected.iter().map(|e| e.name).collect();
    assert!(names.contains(&"dead_time") && names.contains(&"sample_delay"), "{names:?}: {}", dx.selection_ended);
    assert_instant(&dx, 0.75 / Params::default().fs, 0.01);
    assert_final_cl_holds(&dx, cl);
}

/// A late acquisition (150 ns) and a 20 mΩ resistance in series with Cl = 2.2 µF move the
/// sampled vout alike (a delay τ reads like an ESR of τ/Cl ≈ 68 mΩ), but only the delay moves
/// il: with the instant pinned by il, both are selected, the ESR and Cl land in their intervals.
#[test]
fn a_late_reading_does_not_hide_a_load_esr() {
    let (cl, esr) = (2.2e-6, 20e-3);
    let d = read_late(Params { cl, load_esr: esr, ..Params::default() }, 5);
    let dx = diagnose_switched(&d);
    let names: Vec<&str> = dx.selected.iter().map(|e| e.name).collect();
    assert!(names.contains(&"sample_delay") && names.contains(&"load_esr"), "{names:?}: {}", dx.selection_ended);
    let fit = dx.selected.iter().find(|e| e.name == "load_esr").unwrap();
    let [lo, hi] = fit.ci95["load_esr"];
    assert!(lo <= esr && esr <= hi, "load_esr {:e} outside [{lo:e}, {hi:e}]", fit.params["load_esr"]);
    assert_final_cl_holds(&dx, cl);
}

/// A 25 mΩ series resistance, which closes vout's gap by itself, and a reading 30 ns late
/// (one substep of 100), which vout alone cannot tell from a slightly different Cl: the late
/// reading is still found on top of the resistance, in il, and Cl lands in its interval.
#[test]
fn a_late_reading_is_found_behind_a_series_resistance() {
    let cl = 10e-6;
    let d = read_late(Params { cl, switch_resistance: 25e-3, ..Params::default() }, 1);
    let dx = diagnose_switched(&d);
    let names: Vec<&str> = dx.selected.iter().map(|e| e.name).collect();
    assert!(names.contains(&"switch_resistance") && names.contains(&"sample_delay"), "{names:?}: {}", dx.selection_ended);
    assert_instant(&dx, 0.01 / Params::default().fs, 0.1);
    assert_final_cl_holds(&dx, cl);
}

/// A 30 ns dead time (with its diodes) and a reading 150 ns late: both are found, nothing that
/// only stands in for them (a drift of L), and Cl lands in its interval.
#[test]
fn a_dead_time_and_a_late_reading_are_both_found() {
    let cl = 4.7e-6;
    let d = read_late(Params { cl, dead_time: 30e-9, ..Params::default() }, 5);
    let dx = diagnose_switched(&d);
    let names: Vec<&str> = dx.selected.iter().map(|e| e.name).collect();
    assert!(names.contains(&"dead_time") && names.contains(&"sample_delay"), "{names:?}: {}", dx.selection_ended);
    assert!(!names.contains(&"param_drift"), "{names:?}: {}", dx.selection_ended);
    assert_final_cl_holds(&dx, cl);
}

/// `d` as probes with zero and gain errors read it: `vout` as `(1 + gain)·vout + offset` with
/// `(gain, offset)` of `vout_probe`, `il` likewise with `il_probe`.
fn through_probes(mut d: DataSet, vout_probe: (f64, f64), il_probe: (f64, f64)) -> DataSet {
    let read = |(gain, offset): (f64, f64), x: &mut f64| *x = (1.0 + gain) * *x + offset;
    d.vout.iter_mut().for_each(|v| read(vout_probe, v));
    d.il.iter_mut().flatten().for_each(|i| read(il_probe, i));
    d
}

/// A current probe 3 % high with a 50 mA zero error (a Hall probe not degaussed), on data read
/// 150 ns late: read late, il moves by the inductor's slope times the delay, which the probe's
/// errors would otherwise stand in for (without them the instant came out at 117 ns for the true
/// 92 ns on the harness). Fitted beside the instant as nuisances, the probe's errors are
/// recovered, the instant is where it was, nothing else is named, and Cl lands in its interval.
#[test]
fn a_current_probe_calibration_is_fitted_beside_a_late_reading() {
    let cl = 4.7e-6;
    let d = through_probes(read_late(Params { cl, ..Params::default() }, 5), (0.0, 0.0), (0.03, 0.05));
    let dx = diagnose_switched(&d);
    let names: Vec<&str> = dx.selected.iter().map(|e| e.name).collect();
    assert_eq!(names, ["sample_delay"], "{}", dx.selection_ended);
    let late = &dx.selected[0].params;
    let truth = 0.05 / Params::default().fs;
    assert!((late["sample_delay"] / truth - 1.0).abs() < 0.05, "sample delay {:e} vs {truth:e}", late["sample_delay"]);
    assert!((late["il_gain_error"] - 0.03).abs() < 0.003 && (late["il_offset"] - 0.05).abs() < 0.01, "{late:?}");
    assert_final_cl_holds(&dx, cl);
}

/// A voltage probe with a 10 mV zero error, and one through a divider 0.5 % high, on data read
/// 150 ns late. Pinned by what the instant changes (vout's offset projected out, its gain fitted
/// where the model has it), the late reading is found where it is, the probe's error is named
/// with an interval that holds it, and Cl lands in its interval. Without them the late reading
/// made vout worse and Cl's interval spanned 1.7–11 µF on the harness.
#[test]
fn a_voltage_probe_calibration_is_named_beside_a_late_reading() {
    let cl = 4.7e-6;
    let truth = 0.05 / Params::default().fs;
    for (effect, key, probe) in [("sensor_offset", "vout_offset", (0.0, 0.010)), ("sensor_gain", "vout_gain_error", (0.005, 0.0))] {
        let d = through_probes(read_late(Params { cl, ..Params::default() }, 5), probe, (0.0, 0.0));
        let dx = diagnose_switched(&d);
        let names: Vec<&str> = dx.selected.iter().map(|e| e.name).collect();
        assert!(names.contains(&"sample_delay") && names.contains(&effect), "{names:?}: {}", dx.selection_ended);
        let late = dx.selected.iter().find(|e| e.name == "sample_delay").unwrap();
        assert!((late.params["sample_delay"] / truth - 1.0).abs() < 0.05, "sample delay {:e} vs {truth:e}", late.params["sample_delay"]);
        let e = dx.selected.iter().find(|e| e.name == effect).unwrap();
        let [lo, hi] = e.ci95[key];
        let value = if key == "vout_offset" { probe.1 } else { probe.0 };
        assert!(lo <= value && value <= hi, "{key} {:e} outside [{lo:e}, {hi:e}]", e.params[key]);
        assert_final_cl_holds(&dx, cl);
    }
}

/// A ceramic losing 60 % of 20 µF at a 10 V rating, run around 6 V: the data shows Cl and its
/// slope over 4.8–7.2 V, not the part's rating. `cap_dc_bias` is found with its law anchored to
/// the data (rated voltage at the highest vout), and Cl is reported, and lands in its CI95, as
/// the capacitance at the operating point, the time-averaged vout (analytic: `Cl·(1 − b·(v/Vr)²)`
/// of the plant's law at the mean of the plant's own period averages).
#[test]
fn a_biased_ceramic_is_found_and_cl_is_its_value_at_the_operating_point() {
    let p = Params { cl: 20e-6, cap_dc_bias: 0.6, cap_rated_voltage: 10.0, ..Params::default() };
    let d = data(plant(p, Mode::Switched));
    let dx = diagnose_switched(&d);
    let names: Vec<&str> = dx.selected.iter().map(|e| e.name).collect();
    assert_eq!(names, ["cap_dc_bias"], "{}", dx.selection_ended);
    let fit = &dx.selected[0];
    let top = d.vout.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let mean = d.vout.iter().sum::<f64>() / d.len() as f64;
    assert_eq!((fit.params["cap_rated_voltage"], fit.params["cl_reference_voltage"]), (top, mean));
    // The same law seen from the data's top voltage: b·(top/10 V)² of Cl(0) lost there.
    let loss_at_top = 0.6 * (top / 10.0).powi(2);
    let b = fit.params["cap_dc_bias"];
    assert!((b / loss_at_top - 1.0).abs() < 0.05, "cap_dc_bias {b} vs {loss_at_top}");
    let operating = assert_read_at_the_operating_point(&dx, &d);
    let at_operating = p.cl_at(operating);
    let (cl, [lo, hi], _) = dx.final_cl();
    assert!(lo <= at_operating && at_operating <= hi, "Cl {cl:e} outside [{lo:e}, {hi:e}], true {at_operating:e} at {operating:.3} V");
    assert!((at_operating / p.cl - 1.0).abs() > 0.15, "the operating point must be well into the bias");
}

/// The voltage a biased ceramic's Cl is reported at is the plant's own: the mean of its period
/// averages (within a millivolt), not the samples' mean, which the ripple puts 10 mV away
/// here. Returns it.
fn assert_read_at_the_operating_point(dx: &gap::Diagnosis, d: &DataSet) -> f64 {
    let averages = d.vout_avg.as_deref().expect("the plant records its period averages");
    let operating = averages.iter().sum::<f64>() / averages.len() as f64;
    let samples = d.vout.iter().sum::<f64>() / d.len() as f64;
    let reported = dx.selected.last().and_then(|e| e.cl.operating_point).expect("Cl read at the operating point");
    assert!((reported - operating).abs() < 1e-3, "read at {reported} V, the plant's time average is {operating} V");
    assert!((samples - operating).abs() > 5e-3, "the samples' mean {samples} V is the average {operating} V too");
    operating
}

/// The same ceramic under the other shape of bias law, `Cl/(1 + c·v/Vr)²` (convex: most of the
/// loss at low bias, as a charge-controlled part has it): fitted with the quadratic law alone,
/// Cl at the mean output came out high by several of its half-widths (the concave law bends
/// the other way between the two levels the PRBS visits). The data tells the shapes apart: the
/// law the effect reports is the reciprocal one, the quadratic refit is the worse, and Cl lands
/// in its CI95.
#[test]
fn a_ceramic_under_the_other_bias_law_gets_its_cl_from_that_law() {
    let p = Params { cl: 20e-6, cap_dc_bias: 0.6, cap_rated_voltage: 10.0, cap_bias_law: buck_model::BiasLaw::Reciprocal, ..Params::default() };
    let d = data(plant(p, Mode::Switched));
    let dx = diagnose_switched(&d);
    let names: Vec<&str> = dx.selected.iter().map(|e| e.name).collect();
    assert!(names.contains(&"cap_dc_bias"), "{names:?}: {}", dx.selection_ended);
    let law = dx.selected.last().and_then(|e| e.cl.bias_law.as_ref()).expect("the other law tried");
    let reciprocal_better = if law.law == "reciprocal" { law.likelihood_ratio > 0.0 } else { law.likelihood_ratio < 0.0 };
    assert!(law.told_apart && reciprocal_better, "{law:?}");
    assert_reported_under_the_reciprocal_law(&dx);
    let operating = assert_read_at_the_operating_point(&dx, &d);
    let (cl, [lo, hi], test) = dx.final_cl();
    let at_operating = p.cl_at(operating);
    assert!(lo <= at_operating && at_operating <= hi, "Cl {cl:e} outside [{lo:e}, {hi:e}], true {at_operating:e} at {operating:.3} V ({test})");
    // The law's own parameter, the reported one: the same part seen from the data's top
    // voltage, where `(1 + k·v/Vr)⁻²` keeps `1 − b`.
    let top = d.vout.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let k = (1.0 - p.cap_dc_bias).sqrt().recip() - 1.0;
    let loss_at_top = 1.0 - (1.0 + k * top / p.cap_rated_voltage).powi(-2);
    let bias = dx.selected.iter().find(|e| e.name == "cap_dc_bias").expect("selected");
    let b = bias.params["cap_dc_bias"];
    let [b_lo, b_hi] = bias.ci95["cap_dc_bias"];
    assert!((b / loss_at_top - 1.0).abs() < 0.05 && b_lo <= loss_at_top && loss_at_top <= b_hi, "cap_dc_bias {b} [{b_lo}, {b_hi}] vs {loss_at_top}");
}

/// The `cap_dc_bias` effect says the reciprocal law is the one its parameters are under.
fn assert_reported_under_the_reciprocal_law(dx: &gap::Diagnosis) {
    let bias = dx.selected.iter().find(|e| e.name == "cap_dc_bias").expect("selected");
    assert_eq!(bias.params.get(gap::RECIPROCAL_BIAS_LAW), Some(&1.0), "{:?}", bias.params);
}

/// A point-of-load stage (5 V, 1.6 µH, 170 µF at 8.7 mΩ, 875 kHz, 5 A) rings after each PRBS
/// step, swinging its output over 1–4 V, across most of its ceramic's law: 50 µF losing 60 % at
/// 6.3 V, convex (`Cl/(1 + c·v/Vr)²`). A third-generator board of this kind (seed 43) had its
/// `cap_dc_bias` candidate, fitted under the concave quadratic law alone, worse on held-out
/// data than the nominal, and the verdict was `none` with Cl not identified. Started under
/// either shape, the candidate goes on in the better one: the effect is found under the
/// reciprocal law and Cl, read at the operating point, lands in its CI95.
#[test]
fn a_ceramic_swung_across_its_law_is_fitted_in_the_shape_it_follows() {
    let nominal = Params { l: 1.6e-6, rl: 2.4e-3, c: 170e-6, rc: 8.7e-3, fs: 875e3, ..Params::default() };
    let p = Params { cl: 50e-6, cap_dc_bias: 0.6, cap_rated_voltage: 6.3, cap_bias_law: buck_model::BiasLaw::Reciprocal, ..nominal };
    let exp = Experiment { samples: 3001, noise_vout: 2e-3, noise_seed: 11, io: 5.0, vin: 5.0, ..Experiment::default() };
    let mut d = run(&mut ModelPlant::with_converter_in_open_loop(plant(p, Mode::Switched)), &exp).unwrap();
    d.meta.retain(|k, _| k == "fs" || k == "U");
    let (lo, hi) = d.vout.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| (lo.min(v), hi.max(v)));
    assert!(lo < 1.5 && hi > 3.5, "the output must swing across the law: {lo:.2}–{hi:.2} V");
    let dx = diagnose(&d, &nominal, &DiagnoseOptions { nominal: gap::Nominal::Switched, ..DiagnoseOptions::default() }).unwrap();
    let names: Vec<&str> = dx.selected.iter().map(|e| e.name).collect();
    assert_eq!(names.first(), Some(&"cap_dc_bias"), "{names:?}: {}", dx.selection_ended);
    assert_reported_under_the_reciprocal_law(&dx);
    let operating = dx.selected.last().and_then(|e| e.cl.operating_point).expect("Cl read at the operating point");
    let (cl, [lo, hi], test) = dx.final_cl();
    let at_operating = p.cl_at(operating);
    assert!(lo <= at_operating && at_operating <= hi, "Cl {cl:e} outside [{lo:e}, {hi:e}], true {at_operating:e} at {operating:.3} V ({test})");
}

/// An interference no effect explains (20 mV at 7.3 kHz on the reading, seven times the noise):
/// whatever the selection names, a final model that misses `vout` by more than five floors is
/// no model of this converter, and its Cl is not identified rather than an interval around
/// whatever best hides the miss.
#[test]
fn a_model_that_misses_grossly_identifies_no_cl() {
    let mut d = data(plant(Params { cl: CL, ..Params::default() }, Mode::Switched));
    for (v, t) in d.vout.iter_mut().zip(&d.time) {
        *v += 20e-3 * (2.0 * std::f64::consts::PI * 7.3e3 * t).sin();
    }
    let dx = diagnose_switched(&d);
    let (cl, [lo, hi], test) = dx.final_cl();
    assert!(!estimator::validate::identified([lo, hi]), "Cl {cl:e} in [{lo:e}, {hi:e}]: {test}");
    assert!(test.contains("noise floor, no model"), "{test}");
}

/// The CLI's default, the averaged nominal, on a switched converter with dead time and 20 mΩ
/// switches: the ripple is taken first (how the converter runs), so the effects of the
/// switching are tried with the switched model (an averaged series resistance had been taken
/// first, standing in for the dead time, which the averaged model cannot hold).
#[test]
fn the_averaged_nominal_takes_the_ripple_first_and_then_the_switching() {
    let c = plant(Params { cl: CL, dead_time: 40e-9, switch_resistance: 0.02, ..Params::default() }, Mode::Switched);
    let dx = diagnose(&data_at(c, 2.0), &Params::default(), &DiagnoseOptions::default()).unwrap();
    let names: Vec<&str> = dx.selected.iter().map(|e| e.name).collect();
    assert_eq!(names.first(), Some(&"switching_ripple"), "{names:?}: {}", dx.selection_ended);
    assert!(names.contains(&"dead_time") && names.contains(&"switch_resistance"), "{names:?}: {}", dx.selection_ended);
    assert_final_cl_holds(&dx, CL);
}

/// The nominal model the data calls for, when the user names none: averaged data (the plant
/// in averaged mode) the averaged one; switched data the switched one, clean or with a dead
/// time whose volts hide the ripple's millivolts.
#[test]
fn the_data_calls_for_its_nominal_model() {
    let p = Params { cl: CL, ..Params::default() };
    let holdout = DiagnoseOptions::default().holdout;
    let choose = |d: &DataSet| gap::nominal_for(d, &Params::default(), holdout);
    let averaged = choose(&data(plant(p, Mode::Averaged)));
    assert_eq!(averaged.nominal, gap::Nominal::Averaged, "{averaged:?}");
    let switched = choose(&data(plant(p, Mode::Switched)));
    assert_eq!(switched.nominal, gap::Nominal::Switched, "{switched:?}");
    let dead = choose(&data_at(plant(Params { dead_time: 50e-9, ..p }, Mode::Switched), 2.0));
    assert_eq!(dead.nominal, gap::Nominal::Switched, "{dead:?}");
}

/// A 0.8 nH ESL beside Cl = 1.4 µF, read 3 substeps of 100 (91 ns) late: once il pins the late
/// reading, what the ESL leaves on vout is within the noise floor, yet the output-error and
/// high-pass fits of Cl disagree (Hausman ≈ 40). The ESL is named for Cl (significant, moving
/// Cl by more than the tolerance, and the interval test passes with it), and Cl and the ESL
/// land in their CI95 (without the step: sample_delay alone, Cl's interval widened).
#[test]
fn an_esl_hidden_in_the_noise_floor_is_found_through_cl() {
    let (cl, esl) = (1.4e-6, 0.8e-9);
    let d = read_late(Params { cl, esl, ..Params::default() }, 3);
    let dx = diagnose_switched(&d);
    let names: Vec<&str> = dx.selected.iter().map(|e| e.name).collect();
    assert_eq!(names, ["sample_delay", "esl"], "{}", dx.selection_ended);
    let fit = &dx.selected[1];
    assert!(fit.cl_test_failed_without.is_some() && !fit.material, "{}", dx.selection_ended);
    let [lo, hi] = fit.ci95["esl"];
    assert!(lo <= esl && esl <= hi, "esl {:e} outside [{lo:e}, {hi:e}]", fit.params["esl"]);
    assert_final_cl_holds(&dx, cl);
}

/// The bench's harness pair of a capacitor ESR 5.6 % low and 6.5/9.6 mΩ switches, read 6 % of
/// a period late, on the plant: the sequence fills its four steps with the late reading, stand-ins
/// (C drifted 3 %, a divider's gain) and the switches, and still misses `vout` materially (1.7
/// floors, under the joint refit's two): Cl came out 4.99 [3.63, 5.83] µF for 1.61. A full
/// sequence that still misses ran out of steps, not of effects: the joint refit puts the ESR's
/// drift in the stand-ins' place, and Cl's interval holds.
#[test]
fn a_full_sequence_that_still_misses_is_refitted_jointly() {
    let cl = 1.61e-6;
    let d = read_late(Params { cl, rc: 0.0944, switch_resistance: 0.0065, low_side_ratio: 9.6 / 6.5, ..Params::default() }, 6);
    let dx = diagnose_switched(&d);
    let names: Vec<String> = dx.selected.iter().map(|e| e.label()).collect();
    assert!(names.iter().any(|n| n == "switch_resistance") && names.iter().any(|n| n == "param_drift (Rc)"), "{names:?}: {}", dx.selection_ended);
    assert!(!names.iter().any(|n| n == "param_drift (C)" || n == "sensor_gain"), "{names:?}: {}", dx.selection_ended);
    let rc = dx.selected.iter().find_map(|e| e.params.get("Rc").copied()).unwrap();
    assert!((rc / 0.0944 - 1.0).abs() < 0.02, "Rc {rc:e}");
    assert_final_cl_holds(&dx, cl);
}

/// Mains hum over several of its periods averages out: 100 ms of a clean plant (33 001
/// periods at 330 kHz, σ = 2 mV) with 5 mV of 50 Hz on `vout` names nothing, and the true Cl
/// stays inside its interval (widened for the hum the residual keeps). Over half a cycle (a
/// 9 ms record) the hum's mean can read as an offset (the README's advice on captures).
#[test]
fn mains_hum_over_several_of_its_periods_names_nothing() {
    let cl = 10e-6;
    let exp = Experiment { samples: 33_001, noise_vout: 2e-3, noise_seed: 11, ..Experiment::default() };
    let mut d = run(&mut ModelPlant::with_converter_in_open_loop(plant(Params { cl, ..Params::default() }, Mode::Switched)), &exp).unwrap();
    d.meta.retain(|k, _| k == "fs" || k == "U");
    let period = d.sample_period();
    for (k, v) in d.vout.iter_mut().enumerate() {
        *v += 5e-3 * (2.0 * std::f64::consts::PI * 50.0 * k as f64 * period).sin();
    }
    let dx = diagnose_switched(&d);
    assert_eq!(dx.verdict, "none", "{}", dx.selection_ended);
    assert_final_cl_holds(&dx, cl);
}

/// A board with five effects, one of which the joint refit does not carry: dead time (30 ns,
/// 400 pF on the node), 15 mΩ switches, an ESL of 8 nH in C's branch, read 3 % of a period late.
/// The sequence fills its four steps with the others, and the joint refit, which has no ESL to
/// free, put it down as an Rc drift; the sequence goes on and names it, and Cl's interval holds.
#[test]
fn a_full_sequence_the_joint_refit_cannot_finish_goes_on() {
    let cl = 10e-6;
    let p = Params { cl, dead_time: 30e-9, switch_node_capacitance: 400e-12, switch_resistance: 0.015, esl: 8e-9, ..Params::default() };
    let dx = diagnose_switched(&read_late(p, 3));
    let labels: Vec<String> = dx.selected.iter().map(|e| e.label()).collect();
    for effect in ["dead_time", "switch_resistance", "esl", "sample_delay"] {
        assert!(labels.iter().any(|l| l == effect), "{effect} not in {labels:?}: {}", dx.selection_ended);
    }
    assert_final_cl_holds(&dx, cl);
}

/// Closed-loop data (the converter's own PID, a 10-bit DPWM, 2 mV of ADC noise, a ±0.02 PRBS
/// dither; the applied duty recorded): the duty moves every period over tens of levels, and
/// the plant is the nominal one, so the verdict is `none` and Cl holds, as in open loop.
#[test]
fn closed_loop_data_of_the_nominal_plant_is_none() {
    use estimator::experiment::Prbs;
    let cl = 4.7e-6;
    let mut c = plant(Params { cl, ..Params::default() }, Mode::Switched);
    for (id, v) in [(VarId::Control, 2.0), (VarId::DpwmBits, 10.0), (VarId::AdcNoise, 2e-3)] {
        c.set(id, v).unwrap();
    }
    let exp = Experiment { record_applied_duty: true, prbs: Prbs { low: -0.02, high: 0.02, ..Prbs::default() }, ..Experiment::default() };
    let mut d = run(&mut ModelPlant::closed_loop(c), &exp).unwrap();
    d.meta.retain(|k, _| k == "fs" || k == "U");
    let levels = d.duty.iter().map(|x| x.to_bits()).collect::<std::collections::BTreeSet<_>>().len();
    assert!(levels > 20, "{levels} duty levels");
    let dx = diagnose_switched(&d);
    assert_eq!(dx.verdict, "none", "{}", dx.selection_ended);
    assert_final_cl_holds(&dx, cl);
}

/// A clean switched converter whose `io` (2 A) and `vin` (12 V) were recorded by instruments
/// with 40 mA and 30 mV of white noise, as a bench's current probe and scope channel give them.
/// Driven by the recorded noise, the simulation put it into vout, and no quiet window was left
/// for the model-free noise floor; the measured inputs' levels are taken instead (said in
/// `measured_inputs`, each noise within 10 %), and the diagnosis is the clean data's: `none`,
/// Cl inside its interval, the floor model-free.
#[test]
fn measured_inputs_drive_the_models_by_their_levels() {
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};
    let clean = data_at(plant(Params { cl: CL, ..Params::default() }, Mode::Switched), 2.0);
    let mut measured = clean.clone();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
    for (series, sigma) in [(&mut measured.io, 0.04), (&mut measured.vin, 0.03)] {
        let noise = Normal::new(0.0, sigma).unwrap();
        series.iter_mut().for_each(|x| *x += noise.sample(&mut rng));
    }
    let dx = diagnose_switched(&measured);
    assert!(dx.measured_inputs.iter().all(|m| m.replaced), "{:?}", dx.measured_inputs);
    let averaged: Vec<(&str, f64)> = dx.measured_inputs.iter().map(|a| (a.column, a.noise)).collect();
    assert_eq!(averaged.iter().map(|a| a.0).collect::<Vec<_>>(), ["vin", "io"], "{averaged:?}");
    for ((_, noise), sigma) in averaged.iter().zip([0.03, 0.04]) {
        assert!((noise / sigma - 1.0).abs() < 0.1, "{averaged:?}");
    }
    assert_eq!(dx.verdict, "none", "{}", dx.selection_ended);
    assert_eq!(dx.location.noise_floor_from, gap::FloorSource::Differences);
    assert_final_cl_holds(&dx, CL);
    assert!(diagnose_switched(&clean).measured_inputs.is_empty(), "commanded inputs are left as they are");
}

/// A load whose current itself carried 60 mA of white noise (a converter saw it: its vout was
/// simulated with the noisy io): vout's residual under the model fitted on io's level follows
/// that model's response to the noise, so io is kept as recorded (`replaced` false), and the
/// diagnosis is the clean data's.
#[test]
fn an_input_the_converter_saw_is_kept_as_recorded() {
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};
    let truth = Params { cl: CL, ..Params::default() };
    let mut d = data_at(plant(truth, Mode::Switched), 2.0);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
    let load = Normal::new(0.0, 0.06).unwrap();
    d.io.iter_mut().for_each(|x| *x += load.sample(&mut rng));
    let sensor = Normal::new(0.0, 2e-3).unwrap();
    let vout = estimator::simulated::simulate(&truth, &d, d.vout[0]).unwrap();
    d.vout = vout.iter().map(|v| v + sensor.sample(&mut rng)).collect();
    let dx = diagnose_switched(&d);
    assert_eq!(dx.measured_inputs.len(), 1, "{:?}", dx.measured_inputs);
    assert!(!dx.measured_inputs[0].replaced, "{:?}", dx.measured_inputs);
    assert_eq!(dx.verdict, "none", "{}", dx.selection_ended);
    assert_final_cl_holds(&dx, CL);
}

/// A 24 V lab buck (67 µH, 330 µF with 32 mΩ, 118 kHz) with 60 mΩ switches at 1 A, its C
/// `c_share` of the nominal and `cl` of load, 4 mV of noise: diagnosed against the nominal.
fn lab_buck_on_the_ridge(c_share: f64, cl: f64) -> gap::Diagnosis {
    let nominal = Params { l: 67e-6, rl: 0.085, c: 330e-6, rc: 0.032, fs: 118e3, ..Params::default() };
    let truth = Params { cl, c: nominal.c * c_share, switch_resistance: 0.06, ..nominal };
    let exp = Experiment { samples: 3001, noise_vout: 4e-3, noise_seed: 14, io: 1.0, vin: 24.0, ..Experiment::default() };
    let mut d = run(&mut ModelPlant::with_converter_in_open_loop(plant(truth, Mode::Switched)), &exp).unwrap();
    d.meta.retain(|k, _| k == "fs" || k == "U");
    diagnose(&d, &nominal, &DiagnoseOptions { nominal: gap::Nominal::Switched, ..DiagnoseOptions::default() }).unwrap()
}

/// A load small beside a drifted output capacitor lies on the C–Cl ridge (`gap::ridge`): 1.3 µF
/// beside C 11 % high ended on a load ESR and the switches with Cl 37.8 µF, C's drift taken up
/// by Cl; 20 µF beside it on four stand-ins with Cl 56.3 [46.1, 56.8] µF, confidently. The
/// ridge's probe finds as good a model with C drifted, and the interval spans both: 1.3 µF
/// beside C +11.0 % (Cl's interval reaching down to it), 20 µF as not identified. With C at its
/// nominal the probe finds no twin, and Cl stays within a few per cent.
#[test]
fn a_load_small_beside_a_drifted_c_spans_the_ridge() {
    let small = lab_buck_on_the_ridge(1.11, 1.3e-6);
    assert_final_cl_holds(&small, 1.3e-6);
    let twins = small.selected.last().map(|e| e.cl.twins.as_slice()).unwrap_or_default();
    let (twin, drift) = twins.iter().find_map(|t| Some((t, t.selected.iter().find_map(|l| l.strip_prefix("param_drift (C) "))?))).expect("the ridge's twin, with C's drift");
    let percent: f64 = drift.trim_end_matches(" %").parse().unwrap();
    assert!((percent - 11.0).abs() < 1.0, "C {drift} for +11 %: {twin}");
    assert_final_cl_holds(&lab_buck_on_the_ridge(1.11, 20e-6), 20e-6);
    let nominal_c = lab_buck_on_the_ridge(1.0, 1.3e-6);
    let (_, [lo, hi], test) = nominal_c.final_cl();
    assert!(lo <= 1.3e-6 && 1.3e-6 <= hi && hi < 1.1 * lo, "Cl [{lo:e}, {hi:e}] for 1.3 µF ({test})");
}
