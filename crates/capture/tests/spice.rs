//! A capture of the ngspice MOSFET synchronous buck (tests/fixtures/capture: 60 PRBS periods at
//! 330 kHz, 4 per bit so that the duty steps (44 at 0.4, 16 at 0.6), after 100 warm-up
//! periods, resampled at 97.3 MS/s, a clock unrelated to fs, with σ = 5 mV / 5 mA of seeded
//! noise; made by `scripts/spice/buck_spice.py --circuit sync
//! --periods 60 --warmup 100 --seed 5 --bit-periods 4 --out sync_periods.csv --capture
//! sync_scope.csv --truth sync_truth.json`) reduced per
//! period and compared with the generator's own per-period reduction of the exact transient.
//! The fixture is committed so this always runs (the command above regenerates it with ngspice).
use std::collections::BTreeMap;
use std::path::Path;

fn read_periods(path: &Path) -> anyhow::Result<BTreeMap<String, Vec<f64>>> {
    let text = std::fs::read_to_string(path)?;
    let mut lines = text.lines().filter(|l| !l.starts_with('#'));
    let header: Vec<String> = lines.next().ok_or_else(|| anyhow::anyhow!("empty"))?.split(',').map(String::from).collect();
    let mut cols: BTreeMap<String, Vec<f64>> = header.iter().map(|h| (h.clone(), Vec::new())).collect();
    for l in lines {
        for (h, v) in header.iter().zip(l.split(',')) {
            cols.get_mut(h).ok_or_else(|| anyhow::anyhow!("column"))?.push(v.parse()?);
        }
    }
    Ok(cols)
}

fn compare(scope: &Path, periods: &Path) -> anyhow::Result<()> {
    let cap = capture::Capture::parse_csv(&std::fs::read_to_string(scope)?)?;
    let p = capture::reduce(&cap, None)?;
    let truth = read_periods(periods)?;
    let fs = 330e3;
    assert!((p.fs - fs).abs() < 1e-3 * fs, "fs measured {}", p.fs);
    assert!(p.time.len() >= 55, "{} periods", p.time.len());
    let (il, il_avg) = (p.il.clone().unwrap_or_default(), p.il_avg.clone().unwrap_or_default());
    let mut worst = [0.0f64; 5];
    for i in 0..p.time.len() {
        // The generator's period k starts at k·T; the switch node's rising edge lies up to the
        // dead time (30 ns, when il > 0 holds the node low through the body diode) plus half a
        // gate ramp (2.5 ns) later.
        let k = (p.time[i] * fs).round() as usize;
        assert!((p.time[i] - k as f64 / fs).abs() < 40e-9, "period {i} starts at {} s", p.time[i]);
        let errs = [p.duty[i] - truth["duty"][k], p.vout[i] - truth["vout"][k], p.vout_avg[i] - truth["vout_avg"][k], il[i] - truth["il"][k], il_avg[i] - truth["il_avg"][k]];
        for (w, e) in worst.iter_mut().zip(errs) {
            *w = w.max(e.abs());
        }
    }
    println!("worst |error|: duty {:.2e}, vout {:.2e} V, vout_avg {:.2e} V, il {:.2e} A, il_avg {:.2e} A", worst[0], worst[1], worst[2], worst[3], worst[4]);
    // Tolerances. The periods are cut at the switch node's rising edges, which lag the PWM
    // edges the generator cuts at by δ ≤ td + half a ramp = 32.5 ns (1.1 % of T) when il > 0.
    // duty: the node's duty against the commanded one, (td + ramp)·fs = 1.16e-2; vout at the
    // start 20 mV (4σ of one interpolated noisy sample); averages over a window shifted by δ:
    // vout_avg 4 mV (δ/T of the ripple plus σ/√295), il_avg 30 mA (δ/T of the 2.2 A p-p ripple);
    // il at the start 0.1 A (il slews ≈ 2 A/µs over δ, plus 4σ of noise).
    let tol = [35e-9 * fs, 20e-3, 4e-3, 0.1, 30e-3];
    for (w, t) in worst.iter().zip(tol) {
        assert!(w < &t, "worst {worst:?} against tolerances {tol:?}");
    }
    Ok(())
}

#[test]
fn ngspice_capture_matches_the_generators_periods() -> anyhow::Result<()> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/fixtures/capture");
    compare(&dir.join("sync_scope.csv"), &dir.join("sync_periods.csv"))
}

/// The same capture as a real scope would show it: `vout` rings at each switch-node edge (80 mV
/// at 60 MHz, 15 ns decay, from 5 ns before the edge's mid-level: a probe's ground lead and the
/// capacitors' ESL) and is read by an 8-bit channel at 1 V/div (steps of 31 mV). Each period's
/// start value, a straight line through the stretch before the edge, stays within 20 mV of the
/// generator's, RMS within 10 mV (measured 15 and 8.6 mV); the value at the edge itself was up
/// to 60 mV off, RMS 35 mV.
/// (The first period is left out: the capture begins at its edge, so its start is read there.)
#[test]
fn a_ringing_8_bit_capture_keeps_its_start_values() -> anyhow::Result<()> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/fixtures/capture");
    let mut cap = capture::Capture::parse_csv(&std::fs::read_to_string(dir.join("sync_scope.csv"))?)?;
    let sw = cap.sw.clone().ok_or_else(|| anyhow::anyhow!("the fixture has sw"))?;
    let (lo, hi) = sw.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &x| (lo.min(x), hi.max(x)));
    let mid = 0.5 * (lo + hi);
    let crossings: Vec<f64> = (1..sw.len()).filter(|&i| (sw[i - 1] < mid) != (sw[i] < mid)).map(|i| cap.time[i]).collect();
    let lsb = 8.0 / 256.0;
    for (t, v) in cap.time.iter().zip(cap.vout.iter_mut()) {
        let k = crossings.partition_point(|c| *c - 5e-9 <= *t);
        if let Some(start) = k.checked_sub(1).map(|j| crossings[j] - 5e-9) {
            let x = t - start;
            *v += 0.08 * (2.0 * std::f64::consts::PI * 60e6 * x).sin() * (-x / 15e-9).exp();
        }
        *v = 4.6 + ((*v - 4.6) / lsb).round() * lsb;
    }
    let p = capture::reduce(&cap, None)?;
    let truth = read_periods(&dir.join("sync_periods.csv"))?;
    let errors: Vec<f64> = p.time.iter().zip(&p.vout).skip(1).map(|(t, v)| v - truth["vout"][(t * 330e3).round() as usize]).collect();
    let worst = errors.iter().fold(0.0f64, |w, e| w.max(e.abs()));
    let rms = (errors.iter().map(|e| e * e).sum::<f64>() / errors.len() as f64).sqrt();
    assert!(worst < 20e-3 && rms < 10e-3, "vout at the period starts: worst {worst:e} V, RMS {rms:e} V");
    Ok(())
}
