//! `buckid identify --fmu` against FMUs that misbehave on purpose: a small C FMU
//! (`tests/fixtures/misbehaving/fmu.c`) compiled here with `cc` in one variant per failure,
//! packaged with Python's `zipfile`. Each run must exit non-zero with an error naming the
//! function and what the FMU logged. A segfault inside the FMU's own code ends the child process
//! the command runs the FMU in, and `buckid` reports it.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use fmu_fixture::root;

/// Builds the variant `define` (or the well-behaved FMU for `None`) into `dir/<name>.fmu`.
fn build(dir: &Path, define: Option<&str>) -> PathBuf {
    let src = root().join("tests/fixtures/misbehaving");
    let name = define.unwrap_or("GOOD");
    let so = dir.join(format!("{name}.so"));
    let mut cc = Command::new(std::env::var("CC").unwrap_or_else(|_| "cc".into()));
    cc.args(["-shared", "-fPIC", "-O1", "-Wall", "-Wextra", "-Werror", "-o"]).arg(&so).arg(src.join("fmu.c")).arg("-lm");
    if let Some(d) = define {
        cc.arg(format!("-D{d}"));
    }
    let out = cc.output().expect("run cc");
    assert!(out.status.success(), "cc: {}", String::from_utf8_lossy(&out.stderr));
    let fmu = dir.join(format!("{name}.fmu"));
    let zip = Command::new("python3")
        .arg("-c")
        .arg(
            "import sys, zipfile\n\
             with zipfile.ZipFile(sys.argv[1], 'w', zipfile.ZIP_DEFLATED) as z:\n\
             \x20   z.write(sys.argv[2], 'modelDescription.xml')\n\
             \x20   z.write(sys.argv[3], 'binaries/linux64/Misbehaving.so')\n",
        )
        .arg(&fmu)
        .arg(src.join("modelDescription.xml"))
        .arg(&so)
        .output()
        .expect("run python3");
    assert!(zip.status.success(), "zip: {}", String::from_utf8_lossy(&zip.stderr));
    fmu
}

fn identify(fmu: &Path) -> Output {
    identify_in(fmu, &std::env::temp_dir())
}

/// `identify` with `temp` for the temporary folder (`TMPDIR`).
fn identify_in(fmu: &Path, temp: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_buckid")).args(["identify", "--fmu"]).arg(fmu).args(["--samples", "200"]).env("TMPDIR", temp).output().expect("run buckid")
}

#[test]
fn misbehaving_fmus_are_reported_by_function_and_exit_non_zero() {
    let tmp = tempfile::tempdir().unwrap();
    let cases = [
        ("NULL_INSTANTIATE", vec!["fmi2Instantiate(\"buckid\") returned null", "license check failed"]),
        ("DOSTEP_ERROR", vec!["fmi2DoStep returned fmi2Error", "solver diverged at step 10"]),
        ("NO_DOSTEP", vec!["does not export the required function fmi2DoStep"]),
        ("WRONG_VERSION", vec!["fmi2GetVersion returned \"3.0\", expected \"2.0\""]),
        ("NAN_OUTPUT", vec!["not finite"]),
    ];
    for (define, needles) in cases {
        let out = identify(&build(tmp.path(), Some(define)));
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{define}: {}\n{stderr}", out.status);
        for needle in needles {
            assert!(stderr.contains(needle), "{define}: stderr lacks {needle:?}:\n{stderr}");
        }
    }
}

/// The FMU's fault ends the child process that loaded it (`isolate`); `buckid` itself exits 1
/// with an error naming the FMU and the signal, after what the run printed before it, and
/// leaves no extracted FMU behind in the temporary folder.
#[test]
fn a_segfaulting_fmu_is_reported_not_fatal() {
    let tmp = tempfile::tempdir().unwrap();
    let fmu = build(tmp.path(), Some("SEGFAULT_DOSTEP"));
    let temp_root = tempfile::tempdir().unwrap();
    let identified = identify_in(&fmu, temp_root.path());
    // What the run printed before the fault is kept.
    assert!(String::from_utf8_lossy(&identified.stderr).contains("running"));
    let simulated = Command::new(env!("CARGO_BIN_EXE_buckid")).args(["simulate", "--fmu"]).arg(&fmu).env("TMPDIR", temp_root.path()).output().expect("run buckid");
    let left: Vec<_> = std::fs::read_dir(temp_root.path()).unwrap().map(|e| e.unwrap().path()).collect();
    assert!(left.is_empty(), "the crashed runs left {left:?}");
    for out in [identified, simulated] {
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{}: {stderr}", out.status);
        let needle = format!("error: the run of the FMU {} was ended by signal 11 (SIGSEGV: an invalid memory access)", fmu.display());
        assert!(stderr.contains(&needle), "{stderr}");
    }
}
