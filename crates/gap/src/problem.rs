//! What every search of one diagnosis shares: the data, the nominal model, how the data is split
//! between estimation and validation, and the nominal fit's baseline. The searches (the forward
//! and backward steps, the joint refit, the readings' instants) take it whole instead of the
//! same seven values each.
use buck_model::Params;
use estimator::data::DataSet;

use crate::effect::Baseline;

/// One diagnosis's data, nominal and split, as every search of it sees them.
#[derive(Clone, Copy)]
pub(crate) struct Problem<'a> {
    pub data: &'a DataSet,
    /// The nominal circuit (with the ceramic's bias law read at its reference).
    pub nominal: &'a Params,
    /// The nominal model is the switched one (else the averaged, whose ripple is an effect).
    pub switched_nominal: bool,
    /// The data is switched: the switched simulator's effects apply.
    pub switched_data: bool,
    /// Samples every fit estimates on; the rest are held out.
    pub n_est: usize,
    /// Share of the samples held out.
    pub holdout: f64,
    /// The nominal fit's figures every effect is judged against.
    pub baseline: &'a Baseline,
}
