//! What the diagnosis says about switched-plant data carrying each plant effect (one at a time,
//! σ = 2 mV, 3001 samples, Cl = 4.7 µF): a survey of the current candidate set, not a test.
//!
//! `cargo run --release -p gap --example survey`
use buck_model::variables::VarId;
use buck_model::{Converter, Mode, Params};
use estimator::experiment::{Experiment, ModelPlant, run};
use gap::{DiagnoseOptions, Nominal, diagnose};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let cases: [(&str, &[(VarId, f64)]); 10] = [
        ("(none)", &[]),
        ("switch_resistance", &[(VarId::SwitchResistance, 0.02)]),
        ("diode_drop", &[(VarId::DiodeDrop, 0.45)]),
        ("dcm", &[(VarId::Dcm, 1.0)]),
        ("dead_time", &[(VarId::DeadTime, 30e-9)]),
        ("load_esr", &[(VarId::LoadEsr, 0.02)]),
        ("esl", &[(VarId::Esl, 1e-9)]),
        ("delay", &[(VarId::Delay, 1.0)]),
        ("inductor_saturation", &[(VarId::InductorSaturation, 0.2), (VarId::Isat, 1.5)]),
        ("cap_dc_bias", &[(VarId::CapDcBias, 0.5)]),
    ];
    println!("| withheld effect (switched plant) | verdict | gap closed [%] | Cl [µF] (true 4.7) | seconds |");
    println!("|---|---|---:|---:|---:|");
    for (name, settings) in cases {
        let mut c = Converter::new(Params { cl: 4.7e-6, ..Params::default() }, Mode::Switched);
        for (id, v) in settings {
            c.set(*id, *v)?;
        }
        let exp = Experiment { samples: 3001, noise_vout: 2e-3, noise_seed: 11, ..Experiment::default() };
        let mut data = run(&mut ModelPlant::with_converter_in_open_loop(c), &exp)?;
        data.meta.retain(|k, _| k == "fs" || k == "U");
        let t = std::time::Instant::now();
        let dx = diagnose(&data, &Params::default(), &DiagnoseOptions { nominal: Nominal::Switched, ..DiagnoseOptions::default() })?;
        let seconds = t.elapsed().as_secs_f64();
        let best = dx.effects.iter().find(|e| e.name == dx.verdict);
        println!(
            "| {name} | {} | {:.1} | {:.3} | {seconds:.2} |",
            dx.verdict,
            best.map_or(0.0, |e| e.shrink_percent),
            best.map_or(dx.gap_before.cl, |e| e.cl.estimate) * 1e6
        );
    }
    Ok(())
}
