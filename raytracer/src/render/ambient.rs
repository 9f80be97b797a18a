//! Diffuse inter-reflection with an irradiance cache, as Radiance 5.4
//! computes it (`ambient.c` 2.110 and `ambcomp.c` 2.86): Ward, Rubinstein
//! and Clear's cache ("A Ray Tracing Solution for Diffuse
//! Interreflection", SIGGRAPH 1988) with Ward and Heckbert's gradients
//! (1992) and the Hessian-based radii of Schwarzhaupt, Jensen and Jarosz
//! (SIGGRAPH Asia 2012).
//!
//! Where a diffuse surface needs the light arriving from all other
//! surfaces (`-ab` > 0), it first asks the cache. A record made at `P_i`
//! with normal `N_i`, axes `U_i, V_i` and radii `R_u <= R_v` serves a point
//! `P` with normal `N` (`sumambient`) when
//!
//! ```text
//! angle(N, N_i) < maxangle        (10 degrees plus -aa radians)
//! d_t^2 = ((P-P_i).N_i / R_u)^2 + ((P-P_i).U_i / R_u)^2 + ((P-P_i).V_i / R_v)^2 < a^2
//! ```
//!
//! (`a` = `-aa`; a record lying more than a little in front of `P` is not
//! used), and its value, extrapolated along its translational and
//! rotational gradients, counts with the weight
//! `(1 - angle / maxangle) (1 - d_t / a)`. Records of deeper ambient
//! levels are not used by shallower lookups, and a record of the same level
//! only by rays not much heavier than the one it was made for. For rays
//! lighter than 0.6 the angle limit widens towards 90 degrees.
//!
//! Only when no record qualifies is a new hemisphere sampled
//! ([`Hemisphere`]): its mean radiance is the value, and its record is
//! stored. Radii lie in `[size / ar, min(64 size / ar, size / 5)]`, the
//! larger at most twice the smaller.
//!
//! **Evaluation order.** A cache makes a pixel depend on which records
//! existed when it was shaded. Both renderers therefore shade pixels in
//! waves ([`super::waves`]): within a wave every pixel reads the cache as
//! it was when the wave began plus the records its own trace makes, and
//! the wave's records join the cache in pixel order; so the picture does
//! not depend on the order in which pixels are shaded, nor on the number
//! of processors. With `-aa 0` there is no cache.
//!
//! Radiance's leak test for records near occluders (`plugaleak`, the
//! records' `corral`) and its ambient file (`-af`, in `ambient/file.rs`)
//! are implemented. Not implemented: the rotational gradient of a
//! textured normal without a cache.

use std::collections::HashMap;
use std::f64::consts::PI;
use std::hash::{BuildHasherDefault, Hasher};
use std::sync::Arc;

use serde::{Deserialize, Serialize};

use super::options::RenderOptions;
use crate::geometry::Vec3;
use crate::geometry::FTINY;
use crate::scene::Color;

mod file;
mod hemisphere;

pub use file::{append_ambient_file, parse_ambient_file, read_ambient_file, AmbientFile};
pub use hemisphere::{strata_mean_of_first_pass, Hemisphere};

/// Radiance's assumed average reflectance (`AVGREFL`): ambient sample rays
/// carry this share of the weight of the ray they start from, and a record
/// of ambient level `l` is made for rays of weight `AVGREFL^l`.
const AVGREFL: f64 = 0.5;
/// Fewest strata per side of a hemisphere with a cache (`MINADIV`).
const MINADIV: u32 = 7;

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
    pub super_samples: u32,
    /// Side of the scene's bounding cube.
    pub scene_size: f64,
    /// Side of the finest cell of the record grid.
    pub base_cell: f64,
}

impl AmbientSettings {
    /// Settings for a scene whose bounding cube has side `scene_size`
    /// (Radiance's `setambres`).
    pub fn new(o: &RenderOptions, scene_size: f64) -> Self {
        let size = if scene_size.is_finite() && scene_size > 0.0 {
            scene_size
        } else {
            1.0
        };
        let (mut min_radius, mut max_radius) = if o.ar > 0 {
            let m = size / o.ar as f64;
            (m, (64.0 * m).min(0.2 * size))
        } else {
            (0.0, 0.2 * size)
        };
        if min_radius <= FTINY {
            min_radius = 10.0 * FTINY;
        }
        if max_radius <= min_radius {
            max_radius = 64.0 * min_radius;
        }
        let base_cell = (o.aa.max(0.01) * min_radius).max(size * 1e-9);
        Self {
            bounces: o.ab,
            accuracy: o.aa,
            min_radius,
            max_radius,
            super_samples: o.as_,
            scene_size: size,
            base_cell,
        }
    }
}

/// One cached hemisphere (Radiance's `AMBVAL`): where and for which
/// normal it was made, its value (a radiance, multiplied by the diffuse
/// reflectance as `-av` is), its radii along `u` and along `normal x u`,
/// its gradients along those axes, its ambient level and the ray weight it
/// was made for.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct AmbientRecord {
    pub point: Vec3,
    pub normal: Vec3,
    /// First tangent axis (the smaller radius's).
    pub u: Vec3,
    pub value: Color,
    pub radii: [f64; 2],
    /// Translational gradient (relative change per unit length).
    pub gpos: [f64; 2],
    /// Rotational gradient (relative change per radian).
    pub gdir: [f64; 2],
    pub level: u32,
    pub weight: f64,
    /// Directions around the point, in 32 sectors of the tangent plane
    /// counted from `u` towards `v`, in which the hemisphere met an
    /// occluder closer than the record reaches (Radiance's `corral`): a
    /// lookup from such a direction first checks that nothing opaque
    /// stands between it and the record ([`AmbientRecord::leak_test`]).
    #[serde(default)]
    pub corral: u32,
}

/// `cos(70 degrees)^2`: the leak test aims 20 degrees above the plane.
const COS70SQ: f64 = 0.116_977_8;

/// What checking a record for a light leak needs (Radiance's `plugaleak`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum LeakTest {
    /// The record may serve the point.
    Keep,
    /// It may not (the test ray could not be aimed).
    Plug,
    /// It may if nothing opaque crosses this ray from the lookup point
    /// (unit direction, length).
    Trace(Vec3, f64),
}

/// Radiance's starting angle limit: 10 degrees (plus `-aa` radians).
const MIN_ANGLE: f64 = 10.0 * PI / 180.0;

impl AmbientRecord {
    /// The second tangent axis.
    pub fn v(&self) -> Vec3 {
        self.normal.cross(self.u)
    }

    /// The leak test for a lookup at `p` with normal `n` (Radiance's
    /// `plugaleak`): where the record's corral flags the direction of `p`,
    /// a ray from `p` aimed past the record's point, 20 degrees above
    /// the lookup's tangent plane, must not meet an opaque surface.
    pub fn leak_test(&self, p: Vec3, n: Vec3) -> LeakTest {
        if self.corral == 0 {
            return LeakTest::Keep;
        }
        let ck = p - self.point;
        if ck.length() <= 1e-9 * self.radii[0] {
            // The record's own point (where Radiance's test ray cannot be
            // aimed and it would plug): a record always serves it.
            return LeakTest::Keep;
        }
        let mut ang = ck.dot(self.v()).atan2(ck.dot(self.u));
        if ang < 0.0 {
            ang += 2.0 * PI;
        }
        let sector = ((ang * (16.0 / PI)) as u32).min(31);
        if (self.corral >> sector) & 1 == 0 {
            return LeakTest::Keep;
        }
        let vdif = self.point - p;
        let normdot = self.normal.dot(n);
        let ndotd = vdif.dot(n);
        let nadotd = vdif.dot(self.normal);
        let a = normdot * normdot - COS70SQ;
        let b = 2.0 * (normdot * ndotd - nadotd * COS70SQ);
        let c = ndotd * ndotd - vdif.length_squared() * COS70SQ;
        let t = quadratic(a, b, c);
        if t.len() != 2 {
            return LeakTest::Plug;
        }
        if t[1] <= FTINY {
            return LeakTest::Keep;
        }
        let dir = vdif + self.normal * t[1];
        let len = dir.length();
        if !(len > 0.0 && len.is_finite()) {
            return LeakTest::Keep;
        }
        LeakTest::Trace(dir / len, len)
    }

    /// How far the record reaches: no point farther than `a` times this
    /// from it can use it.
    pub fn reach(&self) -> f64 {
        self.radii[0].max(self.radii[1])
    }

    /// The record's value at `p` with normal `n` and its weight there, for
    /// a lookup of accuracy `a` and angle limit `max_angle`, with Radiance's
    /// minimum radius `min_radius`; `None` where the record does not serve
    /// the point.
    pub fn serve(
        &self,
        p: Vec3,
        n: Vec3,
        a: f64,
        max_angle: f64,
        min_radius: f64,
    ) -> Option<(Color, f64)> {
        let cos = self.normal.dot(n);
        if cos <= 0.0 {
            return None;
        }
        let dr2 = 2.0 - 2.0 * cos;
        if dr2 >= max_angle * max_angle {
            return None;
        }
        let ck = p - self.point;
        let d = ck.dot(self.normal);
        if d < -min_radius * a - 0.001 {
            return None;
        }
        let d = d / self.radii[0];
        let mut dt2 = d * d;
        if dt2 >= a * a {
            return None;
        }
        let (u, v) = (self.u, self.v());
        let du = ck.dot(u) / self.radii[0];
        let dv = ck.dot(v) / self.radii[1];
        dt2 += du * du + dv * dv;
        if dt2 >= a * a {
            return None;
        }
        // Extrapolated along the gradients (extambient).
        let mut f = 1.0 + ck.dot(u * self.gpos[0] + v * self.gpos[1]);
        f += self
            .normal
            .cross(n)
            .dot(u * self.gdir[0] + v * self.gdir[1]);
        let f = f.clamp(0.05, 20.0);
        if f <= 0.05 {
            return None;
        }
        let w = (1.0 - dr2.sqrt() / max_angle) * (1.0 - dt2.sqrt() / a);
        Some((self.value * f, w))
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
    /// By (level, cell); only looked up, never iterated.
    cells: CellMap,
    /// Bit `l` set: grid level `l` holds records.
    levels: u64,
    /// Sum of the logarithms of the records' brightnesses (those above
    /// `FTINY`) and their number: Radiance's `avsum` and `navsum`, for
    /// `-aw` ([`AmbientStore::ambient_value`]).
    log_sum: f64,
    log_count: u32,
}

/// The grid's cells, hashed by [`CellHasher`].
type CellMap = HashMap<(u8, [i64; 3]), Vec<u32>, BuildHasherDefault<CellHasher>>;

/// A hasher for the grid's keys, four integers: a rotate, an xor and a
/// multiply per word (FxHash's mixing). SipHash's resistance to chosen
/// keys buys nothing for cells of a scene's geometry, and it took 1.2% of
/// a render with `-ab 1`. The map is never iterated, so its order does
/// not matter.
#[derive(Clone, Copy, Debug, Default)]
struct CellHasher(u64);

impl CellHasher {
    #[inline]
    fn add(&mut self, word: u64) {
        self.0 = (self.0.rotate_left(5) ^ word).wrapping_mul(0x517c_c1b7_2722_0a95);
    }
}

impl Hasher for CellHasher {
    fn finish(&self) -> u64 {
        self.0
    }

    /// Eight bytes a word: a key's `[i64; 3]` arrives here whole (the
    /// standard library hashes a slice of integers as its bytes), and a
    /// byte a round cost 1.7% of a render with `-ab 1`.
    fn write(&mut self, bytes: &[u8]) {
        let mut words = bytes.chunks_exact(8);
        for w in &mut words {
            let mut b = [0u8; 8];
            b.copy_from_slice(w);
            self.add(u64::from_le_bytes(b));
        }
        for &b in words.remainder() {
            self.add(u64::from(b));
        }
    }

    fn write_u8(&mut self, i: u8) {
        self.add(u64::from(i));
    }

    fn write_i64(&mut self, i: i64) {
        self.add(i as u64);
    }

    fn write_usize(&mut self, i: usize) {
        self.add(i as u64);
    }
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

    /// Records usable at `p` with normal `n` by a ray of ambient level
    /// `level` and weight `weight`, as (index, extrapolated value, weight).
    #[allow(clippy::too_many_arguments)]
    fn candidates(
        &self,
        s: &AmbientSettings,
        p: Vec3,
        n: Vec3,
        level: u32,
        weight: f64,
        leak: &mut dyn FnMut(Vec3, Vec3, f64) -> bool,
        mut f: impl FnMut(usize, Color, f64),
    ) {
        if s.accuracy <= 0.0 || !p.is_finite() {
            return;
        }
        let mut max_angle = MIN_ANGLE + s.accuracy;
        if weight < 0.6 {
            // Lighter rays accept records of larger angles.
            max_angle = (max_angle - PI / 2.0) * weight.max(0.0).powf(0.13) + PI / 2.0;
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
                let r = &self.records[i];
                if r.level > level || (r.level == level && r.weight < 0.9 * weight) {
                    continue;
                }
                let Some((v, w)) = r.serve(p, n, s.accuracy, max_angle, s.min_radius) else {
                    continue;
                };
                match r.leak_test(p, n) {
                    LeakTest::Keep => {}
                    LeakTest::Plug => continue,
                    LeakTest::Trace(dir, len) => {
                        if leak(p, dir, len) {
                            continue;
                        }
                    }
                }
                f(i, v, w);
            }
        }
    }

    /// The interpolated value at `p` for a ray of ambient level `level`
    /// and weight `weight`, or `None` if no record qualifies; a record
    /// whose leak test traces a ray counts as occluded where nothing is
    /// (see [`AmbientCache::lookup_plugged`]).
    pub fn lookup(
        &self,
        s: &AmbientSettings,
        p: Vec3,
        n: Vec3,
        level: u32,
        weight: f64,
    ) -> Option<Color> {
        self.lookup_plugged(s, p, n, level, weight, &mut |_, _, _| false)
    }

    /// [`AmbientCache::lookup`] where `occluded(origin, unit direction,
    /// length)` answers the leak tests of records that met occluders
    /// nearby ([`AmbientRecord::leak_test`]): true if an opaque surface
    /// crosses that segment.
    pub fn lookup_plugged(
        &self,
        s: &AmbientSettings,
        p: Vec3,
        n: Vec3,
        level: u32,
        weight: f64,
        occluded: &mut dyn FnMut(Vec3, Vec3, f64) -> bool,
    ) -> Option<Color> {
        interpolate(&[self], s, p, n, level, weight, occluded)
    }

    /// `cache` with `records` stored after its own, in order (copied only
    /// if someone else still holds it).
    pub fn extended(
        cache: Arc<AmbientCache>,
        s: &AmbientSettings,
        records: Vec<AmbientRecord>,
    ) -> Arc<AmbientCache> {
        if records.is_empty() {
            return cache;
        }
        let mut c = Arc::try_unwrap(cache).unwrap_or_else(|b| (*b).clone());
        for r in records {
            c.insert(s, r);
        }
        Arc::new(c)
    }

    /// Stores a record (ignored if it is not finite or caching is off).
    pub fn insert(&mut self, s: &AmbientSettings, r: AmbientRecord) {
        if s.accuracy <= 0.0
            || !(r.point.is_finite() && r.normal.is_finite() && r.value.is_finite())
            || !(r.radii.iter().all(|x| x.is_finite() && *x > 0.0))
        {
            return;
        }
        let influence = s.accuracy * r.reach();
        let l = Self::level_for(s, influence);
        let cell = s.base_cell * (1u64 << l) as f64;
        let lo = cell_of(r.point - Vec3::splat(influence), cell);
        let hi = cell_of(r.point + Vec3::splat(influence), cell);
        let id = self.records.len() as u32;
        let b = crate::image::brightness(r.value);
        if b > FTINY {
            self.log_sum += b.ln();
            self.log_count += 1;
        }
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

/// The weighted mean of the values the records of `caches` (in order)
/// give at `p` ([`AmbientCache::lookup_plugged`]), or `None` if none serves.
fn interpolate(
    caches: &[&AmbientCache],
    s: &AmbientSettings,
    p: Vec3,
    n: Vec3,
    level: u32,
    weight: f64,
    occluded: &mut dyn FnMut(Vec3, Vec3, f64) -> bool,
) -> Option<Color> {
    let mut sum = Color::ZERO;
    let mut wsum = 0.0;
    for c in caches {
        c.candidates(s, p, n, level, weight, occluded, |_, v, w| {
            sum += v * w;
            wsum += w;
        });
    }
    (wsum > FTINY).then(|| sum / wsum)
}

/// The cache a trace state uses: its own, or (the deterministic order of
/// [`super::waves`]) a cache frozen for a wave of pixels, shared
/// read-only, and the records this state made since.
#[derive(Debug, Clone)]
pub enum AmbientStore {
    Local(AmbientCache),
    Frozen {
        base: Arc<AmbientCache>,
        own: AmbientCache,
    },
}

impl Default for AmbientStore {
    fn default() -> Self {
        AmbientStore::Local(AmbientCache::default())
    }
}

impl AmbientStore {
    /// [`AmbientCache::lookup_plugged`]; a frozen store weighs the
    /// records of its base, then its own.
    pub fn lookup(
        &self,
        s: &AmbientSettings,
        p: Vec3,
        n: Vec3,
        level: u32,
        weight: f64,
        occluded: &mut dyn FnMut(Vec3, Vec3, f64) -> bool,
    ) -> Option<Color> {
        match self {
            AmbientStore::Local(c) => c.lookup_plugged(s, p, n, level, weight, occluded),
            AmbientStore::Frozen { base, own } => {
                interpolate(&[base, own], s, p, n, level, weight, occluded)
            }
        }
    }

    pub fn insert(&mut self, s: &AmbientSettings, r: AmbientRecord) {
        match self {
            AmbientStore::Local(c) | AmbientStore::Frozen { own: c, .. } => c.insert(s, r),
        }
    }

    /// The constant ambient value, `av` (`-av`), where no bounce is left
    /// or no hemisphere is sampled: with `aw` (`-aw`) above 0, Radiance's
    /// moving average (`multambient()`): the brightness becomes the
    /// geometric mean of `av`'s, weighted `aw`, and the values of the
    /// records stored so far, each weighted 1, keeping `av`'s colour (a
    /// neutral grey if `av` is black). The records are those this store
    /// holds: for the waves' deterministic order, the cache of the wave
    /// and this trace's own.
    pub fn ambient_value(&self, av: Color, aw: u32) -> Color {
        let (sum, n) = match self {
            AmbientStore::Local(c) => (c.log_sum, c.log_count),
            AmbientStore::Frozen { base, own } => {
                (base.log_sum + own.log_sum, base.log_count + own.log_count)
            }
        };
        if aw == 0 || n == 0 {
            return av;
        }
        let l = crate::image::brightness(av);
        if l > FTINY {
            let d = (l.ln() * aw as f64 + sum) / (aw as f64 + n as f64);
            av * (d.exp() / l)
        } else {
            Color::splat((sum / n as f64).exp())
        }
    }

    /// Records stored so far.
    pub fn len(&self) -> usize {
        match self {
            AmbientStore::Local(c) => c.len(),
            AmbientStore::Frozen { base, own } => base.len() + own.len(),
        }
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The records stored from index `from` on, in order (a frozen
    /// store's base first).
    pub fn records_since(&self, from: usize) -> Vec<AmbientRecord> {
        match self {
            AmbientStore::Local(c) => c.records.get(from..).unwrap_or_default().to_vec(),
            AmbientStore::Frozen { base, own } => base
                .records
                .iter()
                .chain(&own.records)
                .skip(from)
                .copied()
                .collect(),
        }
    }

    /// The records made since the store was frozen (none for a local
    /// store), leaving it with none.
    pub fn take_own(&mut self) -> Vec<AmbientRecord> {
        match self {
            AmbientStore::Local(_) => Vec::new(),
            AmbientStore::Frozen { own, .. } => std::mem::take(own).records,
        }
    }

    /// All records in one cache (a frozen store's base, then its own).
    pub fn into_cache(self, s: &AmbientSettings) -> AmbientCache {
        match self {
            AmbientStore::Local(c) => c,
            AmbientStore::Frozen { base, own } => {
                let mut c = Arc::try_unwrap(base).unwrap_or_else(|b| (*b).clone());
                for r in own.records {
                    c.insert(s, r);
                }
                c
            }
        }
    }
}

/// Real roots of `a x^2 + b x + c` (Radiance's `quadratic`).
fn quadratic(a: f64, b: f64, c: f64) -> Vec<f64> {
    let first = if a < -FTINY {
        1
    } else if a > FTINY {
        0
    } else if b.abs() > FTINY {
        return vec![-c / b];
    } else {
        return Vec::new();
    };
    let b = 0.5 * b;
    let disc = b * b - a * c;
    if disc < -FTINY * FTINY {
        return Vec::new();
    }
    if disc <= FTINY * FTINY {
        return vec![-b / a];
    }
    let disc = disc.sqrt();
    let mut r = [0.0; 2];
    r[first] = (-b - disc) / a;
    r[1 - first] = (-b + disc) / a;
    r.to_vec()
}

#[cfg(test)]
#[path = "ambient/tests.rs"]
mod tests;
