//! Experiment design and plants: a PRBS duty between two levels, constant load current, one
//! sample per switching period, optional seeded measurement noise.
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

use buck_model::variables::VarId;
use buck_model::{Converter, Mode, Params};

use crate::data::DataSet;
use crate::error::EstimatorError;

/// Maximal-length pseudo-random binary sequence from a Fibonacci LFSR.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Prbs {
    /// Low duty level.
    pub low: f64,
    /// High duty level.
    pub high: f64,
    /// Periods per bit.
    pub bit_periods: usize,
    /// Register length (3..=16); the sequence repeats after `2^order − 1` bits.
    pub order: u32,
    /// Selects the initial register state (any value; 0 is mapped to a non-zero state).
    pub seed: u64,
}

impl Default for Prbs {
    fn default() -> Self {
        Self { low: 0.4, high: 0.6, bit_periods: 8, order: 10, seed: 1 }
    }
}

/// Feedback taps (1-based, from the output end) of maximal-length LFSRs.
fn taps(order: u32) -> Option<(u32, u32)> {
    Some(match order {
        3 => (3, 2),
        4 => (4, 3),
        5 => (5, 3),
        6 => (6, 5),
        7 => (7, 6),
        8 => (8, 6), // x^8 + x^6 + x^5 + x^4 + 1 needs four taps; handled below
        9 => (9, 5),
        10 => (10, 7),
        11 => (11, 9),
        12 => (12, 6), // four taps, handled below
        13 => (13, 4), // four taps, handled below
        14 => (14, 5), // four taps, handled below
        15 => (15, 14),
        16 => (16, 15), // four taps, handled below
        _ => return None,
    })
}

/// Extra taps for the orders whose maximal polynomials are not trinomials.
fn extra_taps(order: u32) -> &'static [u32] {
    match order {
        8 => &[5, 4],
        12 => &[4, 1],
        13 => &[3, 1],
        14 => &[3, 1],
        16 => &[13, 4],
        _ => &[],
    }
}

impl Prbs {
    /// Checks the settings.
    pub fn validate(&self) -> Result<(), EstimatorError> {
        // Levels are duties in open loop and duty dither (which may be negative) in closed loop.
        let in_range = |x: f64| (-1.0..=1.0).contains(&x);
        if !(in_range(self.low) && in_range(self.high)) || self.low == self.high {
            return Err(EstimatorError::Config(format!("PRBS levels {} and {} must be distinct values in −1..1", self.low, self.high)));
        }
        if self.bit_periods == 0 {
            return Err(EstimatorError::Config("PRBS bit length must be at least one period".into()));
        }
        if taps(self.order).is_none() {
            return Err(EstimatorError::Config(format!("PRBS order {} is not in 3..=16", self.order)));
        }
        Ok(())
    }

    /// The bit sequence (one value per bit, `2^order − 1` long before it repeats).
    pub fn bits(&self, count: usize) -> Result<Vec<bool>, EstimatorError> {
        self.validate()?;
        let (a, b) = taps(self.order).ok_or_else(|| EstimatorError::Config("bad order".into()))?;
        let mask = (1u32 << self.order) - 1;
        let mut reg = (self.seed as u32 ^ (self.seed >> 32) as u32) & mask;
        if reg == 0 {
            reg = mask;
        }
        let mut out = Vec::with_capacity(count);
        for _ in 0..count {
            out.push(reg & 1 == 1);
            let mut fb = (reg >> (self.order - a)) ^ (reg >> (self.order - b));
            for t in extra_taps(self.order) {
                fb ^= reg >> (self.order - t);
            }
            reg = ((reg >> 1) | ((fb & 1) << (self.order - 1))) & mask;
        }
        Ok(out)
    }

    /// Duty per switching period for `periods` periods.
    pub fn duties(&self, periods: usize) -> Result<Vec<f64>, EstimatorError> {
        let bits = self.bits(periods.div_ceil(self.bit_periods.max(1)))?;
        Ok((0..periods).map(|k| if bits[k / self.bit_periods] { self.high } else { self.low }).collect())
    }
}

/// What to run on a plant.
#[derive(Debug, Clone, PartialEq)]
pub struct Experiment {
    /// Samples to record (one per switching period).
    pub samples: usize,
    /// Periods run before recording starts, so the record begins in periodic steady state.
    pub warmup: usize,
    /// Duty excitation.
    pub prbs: Prbs,
    /// Constant load current \[A\].
    pub io: f64,
    /// Input voltage \[V\].
    pub vin: f64,
    /// Standard deviation of white noise added to `vout` (and `vout_avg`) \[V\].
    pub noise_vout: f64,
    /// Standard deviation of white noise added to `il` (and `il_avg`) \[A\].
    pub noise_il: f64,
    /// Standard deviation of an unmeasured load-current disturbance \[A\], drawn afresh every
    /// period and applied to the plant (process noise); the recorded `io` stays the nominal.
    pub noise_load: f64,
    /// Seed of the noise.
    pub noise_seed: u64,
    /// Record the duty the plant reports as applied (closed loop: the controller's output)
    /// instead of the excitation.
    pub record_applied_duty: bool,
}

impl Default for Experiment {
    fn default() -> Self {
        Self { samples: 3001, warmup: 64, prbs: Prbs::default(), io: 1.0, vin: 12.0, noise_vout: 0.0, noise_il: 0.0, noise_load: 0.0, noise_seed: 7, record_applied_duty: false }
    }
}

/// Raw samples a plant returns for one period (before noise).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PeriodSample {
    /// Output voltage at the period start \[V\].
    pub vout: f64,
    /// Inductor current at the period start \[A\], when the plant has one.
    pub il: Option<f64>,
    /// Averages over the period, when the plant offers them: `(vout, il)`.
    pub average: Option<(f64, f64)>,
    /// Duty that drove the switch in the period just run, when the plant reports it.
    pub duty_applied: Option<f64>,
}

/// Anything that can be driven one switching period at a time: our model in process, an FMU,
/// a third-party model. Implementations keep their own notion of time.
pub trait Plant {
    /// Switching frequency \[Hz\] the experiment steps at.
    fn switching_frequency(&self) -> f64;
    /// Sets the inputs and starts at the operating point of these inputs (period start).
    fn start(&mut self, duty: f64, io: f64, vin: f64) -> Result<(), EstimatorError>;
    /// Outputs at the current period start.
    fn sample(&mut self) -> Result<PeriodSample, EstimatorError>;
    /// Applies the excitation `duty` (the duty command in open loop, the dither in closed loop)
    /// and load current `io` for one switching period; afterwards `sample` gives the next
    /// period start (and the averages and applied duty of the period just run).
    fn step_period(&mut self, duty: f64, io: f64) -> Result<(), EstimatorError>;
    /// Metadata describing the plant for the data set (`fs`, `L`, …).
    fn describe(&self) -> Vec<(String, String)>;
}

/// Runs `exp` on `plant` and records a data set (noise added here, seeded).
pub fn run(plant: &mut dyn Plant, exp: &Experiment) -> Result<DataSet, EstimatorError> {
    if exp.samples < 2 {
        return Err(EstimatorError::Config(format!("{} samples requested; at least 2 are needed", exp.samples)));
    }
    for (name, sigma) in [("noise on vout", exp.noise_vout), ("noise on il", exp.noise_il), ("load noise", exp.noise_load)] {
        if !(sigma >= 0.0 && sigma.is_finite()) {
            return Err(EstimatorError::Config(format!("{name} must be a finite σ ≥ 0, got {sigma}")));
        }
    }
    let duties = exp.prbs.duties(exp.samples + exp.warmup)?;
    let fs = plant.switching_frequency();
    // Load disturbance from its own stream, so adding it leaves the sensor noise unchanged.
    let mut load_rng = ChaCha8Rng::seed_from_u64(exp.noise_seed ^ 0x10AD);
    let load = Normal::new(0.0, exp.noise_load.max(f64::MIN_POSITIVE)).map_err(|e| EstimatorError::Config(e.to_string()))?;
    let mut io_at = move || if exp.noise_load > 0.0 { exp.io + load.sample(&mut load_rng) } else { exp.io };
    plant.start(duties[0], exp.io, exp.vin)?;
    for &d in &duties[..exp.warmup] {
        plant.step_period(d, io_at())?;
    }
    let mut data = DataSet::default();
    let (mut il, mut vavg, mut iavg) = (Vec::new(), Vec::new(), Vec::new());
    let mut has_avg = true;
    let mut has_il = true;
    // The averages of period k arrive after stepping it; the start sample of k before.
    let mut start = plant.sample()?;
    for (k, &d) in duties[exp.warmup..].iter().enumerate() {
        plant.step_period(d, io_at())?;
        let next = plant.sample()?;
        data.time.push(k as f64 / fs);
        data.duty.push(match (exp.record_applied_duty, next.duty_applied) {
            (true, Some(applied)) => applied,
            (true, None) => {
                return Err(EstimatorError::Plant("the plant does not report the applied duty (role duty_applied)".into()));
            }
            (false, _) => d,
        });
        data.vin.push(exp.vin);
        data.io.push(exp.io);
        data.vout.push(start.vout);
        match start.il {
            Some(i) => il.push(i),
            None => has_il = false,
        }
        match next.average {
            Some((v, i)) => {
                vavg.push(v);
                iavg.push(i);
            }
            None => has_avg = false,
        }
        start = next;
    }
    let mut rng = ChaCha8Rng::seed_from_u64(exp.noise_seed);
    let mut add_noise = |v: &mut Vec<f64>, sigma: f64| {
        if sigma > 0.0 {
            let normal = Normal::new(0.0, sigma).unwrap_or_else(|_| unreachable!("σ checked above"));
            v.iter_mut().for_each(|x| *x += normal.sample(&mut rng));
        }
    };
    add_noise(&mut data.vout, exp.noise_vout);
    if has_il {
        add_noise(&mut il, exp.noise_il);
        data.il = Some(il);
    }
    if has_avg {
        add_noise(&mut vavg, exp.noise_vout);
        add_noise(&mut iavg, exp.noise_il);
        data.vout_avg = Some(vavg);
        data.il_avg = Some(iavg);
    }
    data.meta = plant.describe().into_iter().collect();
    data.meta.insert("fs".into(), format!("{fs}"));
    data.meta.insert("U".into(), format!("{}", exp.vin));
    data.meta.insert("noise_vout".into(), format!("{}", exp.noise_vout));
    data.meta.insert("noise_il".into(), format!("{}", exp.noise_il));
    if exp.noise_load > 0.0 {
        data.meta.insert("noise_load".into(), format!("{}", exp.noise_load));
    }
    Ok(data)
}

/// The `buck-model` converter in process, as a plant.
#[derive(Debug, Clone)]
pub struct ModelPlant {
    converter: Converter,
    /// The input the experiment's excitation drives (`duty`, or `duty_dither` in closed loop).
    excite: VarId,
    /// Report the ADC readings (the digital controller's view) instead of the true samples.
    adc: bool,
}

impl ModelPlant {
    /// A plant with these parameters in this mode.
    pub fn new(params: Params, mode: Mode) -> Self {
        Self { converter: Converter::new(params, mode), excite: VarId::Duty, adc: false }
    }

    /// A configured converter in open loop: the experiment drives `duty`, the samples are the
    /// true period-start values.
    pub fn with_converter_in_open_loop(converter: Converter) -> Self {
        Self { converter, excite: VarId::Duty, adc: false }
    }

    /// The same plant reporting the ADC readings (`vout_adc`, `il_adc`: quantization and sensor
    /// noise of the digital controller's converter) instead of the true period-start samples.
    pub fn reading_adc(self) -> Self {
        Self { adc: true, ..self }
    }

    /// A configured converter in closed loop: the experiment drives `duty_dither`, and the
    /// samples are the ADC readings the controller sees (with its sensor noise).
    pub fn closed_loop(converter: Converter) -> Self {
        Self { converter, excite: VarId::Dither, adc: true }
    }
}

fn plant_err(e: buck_model::ModelError) -> EstimatorError {
    EstimatorError::Plant(e.to_string())
}

impl Plant for ModelPlant {
    fn switching_frequency(&self) -> f64 {
        self.converter.params().fs
    }

    fn start(&mut self, duty: f64, io: f64, vin: f64) -> Result<(), EstimatorError> {
        self.converter.set(self.excite, duty).map_err(plant_err)?;
        self.converter.set(VarId::Io, io).map_err(plant_err)?;
        self.converter.set(VarId::Vin, vin).map_err(plant_err)?;
        self.converter.initialize();
        Ok(())
    }

    fn sample(&mut self) -> Result<PeriodSample, EstimatorError> {
        let y = self.converter.outputs();
        let (vout, il) = if self.adc { (y.vout_adc, y.il_adc) } else { (y.vout, y.il) };
        Ok(PeriodSample { vout, il: Some(il), average: Some((y.vout_avg, y.il_avg)), duty_applied: Some(y.duty_applied) })
    }

    fn step_period(&mut self, duty: f64, io: f64) -> Result<(), EstimatorError> {
        self.converter.set(self.excite, duty).map_err(plant_err)?;
        self.converter.set(VarId::Io, io).map_err(plant_err)?;
        self.converter.step(self.converter.params().period()).map_err(plant_err)
    }

    fn describe(&self) -> Vec<(String, String)> {
        let p = self.converter.params();
        let mode = match self.converter.mode() {
            Mode::Averaged => "averaged",
            Mode::Switched => "switched",
        };
        let mut meta = vec![
            ("source".into(), format!("buck-model in process ({mode})")),
            ("L".into(), format!("{}", p.l)),
            ("RL".into(), format!("{}", p.rl)),
            ("C".into(), format!("{}", p.c)),
            ("Rc".into(), format!("{}", p.rc)),
        ];
        if p.rload > 0.0 {
            meta.push(("rload".into(), format!("{}", p.rload)));
        }
        meta
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every supported order yields a maximal-length sequence: period 2^n − 1 with
    /// 2^(n−1) ones per period.
    #[test]
    fn lfsr_is_maximal_length() {
        for order in 3..=16 {
            let prbs = Prbs { order, seed: 5, ..Default::default() };
            let len = (1usize << order) - 1;
            let bits = prbs.bits(2 * len).unwrap();
            assert_eq!(bits[..len], bits[len..], "order {order} does not repeat after {len}");
            let ones = bits[..len].iter().filter(|b| **b).count();
            assert_eq!(ones, 1 << (order - 1), "order {order}");
            // Not periodic with any shorter divisor period.
            for p in (1..len).filter(|p| len.is_multiple_of(*p)) {
                assert_ne!(bits[..len - p], bits[p..len], "order {order} has period {p}");
            }
        }
    }

    #[test]
    fn duties_hold_each_bit_and_use_both_levels() {
        let prbs = Prbs::default();
        let d = prbs.duties(800).unwrap();
        assert!(d.chunks(8).all(|c| c.iter().all(|&x| x == c[0])));
        assert!(d.contains(&0.4) && d.contains(&0.6));
        assert!(Prbs { low: 0.5, high: 0.5, ..prbs }.duties(10).is_err());
        assert!(Prbs { bit_periods: 0, ..prbs }.duties(10).is_err());
    }

    #[test]
    fn run_records_aligned_samples_and_seeded_noise() {
        let exp = Experiment { samples: 200, noise_vout: 2e-3, ..Default::default() };
        let mut plant = ModelPlant::new(Params::default(), Mode::Switched);
        let a = run(&mut plant, &exp).unwrap();
        let b = run(&mut plant, &exp).unwrap();
        assert_eq!(a, b, "same seed, same data");
        a.validate().unwrap();
        let clean = run(&mut plant, &Experiment { noise_vout: 0.0, ..exp.clone() }).unwrap();
        let diff: Vec<f64> = a.vout.iter().zip(&clean.vout).map(|(x, y)| x - y).collect();
        let sd = (diff.iter().map(|d| d * d).sum::<f64>() / diff.len() as f64).sqrt();
        assert!((sd - 2e-3).abs() < 0.3e-3, "noise σ {sd}");
        assert_eq!(a.il, clean.il, "no noise asked on il");
    }

    /// Measures vout only, like a third-party FMU without an inductor current.
    struct VoutOnly(ModelPlant);

    impl Plant for VoutOnly {
        fn switching_frequency(&self) -> f64 {
            self.0.switching_frequency()
        }
        fn start(&mut self, duty: f64, io: f64, vin: f64) -> Result<(), EstimatorError> {
            self.0.start(duty, io, vin)
        }
        fn sample(&mut self) -> Result<PeriodSample, EstimatorError> {
            Ok(PeriodSample { il: None, average: None, ..self.0.sample()? })
        }
        fn step_period(&mut self, duty: f64, io: f64) -> Result<(), EstimatorError> {
            self.0.step_period(duty, io)
        }
        fn describe(&self) -> Vec<(String, String)> {
            self.0.describe()
        }
    }

    #[test]
    fn a_plant_without_il_records_vout_and_no_il_column() {
        let exp = Experiment { samples: 200, noise_il: 1e-3, ..Default::default() };
        let plant = || ModelPlant::new(Params::default(), Mode::Switched);
        let data = run(&mut VoutOnly(plant()), &exp).unwrap();
        data.validate().unwrap();
        assert!(data.il.is_none() && data.il_avg.is_none());
        assert_eq!(data.vout, run(&mut plant(), &exp).unwrap().vout, "the same vout as the full plant");
    }
}
