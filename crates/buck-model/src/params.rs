use serde::{Deserialize, Serialize};

use crate::lti::Lti;

/// Circuit parameters of the buck power stage (SI units). Defaults are the BMR450 thesis values.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Params {
    /// Inductance `L` [H].
    pub l: f64,
    /// Inductor series resistance `RL` [Ω].
    pub rl: f64,
    /// Main output capacitance `C` [F].
    pub c: f64,
    /// Equivalent series resistance of `C`, `Rc` [Ω].
    pub rc: f64,
    /// Load capacitance `Cl` [F].
    pub cl: f64,
    /// Switching frequency `fs` [Hz].
    pub fs: f64,
}

impl Default for Params {
    fn default() -> Self {
        Self { l: 3.3e-6, rl: 0.1, c: 100e-6, rc: 0.1, cl: 10e-6, fs: 330e3 }
    }
}

/// How the switch node is modelled.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
pub enum Mode {
    /// State-space average: the switch node carries `duty·vin` continuously.
    #[default]
    Averaged,
    /// Exact trailing-edge PWM: the switch node is `vin` for `duty·T` after each period start
    /// and 0 for the rest of the period; the duty is latched at the period start.
    Switched,
}

impl Params {
    /// Switching period `T = 1/fs` [s].
    pub fn period(&self) -> f64 {
        1.0 / self.fs
    }

    /// The averaged third-order model: states `[il, vc, vo]`, inputs `[u_sw, io]`.
    ///
    /// ```text
    /// L  dil/dt = u_sw − RL·il − vo
    /// C  dvc/dt = (vo − vc)/Rc
    /// Cl dvo/dt = il − io − (vo − vc)/Rc
    /// ```
    pub fn full_lti(&self) -> Lti {
        let Self { l, rl, c, rc, cl, .. } = *self;
        Lti::new(
            3,
            2,
            &[
                -rl / l, 0.0, -1.0 / l, //
                0.0, -1.0 / (rc * c), 1.0 / (rc * c), //
                1.0 / cl, 1.0 / (rc * cl), -1.0 / (rc * cl),
            ],
            &[
                1.0 / l, 0.0, //
                0.0, 0.0, //
                0.0, -1.0 / cl,
            ],
        )
    }

    /// The reduced second-order model with the inductor current as an input: states
    /// `[vc, vo]`, inputs `[il, io]`.
    pub fn reduced_lti(&self) -> Lti {
        let Self { c, rc, cl, .. } = *self;
        Lti::new(
            2,
            2,
            &[
                -1.0 / (rc * c), 1.0 / (rc * c), //
                1.0 / (rc * cl), -1.0 / (rc * cl),
            ],
            &[
                0.0, 0.0, //
                1.0 / cl, -1.0 / cl,
            ],
        )
    }

    /// DC operating point `[il, vc, vo]` of the averaged model in continuous conduction:
    /// `il = io`, `vc = vo = d·vin − RL·io`.
    pub fn steady_state(&self, duty: f64, vin: f64, io: f64) -> [f64; 3] {
        let vo = duty * vin - self.rl * io;
        [io, vo, vo]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;
    use nalgebra::DVector;

    /// The closed-form DC point must null the derivative of the general state-space model.
    #[test]
    fn steady_state_nulls_the_averaged_dynamics() {
        let p = Params::default();
        let (d, vin, io) = (0.43, 11.0, 2.5);
        let x = DVector::from_row_slice(&p.steady_state(d, vin, io));
        let u = DVector::from_row_slice(&[d * vin, io]);
        let lti = p.full_lti();
        let dx = &lti.a * x + &lti.b * u;
        assert!(dx.amax() < 1e-6, "derivative at the DC point: {dx}");
        assert_relative_eq!(p.steady_state(d, vin, io)[2], d * vin - p.rl * io);
    }
}
