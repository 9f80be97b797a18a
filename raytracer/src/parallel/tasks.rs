//! Everything that travels between processors: the data items, the
//! demand-driven and data-parallel tasks with their byte sizes. (The
//! results, ray-tree records keyed by [`NodeKey`], are in [`super::tree`];
//! the recorded answers of a restartable bundle in [`super::caster`].)

use hybrid_sched::serde::{Deserialize, Serialize};
use hybrid_sched::ByteSize;

use super::caster::{Answer, Replay};
use super::tree::NodeKey;
use crate::accel::{LeafObjects, NodeId, TraceCursor};
use crate::geometry::Vec3;
use crate::render::ambient::{AmbientRecord, AmbientRequest};
use crate::render::{RayTask, ShadowBundle};

/// One octree leaf's objects as a data item: the leaf's own copies of its
/// objects ([`LeafObjects`]), which a data reply carries (serialized, under
/// MPI) and tracing on the receiving processor reads. Caches, requests
/// and replies are accounted in the bytes the objects occupy in the scene
/// (an object listed in n leaves counts 1/n in each), not in the copies'
/// size: the accounting (and the simulated machine) prices a scene whose
/// objects travel once per leaf share.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(crate = "hybrid_sched::serde")]
pub struct CellData {
    pub leaf: NodeId,
    pub bytes: u64,
    /// The leaf's objects (their count is `cell.ids().len()`).
    pub cell: LeafObjects,
}

impl ByteSize for CellData {
    fn byte_size(&self) -> usize {
        self.bytes as usize
    }
}

/// A data item: an octree leaf's objects, or the irradiance-cache records
/// one wave of pixels made, broadcast to every processor when the wave is
/// over (`irradiance.rs`; ids [`wave_item`]).
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(crate = "hybrid_sched::serde")]
pub enum Item {
    Cell(CellData),
    Records(Vec<AmbientRecord>),
}

impl Item {
    /// The leaf's objects (`None` for records).
    #[inline]
    pub fn cell(&self) -> Option<&LeafObjects> {
        match self {
            Item::Cell(c) => Some(&c.cell),
            Item::Records(_) => None,
        }
    }
}

impl ByteSize for Item {
    fn byte_size(&self) -> usize {
        match self {
            Item::Cell(c) => c.byte_size(),
            Item::Records(r) => 8 + std::mem::size_of_val(r.as_slice()),
        }
    }
}

/// The data id of the records wave `wave` made: ids counted down from
/// below `u32::MAX` (an octree numbers far fewer nodes; `u32::MAX` itself
/// marks "no leaf").
pub fn wave_item(wave: u32) -> NodeId {
    u32::MAX - 1 - wave
}

/// A tile: a rectangle of pixels, the renderer's [`Region`](crate::render::Region).
pub type Tile = crate::render::Region;

/// A shadow bundle scheduled demand-driven.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(crate = "hybrid_sched::serde")]
pub struct ShadowJob {
    pub key: NodeKey,
    pub bundle: ShadowBundle,
}

/// Pixels (row-major indices) of one wave of a render with an irradiance
/// cache (`irradiance.rs`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(crate = "hybrid_sched::serde")]
pub struct WaveChunk {
    pub wave: u32,
    pub pixels: Vec<u32>,
}

/// Demand-driven tasks: a tile of primary rays, or the shadow bundles of
/// one shaded point that need cells their processor does not hold (one
/// task, one selection: the union of theirs), or pixels of a wave.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(crate = "hybrid_sched::serde")]
pub enum DdTask {
    Tile(Tile),
    Shadows(Vec<ShadowJob>),
    Wave(Box<WaveChunk>),
}

/// Bytes of the task's origin, which its envelope carries (the framework
/// tracks it: [`hybrid_sched::Ctx::origin`]); tasks carried it themselves before, and the
/// accounting keeps those bytes.
const ORIGIN_BYTES: usize = 8;

impl ByteSize for DdTask {
    fn byte_size(&self) -> usize {
        std::mem::size_of::<Self>()
            + ORIGIN_BYTES
            + match self {
                DdTask::Tile(_) => 0,
                DdTask::Wave(w) => 4 * w.pixels.len(),
                DdTask::Shadows(jobs) => jobs
                    .iter()
                    .map(|j| std::mem::size_of::<ShadowJob>() + 2 * j.key.path.len())
                    .sum(),
            }
    }
}

/// A ray migrating cell by cell.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(crate = "hybrid_sched::serde")]
pub struct RayJob {
    pub key: NodeKey,
    pub task: RayTask,
    pub cursor: TraceCursor,
    /// The leaf it needs next (`None`: start wherever it is).
    pub next: Option<NodeId>,
}

/// A shadow bundle migrating with its recorded answers.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(crate = "hybrid_sched::serde")]
pub struct ShadowDp {
    pub key: NodeKey,
    pub bundle: ShadowBundle,
    pub replay: Replay,
    pub next: Option<NodeId>,
}

/// The leak tests of one irradiance-cache lookup (Radiance's
/// `plugaleak`), migrating with their recorded answers like a shadow
/// bundle: each test a segment from a point (origin, unit direction,
/// length) that an opaque surface may cross, run in order.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(crate = "hybrid_sched::serde")]
pub struct LeakDp {
    /// The pixel whose lookup waits (the path names the shaded point).
    pub key: NodeKey,
    pub req: AmbientRequest,
    pub tests: Vec<(Vec3, Vec3, f64)>,
    pub replay: Replay,
    pub next: Option<NodeId>,
}

/// Data-parallel tasks.
// The variants travel by value between processors; a shadow bundle carries
// its medium, and boxing it would cost an allocation per task.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(crate = "hybrid_sched::serde")]
pub enum DpTask {
    Ray(RayJob),
    Shadow(ShadowDp),
    Leak(LeakDp),
}

impl ByteSize for DpTask {
    fn byte_size(&self) -> usize {
        std::mem::size_of::<Self>()
            + ORIGIN_BYTES
            + match self {
                DpTask::Ray(j) => 2 * j.key.path.len(),
                DpTask::Shadow(s) => {
                    2 * s.key.path.len() + s.replay.answers.len() * std::mem::size_of::<Answer>()
                }
                DpTask::Leak(l) => {
                    2 * l.key.path.len()
                        + std::mem::size_of_val(l.tests.as_slice())
                        + l.replay.answers.len() * std::mem::size_of::<Answer>()
                }
            }
    }
}

/// How many full tiles per processor [`screen_tiles`] splits at the end of
/// the frame (option `tail_tiles`). On the simulated Parsytec CC (the
/// studio at 512x381, 32 processors, the settings of EXPERIMENTS.md's
/// record) the run took 3.2644 s of virtual time without the split, and
/// 3.2090, 3.2074, 3.2013 and 3.2217 s splitting one to four per
/// processor: one or two take most of the idle end away, more only adds
/// selections.
pub const TAIL_TILES_PER_PROC: usize = 2;

/// The frame's tiles in the order the master hands them out: rows of
/// squares of side `side` (cut at the frame's edges). With `tail` (option
/// `tail_tiles`), the last [`TAIL_TILES_PER_PROC`] per processor are each
/// handed out as four of side `side / 2` instead (rounded up to a multiple
/// of `align`, the adaptive sampling grid's step where tiles must keep to
/// it; not split when that is `side` again), so the frame ends on short
/// tasks and the processors run dry together: the idea of guided
/// self-scheduling (Polychronopoulos and Kuck, 1987), tasks that shrink as
/// the work left does. Every pixel is in exactly one tile; pictures do not
/// depend on the tiles.
pub fn screen_tiles(
    width: usize,
    height: usize,
    side: usize,
    align: usize,
    procs: usize,
    tail: bool,
) -> Vec<Tile> {
    let squares = |x: std::ops::Range<usize>, y: std::ops::Range<usize>, s: usize| {
        let s = s.max(1);
        y.clone().step_by(s).flat_map(move |y0| {
            let x = x.clone();
            let y1 = (y0 + s).min(y.end);
            x.clone()
                .step_by(s)
                .map(move |x0| Tile::new(x0..(x0 + s).min(x.end), y0..y1))
        })
    };
    let full: Vec<Tile> = squares(0..width, 0..height, side).collect();
    let half = (side / 2).max(1).div_ceil(align.max(1)) * align.max(1);
    if !tail || half >= side {
        return full;
    }
    let first_split = full
        .len()
        .saturating_sub(TAIL_TILES_PER_PROC * procs.max(1));
    let mut out = Vec::with_capacity(full.len() + 3 * (full.len() - first_split));
    for (k, t) in full.into_iter().enumerate() {
        if k < first_split {
            out.push(t);
        } else {
            let (x, y) = (t.x0 as usize..t.x1 as usize, t.y0 as usize..t.y1 as usize);
            out.extend(squares(x, y, half));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every pixel in exactly one tile, tiles inside the frame.
    fn check_cover(tiles: &[Tile], w: usize, h: usize) {
        let mut seen = vec![0u8; w * h];
        for t in tiles {
            assert!(t.x0 < t.x1 && t.y0 < t.y1, "{t:?} is empty");
            assert!(
                t.x1 as usize <= w && t.y1 as usize <= h,
                "{t:?} leaves the frame"
            );
            for y in t.y0..t.y1 {
                for x in t.x0..t.x1 {
                    seen[y as usize * w + x as usize] += 1;
                }
            }
        }
        assert!(seen.iter().all(|&n| n == 1), "a pixel in no tile or in two");
    }

    #[test]
    fn the_last_tiles_are_split_and_every_pixel_is_in_one_tile() {
        for (w, h, side, align, procs) in [
            (512, 381, 16, 1, 32),
            (37, 23, 16, 1, 2),
            (64, 48, 16, 4, 3),
            (10, 7, 16, 1, 8),
            (5, 5, 1, 1, 4),
            (100, 90, 15, 5, 1000),
            (100, 90, 12, 6, 5),
        ] {
            let plain = screen_tiles(w, h, side, align, procs, false);
            let tail = screen_tiles(w, h, side, align, procs, true);
            check_cover(&plain, w, h);
            check_cover(&tail, w, h);
            let half = (side / 2).max(1).div_ceil(align) * align;
            if half >= side {
                assert_eq!(plain, tail);
                continue;
            }
            // The same tiles first, in the same order; then only smaller ones.
            let kept = plain.len().saturating_sub(TAIL_TILES_PER_PROC * procs);
            assert_eq!(plain[..kept], tail[..kept], "{w}x{h} side {side}");
            assert!(tail[kept..]
                .iter()
                .all(|t| t.x1 - t.x0 <= half as u32 && t.y1 - t.y0 <= half as u32));
            // Tiles keep to the sampling grid (`side` is a multiple of `align`).
            assert!(tail
                .iter()
                .all(|t| t.x0 as usize % align == 0 && t.y0 as usize % align == 0));
        }
        // The studio at 512x381 on 32 processors: 768 tiles, the last 64 in quarters.
        assert_eq!(
            screen_tiles(512, 381, 16, 1, 32, true).len(),
            768 - 64 + 4 * 64
        );
    }
}
