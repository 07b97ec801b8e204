//! The blind check in small: one seeded dataset per effect of the design table (and a clean
//! one), from the bundled FMU when it is built (`cargo xtask fmu`, which `scripts/test` does
//! first) or else from the same model in process, diagnosed without being told. The full check
//! with more datasets and ngspice is `cargo bench -p blind`.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a test: failing loudly is the point
use blind::{Outcome, bundled_fmu, confusion_matrix, diagnose_case, draw, plant_case, plant_effects, rng, score};

/// The seed of the test's datasets.
const SEED: u64 = 7;

#[test]
fn every_withheld_effect_is_named_blind() {
    let fmu = bundled_fmu();
    let outcomes: Vec<Outcome> = plant_effects()
        .enumerate()
        .map(|(i, effect)| {
            let index = i as u64 + 1;
            let case = plant_case(draw(effect, &mut rng(SEED, index)), SEED ^ index, fmu.as_deref()).unwrap();
            diagnose_case(&case)
        })
        .collect();
    let table = confusion_matrix(&outcomes);
    let s = score(&outcomes);
    // Targets of the issue, on one dataset per effect: every clean dataset `none`, ≥ 90 % of
    // the effects named (one miss allowed in twelve), and Cl inside its CI95 when named.
    assert_eq!(s.none, s.clean_cases, "clean data misjudged:\n{table}");
    assert!(s.named + 1 >= s.effect_cases, "named {}/{}:\n{table}", s.named, s.effect_cases);
    assert!(10 * s.cl_covered >= 9 * s.named, "Cl covered {}/{}:\n{table}", s.cl_covered, s.named);
}

/// One short dataset of the independent harness (`scripts/spice/harness/harness.py`) reads as
/// the data contract and diagnoses without an error; skipped without ngspice or the `.venv`.
#[test]
fn an_independent_harness_dataset_reads_and_diagnoses() {
    let Some(harness) = blind::Harness::find(&fmu_fixture::root()) else {
        eprintln!("ngspice or .venv missing (scripts/setup): independent-harness test skipped");
        return;
    };
    let truth = blind::draw_harness("load_esr", &[], &blind::HarnessRanges::default(), &mut rng(SEED, 1));
    let case = blind::harness_case(truth.clone(), SEED, &harness, 1501).unwrap();
    assert_eq!(case.data.len(), 1501);
    assert_eq!(case.data.meta.keys().collect::<Vec<_>>(), ["U", "fs"], "metadata cut to fs and U");
    assert!(case.data.il.is_some());
    // The load's current, exactly; the duty, the PRBS levels.
    assert!(case.data.io.iter().all(|&i| i == truth.io));
    assert!(case.data.duty.iter().all(|&d| d == 0.4 || d == 0.6));
    // The output sits near the averaged DC value 0.4…0.6 · 12 V − io·RL (ripple and transients
    // within 0.5 V).
    let mean = case.data.vout.iter().sum::<f64>() / case.data.vout.len() as f64;
    assert!((mean - (6.0 - truth.io * 0.1)).abs() < 0.5, "mean vout {mean}");
    // What `--keep` writes beside it says what it holds.
    let kept = case.truth_json();
    assert_eq!(kept["effects"], serde_json::json!(["load_esr"]), "{kept}");
    assert_eq!((kept["cl"].as_f64(), kept["io"].as_f64()), (Some(truth.cl), Some(truth.io)), "{kept}");
    assert!(truth.settings.iter().all(|(k, v)| kept["settings"][k].as_f64() == Some(*v)), "{kept}");
    let o = diagnose_case(&case);
    assert!(!o.verdict.starts_with("error"), "{}", o.verdict);
}

/// The harness's synchronous buck with a 30 ns dead time, its ADC 150 ns late (seed 21): the
/// forward steps take the dead time, then a drift of L that stands in for the late reading, then
/// the late reading (in il); the backward step drops the drift, and Cl lands in its interval
/// (without it Cl came out 4.22 [4.10, 4.34] µF against the true 4.7 µF). Skipped without
/// ngspice or the `.venv`.
#[test]
fn a_stand_in_taken_before_a_late_reading_is_dropped() {
    let Some(harness) = blind::Harness::find(&fmu_fixture::root()) else {
        eprintln!("ngspice or .venv missing (scripts/setup): independent-harness test skipped");
        return;
    };
    let settings = vec![("noise_vout", 2.5e-3), ("noise_il", 5e-3), ("adc_delay", 150e-9), ("dead_time", 30e-9), ("diode_is", 1e-11), ("diode_n", 1.1)];
    let (cl, noise) = (4.7e-6, 2.5e-3);
    let truth = blind::Truth { effect: "dead_time", also: Vec::new(), noise, cl, io: 1.2, settings };
    let case = blind::harness_case(truth, 21, &harness, 3001).unwrap();
    let dx = gap::diagnose(&case.data, &case.nominal, &gap::DiagnoseOptions { nominal: gap::Nominal::Switched, ..gap::DiagnoseOptions::default() }).unwrap();
    let names: Vec<&str> = dx.selected.iter().map(|e| e.name).collect();
    assert!(names.contains(&"dead_time") && names.contains(&"sample_delay"), "{names:?}: {}", dx.selection_ended);
    assert!(!names.contains(&"param_drift"), "{names:?}: {}", dx.selection_ended);
    let (est, [lo, hi], _) = dx.final_cl();
    assert!(lo <= cl && cl <= hi, "Cl {est:e} outside [{lo:e}, {hi:e}]");
}

/// The harness's pair of a 5.7 % low ESR of C and unequal 6.5/9.6 mΩ switches beside 1.6 µF,
/// its ADC 190 ns late (the bench's draw, seed 2026): on top of the late reading the screen
/// ranks `diode_drop` and `dcm` first, both fail, and the next round finds the switches and the
/// drift of Rc. Once named only as `sample_delay`, with Cl not identified. Each effect shows by
/// itself (its twin run without it alone). Skipped without ngspice or the `.venv`.
#[test]
fn a_pair_behind_failed_changes_of_switching_is_found() {
    let Some(harness) = blind::Harness::find(&fmu_fixture::root()) else {
        eprintln!("ngspice or .venv missing (scripts/setup): independent-harness test skipped");
        return;
    };
    let (seed, index) = (2026, 1_000_011);
    let truth = blind::draw_harness("param_drift", &["switch_resistance"], &blind::HarnessRanges::default(), &mut rng(seed, index));
    let case = blind::harness_case(truth, seed ^ index, &harness, blind::SAMPLES).unwrap();
    // Each effect's own footprint, from a twin without it alone: both above the noise.
    let each: Vec<f64> = case.effect_rms_each.iter().map(|r| r.expect("a twin of each")).collect();
    assert!(each.len() == 2 && each.iter().all(|&r| r > 0.0 && r <= case.effect_rms.unwrap() * 1.5), "{each:?} of {:?}", case.effect_rms);
    let o = diagnose_case(&case);
    assert!(o.below_detection.is_empty(), "{:?} below detection: {each:?}", o.below_detection);
    assert!(o.hit(), "said {}", o.said());
    assert_eq!(o.final_cl_in_ci95(), Some(true), "Cl {:?} for {:e}", o.final_cl, o.true_cl);
}
