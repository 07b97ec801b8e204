// scratch
use buck_model::Params;
use estimator::model::Free;
use estimator::simulated::{fit_from_exactly, Criterion};
fn main() {
    let a: Vec<String> = std::env::args().collect();
    let d = estimator::data::DataSet::read_csv(a[1].as_ref()).unwrap();
    let nominal = Params { l: 10e-6, rl: 0.03, c: 220e-6, rc: 0.02, fs: 200e3, ..Params::default() };
    let n_est = 2001;
    let base = Params { cl: 21.7e-6, dead_time: 51.98e-9, switch_resistance: 0.01614, switch_node_capacitance: 757e-12, ..nominal };
    for sds in [vec![50e-9], vec![200e-9], vec![50e-9, 200e-9, 600e-9]] {
        let ps: Vec<Params> = sds.iter().map(|&sd| Params { sample_delay: sd, ..base }).collect();
        let sd = sds[0];
        let c = fit_from_exactly(&d, &ps, &[Free::Cl, Free::DeadTime, Free::SwitchResistance, Free::SwitchNodeCapacitance, Free::SampleDelay], n_est, Criterion::OutputError).unwrap();
        let r: f64 = (c.validation.traces.measured.iter().zip(&c.validation.traces.simulated).map(|(m, s)| (m - s).powi(2)).sum::<f64>() / c.validation.traces.measured.len() as f64).sqrt();
        println!("start {sd:e}: delay {:e} cl {:e} iters {} conv {} rms {r:e} cost {:e} x0 {:?}", c.fit.params.sample_delay, c.fit.params.cl, c.fit.iterations, c.fit.converged, c.fit.cost, c.fit.x0);
    }
}
