//! One dataset of the blind bench, diagnosed with every candidate printed: for looking into a
//! miss. `cargo run --release -p blind --example case -- SEED INDEX EFFECT [CSV] [--spice | --harness]`
//! (CSV: also write the dataset there; `--spice`: the ngspice dataset of that index;
//! `--harness`: the independent harness's, EFFECT as `a` or `a+b`, INDEX as the bench draws it:
//! 1000000 + round·12 + position in `HARNESS_CASES`, or 2000000 + round·2 + position in
//! `HARNESS_SEVERAL`)
#![allow(clippy::unwrap_used, clippy::expect_used)] // a tool: failing loudly is fine
use blind::{HARNESS_CASES, HARNESS_SEVERAL, Harness, SAMPLES, Spice, bundled_fmu, draw, draw_harness, harness_case, plant_case, rng, spice_case};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let (seed, index): (u64, u64) = (args[1].parse().unwrap(), args[2].parse().unwrap());
    let case = if args.iter().any(|a| a == "--harness") {
        let (effect, also) =
            HARNESS_CASES.iter().chain(&HARNESS_SEVERAL).find(|(e, a)| std::iter::once(*e).chain(a.iter().copied()).collect::<Vec<_>>().join("+") == args[3]).copied().expect("a HARNESS_CASES entry");
        let truth = draw_harness(effect, also, &blind::HarnessRanges::default(), &mut rng(seed, index));
        println!("{truth:?}");
        harness_case(truth, seed ^ index, &Harness::find(&fmu_fixture::root()).expect("ngspice and .venv (scripts/setup)"), SAMPLES).unwrap()
    } else {
        let effect = blind::plant_effects().find(|e| *e == args[3]).expect("effect name");
        let truth = draw(effect, &mut rng(seed, index));
        println!("{truth:?}");
        if args.iter().any(|a| a == "--spice") {
            spice_case(truth, seed ^ index, &Spice::find(&fmu_fixture::root()).expect("ngspice and .venv (scripts/setup)")).unwrap()
        } else {
            plant_case(truth, seed ^ index, bundled_fmu().as_deref()).unwrap()
        }
    };
    if let Some(path) = args.get(4).filter(|a| !a.starts_with("--")) {
        case.data.write_csv(std::path::Path::new(path)).unwrap();
    }
    let opts = gap::DiagnoseOptions { nominal: case.model, ..gap::DiagnoseOptions::default() };
    let dx = gap::diagnose(&case.data, &case.nominal, &opts).unwrap();
    println!(
        "before {:.5} rms {:.3} mV Cl {:.4} µF, floor {:.3} mV ({:?})",
        dx.gap_before.nrmse,
        dx.gap_before.rms * 1e3,
        dx.gap_before.cl * 1e6,
        dx.location.noise_floor_rms * 1e3,
        dx.location.noise_floor_from
    );
    for e in &dx.effects {
        println!(
            "{:20} nrmse {:.5} rms {:.3} mV shrink {:6.1} aic {:10.1} dAIC {:8.1} LR {:?} sig {} Cl {:.4} [{:.4}, {:.4}] {:?} {:?}",
            e.name,
            e.nrmse_after,
            e.rms_after * 1e3,
            e.shrink_percent,
            e.aic,
            e.delta_aic,
            e.lr_statistic,
            e.significant,
            e.cl.estimate * 1e6,
            e.cl.ci95[0] * 1e6,
            e.cl.ci95[1] * 1e6,
            (e.params.clone(), e.ruled_out_above),
            e.ci95
        );
    }
    for n in &dx.not_tested {
        println!("not tested {}: {}", n.name, n.reason);
    }
    println!("verdict {}", dx.verdict);
    for e in dx.effects.iter().filter(|e| e.name == dx.verdict) {
        println!("Cl {:.4} µF, CI95 [{:.4}, {:.4}]; test {:?} {:?}", e.cl.estimate * 1e6, e.cl.ci95[0] * 1e6, e.cl.ci95[1] * 1e6, e.cl.check, e.cl.check_skipped);
    }
    if let Some(c) = &dx.gap_before.cl_check {
        println!("nominal Cl CI95 [{:.4}, {:.4}]; test {c:?}", dx.gap_before.cl_ci95[0] * 1e6, dx.gap_before.cl_ci95[1] * 1e6);
    }
}
