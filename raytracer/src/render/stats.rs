//! What a render did: rays by kind, effects and why, time per effect,
//! octree and scene statistics. Serialised by `--stats out.json`.

use std::time::Duration;

use serde::{Deserialize, Serialize};

use super::ambient::AmbientCounts;
use super::direct::ShadowCounts;
use super::effects::EffectsReport;
use super::options::RenderOptions;
use crate::accel::OctreeStats;
use crate::scene::SceneStats;

/// Rays by kind. Counts are sums over pixels, so they do not depend on
/// the order in which the image was rendered.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct RayCounts {
    pub primary: u64,
    pub reflection: u64,
    pub refraction: u64,
    /// Rays continued through invisible surfaces (`void`, bare `illum`).
    pub pass_through: u64,
    /// Hemisphere sample rays of diffuse inter-reflection.
    #[serde(default)]
    pub ambient: u64,
    pub shadow: ShadowCounts,
    /// Irradiance cache lookups, hits and hemispheres.
    #[serde(default)]
    pub ambient_cache: AmbientCounts,
}

impl RayCounts {
    pub fn add(&mut self, o: &RayCounts) {
        self.primary += o.primary;
        self.reflection += o.reflection;
        self.refraction += o.refraction;
        self.pass_through += o.pass_through;
        self.ambient += o.ambient;
        self.shadow.add(&o.shadow);
        self.ambient_cache.add(&o.ambient_cache);
    }

    /// Every ray cast into the octree.
    pub fn traced(&self) -> u64 {
        self.primary
            + self.reflection
            + self.refraction
            + self.pass_through
            + self.ambient
            + self.shadow.tested
            + self.shadow.transparent_segments
    }
}

/// Where the time went, in seconds. Effect times are exclusive: the time
/// of a reflected ray does not include the shadow bundles run at its hit
/// point, which count as `direct_s`. They are 0 unless the renderer
/// measures them ([`crate::render::Renderer::with_effect_times`]).
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Timings {
    /// Building the octree; `None` where the render built none (the
    /// sequential renderer traces through the hierarchy).
    #[serde(default)]
    pub octree_build_s: Option<f64>,
    /// Building the hierarchy rays are traced through.
    #[serde(default)]
    pub bvh_build_s: f64,
    /// Wall-clock time of the pixel loop.
    pub render_s: f64,
    /// Tracing and shading primary rays (and rays passed through invisible surfaces).
    pub primary_s: f64,
    /// Shadow bundles: patch subdivision, potentials, shadow rays.
    pub direct_s: f64,
    pub reflection_s: f64,
    pub refraction_s: f64,
    /// Hemisphere sample rays (their hits' shading included, except the
    /// shadow bundles and specular rays they spawn).
    #[serde(default)]
    pub ambient_s: f64,
}

/// Accumulated per-effect durations (kept as `Duration` while rendering).
#[derive(Debug, Clone, Copy, Default)]
pub struct EffectTimes {
    pub primary: Duration,
    pub direct: Duration,
    pub reflection: Duration,
    pub refraction: Duration,
    pub ambient: Duration,
}

impl EffectTimes {
    pub fn add(&mut self, o: &EffectTimes) {
        self.primary += o.primary;
        self.direct += o.direct;
        self.reflection += o.reflection;
        self.refraction += o.refraction;
        self.ambient += o.ambient;
    }
}

/// Everything `--stats` writes.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RenderStats {
    pub width: usize,
    pub height: usize,
    pub rays: RayCounts,
    /// Primary plus traced shadow rays per second of pixel loop, in millions.
    pub mrays_per_s: f64,
    pub effects: EffectsReport,
    pub time: Timings,
    /// The octree's; `None` where the render built none.
    #[serde(default)]
    pub octree: Option<OctreeStats>,
    pub scene: SceneStats,
    pub options: RenderOptions,
    /// Warnings from preparing the render (lights that cannot be sampled).
    pub warnings: Vec<String>,
    /// Irradiance cache records at the end of the render.
    #[serde(default)]
    pub ambient_records: usize,
    /// Pattern and texture evaluations that went wrong (counted over the
    /// scene's renders so far).
    #[serde(default)]
    pub pattern_errors: PatternErrors,
}

/// Function evaluations of patterns, textures and mixtures that failed:
/// Radiance's "compute error" warnings, counted instead of printed per ray.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct PatternErrors {
    /// Library calls, divisions and powers that failed and gave 0 (as in
    /// Radiance's calcomp).
    pub math_errors: u64,
    /// Results that were NaN (the pattern left the ray unchanged).
    pub nans: u64,
    /// Evaluations stopped by an error (recursion too deep, a missing
    /// argument): the pattern left the ray unchanged.
    pub failures: u64,
    /// The first NaN or failure, naming the modifier and its file:line.
    pub first: Option<String>,
}

impl PatternErrors {
    /// True when nothing went wrong.
    pub fn is_empty(&self) -> bool {
        self.math_errors == 0 && self.nans == 0 && self.failures == 0
    }
}
