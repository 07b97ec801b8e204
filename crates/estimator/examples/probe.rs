use buck_model::{Mode, Params};
use estimator::experiment::{run, Experiment, ModelPlant};
use estimator::model::{Free, Model, Sampling, Signal, Structure};
use estimator::pem::{fit, FitOptions, NoiseModel};
use std::time::Instant;

fn main() {
    let noise = std::env::args().nth(1).map(|s| s == "kalman").unwrap_or(false);
    for (mode, structure, outs) in [
        (Mode::Averaged, Structure::Averaged, vec![Signal::Vout]),
        (Mode::Switched, Structure::Pwm, vec![Signal::Vout]),
        (Mode::Switched, Structure::Averaged, vec![Signal::Vout]),
        (Mode::Switched, Structure::Pwm, vec![Signal::Vout, Signal::Il]),
    ] {
        println!("plant {mode:?} model {structure:?} outputs {outs:?}");
        for cl in [0.2e-6, 0.5e-6, 1e-6, 2e-6, 5e-6, 10e-6, 50e-6, 100e-6] {
            let truth = Params { cl, ..Params::default() };
            let exp = Experiment { samples: 3001, noise_vout: 2e-3, noise_il: 20e-3, ..Experiment::default() };
            let data = run(&mut ModelPlant::new(truth, mode), &exp).unwrap();
            let model = Model::new(structure, Sampling::PeriodStart, &outs, &[Free::Cl], &data, truth.period()).unwrap();
            let t = Instant::now();
            let opts = FitOptions { noise: if noise { NoiseModel::Innovations } else { NoiseModel::OutputError }, ..Default::default() };
            let f = fit(&model, &Params::default(), &opts).unwrap();
            let dt = t.elapsed();
            let e = f.estimate("Cl").unwrap();
            println!("  Cl {:7.2} µF: est {:8.3} µF  err {:+7.2} %  ci [{:.3}, {:.3}]  relsd {:.3} it {} {:.2} ms", cl*1e6, e.value*1e6, (e.value/cl-1.0)*100.0, e.ci95.0*1e6, e.ci95.1*1e6, e.rel_std, f.iterations, dt.as_secs_f64()*1e3);
        }
    }
}
