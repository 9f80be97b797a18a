//! The scene model and its loaders.

mod model;

pub use model::*;
