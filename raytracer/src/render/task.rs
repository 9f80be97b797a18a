//! What a ray to shade carries: its kind, depth, weight, seed and the
//! medium it travels in (the bottom of the shading files: the material
//! routines, the medium and the ambient cache all pass rays around).

use serde::{Deserialize, Serialize};

use crate::geometry::Ray;
use crate::scene::Color;

/// Radiance's `intens()`: the largest component.
#[inline]
pub fn intens(c: Color) -> f64 {
    c.max_element()
}

/// What a secondary ray is for (its statistics bucket).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum RayKind {
    Primary,
    Reflection,
    Refraction,
    /// A ray continued unchanged through an invisible surface (`void`,
    /// `illum` without alternate).
    PassThrough,
    /// A hemisphere sample ray of diffuse inter-reflection (`-ab`).
    Ambient,
}

/// A ray to trace and shade.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct RayTask {
    pub ray: Ray,
    pub tmin: f64,
    pub tmax: f64,
    pub kind: RayKind,
    /// Reflection depth: 0 for primary rays (Radiance's `rlvl`).
    pub depth: u32,
    /// Product of the coefficients leading to this ray (Radiance's `rweight`).
    pub weight: f64,
    /// Seed of this ray's random numbers.
    pub seed: u64,
    /// Extinction coefficient per unit length of the medium the ray starts in.
    pub extinction: Color,
    /// A sampled rough-specular ray: it sees sampled light sources as black,
    /// because direct lighting already includes their specular highlight.
    /// Hemisphere rays are sampled too, and so is every ray descended from
    /// a sampled one.
    pub sampled: bool,
    /// Ambient bounces taken on the way to this ray (0 for primary rays).
    #[serde(default)]
    pub ambient: u32,
    /// Antimatter clip set: the ray passes through surfaces of materials
    /// whose [`Scene::clip_bit`](crate::scene::Scene::clip_bit) it shares (see [`super::clip`]).
    #[serde(default)]
    pub clip: u64,
    /// Albedo, eccentricity and scattering sources of the medium the ray
    /// travels through (see [`super::medium`]).
    #[serde(default)]
    pub medium: Medium,
}

impl RayTask {
    /// A primary ray.
    pub fn primary(ray: Ray, tmin: f64, tmax: f64, seed: u64) -> Self {
        Self {
            ray,
            tmin,
            tmax,
            kind: RayKind::Primary,
            depth: 0,
            weight: 1.0,
            seed,
            extinction: Color::ZERO,
            sampled: false,
            ambient: 0,
            clip: 0,
            medium: Medium::default(),
        }
    }
}

/// Where a ray travels besides its extinction: Radiance's `r->albedo`,
/// `r->gecc` and `r->slights`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Medium {
    /// Scattering albedo (scattering over extinction).
    pub albedo: Color,
    /// Henyey-Greenstein eccentricity (0: isotropic).
    pub gecc: f64,
    /// The mists with light sources the ray is inside: bit `k` is the
    /// mist of slot `k` of [`Media`](super::medium::Media).
    pub scatter: u64,
}
