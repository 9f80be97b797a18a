//! Diffuse inter-reflection with an irradiance cache, after Ward,
//! Rubinstein and Clear, "A Ray Tracing Solution for Diffuse
//! Interreflection" (SIGGRAPH 1988), as in Radiance's `ambient.c`.
//!
//! Where a diffuse surface needs the light arriving from all other
//! surfaces (`-ab` > 0), it first asks the cache: records made at nearby
//! points with similar normals are averaged with Ward's weights
//!
//! ```text
//! w_i(P) = 1 / ( |P - P_i| / R_i + sqrt(1 - N . N_i) )
//! ```
//!
//! using every record with `w_i > 1 / a` (`a` = `-aa`), and rejecting
//! records whose point lies in front of `P`. Only when no record qualifies
//! is a new hemisphere sampled: `-ad` cosine-weighted rays in `nt x np`
//! strata (`nt = sqrt(ad / pi)`, `np = pi nt`), then `-as` extra rays into
//! the strata whose neighbours differ most. The mean sample radiance is the
//! record's value (an ambient *radiance*, multiplied by the diffuse
//! reflectance as `-av` is), and the harmonic mean distance of the sample
//! hits is its radius `R_i`, clamped to `[size / ar, 64 size / ar]`. As
//! in Radiance's `doambient`, lighter sample rays get fewer divisions
//! (`-ad` and `-as` times the weight the sample rays carry, at least 6).
//! Sample rays see sources that direct lighting samples as black (no
//! double counting) and, after `-ab` bounces, surfaces use `-av`.
//!
//! **Evaluation order.** A cache makes a pixel depend on which records
//! existed when it was shaded, so an image depends on the order in which
//! pixels are rendered. The sequential renderer is deterministic for a
//! given order (scanlines top to bottom, left to right; the per-pixel
//! random streams of [`super::rng`] are unchanged), and tests fix it. A
//! parallel render evaluates in another order and agrees only within a
//! tolerance (the parallel renderer's ambient pass). With `-aa 0` there is no
//! cache and the image is again independent of the order.
//!
//! Not implemented: Ward and Heckbert's irradiance gradients (1992) and
//! Radiance's ambient file; `-aa` is not scaled by ray weight.

use std::collections::HashMap;
use std::f64::consts::PI;
use std::sync::{Arc, RwLock};

use serde::{Deserialize, Serialize};

use super::options::RenderOptions;
use super::rng::{child_seed, Rng};
use super::task::{intens, RayKind, RayTask};
use crate::geometry::robust::orthonormal_basis;
use crate::geometry::FTINY;
use crate::geometry::{offset_origin_scaled, Ray, Vec3};
use crate::image::brightness;
use crate::scene::Color;

/// Records may be at most this many times `size / ar` wide (Radiance's
/// `maxarad = 64 minarad`).
const MAX_RADIUS_FACTOR: f64 = 64.0;
/// A record lying more than this fraction of its radius in front of the
/// point is not used (Ward 1988's "in front" test).
const FRONT_TOLERANCE: f64 = 0.05;

/// Where a diffuse surface asks for the ambient light: what
/// [`super::material::shade`] returns instead of the `-av` term.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct AmbientRequest {
    pub point: Vec3,
    /// Unit normal on the side the light is gathered from.
    pub normal: Vec3,
    /// Diffuse reflectance (or transmittance) the ambient value is scaled by.
    pub coef: Color,
    /// Magnitude sample ray origins must be offset by.
    pub offset_scale: f64,
    /// 0 for the front side, 1 for diffuse transmission (back side).
    pub side: u32,
}

/// Parameters derived from the options and the scene's size.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct AmbientSettings {
    pub bounces: u32,
    pub accuracy: f64,
    pub min_radius: f64,
    pub max_radius: f64,
    /// Strata in theta and phi.
    pub nt: u32,
    pub np: u32,
    pub super_samples: u32,
    /// Side of the finest cell of the record grid.
    pub base_cell: f64,
}

impl AmbientSettings {
    /// Settings for a scene whose bounding cube has side `scene_size`.
    pub fn new(o: &RenderOptions, scene_size: f64) -> Self {
        let size = if scene_size.is_finite() && scene_size > 0.0 {
            scene_size
        } else {
            1.0
        };
        let (min_radius, max_radius) = if o.ar > 0 {
            let m = size / o.ar as f64;
            (m, MAX_RADIUS_FACTOR * m)
        } else {
            (size * 1e-9, size / 2.0)
        };
        let nt = ((o.ad as f64 / PI).sqrt().round() as u32).max(1);
        let np = ((PI * nt as f64).round() as u32).max(1);
        let base_cell = (o.aa.max(0.01) * min_radius).max(size * 1e-9);
        Self {
            bounces: o.ab,
            accuracy: o.aa,
            min_radius,
            max_radius,
            nt,
            np,
            super_samples: o.as_,
            base_cell,
        }
    }

    /// Hemisphere rays of the first pass at full weight.
    pub fn divisions(&self) -> usize {
        (self.nt * self.np) as usize
    }

    /// Strata for sample rays of weight `w` (at most 1): `-ad w` divisions,
    /// at least 6 (Radiance's minimum with a cache).
    pub fn strata(&self, w: f64) -> (u32, u32) {
        if w >= 1.0 {
            return (self.nt, self.np);
        }
        let ad = (self.nt * self.np) as f64 * w.max(0.0);
        let nt = ((ad / PI).sqrt().round() as u32).clamp(1, self.nt);
        let np = ((PI * nt as f64).round() as u32).clamp(2, self.np.max(2));
        (nt, np)
    }
}

/// One cached hemisphere: Ward's `(P_i, N_i, E_i, R_i)` plus the ambient
/// level it was computed at (records of deeper levels, with fewer bounces
/// left, are not used by shallower ones).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct AmbientRecord {
    pub point: Vec3,
    pub normal: Vec3,
    pub value: Color,
    pub radius: f64,
    pub level: u32,
}

impl AmbientRecord {
    /// Ward's error estimate `e_i(P)`: the record is usable where it is
    /// below `a`; `None` if the record lies in front of the point.
    pub fn error(&self, p: Vec3, n: Vec3) -> Option<f64> {
        let d = p - self.point;
        let along = d.dot(n + self.normal) * 0.5;
        if along < -FRONT_TOLERANCE * self.radius {
            return None;
        }
        let cos = n.dot(self.normal).min(1.0);
        Some(d.length() / self.radius + (1.0 - cos).max(0.0).sqrt())
    }
}

/// What the cache did: lookups answered by interpolation, hemispheres
/// sampled, records stored.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct AmbientCounts {
    pub lookups: u64,
    /// Lookups answered from records.
    pub hits: u64,
    /// Hemispheres sampled (lookups the cache could not answer).
    pub hemispheres: u64,
    /// Lookups that fell back to `-av` (ray too deep or too light to sample).
    pub fallbacks: u64,
}

impl AmbientCounts {
    pub fn add(&mut self, o: &AmbientCounts) {
        self.lookups += o.lookups;
        self.hits += o.hits;
        self.hemispheres += o.hemispheres;
        self.fallbacks += o.fallbacks;
    }
}

/// The irradiance cache: records in a hierarchy of uniform grids. A
/// record lives in the grid whose cells are at least as large as its
/// sphere of influence (`a R_i`), in every cell that sphere touches, so a
/// lookup reads one cell per grid level.
#[derive(Debug, Clone, Default)]
pub struct AmbientCache {
    records: Vec<AmbientRecord>,
    cells: HashMap<(u8, [i64; 3]), Vec<u32>>,
    /// Bit `l` set: grid level `l` holds records.
    levels: u64,
}

fn cell_of(p: Vec3, cell: f64) -> [i64; 3] {
    // `as` saturates (and maps NaN to 0): huge coordinates share a cell.
    [
        (p.x / cell).floor() as i64,
        (p.y / cell).floor() as i64,
        (p.z / cell).floor() as i64,
    ]
}

impl AmbientCache {
    pub fn len(&self) -> usize {
        self.records.len()
    }
    pub fn is_empty(&self) -> bool {
        self.records.is_empty()
    }
    pub fn records(&self) -> &[AmbientRecord] {
        &self.records
    }

    fn level_for(s: &AmbientSettings, influence: f64) -> u8 {
        let mut l = 0u8;
        let mut cell = s.base_cell;
        while cell < influence && l < 62 {
            cell *= 2.0;
            l += 1;
        }
        l
    }

    /// Records usable at `p` with normal `n` and ambient level `level`,
    /// as (index, weight); only records with index >= `from`.
    fn candidates(
        &self,
        s: &AmbientSettings,
        p: Vec3,
        n: Vec3,
        level: u32,
        from: usize,
        mut f: impl FnMut(usize, f64),
    ) {
        if s.accuracy <= 0.0 || !p.is_finite() {
            return;
        }
        let mut levels = self.levels;
        while levels != 0 {
            let l = levels.trailing_zeros() as u8;
            levels &= levels - 1;
            let cell = s.base_cell * (1u64 << l) as f64;
            let Some(ids) = self.cells.get(&(l, cell_of(p, cell))) else {
                continue;
            };
            for &i in ids {
                let i = i as usize;
                if i < from {
                    continue;
                }
                let r = &self.records[i];
                if r.level > level {
                    continue;
                }
                if let Some(e) = r.error(p, n) {
                    if e < s.accuracy {
                        f(i, 1.0 / e.max(1e-9));
                    }
                }
            }
        }
    }

    /// Ward's interpolation at `p`, or `None` if no record qualifies.
    pub fn lookup(&self, s: &AmbientSettings, p: Vec3, n: Vec3, level: u32) -> Option<Color> {
        let mut sum = Color::ZERO;
        let mut wsum = 0.0;
        self.candidates(s, p, n, level, 0, |i, w| {
            sum += self.records[i].value * w;
            wsum += w;
        });
        (wsum > 0.0).then(|| sum / wsum)
    }

    /// True if a record with index >= `from` would answer a lookup at `p`.
    pub fn covered_since(
        &self,
        s: &AmbientSettings,
        p: Vec3,
        n: Vec3,
        level: u32,
        from: usize,
    ) -> bool {
        let mut any = false;
        self.candidates(s, p, n, level, from, |_, _| any = true);
        any
    }

    /// Stores a record (ignored if it is not finite or caching is off).
    pub fn insert(&mut self, s: &AmbientSettings, r: AmbientRecord) {
        if s.accuracy <= 0.0
            || !(r.point.is_finite() && r.normal.is_finite() && r.value.is_finite())
            || !(r.radius.is_finite() && r.radius > 0.0)
        {
            return;
        }
        let influence = s.accuracy * r.radius;
        let l = Self::level_for(s, influence);
        let cell = s.base_cell * (1u64 << l) as f64;
        let lo = cell_of(r.point - Vec3::splat(influence), cell);
        let hi = cell_of(r.point + Vec3::splat(influence), cell);
        let id = self.records.len() as u32;
        self.records.push(r);
        self.levels |= 1 << l;
        for x in lo[0]..=hi[0] {
            for y in lo[1]..=hi[1] {
                for z in lo[2]..=hi[2] {
                    self.cells.entry((l, [x, y, z])).or_default().push(id);
                }
            }
        }
    }
}

/// The cache a trace state uses: its own (sequential), or one shared by
/// several threads (parallel).
#[derive(Debug, Clone)]
pub enum AmbientStore {
    Local(AmbientCache),
    Shared(Arc<RwLock<AmbientCache>>),
}

impl Default for AmbientStore {
    fn default() -> Self {
        AmbientStore::Local(AmbientCache::default())
    }
}

impl AmbientStore {
    pub fn lookup(&self, s: &AmbientSettings, p: Vec3, n: Vec3, level: u32) -> Option<Color> {
        match self {
            AmbientStore::Local(c) => c.lookup(s, p, n, level),
            AmbientStore::Shared(c) => c
                .read()
                .unwrap_or_else(|e| e.into_inner())
                .lookup(s, p, n, level),
        }
    }

    pub fn insert(&mut self, s: &AmbientSettings, r: AmbientRecord) {
        match self {
            AmbientStore::Local(c) => c.insert(s, r),
            AmbientStore::Shared(c) => c.write().unwrap_or_else(|e| e.into_inner()).insert(s, r),
        }
    }

    /// Records stored so far.
    pub fn len(&self) -> usize {
        match self {
            AmbientStore::Local(c) => c.len(),
            AmbientStore::Shared(c) => c.read().unwrap_or_else(|e| e.into_inner()).len(),
        }
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// One hemisphere being sampled. The sequential renderer traces its rays
/// at once; the parallel one hands them out as separate tasks and adds
/// their results in any order: the record depends only on the results.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Hemisphere {
    pub point: Vec3,
    pub normal: Vec3,
    /// Ambient level of the point (bounces already taken above it).
    pub level: u32,
    depth: u32,
    weight: f64,
    seed: u64,
    extinction: Color,
    #[serde(default)]
    medium: crate::render::medium::Medium,
    offset_scale: f64,
    nt: u32,
    np: u32,
    sums: Vec<Color>,
    counts: Vec<u32>,
    inv_dist: f64,
    samples: u32,
}

impl Hemisphere {
    /// A hemisphere for `req` at the hit of `task`, or `None` where the
    /// sample rays would exceed `-lr` or fall below `-lw` (the caller then
    /// uses `-av`, as Radiance does).
    pub fn new(
        s: &AmbientSettings,
        o: &RenderOptions,
        task: &RayTask,
        req: &AmbientRequest,
    ) -> Option<Self> {
        let depth = task.depth + 1;
        let weight = task.weight * intens(req.coef);
        if depth > o.lr || !(weight >= o.lw && weight > 0.0) {
            return None;
        }
        let len = req.normal.length();
        if !(len > 0.0 && len.is_finite() && req.point.is_finite()) {
            return None;
        }
        // Fewer divisions for lighter rays (Radiance's doambient): a
        // hemisphere deep in the tree matters less.
        let (nt, np) = s.strata(weight);
        let n = (nt * np) as usize;
        Some(Self {
            point: req.point,
            normal: req.normal / len,
            level: task.ambient,
            depth,
            weight,
            seed: child_seed(task.seed, 0x616d_0000 + req.side),
            extinction: task.extinction,
            medium: task.medium,
            offset_scale: req.offset_scale,
            nt,
            np,
            sums: vec![Color::ZERO; n],
            counts: vec![0; n],
            inv_dist: 0.0,
            samples: 0,
        })
    }

    /// The sample ray into division `div`; `pass` 0 for the first pass,
    /// 1 for super-samples (a different random draw).
    fn ray(&self, div: usize, pass: u32) -> RayTask {
        let seed = child_seed(self.seed, (div as u32) | (pass << 24));
        let mut rng = Rng::new(seed);
        let (t, p) = (div as u32 / self.np, div as u32 % self.np);
        let s2 = (t as f64 + rng.next_f64()) / self.nt as f64; // sin^2 theta
        let phi = 2.0 * PI * (p as f64 + rng.next_f64()) / self.np as f64;
        let st = s2.sqrt();
        let (u, v) = orthonormal_basis(self.normal);
        let dir = u * (phi.cos() * st) + v * (phi.sin() * st) + self.normal * (1.0 - s2).sqrt();
        let dir = dir.normalize();
        let origin = offset_origin_scaled(self.point, self.normal, dir, self.offset_scale);
        RayTask {
            ray: Ray { origin, dir },
            tmin: 0.0,
            tmax: f64::INFINITY,
            kind: RayKind::Ambient,
            depth: self.depth,
            weight: self.weight,
            seed: rng.next_u64(),
            extinction: self.extinction,
            // Sources that direct lighting samples are already counted.
            sampled: true,
            ambient: self.level + 1,
            clip: 0,
            medium: self.medium,
        }
    }

    /// The first pass: one ray per division, as (division, task).
    pub fn first_pass(&self) -> Vec<(usize, RayTask)> {
        (0..self.sums.len()).map(|d| (d, self.ray(d, 0))).collect()
    }

    /// Super-samples: one more ray into each of the `as` divisions whose
    /// brightness differs most from their neighbours' (call after the
    /// first pass's results are in).
    pub fn second_pass(&self, super_samples: u32) -> Vec<(usize, RayTask)> {
        let n = self.sums.len();
        let super_samples = (super_samples as f64 * self.weight.min(1.0)).round() as u32;
        if super_samples == 0 || n < 2 {
            return Vec::new();
        }
        let b = |i: usize| brightness(self.sums[i] / self.counts[i].max(1) as f64);
        let (nt, np) = (self.nt as usize, self.np as usize);
        let mut var: Vec<(f64, usize)> = (0..n)
            .map(|i| {
                let (t, p) = (i / np, i % np);
                let mut d = 0.0;
                if t > 0 {
                    d += (b(i) - b(i - np)).powi(2);
                }
                if t + 1 < nt {
                    d += (b(i) - b(i + np)).powi(2);
                }
                let left = t * np + (p + np - 1) % np;
                d += (b(i) - b(left)).powi(2);
                (d, i)
            })
            .collect();
        // Largest first; ties by index keep the choice deterministic.
        var.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
        var.iter()
            .take(super_samples as usize)
            .filter(|(d, _)| *d > 0.0)
            .map(|&(_, i)| (i, self.ray(i, 1)))
            .collect()
    }

    /// Adds the result of the ray into `div`: its radiance and the
    /// distance to what it hit (infinite for a miss).
    pub fn add(&mut self, div: usize, value: Color, distance: f64) {
        if let (Some(s), Some(c)) = (self.sums.get_mut(div), self.counts.get_mut(div)) {
            if value.is_finite() {
                *s += value;
            }
            *c += 1;
            if distance.is_finite() && distance > 0.0 {
                self.inv_dist += 1.0 / distance;
            }
            self.samples += 1;
        }
    }

    /// The record: mean radiance over the divisions and harmonic mean
    /// distance, clamped.
    pub fn finish(&self, s: &AmbientSettings) -> AmbientRecord {
        let mut v = Color::ZERO;
        for (sum, &c) in self.sums.iter().zip(&self.counts) {
            if c > 0 {
                v += *sum / c as f64;
            }
        }
        v /= self.sums.len().max(1) as f64;
        let harmonic = if self.inv_dist > FTINY * FTINY {
            self.samples as f64 / self.inv_dist
        } else {
            f64::INFINITY
        };
        AmbientRecord {
            point: self.point,
            normal: self.normal,
            value: v,
            radius: harmonic.clamp(s.min_radius, s.max_radius),
            level: self.level,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn settings(aa: f64) -> AmbientSettings {
        AmbientSettings::new(
            &RenderOptions {
                ab: 1,
                aa,
                ar: 16,
                ad: 64,
                ..Default::default()
            },
            16.0,
        )
    }

    fn rec(p: Vec3, r: f64, v: f64) -> AmbientRecord {
        AmbientRecord {
            point: p,
            normal: Vec3::Z,
            value: Color::splat(v),
            radius: r,
            level: 0,
        }
    }

    #[test]
    fn ward_weights_select_and_interpolate() {
        let s = settings(0.2);
        let mut c = AmbientCache::default();
        assert_eq!(c.lookup(&s, Vec3::ZERO, Vec3::Z, 0), None);
        c.insert(&s, rec(Vec3::ZERO, 1.0, 1.0));
        c.insert(&s, rec(Vec3::new(0.3, 0.0, 0.0), 1.0, 3.0));
        // Exactly at a record: that record dominates.
        let at0 = c.lookup(&s, Vec3::ZERO, Vec3::Z, 0).unwrap();
        assert!((at0.x - 1.0).abs() < 1e-6, "{at0}");
        // Half way: equal weights.
        let mid = c.lookup(&s, Vec3::new(0.15, 0.0, 0.0), Vec3::Z, 0).unwrap();
        assert!((mid.x - 2.0).abs() < 1e-9, "{mid}");
        // Beyond a * R of both: no answer.
        assert!(c.lookup(&s, Vec3::new(5.0, 0.0, 0.0), Vec3::Z, 0).is_none());
        // A tilted normal raises the error: 45 degrees is far beyond a = 0.2.
        let tilted = Vec3::new(1.0, 0.0, 1.0).normalize();
        assert!(c.lookup(&s, Vec3::ZERO, tilted, 0).is_none());
        // A record in front of the point is not used.
        assert!(c
            .lookup(&s, Vec3::new(0.0, 0.0, -0.1), Vec3::Z, 0)
            .is_none());
        // Deeper records are not used by shallower lookups.
        let mut d = AmbientCache::default();
        d.insert(
            &s,
            AmbientRecord {
                level: 1,
                ..rec(Vec3::ZERO, 1.0, 1.0)
            },
        );
        assert!(d.lookup(&s, Vec3::ZERO, Vec3::Z, 0).is_none());
        assert!(d.lookup(&s, Vec3::ZERO, Vec3::Z, 1).is_some());
        assert!(c.covered_since(&s, Vec3::new(0.2, 0.0, 0.0), Vec3::Z, 0, 1));
        assert!(!c.covered_since(&s, Vec3::ZERO, Vec3::Z, 0, 2));
    }

    #[test]
    fn grid_finds_records_of_every_size() {
        let s = settings(0.5);
        let mut c = AmbientCache::default();
        let mut rng = Rng::new(3);
        let recs: Vec<AmbientRecord> = (0..300)
            .map(|i| {
                let p = Vec3::new(rng.next_f64(), rng.next_f64(), 0.0) * 16.0 - 8.0;
                let r = s.min_radius * (1.0 + 63.0 * rng.next_f64());
                rec(p, r, i as f64)
            })
            .collect();
        for r in &recs {
            c.insert(&s, *r);
        }
        // Compare against brute force at random points.
        for _ in 0..500 {
            let p = Vec3::new(rng.next_f64(), rng.next_f64(), 0.0) * 16.0 - 8.0;
            let mut sum = 0.0;
            let mut w = 0.0;
            for r in &recs {
                if let Some(e) = r.error(p, Vec3::Z) {
                    if e < s.accuracy {
                        sum += r.value.x / e.max(1e-9);
                        w += 1.0 / e.max(1e-9);
                    }
                }
            }
            let brute = (w > 0.0).then(|| sum / w);
            let got = c.lookup(&s, p, Vec3::Z, 0).map(|c| c.x);
            match (brute, got) {
                (None, None) => {}
                (Some(a), Some(b)) => assert!((a - b).abs() < 1e-9 * a.abs().max(1.0)),
                other => panic!("{other:?} at {p}"),
            }
        }
    }

    #[test]
    fn no_cache_at_aa_zero_and_bad_records_ignored() {
        let s = settings(0.0);
        let mut c = AmbientCache::default();
        c.insert(&s, rec(Vec3::ZERO, 1.0, 1.0));
        assert!(c.is_empty());
        let s = settings(0.1);
        c.insert(&s, rec(Vec3::splat(f64::NAN), 1.0, 1.0));
        c.insert(&s, rec(Vec3::ZERO, 0.0, 1.0));
        assert!(c.is_empty());
        c.insert(&s, rec(Vec3::splat(1e300), 1.0, 1.0));
        assert_eq!(c.len(), 1);
        assert!(c.lookup(&s, Vec3::splat(1e300), Vec3::Z, 0).is_some());
    }

    #[test]
    fn hemisphere_rays_are_cosine_distributed_and_stratified() {
        let s = settings(0.1);
        let o = RenderOptions {
            ab: 1,
            ..Default::default()
        };
        let task = RayTask::primary(
            Ray {
                origin: Vec3::Z,
                dir: -Vec3::Z,
            },
            0.0,
            f64::INFINITY,
            7,
        );
        let req = AmbientRequest {
            point: Vec3::ZERO,
            normal: Vec3::Z,
            coef: Color::ONE,
            offset_scale: 1.0,
            side: 0,
        };
        let h = Hemisphere::new(&s, &o, &task, &req).unwrap();
        let rays = h.first_pass();
        assert_eq!(rays.len(), s.divisions());
        // E[cos] = 2/3 for a cosine-weighted hemisphere.
        let mean_cos: f64 = rays.iter().map(|(_, t)| t.ray.dir.z).sum::<f64>() / rays.len() as f64;
        assert!((mean_cos - 2.0 / 3.0).abs() < 0.01, "{mean_cos}");
        for (_, t) in &rays {
            assert!(t.ray.dir.z > 0.0 && t.ray.origin.z > 0.0);
            assert_eq!((t.kind, t.ambient, t.sampled), (RayKind::Ambient, 1, true));
        }
        // Constant radiance and distance: the record holds them exactly.
        let mut h2 = h.clone();
        for (d, _) in &rays {
            h2.add(*d, Color::splat(2.0), 4.0);
        }
        assert!(
            h2.second_pass(16).is_empty(),
            "no variance, no super-samples"
        );
        let r = h2.finish(&s);
        assert!((r.value.x - 2.0).abs() < 1e-12);
        assert!((r.radius - 4.0).abs() < 1e-9);
        // Too light a ray: no hemisphere.
        let light = RayTask {
            weight: 1e-3,
            ..task
        };
        assert!(Hemisphere::new(&s, &o, &light, &req).is_none());
    }
}
