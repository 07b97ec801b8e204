//! Reads a data file with `DataSet::read_csv` and prints what it holds: the resource check of
//! `scripts/fuzz` runs it on a 10-million-row file under `/usr/bin/time -v` (peak RSS).
//!
//! `cargo run --release -p estimator --example read_csv -- FILE`
use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let path = std::env::args().nth(1).ok_or("usage: read_csv FILE")?;
    let t = Instant::now();
    match estimator::data::DataSet::read_csv(path.as_ref()) {
        Ok(d) => println!("read {} rows, sample period {:e} s, in {:.2} s", d.len(), d.sample_period(), t.elapsed().as_secs_f64()),
        Err(e) => println!("refused in {:.2} s: {e}", t.elapsed().as_secs_f64()),
    }
    Ok(())
}
