//! Built-in procedural scenes, written as Radiance scene text so that they
//! go through the same loader as any user scene (and can be read by
//! Radiance itself, given `oconv` for the instanced parts).
//!
//! - [`cornell`]: a Cornell box built with `!genbox` and `!xform`;
//! - [`studio`]: a large room full of small objects lit by a few big ceiling
//!   panels high above them (the paper's "studio": about 4,600 primitives and
//!   700 materials);
//! - [`city`]: a city of any size, real geometry (no instances), for
//!   scenes larger than one machine;
//! - [`conference`]: a hall of tables and chairs shared as instances, lit by
//!   many small luminaires just below the ceiling (the paper's "conference
//!   room": about 3,900 objects and 6,100 instances).
//!
//! All generators are deterministic functions of their seed. The files
//! shipped in `examples/scenes/` are their output for [`DEFAULT_SEED`]; a
//! test keeps the two identical (set `HYBRID_RT_BLESS=1` to rewrite them).

mod city;
mod conference;
mod cornell;
mod studio;

use std::fmt::Write as _;
use std::path::Path;

use glam::DVec3;

pub use city::{city, city_view, city_with_stats, CityStats};
pub use conference::{conference, conference_parts, conference_view};
pub use cornell::{cornell, cornell_view};
pub use studio::{studio, studio_view};

/// The seed the shipped scene files were generated with.
pub const DEFAULT_SEED: u64 = 1998;

/// Every shipped file name and its content for `seed`: the three scenes,
/// their view files and the conference room's instanced parts.
pub fn all_files(seed: u64) -> Vec<(&'static str, String)> {
    let mut v = vec![
        ("cornell.rad", cornell(seed)),
        ("cornell.vf", cornell_view().to_string()),
        ("studio.rad", studio(seed)),
        ("studio.vf", studio_view().to_string()),
        ("conference.rad", conference(seed)),
        ("conference.vf", conference_view().to_string()),
    ];
    v.extend(conference_parts(seed));
    v
}

/// Writes [`all_files`] into `dir`.
pub fn write_all(dir: impl AsRef<Path>, seed: u64) -> std::io::Result<()> {
    std::fs::create_dir_all(dir.as_ref())?;
    for (name, text) in all_files(seed) {
        std::fs::write(dir.as_ref().join(name), text)?;
    }
    Ok(())
}

/// The renderer's SplitMix64 ([`crate::geometry::rng::Rng`]) seeded as the
/// generators always were (`seed ^ GOLDEN`): same numbers everywhere.
#[derive(Debug, Clone)]
pub(crate) struct Rng(crate::geometry::rng::Rng);

impl Rng {
    pub fn new(seed: u64) -> Self {
        use crate::geometry::rng::{Rng, GOLDEN};
        Self(Rng::new(seed ^ GOLDEN))
    }

    /// Uniform in `[0, 1)`.
    pub fn f(&mut self) -> f64 {
        self.0.next_f64()
    }

    /// Uniform in `[a, b)`.
    pub fn range(&mut self, a: f64, b: f64) -> f64 {
        a + (b - a) * self.f()
    }
}

/// Formats a number compactly (at most 4 decimals, no trailing zeros).
pub(crate) fn num(x: f64) -> String {
    let s = format!("{x:.4}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" || s.is_empty() {
        "0".to_string()
    } else {
        s.to_string()
    }
}

/// Radiance text writer.
#[derive(Debug, Default)]
pub(crate) struct Rad {
    pub out: String,
    pub primitives: usize,
    pub materials: usize,
}

impl Rad {
    pub fn comment(&mut self, text: &str) {
        for line in text.lines() {
            let _ = writeln!(self.out, "# {line}");
        }
    }

    pub fn blank(&mut self) {
        self.out.push('\n');
    }

    pub fn line(&mut self, text: &str) {
        let _ = writeln!(self.out, "{text}");
    }

    fn record(&mut self, modifier: &str, ptype: &str, id: &str, strs: &[&str], reals: &[f64]) {
        let _ = write!(self.out, "{modifier} {ptype} {id}\n{}", strs.len());
        for s in strs {
            let _ = write!(self.out, " {s}");
        }
        let _ = write!(self.out, "\n0\n{}", reals.len());
        for (k, r) in reals.iter().enumerate() {
            // Three numbers per line keeps polygons readable.
            let sep = if k > 0 && k % 3 == 0 && reals.len() > 5 {
                "\n   "
            } else {
                " "
            };
            let _ = write!(self.out, "{sep}{}", num(*r));
        }
        self.out.push('\n');
    }

    pub fn material(&mut self, ptype: &str, id: &str, reals: &[f64]) {
        self.materials += 1;
        self.record("void", ptype, id, &[], reals);
    }

    pub fn plastic(&mut self, id: &str, c: DVec3, spec: f64, rough: f64) {
        self.material("plastic", id, &[c.x, c.y, c.z, spec, rough]);
    }

    pub fn polygon(&mut self, m: &str, id: &str, pts: &[DVec3]) {
        self.primitives += 1;
        let r: Vec<f64> = pts.iter().flat_map(|p| [p.x, p.y, p.z]).collect();
        self.record(m, "polygon", id, &[], &r);
    }

    pub fn sphere(&mut self, m: &str, id: &str, c: DVec3, r: f64) {
        self.primitives += 1;
        self.record(m, "sphere", id, &[], &[c.x, c.y, c.z, r]);
    }

    pub fn cylinder(&mut self, m: &str, id: &str, a: DVec3, b: DVec3, r: f64) {
        self.primitives += 1;
        self.record(m, "cylinder", id, &[], &[a.x, a.y, a.z, b.x, b.y, b.z, r]);
    }

    pub fn cone(&mut self, m: &str, id: &str, a: DVec3, b: DVec3, ra: f64, rb: f64) {
        self.primitives += 1;
        self.record(m, "cone", id, &[], &[a.x, a.y, a.z, b.x, b.y, b.z, ra, rb]);
    }

    pub fn ring(&mut self, m: &str, id: &str, c: DVec3, n: DVec3, r0: f64, r1: f64) {
        self.primitives += 1;
        self.record(m, "ring", id, &[], &[c.x, c.y, c.z, n.x, n.y, n.z, r0, r1]);
    }

    /// `void instance id  n octree xform...  0  0`.
    pub fn instance(&mut self, id: &str, octree: &str, xform: &str) {
        self.primitives += 1;
        let mut strs = vec![octree];
        strs.extend(xform.split_whitespace());
        self.record("void", "instance", id, &strs, &[]);
    }

    /// The inside of a closed room `[0,len] x [0,dep] x [0,hgt]`: floor, ceiling
    /// and four walls, each facing into the room, named `floor`, `ceiling`,
    /// `wall_south`, `wall_north`, `wall_west`, `wall_east`.
    pub fn room_shell(
        &mut self,
        floor: &str,
        ceiling: &str,
        wall: &str,
        len: f64,
        dep: f64,
        hgt: f64,
    ) {
        let p = DVec3::new;
        #[rustfmt::skip]
        let faces: [(&str, &str, [DVec3; 4]); 6] = [
            (floor, "floor", [p(0.0, 0.0, 0.0), p(len, 0.0, 0.0), p(len, dep, 0.0), p(0.0, dep, 0.0)]),
            (ceiling, "ceiling", [p(0.0, 0.0, hgt), p(0.0, dep, hgt), p(len, dep, hgt), p(len, 0.0, hgt)]),
            (wall, "wall_south", [p(0.0, 0.0, 0.0), p(0.0, 0.0, hgt), p(len, 0.0, hgt), p(len, 0.0, 0.0)]),
            (wall, "wall_north", [p(0.0, dep, 0.0), p(len, dep, 0.0), p(len, dep, hgt), p(0.0, dep, hgt)]),
            (wall, "wall_west", [p(0.0, 0.0, 0.0), p(0.0, dep, 0.0), p(0.0, dep, hgt), p(0.0, 0.0, hgt)]),
            (wall, "wall_east", [p(len, 0.0, 0.0), p(len, 0.0, hgt), p(len, dep, hgt), p(len, dep, 0.0)]),
        ];
        for (m, id, pts) in faces {
            self.polygon(m, id, &pts);
        }
    }

    /// An axis-aligned box from `lo` to `hi` as six outward polygons named
    /// like genbox's (`id.1540` ...), optionally leaving out faces (a bit
    /// per face in genbox order: -y, -x, -z, +y, +x, +z).
    pub fn boxed(&mut self, m: &str, id: &str, lo: DVec3, hi: DVec3, skip: u8) {
        const FACES: [[u8; 4]; 6] = [
            [1, 5, 4, 0],
            [4, 6, 2, 0],
            [2, 3, 1, 0],
            [3, 2, 6, 7],
            [5, 1, 3, 7],
            [6, 4, 5, 7],
        ];
        let corner = |v: u8| {
            DVec3::new(
                if v & 1 != 0 { hi.x } else { lo.x },
                if v & 2 != 0 { hi.y } else { lo.y },
                if v & 4 != 0 { hi.z } else { lo.z },
            )
        };
        for (k, f) in FACES.iter().enumerate() {
            if skip & (1 << k) != 0 {
                continue;
            }
            let pts: Vec<DVec3> = f.iter().map(|&v| corner(v)).collect();
            self.polygon(m, &format!("{id}.{}{}{}{}", f[0], f[1], f[2], f[3]), &pts);
        }
    }

    /// A box of size `s` whose footprint is rotated by `angle_deg` about the
    /// vertical through its base centre `c` (six outward polygons).
    pub fn rotated_box(&mut self, m: &str, id: &str, c: DVec3, s: DVec3, angle_deg: f64) {
        let (sn, cs) = angle_deg.to_radians().sin_cos();
        let rot = |p: DVec3| {
            DVec3::new(
                c.x + p.x * cs - p.y * sn,
                c.y + p.x * sn + p.y * cs,
                c.z + p.z,
            )
        };
        const FACES: [[u8; 4]; 6] = [
            [1, 5, 4, 0],
            [4, 6, 2, 0],
            [2, 3, 1, 0],
            [3, 2, 6, 7],
            [5, 1, 3, 7],
            [6, 4, 5, 7],
        ];
        let corner = |v: u8| {
            rot(DVec3::new(
                if v & 1 != 0 { s.x * 0.5 } else { -s.x * 0.5 },
                if v & 2 != 0 { s.y * 0.5 } else { -s.y * 0.5 },
                if v & 4 != 0 { s.z } else { 0.0 },
            ))
        };
        for f in FACES.iter() {
            let pts: Vec<DVec3> = f.iter().map(|&v| corner(v)).collect();
            self.polygon(m, &format!("{id}.{}{}{}{}", f[0], f[1], f[2], f[3]), &pts);
        }
    }
}

/// Colour from HSV-ish parameters (hue in turns), for varied palettes.
pub(crate) fn hue(h: f64, sat: f64, val: f64) -> DVec3 {
    let f = |n: f64| {
        let k = (n + h * 6.0).rem_euclid(6.0);
        val - val * sat * k.min(4.0 - k).clamp(0.0, 1.0)
    };
    DVec3::new(f(5.0), f(3.0), f(1.0))
}

#[cfg(test)]
mod tests;
