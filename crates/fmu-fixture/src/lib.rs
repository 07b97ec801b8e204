//! The packaged `fmu/BuckConverter.fmu` for tests and benchmarks: built with `cargo xtask fmu`
//! once per process when it is missing or older than its sources (`cargo test` alone does not
//! package it; `scripts/test` does first).
#![forbid(unsafe_code)]

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;
use std::time::SystemTime;

/// The crates the FMU is built from.
const SOURCES: [&str; 4] = ["crates/buck-fmu", "crates/buck-model", "crates/fmi2-schema", "crates/fmi2-sys"];

/// The repository root.
pub fn root() -> PathBuf {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    root.canonicalize().unwrap_or(root)
}

/// Newest modification time of the files below `dir` (recursively).
fn newest(dir: &Path) -> Option<SystemTime> {
    let mut latest = None;
    for entry in std::fs::read_dir(dir).ok()?.flatten() {
        let path = entry.path();
        let t = if path.is_dir() { newest(&path) } else { entry.metadata().ok()?.modified().ok() };
        latest = latest.max(t);
    }
    latest
}

/// Builds the FMU unless it is newer than every source file.
fn build() -> Result<PathBuf, String> {
    let root = root();
    let fmu = root.join("fmu/BuckConverter.fmu");
    let built = std::fs::metadata(&fmu).and_then(|m| m.modified()).ok();
    let sources = SOURCES.iter().filter_map(|d| newest(&root.join(d))).max();
    if built.is_some() && built >= sources {
        return Ok(fmu);
    }
    eprintln!("building {} with `cargo xtask fmu` (missing or stale)", fmu.display());
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let status = Command::new(cargo).current_dir(&root).args(["xtask", "fmu"]).status().map_err(|e| format!("running `cargo xtask fmu`: {e}"))?;
    if !status.success() || !fmu.is_file() {
        return Err(format!("`cargo xtask fmu` failed ({status}); build fmu/BuckConverter.fmu by hand"));
    }
    Ok(fmu)
}

/// The packaged FMU, fresh; built at most once per process.
pub fn buck_fmu() -> Result<&'static Path, &'static str> {
    static FMU: OnceLock<Result<PathBuf, String>> = OnceLock::new();
    FMU.get_or_init(build).as_ref().map(PathBuf::as_path).map_err(String::as_str)
}
