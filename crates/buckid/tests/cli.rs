//! `buckid` as a user runs it: data files in, summary/JSON out, clear errors for bad input.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a test or benchmark: failing loudly is the point
use std::path::Path;
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
    assert_eq!(html.matches("<svg").count(), 4, "traces, ACF, CCF, Bode");
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
    ];
    for (name, text, needle) in cases {
        let path = dir.path().join(name);
        std::fs::write(&path, text).unwrap();
        let o = buckid(&["identify", "--data", path.to_str().unwrap()]);
        assert!(!o.status.success(), "{name} accepted");
        assert!(stderr(&o).contains(needle), "{name}: {:?} lacks {needle:?}", stderr(&o));
        assert!(!stderr(&o).contains("panicked"), "{name}: {}", stderr(&o));
    }
    let o = buckid(&["identify", "--data", dir.path().join("absent.csv").to_str().unwrap()]);
    assert!(!o.status.success() && stderr(&o).contains("absent.csv"), "{}", stderr(&o));
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
