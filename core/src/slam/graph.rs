//! The factor graph: a list of factors over the variables of a [`Values`]. Adding a factor is
//! O(1); [`FactorGraph::chi2`] is O(factors). A generation counter tells the optimiser when the
//! structure (hence its cached symbolic factorisation) changed.

use thiserror::Error;

use super::factors::{Factor, FactorError, MAX_FACTOR_KEYS};
use super::values::{Values, VarId};

/// Why a factor could not be added.
#[derive(Clone, Debug, Error, PartialEq)]
pub enum GraphError {
    /// The factor connects more than [`MAX_FACTOR_KEYS`] variables (how many).
    #[error("factor connects {0} variables; at most {MAX_FACTOR_KEYS} are supported")]
    TooManyKeys(usize),
    /// The factor connects no variable.
    #[error("factor connects no variable")]
    NoKeys,
    /// The factor names this variable twice.
    #[error("factor connects variable {0:?} twice")]
    DuplicateKey(VarId),
}

/// Factors in insertion order.
#[derive(Debug, Default)]
pub struct FactorGraph {
    factors: Vec<Box<dyn Factor>>,
    /// Each factor's keys, beside the boxes: scanning the structure (every window update does)
    /// reads this flat array instead of every factor's heap object.
    keys: Vec<FactorKeys>,
    generation: u64,
}

/// A factor's keys in a fixed-size buffer (the graph caps them at [`MAX_FACTOR_KEYS`]).
#[derive(Clone, Copy, Debug)]
struct FactorKeys {
    ids: [VarId; MAX_FACTOR_KEYS],
    len: usize,
}

impl FactorGraph {
    /// No factor.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds a factor and returns its index.
    pub fn add<F: Factor + 'static>(&mut self, factor: F) -> Result<usize, GraphError> {
        self.add_boxed(Box::new(factor))
    }

    /// Adds a boxed factor and returns its index.
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
        let mut ids = [VarId(0); MAX_FACTOR_KEYS];
        ids[..keys.len()].copy_from_slice(keys);
        self.keys.push(FactorKeys { ids, len: keys.len() });
        self.factors.push(factor);
        self.generation += 1;
        Ok(self.factors.len() - 1)
    }

    /// Number of factors.
    pub fn len(&self) -> usize {
        self.factors.len()
    }

    /// Whether there is no factor.
    pub fn is_empty(&self) -> bool {
        self.factors.is_empty()
    }

    /// The factors, by index.
    pub fn factors(&self) -> &[Box<dyn Factor>] {
        &self.factors
    }

    /// The keys of factor `index`, as its [`Factor::keys`] (from a flat copy). Panics if `index`
    /// is not a factor's.
    pub fn keys_of(&self, index: usize) -> &[VarId] {
        let k = &self.keys[index];
        &k.ids[..k.len]
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::slam::factors::{BetweenSe2, GaussianNoise, PriorSe2};
    use crate::slam::lie::Se2;

    #[test]
    fn flat_keys_are_the_factors_keys() {
        let noise = GaussianNoise::isotropic(3, 0.1).unwrap();
        let mut graph = FactorGraph::new();
        graph.add(PriorSe2::new(VarId(3), Se2::new(0.0, 0.0, 0.0), noise)).unwrap();
        graph.add(BetweenSe2::new(VarId(5), VarId(2), Se2::new(1.0, 0.0, 0.0), noise)).unwrap();
        graph.add(BetweenSe2::new(VarId(0), VarId(7), Se2::new(1.0, 0.0, 0.0), noise)).unwrap();
        assert_eq!(graph.len(), 3);
        assert_eq!(graph.keys_of(0), &[VarId(3)]);
        assert_eq!(graph.keys_of(1), &[VarId(5), VarId(2)]);
        assert_eq!(graph.keys_of(2), &[VarId(0), VarId(7)]);
        for (i, f) in graph.factors().iter().enumerate() {
            assert_eq!(graph.keys_of(i), f.keys());
        }
        // A rejected factor leaves both lists alone.
        let generation = graph.generation();
        assert_eq!(graph.add(BetweenSe2::new(VarId(1), VarId(1), Se2::new(1.0, 0.0, 0.0), noise)), Err(GraphError::DuplicateKey(VarId(1))));
        assert_eq!((graph.len(), graph.generation()), (3, generation));
    }
}
