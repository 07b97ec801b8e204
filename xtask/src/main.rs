//! Project tasks (`cargo xtask <task>`):
//!
//! - `model-description`: write `modelDescription/modelDescription.xml` from the variable table;
//! - `fmu`: build the release cdylib and package `fmu/BuckConverter.fmu`.
//!
//! Both write their file only when its bytes change, and then atomically (a sibling temporary
//! renamed over it): the package is reproducible (fixed timestamps inside the zip), and a test
//! that loads the FMU while another process re-packages it never sees a half-written zip.
use std::io::{Cursor, Write};
use std::path::{Path, PathBuf};
use std::process::Command;

use anyhow::{Context, Result, bail};
use buck_fmu::{MODEL_IDENTIFIER, model_description};

fn main() -> Result<()> {
    let task = std::env::args().nth(1).unwrap_or_default();
    match task.as_str() {
        "model-description" => write_model_description().map(|p| eprintln!("wrote {}", p.display())),
        "fmu" => package_fmu().map(|p| println!("{}", p.display())),
        _ => bail!("usage: cargo xtask <model-description|fmu>"),
    }
}

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).parent().map_or_else(|| PathBuf::from("."), Path::to_path_buf)
}

fn write_model_description() -> Result<PathBuf> {
    let path = root().join("modelDescription/modelDescription.xml");
    std::fs::create_dir_all(path.parent().context("no parent")?)?;
    write_if_changed(&path, model_description().to_xml()?.as_bytes())?;
    Ok(path)
}

fn package_fmu() -> Result<PathBuf> {
    let root = root();
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let status = Command::new(cargo).current_dir(&root).args(["build", "--release", "--package", "buck-fmu", "--lib"]).status().context("running cargo build")?;
    if !status.success() {
        bail!("cargo build of buck-fmu failed");
    }
    let target = std::env::var_os("CARGO_TARGET_DIR").map_or_else(|| root.join("target"), PathBuf::from);
    let so = target.join("release/libbuck_fmu.so");
    let binary = std::fs::read(&so).with_context(|| format!("reading {}", so.display()))?;
    let xml = std::fs::read_to_string(write_model_description()?)?;

    let fmu = root.join("fmu").join(format!("{MODEL_IDENTIFIER}.fmu"));
    std::fs::create_dir_all(fmu.parent().context("no parent")?)?;
    let mut zip = zip::ZipWriter::new(Cursor::new(Vec::new()));
    let options = zip::write::SimpleFileOptions::default().compression_method(zip::CompressionMethod::Deflated).last_modified_time(zip::DateTime::DEFAULT).unix_permissions(0o644);
    zip.start_file("modelDescription.xml", options)?;
    zip.write_all(xml.as_bytes())?;
    zip.start_file(format!("binaries/linux64/{MODEL_IDENTIFIER}.so"), options.unix_permissions(0o755))?;
    zip.write_all(&binary)?;
    write_if_changed(&fmu, &zip.finish()?.into_inner())?;
    Ok(fmu)
}

/// Writes `bytes` to `path` unless it already holds them (then only its modification time is
/// renewed, so that freshness checks against the sources hold); a reader sees the old file or the
/// new one, never a partial write.
fn write_if_changed(path: &Path, bytes: &[u8]) -> Result<()> {
    if std::fs::read(path).is_ok_and(|old| old == bytes) {
        let file = std::fs::File::options().append(true).open(path)?;
        return file.set_modified(std::time::SystemTime::now()).with_context(|| format!("touching {}", path.display()));
    }
    let name = path.file_name().context("no file name")?.to_string_lossy();
    let partial = path.with_file_name(format!(".{name}.{}.partial", std::process::id()));
    let written = std::fs::write(&partial, bytes)
        .with_context(|| format!("writing {}", partial.display()))
        .and_then(|()| std::fs::rename(&partial, path).with_context(|| format!("renaming {} to {}", partial.display(), path.display())));
    if written.is_err() {
        // Nothing half-written is left beside the file (it may not exist: the error is the write's).
        let _ = std::fs::remove_file(&partial);
    }
    written
}

#[cfg(test)]
mod tests {
    use super::write_if_changed;

    fn partials(dir: &std::path::Path) -> Vec<String> {
        std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).filter(|n| n.ends_with(".partial")).collect()
    }

    #[test]
    fn a_changed_file_is_replaced_and_an_unchanged_one_kept() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.fmu");
        write_if_changed(&path, b"one").unwrap();
        write_if_changed(&path, b"two").unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), b"two");
        write_if_changed(&path, b"two").unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), b"two");
        assert!(partials(dir.path()).is_empty());
    }

    #[test]
    fn a_failed_rename_leaves_no_partial_file() {
        // A directory in the file's place: the write succeeds, the rename over it fails.
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.fmu");
        std::fs::create_dir(&path).unwrap();
        std::fs::write(path.join("inside"), b"x").unwrap();
        let err = write_if_changed(&path, b"new").unwrap_err();
        assert!(format!("{err:#}").contains("renaming"), "{err:#}");
        assert!(partials(dir.path()).is_empty(), "{:?}", partials(dir.path()));
    }
}
