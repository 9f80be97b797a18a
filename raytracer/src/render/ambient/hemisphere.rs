//! One hemisphere of diffuse inter-reflection, sampled and turned into an
//! irradiance-cache record as Radiance 5.4 does (`ambcomp.c` 2.86):
//!
//! * `n x n` strata of the unit square (`n = sqrt(-ad w) + 1/2`, at least
//!   7 with a cache), each mapped to the disk by Shirley and Chiu's
//!   concentric map and lifted to the hemisphere: cosine-weighted
//!   directions. A first sample that would lie within a quarter stratum
//!   of an already chosen neighbour is drawn again (`ambcollision`).
//! * `-as` super-samples, spread over the strata in proportion to how much
//!   each one's brightness differs from its eight neighbours' (`ambsupersamp`).
//! * The record's two radii and their axes come from the Hessian of the
//!   irradiance over the hemisphere's triangulated sample points, after
//!   Schwarzhaupt, Jensen and Jarosz, "Practical Hessian-Based Error
//!   Control for Irradiance Caching" (SIGGRAPH Asia 2012): `ambHessian`.
//!   The same triangles give the translational gradient, and the samples'
//!   directions the rotational one (Ward and Heckbert 1992).
//!
//! The sequential renderer traces a hemisphere's rays at once; the
//! parallel one hands them out as separate tasks and adds their results in
//! any order. The first pass's rays are known when the hemisphere is made;
//! the super-samples once the first pass's results are in.

use std::f64::consts::PI;

use serde::{Deserialize, Serialize};

use super::{quadratic, AmbientRecord, AmbientRequest, AmbientSettings, AVGREFL, MINADIV};
use crate::geometry::robust::orthonormal_basis;
use crate::geometry::FTINY;
use crate::geometry::{offset_origin_scaled, Ray, Vec3};
use crate::image::brightness;
use crate::render::options::RenderOptions;
use crate::render::rng::{child_seed, Rng};
use crate::render::task::{intens, RayKind, RayTask};
use crate::scene::Color;

/// One hemisphere being sampled.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Hemisphere {
    pub point: Vec3,
    pub normal: Vec3,
    /// Ambient level of the point (bounces already taken above it).
    pub level: u32,
    depth: u32,
    /// Weight of the sample rays (the hit ray's times `AVGREFL`, as
    /// Radiance's `rayorigin` gives them).
    weight: f64,
    /// Weight the strata, super-samples and radii are reckoned with
    /// (`wt` of `doambient`).
    wt: f64,
    /// The record's weight (`makeambient`'s `amb.weight`).
    record_weight: f64,
    /// A cache is in use (`-aa` > 0): the record's radii are wanted.
    cached: bool,
    seed: u64,
    extinction: Color,
    #[serde(default)]
    medium: crate::render::medium::Medium,
    offset_scale: f64,
    /// Strata per side.
    ns: u32,
    ux: Vec3,
    uy: Vec3,
    /// Direction of each stratum's first sample, and the seed of its ray.
    first: Vec<(Vec3, u64)>,
    sums: Vec<Color>,
    counts: Vec<u32>,
    /// Distance of each stratum's first sample.
    first_dist: Vec<f64>,
    /// Reciprocal of each stratum's nearest sample distance.
    inv_near: Vec<f64>,
}

/// Shirley and Chiu's concentric map of the unit square onto the unit
/// disk (Radiance's `SDsquare2disk`).
fn square_to_disk(x: f64, y: f64) -> (f64, f64) {
    let a = 2.0 * x - 1.0;
    let b = 2.0 * y - 1.0;
    let (r, phi) = if a > -b && a > b {
        (a, (PI / 4.0) * (b / a))
    } else if a < b && a > -b {
        (b, (PI / 4.0) * (2.0 - a / b))
    } else if a < b && a < -b {
        (-a, (PI / 4.0) * (4.0 + b / a))
    } else if b.abs() > 0.0 {
        (-b, (PI / 4.0) * (6.0 - a / b))
    } else {
        (-b, 0.0)
    };
    (r * phi.cos(), r * phi.sin())
}

/// The mean over the strata of each stratum's mean (`sums[k]` of
/// `counts[k]` samples): a hemisphere's value ([`Hemisphere::finish`]).
fn strata_mean(sums: &[Color], counts: &[u32]) -> Color {
    let mut value = Color::ZERO;
    for (&sum, &count) in sums.iter().zip(counts) {
        value += sum / count.max(1) as f64;
    }
    value /= sums.len().max(1) as f64;
    value
}

/// The value of a hemisphere sampled once per stratum (its first pass,
/// no super-samples), `values[k]` stratum `k`'s sample: what
/// [`Hemisphere::add`] then [`Hemisphere::finish`] compute, bit for bit
/// (a sample that is not finite adds nothing). The parallel renderer
/// evaluates a hemisphere whose samples were traced as tasks of their own
/// with it.
pub fn strata_mean_of_first_pass(values: &[Color]) -> Color {
    let sums: Vec<Color> = values
        .iter()
        .map(|&v| {
            let mut sum = Color::ZERO;
            if v.is_finite() {
                sum += v;
            }
            sum
        })
        .collect();
    strata_mean(&sums, &vec![1; values.len()])
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
        let weight = task.weight * AVGREFL;
        if depth > o.lr || !(weight >= o.lw && weight > 0.0) {
            return None;
        }
        let len = req.normal.length();
        if !(len > 0.0 && len.is_finite() && req.point.is_finite()) {
            return None;
        }
        let normal = req.normal / len;
        let cached = s.accuracy > 0.0;
        // makeambient: the weight of a record of this level.
        let mut record_weight = AVGREFL.powi(task.ambient.min(1000) as i32);
        if task.weight < 0.1 * record_weight {
            record_weight = 1.25 * task.weight;
        }
        // A ray heavier than its level's weight (a reflectance above 1 on
        // its way): Radiance's record would not serve the very point it
        // was made for (a lookup there again, from an ambient file or a
        // later wave's pixel at the same point, would sample it again).
        // Such a record carries the ray's weight.
        if task.weight > record_weight {
            record_weight = task.weight;
        }
        let mut wt = if cached { record_weight } else { task.weight };
        if !cached && o.lw > 0.0 {
            // Avoid sample rays too light to be traced.
            let d = 0.8 * intens(req.coef) * task.weight / (o.ad.max(1) as f64 * o.lw);
            if wt > d {
                wt = d;
            }
        }
        let ns = ((o.ad as f64 * wt).max(0.0).sqrt() + 0.5) as u32;
        let ns = ns.clamp(if cached { MINADIV } else { 1 }, 4096);
        let seed = child_seed(task.seed, 0x616d_0000 + req.side);
        // Tangent axes turned by a random angle (getperpendicular's
        // randomised axis).
        let (u0, v0) = orthonormal_basis(normal);
        let turn = 2.0 * PI * Rng::new(child_seed(seed, 0x00ff_ffff)).next_f64();
        let ux = (u0 * turn.cos() + v0 * turn.sin()).normalize();
        let uy = normal.cross(ux);
        let n = (ns * ns) as usize;
        let mut h = Self {
            point: req.point,
            normal,
            level: task.ambient,
            depth,
            weight,
            wt,
            record_weight,
            cached,
            seed,
            extinction: task.extinction,
            medium: task.medium,
            offset_scale: req.offset_scale,
            ns,
            ux,
            uy,
            first: Vec::new(),
            sums: vec![Color::ZERO; n],
            counts: vec![0; n],
            first_dist: vec![f64::INFINITY; n],
            inv_near: vec![0.0; n],
        };
        h.choose_first_directions();
        Some(h)
    }

    /// Strata (divisions) of the hemisphere.
    pub fn divisions(&self) -> usize {
        self.sums.len()
    }

    /// The direction through the point `(x, y)` of the unit square.
    fn direction(&self, x: f64, y: f64) -> Vec3 {
        let (dx, dy) = square_to_disk(x, y);
        let dz = (1.0 - dx * dx - dy * dy).max(0.0).sqrt();
        (self.ux * dx + self.uy * dy + self.normal * dz).normalize()
    }

    /// The direction through stratum `div` at `(s0, s1)` within it.
    fn in_stratum(&self, div: usize, s0: f64, s1: f64) -> Vec3 {
        let ns = self.ns as usize;
        let (i, j) = (div / ns, div % ns);
        self.direction((j as f64 + s1) / ns as f64, (i as f64 + s0) / ns as f64)
    }

    /// A jittered direction in stratum `div` for sample `pass` (0 the
    /// first), and the generator it was drawn from.
    fn jittered(&self, div: usize, pass: u32) -> (Vec3, Rng) {
        let mut rng = Rng::new(child_seed(self.seed, (div as u32) | (pass << 24)));
        let (s0, s1) = (rng.next_f64(), rng.next_f64());
        (self.in_stratum(div, s0, s1), rng)
    }

    /// The first samples' directions, in Radiance's order (last stratum
    /// first), each drawn again while it collides with a neighbour chosen
    /// before it.
    fn choose_first_directions(&mut self) {
        let ns = self.ns as usize;
        let n = ns * ns;
        let mut first = vec![(Vec3::ZERO, 0u64); n];
        // Minimum spacing: a quarter stratum.
        let a = (PI / 4.0) / ns as f64;
        let cos_thresh = 1.0 - 0.5 * a * a;
        for div in (0..n).rev() {
            let (i, j) = (div / ns, div % ns);
            // The neighbours chosen before this stratum (those after it):
            // the next in its row, and the three next to it in the next row.
            let mut before = [usize::MAX; 4];
            if j + 1 < ns {
                before[0] = div + 1;
            }
            if i + 1 < ns {
                before[1] = div + ns;
                if j > 0 {
                    before[2] = div + ns - 1;
                }
                if j + 1 < ns {
                    before[3] = div + ns + 1;
                }
            }
            let (mut dir, mut rng) = self.jittered(div, 0);
            for _ in 0..64 {
                let collides = before
                    .iter()
                    .any(|&k| k != usize::MAX && first[k].0.dot(dir) >= cos_thresh);
                if !collides {
                    break;
                }
                let (s0, s1) = (rng.next_f64(), rng.next_f64());
                dir = self.in_stratum(div, s0, s1);
            }
            first[div] = (dir, rng.next_u64());
        }
        self.first = first;
    }

    fn task(&self, dir: Vec3, seed: u64) -> RayTask {
        let origin = offset_origin_scaled(self.point, self.normal, dir, self.offset_scale);
        RayTask {
            ray: Ray { origin, dir },
            tmin: 0.0,
            tmax: f64::INFINITY,
            kind: RayKind::Ambient,
            depth: self.depth,
            weight: self.weight,
            seed,
            extinction: self.extinction,
            // Sources that direct lighting samples are already counted.
            sampled: true,
            ambient: self.level + 1,
            clip: 0,
            medium: self.medium,
        }
    }

    /// The first pass: one ray per stratum, as (stratum, task).
    pub fn first_pass(&self) -> Vec<(usize, RayTask)> {
        self.first
            .iter()
            .enumerate()
            .map(|(d, &(dir, seed))| (d, self.task(dir, seed)))
            .collect()
    }

    /// Mean radiance of stratum `k` so far.
    fn mean(&self, k: usize) -> Color {
        self.sums[k] / self.counts[k].max(1) as f64
    }

    /// Brightness of each stratum's mean so far.
    fn brightnesses(&self) -> Vec<f64> {
        (0..self.sums.len())
            .map(|k| brightness(self.mean(k)))
            .collect()
    }

    /// Radiance's estimate of each stratum's variance from its neighbours
    /// (`getambdiffs`).
    fn differences(&self) -> Vec<f64> {
        let ns = self.ns as usize;
        let b = self.brightnesses();
        let mut e = vec![0.0; ns * ns];
        let pair = |e: &mut Vec<f64>, k0: usize, k1: usize| {
            let s = b[k0] + b[k1];
            if s > 0.0 {
                let d = b[k0] - b[k1];
                let d2 = d * d / s;
                e[k0] += d2;
                e[k1] += d2;
            }
        };
        for i in 0..ns {
            for j in 0..ns {
                let k = i * ns + j;
                if i > 0 {
                    pair(&mut e, k, k - ns);
                }
                if j > 0 {
                    pair(&mut e, k, k - 1);
                    if i > 0 {
                        pair(&mut e, k, k - ns - 1);
                    }
                }
            }
        }
        // Corners and edges have fewer neighbours.
        for k in [0, ns - 1, (ns - 1) * ns, ns * ns - 1] {
            e[k] *= 8.0 / 3.0;
        }
        for i in 1..ns.saturating_sub(1) {
            e[i * ns] *= 8.0 / 5.0;
            e[i * ns + ns - 1] *= 8.0 / 5.0;
            e[i] *= 8.0 / 5.0;
            e[(ns - 1) * ns + i] *= 8.0 / 5.0;
        }
        e
    }

    /// How many super-samples [`Hemisphere::second_pass`] may make at
    /// most, whatever the first pass's values: `super_samples` times the
    /// hemisphere's weight; none for hemispheres of at most 7 x 7 strata
    /// or fewer than 9 super-samples.
    pub fn most_super_samples(&self, super_samples: u32) -> usize {
        let ns = self.ns as usize;
        if ns * ns <= (MINADIV * MINADIV) as usize {
            return 0;
        }
        match (super_samples as f64 * self.wt + 0.5) as i64 {
            cnt if cnt <= 8 => 0,
            cnt => cnt as usize,
        }
    }

    /// Super-samples (call after the first pass's results are in):
    /// [`Hemisphere::most_super_samples`] at most, spread over the strata
    /// in proportion to their estimated variance.
    pub fn second_pass(&self, super_samples: u32) -> Vec<(usize, RayTask)> {
        let mut cnt = self.most_super_samples(super_samples) as i64;
        if cnt == 0 {
            return Vec::new();
        }
        let e = self.differences();
        let mut rest: f64 = e.iter().sum();
        let mut rng = Rng::new(child_seed(self.seed, 0x7fff_0000));
        let mut out = Vec::new();
        for (k, &ek) in e.iter().enumerate() {
            if rest <= FTINY || cnt <= 0 {
                break;
            }
            let nss = (ek / rest * cnt as f64 + rng.next_f64()) as i64;
            for n in 1..=nss.max(0) {
                let (dir, mut r) = self.jittered(k, n as u32);
                out.push((k, self.task(dir, r.next_u64())));
                cnt -= 1;
                if cnt == 0 {
                    break;
                }
            }
            rest -= ek;
        }
        out
    }

    /// Adds the result of a ray into stratum `div`: its radiance and the
    /// distance to what it hit (infinite for a miss). A stratum's first
    /// result is its first sample's (every first-pass result comes in
    /// before any super-sample is made).
    pub fn add(&mut self, div: usize, value: Color, distance: f64) {
        let Some(c) = self.counts.get_mut(div) else {
            return;
        };
        if *c == 0 {
            self.first_dist[div] = distance;
        }
        *c += 1;
        if value.is_finite() {
            self.sums[div] += value;
        }
        let d = distance.max(FTINY);
        if d.is_finite() && d * self.inv_near[div] < 1.0 {
            self.inv_near[div] = 1.0 / d;
        }
    }

    /// The hemisphere's value (the mean radiance over the strata) and,
    /// with a cache, its record.
    pub fn finish(&self, s: &AmbientSettings) -> (Color, Option<AmbientRecord>) {
        let n = self.sums.len();
        let value = strata_mean(&self.sums, &self.counts);
        if !self.cached || self.ns < MINADIV || !value.is_finite() {
            return (value, None);
        }
        let far = 10.0 * s.scene_size + 1000.0;
        let b = self.brightnesses();
        let total: f64 = b.iter().sum();
        // Relative brightness (Radiance's normalised Y channel); without
        // light, the geometric Hessian alone.
        let lit = AVGREFL * total / n as f64 > FTINY;
        let samples: Vec<Sample> = (0..n)
            .map(|k| {
                let dir = self.first[k].0;
                let dist = self.first_dist[k].clamp(FTINY, far);
                let p = self.point + dir * dist;
                let r = p - self.point;
                Sample {
                    y: if lit {
                        0.99 * n as f64 * b[k] / total + 0.01
                    } else {
                        1.0
                    },
                    inv_dist: self.inv_near[k],
                    p,
                    r,
                    inv_r2: 1.0 / r.dot(r),
                }
            })
            .collect();
        let grid = Grid {
            ns: self.ns as usize,
            samples: &samples,
            normal: self.normal,
        };
        let (uv, mut ra, pg) = grid.hessian(self.ux, self.uy, s.max_radius);
        let (mut pg, mut dg) = if lit {
            (pg, grid.direction_gradient(uv))
        } else {
            ([0.0; 2], [0.0; 2])
        };
        // Radii limited by the gradient, clamped (doambient).
        if lit {
            for a in 0..2 {
                let d = pg[a].abs();
                if ra[a] * d > 1.0 {
                    ra[a] = 1.0 / d;
                }
            }
            if ra[0] > ra[1] {
                ra[0] = ra[1];
            }
        }
        if ra[0] < s.min_radius {
            ra[0] = s.min_radius;
            if ra[1] < s.min_radius {
                ra[1] = s.min_radius;
            }
        }
        let scale = 1.0 / self.wt.sqrt();
        ra[0] *= scale;
        ra[1] *= scale;
        if ra[1] > 2.0 * ra[0] {
            ra[1] = 2.0 * ra[0];
        }
        if ra[1] > s.max_radius {
            ra[1] = s.max_radius;
            if ra[0] > s.max_radius {
                ra[0] = s.max_radius;
            }
        }
        // Directions of nearby occluders (with light only, as Radiance).
        let mut corral = if lit {
            grid.corral(uv, ra[0] * s.accuracy, ra[1] * s.accuracy, s)
        } else {
            0
        };
        let d = pg[0] * pg[0] * ra[0] * ra[0] + pg[1] * pg[1] * ra[1] * ra[1];
        if d > 1.0 {
            let d = 1.0 / d.sqrt();
            pg[0] *= d;
            pg[1] *= d;
        }
        let mut u = uv[0].normalize();
        let finite = ra.iter().chain(&pg).chain(&dg).all(|x| x.is_finite()) && u.is_finite();
        if !finite || ra[0] <= FTINY {
            // A degenerate sample set (where Radiance would keep the value
            // and store nothing): the smallest record, without gradients,
            // so that a lookup here finds it.
            ra = [s.min_radius; 2];
            pg = [0.0; 2];
            dg = [0.0; 2];
            u = self.ux;
            corral = 0;
        }
        let record = AmbientRecord {
            point: self.point,
            normal: self.normal,
            u,
            value,
            radii: ra,
            gpos: pg,
            gdir: dg,
            level: self.level,
            weight: self.record_weight,
            corral,
        };
        (value, Some(record))
    }
}

/// A stratum's first sample as the Hessian reads it.
struct Sample {
    /// Relative brightness.
    y: f64,
    /// Reciprocal of the nearest distance sampled in the stratum.
    inv_dist: f64,
    /// Where the first sample hit (clamped to a far distance).
    p: Vec3,
    /// `p` seen from the hemisphere's point, and `1 / |r|^2`: every edge
    /// at the sample reads them (Radiance computes them for each).
    r: Vec3,
    inv_r2: f64,
}

/// The hemisphere's samples as a grid of triangles, seen from the
/// hemisphere's point (each sample's `r`).
struct Grid<'a> {
    ns: usize,
    samples: &'a [Sample],
    normal: Vec3,
}

/// Edge terms of the Hessian and gradient (Radiance's `FFTRI`), with the
/// products both of them read.
struct Edge {
    r_i: Vec3,
    e_i: Vec3,
    rcp: Vec3,
    ri2_ej2: Vec3,
    /// `normal x e_i`.
    ncp: Vec3,
    i1: f64,
    i2: f64,
    /// `1 / |r_i|^2`, `1 / |r_i1|^2`, `|e_i|^2`, `e_i . r_i`, `e_i . r_i1`
    /// and `|rcp|^2`.
    rdot_r: f64,
    rdot_r1: f64,
    dot_e: f64,
    dot_er: f64,
    dot_er1: f64,
    dot_cp: f64,
}

type Mat3 = [[f64; 3]; 3];

/// A symmetric 3x3 matrix as its upper triangle, in the order of [`SYM`].
/// Every matrix of the Hessian is symmetric entry for entry (each
/// `compose` is, and the diagonal term keeps it so), so its lower
/// triangle would repeat the same sums bit for bit.
type Sym3 = [f64; 6];

/// The (row, column) of each entry of a [`Sym3`].
const SYM: [(usize, usize); 6] = [(0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2)];

/// `va vb^T + vb va^T`, element `(i, j)` of [`SYM`] as `a[i] * b[j] +
/// a[j] * b[i]` (written out: `SYM.map` was not inlined, 2% of a render
/// with `-ab 1`).
#[inline]
fn compose(va: Vec3, vb: Vec3) -> Sym3 {
    let (a, b) = (va.to_array(), vb.to_array());
    [
        a[0] * b[0] + a[0] * b[0],
        a[0] * b[1] + a[1] * b[0],
        a[0] * b[2] + a[2] * b[0],
        a[1] * b[1] + a[1] * b[1],
        a[1] * b[2] + a[2] * b[1],
        a[2] * b[2] + a[2] * b[2],
    ]
}

/// The full matrix of a [`Sym3`].
fn full(h: &Sym3) -> Mat3 {
    let mut m = [[0.0; 3]; 3];
    for (&(i, j), &x) in SYM.iter().zip(h) {
        m[i][j] = x;
        m[j][i] = x;
    }
    m
}

/// An edge's share of the Hessian and of the translational gradient.
#[derive(Clone, Copy)]
struct Terms {
    h: Sym3,
    g: Vec3,
}

impl Terms {
    /// The same edge walked the other way.
    fn reverse(&mut self) {
        for x in self.h.iter_mut() {
            *x = -*x;
        }
        self.g = -self.g;
    }
}

impl Grid<'_> {
    fn at(&self, i: usize, j: usize) -> usize {
        i * self.ns + j
    }

    /// The sectors of the tangent plane (32, counted from `uv[0]` towards
    /// `uv[1]`) in which a sample on the hemisphere's rim met an occluder
    /// inside the ellipse of radii `r0`, `r1` (the record's radii times
    /// the accuracy): Radiance's `ambcorral`. None where the hemisphere
    /// has few strata, or where its ceiling is too low or too near for
    /// the test to mean anything.
    fn corral(&self, uv: [Vec3; 2], r0: f64, r1: f64, s: &AmbientSettings) -> u32 {
        let ns = self.ns;
        if ns < 8 {
            return 0;
        }
        let max_d = 1.0 / (s.min_radius * s.accuracy + 0.001);
        let ang_res = 0.5 * PI / ns as f64;
        let ang_step = ang_res / ((16.0 / PI * ang_res) as i64 as f64 + 1.01);
        // The mean reciprocal distance overhead (the middle half).
        let mut avg_d = 0.0;
        for i in (ns / 4..ns * 3 / 4).rev() {
            for j in (ns / 4..ns * 3 / 4).rev() {
                avg_d += self.samples[self.at(i, j)].inv_dist;
            }
        }
        avg_d *= 4.0 / (ns * ns) as f64;
        if avg_d * r0 >= 1.0 || avg_d >= max_d {
            return 0;
        }
        let mut flags = 0u64;
        for i in 0..ns {
            let step = if i == 0 || i == ns - 1 { 1 } else { ns - 1 };
            for j in (0..ns).step_by(step) {
                let sample = &self.samples[self.at(i, j)];
                let d = sample.inv_dist;
                if d <= FTINY || d >= max_d {
                    continue; // too far or too near
                }
                let vec = sample.r;
                let (u, v) = (vec.dot(uv[0]), vec.dot(uv[1]));
                if (r0 * r0 * u * u + r1 * r1 * v * v) * d * d <= u * u + v * v {
                    continue; // the occluder is outside the ellipse
                }
                let ang = v.atan2(u);
                let mut a1 = ang - ang_res;
                while a1 <= ang + ang_res {
                    let sector = (16.0 / PI * (a1 + if a1 < 0.0 { 2.0 * PI } else { 0.0 })) as i64;
                    // Radiance's 32-bit flags keep sectors 0 to 31.
                    if (0..32).contains(&sector) {
                        flags |= 1 << sector;
                    }
                    a1 += ang_step;
                }
            }
        }
        flags as u32
    }

    /// Brightness of the farthest of three samples.
    fn back(&self, n1: usize, n2: usize, n3: usize) -> f64 {
        let s = self.samples;
        if s[n1].inv_dist <= s[n2].inv_dist {
            if s[n1].inv_dist <= s[n3].inv_dist {
                return s[n1].y;
            }
            return s[n3].y;
        }
        if s[n2].inv_dist <= s[n3].inv_dist {
            return s[n2].y;
        }
        s[n3].y
    }

    fn edge(&self, n0: usize, n1: usize) -> Edge {
        let (s0, s1) = (&self.samples[n0], &self.samples[n1]);
        let (r_i, r_i1) = (s0.r, s1.r);
        let e_i = s1.p - s0.p;
        let rcp = r_i.cross(r_i1);
        let dot_cp = rcp.dot(rcp);
        let rdot_cp = 1.0 / dot_cp;
        let dot_e = e_i.dot(e_i);
        let dot_er = e_i.dot(r_i);
        let (rdot_r, rdot_r1) = (s0.inv_r2, s1.inv_r2);
        let cos = (r_i.dot(r_i1) * (rdot_r * rdot_r1).sqrt()).clamp(-1.0, 1.0);
        let i1 = cos.acos() * rdot_cp.sqrt();
        let dot_er1 = e_i.dot(r_i1);
        let i2 = (dot_er1 * rdot_r1 - dot_er * rdot_r + dot_e * i1) * 0.5 * rdot_cp;
        let j2 = (0.5 * (rdot_r - rdot_r1) - dot_er * i2) / dot_e;
        Edge {
            r_i,
            e_i,
            rcp,
            ri2_ej2: r_i * i2 + e_i * j2,
            ncp: self.normal.cross(e_i),
            i1,
            i2,
            rdot_r,
            rdot_r1,
            dot_e,
            dot_er,
            dot_er1,
            dot_cp,
        }
    }

    /// Radiance's `comp_hessian`, the same operations on the upper
    /// triangle only (the products `edge` shares are the ones it would
    /// compute again: `1 / |r_i|^2` is `rdot_r`, and so on).
    fn edge_hessian(&self, f: &Edge) -> Sym3 {
        let nrm = self.normal;
        let d1 = f.rdot_r;
        let d2 = f.rdot_r1;
        let d3 = 1.0 / f.dot_e;
        let d4 = f.dot_er;
        let i3 = (f.dot_er1 * d2 * d2 - d4 * d1 * d1 + 3.0 / d3 * f.i2) / (4.0 * f.dot_cp);
        let j3 = 0.25 * d3 * (d1 * d1 - d2 * d2) - d4 * d3 * i3;
        let k3 = d3 * (f.i2 - i3 / d1 - 2.0 * d4 * j3);
        let m1 = compose(f.ncp, f.ri2_ej2);
        let m2 = compose(f.r_i, f.r_i);
        let m3 = compose(f.e_i, f.e_i);
        let m4 = compose(f.r_i, f.e_i);
        let dn = nrm.dot(f.rcp);
        let diag = -dn * f.i2;
        let dn = 2.0 * dn;
        let mut h = [0.0; 6];
        for (k, &(i, j)) in SYM.iter().enumerate() {
            let mut v = m1[k] + dn * (i3 * m2[k] + k3 * m3[k] + 2.0 * j3 * m4[k]);
            if i == j {
                v += diag;
            }
            h[k] = v * (-1.0 / PI);
        }
        h
    }

    fn edge_gradient(&self, f: &Edge) -> Vec3 {
        let f1 = 2.0 * self.normal.dot(f.rcp);
        (f.ncp * f.i1 + f.ri2_ej2 * f1) * (0.5 / PI)
    }

    /// Edge `n0`-`n1`'s terms.
    fn terms(&self, n0: usize, n1: usize) -> Terms {
        let f = self.edge(n0, n1);
        Terms {
            h: self.edge_hessian(&f),
            g: self.edge_gradient(&f),
        }
    }

    /// The Hessian's axes in the tangent plane and the radii along them,
    /// and the translational gradient along those axes (`ambHessian`).
    fn hessian(&self, ux: Vec3, uy: Vec3, max_radius: f64) -> ([Vec3; 2], [f64; 2], [f64; 2]) {
        let ns = self.ns;
        let mut hess: Sym3 = [0.0; 6];
        let mut grad = Vec3::ZERO;
        // A triangle's three edges, weighted by its farthest sample's
        // brightness.
        let mut add = |edges: [&Terms; 3], v: f64| {
            for e in edges {
                for (x, ex) in hess.iter_mut().zip(&e.h) {
                    *x += v * ex;
                }
                grad += e.g * v;
            }
        };
        // Clockwise around each triangle as seen from the point.
        let mut row: Vec<Terms> = (0..ns - 1)
            .map(|j| self.terms(self.at(0, j), self.at(0, j + 1)))
            .collect();
        for i in 0..ns - 1 {
            let mut col = self.terms(self.at(i, 0), self.at(i + 1, 0));
            for (j, rj) in row.iter_mut().enumerate() {
                let back = self.back(self.at(i, j), self.at(i, j + 1), self.at(i + 1, j));
                let mut dia = self.terms(self.at(i, j + 1), self.at(i + 1, j));
                col.reverse();
                add([rj, &dia, &col], back);
                *rj = self.terms(self.at(i + 1, j + 1), self.at(i + 1, j));
                let back = self.back(self.at(i + 1, j + 1), self.at(i + 1, j), self.at(i, j + 1));
                col = self.terms(self.at(i, j + 1), self.at(i + 1, j + 1));
                dia.reverse();
                add([rj, &dia, &col], back);
                if i < ns - 2 {
                    rj.reverse();
                }
            }
        }
        let (uv, ra) = eigenvectors([ux, uy], &full(&hess), max_radius);
        let pg = [grad.dot(uv[0]), grad.dot(uv[1])];
        (uv, ra, pg)
    }

    /// The rotational gradient along `uv` (`ambdirgrad`).
    fn direction_gradient(&self, uv: [Vec3; 2]) -> [f64; 2] {
        let mut g = [0.0; 2];
        for s in self.samples {
            let vd = s.r;
            let f = s.y / self.normal.dot(vd);
            g[0] -= uv[1].dot(vd) * f;
            g[1] += uv[0].dot(vd) * f;
        }
        let n = self.samples.len() as f64;
        [g[0] / n, g[1] / n]
    }
}

/// The Hessian projected on the tangent plane: its eigenvectors and the
/// radii `(4 / |eigenvalue|)^(1/4)`, the smaller first (`eigenvectors`).
fn eigenvectors(uv: [Vec3; 2], hess: &Mat3, max_radius: f64) -> ([Vec3; 2], [f64; 2]) {
    let row = |v: Vec3| {
        Vec3::new(
            hess[0][0] * v.x + hess[0][1] * v.y + hess[0][2] * v.z,
            hess[1][0] * v.x + hess[1][1] * v.y + hess[1][2] * v.z,
            hess[2][0] * v.x + hess[2][1] * v.y + hess[2][2] * v.z,
        )
    };
    let (a, b) = (row(uv[0]), row(uv[1]));
    let h00 = uv[0].dot(a);
    let h01 = uv[0].dot(b);
    let h10 = uv[1].dot(a);
    let h11 = uv[1].dot(b);
    let roots = quadratic(1.0, -h00 - h11, h00 * h11 - h01 * h10);
    let (e0, e1) = match roots.as_slice() {
        [r] => (r.abs(), r.abs()),
        [r0, r1] => (r0.abs(), r1.abs()),
        _ => return (uv, [max_radius; 2]),
    };
    if !(e0 > FTINY * FTINY && e1 > FTINY * FTINY) {
        return (uv, [max_radius; 2]);
    }
    let (ra, slope) = if e0 > e1 {
        ([(4.0 / e0).sqrt().sqrt(), (4.0 / e1).sqrt().sqrt()], e1)
    } else {
        ([(4.0 / e1).sqrt().sqrt(), (4.0 / e0).sqrt().sqrt()], e0)
    };
    if h01.abs() <= FTINY {
        return (uv, ra);
    }
    let slope = (slope - h00) / h01;
    let xmag = (1.0 / (1.0 + slope * slope)).sqrt();
    let b = uv[0] * xmag + uv[1] * (slope * xmag);
    let a = uv[0] * (slope * xmag) - uv[1] * xmag;
    ([a, b], ra)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn concentric_map_fills_the_disk_and_keeps_areas() {
        // Equal areas of the square map to equal areas of the disk: the
        // mean squared radius over a fine grid is 1/2.
        let n = 200;
        let mut r2 = 0.0;
        for i in 0..n {
            for j in 0..n {
                let (x, y) =
                    square_to_disk((i as f64 + 0.5) / n as f64, (j as f64 + 0.5) / n as f64);
                let r = x * x + y * y;
                assert!(r <= 1.0 + 1e-12);
                r2 += r;
            }
        }
        assert!((r2 / (n * n) as f64 - 0.5).abs() < 1e-3);
        assert_eq!(square_to_disk(0.5, 0.5), (0.0, 0.0));
    }

    #[test]
    fn quadratic_roots() {
        assert_eq!(quadratic(1.0, -3.0, 2.0), vec![1.0, 2.0]);
        assert_eq!(quadratic(1.0, 2.0, 1.0), vec![-1.0]);
        assert!(quadratic(1.0, 0.0, 1.0).is_empty());
        assert_eq!(quadratic(0.0, 2.0, -4.0), vec![2.0]);
    }
}
