//! Exact transitions of one piece of the circuit in fixed-size arithmetic (no allocation once
//! built): a [`Ladder`] of transitions over the step lengths `T·2⁻ᵏ` and the solution's Taylor
//! polynomial below the shortest, from which any instant of a piece is reached by a few
//! matrix-vector products instead of a matrix exponential.
//!
//! For `dx/dt = A·x + B·u` with `u` held, the transition over `h` needs `e^{Ah}`,
//! `Γ₁(h) = ∫₀ʰ e^{As} ds` and `Γ₂(h) = ∫₀ʰ Γ₁(s) ds`: `x(h) = e^{Ah}·x + Γ₁·B·u` and
//! `∫₀ʰ x = Γ₁·x + Γ₂·B·u`. The shortest rung comes from the Taylor series (`‖A·h‖₁ ≤ 1/8`),
//! each longer one by doubling (scaling and squaring). The doubling carries `F = e^{Ah} − I`
//! rather than `e^{Ah}`, so that each step is "twice the value plus a small product" and keeps
//! full relative accuracy over many doublings (squaring `e^{Ah}` itself loses a bit per
//! doubling of what distinguishes it from `I`).
use nalgebra::{DMatrix, SMatrix, Vector2, Vector4};

/// Largest number of circuit states (`[il, vc, vcl, ic]`, `ic` only with `esl`); smaller
/// circuits are padded with zero rows and columns.
const NX: usize = 4;
/// State matrix (padded).
type Mat = SMatrix<f64, NX, NX>;
/// Input matrix (padded), inputs `[u_sw, io]`.
type Inp = SMatrix<f64, NX, 2>;

/// `m` (at most `NX` rows) padded with zeros to `NX` rows.
pub(crate) fn pad<const C: usize>(m: &DMatrix<f64>) -> SMatrix<f64, NX, C> {
    let mut out = SMatrix::<f64, NX, C>::zeros();
    out.view_mut((0, 0), m.shape()).copy_from(m);
    out
}

/// Largest `‖A·h‖₁` of the shortest rung of a [`Ladder`], where the Taylor series are summed.
const THETA: f64 = 0.125;
/// Terms `X^k/(k+2)!`, `k < TERMS`, of `φ₂`: the first one left out is below
/// `(1/8)¹⁰/12! ≈ 2e-18`.
const TERMS: usize = 10;

/// Transition over one held-input piece: `x(h) = ad·x + bd·u`, `∫₀ʰ x = ia·x + ib·u`.
#[derive(Debug, Clone)]
pub(crate) struct Transition {
    /// Length of the piece \[s\].
    pub h: f64,
    /// See the type.
    pub ad: Mat,
    /// See the type.
    pub bd: Inp,
    /// See the type.
    pub ia: Mat,
    /// See the type.
    pub ib: Inp,
}

impl Transition {
    /// `(x(h), z + ∫x)`.
    ///
    /// Summed in the order of the ideal 3-state model's `[[ad, 0], [ia, I]]·[x; z] + Γ·u`, so
    /// that a transition from [`crate::lti::Lti::discretize`] reproduces the ideal circuit bit
    /// for bit.
    #[inline]
    pub fn apply(&self, x: &Vector4<f64>, z: &Vector4<f64>, u: &Vector2<f64>) -> (Vector4<f64>, Vector4<f64>) {
        let mut xn = Vector4::zeros();
        let mut zn = Vector4::zeros();
        for i in 0..NX {
            let (mut a, mut b) = (0.0, 0.0);
            for j in 0..NX {
                a += self.ad[(i, j)] * x[j];
                b += self.ia[(i, j)] * x[j];
            }
            xn[i] = a + (self.bd[(i, 0)] * u[0] + self.bd[(i, 1)] * u[1]);
            zn[i] = (b + z[i]) + (self.ib[(i, 0)] * u[0] + self.ib[(i, 1)] * u[1]);
        }
        (xn, zn)
    }

    /// `x(h)` alone.
    #[inline]
    fn state(&self, x: &Vector4<f64>, u: &Vector2<f64>) -> Vector4<f64> {
        self.ad * x + self.bd * u
    }

    /// The state `i` of `x(h)` alone, summed as [`Transition::state`] sums it (bit for bit).
    #[inline]
    fn state_of(&self, i: usize, x: &Vector4<f64>, u: &Vector2<f64>) -> f64 {
        let a = self.ad[(i, 0)] * x[0] + self.ad[(i, 1)] * x[1] + self.ad[(i, 2)] * x[2] + self.ad[(i, 3)] * x[3];
        a + (self.bd[(i, 0)] * u[0] + self.bd[(i, 1)] * u[1])
    }

    /// `z + ∫₀ʰ x`.
    #[inline]
    fn integral(&self, x: &Vector4<f64>, z: &Vector4<f64>, u: &Vector2<f64>) -> Vector4<f64> {
        z + self.ia * x + self.ib * u
    }
}

/// `F = e^{Ah} − I`, `Γ₁(h)`, `Γ₂(h)` of one step length `h`.
#[derive(Debug, Clone)]
struct Phi {
    h: f64,
    f: Mat,
    g1: Mat,
    g2: Mat,
}

impl Phi {
    /// Taylor series for `‖A·h‖₁ ≤ THETA`: `φ₂(X) = Σ X^k/(k+2)!` by Horner with `X = A·h`,
    /// then `φ₁ = I + X·φ₂`, `F = X·φ₁`, `Γ₁ = h·φ₁`, `Γ₂ = h²·φ₂`.
    fn taylor(a: &Mat, h: f64) -> Self {
        let x = a * h;
        let mut coeff = [0.0; TERMS];
        let mut factorial = 1.0;
        for (k, c) in coeff.iter_mut().enumerate() {
            factorial *= (k + 2) as f64;
            *c = 1.0 / factorial;
        }
        let mut phi2 = Mat::identity() * coeff[TERMS - 1];
        for &c in coeff[..TERMS - 1].iter().rev() {
            phi2 = x * phi2 + Mat::identity() * c;
        }
        let phi1 = Mat::identity() + x * phi2;
        Self { h, f: x * phi1, g1: phi1 * h, g2: phi2 * (h * h) }
    }

    /// The same over `2h`: `e^{2Ah} = (I + F)²`, `Γ₁(2h) = (I + e^{Ah})·Γ₁`,
    /// `Γ₂(2h) = Γ₂ + h·Γ₁ + e^{Ah}·Γ₂` (the second half starts where the first ends).
    fn doubled(&self) -> Self {
        let Self { h, f, g1, g2 } = self;
        Self { h: 2.0 * h, f: f * 2.0 + f * f, g1: g1 * 2.0 + f * g1, g2: g2 * 2.0 + g1 * *h + f * g2 }
    }

    fn transition(&self, b: &Inp) -> Transition {
        Transition { h: self.h, ad: Mat::identity() + self.f, bd: self.g1 * b, ia: self.g1, ib: self.g2 * b }
    }
}

/// `‖A‖₁`, the largest column sum of magnitudes.
fn norm1(a: &Mat) -> f64 {
    a.column_iter().map(|c| c.abs().sum()).fold(0.0, f64::max)
}

/// Halvings of `tau` that bring `‖A·τ‖₁` down to `theta`.
fn halvings(a: &Mat, tau: f64, theta: f64) -> i32 {
    // The float-to-int cast saturates (and maps NaN to 0).
    (norm1(a) * tau.abs() / theta).log2().ceil().max(0.0) as i32
}

/// Where a piece has got to: time since its start \[s\], state, state integral.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Point {
    pub t: f64,
    pub x: Vector4<f64>,
    pub z: Vector4<f64>,
}

/// Most terms of a [`Tail`] beyond the first: `(1/8)¹¹/12! ≈ 2e-19`.
const TAIL_TERMS: usize = 11;
/// Relative size of the first Taylor term a [`Tail`] leaves out.
const TAIL_EPS: f64 = 1.0 / (1u64 << 60) as f64;

/// A scalar along a piece, `sign·(dⁿxᵢ/dtⁿ − level)` of the state `xᵢ` (`state` `i`: 0 the
/// inductor current, 3 a ringing switch node's voltage) for `order` `n` = 0 (its value) or 1
/// (its slope), that a [`Ladder::descend`] follows until it stops being positive.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Watch {
    pub state: usize,
    pub order: usize,
    pub level: f64,
    pub sign: f64,
}

impl Watch {
    /// The watched scalar where `dⁿxᵢ/dtⁿ` is `v`.
    fn at(self, v: f64) -> f64 {
        self.sign * (v - self.level)
    }
}

/// One linear circuit with exact transitions over `T·2⁻ᵏ`, `k = 0..=depth`, the shortest with
/// `‖A·T·2⁻ᵈᵉᵖᵗʰ‖₁ ≤ 1/8`, and the solution's Taylor polynomial ([`Tail`]) below that.
///
/// An instant `t ≤ T` of a piece is reached by the rungs of the binary digits of `t/T` (a few
/// matrix-vector products; `depth` is 6 for the default circuit, 18 at the stiff corner
/// `Cl` = 1 nF) and the polynomial for the rest, instead of an exponential. Building a ladder
/// costs about as much as one exponential, so circuits that change every period
/// (`cap_dc_bias`) can afford one too. The rungs are built from the shortest up only as far as
/// the pieces asked of the ladder need ([`Ladder::grow`]): a dead-time interval needs none of
/// the long ones. Each rung is the same whenever it is built.
#[derive(Debug, Clone)]
pub(crate) struct Ladder {
    a: Mat,
    b: Inp,
    /// From the shortest up: `rungs[k].h = T·2ᵏ⁻ᵈᵉᵖᵗʰ`.
    rungs: Vec<Transition>,
    /// The step of the longest rung built, which the next one doubles.
    phi: Phi,
    /// The longest rung there can be (`T`).
    top: f64,
    /// Terms of the [`Tail`] beyond the first, for rounding-level truncation at the shortest rung.
    terms: usize,
}

impl Ladder {
    /// The ladder of `dx/dt = A·x + B·u` below `top` (the switching period).
    pub fn new(a: Mat, b: Inp, top: f64) -> Self {
        let mut ladder = Self { a, b, rungs: Vec::new(), phi: Phi { h: 0.0, f: Mat::zeros(), g1: Mat::zeros(), g2: Mat::zeros() }, top, terms: 0 };
        ladder.rebuild(a, b, top);
        ladder
    }

    /// This ladder made the one of `dx/dt = A·x + B·u` below `top`, in the memory it holds (a
    /// circuit that changes every period builds one each period).
    pub fn rebuild(&mut self, a: Mat, b: Inp, top: f64) {
        let depth = halvings(&a, top, THETA);
        let shortest = top * 0.5f64.powi(depth);
        // The first term left out is ‖d₁‖·s·νⁿ/(n+1)! with ν = ‖A·s‖₁.
        let nu = norm1(&a) * shortest;
        let (mut terms, mut bound) = (1, nu / 2.0);
        while bound > TAIL_EPS && terms < TAIL_TERMS {
            bound *= nu / (terms + 2) as f64;
            terms += 1;
        }
        let phi = Phi::taylor(&a, shortest);
        self.rungs.clear();
        self.rungs.reserve(depth as usize + 1);
        self.rungs.push(phi.transition(&b));
        (self.a, self.b, self.phi, self.top, self.terms) = (a, b, phi, top, terms);
    }

    /// Builds the rungs up to the longest not beyond `length` (nor `T`): all a piece of that
    /// length can use.
    pub fn grow(&mut self, length: f64) {
        while 2.0 * self.phi.h <= length.min(self.top) {
            self.phi = self.phi.doubled();
            self.rungs.push(self.phi.transition(&self.b));
        }
    }

    /// `dxᵢ/dt` of the state `i` at the state `x` under the inputs `u`.
    pub fn slope(&self, i: usize, x: &Vector4<f64>, u: &Vector2<f64>) -> f64 {
        (self.a.row(i) * x)[0] + (self.b.row(i) * u)[0]
    }

    /// `dil/dt` at the state `x` under the inputs `u`.
    pub fn dil(&self, x: &Vector4<f64>, u: &Vector2<f64>) -> f64 {
        self.slope(0, x, u)
    }

    /// The value of `watch` at the state `x`.
    pub fn value(&self, watch: Watch, x: &Vector4<f64>, u: &Vector2<f64>) -> f64 {
        watch.at(if watch.order == 0 { x[watch.state] } else { self.slope(watch.state, x, u) })
    }

    fn shortest(&self) -> f64 {
        self.rungs.first().map_or(0.0, |r| r.h)
    }

    /// The Taylor polynomial of the solution at `x`.
    fn tail(&self, x: &Vector4<f64>, u: &Vector2<f64>) -> Tail {
        let mut d = [Vector4::zeros(); TAIL_TERMS + 2];
        d[0] = *x;
        d[1] = self.a * x + self.b * u;
        for k in 2..=self.terms + 1 {
            d[k] = self.a * d[k - 1];
        }
        Tail { d, terms: self.terms }
    }

    /// `p` advanced by `length` (the ladder grown to it).
    pub fn reach(&self, p: &Point, u: &Vector2<f64>, length: f64) -> Point {
        let mut p = *p;
        let mut left = length;
        for rung in self.rungs.iter().rev() {
            // Below the top rung left < 2·rung.h, so this runs at most once and the subtraction
            // is exact (Sterbenz).
            while rung.h <= left {
                p = Point { t: p.t + rung.h, x: rung.state(&p.x, u), z: rung.integral(&p.x, &p.z, u) };
                left -= rung.h;
            }
        }
        if left > 0.0 { self.tail(&p.x, u).point(&p, left) } else { p }
    }

    /// The instant after `start`, not beyond `hi`, at which `watch` stops being positive (or the
    /// point at `hi` if it does not), given that it is positive from `start` until then. A
    /// bisection on the rungs (one trial each) brackets the instant to the shortest rung; the
    /// tail's polynomial then gives it to `tol` by safeguarded Newton iteration. The ladder is
    /// grown to `hi`.
    pub fn descend(&self, start: &Point, u: &Vector2<f64>, hi: f64, watch: Watch, tol: f64) -> Point {
        let mut p = *start;
        for rung in self.rungs.iter().rev() {
            while p.t + rung.h <= hi {
                // A value needs its state alone: the whole state only where the rung is taken.
                let positive = if watch.order == 0 { watch.at(rung.state_of(watch.state, &p.x, u)) > 0.0 } else { self.value(watch, &rung.state(&p.x, u), u) > 0.0 };
                if positive {
                    p = Point { t: p.t + rung.h, x: rung.state(&p.x, u), z: rung.integral(&p.x, &p.z, u) };
                } else {
                    break;
                }
            }
        }
        let span = (hi - p.t).min(self.shortest());
        if span <= 0.0 {
            return p;
        }
        let tail = self.tail(&p.x, u);
        let g = tail.polynomial(watch);
        let g = |s: f64| g.at(s);
        let s = if g(span).0 > 0.0 { span } else { newton(g, span, g(0.0).0, tol) };
        tail.point(&p, s)
    }
}

/// The solution near a point as its Taylor polynomial `x(s) = Σ dₖ·sᵏ/k!`, `k ≤ terms`, with
/// `d₀ = x`, `d₁ = A·x + B·u`, `dₖ₊₁ = A·dₖ` (`d` holds one more for the slope's derivative).
/// Exact to rounding for `s` up to the shortest rung of its [`Ladder`].
struct Tail {
    d: [Vector4<f64>; TAIL_TERMS + 2],
    terms: usize,
}

/// `1/k`, so that the Horner steps of a [`Tail`] multiply instead of divide.
const RECIP: [f64; TAIL_TERMS + 3] = {
    let mut r = [0.0; TAIL_TERMS + 3];
    let mut k = 1;
    while k < r.len() {
        r[k] = 1.0 / k as f64;
        k += 1;
    }
    r
};

impl Tail {
    /// `p` advanced by `s`: `x(s)` and `z + Σ dₖ·sᵏ⁺¹/(k+1)!`, by Horner.
    fn point(&self, p: &Point, s: f64) -> Point {
        let n = self.terms;
        let (mut x, mut z) = (self.d[n], self.d[n]);
        for k in (0..n).rev() {
            x = self.d[k] + x * (s * RECIP[k + 1]);
            z = self.d[k] + z * (s * RECIP[k + 2]);
        }
        Point { t: p.t + s, x, z: p.z + z * s }
    }

    /// `watch` as a polynomial in `s`: coefficients of the value and of its derivative.
    fn polynomial(&self, watch: Watch) -> Polynomial {
        let (j, i) = (watch.order, watch.state);
        // dʲ⁺ᵐxᵢ/dtʲ⁺ᵐ = Σ dₖ₊ⱼ₊ₘ[i]·sᵏ/k! over the d there are.
        let mut value = [0.0; TAIL_TERMS + 2];
        let mut slope = [0.0; TAIL_TERMS + 2];
        let mut factorial = 1.0;
        for k in 0..self.terms + 2 - j {
            if k > 0 {
                factorial *= RECIP[k];
            }
            value[k] = watch.sign * self.d[k + j][i] * factorial;
            if k + j < self.terms + 1 {
                slope[k] = watch.sign * self.d[k + j + 1][i] * factorial;
            }
        }
        value[0] -= watch.sign * watch.level;
        Polynomial { value, slope, len: self.terms + 2 - j }
    }
}

/// A watched scalar near a point: `g(s) = Σ value[k]·sᵏ`, `g'(s) = Σ slope[k]·sᵏ`.
struct Polynomial {
    value: [f64; TAIL_TERMS + 2],
    slope: [f64; TAIL_TERMS + 2],
    len: usize,
}

impl Polynomial {
    fn at(&self, s: f64) -> (f64, f64) {
        let (mut v, mut d) = (0.0, 0.0);
        for k in (0..self.len).rev() {
            v = v * s + self.value[k];
            d = d * s + self.slope[k];
        }
        (v, d)
    }
}

/// Root of `f` in `[0, hi]` with `f(0) = f0 ≥ 0 ≥ f(hi)`: Newton steps from the secant guess,
/// replaced by bisection whenever they leave the bracket.
fn newton(f: impl Fn(f64) -> (f64, f64), hi: f64, f0: f64, tol: f64) -> f64 {
    let (mut lo, mut up) = (0.0, hi);
    let f_hi = f(hi).0;
    let mut t = if f0 - f_hi > 0.0 { hi * f0 / (f0 - f_hi) } else { hi };
    for _ in 0..100 {
        let (v, dv) = f(t);
        if v > 0.0 {
            lo = t;
        } else {
            up = t;
        }
        if v == 0.0 || up - lo <= tol {
            return t;
        }
        let mut next = t - v / dv;
        if !(next > lo && next < up) {
            next = 0.5 * (lo + up);
        }
        if (next - t).abs() <= tol {
            return next;
        }
        t = next;
    }
    t
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Params;
    use crate::lti::Lti;
    use nalgebra::DVector;

    fn padded(lti: &Lti) -> (Mat, Inp) {
        (pad(&lti.a), pad(&lti.b))
    }

    /// The ladder of `a`, `b` below `top`, with every rung built.
    fn grown(a: Mat, b: Inp, top: f64) -> Ladder {
        let mut ladder = Ladder::new(a, b, top);
        ladder.grow(top);
        ladder
    }

    /// The longest rung of the ladder below `tau`: the transition over `tau`.
    fn top(a: Mat, b: Inp, tau: f64) -> Transition {
        grown(a, b, tau).rungs.pop().expect("a ladder has a rung")
    }

    /// Largest difference of the four blocks, relative to each block's largest entry.
    fn mismatch(t: &Transition, lti: &Lti, tau: f64) -> f64 {
        let d = lti.discretize(tau);
        fn rel<const C: usize>(x: &SMatrix<f64, NX, C>, y: &DMatrix<f64>) -> f64 {
            let x = DMatrix::from_fn(y.nrows(), y.ncols(), |i, j| x[(i, j)]);
            (x - y).amax() / y.amax().max(1e-300)
        }
        rel(&t.ad, &d.ad).max(rel(&t.bd, &d.bd)).max(rel(&t.ia, &d.ia)).max(rel(&t.ib, &d.ib))
    }

    /// Circuits spanning the parameter range: the ideal one, the stiff corner (`Rc·Cl` =
    /// 0.1 ns ≪ T), the 4-state `esl` circuit, the blocked inductor.
    fn circuits() -> Vec<Lti> {
        let p = Params::default();
        vec![
            p.piece_lti(0.1, 3.3e-6, 10e-6, false),
            p.piece_lti(0.1, 3.3e-6, 1e-9, false),
            Params { esl: 1e-9, load_esr: 0.01, ..p }.piece_lti(0.12, 2.0e-6, 4.7e-6, false),
            p.piece_lti(0.1, 3.3e-6, 0.2e-6, true),
        ]
    }

    /// Decoupled modes have closed forms (top rung): `e^{λτ}`, `(e^{λτ} − 1)/λ` and
    /// `((e^{λτ} − 1)/λ − τ)/λ`, here from a stiff mode (`λτ = −60`)
    /// to a slow and a marginal one, matched to 1e-14 relative (of 1 for `e^{λτ}`).
    #[test]
    fn transition_matches_closed_form() {
        let tau = 3.0e-6;
        let lambdas = [-2.0e7, -3.0e5, -1.0e2, 0.0];
        let a = Mat::from_diagonal(&Vector4::from_column_slice(&lambdas));
        let b = Inp::from_fn(|_, j| if j == 0 { 1.0 } else { 0.0 });
        let t = &top(a, b, tau);
        for (i, &l) in lambdas.iter().enumerate() {
            let g1 = if l == 0.0 { tau } else { (l * tau).exp_m1() / l };
            // (g1 − τ)/λ cancels for small λτ: its series τ²·Σ (λτ)ᵏ/(k+2)! instead.
            let g2 = if (l * tau).abs() < 1.0 {
                let (mut term, mut sum) = (0.5, 0.0);
                for k in 0..30 {
                    sum += term;
                    term *= l * tau / f64::from(k + 3);
                }
                tau * tau * sum
            } else {
                (g1 - tau) / l
            };
            let e = (l * tau).exp();
            // e^{λτ} is carried as I + (e^{λτ} − 1): accurate to rounding of 1, not of e^{−60}.
            for (got, want, scale) in [(t.ad[(i, i)], e, 1.0), (t.ia[(i, i)], g1, g1), (t.bd[(i, 0)], g1, g1), (t.ib[(i, 0)], g2, g2)] {
                assert!((got - want).abs() <= 1e-14 * scale, "λ = {l:e}: {got:e} vs {want:e}");
            }
        }
    }

    /// The top rung (scaling and squaring) agrees with the Van Loan exponential of
    /// [`Lti::discretize`] (Padé) to 1e-12 of each block's scale, for pieces up to seven periods;
    /// 1e-11 at the stiff corner, where the Padé result itself is off by 5e-13 over one period
    /// and 4e-12 over seven (against a 60-digit mpmath `expm`; this kernel was within 4e-16).
    #[test]
    fn transition_matches_van_loan() {
        let period = 1.0 / 330e3;
        for (k, lti) in circuits().iter().enumerate() {
            let (a, b) = padded(lti);
            let tol = if k == 1 { 1e-11 } else { 1e-12 };
            for tau in [1e-12, 0.37 * period, period, 7.0 * period] {
                let err = mismatch(&top(a, b, tau), lti, tau);
                assert!(err < tol, "circuit {k}, τ = {tau:e}: {err:e}");
            }
        }
    }

    /// Every rung, and any instant reached by composing rungs, agrees with the Van Loan
    /// exponential over the same length to 1e-12 of the state's scale.
    #[test]
    fn ladder_rungs_and_compositions_match_van_loan() {
        let period = 1.0 / 330e3;
        let u = Vector2::new(12.0, 1.0);
        let x0 = Vector4::new(1.3, 5.8, 5.9, 0.0);
        for lti in circuits() {
            let (a, b) = padded(&lti);
            let ladder = grown(a, b, period);
            for (k, rung) in ladder.rungs.iter().enumerate() {
                let err = mismatch(rung, &lti, rung.h);
                assert!(err < 1e-12, "rung {k}: {err:e}");
            }
            for frac in [0.123_456_789, 0.5, 0.999_999_9, 1.0] {
                let tau = frac * period;
                let start = Point { t: 0.0, x: x0, z: Vector4::zeros() };
                let p = ladder.reach(&start, &u, tau);
                let d = lti.discretize(tau);
                let n = lti.states();
                let x = DVector::from_column_slice(&x0.as_slice()[..n]);
                let ud = DVector::from_column_slice(u.as_slice());
                let (xr, zr) = (&d.ad * &x + &d.bd * &ud, &d.ia * &x + &d.ib * &ud);
                assert!((p.t - tau).abs() <= 1e-15 * tau);
                for i in 0..n {
                    assert!((p.x[i] - xr[i]).abs() <= 1e-12 * (xr.amax() + 1.0), "x[{i}] at {frac}: {} vs {}", p.x[i], xr[i]);
                    assert!((p.z[i] - zr[i]).abs() <= 1e-12 * zr.amax(), "z[{i}] at {frac}: {} vs {}", p.z[i], zr[i]);
                }
            }
        }
    }

    /// One state of a rung's step is the whole step's, bit for bit (the descent tests values on
    /// it, and a crossing found must not depend on which was computed).
    #[test]
    fn one_state_of_a_step_is_the_whole_steps_bit_for_bit() {
        let lti = Params { cl: 0.47e-6, ..Params::default() }.piece_lti(0.1, 3.3e-6, 0.47e-6, false);
        let (a, b) = padded(&lti);
        let ladder = grown(a, b, 1.0 / 330e3);
        let u = Vector2::new(12.0, 3.0);
        for (k, x) in [Vector4::new(1.3, 5.9, 5.95, 0.0), Vector4::new(-0.7, 6.1, 6.0, 0.0), Vector4::new(2.9e-3, -1e-4, 12.5, 0.0)].iter().enumerate() {
            for rung in &ladder.rungs {
                let whole = rung.state(x, &u);
                for i in 0..NX {
                    assert_eq!(rung.state_of(i, x, &u).to_bits(), whole[i].to_bits(), "state {i} of x{k} over {:e} s", rung.h);
                }
            }
        }
    }

    /// A descent finds the valley of `il` (`dil/dt = 0`) and a crossing of `il` before it: the
    /// Van Loan solution at the instants found has `dil/dt` within 1e-9 of its start value and
    /// `il` within 1e-12 A of the level (both far above what the 1e-15·T tolerance allows).
    #[test]
    fn descend_finds_extremum_and_crossing() {
        let period = 1.0 / 330e3;
        let lti = Params::default().piece_lti(0.1, 3.3e-6, 10e-6, false);
        let (a, b) = padded(&lti);
        let ladder = grown(a, b, period);
        let u = Vector2::new(12.0, 1.0);
        // vcl above vin: il falls until Cl has discharged below vin - RL·il, then rises.
        let x0 = Vector4::new(1.0, 5.9, 13.0, 0.0);
        let start = Point { t: 0.0, x: x0, z: Vector4::zeros() };
        let exact = |t: f64| {
            let d = lti.discretize(t);
            let x = &d.ad * DVector::from_column_slice(&x0.as_slice()[..3]) + &d.bd * DVector::from_column_slice(u.as_slice());
            let x = Vector4::new(x[0], x[1], x[2], 0.0);
            (x[0], ladder.dil(&x, &u))
        };
        let tol = 1e-15 * period;
        let dil0 = ladder.dil(&x0, &u);
        assert!(dil0 < 0.0);
        let turn = ladder.descend(&start, &u, period, Watch { state: 0, order: 1, level: 0.0, sign: -1.0 }, tol);
        assert!(turn.t > 0.0 && turn.t < period, "valley at {:e}", turn.t);
        let (valley, slope) = exact(turn.t);
        assert!(slope.abs() <= 1e-9 * dil0.abs(), "dil/dt {slope:e} at the valley");
        let level = 0.5 * (1.0 + valley);
        let at = ladder.descend(&start, &u, turn.t, Watch { state: 0, order: 0, level, sign: 1.0 }, tol);
        assert!((exact(at.t).0 - level).abs() <= 1e-12, "il {} vs level {level}", exact(at.t).0);
        assert!((at.x[0] - level).abs() <= 1e-12, "il {} vs level {level}", at.x[0]);
    }
}
