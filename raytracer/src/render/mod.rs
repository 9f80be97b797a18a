//! The sequential reference renderer and the shading model, after
//! Radiance's `rpict` (diffuse inter-reflection, which the paper deferred,
//! only when `-ab` > 0).
//!
//! - [`options`]: [`RenderOptions`] under Radiance's names (`-ds`, `-dt`, ...);
//! - [`material`]: shading one hit point into local light plus *requests*
//!   (shadow bundles, reflected and refracted rays), the unit of work the
//!   parallel renderer schedules; it sits on [`task`] (the ray to shade),
//!   [`surface`] (how each surface weighs light from a direction) and
//!   [`shading`] (requests, shadow bundles and the emitter every material
//!   routine writes through);
//! - [`ambient`]: diffuse inter-reflection with an irradiance cache (`-ab`);
//! - [`light`] and [`direct`]: source subdivision and adaptive shadow testing;
//! - [`medium`]: participating media (`mist`, `-me -ma -mg -ms`);
//! - [`effects`]: which effects a scene calls for, and why;
//! - [`sequential`]: the [`Renderer`] that evaluates it all in process;
//! - [`stats`]: rays by kind, time per effect, `--stats` JSON;
//! - [`rng`]: per-pixel random streams (tile order never changes a pixel).

pub mod adaptive;
pub mod ambient;
pub mod aniso;
pub mod ashik;
pub mod brdf;
pub mod bsdf;
pub mod caster;
pub mod clip;
pub mod direct;
pub mod effects;
pub mod light;
pub mod material;
pub mod medium;
pub mod options;
pub use crate::geometry::rng;
pub mod sequential;
pub mod shading;
pub mod stats;
pub mod surface;
pub mod task;
pub mod virtual_source;
pub mod waves;

#[cfg(test)]
mod aniso_tests;
#[cfg(test)]
mod bsdf_tests;
#[cfg(test)]
mod shading_tests;

pub use caster::{BruteForceCaster, BvhCaster, OctreeCaster, RayCaster};
pub use effects::{Effect, EffectsReport};
pub use material::{RayKind, RayTask, Request, ShadowBundle};
pub use options::{RenderOptions, QUALITY_PRESETS, RADIANCE_OPTIONS};
pub use sequential::{check_resolution, Camera, Region, Renderer, TraceState};
pub use stats::{RayCounts, RenderStats, Timings};
