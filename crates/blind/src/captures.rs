//! The recorded ngspice runs the tests read (`tests/fixtures/captures`, written and keyed as
//! `tests/python/captures.py` does): a harness run recorded there is read instead of simulated.
//! A run's key is the SHA-256 of its generator's sources (the script and the netlist templates
//! beside it) and its arguments, its output path apart; editing the generator changes every
//! key, and `tests/python/test_captures.py` then asks for them to be recorded again. With
//! `BUCKID_RECORD_CAPTURES=1` a run simulated live is stored too.

use std::fs::File;
use std::io::{self, Write};
use std::path::{Path, PathBuf};
use std::process::Command;

use flate2::read::GzDecoder;
use flate2::{Compression, GzBuilder};
use sha2::{Digest, Sha256};

/// The store's folder under the repository `root`.
fn store(root: &Path) -> PathBuf {
    root.join("tests/fixtures/captures")
}

/// A run's key, as `captures.py`'s `key`: each source's path relative to `root` and its bytes,
/// then the arguments as Python's `json.dumps` writes them; the first 20 hex digits.
fn key(root: &Path, generator: &Path, args: &[String]) -> io::Result<String> {
    let dir = generator.parent().unwrap_or(root);
    let mut templates: Vec<PathBuf> = std::fs::read_dir(dir)?.filter_map(|e| e.ok().map(|e| e.path())).filter(|p| p.extension().is_some_and(|x| x == "cir")).collect();
    templates.sort();
    let mut digest = Sha256::new();
    for path in std::iter::once(generator.to_path_buf()).chain(templates) {
        let relative = path.strip_prefix(root).map_err(|_| io::Error::other(format!("{} is outside {}", path.display(), root.display())))?;
        digest.update(relative.to_string_lossy().replace('\\', "/").as_bytes());
        digest.update([0]);
        digest.update(std::fs::read(&path)?);
        digest.update([0]);
    }
    let quoted: Vec<String> = args.iter().map(|a| serde_json::to_string(a).unwrap_or_default()).collect();
    digest.update(format!("[{}]", quoted.join(", ")).as_bytes());
    Ok(digest.finalize().iter().map(|b| format!("{b:02x}")).collect::<String>()[..20].to_string())
}

/// Writes the recorded `--out` of the run of `generator` with `args` to `out`: whether one was
/// recorded.
pub(crate) fn read_recorded(root: &Path, generator: &Path, args: &[String], out: &Path) -> io::Result<bool> {
    let entry = store(root).join(key(root, generator, args)?);
    if !entry.is_dir() {
        return Ok(false);
    }
    io::copy(&mut GzDecoder::new(File::open(entry.join("out.gz"))?), &mut File::create(out)?)?;
    Ok(true)
}

/// Whether runs simulated live are to be stored (`BUCKID_RECORD_CAPTURES=1`).
pub(crate) fn recording() -> bool {
    std::env::var("BUCKID_RECORD_CAPTURES").is_ok_and(|v| v == "1")
}

/// Stores the run of `generator` with `args` whose `--out` is `out`, as `captures.py` does
/// (through a temporary name: tests run in parallel threads).
pub(crate) fn record(root: &Path, generator: &Path, args: &[String], out: &Path) -> io::Result<()> {
    let entry = store(root).join(key(root, generator, args)?);
    let staging = entry.with_extension(format!("{}", std::process::id()));
    std::fs::create_dir_all(&staging)?;
    let mut gz = GzBuilder::new().mtime(0).write(File::create(staging.join("out.gz"))?, Compression::default());
    io::copy(&mut File::open(out)?, &mut gz)?;
    gz.finish()?.flush()?;
    let version =
        Command::new("ngspice").arg("-v").output().map(|o| String::from_utf8_lossy(&o.stdout).lines().find(|l| l.contains("ngspice-")).map(|l| l.trim_matches(|c| c == '*' || c == ' ').to_string()));
    let manifest = serde_json::json!({
        "generator": generator.strip_prefix(root).unwrap_or(generator).to_string_lossy().replace('\\', "/"),
        "args": args,
        "outputs": ["--out"],
        "ngspice": version.ok().flatten().unwrap_or_else(|| "unknown".to_string()),
    });
    std::fs::write(staging.join("run.json"), serde_json::to_string_pretty(&manifest).map_err(io::Error::other)? + "\n")?;
    // Another thread stored the same run first.
    if std::fs::rename(&staging, &entry).is_err() {
        std::fs::remove_dir_all(&staging)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The key of every recorded run, recomputed from its `run.json`, is its folder's name: this
    /// module keys a run as `captures.py` does (most were recorded from Python), so either side
    /// reads the other's records. Like `test_captures.py`, it fails once a generator changes
    /// until its runs are recorded again.
    #[test]
    fn every_recorded_run_is_found_under_the_key_python_gave_it() -> Result<(), Box<dyn std::error::Error>> {
        let root = fmu_fixture::root();
        let mut checked = 0;
        for entry in std::fs::read_dir(store(&root))? {
            let entry = entry?.path();
            if !entry.is_dir() {
                continue;
            }
            let run: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(entry.join("run.json"))?)?;
            let generator = root.join(run["generator"].as_str().ok_or("no generator")?);
            let args: Vec<String> = serde_json::from_value(run["args"].clone())?;
            assert_eq!(entry.file_name().and_then(|n| n.to_str()), Some(key(&root, &generator, &args)?.as_str()), "{}", entry.display());
            checked += 1;
        }
        assert!(checked >= 20, "{checked} recorded runs");
        Ok(())
    }
}
