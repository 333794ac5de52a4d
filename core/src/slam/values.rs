//! The state of a factor graph: one [`Variable`] per [`VarId`], in a flat vector, each with a
//! "fixed" flag (fixed variables are constants: the gauge anchor, or the keyframes outside a
//! sliding window). O(1) access.

use nalgebra::{Vector2, Vector3, Vector6};
use serde::{Deserialize, Serialize};

use super::lie::{Se2, Se3};

/// Index of a variable in [`Values`] (dense, from 0, in insertion order).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
pub struct VarId(pub usize);

/// One optimisation variable. Tangent dimensions: SE(2) 3, SE(3) 6, points 2 and 3; poses are
/// perturbed on the right (`x · Exp(ξ)`, ξ = (δt, δφ)), points additively.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum Variable {
    /// A planar pose, `world_from_body`.
    Se2(Se2),
    /// A 3D pose, `world_from_body`.
    Se3(Se3),
    /// A 2D point (landmark) in the world frame, metres.
    Point2(Vector2<f64>),
    /// A 3D point (landmark) in the world frame, metres.
    Point3(Vector3<f64>),
}

impl Variable {
    /// Tangent-space dimension.
    pub fn dim(&self) -> usize {
        match self {
            Variable::Se2(_) => 3,
            Variable::Se3(_) => 6,
            Variable::Point2(_) => 2,
            Variable::Point3(_) => 3,
        }
    }

    /// Name of the kind, for error messages.
    pub fn kind(&self) -> &'static str {
        match self {
            Variable::Se2(_) => "SE2",
            Variable::Se3(_) => "SE3",
            Variable::Point2(_) => "Point2",
            Variable::Point3(_) => "Point3",
        }
    }

    /// `self ⊕ δ`; `delta` has at least [`Variable::dim`] entries (extra ones are ignored).
    pub fn retract(&self, delta: &[f64]) -> Variable {
        match self {
            Variable::Se2(p) => Variable::Se2(p.retract(&Vector3::new(delta[0], delta[1], delta[2]))),
            Variable::Se3(p) => Variable::Se3(p.retract(&Vector6::from_column_slice(&delta[..6]))),
            Variable::Point2(p) => Variable::Point2(p + Vector2::new(delta[0], delta[1])),
            Variable::Point3(p) => Variable::Point3(p + Vector3::new(delta[0], delta[1], delta[2])),
        }
    }

    /// Whether every component is finite.
    pub fn is_finite(&self) -> bool {
        match self {
            Variable::Se2(p) => p.is_finite(),
            Variable::Se3(p) => p.is_finite(),
            Variable::Point2(p) => p.iter().all(|v| v.is_finite()),
            Variable::Point3(p) => p.iter().all(|v| v.is_finite()),
        }
    }
}

/// All variables of a problem, with their fixed flags.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Values {
    vars: Vec<Variable>,
    fixed: Vec<bool>,
}

impl Values {
    /// No variable.
    pub fn new() -> Self {
        Self::default()
    }

    /// Appends a free variable and returns its id.
    pub fn push(&mut self, var: Variable) -> VarId {
        self.vars.push(var);
        self.fixed.push(false);
        VarId(self.vars.len() - 1)
    }

    /// Number of variables, fixed ones included.
    pub fn len(&self) -> usize {
        self.vars.len()
    }

    /// Whether there is no variable.
    pub fn is_empty(&self) -> bool {
        self.vars.is_empty()
    }

    /// The variable `id`, if it exists.
    pub fn get(&self, id: VarId) -> Option<&Variable> {
        self.vars.get(id.0)
    }

    /// Replaces a variable (same id); returns false if `id` does not exist.
    pub fn set(&mut self, id: VarId, var: Variable) -> bool {
        match self.vars.get_mut(id.0) {
            Some(v) => {
                *v = var;
                true
            }
            None => false,
        }
    }

    /// The variable `id` if it is an SE(2) pose.
    pub fn se2(&self, id: VarId) -> Option<Se2> {
        match self.vars.get(id.0) {
            Some(Variable::Se2(p)) => Some(*p),
            _ => None,
        }
    }

    /// The variable `id` if it is an SE(3) pose.
    pub fn se3(&self, id: VarId) -> Option<Se3> {
        match self.vars.get(id.0) {
            Some(Variable::Se3(p)) => Some(*p),
            _ => None,
        }
    }

    /// The variable `id` if it is a 2D point, metres.
    pub fn point2(&self, id: VarId) -> Option<Vector2<f64>> {
        match self.vars.get(id.0) {
            Some(Variable::Point2(p)) => Some(*p),
            _ => None,
        }
    }

    /// The variable `id` if it is a 3D point, metres.
    pub fn point3(&self, id: VarId) -> Option<Vector3<f64>> {
        match self.vars.get(id.0) {
            Some(Variable::Point3(p)) => Some(*p),
            _ => None,
        }
    }

    /// Marks a variable fixed (a constant of the optimisation) or free. Ignores unknown ids.
    pub fn set_fixed(&mut self, id: VarId, fixed: bool) {
        if let Some(f) = self.fixed.get_mut(id.0) {
            *f = fixed;
        }
    }

    /// Whether the variable is fixed; unknown ids count as fixed.
    pub fn is_fixed(&self, id: VarId) -> bool {
        self.fixed.get(id.0).copied().unwrap_or(true)
    }

    /// The fixed flags, indexed by `VarId.0`.
    pub fn fixed_flags(&self) -> &[bool] {
        &self.fixed
    }

    /// Variables in id order.
    pub fn iter(&self) -> impl Iterator<Item = (VarId, &Variable)> {
        self.vars.iter().enumerate().map(|(i, v)| (VarId(i), v))
    }

    /// Retracts variable `id` by `delta` in place (no-op for unknown ids).
    pub fn retract_in_place(&mut self, id: VarId, delta: &[f64]) {
        if let Some(v) = self.vars.get_mut(id.0) {
            *v = v.retract(delta);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn push_get_fix_and_retract() {
        let mut values = Values::new();
        let a = values.push(Variable::Point2(Vector2::new(1.0, 2.0)));
        let b = values.push(Variable::Se2(Se2::new(0.0, 0.0, 0.0)));
        assert_eq!((a, b), (VarId(0), VarId(1)));
        assert!(values.se2(a).is_none());
        assert_eq!(values.point2(a), Some(Vector2::new(1.0, 2.0)));
        values.set_fixed(a, true);
        assert!(values.is_fixed(a) && !values.is_fixed(b) && values.is_fixed(VarId(7)));
        values.retract_in_place(a, &[0.5, -1.0]);
        assert_eq!(values.point2(a), Some(Vector2::new(1.5, 1.0)));
        // Pure rotation retract of the identity pose.
        values.retract_in_place(b, &[0.0, 0.0, 0.25]);
        assert_eq!(values.se2(b), Some(Se2::new(0.0, 0.0, 0.25)));
    }
}
