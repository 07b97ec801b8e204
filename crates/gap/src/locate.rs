//! Where the nominal model misses: the held-out residual broken down by frequency band, by
//! operating point and by time window, each against the noise floor (white sensor noise
//! estimated from the data alone; where that is impossible, the residual that the best
//! significant model leaves).
use estimator::data::DataSet;
use serde::Serialize;

/// Residual power in one frequency band.
#[derive(Debug, Clone, Serialize)]
pub struct Band {
    /// Lower band edge \[Hz\].
    pub from_hz: f64,
    /// Upper band edge \[Hz\].
    pub to_hz: f64,
    /// Mean residual power spectral density against the floor's in this band \[dB\].
    pub db_over_floor: f64,
}

/// Residual statistics of a group of samples.
#[derive(Debug, Clone, Serialize)]
pub struct Group {
    /// What the group is (e.g. `duty = 0.6`, `il < 0`, `window 3/5`).
    pub label: String,
    /// Samples in the group.
    pub samples: usize,
    /// Residual RMS \[V\].
    pub rms: f64,
    /// Residual mean \[V\] (a bias at this operating point).
    pub mean: f64,
    /// RMS against the noise floor's RMS.
    pub rms_over_floor: f64,
}

/// What the gap is compared with.
#[derive(Debug, Clone, Copy)]
pub(crate) enum Floor<'a> {
    /// White sensor noise of this RMS \[V\], estimated from the data alone.
    White(f64),
    /// The residual a model leaves (when the data gives no model-free estimate).
    Residual(&'a [f64]),
}

/// How the noise floor was found.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum FloorSource {
    /// White noise from fourth differences of `vout` between input steps, no model involved.
    Differences,
    /// The residual of the best significant model (the inputs step too often for the former).
    ModelResidual,
}

impl FloorSource {
    /// One line for people.
    pub fn describe(self) -> &'static str {
        match self {
            Self::Differences => "white noise from fourth differences of vout between input steps (no model)",
            Self::ModelResidual => "the residual of the best significant model (the inputs step too often for a model-free estimate)",
        }
    }
}

/// The breakdown of the gap.
#[derive(Debug, Clone, Serialize)]
pub struct Where {
    /// RMS of the noise floor \[V\].
    pub noise_floor_rms: f64,
    /// How the noise floor was found.
    pub noise_floor_from: FloorSource,
    /// By frequency band (log-spaced up to the Nyquist frequency).
    pub bands: Vec<Band>,
    /// By operating point: duty level; sign and size of il, and DCM, when il is measured.
    pub operating_points: Vec<Group>,
    /// By time window of the held-out part.
    pub windows: Vec<Group>,
    /// One sentence: the worst band, operating point and window.
    pub summary: String,
}

const SEGMENT: usize = 256;
const BANDS: usize = 6;

/// The Hann window of `n` points (periodic).
fn hann(n: usize) -> Vec<f64> {
    (0..n).map(|i| 0.5 - 0.5 * (2.0 * std::f64::consts::PI * i as f64 / n as f64).cos()).collect()
}

/// Welch periodogram (Hann window, 50 % overlap) of `x`, `SEGMENT/2 + 1` bins from 0 to fs/2.
fn psd(x: &[f64]) -> Vec<f64> {
    let n = SEGMENT.min(x.len());
    let window = hann(n);
    let mut acc = vec![0.0; n / 2 + 1];
    let mut segments = 0;
    let mut start = 0;
    while start + n <= x.len() {
        let seg = &x[start..start + n];
        let mean = seg.iter().sum::<f64>() / n as f64;
        for (k, a) in acc.iter_mut().enumerate() {
            let (mut re, mut im) = (0.0, 0.0);
            for (i, (v, w)) in seg.iter().zip(&window).enumerate() {
                let phi = -2.0 * std::f64::consts::PI * (k * i) as f64 / n as f64;
                re += (v - mean) * w * phi.cos();
                im += (v - mean) * w * phi.sin();
            }
            *a += re * re + im * im;
        }
        segments += 1;
        start += n / 2;
    }
    acc.iter().map(|a| a / segments.max(1) as f64).collect()
}

fn group(label: String, r: &[f64], floor_rms: f64) -> Group {
    let n = r.len().max(1) as f64;
    let mean = r.iter().sum::<f64>() / n;
    let rms = crate::effect::rms(r);
    Group { label, samples: r.len(), rms, mean, rms_over_floor: rms / floor_rms.max(1e-300) }
}

/// Breaks the nominal model's held-out residual `residual` down (samples `n_est..` of `data`).
pub(crate) fn locate(data: &DataSet, n_est: usize, residual: &[f64], floor: Floor<'_>) -> Where {
    let n = residual.len().min(data.len() - n_est);
    let residual = &residual[..n];
    let fs = 1.0 / data.sample_period();
    let pr = psd(residual);
    let bins = pr.len();
    let (floor_rms, pf, noise_floor_from) = match floor {
        Floor::White(sigma) => {
            // White noise of variance σ² has σ²·Σw² in every bin of the Hann-windowed periodogram.
            let w2: f64 = hann(SEGMENT.min(n)).iter().map(|w| w * w).sum();
            (sigma, vec![sigma * sigma * w2; bins], FloorSource::Differences)
        }
        Floor::Residual(r) => {
            let r = &r[..n.min(r.len())];
            (crate::effect::rms(r), psd(r), FloorSource::ModelResidual)
        }
    };
    let edges: Vec<usize> = (0..=BANDS).map(|b| (((bins - 1) as f64).powf(b as f64 / BANDS as f64)).round() as usize).collect();
    let bands = edges
        .windows(2)
        .filter(|w| w[1] > w[0])
        .map(|w| {
            let (a, b) = (w[0].max(1), w[1]);
            let r: f64 = pr[a..=b].iter().sum();
            let f: f64 = pf[a..=b].iter().sum();
            let hz = |i: usize| i as f64 * fs / SEGMENT as f64;
            Band { from_hz: hz(a), to_hz: hz(b), db_over_floor: 10.0 * (r / f.max(1e-300)).log10() }
        })
        .collect::<Vec<_>>();

    let duty = &data.duty[n_est..n_est + n];
    let mut levels: Vec<f64> = duty.to_vec();
    levels.sort_by(f64::total_cmp);
    levels.dedup();
    let mut operating_points = Vec::new();
    if levels.len() <= 6 {
        for l in levels {
            let r: Vec<f64> = (0..n).filter(|&k| duty[k] == l).map(|k| residual[k]).collect();
            operating_points.push(group(format!("duty = {l}"), &r, floor_rms));
        }
    } else {
        let q = |p: f64| levels[((levels.len() - 1) as f64 * p) as usize];
        let (lo, hi) = (q(1.0 / 3.0), q(2.0 / 3.0));
        for (label, keep) in [
            (format!("duty < {lo:.3}"), Box::new(move |d: f64| d < lo) as Box<dyn Fn(f64) -> bool>),
            (format!("{lo:.3} ≤ duty < {hi:.3}"), Box::new(move |d: f64| d >= lo && d < hi)),
            (format!("duty ≥ {hi:.3}"), Box::new(move |d: f64| d >= hi)),
        ] {
            let r: Vec<f64> = (0..n).filter(|&k| keep(duty[k])).map(|k| residual[k]).collect();
            operating_points.push(group(label, &r, floor_rms));
        }
    }
    if let Some(il) = &data.il {
        let il = &il[n_est..n_est + n];
        let peak = il.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let dcm = |v: f64| v.abs() < 0.01 * peak;
        let classes: [(&str, &dyn Fn(f64) -> bool); 3] =
            [("il < 0 at the period start", &|v| v < 0.0 && !dcm(v)), ("il > 0 at the period start", &|v| v > 0.0 && !dcm(v)), ("il ≈ 0 at the period start (DCM or a zero crossing)", &dcm)];
        for (label, keep) in classes {
            let r: Vec<f64> = (0..n).filter(|&k| keep(il[k])).map(|k| residual[k]).collect();
            if !r.is_empty() {
                operating_points.push(group(label.to_string(), &r, floor_rms));
            }
        }
    }
    let windows: Vec<Group> = (0..5)
        .map(|w| {
            let (a, b) = (w * n / 5, (w + 1) * n / 5);
            group(format!("window {}/5", w + 1), &residual[a..b], floor_rms)
        })
        .collect();
    let worst_band = bands.iter().max_by(|a, b| a.db_over_floor.total_cmp(&b.db_over_floor));
    let worst = |g: &[Group]| g.iter().filter(|x| x.samples > 0).max_by(|a, b| a.rms_over_floor.total_cmp(&b.rms_over_floor)).cloned();
    let summary = match (worst_band, worst(&operating_points), worst(&windows)) {
        (Some(b), Some(o), Some(w)) => format!(
            "largest miss in {:.3}–{:.3} kHz ({:+.1} dB over the floor), at {} ({:.1}× the floor), in {} ({:.1}×)",
            b.from_hz / 1e3,
            b.to_hz / 1e3,
            b.db_over_floor,
            o.label,
            o.rms_over_floor,
            w.label,
            w.rms_over_floor
        ),
        _ => "too few held-out samples to break the gap down".to_string(),
    };
    Where { noise_floor_rms: floor_rms, noise_floor_from, bands, operating_points, windows, summary }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A sine at a known bin shows up in the band that holds it, white noise is flat.
    #[test]
    fn periodogram_finds_a_tone_in_its_bin() {
        let n = 2048;
        let x: Vec<f64> = (0..n).map(|i| (2.0 * std::f64::consts::PI * 32.0 * i as f64 / SEGMENT as f64).sin()).collect();
        let p = psd(&x);
        let peak = p.iter().enumerate().max_by(|a, b| a.1.total_cmp(b.1)).map(|(i, _)| i);
        assert_eq!(peak, Some(32));
    }
}
