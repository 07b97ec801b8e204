//! `buckid` as a user runs it: data files in, summary/JSON out, clear errors for bad input.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a test or benchmark: failing loudly is the point
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use buck_model::{Mode, Params};
use estimator::experiment::{Experiment, ModelPlant, run};

fn buckid(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_buckid")).args(args).output().expect("run buckid")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// A switched-plant data file with a known Cl, in the CSV contract.
fn write_data(dir: &Path, cl: f64) -> std::path::PathBuf {
    let truth = Params { cl, ..Params::default() };
    let exp = Experiment { samples: 1500, noise_vout: 2e-3, ..Experiment::default() };
    let data = run(&mut ModelPlant::new(truth, Mode::Switched), &exp).unwrap();
    let path = dir.join("switched.csv");
    data.write_csv(&path).unwrap();
    path
}

fn json(path: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

use fmu_fixture::root;

/// A committed ngspice data set (`scripts/spice/spice_fixtures.py`).
fn spice_fixture(name: &str) -> PathBuf {
    root().join("tests/fixtures/spice").join(name)
}

/// A committed data set of the generator `generator` (`third`, `harness`) and its truth
/// (`tests/fixtures/<generator>/README.md`).
fn generated_fixture(generator: &str, name: &str) -> (PathBuf, serde_json::Value) {
    let dir = root().join("tests/fixtures").join(generator);
    (dir.join(format!("{name}.csv")), json(&dir.join(format!("{name}.truth.json"))))
}

/// A committed third-generator data set and its truth (`tests/fixtures/third/README.md`).
fn third_fixture(name: &str) -> (PathBuf, serde_json::Value) {
    generated_fixture("third", name)
}

/// `buckid diagnose --nominal switched` on a third-generator fixture: its JSON and the truth.
fn diagnose_third(name: &str) -> (serde_json::Value, serde_json::Value) {
    diagnose_generated(third_fixture(name))
}

/// `buckid diagnose --nominal switched` on a generated data set and its truth: its JSON and the
/// truth.
fn diagnose_generated(fixture: (PathBuf, serde_json::Value)) -> (serde_json::Value, serde_json::Value) {
    let (dx, truth, _) = diagnose_generated_text(fixture);
    (dx, truth)
}

/// [`diagnose_generated`], and what the CLI printed.
fn diagnose_generated_text((data, truth): (PathBuf, serde_json::Value)) -> (serde_json::Value, serde_json::Value, String) {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("dx.json");
    let o = buckid(&["diagnose", "--data", data.to_str().unwrap(), "--nominal", "switched", "--json", out.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    (json(&out), truth, String::from_utf8_lossy(&o.stdout).into_owned())
}

/// The names of the effects the diagnosis `dx` selected, in order.
fn selected_names(dx: &serde_json::Value) -> Vec<&str> {
    dx["selected"].as_array().unwrap().iter().map(|e| e["name"].as_str().unwrap()).collect()
}

/// The fitted value of the parameter `key` in the diagnosis `dx`, from the first selected
/// effect that holds it.
fn selected_param<'a>(dx: &'a serde_json::Value, key: &str) -> &'a serde_json::Value {
    dx["selected"].as_array().unwrap().iter().find_map(|e| e["params"].get(key)).unwrap_or_else(|| panic!("no {key} in {:?}", selected_names(dx)))
}

/// Asserts that a fitted `value` of `what` lies within a share `rel` of its `truth`.
fn assert_within(what: &str, value: &serde_json::Value, truth: &serde_json::Value, rel: f64) {
    let (v, t) = (value.as_f64().unwrap(), truth.as_f64().unwrap());
    assert!((v / t - 1.0).abs() < rel, "{what} {v} for {t}");
}

/// The final model's step in the diagnosis `dx`: the last effect selected.
fn final_step(dx: &serde_json::Value) -> &serde_json::Value {
    dx["selected"].as_array().and_then(|s| s.last()).expect("an effect selected")
}

/// The CI95 of a diagnosis's `cl` (an unbounded end as infinite), asserted to hold the truth's
/// `cl_true`.
fn assert_cl_holds_truth(cl: &serde_json::Value, truth: &serde_json::Value) -> [f64; 2] {
    let f = |v: &serde_json::Value| v.as_f64().unwrap_or(f64::INFINITY);
    let (lo, hi, cl_true) = (f(&cl["ci95"][0]), f(&cl["ci95"][1]), f(&truth["cl_true"]));
    assert!(lo <= cl_true && cl_true <= hi, "Cl {} [{lo:e}, {hi:e}] for {cl_true:e}", cl["estimate"]);
    [lo, hi]
}

/// The final model's Cl interval in the diagnosis `dx`, asserted to hold the truth's `cl_true`
/// and to span less than a factor `max_ratio`.
fn assert_final_cl_holds_truth(dx: &serde_json::Value, truth: &serde_json::Value, max_ratio: f64) -> [f64; 2] {
    let last = final_step(dx);
    let [lo, hi] = assert_cl_holds_truth(&last["cl"], truth);
    assert!(hi / lo < max_ratio, "Cl not identified: [{lo:e}, {hi:e}] spans a factor of {max_ratio} or more");
    [lo, hi]
}

/// The labels of the effects of a twin model in a diagnosis's JSON (`cl.twins[i]`), in order.
fn twin_labels(twin: &serde_json::Value) -> Vec<&str> {
    twin["selected"].as_array().map(|s| s.iter().filter_map(serde_json::Value::as_str).collect()).unwrap_or_default()
}

/// Asserts that the final model of the diagnosis `dx` leaves less than `floors` noise floors
/// held out.
fn assert_final_within_floors(dx: &serde_json::Value, floors: f64) {
    let last = final_step(dx);
    let (left, floor) = (last["rms_after"].as_f64().unwrap(), dx["where"]["noise_floor_rms"].as_f64().unwrap());
    assert!(left < floors * floor, "{left} V left, {:.2} floors", left / floor);
}

/// Asserts that a ringing switch node's fitted capacitance `csw` lies between a harness
/// dataset's own node capacitance and that plus its diode's junction (`truth`'s settings).
fn assert_node_of_harness_diode(csw: f64, truth: &serde_json::Value) {
    let settings = &truth["settings"];
    let (own, junction) = (settings["csw"].as_f64().unwrap(), settings["diode_cjo"].as_f64().unwrap());
    assert!((own..own + junction).contains(&csw), "node {csw:e} F for {own:e} + {junction:e}");
}

/// `buckid identify --data` on a third-generator fixture: its JSON, the truth, and what it printed.
fn identify_third(name: &str) -> (serde_json::Value, serde_json::Value, String) {
    let (data, truth) = third_fixture(name);
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("id.json");
    let o = buckid(&["identify", "--data", data.to_str().unwrap(), "--json", out.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    (json(&out), truth, String::from_utf8_lossy(&o.stdout).to_string())
}

/// The project's packaged FMU, (re)built when missing or stale.
fn buck_fmu() -> &'static Path {
    fmu_fixture::buck_fmu().unwrap_or_else(|e| panic!("{e}"))
}

fn assert_clean_failure(o: &Output, needle: &str) {
    let err = stderr(o);
    assert!(!o.status.success(), "accepted; stderr: {err}");
    assert!(err.contains(needle), "{err:?} lacks {needle:?}");
    assert!(!err.contains("panicked"), "{err}");
}

#[test]
fn identify_from_a_data_file_writes_the_json_contract_and_a_report() {
    let dir = tempfile::tempdir().unwrap();
    let data = write_data(dir.path(), 3.3e-6);
    let out = dir.path().join("out.json");
    let report = dir.path().join("report");
    let o = buckid(&["identify", "--data", data.to_str().unwrap(), "--json", out.to_str().unwrap(), "--report", report.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let summary = String::from_utf8_lossy(&o.stdout);
    assert!(summary.contains("Cl ") && summary.contains("held-out"), "{summary}");
    let j = json(&out);
    let (lo, hi) = (j["cl"]["ci95"][0].as_f64().unwrap(), j["cl"]["ci95"][1].as_f64().unwrap());
    assert!(lo < 3.3e-6 && 3.3e-6 < hi, "true Cl outside [{lo}, {hi}]");
    assert_eq!(j["model"], "pwm", "the ripple-exact model must win on switched data");
    assert_eq!(j["samples"].as_u64().unwrap() + j["validation_samples"].as_u64().unwrap(), 1500);
    for key in ["simulation", "prediction"] {
        assert!(j["fit_percent"][key].as_f64().unwrap() > 95.0, "{key}: {}", j["fit_percent"]);
    }
    assert!(j["seconds"].as_f64().unwrap() > 0.0);
    let html = std::fs::read_to_string(report.join("index.html")).unwrap();
    assert_eq!(html.matches("<svg").count(), 4, "held-out, ACF, CCF, Bode");
    // Under the traces, the residual against the ±noise-floor band; the Bode plot's CI95 is a
    // band and the nominal a dashed line; the legends under the plot areas.
    let heldout = figure(&html, "heldout");
    assert!(heldout.contains("residual [mV]") && heldout.contains("time since hold-out start [ms]"), "axes in SI units");
    assert!(heldout.contains("<polygon") && heldout.contains("±noise floor"), "floor band");
    let bode = figure(&html, "bode");
    assert!(bode.contains("<polygon") && bode.contains("CI95 of the fitted Cl") && bode.contains("kHz"));
    assert_no_exponent(&html);
}

/// The inline `<svg>` of the page's `<figure id="{id}">`.
fn figure<'a>(html: &'a str, id: &str) -> &'a str {
    let start = html.find(&format!("<figure id=\"{id}\">")).unwrap_or_else(|| panic!("no figure {id}"));
    let end = start + html[start..].find("</figure>").unwrap();
    &html[start..end]
}

/// No number in the page's text (tags, attributes and file paths aside) is in exponent
/// notation like `1.2345e-6`: every number went through the SI helpers.
fn assert_no_exponent(html: &str) {
    let mut text = String::new();
    let (mut in_tag, mut in_code) = (false, false);
    for (i, c) in html.char_indices() {
        match c {
            '<' => {
                in_tag = true;
                in_code = if html[i..].starts_with("<code>") {
                    true
                } else if html[i..].starts_with("</code>") {
                    false
                } else {
                    in_code
                };
            }
            '>' => {
                in_tag = false;
                text.push(' ');
            }
            _ if !in_tag && !in_code => text.push(c),
            _ => {}
        }
    }
    let c: Vec<char> = text.chars().collect();
    for i in 1..c.len().saturating_sub(2) {
        let sign = usize::from(c[i + 1] == '-' || c[i + 1] == '+');
        if c[i - 1].is_ascii_digit() && c[i] == 'e' && c.get(i + 1 + sign).is_some_and(char::is_ascii_digit) {
            let context: String = c[i.saturating_sub(40)..(i + 20).min(c.len())].iter().collect();
            panic!("a number in exponent notation: …{context}…");
        }
    }
}

#[test]
fn bad_data_files_fail_with_a_message_naming_the_problem() {
    let dir = tempfile::tempdir().unwrap();
    let cases = [
        ("empty.csv", "", "empty"),
        ("nan.csv", "# U = 12\n# io = 1\ntime,duty,vout\n0,0.5,5.9\n3e-6,0.5,NaN\n", "line 5: column `vout`"),
        ("text.csv", "time,duty,vin,io,vout\n0,0.5,12,1,five\n", "line 2: column `vout` value \"five\""),
        ("novout.csv", "time,duty\n0,0.5\n", "required column `vout` is missing"),
        ("short.csv", "# U = 12\n# io = 1\ntime,duty,vout\n0,0.5,5.9\n3e-6,0.5,5.9\n", "too few"),
        // A scope channel AC-coupled: the ripple around zero, where a buck at half duty from
        // 12 V gives about 6 V.
        ("accoupled.csv", "# U = 12\n# io = 1\ntime,duty,vout\n0,0.5,0.01\n3e-6,0.5,-0.01\n", "`vout` averages 0.000 V where duty·vin averages 6.000 V"),
        // The output in millivolts under a bare `vout` header.
        ("millivolts.csv", "# U = 12\n# io = 1\ntime,duty,vout\n0,0.5,5900\n3e-6,0.5,5910\n", "above the 12.000 V `vin` averages"),
        // The load current in milliamps under a bare `io` header (RL the thesis's 100 mΩ).
        ("milliamps.csv", "# U = 12\ntime,duty,io,vout\n0,0.5,1000,5.9\n3e-6,0.5,1000,5.9\n", "`io` averages 1.000 kA where the input could drive 120.0 A"),
    ];
    for (name, text, needle) in cases {
        let path = dir.path().join(name);
        std::fs::write(&path, text).unwrap();
        let o = buckid(&["identify", "--data", path.to_str().unwrap()]);
        assert!(!o.status.success(), "{name} accepted");
        assert!(stderr(&o).contains(needle), "{name}: {:?} lacks {needle:?}", stderr(&o));
        assert!(!stderr(&o).contains("panicked"), "{name}: {}", stderr(&o));
    }
    // A missing file is named, with the system's reason said once (it was printed twice).
    let absent = dir.path().join("absent.csv");
    for args in [["identify", "--data"], ["diagnose", "--sweep"]] {
        let o = buckid(&[args[0], args[1], absent.to_str().unwrap()]);
        let err = stderr(&o);
        let line = err.lines().find(|l| l.starts_with("error:")).unwrap_or_default();
        assert!(!o.status.success() && line.contains("absent.csv"), "{err}");
        let reason = line.rsplit(": ").next().unwrap_or_default();
        assert_eq!(line.matches(reason).count(), 1, "{line}");
    }
}

/// A spreadsheet's export in a locale with a decimal comma: semicolons, headers in any case with
/// their units (`Time [ms]`, `Vout [mV]`, `Duty [%]`), the time printed to six significant
/// digits (0.5 % of a period at row 1500, once refused as "not uniform"). It reads as the
/// contract's own file: the same Cl. A `# fs` the rows' spacing departs from by 2 % (a
/// controller's oscillator) is taken from the rows, aloud; one they contradict (time in
/// milliseconds under an SI header) is refused, where the model had switched at 330 Hz.
#[test]
fn a_spreadsheets_export_reads_as_the_contract() {
    let dir = tempfile::tempdir().unwrap();
    let contract = write_data(dir.path(), 10e-6);
    let data = estimator::data::DataSet::read_csv(&contract).unwrap();
    let comma = |v: f64| format!("{v:e}").replace('.', ",");
    let mut text: String = data.meta.iter().map(|(k, v)| format!("# {k} = {v}\n")).collect();
    text += "Time [ms];DUTY [%];Vin [V];Io (A);Vout [mV]\n";
    for k in 0..data.len() {
        // Six significant digits, in milliseconds.
        let time = format!("{:.5e}", data.time[k] * 1e3);
        let row = [time.replace('.', ","), comma(data.duty[k] * 100.0), comma(data.vin[k]), comma(data.io[k]), comma(data.vout[k] * 1e3)];
        text += &(row.join(";") + "\n");
    }
    let export = dir.path().join("export.csv");
    std::fs::write(&export, &text).unwrap();
    let cl = |path: &Path| {
        let out = dir.path().join("id.json");
        let o = buckid(&["identify", "--data", path.to_str().unwrap(), "--json", out.to_str().unwrap()]);
        assert!(o.status.success(), "{}", stderr(&o));
        (json(&out)["cl"]["estimate"].as_f64().unwrap(), stderr(&o))
    };
    let (want, _) = cl(&contract);
    let (got, _) = cl(&export);
    assert!((got / want - 1.0).abs() < 1e-5, "export {got:e} against the contract's {want:e}");
    let fs = data.meta_f64("fs").unwrap().unwrap();
    let drifted = dir.path().join("drifted.csv");
    std::fs::write(&drifted, std::fs::read_to_string(&contract).unwrap().replace(&format!("# fs = {fs}"), &format!("# fs = {}", fs * 1.02))).unwrap();
    let (got, notes) = cl(&drifted);
    assert!(notes.contains("from the rows' spacing"), "{notes}");
    assert_eq!(got, want, "the model switches once per row either way");
    let ms = dir.path().join("ms.csv");
    let mut in_ms = data.clone();
    in_ms.time.iter_mut().for_each(|t| *t *= 1e3);
    in_ms.write_csv(&ms).unwrap();
    let o = buckid(&["identify", "--data", ms.to_str().unwrap()]);
    assert!(!o.status.success() && stderr(&o).contains("time in other units than seconds?"), "{}", stderr(&o));
}

#[test]
fn bad_fmus_and_bad_arguments_fail_cleanly() {
    let dir = tempfile::tempdir().unwrap();
    let not_zip = dir.path().join("x.fmu");
    std::fs::write(&not_zip, "not a zip").unwrap();
    let o = buckid(&["identify", "--fmu", not_zip.to_str().unwrap()]);
    assert!(!o.status.success() && stderr(&o).starts_with("loading") && stderr(&o).contains("error:"), "{}", stderr(&o));
    let o = buckid(&["identify"]);
    assert!(!o.status.success() && stderr(&o).contains("--fmu"), "{}", stderr(&o));
    let data = write_data(dir.path(), 1e-6);
    let o = buckid(&["identify", "--data", data.to_str().unwrap(), "--holdout", "0.95"]);
    assert!(!o.status.success() && stderr(&o).contains("hold-out fraction"), "{}", stderr(&o));
}

#[test]
fn diagnose_writes_a_report_whose_figures_hold_the_diagnosis() {
    let dir = tempfile::tempdir().unwrap();
    let data = write_data(dir.path(), 4.7e-6);
    let out = dir.path().join("dx.json");
    let report = dir.path().join("report");
    let o = buckid(&["diagnose", "--data", data.to_str().unwrap(), "--json", out.to_str().unwrap(), "--report", report.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let j = json(&out);
    assert!(j.get("fmu").is_none(), "no --fmu, no fmu member");
    let read = |f: &str| std::fs::read_to_string(report.join(f)).unwrap_or_else(|e| panic!("{f}: {e}"));
    // One bar per band, operating point and window of the JSON, each with its value.
    let w = &j["where"];
    for (file, key, fill) in [("gap_bands.svg", "bands", "#1F77B4"), ("gap_operating_points.svg", "operating_points", "#FF7F0E"), ("gap_windows.svg", "windows", "#FF7F0E")] {
        let svg = read(file);
        let n = w[key].as_array().unwrap().len();
        assert!(n > 0, "{key} empty");
        assert_eq!(svg.matches(&format!(r#"fill="{fill}""#)).count(), n, "{file}: one bar each");
        assert!(svg.starts_with("<?xml") && svg.trim_end().ends_with("</svg>"), "{file}");
    }
    assert_eq!(read("gap_bands.svg").matches("Hz – ").count(), w["bands"].as_array().unwrap().len(), "band labels with SI prefixes");
    // The signature: the traces (measured, nominal and, verdict ≠ none, the final model), each
    // a polyline through every held-out sample, then each model's residual over the ±floor band.
    let signature = read("signature.svg");
    let held_out = 1500 - (1500.0 * (1.0 - 1.0 / 3.0_f64)).round() as usize;
    let lines: Vec<usize> = signature.split("points=\"").skip(1).map(|p| p.split('"').next().unwrap().split_whitespace().count()).filter(|n| *n > 10).collect();
    let models = if j["verdict"] == "none" { 1 } else { 2 };
    assert_eq!(lines, vec![held_out; 1 + 2 * models], "points per polyline: traces, then residuals");
    assert_eq!(signature.matches("<polygon").count(), models, "a ±floor band under each residual");
    assert!(signature.contains("±noise floor") && signature.contains("residual [") && signature.contains("× the floor"));
    // The waterfall: the gap, one bar per selected effect, what is left.
    let selected = j["selected"].as_array().unwrap();
    if !selected.is_empty() && selected.iter().all(|e| e["closed_percent"].is_number()) {
        let waterfall = read("waterfall.svg");
        assert_eq!(waterfall.matches(r##"fill="#2CA02C""##).count() + waterfall.matches(r##"fill="#D62728""##).count(), selected.len());
        for e in selected {
            assert!(waterfall.contains(&format!("+ {} →", e["name"].as_str().unwrap())));
        }
    }
    // The page: the figures inline, the table of effects, the verdict and the effects not tested.
    let html = read("index.html");
    let figures = 4 + usize::from(report.join("waterfall.svg").exists());
    assert_eq!(html.matches("<svg").count(), figures, "signature, waterfall, bands, operating points, windows");
    assert_no_exponent(&html);
    for e in j["effects"].as_array().unwrap() {
        assert!(html.contains(&format!("<td>{}</td>", e["name"].as_str().unwrap())) || html.contains(&format!("<b>{}</b>", e["name"].as_str().unwrap())));
    }
    assert!(html.contains(&format!("Verdict: {}", j["verdict"].as_str().unwrap())));
    for n in j["not_tested"].as_array().unwrap() {
        assert!(html.contains(n["name"].as_str().unwrap()));
    }
}

#[test]
fn diagnose_runs_the_bundled_fmu_as_given_and_takes_its_circuit() {
    let dir = tempfile::tempdir().unwrap();
    let data = spice_fixture("ideal.csv");
    let fmu = buck_fmu();
    let out = dir.path().join("dx.json");
    let o = buckid(&["diagnose", "--data", data.to_str().unwrap(), "--fmu", fmu.to_str().unwrap(), "--json", out.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("circuit values from the FMU's start values: C, L, RL, Rc, fs"), "{}", stderr(&o));
    assert!(String::from_utf8_lossy(&o.stdout).contains("FMU         held-out NRMSE"));
    let j = json(&out);
    let f = &j["fmu"];
    assert_eq!(f["path"], fmu.display().to_string());
    assert_eq!(f["model_name"], "BuckConverter");
    // Our FMU starts in mode 1: the averaged nominal model.
    assert_eq!(f["mode"], "averaged");
    assert_eq!(j["nominal"], "averaged");
    assert_eq!(f["circuit"]["L"].as_f64(), Some(3.3e-6));
    // Run with the nominal fit's Cl, the averaged FMU is the nominal model itself: the same
    // held-out error up to the initial state (the fit estimates it, the FMU starts at the DC
    // point of the first duty), 2 % here.
    assert_eq!(f["cl"], j["gap_before"]["cl"]);
    let (fmu_nrmse, before) = (f["nrmse"].as_f64().unwrap(), j["gap_before"]["nrmse"].as_f64().unwrap());
    assert!(before > 0.01, "the averaged model misses the ripple: {before}");
    assert!((fmu_nrmse - before).abs() < 0.02 * before, "FMU {fmu_nrmse} vs nominal {before}");

    // --nominal overrides the FMU's mode; the FMU still runs as given.
    let o = buckid(&["diagnose", "--data", data.to_str().unwrap(), "--fmu", fmu.to_str().unwrap(), "--nominal", "switched", "--json", out.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("nominal model switched as asked"), "{}", stderr(&o));
    let j = json(&out);
    assert_eq!(j["nominal"], "switched");
    assert!((j["fmu"]["nrmse"].as_f64().unwrap() - fmu_nrmse).abs() < 0.02 * fmu_nrmse);
    assert!(j["gap_before"]["nrmse"].as_f64().unwrap() < 0.1 * before, "the switched model has the ripple");
}

#[test]
fn diagnose_rejects_bad_fmus_and_options_cleanly() {
    let dir = tempfile::tempdir().unwrap();
    let data = write_data(dir.path(), 4.7e-6);
    let data = data.to_str().unwrap();
    let absent = dir.path().join("absent.fmu");
    let o = buckid(&["diagnose", "--data", data, "--fmu", absent.to_str().unwrap()]);
    assert_clean_failure(&o, &format!("FMU {} does not exist", absent.display()));
    let not_zip = dir.path().join("x.fmu");
    std::fs::write(&not_zip, "not a zip").unwrap();
    let o = buckid(&["diagnose", "--data", data, "--fmu", not_zip.to_str().unwrap()]);
    assert_clean_failure(&o, "is not a valid FMU (zip) archive");
    let o = buckid(&["diagnose", "--data", data, "--nominal", "spice"]);
    assert_clean_failure(&o, "invalid value 'spice' for '--nominal <NOMINAL>'");
    assert!(stderr(&o).contains("averaged") && stderr(&o).contains("switched"), "lists the choices: {}", stderr(&o));
    let o = buckid(&["diagnose", "--data", data, "--map", "vout=V"]);
    assert_clean_failure(&o, "--fmu");
}

#[test]
fn identify_and_diagnose_the_ngspice_fixture() {
    // tests/fixtures/spice/ideal.csv: ngspice, ideal switch, 500 PRBS periods, no noise; the
    // truth sidecar holds the Cl simulated.
    let dir = tempfile::tempdir().unwrap();
    let data = spice_fixture("ideal.csv");
    let truth = json(&spice_fixture("ideal.truth.json"))["params"]["Cl"].as_f64().unwrap();
    let out = dir.path().join("id.json");
    let o = buckid(&["identify", "--data", data.to_str().unwrap(), "--json", out.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let j = json(&out);
    let est = j["cl"]["estimate"].as_f64().unwrap();
    let (lo, hi) = (j["cl"]["ci95"][0].as_f64().unwrap(), j["cl"]["ci95"][1].as_f64().unwrap());
    assert!(lo <= est && est <= hi, "{est} outside its CI [{lo}, {hi}]");
    // Noise-free data: the CI (±6e-6 relative) reflects only ngspice's own error, so the
    // tolerance is that error's size (tens of ppm; buck_spice.py) with margin, 0.1 %, or the
    // CI half-width when wider.
    let tol = (0.5 * (hi - lo)).max(1e-3 * truth);
    assert!((est - truth).abs() < tol, "Cl {est} vs truth {truth} (±{tol})");
    assert_eq!(j["model"], "pwm", "the switched data needs the ripple-exact model");
    assert_eq!(j["samples"].as_u64().unwrap() + j["validation_samples"].as_u64().unwrap(), 500);
    assert!(j["fit_percent"]["simulation"].as_f64().unwrap() > 99.0 && j["seconds"].as_f64().unwrap() > 0.0);

    // Told no nominal model, the diagnosis takes the switched one for samples of a switching
    // converter, and says why.
    let out = dir.path().join("dx.json");
    let o = buckid(&["diagnose", "--data", data.to_str().unwrap(), "--json", out.to_str().unwrap()]);
    assert!(o.status.success() && stderr(&o).contains("nominal model switched (samples of a switching converter"), "{}", stderr(&o));
    assert_eq!(json(&out)["nominal"], "switched");
    let o = buckid(&["diagnose", "--data", data.to_str().unwrap(), "--nominal", "averaged", "--json", out.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let j = json(&out);
    assert!(j["gap_before"]["nrmse"].as_f64().unwrap() > 0.01, "the averaged model misses the ripple");
    assert!(j["where"].is_object() && j["where"]["bands"].as_array().is_some_and(|b| !b.is_empty()));
    let effects = j["effects"].as_array().unwrap();
    assert!(!effects.is_empty());
    for e in effects {
        for key in ["name", "params", "nrmse_after", "shrink_percent"] {
            assert!(e.get(key).is_some(), "effect lacks {key}: {e}");
        }
    }
    let sorted = effects.windows(2).all(|w| w[0]["nrmse_after"].as_f64() <= w[1]["nrmse_after"].as_f64());
    assert!(sorted, "effects are best first");
    let verdict = j["verdict"].as_str().unwrap();
    let judged = effects.iter().find(|e| e["name"] == verdict).unwrap_or_else(|| panic!("verdict {verdict} is not among the effects"));
    // Whatever it names, the verdict's model closes the gap and recovers Cl.
    assert!(judged["shrink_percent"].as_f64().unwrap() > 90.0, "{judged}");
    let cl = judged["cl"]["estimate"].as_f64().unwrap();
    assert!((cl - truth).abs() < 1e-3 * truth, "verdict's Cl {cl} vs truth {truth}");
    // The interval's test is reported, made or not (noise-free data can leave the high-pass
    // refit's information singular), in the JSON and on stdout.
    let cl_json = &judged["cl"];
    assert!(cl_json["check"].is_object() || cl_json["check_skipped"].is_string(), "{cl_json}");
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(stdout.lines().any(|l| l.starts_with("Cl ") && l.contains("CI95")), "{stdout}");
}

/// A resistive load through the CLI: `identify --fmu … --set rload=10` runs our FMU with the
/// resistor, the recorded data's metadata carries it, the models use it (JSON `nominal.rload`),
/// and Cl lands inside its CI95; a data file with a constant `rload` column is read the same way.
#[test]
fn identify_with_a_resistive_load_from_the_fmu_and_from_a_file() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("fmu.json");
    let saved = dir.path().join("saved.csv");
    let fmu = buck_fmu().to_str().unwrap();
    let o = buckid(&[
        "identify",
        "--fmu",
        fmu,
        "--set",
        "rload=10",
        "--set",
        "Cl=4.7e-6",
        "--samples",
        "2000",
        "--noise-vout",
        "2e-3",
        "--json",
        out.to_str().unwrap(),
        "--save-data",
        saved.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let j = json(&out);
    assert_eq!(j["nominal"]["rload"], 10.0);
    let (cl, lo, hi) = (j["cl"]["estimate"].as_f64().unwrap(), j["cl"]["ci95"][0].as_f64().unwrap(), j["cl"]["ci95"][1].as_f64().unwrap());
    assert!(lo <= 4.7e-6 && 4.7e-6 <= hi, "Cl {cl:e}, CI95 [{lo:e}, {hi:e}]");
    assert!(std::fs::read_to_string(&saved).unwrap().contains("# rload = 10"), "the resistor is in the saved metadata");

    // The same circuit from a file whose resistor is a column.
    let truth = Params { cl: 2.2e-6, rload: 5.0, ..Params::default() };
    let data = run(&mut ModelPlant::new(truth, Mode::Switched), &Experiment { samples: 1500, noise_vout: 2e-3, ..Experiment::default() }).unwrap();
    let text = data.to_csv().replace("# rload = 5\n", "");
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    let header = lines.iter().position(|l| !l.starts_with('#')).unwrap();
    for (i, line) in lines.iter_mut().enumerate().skip(header) {
        line.push_str(if i == header { ",rload" } else { ",5" });
    }
    let file = dir.path().join("column.csv");
    std::fs::write(&file, lines.join("\n") + "\n").unwrap();
    let out = dir.path().join("file.json");
    let o = buckid(&["identify", "--data", file.to_str().unwrap(), "--json", out.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let j = json(&out);
    assert_eq!(j["nominal"]["rload"], 5.0);
    let (lo, hi) = (j["cl"]["ci95"][0].as_f64().unwrap(), j["cl"]["ci95"][1].as_f64().unwrap());
    assert!(lo <= 2.2e-6 && 2.2e-6 <= hi, "CI95 [{lo:e}, {hi:e}]");
}

/// `diagnose` on clean switched data with a resistive load (`# rload = 5`): the nominal it
/// builds from the metadata carries the resistor, so there is nothing to explain (`none`) and
/// the final Cl's interval covers the truth.
#[test]
fn diagnose_takes_the_resistive_load_from_the_metadata() {
    let dir = tempfile::tempdir().unwrap();
    let truth = Params { cl: 4.7e-6, rload: 5.0, ..Params::default() };
    let data = run(&mut ModelPlant::new(truth, Mode::Switched), &Experiment { samples: 1500, noise_vout: 2e-3, ..Experiment::default() }).unwrap();
    let path = dir.path().join("rload.csv");
    data.write_csv(&path).unwrap();
    let out = dir.path().join("dx.json");
    let o = buckid(&["diagnose", "--data", path.to_str().unwrap(), "--nominal", "switched", "--json", out.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let j = json(&out);
    assert_eq!(j["verdict"], "none", "{}", String::from_utf8_lossy(&o.stdout));
    let cl = j["gap_before"]["cl"].as_f64().unwrap();
    assert!((cl / 4.7e-6 - 1.0).abs() < 0.01, "nominal fit's Cl {cl:e}");
}

/// `diagnose --sweep` on the student-lab sweep: a JSON with a forward-selection sequence and a
/// verdict that is not `none`.
#[test]
fn diagnose_sweep_on_the_lab_fixture() -> anyhow::Result<()> {
    let dir = tempfile::tempdir()?;
    let json = dir.path().join("sweep.json");
    let lab = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/fixtures/sweep/lab24v.csv");
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_buckid")).args(["diagnose", "--sweep"]).arg(&lab).arg("--json").arg(&json).arg("--report").arg(dir.path().join("report")).output()?;
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(String::from_utf8_lossy(&out.stderr).contains("assuming rds_on"));
    let v: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&json)?)?;
    assert!(v["selected"].as_array().is_some_and(|s| !s.is_empty()), "{v}");
    assert_ne!(v["verdict"], "none");
    assert!(v["gap_before"]["rms"].as_f64().is_some_and(|r| r > 0.5));
    assert!(v["where"]["by_operating_point"].as_array().is_some_and(|p| p.len() == 9));
    assert!(dir.path().join("report/index.html").exists());
    Ok(())
}

/// Partial metadata: the ngspice fixture without `# L`, `# RL`, `# C`, `# Rc`. The CLI says
/// which values it assumed, and `--estimate-missing` estimates them with Cl: each within 0.1 %
/// of the values ngspice simulated (noise-free data) and identified; `--estimate L` alone
/// frees only L.
#[test]
fn missing_circuit_values_are_assumed_aloud_and_can_be_estimated() {
    let dir = tempfile::tempdir().unwrap();
    let full = std::fs::read_to_string(spice_fixture("ideal.csv")).unwrap();
    let partial: String = full.lines().filter(|l| !["# L =", "# RL =", "# C =", "# Rc ="].iter().any(|k| l.starts_with(k))).map(|l| format!("{l}\n")).collect();
    let data = dir.path().join("partial.csv");
    std::fs::write(&data, partial).unwrap();
    let out = dir.path().join("id.json");
    let o = buckid(&["identify", "--data", data.to_str().unwrap(), "--model", "pwm", "--estimate-missing", "--json", out.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    for key in ["L", "RL", "C", "Rc"] {
        assert!(stderr(&o).contains(&format!("assuming {key} = ")), "{}", stderr(&o));
    }
    let j = json(&out);
    for (key, truth) in [("L", 3.3e-6), ("RL", 0.1), ("C", 100e-6), ("Rc", 0.1)] {
        let e = &j["estimated"][key];
        let est = e["estimate"].as_f64().unwrap();
        assert!((est / truth - 1.0).abs() < 1e-3, "{key} {est:e} vs {truth:e}");
        assert_eq!(e["identified"], true, "{key}: {e}");
    }
    let o = buckid(&["identify", "--data", data.to_str().unwrap(), "--model", "pwm", "--estimate", "L", "--json", out.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let estimated = json(&out)["estimated"].as_object().unwrap().keys().cloned().collect::<Vec<_>>();
    assert_eq!(estimated, ["L"]);
}

/// Data that cannot support an answer says so: a constant duty, io and vin excite nothing, and
/// both commands refuse plainly instead of printing a Cl.
#[test]
fn unexcited_data_is_refused_plainly() {
    let dir = tempfile::tempdir().unwrap();
    let rows: String = (0..600).map(|k| format!("{},0.5,12,1,{}\n", k as f64 / 330e3, 5.9 + 1e-3 * ((k * 7919) % 13) as f64)).collect();
    let data = dir.path().join("flat.csv");
    std::fs::write(&data, format!("# fs = 330000\ntime,duty,vin,io,vout\n{rows}")).unwrap();
    for cmd in ["identify", "diagnose"] {
        let o = buckid(&[cmd, "--data", data.to_str().unwrap()]);
        assert_clean_failure(&o, "no excitation");
        assert!(!String::from_utf8_lossy(&o.stdout).contains("µF"), "{cmd} printed a Cl");
    }
}

#[test]
fn simulate_drives_our_fmu_with_stepped_duty_to_its_dc_points() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("duty.csv");
    std::fs::write(&input, "time,duty\n0,0.5\n1e-3,0.25\n").unwrap();
    let out = dir.path().join("out.csv");
    let fmu = buck_fmu().to_str().unwrap();
    let args = ["simulate", "--fmu", fmu, "--input", input.to_str().unwrap(), "--set", "mode=1", "--stop", "2e-3", "--step", "1e-5"];
    let o = buckid(&[&args[..], &["--output", "vout", "--output", "mode", "--out", out.to_str().unwrap()]].concat());
    assert!(o.status.success(), "{}", stderr(&o));
    let text = std::fs::read_to_string(&out).unwrap();
    let rows: Vec<Vec<f64>> = text.lines().skip(1).map(|l| l.split(',').map(|x| x.parse().unwrap()).collect()).collect();
    assert_eq!(text.lines().next(), Some("time,vout,mode"));
    assert_eq!(rows.len(), 201, "the start and 200 steps");
    // Averaged DC point vout = d·U − RL·io (U = 12 V, RL = 0.1 Ω, io = 1 A): the FMU starts at
    // that of duty 0.5 and has settled on 0.25 after 1 ms (30 time constants 2L/(RL + Rc) = 33 µs).
    let at = |t: f64| rows.iter().find(|r| (r[0] - t).abs() < 1e-12).unwrap()[1];
    assert!((at(0.0) - 5.9).abs() < 1e-9, "{}", at(0.0));
    assert!((at(1e-3) - 5.9).abs() < 1e-6, "{}", at(1e-3));
    assert!((at(2e-3) - 2.9).abs() < 1e-6, "{}", at(2e-3));
    assert!(rows.iter().all(|r| r[2] == 1.0), "mode recorded as the Integer it was set to");

    let o = buckid(&["simulate", "--fmu", fmu, "--set", "mode=1.5"]);
    assert_clean_failure(&o, "mode");
    let o = buckid(&["simulate", "--fmu", fmu, "--set", "duty=nan"]);
    assert_clean_failure(&o, "not a finite number");
}

/// Our FMU at Cl 4.7 µF with 2 mV of noise on its ADC's vout and the ADC settings `adc`, run by
/// `simulate` on a PRBS duty and recorded from its ADC as data in the contract's CSV, diagnosed
/// told nothing: the diagnosis. A period's applied duty arrives at its end, and so do its
/// readings where the ADC reads `within_period` (`adc_delay`), else at its start.
fn diagnose_our_fmus_adc(adc: &[&str], within_period: bool) -> serde_json::Value {
    let (period, warmup, n) = (1.0 / 330e3, 200, 3001);
    let dir = tempfile::tempdir().unwrap();
    let duties = estimator::experiment::Prbs::default().duties(warmup + n + 1).unwrap();
    let input = dir.path().join("duty.csv");
    let rows: String = duties.iter().enumerate().map(|(k, d)| format!("{:e},{d}\n", k as f64 * period)).collect();
    std::fs::write(&input, format!("time,duty\n{rows}")).unwrap();
    let out = dir.path().join("adc.csv");
    let (stop, step) = (format!("{:e}", (warmup + n + 1) as f64 * period), format!("{period:e}"));
    let sets = [&["mode=2", "Cl=4.7e-6", "adc_noise=2e-3", "noise_seed=3"], adc].concat().into_iter().flat_map(|s| ["--set", s]).collect::<Vec<_>>();
    let outputs = ["duty_applied", "vout_adc", "il_adc"].map(|s| ["--output", s]).concat();
    let args =
        [&["simulate", "--fmu", buck_fmu().to_str().unwrap(), "--input", input.to_str().unwrap(), "--stop", &stop, "--step", &step][..], &sets, &outputs, &["--out", out.to_str().unwrap()]].concat();
    let o = buckid(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = std::fs::read_to_string(&out).unwrap();
    let recorded: Vec<Vec<f64>> = text.lines().skip(1).map(|l| l.split(',').map(|x| x.parse().unwrap()).collect()).collect();
    // Row k of the data: period k's duty, recorded at its end (row k + 1), and its readings.
    let readings_at = warmup + usize::from(within_period);
    let column = |i: usize, from: usize| recorded[from..from + n].iter().map(|r| r[i]).collect::<Vec<f64>>();
    let meta = [("fs", "330000"), ("U", "12")].map(|(k, v)| (k.to_string(), v.to_string())).into();
    let data_set = estimator::data::DataSet {
        time: (0..n).map(|k| k as f64 * period).collect(),
        duty: column(1, warmup + 1),
        vin: vec![12.0; n],
        io: vec![1.0; n],
        vout: column(2, readings_at),
        il: Some(column(3, readings_at)),
        meta,
        ..estimator::data::DataSet::default()
    };
    let data = dir.path().join("data.csv");
    data_set.write_csv(&data).unwrap();
    let dx_path = dir.path().join("dx.json");
    let o = buckid(&["diagnose", "--data", data.to_str().unwrap(), "--nominal", "switched", "--json", dx_path.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    json(&dx_path)
}

/// Our FMU with its ADC reading 0.2 T after each period start (`adc_delay`): `diagnose` names
/// the late reading alone, at the ADC's instant within 1 %, and Cl's interval holds the FMU's.
#[test]
fn a_late_adc_in_our_fmu_is_named_with_its_instant() {
    let delay = 0.2 / 330e3;
    let dx = diagnose_our_fmus_adc(&[&format!("adc_delay={delay:e}")], true);
    assert_eq!(selected_names(&dx), ["sample_delay"], "{}", dx["selection_ended"]);
    let found = selected_param(&dx, "sample_delay").as_f64().unwrap();
    assert!((found / delay - 1.0).abs() < 0.01, "sample_delay {found:e} for the ADC's {delay:e}");
    assert_final_cl_holds_truth(&dx, &serde_json::json!({ "cl_true": 4.7e-6 }), 1.05);
}

/// Our FMU with an RC anti-alias filter in front of its ADC's vout channel (`adc_filter`, the
/// corner at half the switching frequency): `diagnose` names the filter alone, its time constant
/// within 3 %, and Cl's interval holds the FMU's.
#[test]
fn an_anti_alias_filter_in_our_fmu_is_named_with_its_time_constant() {
    let tau = 1.0 / (std::f64::consts::PI * 330e3);
    let dx = diagnose_our_fmus_adc(&[&format!("adc_filter={tau:e}")], false);
    assert_eq!(selected_names(&dx), ["sensor_filter"], "{}", dx["selection_ended"]);
    assert_time_constants(&dx, &[("vout_filter", tau)]);
    assert_final_cl_holds_truth(&dx, &serde_json::json!({ "cl_true": 4.7e-6 }), 1.05);
}

/// Our FMU with a low-pass in front of each of its ADC's channels (`adc_filter` at half the
/// switching frequency on vout, `adc_il_filter` at two thirds of it on il), alone and beside 30
/// ns of dead time: `diagnose` names the dead time where there is one, then the filters on both
/// channels, each time constant within 3 %, and Cl's interval holds the FMU's. Alone, vout's
/// filter closes vout's gap in the first step and il's, which vout cannot show, is named on top
/// of it from il (968.6 and 723.4 ns for 964.6 and 723.4, Cl 4.674 [4.614, 4.736] µF); before,
/// il's was left unnamed. Beside the dead time, since il's screen asks for a share beyond the
/// probe's calibration, vout's filter again comes first and il's on top (966.5 and 723.2 ns, Cl
/// 4.688 [4.403, 4.992] µF), where the filter on both channels had been one step. Our ngspice
/// buck's come in one (pytest `test_filters_on_both_channels_are_found_and_cl_holds`).
#[test]
fn filters_on_both_channels_of_our_fmus_adc_are_named_with_their_time_constants() {
    let (tau, il_tau) = (1.0 / (std::f64::consts::PI * 330e3), 0.75 / (std::f64::consts::PI * 330e3));
    let filters = [format!("adc_filter={tau:e}"), format!("adc_il_filter={il_tau:e}")];
    for (settings, circuit) in [(&[][..], &[][..]), (&["dead_time=30e-9"], &["dead_time"])] {
        let adc: Vec<&str> = settings.iter().copied().chain(filters.iter().map(String::as_str)).collect();
        let dx = diagnose_our_fmus_adc(&adc, false);
        // The filter on both channels, or vout's then il's.
        let names = selected_names(&dx);
        let (named, readings) = names.split_at(circuit.len().min(names.len()));
        assert!(named == circuit && (1..=2).contains(&readings.len()) && readings.iter().all(|n| *n == "sensor_filter"), "{names:?}: {}", dx["selection_ended"]);
        assert_time_constants(&dx, &[("vout_filter", tau), ("il_filter", il_tau)]);
        assert_final_cl_holds_truth(&dx, &serde_json::json!({ "cl_true": 4.7e-6 }), 1.15);
    }
}

/// Our FMU's ADC converting il 40 ns into each period and vout 600 ns after it
/// (`adc_vout_skew`, a multiplexed ADC): `diagnose`, told nothing, names the two instants
/// (`channel_skew`), each within 2 %, and Cl's interval holds the FMU's (il read noise-free; with
/// noise on il, see the next test).
#[test]
fn a_multiplexed_adc_in_our_fmu_is_named_with_its_channels_instants() {
    let (il_at, skew) = (40e-9, 600e-9);
    let dx = diagnose_our_fmus_adc(&[&format!("adc_delay={il_at:e}"), &format!("adc_vout_skew={skew:e}")], true);
    assert_eq!(selected_names(&dx), ["channel_skew"], "{}", dx["selection_ended"]);
    for (name, truth) in [("sample_delay", il_at), ("vout_skew", skew)] {
        let found = selected_param(&dx, name).as_f64().unwrap();
        assert!((found / truth - 1.0).abs() < 0.02, "{name} {found:e} for the ADC's {truth:e}");
    }
    assert_final_cl_holds_truth(&dx, &serde_json::json!({ "cl_true": 4.7e-6 }), 1.05);
}

/// Our FMU's ADC as above, with 10 mA of noise on its il channel (`adc_il_noise`, `noise_seed`
/// 4): il's late reading is taken first, on il's word, and the path goes on to what vout read
/// apart from il looks like. vout 300 ns after il: a ceramic's bias and an ESL, 2.863 mV held
/// out; the late reading with vout's own instant explains vout better (2.035 mV) with fewer
/// effects and is taken instead: `channel_skew` at 39.7 and 299.6 ns, each within 3 % and inside
/// its CI95, Cl 4.699 [4.649, 4.768] µF for 4.7. vout 60 ns after il: the late reading and an
/// ESL (2.115 mV, Cl 4.427 µF), alike to vout's own instant at 61.1 ns (2.035 mV, Cl 4.705 µF):
/// Cl's interval spans both, [4.331, 4.724] µF. (Seeds 3 to 7 all name `channel_skew` at 300 ns
/// with Cl inside its interval; il's instant lies inside its CI95 on 4 of them, seed 3's at
/// 37.2 [35.5, 39.0] ns.)
#[test]
fn vouts_own_instant_in_our_fmu_is_weighed_against_the_path_il_read_noisy() {
    let il_at = 40e-9;
    let settings = |skew: f64| [format!("adc_delay={il_at:e}"), format!("adc_vout_skew={skew:e}"), "adc_il_noise=10e-3".to_string(), "noise_seed=4".to_string()];
    let s = settings(300e-9);
    let dx = diagnose_our_fmus_adc(&[&s[0], &s[1], &s[2], &s[3]], true);
    assert_eq!(selected_names(&dx), ["channel_skew"], "{}", dx["selection_ended"]);
    assert!(dx["selection_ended"].as_str().unwrap().contains("taken instead of the path"), "{}", dx["selection_ended"]);
    for (name, truth) in [("sample_delay", il_at), ("vout_skew", 300e-9)] {
        let found = selected_param(&dx, name).as_f64().unwrap();
        assert!((found / truth - 1.0).abs() < 0.03, "{name} {found:e} for the ADC's {truth:e}");
        let ci95 = dx["selected"][0]["ci95"][name].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect::<Vec<f64>>();
        assert!(ci95[0] <= truth && truth <= ci95[1], "{name}'s CI95 {ci95:?} leaves out the ADC's {truth:e}");
    }
    assert_final_cl_holds_truth(&dx, &serde_json::json!({ "cl_true": 4.7e-6 }), 1.05);
    let s = settings(60e-9);
    let dx = diagnose_our_fmus_adc(&[&s[0], &s[1], &s[2], &s[3]], true);
    let apart = &final_step(&dx)["cl"]["read_late"];
    assert_eq!(apart["instant"], "vout_skew", "{}", dx["selected"]);
    assert!((apart["value"].as_f64().unwrap() / 60e-9 - 1.0).abs() < 0.1, "{apart}");
    assert_final_cl_holds_truth(&dx, &serde_json::json!({ "cl_true": 4.7e-6 }), 1.15);
}

/// Asserts that each time constant `name` the diagnosis `dx` selected lies within 3 % of the
/// ADC's `want`.
fn assert_time_constants(dx: &serde_json::Value, filters: &[(&str, f64)]) {
    for &(name, want) in filters {
        let found = selected_param(dx, name).as_f64().unwrap();
        assert!((found / want - 1.0).abs() < 0.03, "{name} {found:e} s for the ADC's {want:e} s");
    }
}

/// Our FMU with vout read directly and il through a current-sense amplifier's bandwidth
/// (τ = T/π): alone, vout has no gap and il's filter is the first step, judged in il; beside a
/// dead time, it is named on top of it. Each at its time constant, Cl held.
#[test]
fn a_filter_on_il_alone_is_named_from_il() {
    let tau = 1.0 / (std::f64::consts::PI * 330e3);
    let filter = format!("adc_il_filter={tau:e}");
    for (adc, names) in [(vec![filter.as_str()], &["sensor_filter"][..]), (vec!["dead_time=30e-9", filter.as_str()], &["dead_time", "sensor_filter"][..])] {
        let dx = diagnose_our_fmus_adc(&adc, false);
        assert_eq!(selected_names(&dx), names, "{adc:?}: {}", dx["selection_ended"]);
        assert_eq!(dx["verdict"], names[0]);
        let filtered = final_step(&dx);
        assert!(filtered["params"].get("vout_filter").is_none() && filtered["il_closed_percent"].as_f64().unwrap() > 95.0, "{filtered}");
        assert_time_constants(&dx, &[("il_filter", tau)]);
        assert_final_cl_holds_truth(&dx, &serde_json::json!({ "cl_true": 4.7e-6 }), 1.05);
    }
}

/// A clean point-of-load capture from the third ngspice generator (5 V, 1.2 µH, 57 µF with
/// 7.3 mΩ, 538 kHz, 5.3 A, 73 µF of load, vout alone), told nothing, is clean. The nominal fit
/// ranks Cl's grid on the first samples and starts from the best point alone; here it ended at
/// Cl 163 µF, missing worse than the data's mean (held-out NRMSE 1.2), and every candidate then
/// "closed" that gap with a value of nothing (a 5 µΩ load ESR, an 8.5 ps dead time) by moving Cl
/// to its true value. A nominal that misses worse than the mean is refitted from the whole grid.
#[test]
fn a_clean_point_of_load_capture_is_clean() {
    let (dx, truth) = diagnose_third("pol-clean-1901");
    assert_eq!(truth["effects"], serde_json::json!([]));
    assert!(dx["gap_before"]["nrmse"].as_f64().unwrap() < 0.05, "{}", dx["gap_before"]);
    assert_eq!(dx["verdict"], "none", "{}", dx["selection_ended"]);
    // The generator's Cl within 0.1 % (its ever-present parasitics move it by about 1e-5).
    let (cl, cl_true) = (dx["gap_before"]["cl"].as_f64().unwrap(), truth["cl_true"].as_f64().unwrap());
    assert!((cl / cl_true - 1.0).abs() < 1e-3, "Cl {cl:e} for {cl_true:e}");
}

/// A clean point-of-load capture (third generator, seed 7902: 5 V, 1.7 µH, 200 µF with 13 mΩ,
/// 819 kHz, 8.8 A) whose 1.83 µF of load is 0.9 % of the output's capacitance: Cl leans −103 on
/// C and −108 on L, so the 0.0025 % the circuit's parasitics move them puts Cl 0.27 % high,
/// outside the ±0.2 % its interval had been held to. Held to the circuit model's fidelity of L
/// and C through that leverage (±1.1 %), both `diagnose` and `identify` hold the true Cl, and
/// say why the interval is that wide.
#[test]
fn a_small_cl_beside_a_large_c_is_held_to_l_and_cs_fidelity() {
    let (dx, truth) = diagnose_third("pol-clean-7902");
    assert_eq!(truth["effects"], serde_json::json!([]));
    assert_eq!(dx["verdict"], "none", "{}", dx["selection_ended"]);
    let cl_true = truth["cl_true"].as_f64().unwrap();
    let [lo, hi] = [0, 1].map(|i| dx["gap_before"]["cl_ci95"][i].as_f64().unwrap());
    assert!(lo <= cl_true && cl_true <= hi, "Cl {cl_true:e} outside [{lo:e}, {hi:e}]");
    let lean = ["L", "C"].map(|x| dx["cl_leverage"][x].as_f64().unwrap().abs()).into_iter().fold(0.0, f64::max);
    let fidelity = dx["cl_fidelity"].as_f64().unwrap();
    assert!(lean > 50.0 && (fidelity / (gap::CIRCUIT_FIDELITY * lean).exp_m1() - 1.0).abs() < 1e-9, "fidelity {fidelity} for a leverage of {lean}");
    // The interval is no wider than that fidelity asks.
    assert!(hi / lo < (1.0 + fidelity).powi(2) * 1.001, "[{lo:e}, {hi:e}] wider than ±{fidelity}");

    let (id, _, stdout) = identify_third("pol-clean-7902");
    let [lo, hi] = [0, 1].map(|i| id["cl"]["ci95"][i].as_f64().unwrap());
    assert!(lo <= cl_true && cl_true <= hi, "identify: Cl {cl_true:e} outside [{lo:e}, {hi:e}]");
    assert!(stdout.contains("through Cl's leverage on them"), "{stdout}");
}

/// A point-of-load buck with dead time, the switches' resistance, L −10 % and Rc −20 %, and a
/// probe 1.2 % high (third generator, seed 7701: 5 V, 575 kHz, 14.5 µF of load beside 75 µF,
/// vout and il). Its final model fits L at −5 % with C + Cl 84.7 µF for 89.5, the resonance
/// kept, and had Cl 9.68 [3.75, 10.6] µF: confidently wrong. Its current needs a probe gain of
/// ×1.06, which is the probe's or the impedance's: taken as the impedance's, the output's
/// capacitance is ×1.06 and Cl near 15 µF. The interval spans both, holds the truth, and says
/// why.
#[test]
fn a_fitted_l_spans_cl_with_the_current_probe_exact() {
    let (dx, truth) = diagnose_third("pol-several-7701");
    let last = final_step(&dx);
    assert!(dx["selected"].as_array().unwrap().iter().any(|e| e["params"]["L"].is_number()), "L not fitted: {}", dx["selected"]);
    let probe = &last["cl"]["probe_exact"];
    let gain = probe["probe_gain"].as_f64().unwrap();
    assert!((gain - 1.0).abs() > 0.03 && (gain - 1.0).abs() <= gap::PROBE_GAIN_TOLERANCE, "{probe}");
    let [_, hi] = assert_final_cl_holds_truth(&dx, &truth, 10.0);
    let cl_true = truth["cl_true"].as_f64().unwrap();
    // The fit's own Cl stays below the truth; the probe-exact one lies above it, and the
    // interval reaches it.
    let (estimate, exact) = (last["cl"]["estimate"].as_f64().unwrap(), probe["cl"].as_f64().unwrap());
    assert!(estimate < cl_true && cl_true < exact && exact <= hi, "Cl {estimate:e}, with the probe exact {exact:e}, interval up to {hi:e}");
}

/// The same board's path (four effects, then their joint refit, pruned) ended 1.60 mV held out,
/// 1.2 floors, materially above the floor; the converter's joint model from the nominal values
/// ends at the floor (1.43 mV) with seven effects, each a finding given the others: an adequate
/// model is taken before one that is not, and it names the late reading and the low side's own
/// too.
#[test]
fn a_joint_model_from_the_nominal_values_at_the_floor_replaces_a_simpler_path_above_it() {
    let (dx, truth) = diagnose_third("pol-several-7701");
    let ended = dx["selection_ended"].as_str().unwrap();
    assert!(ended.starts_with("the converter's joint model from its nominal values") && ended.contains("4 effects selected"), "{ended}");
    let names = selected_names(&dx);
    assert!(names.len() > 4 && names.contains(&"sample_delay") && names.contains(&"unequal_switches"), "{names:?}");
    assert_final_cl_holds_truth(&dx, &truth, 10.0);
}

/// A 24 V lab buck whose 260 µF electrolytic has 19 nH of ESL, 1.75 µF of load at 0.22 A, read
/// 359 ns late (third generator, seed 10402). The late reading il shows came first; on top of
/// it the screen ranked the ESL sixth on its 1 nH probe, and a −0.011 % gain of the vout
/// reading, the explanation of last resort, reached the floor with Cl 2.00 [1.96, 2.05] µF. The
/// extensions along Cl the screen passed over are fitted before a calibration is taken: the ESL
/// is named with its value, and Cl's interval holds the truth.
#[test]
fn a_circuit_effect_the_screen_passed_over_is_fitted_before_a_readings_calibration() {
    let (dx, truth) = diagnose_third("lab-single-10402");
    assert_eq!(selected_names(&dx), ["sample_delay", "esl"], "{}", dx["selection_ended"]);
    assert_within("ESL [H]", selected_param(&dx, "esl"), &truth["circuit"]["esl_c"], 0.05);
    assert_final_cl_holds_truth(&dx, &truth, 1.2);
}

/// A 24 V lab buck whose inductor is 7.5 % high, 20.7 µF of load, read 55 ns late (third
/// generator, seed 10602). The late reading came first, its il probe's gain and zero standing in
/// for what L does to the current, and its path stopped 5.1 floors above the noise with Cl 44.7
/// [44.2, 45.1] µF. The circuit's findings are the alternatives of a late first step too: L's
/// drift, refitted in the simulator's form, leaves vout at its floor and il at its own, and is
/// named with its value; Cl's interval holds the truth, its estimate within 1 %. (Since the
/// stuck path's joint refit also starts from the drifts' tolerance ends, its pruning records a
/// twin with C 9 % low and Cl 48 µF, as good held out: the interval reaches up to it.)
#[test]
fn a_drift_that_explains_both_outputs_replaces_a_late_reading_that_stood_in_for_it() {
    let (dx, truth) = diagnose_third("lab-single-10602");
    assert_eq!(selected_names(&dx), ["param_drift"], "{}", dx["selection_ended"]);
    assert_within("L [H]", selected_param(&dx, "L"), &truth["circuit"]["L"], 0.003);
    let cl = &dx["selected"][0]["cl"];
    assert_cl_holds_truth(cl, &truth);
    assert_within("Cl [F]", &cl["estimate"], &truth["cl_true"], 0.01);
}

/// A 5 V point-of-load diode buck at 0.3 A, so light that its Schottky blocks in every period,
/// with L 15 % high, read 86 ns late, and a 27 Ω / 7.3 nF RC snubber across the diode (third
/// generator, seed 10402). Once the diode blocks, the inductor rings with the snubber and draws
/// its charge from the output each period; without that ring the path stopped at the
/// diode and L's drift 11.6 noise floors above the noise, Cl "not identified" (49 µF for 17.1).
/// The ring is named with the snubber's capacitance (7.05 nF) and a resistance within a factor
/// of two of its own (17.6 Ω: the node's own 1.6 nF rings beside it), L with its drift, and Cl's
/// interval holds the truth.
#[test]
fn a_diode_bucks_snubber_rings_and_lets_cl_be_identified() {
    let (dx, truth) = diagnose_third("pol-several-10402");
    let names = selected_names(&dx);
    assert!(names.starts_with(&["diode_drop", "param_drift", "switch_node_ring"]), "{names:?}: {}", dx["selection_ended"]);
    let snubber = &truth["circuit"]["snubber"];
    assert_within("snubber's C [F]", selected_param(&dx, "switch_node_capacitance"), &snubber["c"], 0.1);
    let damping = selected_param(&dx, "switch_node_damping").as_f64().unwrap() / snubber["r"].as_f64().unwrap();
    assert!((0.5..2.0).contains(&damping), "snubber's R off by ×{damping}");
    assert_within("L [H]", selected_param(&dx, "L"), &truth["circuit"]["L"], 0.05);
    assert_final_cl_holds_truth(&dx, &truth, 10.0);
    // Every period ends with the diode blocked: counted with the node held, since a ringing
    // node's current at a period start has either sign (counted on the ring, 49 %).
    assert!(dx["dcm_share"].as_f64().unwrap() > 0.99, "{}", dx["dcm_share"]);
}

/// An independent-harness diode buck at 0.66 A, in DCM in every period, 0.82 nF on its node
/// beside the Schottky's 0.2 nF, its ADC 203 ns late (blind bench, seed 4343, dataset 3). The
/// diode alone leaves 12 noise floors: once it blocks, the node rings with L. The ring fitted
/// with a damping resistance (3.2 Ω) left 1.4 floors with Cl 17.8 [15.2, 24.0] µF for 11.4: the
/// damping stood in for the late reading, which, fitted on top, left it unidentified and was
/// refused. Beside the late reading the ring is undamped: the node's capacitance between its
/// own and the junction's added, the instant at the harness's, the floor reached, and Cl's
/// interval holds the truth.
#[test]
fn a_late_reading_that_unpins_a_rings_damping_is_taken_with_the_ring_undamped() {
    let (dx, truth, stdout) = diagnose_generated_text(generated_fixture("harness", "diode-ring-4343-3"));
    assert_eq!(selected_names(&dx), ["diode_drop", "switch_node_ring", "sample_delay"], "{}", dx["selection_ended"]);
    assert!(stdout.contains("its switch node ringing with L)"), "{stdout}");
    let ring = &dx["selected"][1]["params"];
    assert!(ring.get("switch_node_damping").is_none(), "{ring}");
    assert_node_of_harness_diode(ring["switch_node_capacitance"].as_f64().unwrap(), &truth);
    assert_within("the reading's instant [s]", selected_param(&dx, "sample_delay"), &truth["settings"]["adc_delay"], 0.05);
    assert_final_within_floors(&dx, 1.1);
    assert_final_cl_holds_truth(&dx, &truth, 1.5);
}

/// An independent-harness diode buck at 1.37 A (a silicon diode, 0.25 nF of junction beside
/// 0.91 nF on the node), 1.22 µF of load, its ADC 288 ns late, blocked in 55 % of its periods
/// (blind bench, seed 4545, dataset 3). Its node rings with L once the diode blocks, damped by
/// the loop's ohm or so. Started only snubbed (about critically damped), the ring's fit ran to
/// 12.5 nF behind 13 Ω, the late reading it displaced, and the path ended at 3.7 floors with Cl
/// at its 1 nF bound; from the bare node's lightly damped starts, fitted apart, it finds the
/// node's capacitance, the floor comes near, and Cl's interval holds the truth.
#[test]
fn a_bare_nodes_ring_is_fitted_from_light_damping_apart_from_a_snubbers() {
    let (dx, truth) = diagnose_generated(generated_fixture("harness", "diode-bare-ring-4545-3"));
    let names = selected_names(&dx);
    assert!(names.contains(&"diode_drop") && names.contains(&"switch_node_ring"), "{names:?}");
    let ring = &dx["selected"].as_array().unwrap().iter().find(|e| e["name"] == "switch_node_ring").unwrap()["params"];
    let csw = ring["switch_node_capacitance"].as_f64().unwrap();
    assert_node_of_harness_diode(csw, &truth);
    // Lightly damped: the loop's ohm or so against the ring's √(L/C) of about 57 Ω.
    let damping = ring["switch_node_damping"].as_f64().unwrap();
    assert!(damping < 0.05 * (3.3e-6 / csw).sqrt(), "{damping} Ω");
    assert_final_within_floors(&dx, 1.25);
    assert_final_cl_holds_truth(&dx, &truth, 10.0);
}

/// An independent-harness diode buck at 0.95 A (a silicon diode with 40 mΩ of its own, the high
/// side's 6.6 mΩ), blocked in most periods, 2.06 µF of load, its ADC 103 ns late (blind bench,
/// seed 4444, dataset 10). On top of the diode, the late reading and the node's ring, the
/// screen ranked the series and the switches' resistance first; each closed too little, and the
/// path ended 1.3 floors up with Cl 2.42 [2.29, 2.59] µF. A second round fits the next most
/// promising while nothing is material: the diode's slope resistance closes the material share,
/// and Cl's interval holds the truth.
#[test]
fn a_step_with_nothing_material_fits_the_next_most_promising() {
    let (dx, truth) = diagnose_generated(generated_fixture("harness", "diode-slope-4444-10"));
    let names = selected_names(&dx);
    assert!(["diode_drop", "switch_node_ring", "diode_resistance"].iter().all(|n| names.contains(n)), "{names:?}");
    let slope = selected_param(&dx, "diode_resistance").as_f64().unwrap();
    assert!((0.02..0.12).contains(&slope), "{slope} Ω");
    assert_final_within_floors(&dx, 1.25);
    assert_final_cl_holds_truth(&dx, &truth, 1.5);
}

/// An independent-harness diode buck at 2.07 A (a silicon diode with 0.31 nF of junction,
/// 0.42 nF on the node), blocked in about half its periods, 80.7 µF of load, its ADC 69 ns late
/// (blind bench, seed 4040, dataset 27). Probed only as a snubber (200 pF behind `√(L/C)`), the
/// node's ring promised too little to be fitted, and the path ended 6.9 floors up with Cl "not
/// identified"; probed also as a bare node (lightly damped), it is fitted, the floor comes near,
/// and Cl's interval holds the truth within 1 %.
#[test]
fn a_bare_nodes_ring_is_screened_by_a_lightly_damped_probe() {
    let (dx, truth) = diagnose_generated(generated_fixture("harness", "diode-node-probe-4040-27"));
    assert_node_of_harness_diode(selected_param(&dx, "switch_node_capacitance").as_f64().unwrap(), &truth);
    assert_final_within_floors(&dx, 1.6);
    assert_final_cl_holds_truth(&dx, &truth, 1.05);
}

/// An independent-harness synchronous buck with L 16 % low (2.77 µH), switches of 21 and 33 mΩ,
/// 7.35 µF of load at 4.5 A, its ADC 250 ns late (blind bench, seed 4646, dataset 36). Its
/// path took an inductor's saturation first, then Rc, the switches and C, and went on past a
/// sequence's four effects to the late reading, a 1.8 ns dead time and a filter, 1.15 floors
/// up with Cl 5.7 [5.1, 6.8] µF. The converter's joint model from its nominal values, kept of
/// the kind the first four steps took (no dead time), holds the switches, L and the late
/// reading at the floor, and is taken: L as drawn, Cl's interval holding the truth.
#[test]
fn a_kind_taken_while_going_on_does_not_shape_the_joint_model_from_the_nominal() {
    let (dx, truth) = diagnose_generated(generated_fixture("harness", "drift-switches-4646-36"));
    let ended = dx["selection_ended"].as_str().unwrap();
    assert!(ended.starts_with("the converter's joint model from its nominal values"), "{ended}");
    assert!(!selected_names(&dx).contains(&"dead_time"), "{:?}", selected_names(&dx));
    assert_within("L [H]", selected_param(&dx, "L"), &truth["settings"]["L"], 0.01);
    assert_final_within_floors(&dx, 1.1);
    assert_final_cl_holds_truth(&dx, &truth, 1.1);
}

/// The thesis buck with an 88 mΩ ESR on its 3.05 µF load, read 47 ns late (third generator,
/// seed 8302): il shows the late reading, so it is taken first; the ESR alone had closed 99 % of
/// the gap, yet on top of the late reading the screen's linearization ranked it twelfth of
/// thirteen, and an ESL and a filter stood in for it, Cl "not identified". Fitted past the
/// screen, the ESR is named with its value and Cl's interval holds the truth.
#[test]
fn an_effect_that_alone_beat_the_late_reading_is_fitted_on_top_of_it() {
    let (dx, truth) = diagnose_third("thesis-single-8302");
    let selected = dx["selected"].as_array().unwrap();
    let names = selected_names(&dx);
    assert_eq!(names, ["sample_delay", "load_esr"], "{}", dx["selection_ended"]);
    assert_within("load ESR [Ω]", &selected[1]["params"]["load_esr"], &truth["circuit"]["rcl"], 0.1);
    assert_final_cl_holds_truth(&dx, &truth, 1.2);
}

/// An independent-harness buck with L 12 % low at 4.2 A of load (blind bench, seed 3030, dataset
/// 31), il ringing −5 … 11 A at the duty steps: an inductor saturation with its knee at 33 mA
/// beat the drift of L by 17 in Akaike's criterion, fitted to the slivers where il crosses
/// zero, no better held out; then a load ESR, and Cl "not identified" (0.33–7.1 µF for 3.61).
/// A knee the current lies below at 0.4 % of the samples is not placed by the data: the drift of
/// L is named with its value, then the harness's late ADC, and Cl's interval holds the truth.
#[test]
fn an_inductance_low_throughout_is_a_drift_not_a_saturation_below_every_current() {
    let (dx, truth) = diagnose_generated(generated_fixture("harness", "param-drift-3030-31"));
    let selected = dx["selected"].as_array().unwrap();
    let names = selected_names(&dx);
    assert_eq!(names, ["param_drift", "sample_delay"], "{}", dx["selection_ended"]);
    assert_within("L [H]", &selected[0]["params"]["L"], &truth["settings"]["L"], 0.01);
    let saturation = dx["effects"].as_array().unwrap().iter().find(|e| e["name"] == "inductor_saturation").expect("the saturation candidate");
    assert_eq!(saturation["identifiable"], false, "{saturation}");
    assert_final_cl_holds_truth(&dx, &truth, 1.2);
}

/// A point-of-load buck with dead time, the switches' resistance, C +13 % and an ESL, 2.03 µF of
/// load beside 66 µF, read late (third generator, seed 10102). Its path ended at the floor
/// with Rc +24 % and a 0.2 % gain error of the reading where C had drifted, C's drift pruned
/// from the joint refit beside Cl: Cl 11.0 [10.7, 11.2] µF, five times the truth and confident.
/// The converter's joint model from its nominal values, which the path's miss asks for, is as
/// good held out (1.532 mV against 1.534) with C +12 %, and puts Cl at 2.4 µF: the data does
/// not tell the two apart, and Cl's interval spans both, holding the truth. The model the
/// joint refit pruned to the path's (10.9 µF) is a twin too: both are named, each inside the
/// interval (the JSON's `cl.twins`, once a single `cl.twin` that the later replaced).
#[test]
fn a_joint_model_from_the_nominal_values_as_good_as_the_path_spans_cl() {
    let (dx, truth) = diagnose_third("pol-several-10102");
    let last = final_step(&dx);
    let twins = last["cl"]["twins"].as_array().expect("Cl's twins");
    let twin = twins.iter().find(|t| twin_labels(t).contains(&"param_drift (C)")).expect("a twin with C's drift");
    assert!(!twin_labels(twin).contains(&"sensor_gain"), "{twin}");
    assert!(twin["rms_after"].as_f64().unwrap() <= last["rms_after"].as_f64().unwrap(), "{twin}");
    let [lo, hi] = assert_final_cl_holds_truth(&dx, &truth, 10.0);
    assert_eq!(twins.len(), 2, "the pruning's twin and the nominal values' both named: {twins:?}");
    for t in twins {
        let cl = t["cl"].as_f64().unwrap();
        assert!(lo <= cl && cl <= hi, "twin's Cl {cl:e} outside [{lo:e}, {hi:e}]: {t}");
    }
}

/// An independent-harness buck with a 2.3 nH ESL behind its main capacitor, 2.12 µF of load,
/// read 55 ns late (blind bench, seed 3737, dataset 18). On top of the late reading both a
/// 0.09 % gain error of the vout reading and the ESL closed all the gap left, and the gain, by
/// Akaike's criterion, was named: Cl 2.21 [2.18, 2.27] µF, confidently wrong. A reading's
/// calibration is the explanation of last resort, also where a circuit effect explains all that
/// is left: the ESL is named, at its drawn value, and Cl's interval holds the truth.
#[test]
fn a_circuit_effect_that_explains_all_is_named_before_a_readings_gain() {
    let (dx, truth) = diagnose_generated(generated_fixture("harness", "esl-3737-18"));
    let selected = dx["selected"].as_array().unwrap();
    assert_eq!(selected_names(&dx), ["sample_delay", "esl"], "{}", dx["selection_ended"]);
    assert_within("ESL [H]", &selected[1]["params"]["esl"], &truth["settings"]["esl"], 0.1);
    assert_final_cl_holds_truth(&dx, &truth, 1.1);
}

/// An independent-harness buck with L 8.8 % low at 2.0 A of load (blind bench, seed 3636, dataset
/// 31): an inductor saturation, its knee at 246 mA and placed by the data, beat the drift of L
/// by 44 in Akaike's criterion and predicted the held-out data no better (6.14 mV against 6.08);
/// its path stopped 2.4 floors above the noise, Cl 6.2 [3.5, 20] µF for 8.83. The saturation
/// holds the drift as a special case, and of two such the richer is taken only where it predicts
/// better: the drift of L, then the late ADC, at the floor, Cl inside its interval.
#[test]
fn a_saturation_that_predicts_no_better_than_the_drift_of_l_is_the_drift() {
    let (dx, truth) = diagnose_generated(generated_fixture("harness", "param-drift-3636-31"));
    let effects = dx["effects"].as_array().unwrap();
    let held_out = |name: &str| effects.iter().find(|e| e["name"] == name).map(|e| (e["finding"].as_bool().unwrap(), e["rms_after"].as_f64().unwrap())).unwrap();
    let ((sat_finding, sat_rms), (drift_finding, drift_rms)) = (held_out("inductor_saturation"), held_out("param_drift"));
    assert!(sat_finding && drift_finding && drift_rms <= sat_rms, "saturation {sat_rms}, drift {drift_rms}");
    let selected = dx["selected"].as_array().unwrap();
    assert_eq!(selected_names(&dx), ["param_drift", "sample_delay"], "{}", dx["selection_ended"]);
    assert_within("L [H]", &selected[0]["params"]["L"], &truth["settings"]["L"], 0.01);
    assert_within("ADC delay [s]", &selected[1]["params"]["sample_delay"], &truth["settings"]["adc_delay"], 0.05);
    assert_final_cl_holds_truth(&dx, &truth, 1.05);
}

/// An independent-harness synchronous buck with L 22 % high and unequal switches (19.8 and
/// 29.4 mΩ), read 166 ns late (blind bench, seed 3030, dataset 24). The first step's best, a load
/// ESR, led to a path that stopped 2.6 floors above the noise, its model's inductor current
/// matching the measured one only through a probe gain of ×0.79 (a model whose impedance is not
/// the converter's), Cl "not identified" for 91.3 µF. Such a path gives way to the next first
/// step's: from the switches' resistance the drift of L, the low side's ratio and the late
/// reading follow, at the floor, Cl inside its interval.
#[test]
fn a_path_whose_current_contradicts_the_measured_one_gives_way() {
    let (dx, truth) = diagnose_generated(generated_fixture("harness", "drift-switches-3030-24"));
    let selected = dx["selected"].as_array().unwrap();
    let names = selected_names(&dx);
    assert_eq!(names.first(), Some(&"switch_resistance"), "{}", dx["selection_ended"]);
    assert!(names.contains(&"param_drift") && names.contains(&"unequal_switches"), "{names:?}");
    let ended = dx["selection_ended"].as_str().unwrap();
    assert!(ended.contains("inductor current matching the measured one only through a probe gain"), "{ended}");
    let drift = selected.iter().find(|e| e["name"] == "param_drift").unwrap();
    assert_within("L [H]", &drift["params"]["L"], &truth["settings"]["L"], 0.01);
    assert_within("high side [Ω]", &selected[0]["params"]["switch_resistance"], &truth["settings"]["ron_hs"], 0.1);
    assert_final_cl_holds_truth(&dx, &truth, 1.1);
}

/// Independent-harness synchronous bucks whose greedy paths took stand-ins and stayed in their
/// valley, their joint refits too (blind bench, seed 3434). Dataset 36 (L +11 %, a 35 mΩ high
/// side over a 14 mΩ low side, read 142 ns late, 9.37 µF) ended 1.5 floors above the noise with
/// a 1 Ω load ESR, a filter and a gain error beside the switches and L +8 %, Cl not identified.
/// Dataset 24 (L +23 %, 25 mΩ switches, read 148 ns late, 0.59 µF) ended at the floor with C
/// +11 %, an offset, a 96 nH ESL and a load ESR, its model's inductor current matching the
/// measured one only through a probe gain of ×0.82, Cl not identified. The converter's joint
/// model from its nominal values, fitted from Cl's grid and pruned, is L, the switches and the
/// instant as drawn, with Cl inside its interval; on dataset 24 the path at the floor whose
/// current contradicts the measured one is no twin of it.
#[test]
fn the_converters_joint_model_from_its_nominal_values_replaces_a_path_of_stand_ins() {
    for (name, ron_ls) in [("drift-switches-3434-36", true), ("drift-switches-3434-24", false)] {
        assert_joint_model_from_nominal_values_as_drawn(name, ron_ls);
    }
}

/// Diagnoses the harness fixture `name` and asserts that the converter's joint model from its
/// nominal values was taken, with L, the switches (the low side's own where `ron_ls`) and the
/// instant as drawn, and Cl inside its interval.
fn assert_joint_model_from_nominal_values_as_drawn(name: &str, ron_ls: bool) {
    let (dx, truth) = diagnose_generated(generated_fixture("harness", name));
    let ended = dx["selection_ended"].as_str().unwrap();
    assert!(ended.starts_with("the converter's joint model from its nominal values"), "{name}: {ended}");
    assert_switches_and_instant_as_drawn(name, &dx, &truth, ron_ls);
}

/// Asserts that the diagnosis `dx` of the harness fixture `name` holds L, the switches (the low
/// side's own where `ron_ls`) and the instant as drawn, and Cl inside its interval.
fn assert_switches_and_instant_as_drawn(name: &str, dx: &serde_json::Value, truth: &serde_json::Value, ron_ls: bool) {
    let names = selected_names(dx);
    assert!(names.iter().all(|n| ["param_drift", "switch_resistance", "unequal_switches", "sample_delay"].contains(n)), "{name}: {names:?}");
    let param = |key: &str| selected_param(dx, key);
    assert_within("L [H]", param("L"), &truth["settings"]["L"], 0.01);
    assert_within("high side [Ω]", param("switch_resistance"), &truth["settings"]["ron_hs"], 0.02);
    if ron_ls {
        let low = param("low_side_ratio").as_f64().unwrap() * param("switch_resistance").as_f64().unwrap();
        assert_within("low side [Ω]", &serde_json::json!(low), &truth["settings"]["ron_ls"], 0.05);
    }
    assert_within("ADC delay [s]", param("sample_delay"), &truth["settings"]["adc_delay"], 0.05);
    assert_final_cl_holds_truth(dx, truth, 1.6);
}

/// An independent-harness buck (blind bench, seed 3939, dataset 12: C 14.7 % low, switches of
/// 14.7 and 13.9 mΩ, read 144 ns late, 25.2 µF of load at 3.6 A). A 10 mΩ load ESR stood in for
/// the late reading: with C's drift and the switches it left vout at the floor, Cl 24.30 [24.06,
/// 24.54] µF for 25.19, while il still missed by 0.29 A. The late reading il shows displaced the
/// ESR, and the swap, judged on vout, closed no material share of a gap already within the
/// floor. Judged by il, as a late step is, it replaces the stand-in.
#[test]
fn a_late_reading_il_shows_replaces_a_stand_in_that_left_vout_at_the_floor() {
    let (dx, truth) = diagnose_generated(generated_fixture("harness", "drift-switches-3939-12"));
    let mut names = selected_names(&dx);
    names.sort_unstable();
    assert_eq!(names, ["param_drift", "sample_delay", "switch_resistance"], "{}", dx["selection_ended"]);
    assert_within("C [F]", selected_param(&dx, "C"), &truth["settings"]["C"], 0.01);
    assert_within("ADC delay [s]", selected_param(&dx, "sample_delay"), &truth["settings"]["adc_delay"], 0.05);
    assert_final_cl_holds_truth(&dx, &truth, 1.1);
}

/// An independent-harness buck (blind bench, seed 3838, dataset 12: L 12.5 % low, switches of
/// 37.6 and 6.2 mΩ, read 111 ns late, 2.29 µF of load at 2.9 A). Its path took the switches'
/// resistance as one series resistance, which the low side's own could not refine, and L, and
/// stopped 3.0 floors above the noise, Cl not identified (the converter's joint model from its
/// nominal values then stood in). The series resistance splits into the switches' own and the
/// low side's ratio: the path itself ends at the floor with everything as drawn.
#[test]
fn a_series_resistance_splits_into_the_high_sides_and_the_low_sides() {
    let name = "drift-switches-3838-12";
    let (dx, truth) = diagnose_generated(generated_fixture("harness", name));
    let ended = dx["selection_ended"].as_str().unwrap();
    assert!(ended.contains("switch_resistance, taken in series with L, split between the high side and the low side: unequal_switches"), "{ended}");
    assert_switches_and_instant_as_drawn(name, &dx, &truth, true);
}

/// An independent-harness diode buck (blind bench, seed 4141, dataset 10: a 37 mΩ high side, a
/// Schottky with 11 mΩ of its own, 16.1 µF of load at 4.6 A, read 179 ns late). Its path took the
/// switches' resistance as one in series with L (32 mΩ in the on- and the off-time alike), on
/// which the diode's slope resistance could only add to the off-time's and ran to zero: Cl 15.90
/// [15.69, 16.06] µF for 16.11. Split between the switch and the diode, the high side is as
/// drawn, the diode's slope takes its 11 mΩ and its `n·Vt/I`, and Cl's interval holds the truth.
#[test]
fn a_series_resistance_splits_into_the_switchs_and_the_diodes() {
    let (dx, truth) = diagnose_generated(generated_fixture("harness", "diode-switches-4141-10"));
    let names = selected_names(&dx);
    assert!(["diode_drop", "switch_resistance", "diode_resistance"].iter().all(|n| names.contains(n)), "{names:?}");
    let ended = dx["selection_ended"].as_str().unwrap();
    assert!(ended.contains("switch_resistance, taken in series with L, split between the switch (on-time) and the diode (off-time): diode_resistance"), "{ended}");
    assert!(dx["selected"].as_array().unwrap().iter().all(|e| e["params"].get("series_resistance").is_none()), "{names:?}");
    assert_within("high side [Ω]", selected_param(&dx, "switch_resistance"), &truth["settings"]["ron_hs"], 0.1);
    let slope = selected_param(&dx, "diode_resistance").as_f64().unwrap();
    let rs = truth["settings"]["diode_rs"].as_f64().unwrap();
    assert!(slope > rs && slope < 4.0 * rs, "the diode's slope resistance {slope} for its rs {rs}");
    assert_final_cl_holds_truth(&dx, &truth, 1.1);
}

/// An independent-harness diode buck (blind bench, seed 4242, dataset 10: a 19.7 mΩ high side, a
/// Schottky with 31.7 mΩ of its own and n = 1.33, 13.8 µF of load at 1.57 A, read 225 ns late).
/// Beside the diode's drop its slope resistance (4.04 mV held out) and a resistance in series
/// with L in both phases (4.17 mV) leave the gap alike over a floor of 1.3 mV: at a duty of 0.4
/// or 0.6 and one load current, a resistance in the on-time and one in the off-time differ only
/// by how they share the period. The step takes the slope by Akaike's criterion and says that
/// the data does not tell it from the switches': every effect drawn is named or alike.
#[test]
fn a_step_says_which_findings_the_data_does_not_tell_from_it() {
    let (dx, truth, text) = diagnose_generated_text(generated_fixture("harness", "diode-switches-alike-4242-10"));
    assert!(text.contains("alike: the data does not tell it from switch_resistance (series_resistance = "), "{text}");
    let selected = dx["selected"].as_array().unwrap();
    let slope = selected.iter().find(|e| e["name"] == "diode_resistance").unwrap_or_else(|| panic!("{:?}", selected_names(&dx)));
    let alike: Vec<&str> = slope["alike"].as_array().map(|a| a.iter().map(|x| x["name"].as_str().unwrap()).collect()).unwrap_or_default();
    assert_eq!(alike, ["switch_resistance"], "{slope}");
    let series = slope["alike"][0]["params"]["series_resistance"].as_f64().unwrap();
    let (ron, rs) = (truth["settings"]["ron_hs"].as_f64().unwrap(), truth["settings"]["diode_rs"].as_f64().unwrap());
    assert!(series > ron && series < ron + rs + 0.03, "a series resistance of {series} Ω for a {ron} Ω switch and a {rs} Ω diode");
    let told: Vec<&str> = selected.iter().flat_map(|e| std::iter::once(e["name"].as_str().unwrap()).chain(e["alike"].as_array().into_iter().flatten().map(|a| a["name"].as_str().unwrap()))).collect();
    assert!(truth["effects"].as_array().unwrap().iter().all(|e| told.contains(&e.as_str().unwrap())), "{told:?}");
    // The effects that were not taken are not named.
    assert!(!selected_names(&dx).contains(&"switch_resistance"));
    assert_final_cl_holds_truth(&dx, &truth, 1.2);
}

/// ngspice's ideal switch with every pulse stretched by 30 ns (`tests/fixtures/spice/README.md`):
/// at a constant load in CCM a stretched pulse lifts vout by `vin·δ/T` = 119 mV, as a zero error
/// of the reading would. Before the candidate, the diagnosis named `sensor_offset` (118.5 mV) and
/// took Cl 2.5 % high; the inductor current's ripple, which the duty sets, tells them apart by
/// a little. Named with its value, the offset said alike, Cl inside a tight interval.
#[test]
fn a_stretched_gate_pulse_is_named_not_taken_for_a_reading_offset() {
    let (dx, truth, text) = diagnose_generated_text(generated_fixture("spice", "ideal-pwd-30ns"));
    assert_eq!(selected_names(&dx), ["pulse_width_distortion"], "{text}");
    assert_within("pulse_width_distortion [s]", selected_param(&dx, "pulse_width_distortion"), &truth["effects"]["pulse_width_distortion"]["seconds"], 0.03);
    assert!(text.contains("alike: the data does not tell it from sensor_offset (vout_offset = "), "{text}");
    let cl_true = serde_json::json!({ "cl_true": truth["params"]["Cl"] });
    assert_final_cl_holds_truth(&dx, &cl_true, 1.05);
}

/// An independent-harness buck (blind bench, seed 3636, dataset 12: C 14.6 % high, switches of
/// 6.1 and 23.2 mΩ, read 72 ns late, 9.16 µF of load at 2.4 A). Its path took an 11.5 mΩ load
/// ESR for the late reading and reached the floor with four effects, Cl 8.55 [8.37, 9.00] µF
/// for 9.16; going on, the late reading il shows replaced the ESR, and the sequence, as long as
/// before, was not counted as gone on. A swap makes another model too: taken.
#[test]
fn going_on_that_swaps_a_stand_in_out_is_taken() {
    let (dx, truth) = diagnose_generated(generated_fixture("harness", "drift-switches-3636-12"));
    let ended = dx["selection_ended"].as_str().unwrap();
    assert!(ended.contains("it went on: sample_delay replaced load_esr"), "{ended}");
    let mut names = selected_names(&dx);
    names.sort_unstable();
    assert_eq!(names, ["param_drift", "sample_delay", "switch_resistance", "unequal_switches"], "{ended}");
    assert_within("C [F]", selected_param(&dx, "C"), &truth["settings"]["C"], 0.01);
    assert_within("high side [Ω]", selected_param(&dx, "switch_resistance"), &truth["settings"]["ron_hs"], 0.05);
    assert_within("ADC delay [s]", selected_param(&dx, "sample_delay"), &truth["settings"]["adc_delay"], 0.1);
    assert_final_cl_holds_truth(&dx, &truth, 1.1);
}

/// Two independent-harness bucks whose final models reach the noise floor with an effect whose
/// form only approximates the device (blind bench, seed 3636): dataset 8, an inductor with a
/// soft saturation knee (20 % of L lost over 5 % of its 4.05 A) fitted with a hard knee, 3.15 µF
/// of load, Cl leaning −16.7 on L; dataset 23, a synchronous buck with 19 ns of dead time,
/// 159 pF on its node and body diodes, 1.58 µF of load behind a 32 mΩ ESR, leaning −18 on C.
/// Their intervals, held to ±1 %, missed the truth by 3.1 % and 4.3 %: the approximation went
/// into L and C, by 0.19 % and 0.24 %. Held to 0.3 % of L and C through that leverage
/// ([`gap::CIRCUIT_FIDELITY_WITH_DEVICES`]), they hold it, and say why.
#[test]
fn a_model_that_approximates_a_device_holds_cl_to_its_fidelity_of_l_and_c() {
    for (name, device) in [("inductor-saturation-3636-08", "inductor_saturation"), ("dead-time-load-esr-3636-23", "dead_time")] {
        let (data, truth) = generated_fixture("harness", name);
        let (dx, truth) = diagnose_generated((data.clone(), truth));
        let names = selected_names(&dx);
        assert_eq!(names.first(), Some(&device), "{name}: {names:?}");
        assert_eq!(dx["cl_circuit_fidelity"].as_f64().unwrap(), gap::CIRCUIT_FIDELITY_WITH_DEVICES, "{name}");
        let lean = ["L", "C"].map(|x| dx["cl_leverage"][x].as_f64().unwrap().abs()).into_iter().fold(0.0, f64::max);
        let fidelity = dx["cl_fidelity"].as_f64().unwrap();
        assert!(lean > 10.0 && (fidelity / (gap::CIRCUIT_FIDELITY_WITH_DEVICES * lean).exp_m1() - 1.0).abs() < 1e-9, "{name}: fidelity {fidelity} for a leverage of {lean}");
        assert_final_cl_holds_truth(&dx, &truth, 1.15);
        let o = buckid(&["diagnose", "--data", data.to_str().unwrap(), "--nominal", "switched"]);
        let stdout = String::from_utf8_lossy(&o.stdout);
        assert!(stdout.contains("(0.30 % of L and C, through Cl's leverage on them)"), "{name}: {stdout}");
    }
}

/// An independent-harness synchronous buck with 40 ns of dead time, 535 pF on its node and
/// switches of 0.03 mΩ, 0.61 µF of load behind a 44 mΩ ESR, read 238 ns late (blind bench, seed
/// 3131, dataset 11). After the dead time, the late reading and the node's capacitance, a
/// switch resistance of 0.64 mΩ closed most of the 1.2 floors left, and was named: 0.6 % of
/// the 100 mΩ in series with L, an RL within its 1 % tolerance. It is said so, not named, and
/// Cl's interval, widened for what the model still misses, holds the truth.
#[test]
fn a_resistance_within_the_tolerance_of_rl_is_no_finding() {
    let (dx, truth) = diagnose_generated(generated_fixture("harness", "dead-time-load-esr-3131-11"));
    let names = selected_names(&dx);
    assert_eq!(names.first(), Some(&"dead_time"), "{names:?}");
    assert!(names.contains(&"switch_node_capacitance") && !names.contains(&"switch_resistance"), "{names:?}");
    let ended = dx["selection_ended"].as_str().unwrap();
    assert!(ended.contains("drift within tolerance (switch_resistance") && ended.contains("% of RL)"), "{ended}");
    let dead_time = &dx["selected"][0]["params"]["dead_time"];
    assert_within("dead time [s]", dead_time, &truth["settings"]["dead_time"], 0.05);
    assert_final_cl_holds_truth(&dx, &truth, 1.6);
}

/// An independent-harness synchronous buck with L 19 % high and switches of 8.5 and 12.4 mΩ,
/// 0.70 µF of load, read 42 ns late (blind bench, seed 3232, dataset 12). The drift and the
/// switches leave the held-out vout at the floor read at the period start, with Cl
/// 0.542 [0.435, 0.555] µF: the late reading is not material there. Refitted with the reading's
/// instant free, the data makes 46 ns significant and puts Cl at 0.78 µF (`Cl·Rc` is 70 ns: the
/// reading samples the load's own transient after each edge), so the interval spans both.
#[test]
fn a_significant_reading_instant_that_moves_cl_widens_its_interval() {
    let (dx, truth) = diagnose_generated(generated_fixture("harness", "drift-switches-3232-12"));
    assert_eq!(selected_names(&dx), ["param_drift", "switch_resistance"], "{}", dx["selection_ended"]);
    let last = final_step(&dx);
    let late = &last["cl"]["read_late"];
    assert_eq!(late["instant"], "sample_delay", "{late}");
    assert_within("the reading's instant [s]", &late["value"], &truth["settings"]["adc_delay"], 0.2);
    assert!(late["lr"][0].as_f64().unwrap() > late["lr"][1].as_f64().unwrap(), "{late}");
    assert_final_cl_holds_truth(&dx, &truth, 2.0);
}

/// An independent-harness synchronous buck with 58 ns of dead time, its ADC 263 ns late and
/// 1.2 µF of load behind a 36 mΩ ESR at 2.4 A (blind bench, seed 3232, dataset 35). After the
/// dead time, the late reading and the node's capacitance, the step's screen passed only C
/// +0.73 %, within tolerance, 1.5 floors above the noise: the load ESR, nearly along Cl (its
/// corner near 4 MHz), promised nothing there, and Cl was not identified (0.95 [0.31, 8.9] µF).
/// The extensions the screen passed over are fitted then; and the joint refit, which had
/// pruned the ESR first as lost beside L, C and Rc all free, returns the tolerated drifts to
/// nominal before it prunes an effect the selection found.
#[test]
fn a_load_esr_along_cl_is_fitted_where_the_screen_finds_only_a_drift_within_tolerance() {
    let (dx, truth) = diagnose_generated(generated_fixture("harness", "dead-time-load-esr-3232-35"));
    let names = selected_names(&dx);
    assert_eq!(names.first(), Some(&"dead_time"), "{names:?}");
    let esr = dx["selected"].as_array().unwrap().iter().find(|e| e["name"] == "load_esr").unwrap_or_else(|| panic!("no load ESR in {names:?}: {}", dx["selection_ended"]));
    assert_within("load ESR [Ω]", &esr["params"]["load_esr"], &truth["settings"]["load_esr"], 0.2);
    assert_final_cl_holds_truth(&dx, &truth, 3.0);
}

/// A third-generator 24 V, 95 kHz lab buck whose 280 µF electrolytic is 15.7 % high (324 µF
/// behind its 37 mΩ ESR), 5.65 µF of load (seed 9301). The grey-box drift of C, fitted from its
/// grid alone, ran to 350 µF with Cl at its 1 nF bound, worse held out than the nominal, and Cl
/// took up the drift behind a 338 mΩ load ESR: 49.6 [49.1, 50.1] µF, confidently 9× the
/// truth. Fitted from the nominal's fit too, the drift is found and is the verdict; the load
/// ESR's model, as good held out, is a twin whose Cl the interval spans.
#[test]
fn a_capacitor_drift_cl_could_take_up_is_fitted_from_the_nominal_fit_too() {
    let (dx, truth) = diagnose_third("lab-single-9301");
    assert_eq!(dx["verdict"], "param_drift", "{}", dx["selection_ended"]);
    assert_within("C [F]", &dx["selected"][0]["params"]["C"], &truth["circuit"]["C"], 0.01);
    let last = final_step(&dx);
    assert_within("Cl [F]", &last["cl"]["estimate"], &truth["cl_true"], 0.02);
    assert_final_cl_holds_truth(&dx, &truth, 10.0);
}

/// Diode bucks in DCM whose inductor is off its nominal (third generator): in DCM the output's
/// level is set by L, so neither the DCM model at nominal L nor L's drift on the synchronous
/// model closes a material share of the gap, and the selection had said `none`. Fitted
/// together as a pair, they are the first two steps. Seed 9701 (L −19 %, 60 % of its periods in
/// DCM, its Schottky's 0.35 V taken up by L): Cl 38.9 µF inside its interval, where every
/// candidate had ended with Cl on its 1 F bound. Seed 4302 (L +11 %, every period in DCM):
/// its diode candidate ran to the 5 V bound; now L's drift is named, and Cl, which a model in
/// DCM all the time that still misses cannot pin down, is said not identified.
#[test]
fn effects_that_only_together_explain_a_diode_buck_in_dcm_are_fitted_as_a_pair() {
    let (dx, truth) = diagnose_third("thesis-several-9701");
    let ended = dx["selection_ended"].as_str().unwrap();
    assert_eq!(selected_names(&dx)[..2], ["dcm", "param_drift"], "{ended}");
    assert!(ended.starts_with("no single effect is a finding; dcm with a drift of L"), "{ended}");
    assert_within("L [H]", &dx["selected"][1]["params"]["L"], &truth["circuit"]["L"], 0.08);
    assert_final_cl_holds_truth(&dx, &truth, 10.0);

    let (dx, truth) = diagnose_third("thesis-several-4302");
    assert_eq!(selected_names(&dx)[..2], ["dcm", "param_drift"], "{}", dx["selection_ended"]);
    assert_within("L [H]", &dx["selected"][1]["params"]["L"], &truth["circuit"]["L"], 0.06);
    let last = final_step(&dx);
    assert!(last["cl"]["ci95"][1].is_null() && last["cl"]["deep_dcm_miss"]["dcm_share"].as_f64() > Some(0.9), "{}", last["cl"]);
}

/// Clean captures ten times quieter than the bench's (σ ≈ 0.2 mV). On the point-of-load buck
/// the parasitics every converter carries leave a gap of 0.02 % of the output's swing, far
/// above this floor, and were named as a 2.2 µΩ switch resistance "closing 92 %" of it. On the
/// 60 V lab buck they leave 0.34 % of the swing, 13 floors, and its Cl (0.3 % off) was "not
/// identified" as a gross miss. Neither is an effect to name: the verdict is `none`, with Cl
/// identified inside its interval, and the selection says why: the first gap is immaterial
/// against the swing, the second is material but nothing explains it (flagged `unexplained`:
/// the parasitics are a mechanism no candidate is).
#[test]
fn a_quiet_clean_capture_is_clean() {
    for (name, why) in [("pol-quiet-1701", "immaterial (below 0.05 %)"), ("lab-quiet-1302", "yet no candidate closes 25 %")] {
        let (dx, truth) = diagnose_third(name);
        assert_eq!(truth["effects"], serde_json::json!([]));
        let floor = dx["where"]["noise_floor_rms"].as_f64().unwrap();
        assert!(dx["gap_before"]["rms"].as_f64().unwrap() > 1.2 * floor, "{name}: the nominal misses above this floor: {}", dx["gap_before"]);
        assert_eq!(dx["verdict"], "none", "{name}: {}", dx["selection_ended"]);
        assert!(dx["selection_ended"].as_str().unwrap().contains(why), "{name}: {}", dx["selection_ended"]);
        // Material but no candidate's: the parasitics, a mechanism none of them is.
        assert_eq!(dx.get("unexplained").is_some(), name == "lab-quiet-1302", "{name}");
        let [lo, hi] = [0, 1].map(|i| dx["gap_before"]["cl_ci95"][i].as_f64().unwrap_or(f64::INFINITY));
        let cl_true = truth["cl_true"].as_f64().unwrap();
        assert!(lo <= cl_true && cl_true <= hi && hi < 1.1 * lo, "{name}: Cl {cl_true:e} against [{lo:e}, {hi:e}]");
    }
}

/// A thesis-stage diode buck with an RC snubber across its diode, L 15.5 % high, in DCM (third
/// generator, seed 10602): the nominal misses by 90 noise floors, and no candidate explains it
/// (the snubber's ring is offered on top of a diode, and no diode alone fits: a drop of 4.8 V).
/// The verdict stays `none` in the JSON's contract, flagged `unexplained`, and the summary says
/// it is no candidate's, not clean data's, with Cl not identified and no leverage said; a clean
/// capture says `none` alone.
#[test]
fn an_unexplained_gap_is_not_said_as_clean_datas_none() {
    let (dx, _, stdout) = diagnose_generated_text(third_fixture("thesis-several-10602"));
    assert_eq!(dx["verdict"], "none", "{}", dx["selection_ended"]);
    assert_eq!(dx["unexplained"], true);
    assert!(stdout.contains("verdict     none of the candidates: the nominal misses materially"), "{stdout}");
    // Its Cl is not identified: no interval holds the values it leans on, so no leverage is said.
    assert!(stdout.contains("(not identified)") && !stdout.contains("leverage"), "{stdout}");
    let (clean, _) = diagnose_third("pol-clean-7902");
    assert_eq!(clean["verdict"], "none");
    assert!(clean.get("unexplained").is_none(), "{clean}");
}

/// `identify` on the same clean capture: its fit ranked Cl's grid on the first samples, started
/// from the best point alone and ended at 163.0 [158.7, 167.4] µF for 73.0 (held-out fit −22 %).
/// A fit that misses worse than the data's mean is refitted from every point of the grid.
#[test]
fn identify_refits_from_the_whole_grid_a_fit_worse_than_the_mean() {
    let (id, truth, _) = identify_third("pol-clean-1901");
    let (cl, cl_true) = (id["cl"]["estimate"].as_f64().unwrap(), truth["cl_true"].as_f64().unwrap());
    assert!((cl / cl_true - 1.0).abs() < 1e-3, "Cl {cl:e} for {cl_true:e}");
    assert!(id["fit_percent"]["simulation"].as_f64().unwrap() > 99.0, "{}", id["fit_percent"]);
}

/// `identify` on a circuit's data tests Cl's interval as `diagnose` does. On the clean capture the
/// fit's own interval, [72.9949, 72.9955] µF, missed the generator's 72.9946 (its parasitics move
/// Cl by more than a white residual can show); tested, it is held to the circuit model's
/// fidelity and holds it. On the capture with a ceramic's bias law, which the nominal lacks, the
/// fit's 22.99 [22.93, 23.05] µF missed the operating point's 22.55 by 2 %; tested, the model
/// misses by tens of noise floors and Cl is "not identified".
#[test]
fn identify_tests_the_interval_on_a_circuits_data() {
    let run = |name: &str| {
        let (id, truth, stdout) = identify_third(name);
        (id, truth["cl_true"].as_f64().unwrap(), stdout)
    };
    let (id, cl_true, _) = run("pol-clean-1901");
    let [lo, hi] = [0, 1].map(|i| id["cl"]["ci95"][i].as_f64().unwrap());
    assert!(lo <= cl_true && cl_true <= hi, "Cl {cl_true:e} outside [{lo:e}, {hi:e}]");
    let [model_lo, model_hi] = [0, 1].map(|i| id["cl_test"]["model_ci95"][i].as_f64().unwrap());
    assert!(model_hi - model_lo < hi - lo, "{}", id["cl_test"]);
    assert_eq!(id["cl_test"]["at_fidelity"], true, "{}", id["cl_test"]);
    let (id, _, stdout) = run("pol-single-2301");
    assert!(id["cl_test"]["misses_by_floors"].as_f64().is_some_and(|k| k > 5.0), "{}", id["cl_test"]);
    assert!(id["cl"]["ci95"][1].is_null() || !id["cl"]["ci95"][1].as_f64().unwrap().is_finite(), "{}", id["cl"]);
    assert!(stdout.contains("not identified"), "{stdout}");
}

/// A lab buck with five effects whose selection ended with L −39 % and Cl 16 times too large,
/// the LC resonance kept (`gap::current`): 234 [229, 241] µF for 14.4 µF. Its model's inductor
/// current matches the measured one only through a probe gain of ×0.60, so its impedance, and
/// its Cl, is not the converter's: Cl is not identified, and the JSON says why.
#[test]
fn a_model_with_the_wrong_impedance_is_not_identified() {
    let (dx, _) = diagnose_third("lab-several-4101");
    let cl = &final_step(&dx)["cl"];
    let upper = cl["ci95"][1].as_f64();
    assert!(upper.is_none_or(|u| !u.is_finite()), "{cl}");
    let gain = cl["current_misfit"]["probe_gain"].as_f64().expect("the current's misfit");
    assert!((gain - 1.0).abs() > gap::PROBE_GAIN_TOLERANCE, "{cl}");
}

/// A ceramic that follows neither of the model's two bias laws (the third generator's
/// `Cl₀/√(1 + (v/V₀)²)`): the reciprocal law fits better by a likelihood ratio of 2748 and the
/// quadratic's Cl lies 4 % above it, yet the better law still misses vout above its noise floor,
/// so neither is the ceramic's shape. Judged on the worse law's residual, Cl was "not
/// identified" (a gross miss of 7.6 floors); with the better law's own interval it missed the
/// truth. Judged on the better law's fit, its interval spanning both laws' Cl, it holds it.
#[test]
fn a_ceramic_between_the_two_laws_gets_an_interval_spanning_both() {
    let (dx, truth) = diagnose_third("pol-single-2301");
    assert_eq!(truth["effects"], serde_json::json!(["cap_dc_bias"]));
    let last = final_step(&dx);
    assert!(dx["selected"].as_array().unwrap().iter().any(|e| e["name"] == "cap_dc_bias"), "{}", dx["selection_ended"]);
    let (cl, law) = (&last["cl"], &last["cl"]["bias_law"]);
    assert!(law["told_apart"] == true && law["fits_to_floor"] == false, "{law}");
    let [lo, hi] = assert_cl_holds_truth(cl, &truth);
    assert!(hi.is_finite(), "{cl}");
    let f = |v: &serde_json::Value| v.as_f64().unwrap();
    for law_cl in [f(&law["law_cl"]), f(&law["other_cl"])] {
        assert!(lo <= law_cl && law_cl <= hi, "[{lo:e}, {hi:e}] leaves out a law's Cl {law_cl:e}");
    }
}

/// A 0.26 µF load beside 100 µF behind a 78 ns dead time whose edges the model takes as ideal:
/// the final model fails the interval's test (its high-pass refit puts Cl at 0.53 µF against
/// 0.94 µF) and the data prefers the other bias law, whose own interval (0.943 µF ± 2 %) had
/// replaced the widened one: Cl reported 3.6 times too large, confidently. The failed test
/// widens whichever law's Cl is reported.
#[test]
fn a_failed_interval_test_widens_the_other_laws_cl_too() {
    let (dx, truth) = diagnose_third("thesis-single-7301");
    assert_eq!(truth["effects"], serde_json::json!(["dead_time"]));
    let last = final_step(&dx);
    let cl = &last["cl"];
    assert_eq!(cl["check"]["consistent"], false, "{cl}");
    let [lo, hi] = assert_cl_holds_truth(cl, &truth);
    let high_pass = cl["check"]["high_pass"].as_f64().unwrap_or(f64::INFINITY);
    assert!(lo <= high_pass && high_pass <= hi, "{cl}");
}

/// A lab buck with C 11 % and Rc 9 % off their nominal values and 1.3 µF of load beside 330 µF:
/// the joint refit puts C and Rc at their true values, with Cl not identified beside them; its
/// pruning then drops C's drift, which Cl takes up, and the model left had Cl at
/// 38.1 [36.5, 39.9] µF. The model pruned to it is as good a model, whose Cl the interval spans.
/// (That twin is the path's to find: a path that fits the switches' resistance before any drift
/// lands its joint refit at C within tolerance and Cl 37.7 [36.8, 39.2] µF, the other end of a
/// C–Cl ridge no local interval covers; the ridge's probe, `gap::ridge`, finds as good a model
/// with C +6.7 % and Cl not identified there. See the README's fiftieth and fifty-first sessions.)
#[test]
fn a_drift_pruned_into_cl_leaves_cl_not_identified() {
    let (dx, truth) = diagnose_third("lab-several-7502");
    let last = final_step(&dx);
    let cl = &last["cl"];
    let twins = cl["twins"].as_array().expect("Cl's twins");
    assert!(twins.iter().any(|t| twin_labels(t).contains(&"param_drift (C)")), "{cl}");
    assert_cl_holds_truth(cl, &truth);
}

/// Two 5 V Schottky bucks from the third generator read on vout alone, where a synchronous
/// stand-in took the first step and its path ended materially above the floor: the diode's path
/// is followed too, whatever share its first step closed (`select::RIVAL_CLOSED` binds only
/// where il was recorded), and taken.
/// - Seed 1170 (9.65 A, a snubber, L 13.5 % low, 2.77 µF of load beside 88 µF and a 118 µF
///   bulk): a dead time closed 89.5 %, the diode 88.6 %; from the dead time Cl was
///   0.020 [0.010, 2.42] µF, C's drift holding the load (the ridge's other end spanned up to
///   2.3 µF); from the diode 2.0 [1.6, 3.4] µF with L −12.8 % (true −13.5 %).
/// - Seed 1190 (9 A, C 10.5 % high, 2.0 µF of load): the switches' resistance closed 95.5 %, the
///   diode 78.7 %; the switches' path took a dead time, a low side 3.4 times the high and a 6.5 %
///   gain error for the diode, ended 2.9 floors up and said 24.6 [7.1, 31.8] µF, confidently;
///   from the diode it ends 1.7 floors up with Cl not identified (C's drift and Cl one ridge).
#[test]
fn a_diode_buck_read_on_vout_alone_is_followed_from_its_diode() {
    for board in ["pol-several-1170", "pol-several-1190"] {
        let (dx, truth) = diagnose_third(board);
        assert_eq!(dx["verdict"], "diode_drop", "{board}: {}", dx["selection_ended"]);
        let last = final_step(&dx);
        let [lo, hi] = assert_cl_holds_truth(&last["cl"], &truth);
        if board == "pol-several-1170" {
            assert!(estimator::validate::identified([lo, hi]), "{board}: Cl [{lo:e}, {hi:e}] not identified");
        }
    }
}

/// A 5 V point-of-load buck with C 17 % low, dead time, 9.5 mΩ switches and 1.64 µF of load
/// behind 0.22 Ω, at 7.2 A, vout alone recorded (third generator, seed 1201). L's drift alone
/// fitted better than C's (the same resonance), so the path took an inductor's saturation and a
/// dead time, stopped 94 floors above the noise, and its joint refit from there stayed at
/// C −5 %, 51 floors up: Cl 0.11 µF, not identified, C's drift never named. Started again from
/// the drifts' tolerance ends, the refit finds C −17 %, and the pruned model (the dead time, C,
/// the switches, the node's charge) has Cl 1.72 [0.38, 3.65] µF.
#[test]
fn a_stuck_paths_refit_starts_from_the_drifts_tolerance_ends() {
    let (dx, truth) = diagnose_third("pol-several-1201");
    let names = selected_names(&dx);
    assert!(["dead_time", "param_drift", "switch_resistance"].iter().all(|n| names.contains(n)), "{names:?}: {}", dx["selection_ended"]);
    assert_within("C [F]", selected_param(&dx, "C"), &truth["circuit"]["C"], 0.02);
    let last = final_step(&dx);
    let [_, hi] = assert_cl_holds_truth(&last["cl"], &truth);
    assert!(hi < 3.0 * truth["cl_true"].as_f64().unwrap(), "Cl up to {hi:e}: not pinned down");
}

/// The thesis stage into 5.76 Ω with a DC-biased ceramic (22.75 µF at its 5.84 V), a dead
/// time, the switches and the ADC 255 ns late (third generator, seed 1201). The path ended on
/// an inductor's saturation 1.1 floors above the noise with Cl 23.74 [23.51, 23.98] µF, 4.4 %
/// high, where the step before it (C +3.5 %), missing about twice as much, had 22.43 µF. A
/// final model that still misses lacks an effect the size of its last steps, and those moved
/// Cl that far: the interval spans the path's models near the final one, and stays narrow.
#[test]
fn a_final_model_that_still_misses_spans_its_paths_near_steps() {
    let (dx, truth) = diagnose_third("thesis-several-1201");
    let near = final_step(&dx)["cl"]["near_steps"].as_array().map_or(0, Vec::len);
    assert!(near > 0, "no near step spanned: {}", final_step(&dx)["cl"]);
    assert_final_cl_holds_truth(&dx, &truth, 1.15);
}

/// A capture too short for a model-free noise floor (200 periods: the PRBS steps too often for
/// the differences between steps): the floor is the best model's residual, so no share of a gap
/// above it exists, and the selection says so with the NRMSE's shrink instead of "no gap above
/// the floor" (which it had printed beside an 85 % shrink); the report, why it has no waterfall.
#[test]
fn a_capture_without_a_model_free_floor_reports_the_shrink() {
    let (data, _) = third_fixture("pol-single-2301");
    let text = std::fs::read_to_string(data).unwrap();
    let meta = text.lines().filter(|l| l.starts_with('#'));
    let rows = text.lines().filter(|l| !l.starts_with('#')).take(201);
    let dir = tempfile::tempdir().unwrap();
    let (short, out) = (dir.path().join("short.csv"), dir.path().join("dx.json"));
    std::fs::write(&short, meta.chain(rows).collect::<Vec<_>>().join("\n") + "\n").unwrap();
    let report = dir.path().join("report");
    let o = buckid(&["diagnose", "--data", short.to_str().unwrap(), "--nominal", "switched", "--json", out.to_str().unwrap(), "--report", report.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(json(&out)["where"]["noise_floor_from"], "model_residual");
    let html = std::fs::read_to_string(report.join("index.html")).unwrap();
    assert!(html.contains("the noise floor is a model's residual") && !html.contains("gap is within the noise floor"), "the report's waterfall note");
    let stdout = String::from_utf8_lossy(&o.stdout);
    let selected: Vec<&str> = stdout.lines().filter(|l| l.starts_with("selected")).collect();
    assert!(!selected.is_empty(), "{stdout}");
    for line in selected {
        assert!(line.contains("no model-free floor") && !line.contains("no gap in vout above the floor"), "{line}");
    }
}

/// The committed ngspice scope capture, as a Tektronix MSO exports it (its settings before a
/// header row of quoted channel names, current in mA): `convert` with the channels named
/// writes the same data file as from the capture in the contract's own names; unnamed, it
/// fails naming the missing column and the option.
#[test]
fn convert_reads_an_oscilloscopes_export_with_its_columns_named() {
    let dir = tempfile::tempdir().unwrap();
    let scope = root().join("tests/fixtures/capture/sync_scope.csv");
    let text = std::fs::read_to_string(&scope).unwrap();
    let rows = text.lines().filter(|l| !l.starts_with('#')).skip(1).map(|l| {
        let f: Vec<f64> = l.split(',').map(|x| x.parse().unwrap()).collect();
        format!("{:e},{},{},{}\n", f[0], f[1], f[2] * 1e3, f[3])
    });
    let tek = dir.path().join("tek.csv");
    let preamble = "Model,MSO54\nFirmware Version,1.28\n\nWaveform Type,ANALOG\nHorizontal Units,s\n\"TIME\",\"CH1\",\"CH2 [mA]\",\"CH3\"\n";
    std::fs::write(&tek, preamble.to_string() + &rows.collect::<String>()).unwrap();
    let (plain, named) = (dir.path().join("plain.csv"), dir.path().join("named.csv"));
    let o = buckid(&["convert", "--scope", scope.to_str().unwrap(), "--out", plain.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let columns = ["--column", "time=TIME", "--column", "vout=CH1", "--column", "il=CH2", "--column", "sw=CH3"];
    let o = buckid(&[&["convert", "--scope", tek.to_str().unwrap(), "--out", named.to_str().unwrap()][..], &columns].concat());
    assert!(o.status.success(), "{}", stderr(&o));
    // The same rows (the metadata differs: the export carries none of the capture's).
    let body = |p: &Path| std::fs::read_to_string(p).unwrap().lines().filter(|l| !l.starts_with('#')).map(str::to_string).collect::<Vec<_>>();
    let (a, b) = (body(&plain), body(&named));
    assert_eq!(a.len(), b.len());
    for (x, y) in a.iter().zip(&b).skip(1) {
        let nums = |r: &str| r.split(',').map(|v| v.parse::<f64>().unwrap()).collect::<Vec<_>>();
        assert!(nums(x).iter().zip(nums(y)).all(|(p, q)| (p - q).abs() <= 1e-9 * p.abs().max(1.0)), "{x} against {y}");
    }
    assert_clean_failure(&buckid(&["convert", "--scope", tek.to_str().unwrap(), "--out", named.to_str().unwrap()]), "--column vout=CH1");
    assert_clean_failure(&buckid(&["convert", "--scope", tek.to_str().unwrap(), "--out", named.to_str().unwrap(), "--column", "vout"]), "is not NAME=HEADER");
    assert_clean_failure(&buckid(&["convert", "--scope", tek.to_str().unwrap(), "--out", named.to_str().unwrap(), "--column", "il=CH2*ten"]), "NAME=HEADER*SCALE");
}

/// The committed ngspice scope capture saved one channel per file, as oscilloscopes also save
/// them: `vout` as a LeCroy writes a trace (its notes, then `Time,Ampl`), the switch node as a
/// Tektronix TDS does (no header row; each row its settings' label, value and unit, then the
/// sample), and `il` read in volts across a 0.1 Ω shunt. `convert --channel` writes the same
/// rows as from the whole capture, with `--meta` at the top; bad channels fail naming why.
#[test]
fn convert_reads_each_channel_from_a_file_of_its_own() {
    let dir = tempfile::tempdir().unwrap();
    let scope = root().join("tests/fixtures/capture/sync_scope.csv");
    let text = std::fs::read_to_string(&scope).unwrap();
    let samples: Vec<Vec<f64>> = text.lines().filter(|l| !l.starts_with('#')).skip(1).map(|l| l.split(',').map(|x| x.parse().unwrap()).collect()).collect();
    let lecroy = format!("LECROYWR104Xi,51234,Waveform\nSegments,1,SegmentSize,{}\nSegment,TrigTime,TimeSinceSegment1\n#1,27-Nov-2026 10:11:12,0\nTime,Ampl\n", samples.len())
        + &samples.iter().map(|f| format!("{:e},{}\n", f[0], f[1])).collect::<String>();
    let notes = ["Record Length,1.769100e+04,", "Sample Interval,1.027749e-08,", "Trigger Point,0.0e+00,", ",,", "Source,CH3,", "Vertical Units,V,", "Horizontal Units,s,"];
    let tds: String = samples.iter().enumerate().map(|(k, f)| format!("{},{:e},{},\r\n", notes.get(k).unwrap_or(&",,"), f[0], f[3])).collect();
    let shunt: String = "time,value\n".to_string() + &samples.iter().map(|f| format!("{:e},{:e}\n", f[0], f[2] / 10.0)).collect::<String>();
    let files = [("C1--trace--00000.txt", lecroy), ("F0000CH3.CSV", tds), ("shunt.csv", shunt)];
    for (name, body) in &files {
        std::fs::write(dir.path().join(name), body).unwrap();
    }
    let at = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    let (plain, split) = (dir.path().join("plain.csv"), dir.path().join("split.csv"));
    assert!(buckid(&["convert", "--scope", scope.to_str().unwrap(), "--out", plain.to_str().unwrap()]).status.success());
    let channels = [format!("vout={}", at(files[0].0)), format!("sw={}", at(files[1].0)), format!("il={}*10", at(files[2].0))];
    let args = ["convert", "--channel", &channels[0], "--channel", &channels[1], "--channel", &channels[2], "--meta", "U=12", "--out", split.to_str().unwrap()];
    let o = buckid(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    let written = std::fs::read_to_string(&split).unwrap();
    assert!(written.lines().any(|l| l == "# U = 12"), "{written}");
    let body = |t: &str| t.lines().filter(|l| !l.starts_with('#')).map(str::to_string).collect::<Vec<_>>();
    let (a, b) = (body(&std::fs::read_to_string(&plain).unwrap()), body(&written));
    assert_eq!((a.len(), &a[0]), (b.len(), &b[0]));
    for (x, y) in a.iter().zip(&b).skip(1) {
        let nums = |r: &str| r.split(',').map(|v| v.parse::<f64>().unwrap()).collect::<Vec<_>>();
        assert!(nums(x).iter().zip(nums(y)).all(|(p, q)| (p - q).abs() <= 1e-9 * p.abs().max(1.0)), "{x} against {y}");
    }
    let out = ["--out", split.to_str().unwrap()];
    assert_clean_failure(&buckid(&[&["convert", "--channel", &channels[1]][..], &out].concat()), "no `vout` channel");
    assert_clean_failure(&buckid(&[&["convert", "--channel", "vout=missing.txt"][..], &out].concat()), "reading missing.txt");
    assert_clean_failure(&buckid(&[&["convert", "--channel", &channels[0], "--scope", scope.to_str().unwrap()][..], &out].concat()), "cannot be used with");
    assert_clean_failure(&buckid(&[&["convert", "--channel", &format!("vout={}", plain.display())][..], &out].concat()), "a file of several channels");
    assert_clean_failure(&buckid(&[&["convert", "--scope", scope.to_str().unwrap(), "--meta", "U"][..], &out].concat()), "is not KEY=VALUE");
}
