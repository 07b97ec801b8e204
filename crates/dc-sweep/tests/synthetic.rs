//! Synthetic sweeps from the DC model itself with known effects and seeded noise: recovered
//! within their CI95; too little data gives the plain "cannot support" answer.
use dc_sweep::{Circuit, Effects, OperatingPoint, Options, Sweep, diagnose, solve};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

fn sweep(c: &Circuit, e: &Effects, points: &[OperatingPoint], sigma: f64, seed: u64) -> Sweep {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let noise = Normal::new(0.0, sigma).unwrap_or_else(|_| unreachable!());
    let vout = points.iter().map(|op| solve(c, e, op).map(|s| s.vout).unwrap_or(f64::NAN) + noise.sample(&mut rng)).collect();
    Sweep { points: points.to_vec(), vout, ..Sweep::default() }
}

fn grid() -> Vec<OperatingPoint> {
    let mut v = Vec::new();
    for d in [0.2, 0.35, 0.5, 0.65, 0.8] {
        for io in [2.0, 5.0] {
            v.push(OperatingPoint { duty: d, vin: 12.0, io, rload: None });
        }
    }
    v
}

#[test]
fn diode_drop_and_series_resistance_are_recovered_within_their_ci() {
    let c = Circuit { l: 10e-6, rl: 0.05, fs: 200e3, ..Circuit::default() };
    let truth = Effects { diode: true, diode_drop: 0.45, r_series: 0.08, ..Effects::default() };
    let mut hits = 0;
    for seed in 0..5 {
        let s = sweep(&c, &truth, &grid(), 2e-3, seed);
        let d = diagnose(&s, &c, &Options::default()).unwrap();
        let fin = d.final_fit.unwrap();
        let vf = fin.params["diode_drop"]["vf"];
        let ci = fin.ci95["diode_drop"]["vf"];
        let r = fin.params["switch_resistance"]["r_series"];
        let rci = fin.ci95["switch_resistance"]["r_series"];
        assert!((vf - 0.45).abs() < 0.02 && (r - 0.08).abs() < 0.01, "seed {seed}: vf {vf} r {r}");
        hits += usize::from(ci[0] <= 0.45 && 0.45 <= ci[1]) + usize::from(rci[0] <= 0.08 && 0.08 <= rci[1]);
        assert_eq!(d.selected.len(), 2, "seed {seed}: {:?}", d.selected.iter().map(|s| s.name).collect::<Vec<_>>());
    }
    // 10 intervals at 95 %: at least 8 cover (P(≤ 7) < 1.2 %).
    assert!(hits >= 8, "{hits}/10 intervals cover the truth");
}

#[test]
fn dead_time_is_recovered_in_a_synchronous_buck() {
    let c = Circuit { l: 3.3e-6, rl: 0.1, fs: 330e3, ..Circuit::default() };
    let truth = Effects { dead_time: 40e-9, ..Effects::default() };
    let s = sweep(&c, &truth, &grid(), 1e-3, 7);
    let d = diagnose(&s, &c, &Options::default()).unwrap();
    assert_eq!(d.verdict, "dead_time");
    let fin = d.final_fit.unwrap();
    let ci = fin.ci95["dead_time"]["td"];
    assert!(ci[0] <= 40e-9 && 40e-9 <= ci[1], "{ci:?}");
}

#[test]
fn the_ideal_converter_gives_none() {
    let c = Circuit::default();
    let s = sweep(&c, &Effects::default(), &grid(), 1e-3, 3);
    let d = diagnose(&s, &c, &Options::default()).unwrap();
    assert_eq!(d.verdict, "none");
    assert!(d.selected.is_empty());
}

#[test]
fn too_few_or_identical_points_cannot_support_an_answer() {
    let c = Circuit::default();
    let truth = Effects { diode: true, diode_drop: 0.45, ..Effects::default() };
    let same = vec![OperatingPoint { duty: 0.5, vin: 12.0, io: 2.0, rload: None }; 6];
    for points in [same, grid()[..2].to_vec()] {
        let s = sweep(&c, &truth, &points, 1e-3, 1);
        let d = diagnose(&s, &c, &Options::default()).unwrap();
        assert!(!d.supported);
        assert!(d.message.as_deref().is_some_and(|m| m.contains("cannot support")), "{:?}", d.message);
        assert_eq!(d.verdict, "none");
        assert!(d.effects.iter().all(|e| e.params.is_none()));
    }
    // Three points carry one parameter, not two: the two-parameter steps say so.
    let s = sweep(&c, &truth, &grid()[..3], 1e-3, 1);
    let d = diagnose(&s, &c, &Options::default()).unwrap();
    assert!(d.supported);
}
