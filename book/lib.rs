//! The book's Rust code blocks, compiled and run as doctests of this crate:
//! `cargo test --doc -p hybrid-book` checks every chapter, so prose and code
//! cannot drift apart. `mdbook test` is not needed.

#[cfg(doctest)]
#[doc = include_str!("src/introduction.md")]
pub struct Introduction;

#[cfg(doctest)]
#[doc = include_str!("src/framework.md")]
pub struct Framework;

#[cfg(doctest)]
#[doc = include_str!("src/rendering.md")]
pub struct Rendering;

#[cfg(doctest)]
#[doc = include_str!("src/parallel.md")]
pub struct Parallel;

#[cfg(doctest)]
#[doc = include_str!("src/accuracy.md")]
pub struct Accuracy;

#[cfg(doctest)]
#[doc = include_str!("src/hard-cases.md")]
pub struct HardCases;

#[cfg(doctest)]
#[doc = include_str!("src/simulation.md")]
pub struct Simulation;

#[cfg(doctest)]
#[doc = include_str!("src/mpi.md")]
pub struct Mpi;

#[cfg(doctest)]
#[doc = include_str!("src/benchmarks.md")]
pub struct Benchmarks;

#[cfg(doctest)]
#[doc = include_str!("src/scenes.md")]
pub struct Scenes;

#[cfg(doctest)]
#[doc = include_str!("src/radiance.md")]
pub struct RadianceCompatibility;
