//! Radiance's modifiers that are not materials: patterns (colour),
//! textures (normal perturbation) and mixtures, with the data they read
//! (data files, pictures, fonts).

pub mod data;
pub mod font;
