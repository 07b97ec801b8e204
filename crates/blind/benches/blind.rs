//! The blind check of the gap diagnosis: seeded datasets with one withheld effect each (and
//! clean ones), from the FMU, from the own ngspice netlists and from the independent harness
//! (one or two withheld effects, circuits written apart from the model), diagnosed without being
//! told; prints, per source, the confusion matrix, the targets and the diagnosis time.
//!
//! `cargo bench -p blind -- [--per-effect N] [--seed S] [--spice-per-effect M] [--no-spice]
//! [--harness-per-effect K] [--harness-adc-delay LO,HI] [--only I,J,…] [--keep DIR]` (0 turns
//! a source off; the harness's ADC delay range in seconds, default 20e-9,300e-9; `--only` runs
//! just the listed dataset numbers of the progress lines, same draws; `--keep` writes each
//! diagnosed dataset to `DIR/NNN-label.csv`, for `buckid diagnose`, with what it holds in
//! `DIR/NNN-label.truth.json`)
//!
//! The FMU is `fmu/BuckConverter.fmu`, rebuilt by `cargo xtask fmu` when stale (the same model
//! in process when that fails); ngspice datasets need `ngspice` on PATH and the `.venv` of
//! `scripts/setup`.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a benchmark binary: failing loudly is fine
use blind::{
    Case, HARNESS_CASES, HARNESS_SEVERAL, Harness, HarnessCase, HarnessRanges, Outcome, SAMPLES, SPICE_EFFECTS, Spice, bundled_fmu, confusion_matrix, diagnose_case, draw, draw_harness, harness_case,
    plant_case, plant_effects, rng, score, spice_case,
};

fn arg(name: &str) -> Option<String> {
    let args: Vec<String> = std::env::args().collect();
    args.iter().position(|a| a == name).and_then(|i| args.get(i + 1)).cloned()
}

/// Whether dataset `index` is to run (`--only`), and the diagnosis of `case` with its data kept
/// (`--keep`).
struct Selection {
    only: Option<Vec<u64>>,
    keep: Option<std::path::PathBuf>,
}

impl Selection {
    fn from_args() -> Self {
        let only = arg("--only").map(|s| s.split(',').map(|x| x.trim().parse().expect("--only I,J,…")).collect());
        let keep = arg("--keep").map(std::path::PathBuf::from);
        if let Some(dir) = &keep {
            std::fs::create_dir_all(dir).expect("--keep DIR: cannot create");
        }
        Self { only, keep }
    }

    fn runs(&self, index: u64) -> bool {
        self.only.as_ref().is_none_or(|o| o.contains(&index))
    }

    fn diagnose(&self, index: u64, case: &blind::Case) -> Outcome {
        if let Some(dir) = &self.keep {
            let path = dir.join(format!("{index:03}-{}-{}.csv", case.source, case.truth.label().replace('+', "-")));
            case.data.write_csv(&path).expect("--keep: cannot write");
            std::fs::write(path.with_extension("truth.json"), format!("{:#}\n", case.truth_json())).expect("--keep: cannot write");
        }
        let o = diagnose_case(case);
        progress(index, &o);
        o
    }
}

fn percent(a: usize, b: usize) -> String {
    if b == 0 { "–".into() } else { format!("{:.0} % ({a}/{b})", 100.0 * a as f64 / b as f64) }
}

/// The diagnosis's own noise floor against the true measurement noise [%].
fn floor_error_percent(o: &Outcome) -> Option<f64> {
    o.noise_floor.map(|f| 100.0 * (f / o.truth.measurement_noise() - 1.0))
}

/// A Cl interval \[F\] in µF to `digits` decimals, or "(not identified)" where it pins nothing
/// down (no bound of 10¹⁵¹ µF printed as a figure).
fn interval_uf([lo, hi]: [f64; 2], digits: usize) -> String {
    if estimator::validate::identified([lo, hi]) { format!("[{:.digits$}, {:.digits$}]", lo * 1e6, hi * 1e6) } else { "(not identified)".to_string() }
}

/// One line per dataset on stderr.
fn progress(index: u64, o: &Outcome) {
    let floor = floor_error_percent(o).map_or_else(|| "no model-free floor".to_string(), |e| format!("floor {e:+.0} %"));
    let check = o.cl_check.as_ref().map_or_else(String::new, |c| format!(", Cl test H {:.1}{}", c.hausman, if c.consistent { "" } else { " (widened)" }));
    let cl = o.final_cl.map_or_else(String::new, |(cl, [lo, hi])| {
        let inside = match (o.final_cl_in_ci95(), estimator::validate::identified([lo, hi])) {
            (Some(true), _) => "",
            (_, false) => " NOT IDENTIFIED",
            _ => " MISSED",
        };
        format!(", Cl {:.4} {} µF (true {:.4}{inside})", cl * 1e6, interval_uf([lo, hi], 4), o.true_cl * 1e6)
    });
    eprintln!("{:>3} {:10} {:32} → {:28} {:.2} s, {floor}{check}{cl}", index, o.source, o.truth.label(), o.said(), o.seconds);
}

/// A truth's settings, three significant digits each.
fn settings(o: &Outcome) -> String {
    let parts: Vec<String> = o.truth.settings.iter().map(|(k, v)| format!("{k} {v:.3e}")).collect();
    parts.join(", ")
}

/// The targets of one source's datasets.
fn report(source: &str, seed: u64, part: &[Outcome]) {
    println!("\n## {source} datasets ({}; seed {seed})\n", part.len());
    println!("{}", confusion_matrix(part));
    let s = score(part);
    let mut times: Vec<f64> = part.iter().map(|o| o.seconds).collect();
    times.sort_by(f64::total_cmp);
    println!("| target | result |\n|---|---|");
    println!("| withheld effect named (≥ 90 %) | {} |", percent(s.named, s.effect_cases));
    println!(
        "| … of those whose effect leaves a gap above the measurement noise | {} ({} below the detection limit) |",
        percent(s.detectable_named, s.detectable_cases),
        s.effect_cases - s.detectable_cases
    );
    println!("| … named, or said alike to the effect named (the data does not tell them apart) | {} |", percent(s.told, s.effect_cases));
    println!("| `none` on clean data (≥ 90 %) | {} |", percent(s.none, s.clean_cases));
    if s.pair_cases > 0 {
        println!("| both effects of a two-effect dataset named (≥ 80 %) | {} (at least one: {}) |", percent(s.pair_named, s.pair_cases), percent(s.pair_one_named, s.pair_cases));
        println!(
            "| … of those each of whose effects leaves a gap above the measurement noise by itself | {} ({} with one below the detection limit) |",
            percent(s.pair_detectable_named, s.pair_detectable_cases),
            s.pair_cases - s.pair_detectable_cases
        );
        println!("| … each named or said alike to an effect named | {} |", percent(s.pair_told, s.pair_cases));
    }
    if s.several_cases > 0 {
        println!("| every effect of a several-effect dataset named | {} (of their effects: {}) |", percent(s.several_named, s.several_cases), percent(s.several_effects_named, s.several_effects));
    }
    let named = part.iter().filter(|o| !o.truth.effects().is_empty() && o.hit()).count();
    println!(
        "| ≥ 70 % of the held-out gap above the measurement noise closed, of the named with a gap | {} ({} named had none above the noise) |",
        percent(s.closed_70, s.with_gap),
        named - s.with_gap
    );
    println!("| true Cl inside the verdict's CI95 (identified), of the named | {} |", percent(s.cl_covered, named));
    println!("| true Cl inside the final CI95 (identified), of all (≥ 90 %) | {} |", percent(s.final_cl_covered, s.final_cl_cases));
    if let (Some(mid), Some(max)) = (times.get(times.len() / 2), times.last()) {
        println!("| diagnosis time, {SAMPLES} samples (≤ 1 s) | median {mid:.2} s, max {max:.2} s |");
    }
    let mut shrink: Vec<f64> = part.iter().filter(|o| o.hit()).filter_map(|o| o.shrink_percent).collect();
    shrink.sort_by(f64::total_cmp);
    if !shrink.is_empty() {
        println!("| (held-out NRMSE shrink, sensor noise included, of the named) | median {:.0} %, min {:.0} % |", shrink[shrink.len() / 2], shrink[0]);
    }
    let mut floor: Vec<f64> = part.iter().filter_map(floor_error_percent).collect();
    floor.sort_by(f64::total_cmp);
    if !floor.is_empty() {
        println!(
            "| diagnosis's own noise-floor estimate vs the true measurement noise | median {:+.1} %, range {:+.1} … {:+.1} % ({} of {}) |",
            floor[floor.len() / 2],
            floor[0],
            floor[floor.len() - 1],
            floor.len(),
            part.len()
        );
    }
    println!("\nMisses ({source}):");
    let with_effect = |o: &&Outcome| !o.truth.effects().is_empty() && o.hit();
    for o in part.iter().filter(with_effect).filter(|o| !o.closed_percent.is_some_and(|c| c >= 70.0)) {
        let closed = o.closed_percent.map_or_else(|| "no gap above the noise".to_string(), |c| format!("closed {c:.0} % of the gap above the noise"));
        println!("- {}: named, {closed} (Cl {:.2} µF, io {:.2} A; {})", o.truth.label(), o.true_cl * 1e6, o.truth.io, settings(o));
    }
    for o in part.iter().filter(with_effect).filter(|o| o.cl_in_ci95() == Some(false)) {
        let (cl, [lo, hi]) = o.cl.unwrap_or((f64::NAN, [f64::NAN; 2]));
        println!(
            "- {}: named, true Cl {:.4} µF {} the CI95 {:.4} {} µF ({:+.2} %, {:.1} half-widths; io {:.2} A; {})",
            o.truth.label(),
            o.true_cl * 1e6,
            if estimator::validate::identified([lo, hi]) { "outside" } else { "not identified by" },
            cl * 1e6,
            interval_uf([lo, hi], 4),
            100.0 * (cl / o.true_cl - 1.0),
            (cl - o.true_cl).abs() / (0.5 * (hi - lo)),
            o.truth.io,
            settings(o)
        );
    }
    for o in part.iter().filter(|o| !o.hit()) {
        let limit = match o.below_detection.as_slice() {
            [] if o.detectable || o.truth.effects().is_empty() => String::new(),
            [] => ", no gap above the noise".to_string(),
            below => format!(", no gap above the noise from {}", below.join(" or ")),
        };
        let final_cl = o.final_cl.map_or_else(String::new, |(cl, [lo, hi])| format!(", final Cl {:.3} {} µF", cl * 1e6, interval_uf([lo, hi], 3)));
        println!("- {}: said {}{limit} (Cl {:.2} µF{final_cl}, io {:.2} A; {})", o.truth.label(), o.said(), o.true_cl * 1e6, o.truth.io, settings(o));
    }
}

fn main() {
    let per_effect: usize = arg("--per-effect").map_or(4, |s| s.parse().expect("--per-effect N"));
    let spice_per_effect: usize = arg("--spice-per-effect").map_or(1, |s| s.parse().expect("--spice-per-effect M"));
    let harness_per_effect: usize = arg("--harness-per-effect").map_or(1, |s| s.parse().expect("--harness-per-effect K"));
    let harness_several: usize = arg("--harness-several").map_or(0, |s| s.parse().expect("--harness-several R"));
    let ranges = arg("--harness-adc-delay").map_or_else(HarnessRanges::default, |s| {
        let v: Vec<f64> = s.split(',').map(|x| x.trim().parse().expect("--harness-adc-delay LO,HI [s]")).collect();
        HarnessRanges { adc_delay: [v[0], *v.get(1).unwrap_or(&v[0])] }
    });
    let seed: u64 = arg("--seed").map_or(2026, |s| s.parse().expect("--seed S"));
    let no_spice = std::env::args().any(|a| a == "--no-spice");
    let selection = Selection::from_args();
    let root = fmu_fixture::root();
    let mut outcomes: Vec<Outcome> = Vec::new();
    let mut index = 0u64;
    if per_effect > 0 {
        let fmu = bundled_fmu();
        match &fmu {
            Some(p) => eprintln!("plant datasets from {}", p.display()),
            None => eprintln!("no fmu/BuckConverter.fmu (cargo xtask fmu failed): plant datasets from the same model in process"),
        }
        for _ in 0..per_effect {
            for effect in plant_effects() {
                index += 1;
                if !selection.runs(index) {
                    continue;
                }
                let mut r = rng(seed, index);
                let case = plant_case(draw(effect, &mut r), seed ^ index, fmu.as_deref()).expect("plant dataset");
                outcomes.push(selection.diagnose(index, &case));
            }
        }
    }
    let spice = if no_spice || spice_per_effect == 0 { None } else { Spice::find(&root) };
    if spice.is_none() && !no_spice && spice_per_effect > 0 {
        eprintln!("ngspice or .venv missing (scripts/setup): no ngspice datasets");
    }
    if let Some(spice) = &spice {
        for _ in 0..spice_per_effect {
            for effect in SPICE_EFFECTS {
                index += 1;
                if !selection.runs(index) {
                    continue;
                }
                let mut r = rng(seed, index);
                let case = spice_case(draw(effect, &mut r), seed ^ index, spice).expect("ngspice dataset");
                outcomes.push(selection.diagnose(index, &case));
            }
        }
    }
    let harness = if no_spice || harness_per_effect + harness_several == 0 { None } else { Harness::find(&root) };
    if harness.is_none() && !no_spice && harness_per_effect + harness_several > 0 {
        eprintln!("ngspice or .venv missing (scripts/setup): no independent-harness datasets");
    }
    if let Some(harness) = &harness {
        // Indices of their own (offset) so that adding plant or ngspice datasets does not
        // change the harness's draws; the several-effect sets apart from the one- and
        // two-effect sets' (which they leave as they were), and a source of their own.
        let kinds: [(&[HarnessCase], usize, u64, &'static str); 2] = [(&HARNESS_CASES, harness_per_effect, 1_000_000, "harness"), (&HARNESS_SEVERAL, harness_several, 2_000_000, "harness-several")];
        for (cases, rounds, offset, source) in kinds {
            for round in 0..rounds {
                for (i, (effect, also)) in cases.iter().enumerate() {
                    let hindex = offset + (round * cases.len() + i) as u64;
                    index += 1;
                    if !selection.runs(index) {
                        continue;
                    }
                    let truth = draw_harness(effect, also, &ranges, &mut rng(seed, hindex));
                    match harness_case(truth.clone(), seed ^ hindex, harness, SAMPLES) {
                        Ok(case) => outcomes.push(selection.diagnose(index, &Case { source, ..case })),
                        Err(e) => eprintln!("{index:>3} harness {}: generator failed: {e}", truth.label()),
                    }
                }
            }
        }
    }
    if harness.is_some() {
        eprintln!("harness ADC delay drawn in [{:e}, {:e}] s", ranges.adc_delay[0], ranges.adc_delay[1]);
    }
    for (source, title) in [
        ("fmu", "own FMU"),
        ("in-process", "own model in process"),
        ("ngspice", "own ngspice netlists"),
        ("harness", "independent harness"),
        ("harness-several", "independent harness, several effects at once"),
    ] {
        let part: Vec<Outcome> = outcomes.iter().filter(|o| o.source == source).cloned().collect();
        if !part.is_empty() {
            report(title, seed, &part);
        }
    }
}
