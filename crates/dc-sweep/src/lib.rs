//! Steady-state diagnosis of operating-point sweeps: the averaged DC model of a buck converter
//! with its non-ideal effects ([`model`]: CCM and DCM, current and resistive load, diode drop,
//! series resistance, dead time), read from a sweep file ([`data`]), and which effects explain
//! the gap between the measured mean output voltages and the nominal model ([`diagnose()`]:
//! nonlinear least squares with CI95, forward selection of material, significant effects).
//!
//! Its one job is the DC view: a sweep of steady operating points cannot show dynamics (`Cl`,
//! ESR, ESL), so this crate is separate from `gap`, which diagnoses time series.
//!
//! ```
//! use dc_sweep::{Circuit, Options, Sweep, diagnose};
//! let csv = "# U = 12\n# RL = 0\nduty,io,vout\n0.2,1,2.1\n0.4,1,4.5\n0.6,1,6.9\n0.8,1,9.3\n";
//! let sweep = Sweep::parse_csv(csv)?;
//! let (circuit, _assumed) = sweep.circuit(&Circuit::default())?;
//! let d = diagnose(&sweep, &circuit, &Options::default())?;
//! assert!(d.gap_before.rms > 0.0);
//! # Ok::<(), dc_sweep::SweepError>(())
//! ```
#![forbid(unsafe_code)]

pub mod data;
pub mod diagnose;
mod error;
pub mod model;
pub mod stats;

pub use data::Sweep;
pub use diagnose::{Diagnosis, Effect, EffectFit, Options, diagnose};
pub use error::SweepError;
pub use model::{Circuit, Conduction, DcPoint, Effects, OperatingPoint, solve};
