//! The two solvers behind [`super::GraphSlam`] (module doc there): the batch solver's graph and
//! values, or iSAM2 with what the current keyframe adds to it.

use nalgebra::Vector3;

use crate::slam::backend::SlamError;
use crate::slam::factors::Factor;
use crate::slam::graph::FactorGraph;
use crate::slam::incremental::Isam2;
use crate::slam::lie::Se3;
use crate::slam::optimizer::{LevenbergMarquardt, OptError, Optimizer, Summary};
use crate::slam::values::{Values, VarId, Variable};

/// The batch solver's state.
#[derive(Debug)]
pub(super) struct Batch {
    pub(super) graph: FactorGraph,
    pub(super) values: Values,
    pub(super) optimizer: LevenbergMarquardt,
}

/// The incremental solver and what the current keyframe adds to it.
#[derive(Debug)]
pub(super) struct Incremental {
    pub(super) isam: Isam2,
    pub(super) new_variables: Vec<Variable>,
    pub(super) new_factors: Vec<Box<dyn Factor>>,
}

#[derive(Debug)]
pub(super) enum Solver {
    Batch(Box<Batch>),
    Incremental(Box<Incremental>),
}

impl Solver {
    /// The id the next variable added gets.
    pub(super) fn next_id(&self) -> VarId {
        match self {
            Solver::Batch(b) => VarId(b.values.len()),
            Solver::Incremental(i) => VarId(i.isam.len() + i.new_variables.len()),
        }
    }

    pub(super) fn add_variable(&mut self, v: Variable) -> VarId {
        match self {
            Solver::Batch(b) => b.values.push(v),
            Solver::Incremental(i) => {
                i.new_variables.push(v);
                VarId(i.isam.len() + i.new_variables.len() - 1)
            }
        }
    }

    pub(super) fn add_factor(&mut self, f: impl Factor + 'static) -> Result<(), SlamError> {
        match self {
            Solver::Batch(b) => {
                b.graph.add(f)?;
            }
            Solver::Incremental(i) => i.new_factors.push(Box::new(f)),
        }
        Ok(())
    }

    /// The current estimate of `id` (a variable of this keyframe: its initial value).
    pub(super) fn get(&self, id: VarId) -> Option<Variable> {
        match self {
            Solver::Batch(b) => b.values.get(id).copied(),
            Solver::Incremental(i) => match id.0.checked_sub(i.isam.len()) {
                Some(k) => i.new_variables.get(k).copied(),
                None => i.isam.estimate_of(id),
            },
        }
    }

    pub(super) fn se3(&self, id: VarId) -> Option<Se3> {
        match self.get(id) {
            Some(Variable::Se3(t)) => Some(t),
            _ => None,
        }
    }

    pub(super) fn point3(&self, id: VarId) -> Option<Vector3<f64>> {
        match self.get(id) {
            Some(Variable::Point3(p)) => Some(p),
            _ => None,
        }
    }
}

impl Batch {
    pub(super) fn run(&mut self) -> Result<Summary, SlamError> {
        match self.optimizer.optimize(&self.graph, &mut self.values) {
            Ok(s) => Ok(s),
            // Not converged within the budget: the values hold the best estimate; keep going.
            Err(OptError::MaxIterations(s)) => Ok(s),
            Err(e) => Err(e.into()),
        }
    }
}
