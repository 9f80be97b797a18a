//! `hybrid-rt`: a Radiance-style ray tracer whose parallel form is the
//! hybrid-scheduled renderer of Reinhard, Chalmers and Jansen.
//!
//! Physics lives in [`geometry`], [`scene`], [`accel`] and [`render`]; the
//! sequential renderer in [`render`] is the oracle every parallel runtime must
//! reproduce bit for bit.
//!
//! The physics folders form layers, each using only those below it (and the
//! crate root's [`error`] and [`input`]); none knows of processors,
//! partitions or the scheduling framework:
//!
//! 1. [`geometry`]: vectors, colours, rays, boxes, shapes and objects, the
//!    bounding volume hierarchy an instance holds, the random streams;
//! 2. [`image`]: pictures in and out;
//! 3. [`cal`]: the `.cal` expression language;
//! 4. [`modifier`]: patterns, textures, data and fonts;
//! 5. [`scene`]: the scene model and its loaders and generators;
//! 6. [`accel`]: the octree over a scene and pyramid clipping;
//! 7. [`render`]: lights, materials, shading and the sequential renderer.
//!
//! Above them: [`compiled`] (compiled scenes, grouped by octree cell),
//! [`parallel`] (the hybrid-scheduled renderer), [`experiment`],
//! [`report`] and [`cli`].

pub mod accel;
pub mod cal;
pub mod cli;
pub mod compiled;
pub mod error;
pub mod experiment;
pub mod geometry;
pub mod image;
pub mod input;
pub mod modifier;
pub mod parallel;
pub mod render;
pub mod report;
pub mod scene;
#[cfg(test)]
mod testdata;

pub use error::{Error, Result, SourceLoc};
