//! Layered media: [`Layer`], [`Stack`], derived quantities, validation and mixtures.

mod layer;
mod mix;
mod stack;

pub use layer::Layer;
pub use mix::{mix, Component};
pub use stack::Stack;
