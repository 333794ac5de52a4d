//! The factor graph: a list of factors over the variables of a [`Values`]. Adding a factor is
//! O(1); [`FactorGraph::chi2`] is O(factors). A generation counter tells the optimiser when the
//! structure (hence its cached symbolic factorisation) changed.

use thiserror::Error;

use super::factors::{Factor, FactorError, MAX_FACTOR_KEYS};
use super::values::{Values, VarId};

#[derive(Clone, Debug, Error, PartialEq)]
pub enum GraphError {
    #[error("factor connects {0} variables; at most {MAX_FACTOR_KEYS} are supported")]
    TooManyKeys(usize),
    #[error("factor connects no variable")]
    NoKeys,
    #[error("factor connects variable {0:?} twice")]
    DuplicateKey(VarId),
}

/// Factors in insertion order.
#[derive(Debug, Default)]
pub struct FactorGraph {
    factors: Vec<Box<dyn Factor>>,
    generation: u64,
}

impl FactorGraph {
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds a factor and returns its index.
    pub fn add<F: Factor + 'static>(&mut self, factor: F) -> Result<usize, GraphError> {
        self.add_boxed(Box::new(factor))
    }

    pub fn add_boxed(&mut self, factor: Box<dyn Factor>) -> Result<usize, GraphError> {
        let keys = factor.keys();
        if keys.is_empty() {
            return Err(GraphError::NoKeys);
        }
        if keys.len() > MAX_FACTOR_KEYS {
            return Err(GraphError::TooManyKeys(keys.len()));
        }
        for (i, k) in keys.iter().enumerate() {
            if keys[..i].contains(k) {
                return Err(GraphError::DuplicateKey(*k));
            }
        }
        self.factors.push(factor);
        self.generation += 1;
        Ok(self.factors.len() - 1)
    }

    pub fn len(&self) -> usize {
        self.factors.len()
    }

    pub fn is_empty(&self) -> bool {
        self.factors.is_empty()
    }

    pub fn factors(&self) -> &[Box<dyn Factor>] {
        &self.factors
    }

    /// Changes whenever a factor is added.
    pub fn generation(&self) -> u64 {
        self.generation
    }

    /// Σ eᵀ Ω e over all factors.
    pub fn chi2(&self, values: &Values) -> Result<f64, FactorError> {
        self.factors.iter().map(|f| f.chi2(values)).sum()
    }
}
