//! Buck converter physics: the thesis circuit (inductor with series resistance, output
//! capacitor with ESR, load capacitor `Cl`, constant load current and an optional load resistor
//! `rload` at the output node), integrated exactly.
//!
//! The circuit is linear between switching events, so every piece is solved with a matrix
//! exponential ([`lti`]) instead of a time-stepping integrator: the fast `Rc·Cl` mode (20 ns
//! for `Cl` = 0.2 µF) costs nothing and causes no stiffness trouble. [`Converter`] advances
//! the averaged or the exact switched circuit over steps of any length, with the non-ideal
//! effects of [`Params`] (switch resistance, diode drop and DCM, dead time, ESR of `Cl`, ESL
//! of `C`, inductor saturation, DC bias of `Cl`) as further linear pieces and state events of
//! the same exact engine; [`variables`] holds
//! the one table of externally visible variables from which the FMU and its
//! `modelDescription.xml` are derived.
#![forbid(unsafe_code)]

mod converter;
pub mod digital;
mod error;
mod flow;
pub mod lti;
mod params;
pub mod variables;

pub use converter::{Converter, Inputs, Outputs, State};
pub use error::ModelError;
pub use params::{BiasLaw, Mode, Params};
