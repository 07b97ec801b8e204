//! Wall time of the exact switched simulation with each state-event effect: 3001 switching
//! periods at 330 kHz, PRBS duty 0.4/0.6, io = 1 A, Cl = 4.7 µF, a fresh converter per run
//! (transition caches cold, as after a parameter change in an estimator). Prints the best and
//! the median of several runs in ms per 3001 periods, next to the best time of the engine
//! before the ladder of exact transitions (commit 8effe05, which took a dynamic-size matrix
//! exponential per Newton step of a state event), measured on the same 2-core machine.
//!
//! `cargo run --release -p buck-model --example event_speed -- [--dump DIR]`
//! `--dump` writes each case's trajectory (`vout,il,vc,vout_avg,il_avg` at each period end,
//! shortest round-trip digits) to `DIR/<case>.csv`, to compare two versions of the engine.
use std::io::Write;
use std::time::Instant;

use buck_model::variables::VarId;
use buck_model::{Converter, Inputs, Mode, Outputs, Params};

const PERIODS: usize = 3001;
const RUNS: usize = 7;

/// Duties of a 9-bit maximum-length sequence (x⁹ + x⁵ + 1), one bit per period.
fn prbs(n: usize) -> Vec<f64> {
    let mut reg: u16 = 0x1ff;
    (0..n)
        .map(|_| {
            let bit = ((reg >> 8) ^ (reg >> 4)) & 1;
            reg = ((reg << 1) | bit) & 0x1ff;
            if bit == 1 { 0.6 } else { 0.4 }
        })
        .collect()
}

fn run(params: Params, duties: &[f64]) -> Result<Vec<Outputs>, Box<dyn std::error::Error>> {
    let mut conv = Converter::new(params, Mode::Switched);
    conv.set_inputs(Inputs { duty: duties[0], io: 1.0, vin: 12.0, ..Inputs::default() })?;
    conv.initialize();
    let mut out = Vec::with_capacity(duties.len());
    for &d in duties {
        conv.set(VarId::Duty, d)?;
        conv.step(params.period())?;
        out.push(conv.outputs());
    }
    Ok(out)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let dump = args.iter().position(|a| a == "--dump").and_then(|i| args.get(i + 1));
    let base = Params { cl: 4.7e-6, ..Params::default() };
    // A Schottky on its exponential law (`diode_emission`), beside the same diode's straight line.
    let schottky = Params { diode_drop: 0.35, diode_resistance: 0.025, ..base };
    // (name, parameters, best ms of commit 8effe05 where it had the effect)
    let cases = [
        ("ideal", base, Some(0.279)),
        ("diode_drop (DCM)", Params { diode_drop: 0.45, ..base }, Some(89.0)),
        ("dead_time", Params { dead_time: 30e-9, ..base }, Some(14.1)),
        ("inductor_saturation", Params { inductor_saturation: 0.2, isat: 1.5, ..base }, Some(157.5)),
        ("cap_dc_bias", Params { cap_dc_bias: 0.5, ..base }, Some(40.2)),
        ("esl", Params { esl: 1e-9, ..base }, Some(0.285)),
        ("DCM + saturation + dc_bias", Params { diode_drop: 0.45, inductor_saturation: 0.2, isat: 1.5, cap_dc_bias: 0.5, ..base }, Some(433.0)),
        ("schottky_line (DCM)", schottky, None),
        ("schottky_law (DCM)", Params { diode_emission: 0.028, ..schottky }, None),
    ];
    let duties = prbs(PERIODS);
    println!("{:<28} {:>10} {:>10} {:>10} {:>8}  final vout_avg", "case", "before ms", "best ms", "median ms", "speedup");
    for (name, params, before) in cases {
        let mut times = Vec::with_capacity(RUNS);
        let mut trajectory = Vec::new();
        for _ in 0..RUNS {
            let start = Instant::now();
            trajectory = run(params, &duties)?;
            times.push(start.elapsed().as_secs_f64() * 1e3);
        }
        times.sort_by(f64::total_cmp);
        let last = trajectory.last().map_or(f64::NAN, |y| y.vout_avg);
        let (best, median) = (times[0], times[RUNS / 2]);
        let (before, speedup) = before.map_or(("—".to_string(), "—".to_string()), |b| (format!("{b:.3}"), format!("{:.1}×", b / best)));
        println!("{name:<28} {before:>10} {best:>10.3} {median:>10.3} {speedup:>8}  {last:.12}");
        if let Some(dir) = dump {
            let file = format!("{dir}/{}.csv", name.split_whitespace().next().unwrap_or(name));
            let mut w = std::io::BufWriter::new(std::fs::File::create(file)?);
            writeln!(w, "vout,il,vc,vout_avg,il_avg")?;
            for y in &trajectory {
                writeln!(w, "{:e},{:e},{:e},{:e},{:e}", y.vout, y.il, y.vc, y.vout_avg, y.il_avg)?;
            }
        }
    }
    Ok(())
}
