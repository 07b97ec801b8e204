//! Validation on held-out data: fit percentages for simulation and one-step prediction
//! (labelled separately), residual whiteness and residual–input independence at 99 %.

/// Lags used by the correlation tests.
pub const LAGS: usize = 25;
/// Standard normal 99.5 % quantile: two-sided 99 % band of one correlation coefficient.
const Z_995: f64 = 2.575_829;
/// Standard normal 99 % quantile: a one-sided 99 % bound in σ (and the one-sided chi-square
/// approximation).
pub const Z_99: f64 = 2.326_348;
/// Standard normal 97.5 % quantile: the half-width of a two-sided 95 % interval in σ.
pub const Z_975: f64 = 1.959_964;
/// Standard normal 95 % quantile: a one-sided 95 % bound in σ.
pub const Z_95: f64 = 1.644_854;
/// Widest ratio of a CI95's bounds for which a positive quantity counts as identified.
pub const IDENTIFIABLE_SPAN: f64 = 10.0;

/// Whether a CI95 pins a quantity down: finite, of one sign (zero excluded), its bounds within a
/// factor of [`IDENTIFIABLE_SPAN`] (a decade). A positive quantity's interval is positive; a
/// signed one's (an offset) may lie wholly below zero.
pub fn identified([lo, hi]: [f64; 2]) -> bool {
    let (near, far) = if hi < 0.0 { (-hi, -lo) } else { (lo, hi) };
    near > 0.0 && far.is_finite() && far < IDENTIFIABLE_SPAN * near
}

/// `100·(1 − ‖y − ŷ‖/‖y − ȳ‖)`: 100 % is a perfect fit, 0 % no better than the mean.
pub fn fit_percent(y: &[f64], yhat: &[f64]) -> f64 {
    let mean = y.iter().sum::<f64>() / y.len() as f64;
    let err: f64 = y.iter().zip(yhat).map(|(a, b)| (a - b).powi(2)).sum();
    let spread: f64 = y.iter().map(|a| (a - mean).powi(2)).sum();
    100.0 * (1.0 - (err / spread.max(1e-300)).sqrt())
}

/// Root-mean-square error normalized by the spread of `y` (`1 − fit/100`).
pub fn nrmse(y: &[f64], yhat: &[f64]) -> f64 {
    1.0 - fit_percent(y, yhat) / 100.0
}

/// Normalized correlation `Σ a[t]·b[t−lag] / (N·σa·σb)` of two demeaned signals.
pub fn correlation(a: &[f64], b: &[f64], lag: isize) -> f64 {
    let n = a.len().min(b.len());
    let demean = |v: &[f64]| {
        let m = v[..n].iter().sum::<f64>() / n as f64;
        v[..n].iter().map(|x| x - m).collect::<Vec<_>>()
    };
    let (a, b) = (demean(a), demean(b));
    let norm = (a.iter().map(|x| x * x).sum::<f64>() * b.iter().map(|x| x * x).sum::<f64>()).sqrt();
    if norm == 0.0 {
        return 0.0;
    }
    let mut s = 0.0;
    for t in 0..n as isize {
        let u = t - lag;
        if u >= 0 && (u as usize) < n {
            s += a[t as usize] * b[u as usize];
        }
    }
    s / norm
}

/// Upper 99 % quantile of χ² with `k` degrees of freedom (Wilson–Hilferty; < 1 % error for k ≥ 10).
pub fn chi2_99(k: usize) -> f64 {
    let k = k as f64;
    let h = 2.0 / (9.0 * k);
    k * (1.0 - h + Z_99 * h.sqrt()).powi(3)
}

/// Residual tests of one output.
#[derive(Debug, Clone, PartialEq)]
pub struct ResidualTests {
    /// Autocorrelation of the residual at lags 1..=[`LAGS`].
    pub acf: Vec<f64>,
    /// Cross-correlation residual vs input at lags −[`LAGS`]..=[`LAGS`].
    pub ccf: Vec<f64>,
    /// Half-width of the 99 % band of one coefficient, `2.576/√N`.
    pub band99: f64,
    /// Ljung–Box statistic over the autocorrelation lags.
    pub ljung_box: f64,
    /// Its 99 % critical value.
    pub ljung_box_limit: f64,
    /// `N·Σ r²` over the causal cross-correlation lags 0..=LAGS.
    pub ccf_statistic: f64,
    /// Its 99 % critical value.
    pub ccf_limit: f64,
}

impl ResidualTests {
    /// Runs both tests on residual `e` and input `u`.
    pub fn new(e: &[f64], u: &[f64]) -> Self {
        let n = e.len() as f64;
        let acf: Vec<f64> = (1..=LAGS as isize).map(|l| correlation(e, e, l)).collect();
        let ccf: Vec<f64> = (-(LAGS as isize)..=LAGS as isize).map(|l| correlation(e, u, l)).collect();
        let ljung_box = n * (n + 2.0) * acf.iter().enumerate().map(|(i, r)| r * r / (n - (i + 1) as f64)).sum::<f64>();
        let ccf_statistic = n * ccf[LAGS..].iter().map(|r| r * r).sum::<f64>();
        Self { acf, ccf, band99: Z_995 / n.sqrt(), ljung_box, ljung_box_limit: chi2_99(LAGS), ccf_statistic, ccf_limit: chi2_99(LAGS + 1) }
    }

    /// The residual is white at the 99 % level.
    pub fn white(&self) -> bool {
        self.ljung_box <= self.ljung_box_limit
    }

    /// The residual is uncorrelated with past inputs at the 99 % level.
    pub fn independent_of_input(&self) -> bool {
        self.ccf_statistic <= self.ccf_limit
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};

    fn noise(n: usize, seed: u64) -> Vec<f64> {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let d = Normal::new(0.0, 1.0).unwrap();
        (0..n).map(|_| d.sample(&mut rng)).collect()
    }

    #[test]
    fn fit_percent_references() {
        let y = [1.0, 2.0, 3.0, 4.0];
        assert_eq!(fit_percent(&y, &y), 100.0);
        assert!(fit_percent(&y, &[2.5; 4]).abs() < 1e-12, "the mean fits 0 %");
    }

    /// χ²₂₅ 99 % quantile is 44.314 (tables); Wilson–Hilferty is within 0.1 %.
    #[test]
    fn chi2_quantile_matches_tables() {
        assert!((chi2_99(25) - 44.314).abs() < 0.05, "{}", chi2_99(25));
        assert!((chi2_99(26) - 45.642).abs() < 0.05, "{}", chi2_99(26));
    }

    /// White noise passes about 99 % of the time, filtered noise and noise correlated with the
    /// input fail. Over 200 seeds the whiteness test's false-alarm rate is near 1 %.
    #[test]
    fn tests_separate_white_from_coloured() {
        let alarms = (0..200).filter(|s| !ResidualTests::new(&noise(2000, *s), &noise(2000, 1000 + s)).white()).count();
        assert!(alarms <= 8, "{alarms} false alarms out of 200 at the 1 % level");
        let w = noise(2000, 3);
        let coloured: Vec<f64> = w.windows(2).map(|p| p[0] + 0.8 * p[1]).collect();
        assert!(!ResidualTests::new(&coloured, &noise(1999, 4)).white());
        let u = noise(2000, 5);
        let leaky: Vec<f64> = (0..2000).map(|t| w[t] + if t >= 2 { 0.3 * u[t - 2] } else { 0.0 }).collect();
        let r = ResidualTests::new(&leaky, &u);
        assert!(!r.independent_of_input());
        assert!((r.ccf[LAGS + 2] - 0.3 / (1.0f64 + 0.09).sqrt()).abs() < 0.05, "peak at lag 2: {}", r.ccf[LAGS + 2]);
    }
}
