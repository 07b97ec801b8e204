//! Identification of the load capacitance `Cl` of a buck converter from one sample per
//! switching period, with the prediction-error method on grey-box models.
//!
//! Data flows one way: an [`experiment::Experiment`] run on a [`experiment::Plant`] (the
//! in-process model, an FMU, anything) or a CSV file gives a [`data::DataSet`]; a
//! [`model::Structure`] turns known circuit values and the data into a discrete predictor; the
//! [`pem`] fit returns `Cl` with its confidence interval and validation on held-out data.
#![forbid(unsafe_code)]

pub mod candidate;
pub mod data;
mod error;
pub mod experiment;
pub mod fmu_plant;
pub mod identify;
pub mod inputs;
pub mod model;
pub mod noise;
pub mod pem;
pub mod simulated;
pub mod validate;

pub use error::EstimatorError;
