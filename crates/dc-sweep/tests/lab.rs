//! The student-lab sweep (tests/fixtures/sweep/lab24v.csv: 24 V, L = 100 µH, 10 Ω load, fs not
//! recorded and assumed 50 kHz, RL not recorded and assumed 0): what a physical reading needs.
use dc_sweep::{Circuit, Options, Sweep, diagnose};

#[test]
fn lab_sweep_is_read_as_diode_drop_plus_series_resistance() -> anyhow::Result<()> {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/fixtures/sweep/lab24v.csv");
    let sweep = Sweep::read_csv(&path)?;
    let (circuit, _) = sweep.circuit(&Circuit::default())?;
    let d = diagnose(&sweep, &circuit, &Options::default())?;
    assert!(d.supported);
    assert!(d.gap_before.rms > 0.5, "shortfall 0.46–1.01 V: {}", d.gap_before.rms);
    let names: Vec<&str> = d.selected.iter().map(|s| s.name).collect();
    assert!(names.contains(&"diode_drop") && names.contains(&"switch_resistance"), "{names:?}");
    assert_ne!(d.verdict, "none");
    let fin = d.final_fit.as_ref().ok_or_else(|| anyhow::anyhow!("no final fit"))?;
    for (effect, params) in &fin.params {
        for (name, v) in params {
            let ci = fin.ci95[effect][name];
            assert!(*v > 0.0 && ci[0] > 0.0 && ci[1] > ci[0], "{effect}.{name} = {v} CI {ci:?}");
        }
    }
    // Within a few tens of mV RMS after the two effects (a DMM reading to 10 mV; the 50 kHz
    // assumption puts duty 0.1 at the DCM boundary, the largest remaining miss).
    assert!(fin.gap.rms < 0.05, "rms after {}", fin.gap.rms);
    // Neither alone explains it: each single effect leaves several times that.
    for e in &d.effects {
        if e.name == "diode_drop" || e.name == "switch_resistance" {
            assert!(e.rms_after.is_some_and(|r| r > 3.0 * fin.gap.rms), "{} alone: {:?}", e.name, e.rms_after);
        }
    }
    Ok(())
}
