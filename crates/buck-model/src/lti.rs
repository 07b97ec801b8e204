//! Continuous linear time-invariant models and their exact zero-order-hold discretization.
//!
//! Discretization uses the block matrix exponential (Van Loan): for `dx/dt = A·x + B·u` with `u`
//! held over `τ`, `exp([[A, B], [0, 0]]·τ) = [[Ad, Bd], [0, I]]`. Augmenting with `dz/dt = x`
//! gives the exact integral of the state over the piece as well, from which period averages
//! follow without sampling error. Both are exact for any stiffness: nothing is stepped.
use nalgebra::DMatrix;

/// `dx/dt = A·x + B·u`.
#[derive(Debug, Clone, PartialEq)]
pub struct Lti {
    /// State matrix, `n × n`.
    pub a: DMatrix<f64>,
    /// Input matrix, `n × m`.
    pub b: DMatrix<f64>,
}

/// Exact discretization over one held-input piece of length `τ`.
#[derive(Debug, Clone, PartialEq)]
pub struct Discrete {
    /// `x(τ) = ad·x(0) + bd·u`.
    pub ad: DMatrix<f64>,
    /// See `ad`.
    pub bd: DMatrix<f64>,
    /// `∫₀^τ x dt = ia·x(0) + ib·u`.
    pub ia: DMatrix<f64>,
    /// See `ia`.
    pub ib: DMatrix<f64>,
}

impl Lti {
    /// Builds a model from row-major `a` (`n·n` values) and `b` (`n·m` values).
    ///
    /// # Panics
    /// If the slices do not have `n·n` and `n·m` elements (a programming error).
    pub fn new(n: usize, m: usize, a: &[f64], b: &[f64]) -> Self {
        Self { a: DMatrix::from_row_slice(n, n, a), b: DMatrix::from_row_slice(n, m, b) }
    }

    /// Number of states.
    pub fn states(&self) -> usize {
        self.a.nrows()
    }

    /// Number of inputs.
    pub fn inputs(&self) -> usize {
        self.b.ncols()
    }

    /// Generator of `[x; z; u]` with `dx = A·x + B·u`, `dz = x`, `du = 0`; `integral` adds the
    /// `dz = x` block (zero for derivative generators, whose `z` rows carry no identity).
    fn generator(&self, integral: bool) -> DMatrix<f64> {
        let (n, m) = (self.states(), self.inputs());
        let mut g = DMatrix::zeros(2 * n + m, 2 * n + m);
        g.view_mut((0, 0), (n, n)).copy_from(&self.a);
        g.view_mut((0, 2 * n), (n, m)).copy_from(&self.b);
        if integral {
            g.view_mut((n, 0), (n, n)).fill_with_identity();
        }
        g
    }

    /// Splits `exp(generator·τ)` (or its derivative) into the four discrete blocks.
    fn blocks(&self, e: &DMatrix<f64>, offset: (usize, usize)) -> Discrete {
        let (n, m) = (self.states(), self.inputs());
        let (r, c) = offset;
        Discrete {
            ad: e.view((r, c), (n, n)).into_owned(),
            bd: e.view((r, c + 2 * n), (n, m)).into_owned(),
            ia: e.view((r + n, c), (n, n)).into_owned(),
            ib: e.view((r + n, c + 2 * n), (n, m)).into_owned(),
        }
    }

    /// Exact discretization with the state integral, for inputs held over `tau` seconds.
    pub fn discretize(&self, tau: f64) -> Discrete {
        self.blocks(&(self.generator(true) * tau).exp(), (0, 0))
    }

    /// [`Lti::discretize`] and its derivative with respect to a parameter `θ`, given
    /// `derivative.a = ∂A/∂θ` and `derivative.b = ∂B/∂θ`.
    ///
    /// Uses the block identity `exp([[X, Y], [0, X]]) = [[e^X, D_Y e^X], [0, e^X]]`, where
    /// `D_Y e^X` is the Fréchet derivative of the exponential in direction `Y`: exact, no
    /// finite differences.
    pub fn discretize_with_derivative(&self, derivative: &Lti, tau: f64) -> (Discrete, Discrete) {
        let g = self.generator(true) * tau;
        let dg = derivative.generator(false) * tau;
        let k = g.nrows();
        let mut big = DMatrix::zeros(2 * k, 2 * k);
        big.view_mut((0, 0), (k, k)).copy_from(&g);
        big.view_mut((k, k), (k, k)).copy_from(&g);
        big.view_mut((0, k), (k, k)).copy_from(&dg);
        let e = big.exp();
        (self.blocks(&e, (0, 0)), self.blocks(&e, (0, k)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    /// Scalar `dx/dt = −a·x + b·u` has closed forms for the step and its integral.
    #[test]
    fn first_order_matches_closed_form() {
        let (a, b, tau) = (2.0e7, 3.0, 3.0e-6); // stiff: a·τ = 60
        let d = Lti::new(1, 1, &[-a], &[b]).discretize(tau);
        let decay = (-a * tau).exp();
        assert_relative_eq!(d.ad[0], decay, epsilon = 1e-15);
        assert_relative_eq!(d.bd[0], b / a * (1.0 - decay), max_relative = 1e-12);
        assert_relative_eq!(d.ia[0], (1.0 - decay) / a, max_relative = 1e-12);
        assert_relative_eq!(d.ib[0], b / a * (tau - (1.0 - decay) / a), max_relative = 1e-12);
    }

    /// The block-exponential derivative agrees with a central difference of `discretize`.
    #[test]
    fn derivative_matches_central_difference() {
        let tau = 1.3e-6;
        let build = |cl: f64| crate::Params { cl, ..Default::default() }.full_lti();
        let cl = 2e-6;
        // dA/dCl and dB/dCl of the averaged model: the entries that scale with 1/Cl.
        let base = build(cl);
        let mut da = base.a.clone() * 0.0;
        for j in 0..3 {
            da[(2, j)] = -base.a[(2, j)] / cl;
        }
        let mut db = base.b.clone() * 0.0;
        db[(2, 1)] = -base.b[(2, 1)] / cl;
        let (_, d) = base.discretize_with_derivative(&Lti { a: da, b: db }, tau);
        let h = cl * 1e-6;
        let (up, down) = (build(cl + h).discretize(tau), build(cl - h).discretize(tau));
        let fd = |f: fn(&Discrete) -> &DMatrix<f64>| (f(&up) - f(&down)) / (2.0 * h);
        let close = |a: &DMatrix<f64>, b: &DMatrix<f64>| (a - b).amax() <= 1e-6 * b.amax().max(1e-30);
        assert!(close(&d.ad, &fd(|x| &x.ad)), "ad: {} vs {}", d.ad, fd(|x| &x.ad));
        assert!(close(&d.bd, &fd(|x| &x.bd)));
        assert!(close(&d.ia, &fd(|x| &x.ia)));
        assert!(close(&d.ib, &fd(|x| &x.ib)));
    }

    /// Two half steps compose into one full step (semigroup property), also for the integral.
    #[test]
    fn half_steps_compose() {
        let lti = crate::Params { cl: 0.2e-6, ..Default::default() }.full_lti();
        let tau = 3.0e-6;
        let full = lti.discretize(tau);
        let half = lti.discretize(tau / 2.0);
        assert_relative_eq!(full.ad, &half.ad * &half.ad, epsilon = 1e-12);
        assert_relative_eq!(full.bd, &half.ad * &half.bd + &half.bd, epsilon = 1e-12);
        let ia = &half.ia + &half.ia * &half.ad;
        assert_relative_eq!(full.ia, ia, epsilon = 1e-16);
    }
}
