//! Project tasks (`cargo xtask <task>`):
//!
//! - `model-description`: write `modelDescription/modelDescription.xml` from the variable table;
//! - `fmu`: build the release cdylib and package `fmu/BuckConverter.fmu`.
use std::io::Write;
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
    std::fs::write(&path, model_description().to_xml()?)?;
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
    let mut zip = zip::ZipWriter::new(std::fs::File::create(&fmu)?);
    let options = zip::write::SimpleFileOptions::default().compression_method(zip::CompressionMethod::Deflated).unix_permissions(0o644);
    zip.start_file("modelDescription.xml", options)?;
    zip.write_all(xml.as_bytes())?;
    zip.start_file(format!("binaries/linux64/{MODEL_IDENTIFIER}.so"), options.unix_permissions(0o755))?;
    zip.write_all(&binary)?;
    zip.finish()?;
    Ok(fmu)
}
