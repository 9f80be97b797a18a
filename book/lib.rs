//! The book's Rust code blocks, compiled and run as doctests of this crate:
//! `cargo test --doc -p hybrid-book` checks every chapter, so prose and code
//! cannot drift apart. `mdbook test` is not needed. Every chapter of
//! `src/SUMMARY.md` is included here, in its order.

#[cfg(doctest)]
#[doc = include_str!("src/introduction.md")]
pub struct Introduction;

#[cfg(doctest)]
#[doc = include_str!("src/framework.md")]
pub struct Framework;

#[cfg(doctest)]
#[doc = include_str!("src/tutorial-first.md")]
pub struct TutorialFirst;

#[cfg(doctest)]
#[doc = include_str!("src/tutorial-fallback.md")]
pub struct TutorialFallback;

#[cfg(doctest)]
#[doc = include_str!("src/tutorial-scheduling.md")]
pub struct TutorialScheduling;

#[cfg(doctest)]
#[doc = include_str!("src/tutorial-sim.md")]
pub struct TutorialSim;

#[cfg(doctest)]
#[doc = include_str!("src/tutorial-mpi.md")]
pub struct TutorialMpi;

#[cfg(doctest)]
#[doc = include_str!("src/tutorial-epochs.md")]
pub struct TutorialEpochs;

#[cfg(doctest)]
#[doc = include_str!("src/parallel.md")]
pub struct Parallel;

#[cfg(doctest)]
#[doc = include_str!("src/rendering.md")]
pub struct Rendering;

#[cfg(doctest)]
#[doc = include_str!("src/scenes.md")]
pub struct Scenes;

#[cfg(doctest)]
#[doc = include_str!("src/radiance.md")]
pub struct RadianceCompatibility;

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
#[doc = include_str!("src/appendix-history.md")]
pub struct AppendixHistory;

/// Every chapter of `src/SUMMARY.md` is included above: a chapter added to
/// the book but not here would go untested.
#[cfg(test)]
mod tests {
    #[test]
    fn every_chapter_is_tested() {
        let summary = include_str!("src/SUMMARY.md");
        let lib = include_str!("lib.rs");
        let mut chapters = 0;
        for line in summary.lines() {
            let Some(start) = line.find("](") else {
                continue;
            };
            let rest = &line[start + 2..];
            let file = &rest[..rest.find(')').expect("a link ends")];
            let include = format!("include_str!(\"src/{file}\")");
            assert!(
                lib.contains(&include),
                "{file} is not included in book/lib.rs"
            );
            chapters += 1;
        }
        assert_eq!(chapters, 18);
    }
}
