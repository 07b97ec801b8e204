//! Prediction-error identification: a one-step predictor in innovations form
//!
//! ```text
//! x̂[k+1] = F_j·x̂[k] + G_j·u[k] + K·e[k],   e[k] = y[k] − H_j·x̂[k] − D_j·u[k]
//! ```
//!
//! with the free circuit parameters (log scale), the initial state and, for the
//! [`NoiseModel::Innovations`] predictor, the Kalman gain `K` as unknowns. The criterion is the
//! weighted sum of squared prediction errors; Levenberg–Marquardt steps use the exact
//! Jacobian from a forward sensitivity recursion, and the covariance is `s²·(JᵀJ)⁻¹`.
//!
//! With white measurement noise only (the usual open-loop case), the optimal predictor has
//! `K = 0` and the criterion is the output-error one, which is then the maximum-likelihood fit.
use buck_model::Params;
use nalgebra::{DMatrix, DVector};

use crate::error::EstimatorError;
use crate::model::{Free, Level, Model};
use crate::validate::Z_975;

/// Disturbance model of the predictor.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NoiseModel {
    /// `K = 0`: white measurement noise (maximum likelihood for open-loop data with sensor
    /// noise; simulation and one-step prediction coincide).
    OutputError,
    /// `K` estimated (innovations form): process and measurement noise, closed-loop data.
    Innovations,
}

/// Settings of a fit.
#[derive(Debug, Clone, PartialEq)]
pub struct FitOptions {
    /// Disturbance model.
    pub noise: NoiseModel,
    /// Start values of the free parameters (`None`: a grid over 0.1–300 µF for Cl and over
    /// factors 0.8–2 of the nominal value of each other free parameter).
    pub guess: Option<Vec<f64>>,
    /// Iteration limit of Levenberg–Marquardt.
    pub max_iterations: usize,
}

impl Default for FitOptions {
    fn default() -> Self {
        Self { noise: NoiseModel::OutputError, guess: None, max_iterations: 100 }
    }
}

/// An estimated parameter with its 95 % confidence interval.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Estimate {
    /// Name (as in the variable table).
    pub name: &'static str,
    /// Point estimate.
    pub value: f64,
    /// Lower and upper 95 % bounds (from the log-scale normal approximation).
    pub ci95: (f64, f64),
    /// Standard deviation of `ln(value)` (≈ relative standard deviation).
    pub rel_std: f64,
}

/// Result of a fit.
#[derive(Debug, Clone)]
pub struct Fit {
    /// Circuit parameters with the estimates in place.
    pub params: Params,
    /// Free parameters, in the model's order.
    pub estimates: Vec<Estimate>,
    /// Estimated initial state (of a simulated fit: its [`crate::simulated::Start`], `[v0, dil]`).
    pub x0: Vec<f64>,
    /// Estimated predictor gain (`nx × ny`, row-major); zeros for output error.
    pub gain: Vec<f64>,
    /// Residual standard deviation of each output.
    pub sigma: Vec<f64>,
    /// Final weighted criterion `Σ (e/σ)²`.
    pub cost: f64,
    /// Levenberg–Marquardt iterations.
    pub iterations: usize,
    /// Whether the relative change of the criterion fell below tolerance.
    pub converged: bool,
    /// Number of estimated values (free parameters, initial state, gain).
    pub n_params: usize,
    /// Covariance of the free parameters on log scale.
    pub covariance: DMatrix<f64>,
}

impl Fit {
    /// The estimate of a free parameter by name.
    pub fn estimate(&self, name: &str) -> Option<&Estimate> {
        self.estimates.iter().find(|e| e.name == name)
    }

    /// Akaike's information criterion of the fit, `N·ny·ln(det Σ) + 2·n_params` with the
    /// residual covariance taken diagonal.
    pub fn aic(&self, samples: usize) -> f64 {
        let ln_det: f64 = self.sigma.iter().map(|s| 2.0 * s.max(1e-300).ln()).sum();
        samples as f64 * ln_det + 2.0 * self.n_params as f64
    }
}

/// Layout of the unknown vector `[ln θ (nf) | x0 (nx) | K (nx·ny)]`.
#[derive(Debug, Clone, Copy)]
struct Layout {
    nf: usize,
    nx: usize,
    ny: usize,
    gain: bool,
}

impl Layout {
    fn np(&self) -> usize {
        self.nf + self.nx + if self.gain { self.nx * self.ny } else { 0 }
    }
}

/// Criterion value and, on request, normal equations.
struct Eval {
    cost: f64,
    sum_sq: Vec<f64>,
    jtj: DMatrix<f64>,
    jtr: DVector<f64>,
}

/// Largest number of unknowns (e.g. 2 circuit parameters, 4 states, a 4 × 2 gain).
const NP_MAX: usize = 14;

/// One level's maps in fixed-size arrays, for the specialised inner loop.
struct Fixed<const NX: usize, const NY: usize, const NU: usize> {
    f: [[f64; NX]; NX],
    g: [[f64; NU]; NX],
    h: [[f64; NX]; NY],
    d: [[f64; NU]; NY],
}

impl<const NX: usize, const NY: usize, const NU: usize> Fixed<NX, NY, NU> {
    fn from(m: &crate::model::Maps) -> Self {
        let mut out = Self { f: [[0.0; NX]; NX], g: [[0.0; NU]; NX], h: [[0.0; NX]; NY], d: [[0.0; NU]; NY] };
        for i in 0..NX {
            for j in 0..NX {
                out.f[i][j] = m.f[i * NX + j];
            }
            for j in 0..NU {
                out.g[i][j] = m.g[i * NU + j];
            }
        }
        for o in 0..NY {
            for j in 0..NX {
                out.h[o][j] = m.h[o * NX + j];
            }
            for j in 0..NU {
                out.d[o][j] = m.d[o * NU + j];
            }
        }
        out
    }
}

fn dot<const N: usize>(a: &[f64; N], b: &[f64; N]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// Runs the predictor over the data: criterion, per-output residual sums of squares and,
/// when `jacobian`, `JᵀJ` and `Jᵀr` of the weighted residuals. `sensitivities = false` skips
/// the derivative columns of the circuit parameters (their maps may then be absent).
#[allow(clippy::too_many_arguments)]
fn evaluate(model: &Model, levels: &[Level], lay: Layout, p: &[f64], weights: &[f64], jacobian: bool, sensitivities: bool, record: Option<&mut Vec<f64>>) -> Eval {
    match (lay.nx, lay.ny, model.nu()) {
        (3, 1, 2) => evaluate_n::<3, 1, 2>(model, levels, lay, p, weights, jacobian, sensitivities, record),
        (3, 2, 2) => evaluate_n::<3, 2, 2>(model, levels, lay, p, weights, jacobian, sensitivities, record),
        (2, 1, 4) => evaluate_n::<2, 1, 4>(model, levels, lay, p, weights, jacobian, sensitivities, record),
        (3, 1, 3) => evaluate_n::<3, 1, 3>(model, levels, lay, p, weights, jacobian, sensitivities, record),
        (3, 2, 3) => evaluate_n::<3, 2, 3>(model, levels, lay, p, weights, jacobian, sensitivities, record),
        (4, 1, 3) => evaluate_n::<4, 1, 3>(model, levels, lay, p, weights, jacobian, sensitivities, record),
        (4, 2, 3) => evaluate_n::<4, 2, 3>(model, levels, lay, p, weights, jacobian, sensitivities, record),
        (nx, ny, nu) => unreachable!("no model has {nx} states, {ny} outputs and {nu} inputs"),
    }
}

/// [`evaluate`] for `NX` states, `NY` outputs and `NU` inputs. Sensitivities are kept column by column
/// (`s[c] = ∂x̂/∂p_c`), so every product is a small fixed-size loop.
#[allow(clippy::too_many_arguments, clippy::needless_range_loop)]
fn evaluate_n<const NX: usize, const NY: usize, const NU: usize>(
    model: &Model,
    levels: &[Level],
    lay: Layout,
    p: &[f64],
    weights: &[f64],
    jacobian: bool,
    sensitivities: bool,
    mut record: Option<&mut Vec<f64>>,
) -> Eval {
    let nf = lay.nf;
    let np = lay.np();
    let maps: Vec<Fixed<NX, NY, NU>> = levels.iter().map(|l| Fixed::from(&l.maps)).collect();
    let derivs: Vec<Vec<Fixed<NX, NY, NU>>> = levels.iter().map(|l| if sensitivities { l.derivs.iter().take(nf).map(Fixed::from).collect() } else { Vec::new() }).collect();
    let mut x = [0.0; NX];
    x.copy_from_slice(&p[nf..nf + NX]);
    let mut k_gain = [[0.0; NY]; NX];
    if lay.gain {
        for i in 0..NX {
            for o in 0..NY {
                k_gain[i][o] = p[nf + NX + i * NY + o];
            }
        }
    }
    let w: [f64; NY] = std::array::from_fn(|o| weights[o]);
    let mut s = [[0.0; NX]; NP_MAX];
    for i in 0..NX {
        s[nf + i][i] = 1.0;
    }
    let mut de = [[0.0; NY]; NP_MAX];
    let mut jtj = [[0.0; NP_MAX]; NP_MAX];
    let mut jtr = [0.0; NP_MAX];
    let mut cost = 0.0;
    let mut sum_sq = [0.0; NY];
    for k in 0..model.len() {
        let j = model.level_of[k];
        let m = &maps[j];
        let u: [f64; NU] = std::array::from_fn(|j| model.u[k * NU + j]);
        let mut e = [0.0; NY];
        for o in 0..NY {
            let yh = dot(&m.h[o], &x) + dot(&m.d[o], &u);
            e[o] = model.y[k * NY + o] - yh;
            sum_sq[o] += e[o] * e[o];
            cost += (w[o] * e[o]) * (w[o] * e[o]);
        }
        if let Some(rec) = record.as_deref_mut() {
            rec.extend((0..NY).map(|o| model.y[k * NY + o] - e[o]));
        }
        if jacobian {
            for c in 0..np {
                for o in 0..NY {
                    de[c][o] = -dot(&m.h[o], &s[c]);
                }
            }
            for (f, dm) in derivs[j].iter().enumerate() {
                for o in 0..NY {
                    de[f][o] -= dot(&dm.h[o], &x) + dot(&dm.d[o], &u);
                }
            }
            for o in 0..NY {
                let ww = w[o] * w[o];
                for a in 0..np {
                    let ra = ww * de[a][o];
                    jtr[a] += ra * e[o];
                    for b in a..np {
                        jtj[a][b] += ra * de[b][o];
                    }
                }
            }
        }
        // State update x̂ ← F x̂ + G u + K e, and the sensitivities with it.
        let mut xn = [0.0; NX];
        for i in 0..NX {
            xn[i] = dot(&m.f[i], &x) + dot(&m.g[i], &u) + dot(&k_gain[i], &e);
        }
        if jacobian {
            // Column c of the new sensitivity depends only on column c of the old one, so the
            // update runs in place.
            for c in 0..np {
                let old = s[c];
                for i in 0..NX {
                    s[c][i] = dot(&m.f[i], &old) + dot(&k_gain[i], &de[c]);
                }
            }
            for (f, dm) in derivs[j].iter().enumerate() {
                for i in 0..NX {
                    s[f][i] += dot(&dm.f[i], &x) + dot(&dm.g[i], &u);
                }
            }
            if lay.gain {
                for i in 0..NX {
                    for o in 0..NY {
                        s[nf + NX + i * NY + o][i] += e[o];
                    }
                }
            }
        }
        x = xn;
        if !cost.is_finite() {
            break;
        }
    }
    let mut out = Eval { cost: if cost.is_finite() { cost } else { f64::INFINITY }, sum_sq: sum_sq.to_vec(), jtj: DMatrix::zeros(np, np), jtr: DVector::zeros(np) };
    for a in 0..np {
        out.jtr[a] = jtr[a];
        for b in a..np {
            out.jtj[(a, b)] = jtj[a][b];
            out.jtj[(b, a)] = jtj[a][b];
        }
    }
    out
}

/// Circuit parameters with the free ones set from log values.
fn with_free(nominal: &Params, free: &[Free], logs: &[f64]) -> Params {
    let mut p = *nominal;
    for (f, l) in free.iter().zip(logs) {
        f.set(&mut p, l.exp());
    }
    p
}

/// Samples used to rank the grid of start values.
const GRID_SAMPLES: usize = 1000;

/// Grid of start values for Cl as multiples of the main capacitance C, log-spaced a half decade
/// apart (0.1–300 µF beside the thesis's 100 µF): a load capacitance is judged against the
/// converter's own output capacitance, at any scale.
pub(crate) const CL_GRID: [f64; 8] = [1e-3, 3e-3, 1e-2, 3e-2, 0.1, 0.3, 1.0, 3.0];

/// Factors on the start value of each free parameter other than Cl tried with the Cl grid (a
/// series resistance or a drifted L, C, Rc starts from its nominal value, which can be far).
const MAGNITUDE_GRID: [f64; 4] = [0.8, 1.0, 1.25, 2.0];

/// Most free parameters besides Cl gridded jointly (the grid grows as 4ⁿ).
const MAX_GRIDDED: usize = 2;

/// Fits the free parameters of `model` to its data, starting from the circuit values `nominal`.
///
/// ```
/// use buck_model::{Mode, Params};
/// use estimator::experiment::{run, Experiment, ModelPlant};
/// use estimator::model::{Free, Model, Sampling, Signal, Structure};
/// use estimator::pem::{fit, FitOptions};
///
/// let truth = Params { cl: 4.7e-6, ..Params::default() };
/// let exp = Experiment { samples: 1000, noise_vout: 2e-3, ..Experiment::default() };
/// let data = run(&mut ModelPlant::new(truth, Mode::Averaged), &exp).unwrap();
/// let model = Model::new(Structure::Averaged, Sampling::PeriodStart, &[Signal::Vout], &[Free::Cl], &data, truth.period()).unwrap();
/// let f = fit(&model, &Params::default(), &FitOptions::default()).unwrap();
/// let cl = f.estimate("Cl").unwrap();
/// assert!(cl.ci95.0 < 4.7e-6 && 4.7e-6 < cl.ci95.1);
/// ```
pub fn fit(model: &Model, nominal: &Params, opts: &FitOptions) -> Result<Fit, EstimatorError> {
    let nf = model.free.len();
    let lay = Layout { nf, nx: model.nx(), ny: model.ny(), gain: opts.noise == NoiseModel::Innovations };
    let np = lay.np();
    let n_obs = model.len() * model.ny();
    if n_obs <= np {
        return Err(EstimatorError::Fit(format!("{n_obs} observations cannot determine {np} unknowns")));
    }
    // Start: nominal values (or the guess), DC state, zero gain.
    let mut logs: Vec<f64> = match &opts.guess {
        Some(g) if g.len() == nf => g.iter().map(|v| v.ln()).collect(),
        Some(g) => return Err(EstimatorError::Config(format!("{} start values for {nf} free parameters", g.len()))),
        None => model.free.iter().map(|f| f.get(nominal).ln()).collect(),
    };
    if logs.iter().any(|l| !l.is_finite()) {
        return Err(EstimatorError::Config("start values of free parameters must be positive".into()));
    }
    // Output weights: 1/spread of each measured output, refined from residuals below.
    let mut weights: Vec<f64> = (0..lay.ny)
        .map(|o| {
            let col: Vec<f64> = model.y.iter().skip(o).step_by(lay.ny).copied().collect();
            let mean = col.iter().sum::<f64>() / col.len() as f64;
            let var = col.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / col.len() as f64;
            1.0 / var.sqrt().max(1e-12)
        })
        .collect();

    let cl_index = model.free.iter().position(|f| *f == Free::Cl);
    let mut p = vec![0.0; np];
    p[..nf].copy_from_slice(&logs);
    p[nf..nf + lay.nx].copy_from_slice(&model.dc_state(&with_free(nominal, &model.free, &logs)));
    if let (Some(ci), None) = (cl_index, &opts.guess) {
        // Coarse grid over Cl and the other free parameters' magnitudes, from the DC state of
        // each point: a wrong initial state only spoils the first few dozen samples (the LC mode
        // decays within ~10 periods), not the ranking, which needs no more than the first
        // GRID_SAMPLES samples. Starting the others at their nominal values alone can leave the
        // fit in a valley where Cl runs to a bound and absorbs what the others should explain.
        let head = model.prefix(GRID_SAMPLES);
        let others: Vec<usize> = (0..nf).filter(|&i| i != ci).collect();
        let scales: &[f64] = if others.len() <= MAX_GRIDDED { &MAGNITUDE_GRID } else { &[1.0] };
        let mut best = (f64::INFINITY, logs.clone());
        for point in 0..CL_GRID.len() * scales.len().pow(others.len() as u32) {
            let mut trial = logs.clone();
            trial[ci] = (CL_GRID[point % CL_GRID.len()] * nominal.c).ln();
            let mut rest = point / CL_GRID.len();
            for &i in &others {
                trial[i] += scales[rest % scales.len()].ln();
                rest /= scales.len();
            }
            let params = with_free(nominal, &head.free, &trial);
            let levels = head.levels(&params, false);
            p[..nf].copy_from_slice(&trial);
            p[nf..nf + lay.nx].copy_from_slice(&head.dc_state(&params));
            let cost = evaluate(&head, &levels, lay, &p, &weights, false, false, None).cost;
            if cost < best.0 {
                best = (cost, trial);
            }
        }
        logs = best.1;
        p[..nf].copy_from_slice(&logs);
        p[nf..nf + lay.nx].copy_from_slice(&model.dc_state(&with_free(nominal, &model.free, &logs)));
    }
    // The prediction is affine in x0 (output error), so one Gauss–Newton step solves it.
    let levels = model.levels(&with_free(nominal, &model.free, &logs), false);
    if let Some(q) = solve_initial_state(model, &levels, lay, p.clone(), &weights) {
        p = q;
    }

    let mut total_iterations = 0;
    let mut converged = false;
    // Two passes when there are several outputs: the second with weights 1/σ from the first.
    let passes = if lay.ny > 1 { 3 } else { 1 };
    let mut last = None;
    let mut final_eval = None;
    for _ in 0..passes {
        let (q, it, conv, eval) = levenberg_marquardt(model, nominal, lay, p, &weights, opts.max_iterations)?;
        p = q;
        total_iterations += it;
        converged = conv;
        let sig: Vec<f64> = eval.sum_sq.iter().map(|s| (s / model.len() as f64).sqrt()).collect();
        weights = sig.iter().map(|s| 1.0 / s.max(1e-15)).collect();
        last = Some(sig);
        final_eval = Some(eval);
    }
    let sigma = last.unwrap_or_default();
    let params = with_free(nominal, &model.free, &p[..nf]);
    // With one output the covariance s²(JᵀJ)⁻¹ does not depend on the weight's scale, so the
    // last iteration's normal equations serve; with several, re-evaluate at the final weights.
    let eval = match final_eval {
        Some(e) if lay.ny == 1 => e,
        _ => evaluate(model, &model.levels(&params, true), lay, &p, &weights, true, true, None),
    };
    let s2 = eval.cost / (n_obs - np) as f64;
    let cov_all = covariance(eval.jtj.clone(), s2)?;
    let covariance = cov_all.view((0, 0), (nf, nf)).into_owned();
    let estimates = log_estimates(&model.free, &p[..nf], &covariance);
    Ok(Fit {
        params,
        estimates,
        x0: p[nf..nf + lay.nx].to_vec(),
        gain: if lay.gain { p[nf + lay.nx..].to_vec() } else { vec![0.0; lay.nx * lay.ny] },
        sigma,
        cost: eval.cost,
        iterations: total_iterations,
        converged,
        n_params: np,
        covariance,
    })
}

/// Covariance `s²·(JᵀJ)⁻¹` of the unknowns from the information matrix `jtj`.
pub(crate) fn covariance(jtj: DMatrix<f64>, s2: f64) -> Result<DMatrix<f64>, EstimatorError> {
    jtj.cholesky().map(|c| c.inverse() * s2).ok_or_else(|| EstimatorError::Fit("the information matrix is singular: the parameters are not identifiable from this data".into()))
}

/// The estimates of `free` from their unknowns `logs` (log values, or logits below a ceiling:
/// [`Free::to_unknown`]) and the covariance of the unknowns (whose leading block belongs to
/// them), with 95 % intervals from the normal approximation on that scale.
pub(crate) fn log_estimates(free: &[Free], logs: &[f64], covariance: &DMatrix<f64>) -> Vec<Estimate> {
    free.iter()
        .enumerate()
        .map(|(i, f)| {
            let sd = covariance[(i, i)].max(0.0).sqrt();
            Estimate { name: f.name(), value: f.from_unknown(logs[i]), ci95: (f.from_unknown(logs[i] - Z_975 * sd), f.from_unknown(logs[i] + Z_975 * sd)), rel_std: sd * f.relative_slope(logs[i]) }
        })
        .collect()
}

/// One Gauss–Newton step in the initial state only (exact for output error, where the
/// prediction is affine in `x0`).
fn solve_initial_state(model: &Model, levels: &[Level], lay: Layout, mut p: Vec<f64>, w: &[f64]) -> Option<Vec<f64>> {
    let eval = evaluate(model, levels, lay, &p, w, true, false, None);
    let (nf, nx) = (lay.nf, lay.nx);
    let a = eval.jtj.view((nf, nf), (nx, nx)).into_owned();
    let b = eval.jtr.rows(nf, nx).into_owned();
    let step = a.cholesky()?.solve(&(-b));
    for i in 0..nx {
        p[nf + i] += step[i];
    }
    Some(p)
}

/// Levenberg–Marquardt with Marquardt's diagonal scaling. Stops when the Gauss–Newton
/// step of every unknown is below 1e-4 of its own standard deviation (further iterations
/// could not move the estimate by anything the data can resolve) or the criterion stalls.
fn levenberg_marquardt(model: &Model, nominal: &Params, lay: Layout, mut p: Vec<f64>, weights: &[f64], max_iterations: usize) -> Result<(Vec<f64>, usize, bool, Eval), EstimatorError> {
    let np = lay.np();
    let eval_at = |p: &[f64], jacobian: bool| {
        let levels = model.levels(&with_free(nominal, &model.free, &p[..lay.nf]), jacobian);
        evaluate(model, &levels, lay, p, weights, jacobian, jacobian, None)
    };
    let mut cur = eval_at(&p, true);
    if lay.np() > NP_MAX {
        return Err(EstimatorError::Config(format!("{} unknowns exceed the supported {NP_MAX}", lay.np())));
    }
    if !cur.cost.is_finite() {
        return Err(EstimatorError::Fit("the predictor diverges at the start values".into()));
    }
    let dof = ((model.len() * lay.ny) as f64 - np as f64).max(1.0);
    let mut lambda = 1e-4;
    let mut it = 0;
    while it < max_iterations {
        it += 1;
        let mut a = cur.jtj.clone();
        for i in 0..np {
            a[(i, i)] += lambda * cur.jtj[(i, i)].max(1e-12);
        }
        let Some(chol) = a.cholesky() else {
            lambda *= 10.0;
            continue;
        };
        let step = chol.solve(&(-&cur.jtr));
        // Converged when no unknown moves by more than 1e-4 of its standard deviation.
        let s2 = cur.cost / dof;
        let resolved = (0..np).all(|i| step[i].abs() <= 1e-4 * (s2 / cur.jtj[(i, i)].max(1e-300)).sqrt().max(0.0) * 1e2 || step[i] == 0.0);
        let tiny = (0..np).all(|i| step[i].powi(2) * cur.jtj[(i, i)] <= 1e-8 * s2.max(1e-300));
        if tiny || (resolved && lambda < 1e-2) {
            return Ok((p, it, true, cur));
        }
        // Keep log-parameter steps sane (a factor e per iteration at most).
        let scale = (1.0 / step.rows(0, lay.nf).amax().max(1e-300)).min(1.0);
        let trial: Vec<f64> = p.iter().zip(step.iter()).map(|(x, s)| x + scale * s).collect();
        // The Jacobian comes with the trial: near the optimum nearly every trial is accepted.
        // A trial outside a parameter's range is refused like one that does not descend (a
        // nominal fit far from the data ran Cl to 1.7 pF, a value no converter simulates).
        let inside = model.free.iter().zip(&trial).all(|(f, l)| f.admits(l.exp()));
        if let Some(next) = inside.then(|| eval_at(&trial, true)).filter(|next| next.cost < cur.cost) {
            let rel = (cur.cost - next.cost) / cur.cost.max(1e-300);
            p = trial;
            cur = next;
            lambda = (lambda / 10.0).max(1e-12);
            if rel < 1e-12 {
                return Ok((p, it, true, cur));
            }
        } else {
            lambda *= 10.0;
            if lambda > 1e12 {
                // No descent direction left: a minimum to working precision.
                return Ok((p, it, true, cur));
            }
        }
    }
    Ok((p, it, false, cur))
}

/// Simulated (`K = 0`) or one-step-predicted outputs of a fit over `model`'s data, `ny`
/// values per sample; `x0` and `gain` as in [`Fit`].
pub fn outputs(model: &Model, params: &Params, x0: &[f64], gain: Option<&[f64]>) -> Vec<f64> {
    let lay = Layout { nf: model.free.len(), nx: model.nx(), ny: model.ny(), gain: gain.is_some() };
    let levels = model.levels(params, false);
    let mut p = vec![0.0; lay.np()];
    for (i, f) in model.free.iter().enumerate() {
        p[i] = f.get(params).ln();
    }
    p[lay.nf..lay.nf + lay.nx].copy_from_slice(x0);
    if let Some(g) = gain {
        p[lay.nf + lay.nx..].copy_from_slice(g);
    }
    let mut rec = Vec::with_capacity(model.y.len());
    evaluate(model, &levels, lay, &p, &vec![1.0; lay.ny], false, false, Some(&mut rec));
    rec
}

/// Cramér–Rao bound on the free parameters (log scale, so the diagonal is the relative
/// variance) at circuit values `params` and initial state `x0`, for white Gaussian output
/// noise of standard deviation `sigma` per output. The initial state counts as unknown.
pub fn crlb(model: &Model, params: &Params, x0: &[f64], sigma: &[f64]) -> Result<DMatrix<f64>, EstimatorError> {
    let lay = Layout { nf: model.free.len(), nx: model.nx(), ny: model.ny(), gain: false };
    if sigma.len() != lay.ny || x0.len() != lay.nx {
        return Err(EstimatorError::Config(format!("{} σ and {} initial states for {} outputs and {} states", sigma.len(), x0.len(), lay.ny, lay.nx)));
    }
    let mut p = vec![0.0; lay.np()];
    for (i, f) in model.free.iter().enumerate() {
        p[i] = f.get(params).ln();
    }
    p[lay.nf..].copy_from_slice(x0);
    let weights: Vec<f64> = sigma.iter().map(|s| 1.0 / s).collect();
    let levels = model.levels(params, true);
    let info = evaluate(model, &levels, lay, &p, &weights, true, true, None).jtj;
    let cov = info.cholesky().map(|c| c.inverse()).ok_or_else(|| EstimatorError::Fit("singular Fisher information".into()))?;
    Ok(cov.view((0, 0), (lay.nf, lay.nf)).into_owned())
}
