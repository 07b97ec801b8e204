//! The blind check of the gap diagnosis: seeded datasets with one withheld effect each (and
//! clean ones), from the FMU and from ngspice, diagnosed without being told; prints the
//! confusion matrix, the four targets and the diagnosis time.
//!
//! `cargo bench -p blind -- [--per-effect N] [--seed S] [--spice-per-effect M] [--no-spice]`
//!
//! The FMU is `fmu/BuckConverter.fmu`, rebuilt by `cargo xtask fmu` when stale (the same model
//! in process when that fails); ngspice datasets need `ngspice` on PATH and the `.venv` of `scripts/setup`.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a benchmark binary: failing loudly is fine
use blind::{
    Outcome, SPICE_EFFECTS, Spice, bundled_fmu, confusion_matrix, diagnose_case, draw, plant_case,
    plant_effects, rng, score, spice_case,
};

fn arg(name: &str) -> Option<String> {
    let args: Vec<String> = std::env::args().collect();
    args.iter().position(|a| a == name).and_then(|i| args.get(i + 1)).cloned()
}

fn percent(a: usize, b: usize) -> String {
    if b == 0 { "–".into() } else { format!("{:.0} % ({a}/{b})", 100.0 * a as f64 / b as f64) }
}

/// The diagnosis's own noise floor against the true measurement noise [%].
fn floor_error_percent(o: &Outcome) -> Option<f64> {
    o.noise_floor.map(|f| 100.0 * (f / o.truth.measurement_noise() - 1.0))
}

/// One line per dataset on stderr.
fn progress(index: u64, o: &Outcome) {
    let floor = floor_error_percent(o).map_or_else(|| "no model-free floor".to_string(), |e| format!("floor {e:+.0} %"));
    let check = o.cl_check.as_ref().map_or_else(String::new, |c| format!(", Cl test H {:.1}{}", c.hausman, if c.consistent { "" } else { " (widened)" }));
    eprintln!("{:>3} {:10} {:20} → {:20} {:.2} s, {floor}{check}", index, o.source, o.truth.effect, o.verdict, o.seconds);
}

fn main() {
    let per_effect: usize = arg("--per-effect").map_or(4, |s| s.parse().expect("--per-effect N"));
    let spice_per_effect: usize = arg("--spice-per-effect").map_or(1, |s| s.parse().expect("--spice-per-effect M"));
    let seed: u64 = arg("--seed").map_or(2026, |s| s.parse().expect("--seed S"));
    let fmu = bundled_fmu();
    let spice = if std::env::args().any(|a| a == "--no-spice") { None } else { Spice::find(&fmu_fixture::root()) };
    match &fmu {
        Some(p) => eprintln!("plant datasets from {}", p.display()),
        None => eprintln!("no fmu/BuckConverter.fmu (cargo xtask fmu failed): plant datasets from the same model in process"),
    }
    if spice.is_none() {
        eprintln!("ngspice or .venv missing (scripts/setup): no ngspice datasets");
    }
    let mut outcomes: Vec<Outcome> = Vec::new();
    let mut index = 0u64;
    for _ in 0..per_effect {
        for effect in plant_effects() {
            index += 1;
            let mut r = rng(seed, index);
            let case = plant_case(draw(effect, &mut r), seed ^ index, fmu.as_deref()).expect("plant dataset");
            let o = diagnose_case(&case);
            progress(index, &o);
            outcomes.push(o);
        }
    }
    if let Some(spice) = &spice {
        for _ in 0..spice_per_effect {
            for effect in SPICE_EFFECTS {
                index += 1;
                let mut r = rng(seed, index);
                let case = spice_case(draw(effect, &mut r), seed ^ index, spice).expect("ngspice dataset");
                let o = diagnose_case(&case);
                progress(index, &o);
                outcomes.push(o);
            }
        }
    }
    for source in ["fmu", "in-process", "ngspice"] {
        let part: Vec<Outcome> = outcomes.iter().filter(|o| o.source == source).cloned().collect();
        if part.is_empty() {
            continue;
        }
        println!("\n## {source} datasets ({}; seed {seed})\n", part.len());
        println!("{}", confusion_matrix(&part));
    }
    let s = score(&outcomes);
    let mut times: Vec<f64> = outcomes.iter().map(|o| o.seconds).collect();
    times.sort_by(f64::total_cmp);
    println!("| target | result |\n|---|---|");
    println!("| withheld effect named (≥ 90 %) | {} |", percent(s.named, s.effect_cases));
    println!(
        "| … of those whose effect leaves a gap above the measurement noise | {} ({} below the detection limit) |",
        percent(s.detectable_named, s.detectable_cases),
        s.effect_cases - s.detectable_cases
    );
    println!("| `none` on clean data (≥ 90 %) | {} |", percent(s.none, s.clean_cases));
    println!(
        "| ≥ 70 % of the held-out gap above the measurement noise closed, of the named with a gap | {} ({} named had none above the noise) |",
        percent(s.closed_70, s.with_gap),
        s.named - s.with_gap
    );
    println!("| true Cl inside the CI95, of the named | {} |", percent(s.cl_covered, s.named));
    println!(
        "| diagnosis time, 3001 samples (≤ 1 s) | median {:.2} s, max {:.2} s |",
        times[times.len() / 2],
        times[times.len() - 1]
    );
    let mut shrink: Vec<f64> = outcomes.iter().filter(|o| o.verdict == o.truth.effect).filter_map(|o| o.shrink_percent).collect();
    shrink.sort_by(f64::total_cmp);
    if !shrink.is_empty() {
        println!("| (held-out NRMSE shrink, sensor noise included, of the named) | median {:.0} %, min {:.0} % |", shrink[shrink.len() / 2], shrink[0]);
    }
    let mut floor: Vec<f64> = outcomes.iter().filter_map(floor_error_percent).collect();
    floor.sort_by(f64::total_cmp);
    if !floor.is_empty() {
        println!(
            "| diagnosis's own noise-floor estimate vs the true measurement noise | median {:+.1} %, range {:+.1} … {:+.1} % ({} of {}) |",
            floor[floor.len() / 2],
            floor[0],
            floor[floor.len() - 1],
            floor.len(),
            outcomes.len()
        );
    }
    println!("\nMisses:");
    for o in outcomes.iter().filter(|o| o.truth.effect != "none" && o.verdict == o.truth.effect && !o.closed_percent.is_some_and(|c| c >= 70.0)) {
        let closed = o.closed_percent.map_or_else(|| "no gap above the noise".to_string(), |c| format!("closed {c:.0} % of the gap above the noise"));
        println!("- {} {}: named, {closed} (Cl {:.2} µF, io {:.2} A, {:?})", o.source, o.truth.effect, o.truth.cl * 1e6, o.truth.io, o.truth.settings);
    }
    for o in outcomes.iter().filter(|o| o.truth.effect != "none" && o.verdict == o.truth.effect && o.cl_in_ci95() == Some(false)) {
        let (cl, [lo, hi]) = o.cl.unwrap_or((f64::NAN, [f64::NAN; 2]));
        println!(
            "- {} {}: named, true Cl {:.4} µF outside the CI95 {:.4} [{:.4}, {:.4}] µF ({:+.2} %, {:.1} half-widths; io {:.2} A, {:?})",
            o.source,
            o.truth.effect,
            o.truth.cl * 1e6,
            cl * 1e6,
            lo * 1e6,
            hi * 1e6,
            100.0 * (cl / o.truth.cl - 1.0),
            (cl - o.truth.cl).abs() / (0.5 * (hi - lo)),
            o.truth.io,
            o.truth.settings
        );
    }
    for o in outcomes.iter().filter(|o| o.verdict != o.truth.effect) {
        let limit = if o.detectable { "" } else { ", no gap above the noise" };
        println!("- {} {}: said {}{limit} (Cl {:.2} µF, io {:.2} A, {:?})", o.source, o.truth.effect, o.verdict, o.truth.cl * 1e6, o.truth.io, o.truth.settings);
    }
}
