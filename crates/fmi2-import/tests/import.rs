//! Runs the project's own `BuckConverter.fmu` through the importer, and feeds the importer
//! broken FMUs built here with the `zip` crate.
//!
//! The FMU is (re)built with `cargo xtask fmu` when it is missing or older than the sources of
//! `buck-fmu`/`buck-model`, because `cargo test --workspace` runs before anyone packages it.
#![allow(clippy::unwrap_used)]

use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

use anyhow::Result;
use fmi2_import::{Fmu, ImportError, Instance, InstantiateOptions, Status, VarKind};
use fmu_fixture::root;

/// Switching period of the thesis converter \[s\].
const T: f64 = 1.0 / 330e3;
/// Steady-state tolerance on voltages \[V\] and currents \[A\] after 2000 periods (≈180 time
/// constants 2L/(RL+Rc) = 33 µs, so the transient is far below this).
const TOL: f64 = 1e-6;

/// The packaged FMU, (re)built when missing or stale.
fn buck_fmu() -> &'static Path {
    fmu_fixture::buck_fmu().unwrap_or_else(|e| panic!("{e}"))
}

fn vr(fmu: &Fmu, name: &str) -> u32 {
    fmu.value_reference(name).unwrap().0
}

/// Instantiates in averaged mode, starting from zero state, and initialises with `duty`.
fn averaged(fmu: &Fmu, name: &str, duty: f64) -> Result<Instance> {
    let mut inst = fmu.instantiate(name)?;
    let (mode, kind) = fmu.value_reference("mode")?;
    // Declared as an Integer 1..2 today; an Enumeration would be set the same way.
    assert!(matches!(kind, VarKind::Integer | VarKind::Enumeration), "{kind:?}");
    inst.set_integer(&[mode], &[1])?;
    inst.set_boolean(&[vr(fmu, "start_at_steady_state")], &[false])?;
    inst.setup_experiment(0.0, None)?;
    inst.enter_initialization_mode()?;
    inst.set_real(&[vr(fmu, "duty"), vr(fmu, "io"), vr(fmu, "vin")], &[duty, 1.0, 12.0])?;
    inst.exit_initialization_mode()?;
    Ok(inst)
}

fn get(inst: &mut Instance, fmu: &Fmu, name: &str) -> f64 {
    let mut v = [f64::NAN];
    inst.get_real(&[vr(fmu, name)], &mut v).unwrap();
    v[0]
}

/// Averaged steady state: vout = d·vin − RL·io, il = io.
fn steady_vout(duty: f64) -> f64 {
    duty * 12.0 - 0.1 * 1.0
}

#[test]
fn averaged_mode_settles_at_duty_times_vin_minus_resistive_drop() -> Result<()> {
    let fmu = Fmu::open(buck_fmu())?;
    assert!(fmu.problems().is_empty(), "{:?}", fmu.problems());
    let mut inst = averaged(&fmu, "averaged", 0.5)?;
    let mut flag = [true];
    inst.get_boolean(&[vr(&fmu, "start_at_steady_state")], &mut flag)?;
    assert!(!flag[0], "set_boolean/get_boolean round trip");
    let mut mode = [0];
    inst.get_integer(&[vr(&fmu, "mode")], &mut mode)?;
    assert_eq!(mode, [1]);
    assert!(get(&mut inst, &fmu, "vout").abs() < 1.0, "starts from zero, not at the operating point");
    for k in 0..2000 {
        inst.do_step(f64::from(k) * T, T)?;
    }
    let vout = get(&mut inst, &fmu, "vout");
    let il = get(&mut inst, &fmu, "il");
    assert!((vout - 5.9).abs() < TOL, "vout = {vout}, expected 5.9 ± {TOL}");
    assert!((il - 1.0).abs() < TOL, "il = {il}, expected 1 ± {TOL}");
    inst.terminate()?;
    Ok(())
}

#[test]
fn two_instances_in_one_process_stay_independent() -> Result<()> {
    let fmu = Fmu::open(buck_fmu())?;
    let mut a = averaged(&fmu, "a", 0.5)?;
    let mut b = averaged(&fmu, "b", 0.25)?;
    for k in 0..2000 {
        a.do_step(f64::from(k) * T, T)?;
        b.do_step(f64::from(k) * T, T)?;
    }
    let (va, vb) = (get(&mut a, &fmu, "vout"), get(&mut b, &fmu, "vout"));
    assert!((va - steady_vout(0.5)).abs() < TOL, "a: vout = {va}");
    assert!((vb - steady_vout(0.25)).abs() < TOL, "b: vout = {vb}");
    // Freeing one must leave the other usable.
    drop(a);
    b.do_step(2000.0 * T, T)?;
    assert!((get(&mut b, &fmu, "vout") - steady_vout(0.25)).abs() < TOL);
    Ok(())
}

#[test]
fn instance_outlives_its_fmu_and_keeps_the_extraction() -> Result<()> {
    let fmu = Fmu::open(buck_fmu())?;
    let dir = fmu.dir().to_path_buf();
    let (vout, _) = fmu.value_reference("vout")?;
    let mut inst = averaged(&fmu, "orphan", 0.5)?;
    drop(fmu);
    assert!(dir.is_dir(), "the instance keeps the extracted folder");
    inst.do_step(0.0, T)?;
    let mut v = [f64::NAN];
    inst.get_real(&[vout], &mut v)?;
    assert!(v[0].is_finite());
    drop(inst);
    assert!(!dir.exists(), "the folder goes with the last owner");
    Ok(())
}

#[test]
fn bad_value_error_names_the_function_and_carries_the_fmu_log() -> Result<()> {
    let fmu = Fmu::open(buck_fmu())?;
    let seen = Arc::new(Mutex::new(Vec::new()));
    let sink = Arc::clone(&seen);
    let options = InstantiateOptions::new().log_callback(move |m| sink.lock().unwrap().push(m.message.clone()));
    let mut inst = fmu.instantiate_with("bad", options)?;
    inst.setup_experiment(0.0, None)?;
    inst.enter_initialization_mode()?;
    let err = inst.set_real(&[vr(&fmu, "duty")], &[1.5]).unwrap_err();
    let text = err.to_string();
    assert!(text.starts_with("fmi2SetReal returned fmi2Error; the FMU logged:"), "{text}");
    assert!(text.contains("duty"), "the logged message names the variable: {text}");
    let ImportError::Call { function, status, log } = &err else { panic!("{err:?}") };
    assert_eq!((*function, *status), ("fmi2SetReal", Status::Error));
    assert!(log.iter().all(|m| m.instance_name == "bad"), "{log:?}");
    assert!(seen.lock().unwrap().iter().any(|m| m.contains("duty")), "the user callback saw it too");
    assert!(inst.take_log().iter().any(|m| m.message.contains("duty")));
    Ok(())
}

#[test]
fn length_mismatch_is_an_error_not_a_panic() -> Result<()> {
    let fmu = Fmu::open(buck_fmu())?;
    let mut inst = fmu.instantiate("len")?;
    let err = inst.set_real(&[0, 1], &[0.5]).unwrap_err();
    assert_eq!(err.to_string(), "fmi2SetReal: 2 value references but 1 values");
    let mut out = [0.0; 3];
    assert!(matches!(inst.get_real(&[3], &mut out), Err(ImportError::LengthMismatch { .. })));
    Ok(())
}

#[test]
fn state_snapshot_restores_and_reset_returns_to_instantiated() -> Result<()> {
    let fmu = Fmu::open(buck_fmu())?;
    let mut inst = averaged(&fmu, "state", 0.5)?;
    for k in 0..10 {
        inst.do_step(f64::from(k) * T, T)?;
    }
    let snapshot = inst.get_state()?;
    let at_snapshot = get(&mut inst, &fmu, "vout");
    for k in 10..20 {
        inst.do_step(f64::from(k) * T, T)?;
    }
    assert_ne!(get(&mut inst, &fmu, "vout"), at_snapshot, "still in the transient");
    inst.set_state(&snapshot)?;
    assert_eq!(get(&mut inst, &fmu, "vout"), at_snapshot, "bit-exact restore");
    inst.free_state(snapshot)?;
    inst.reset()?;
    inst.setup_experiment(0.0, None)?;
    inst.enter_initialization_mode()?;
    inst.exit_initialization_mode()?;
    Ok(())
}

#[test]
fn unknown_variable_error_lists_the_variables() -> Result<()> {
    let fmu = Fmu::open(buck_fmu())?;
    let err = fmu.value_reference("v_out").unwrap_err();
    let text = err.to_string();
    assert!(text.starts_with(r#"the FMU has no variable "v_out"; its variables are: duty, io, vin, vout"#), "{text}");
    assert!(text.contains("mode"), "{text}");
    Ok(())
}

// ---- Broken FMUs ---------------------------------------------------------------------------

/// Writes a zip with `entries` into a fresh temporary folder.
fn zip_fmu(entries: &[(&str, &[u8])]) -> Result<(tempfile::TempDir, PathBuf)> {
    let tmp = tempfile::tempdir()?;
    let path = tmp.path().join("broken.fmu");
    let mut zip = zip::ZipWriter::new(std::fs::File::create(&path)?);
    for (name, data) in entries {
        zip.start_file(*name, zip::write::SimpleFileOptions::default())?;
        zip.write_all(data)?;
    }
    zip.finish()?;
    Ok((tmp, path))
}

fn buck_xml() -> String {
    std::fs::read_to_string(root().join("modelDescription/modelDescription.xml")).unwrap()
}

#[test]
fn not_a_zip_is_a_clear_error() -> Result<()> {
    let tmp = tempfile::tempdir()?;
    let path = tmp.path().join("text.fmu");
    std::fs::write(&path, "this is not a zip archive")?;
    let err = Fmu::open(&path).unwrap_err();
    assert!(matches!(err, ImportError::Zip { .. }), "{err:?}");
    assert!(err.to_string().contains("is not a valid FMU (zip) archive"), "{err}");
    let err = Fmu::open(tmp.path().join("absent.fmu")).unwrap_err();
    assert!(matches!(err, ImportError::Io { .. }), "{err:?}");
    Ok(())
}

#[test]
fn zip_without_model_description_is_a_clear_error() -> Result<()> {
    let (_tmp, path) = zip_fmu(&[("resources/readme.txt", b"hello")])?;
    let err = Fmu::open(&path).unwrap_err();
    assert!(matches!(err, ImportError::MissingModelDescription { .. }), "{err:?}");
    assert!(err.to_string().contains("no modelDescription.xml"), "{err}");
    Ok(())
}

#[test]
fn malformed_xml_is_a_clear_error() -> Result<()> {
    let xml = buck_xml();
    let (_tmp, path) = zip_fmu(&[("modelDescription.xml", &xml.as_bytes()[..xml.len() / 2])])?;
    let err = Fmu::open(&path).unwrap_err();
    assert!(matches!(err, ImportError::ModelDescription { .. }), "{err:?}");
    assert!(err.to_string().contains("broken.fmu/modelDescription.xml"), "{err}");
    Ok(())
}

#[test]
fn entry_escaping_the_folder_is_refused() -> Result<()> {
    let xml = buck_xml();
    let (tmp, path) = zip_fmu(&[("modelDescription.xml", xml.as_bytes()), ("../evil", b"pwned")])?;
    let err = Fmu::open(&path).unwrap_err();
    assert!(matches!(&err, ImportError::UnsafeEntry { entry } if entry == "../evil"), "{err:?}");
    assert!(!tmp.path().join("evil").exists() && !std::env::temp_dir().join("evil").exists());
    Ok(())
}

#[test]
fn missing_binary_names_the_expected_path() -> Result<()> {
    let xml = buck_xml();
    let (_tmp, path) = zip_fmu(&[("modelDescription.xml", xml.as_bytes())])?;
    let fmu = Fmu::open(&path)?;
    assert_eq!(fmu.variables().len(), fmu.model_description().variables().len(), "readable without binary");
    let err = fmu.instantiate("x").err().unwrap();
    assert!(matches!(err, ImportError::MissingBinary { .. }), "{err:?}");
    assert!(err.to_string().contains("binaries/linux64/BuckConverter.so"), "{err}");
    Ok(())
}

#[test]
fn unrelated_library_names_the_missing_symbol() -> Result<()> {
    let Some(libm) = ["/lib/x86_64-linux-gnu/libm.so.6", "/usr/lib/x86_64-linux-gnu/libm.so.6", "/lib64/libm.so.6"].into_iter().map(Path::new).find(|p| p.is_file()) else {
        eprintln!("skipped: no system libm found");
        return Ok(());
    };
    let xml = buck_xml();
    let lib = std::fs::read(libm)?;
    let (_tmp, path) = zip_fmu(&[("modelDescription.xml", xml.as_bytes()), ("binaries/linux64/BuckConverter.so", &lib)])?;
    let err = Fmu::open(&path)?.instantiate("x").err().unwrap();
    assert!(matches!(err, ImportError::MissingSymbol { .. }), "{err:?}");
    assert!(err.to_string().contains("does not export the required function fmi2GetTypesPlatform"), "{err}");
    Ok(())
}

#[test]
fn wrong_guid_fails_instantiation_with_the_fmu_log() -> Result<()> {
    let source = Fmu::open(buck_fmu())?;
    let dir = tempfile::tempdir()?;
    let bin = dir.path().join("binaries/linux64");
    std::fs::create_dir_all(&bin)?;
    std::fs::copy(source.binary_path(), bin.join("BuckConverter.so"))?;
    let guid = &source.model_description().guid;
    std::fs::write(dir.path().join("modelDescription.xml"), buck_xml().replace(guid.as_str(), "{stale-guid}"))?;
    let err = Fmu::from_dir(dir.path())?.instantiate("stale").err().unwrap();
    let ImportError::Instantiate { instance, log } = &err else { panic!("{err:?}") };
    assert_eq!(instance, "stale");
    assert!(!log.is_empty(), "the FMU explains why: {err}");
    assert!(err.to_string().contains("fmi2Instantiate(\"stale\") returned null; the FMU logged:"), "{err}");
    Ok(())
}

/// A Modelica Association Reference FMU from `tests/fixtures/reference-fmus/`.
fn reference_fmu(name: &str) -> PathBuf {
    root().join("tests/fixtures/reference-fmus").join(format!("{name}.fmu"))
}

#[test]
fn simulate_runs_dahlquist_as_its_fixed_euler_step() -> Result<()> {
    use fmi2_import::Value;
    use fmi2_import::simulate::{Experiment, simulate};
    let fmu = Fmu::open(reference_fmu("Dahlquist"))?;
    let exp = Experiment::for_fmu(&fmu, None, None, None)?;
    assert_eq!(exp, Experiment { start: 0.0, stop: 10.0, step: 0.1 }, "its DefaultExperiment");
    let k = fmu.resolve("k")?;
    let rec = simulate(&fmu, &exp, &[(k, Value::Real(2.0))], None, &fmu.outputs())?;
    assert_eq!(rec.variables.iter().map(|v| v.name.as_str()).collect::<Vec<_>>(), ["x"]);
    assert_eq!(rec.time.len(), 101, "the start and 100 steps");
    // dx/dt = −k·x with forward Euler at its FIXED_SOLVER_STEP 0.1 (config.h): x_n = (1 − 0.1·k)^n.
    for (n, (t, row)) in rec.time.iter().zip(&rec.rows).enumerate() {
        let want = 0.8f64.powi(n as i32);
        let Value::Real(x) = row[0] else { panic!("x is Real") };
        assert!((t - 0.1 * n as f64).abs() < 1e-12, "t = {t}");
        assert!((x - want).abs() <= 1e-12 * want, "x({t}) = {x}, expected {want}");
    }
    Ok(())
}

#[test]
fn simulate_ends_where_stair_terminates() -> Result<()> {
    use fmi2_import::Value;
    use fmi2_import::simulate::{Experiment, simulate};
    let fmu = Fmu::open(reference_fmu("Stair"))?;
    let exp = Experiment::for_fmu(&fmu, None, None, Some(0.5))?;
    let rec = simulate(&fmu, &exp, &[], None, &fmu.outputs())?;
    // The counter starts at 1 and counts each second; at 10 (t = 9 s) the FMU terminates.
    assert_eq!(rec.time.last().copied(), Some(9.0));
    assert_eq!(rec.rows.last(), Some(&vec![Value::Integer(10)]));
    assert_eq!(rec.rows[3], vec![Value::Integer(2)], "t = 1.5 s");
    assert!(rec.notes.iter().any(|n| n.contains("ended the simulation at 9 s")), "{:?}", rec.notes);
    Ok(())
}
