//! A loaded SLAM problem (factor graph, initial values, file ids) and the choice of gauge.
//!
//! Pose graphs without a prior are invariant to a global rigid motion (the gauge freedom), so
//! H is singular until the gauge is fixed. g2o's tools fix one vertex (the first); GTSAM's
//! examples add a prior on the first pose. [`Gauge`] offers both; the χ² of the minimum is the
//! same, and the marginal of a pose is relative to the anchored first pose.

use serde::{Deserialize, Serialize};

use super::factors::{GaussianNoise, NoiseError, PriorSe2, PriorSe3};
use super::graph::{FactorGraph, GraphError};
use super::values::{Values, VarId, Variable};

/// How the global pose of the problem is anchored.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub enum Gauge {
    /// Fix the pose with the smallest id at its initial value (g2o's convention; default). A g2o
    /// file's `FIX` lines replace it ([`super::g2o::G2oFile::to_problem`]).
    #[default]
    FixFirst,
    /// Add a prior at its initial value on the pose with the smallest id, with standard deviation
    /// `sigma` on every tangent component (GTSAM's convention).
    PriorOnFirst {
        /// Standard deviation on every tangent component (metres and radians), > 0.
        sigma: f64,
    },
    /// Leave the gauge free (H is then singular unless other factors fix it).
    Free,
}

/// A problem read from a file.
#[derive(Debug, Default)]
pub struct Problem {
    /// The factors (with a gauge prior once [`Self::apply_gauge`] adds one).
    pub graph: FactorGraph,
    /// The variables at their initial values, with their fixed flags.
    pub values: Values,
    /// (file id, variable) of every pose, by increasing file id.
    pub poses: Vec<(u64, VarId)>,
    /// (file id, variable) of every landmark, by increasing file id.
    pub landmarks: Vec<(u64, VarId)>,
}

/// Why the gauge could not be applied.
#[derive(Clone, Debug, thiserror::Error, PartialEq)]
pub enum GaugeError {
    /// [`Gauge::PriorOnFirst`]'s sigma cannot make a noise model (not finite or not > 0).
    #[error("gauge prior: {0}")]
    Noise(#[from] NoiseError),
    /// The prior could not be added to the graph.
    #[error(transparent)]
    Graph(#[from] GraphError),
}

impl Problem {
    /// The pose with the largest file id.
    pub fn last_pose(&self) -> Option<VarId> {
        self.poses.last().map(|&(_, v)| v)
    }

    /// The pose with the smallest file id.
    pub fn first_pose(&self) -> Option<VarId> {
        self.poses.first().map(|&(_, v)| v)
    }

    /// Applies the gauge to the first pose (no-op without poses).
    pub fn apply_gauge(&mut self, gauge: Gauge) -> Result<(), GaugeError> {
        let Some(first) = self.first_pose() else { return Ok(()) };
        match gauge {
            Gauge::FixFirst => self.values.set_fixed(first, true),
            Gauge::Free => {}
            Gauge::PriorOnFirst { sigma } => match self.values.get(first) {
                Some(Variable::Se2(p)) => {
                    self.graph.add(PriorSe2::new(first, *p, GaussianNoise::isotropic(3, sigma)?))?;
                }
                Some(Variable::Se3(p)) => {
                    self.graph.add(PriorSe3::new(first, *p, GaussianNoise::isotropic(6, sigma)?))?;
                }
                _ => {}
            },
        }
        Ok(())
    }
}
