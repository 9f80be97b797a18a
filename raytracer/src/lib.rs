//! `hybrid-rt`: a Radiance-style ray tracer whose parallel form is the
//! hybrid-scheduled renderer of Reinhard, Chalmers and Jansen.
//!
//! Physics lives in [`geometry`], [`scene`], [`accel`] and [`render`]; the
//! sequential renderer in [`render`] is the oracle every parallel runtime must
//! reproduce bit for bit.

pub mod accel;
pub mod cal;
pub mod cli;
pub mod error;
pub mod experiment;
pub mod geometry;
pub mod image;
pub mod modifier;
pub mod parallel;
pub mod render;
pub mod report;
pub mod scene;
#[cfg(test)]
mod testdata;

pub use error::{Error, Result, SourceLoc};
