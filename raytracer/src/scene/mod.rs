//! The scene model and its loaders.
//!
//! - [`load`]: Radiance `.rad` files and Wavefront `.obj` files, several
//!   forming one scene (like `oconv`: later files may use earlier materials);
//! - [`load_rad_str`]: scene text from memory (tests, examples);
//! - [`view`]: Radiance views (`-vtv -vp ...`, view files) and primary rays;
//! - [`record`]: a scene as the program of its records, its plain surfaces
//!   apart (what a compiled scene stores);
//! - [`generate`]: the built-in procedural scenes (Cornell box, studio,
//!   conference room), written as Radiance text.
//!
//! Every input error names file, line and reason; no input makes a loader
//! panic, and scene files never run shell commands.

mod bsdf_load;
mod build;
mod command;
mod genbox;
pub mod generate;
mod generators;
pub mod klems;
mod load;
mod model;
mod modifiers;
mod modstate;
mod obj;
mod octfile;
mod rad;
pub(crate) mod radbin;
pub mod record;
mod rtm;
pub mod view;
mod xform;

pub use crate::input;
pub(crate) use build::is_light_material;
pub use build::LoadOptions;
pub use load::{load, load_obj_str, load_rad_str, load_with};
pub use model::*;
pub use view::{View, ViewType};

#[cfg(test)]
mod binformat_tests;
#[cfg(test)]
mod tests;
