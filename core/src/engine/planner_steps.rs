//! The planner sequence on an [`Engine`]: [`Engine::predict_planner`] and the
//! steps [`crate::planner::sequence`] runs, in the model's unit.

use super::{Backend, Engine};
use crate::output::PredictError;
use crate::planner::PlannerOutput;

impl<B: Backend, const W: usize> Engine<'_, B, W> {
    crate::planner::planner_call! {
        /// The planner sequence in the model's unit, as
        /// [`Predictor::predict_planner`](crate::Predictor::predict_planner) runs it in the
        /// caller's: the endpoint set into `endpoints` ([`Engine::predict_endpoint_set`]
        /// with its `N`), their probabilities into `probabilities`
        /// ([`Engine::probabilities`]), then the point forecast (with a point head) and,
        /// for a model with probabilities, the radii ([`crate::planner::radii`]).
        /// [`PredictError::BadSampleCount`] when the two buffers differ in length.
        pub fn predict_planner<const N: usize>(&mut self, past: &[[f32; 2]], seed: u64, endpoints: &mut [[f32; 2]], probabilities: &mut [f32]) -> Result<PlannerOutput, PredictError>;
    }
}

crate::planner::steps_by_calls!([B: Backend, const W: usize] Engine<'_, B, W>);
