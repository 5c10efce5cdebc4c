//! A stack of layers between two ambient media.

use super::Layer;
use crate::error::{check_index, Error, Result};

/// Smallest thickness of a finite layer relative to the depth of its bottom face, 2⁻⁴⁰ ≈ 9.1e-13:
/// positions at depth z are resolved to about 1.1e-16 z, so a thinner layer's faces could not be
/// told apart (its thickness would be off by more than 1e-4 relative).
pub const MIN_THICKNESS_PER_DEPTH: f64 = 9.094947017729282e-13;

/// Layers from top (z = 0, light arrives from above) to bottom, with the refractive indices
/// of the ambient media above and below. Only the last layer may be semi-infinite.
#[derive(Clone, Debug, PartialEq)]
pub struct Stack {
    /// The layers, top first.
    pub layers: Vec<Layer>,
    /// Refractive index above the stack (≥ 1).
    pub n_above: f64,
    /// Refractive index below the stack (≥ 1; irrelevant if the last layer is semi-infinite).
    pub n_below: f64,
}

impl Stack {
    /// Validate and build a stack.
    pub fn new(layers: Vec<Layer>, n_above: f64, n_below: f64) -> Result<Self> {
        if layers.is_empty() {
            return Err(Error::Invalid("layers: the stack is empty; give at least one layer".into()));
        }
        check_index("n_above", n_above)?;
        check_index("n_below", n_below)?;
        let last = layers.len() - 1;
        let mut depth = 0.0;
        for (i, l) in layers.iter().enumerate() {
            l.validate(&format!("layers[{i}]."))?;
            if l.thickness.is_infinite() {
                if i != last {
                    return Err(Error::param(
                        format!("layers[{i}].thickness"),
                        l.thickness,
                        "finite: only the last layer may be semi-infinite",
                    ));
                }
                break;
            }
            depth += l.thickness;
            if !depth.is_finite() {
                return Err(Error::param(
                    format!("layers[{i}].thickness"),
                    l.thickness,
                    "such that the stack's total thickness stays finite (mm)",
                ));
            }
            if l.thickness < MIN_THICKNESS_PER_DEPTH * depth {
                return Err(Error::param(
                    format!("layers[{i}].thickness"),
                    l.thickness,
                    "at least 9.1e-13 times the depth of the layer's bottom face (the layers above are too \
                     thick for its faces to be resolved)",
                ));
            }
        }
        Ok(Stack { layers, n_above, n_below })
    }

    /// Depths of the interfaces: `[0, d0, d0 + d1, …]` (length = layers + 1; the last entry
    /// is infinite for a semi-infinite stack).
    pub fn boundaries(&self) -> Vec<f64> {
        let mut z = Vec::with_capacity(self.layers.len() + 1);
        let mut acc = 0.0;
        z.push(acc);
        for l in &self.layers {
            acc += l.thickness;
            z.push(acc);
        }
        z
    }

    /// Total thickness in mm (infinite for a semi-infinite stack).
    pub fn thickness(&self) -> f64 {
        self.layers.iter().map(|l| l.thickness).sum()
    }

    /// Whether the last layer is semi-infinite.
    pub fn is_semi_infinite(&self) -> bool {
        self.layers.last().is_some_and(|l| l.thickness.is_infinite())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn layer(d: f64) -> Layer {
        Layer::new(1.4, 0.1, 10.0, 0.9, d).unwrap()
    }

    #[test]
    fn validation() {
        assert!(Stack::new(vec![], 1.0, 1.0).unwrap_err().to_string().contains("empty"));
        let e = Stack::new(vec![layer(f64::INFINITY), layer(1.0)], 1.0, 1.0).unwrap_err().to_string();
        assert!(e.starts_with("layers[0].thickness"), "{e}");
        assert!(Stack::new(vec![layer(1.0)], 0.5, 1.0).unwrap_err().to_string().starts_with("n_above"));
        let mut bad = layer(1.0);
        bad.mus = -1.0;
        assert!(Stack::new(vec![layer(1.0), bad], 1.0, 1.0).unwrap_err().to_string().starts_with("layers[1].mus"));
        // a 1 mm layer below 1e308 mm of glass cannot be resolved; total depth must stay finite
        let glass = |d| Layer::new(1.0, 0.0, 0.0, 0.0, d).unwrap();
        let e = Stack::new(vec![glass(1e308), layer(1.0)], 1.0, 1.0).unwrap_err().to_string();
        assert!(e.starts_with("layers[1].thickness = 1.0 is out of range"), "{e}");
        let e = Stack::new(vec![glass(1e308), glass(1e308)], 1.0, 1.0).unwrap_err().to_string();
        assert!(e.starts_with("layers[1].thickness = 1e+308"), "{e}");
        assert!(Stack::new(vec![glass(1e6), layer(1e-6), layer(f64::INFINITY)], 1.0, 1.0).is_ok());
        assert_eq!(MIN_THICKNESS_PER_DEPTH, 2f64.powi(-40));
        let s = Stack::new(vec![layer(1.0), layer(f64::INFINITY)], 1.0, 1.0).unwrap();
        assert!(s.is_semi_infinite());
        assert_eq!(s.boundaries()[1], 1.0);
    }
}
