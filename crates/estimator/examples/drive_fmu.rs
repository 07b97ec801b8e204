//! Drives an FMU one switching period per line of duty read from stdin through the
//! estimator's `FmuPlant` (our Rust importer), and prints the wall time of the stepping loop
//! to stderr. Used by `scripts/bench_sim.py` to time the FMU without Python in the loop.
//!
//! `drive_fmu FMU [NAME=VALUE ...] < duties.txt`
use std::io::BufRead;
use std::time::Instant;

use estimator::experiment::Plant;
use estimator::fmu_plant::{FmuOptions, FmuPlant};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let path = args.next().ok_or("usage: drive_fmu FMU [NAME=VALUE ...] < duties")?;
    let mut set = Vec::new();
    for a in args {
        let (k, v) = a.split_once('=').ok_or("expected NAME=VALUE")?;
        set.push((k.to_string(), v.parse::<f64>()?));
    }
    let duties: Vec<f64> = std::io::stdin().lock().lines().map(|l| Ok(l?.trim().parse()?)).collect::<Result<_, Box<dyn std::error::Error>>>()?;
    let mut plant = FmuPlant::open(path.as_ref(), &FmuOptions { set, ..FmuOptions::default() })?;
    plant.start(duties.first().copied().unwrap_or(0.5), 1.0, 12.0)?;
    let start = Instant::now();
    let mut last = 0.0;
    for &d in &duties {
        plant.step_period(d, 1.0)?;
        last = plant.sample()?.vout;
    }
    eprintln!("simulated {} periods in {:.3} ms (last vout {last:.4} V)", duties.len(), start.elapsed().as_secs_f64() * 1e3);
    Ok(())
}
