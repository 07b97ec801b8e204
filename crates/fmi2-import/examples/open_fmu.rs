//! Opens an FMU archive with `Fmu::open` (extraction and model description, no binary) and
//! prints the outcome: the resource check of `scripts/fuzz` runs it on zip bombs under
//! `/usr/bin/time -v` (peak RSS) with a private `TMPDIR`.
//!
//! `cargo run --release -p fmi2-import --example open_fmu -- FILE`
use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let path = std::env::args().nth(1).ok_or("usage: open_fmu FILE")?;
    let t = Instant::now();
    match fmi2_import::Fmu::open(&path) {
        Ok(fmu) => println!("opened {} ({} variables) in {:.2} s", fmu.model_identifier(), fmu.variables().len(), t.elapsed().as_secs_f64()),
        Err(e) => println!("refused in {:.2} s: {e}", t.elapsed().as_secs_f64()),
    }
    Ok(())
}
