//! Primary rays traced as packets: the pixels of a tile (8 x 8) have
//! their primary rays traced through the hierarchy together
//! ([`crate::geometry::Bvh::intersect_packet`]), then each pixel is shaded
//! from its known nearest hit ([`Renderer::trace_from_hit`]). A packet's
//! answers are the single rays' bit for bit, so no picture changes; the
//! book's benchmarks chapter has what the packets save.

use super::caster::RayCaster;
use super::sequential::{Bucket, Camera, Renderer, TraceState};
use super::RayTask;
use crate::accel::Hit;
use crate::geometry::{Segment, PACKET};
use crate::scene::Color;

/// The side of a square tile whose primary rays make one packet.
pub const TILE: usize = 8;

impl Renderer<'_> {
    /// Radiance of pixel (`x`, `y`) traced through `caster` ([`Renderer::pixel`]
    /// through another caster that answers as the renderer's own).
    pub fn pixel_with<Cam: Camera + ?Sized, C: RayCaster>(
        &self,
        camera: &Cam,
        (width, height): (usize, usize),
        caster: &C,
        (x, y): (usize, usize),
        st: &mut TraceState,
    ) -> Color {
        let n = self.options().pn.max(1);
        if n == 1 {
            return match self.primary_task(camera, width, height, x, y) {
                Some(task) => self.trace_with(caster, &task, st).0,
                None => Color::ZERO,
            };
        }
        let mut sum = Color::ZERO;
        for k in 0..n {
            if let Some(task) = self.sample_task(camera, width, height, x, y, k) {
                sum += self.trace_with(caster, &task, st).0;
            }
        }
        sum / n as f64
    }

    /// Shades the pixels `pixels` ((x, y), in order; best a tile of them)
    /// of a `width` x `height` picture through `caster`, handing each value
    /// to `out`: their primary rays traced as packets of at most
    /// [`PACKET`] where `caster` traces packets and a pixel has one ray
    /// (`-pn 1`), one at a time otherwise. The values are
    /// [`Renderer::pixel_with`]'s, bit for bit.
    pub fn trace_pixels<Cam: Camera + ?Sized, C: RayCaster>(
        &self,
        camera: &Cam,
        (width, height): (usize, usize),
        caster: &C,
        pixels: &[(usize, usize)],
        st: &mut TraceState,
        out: &mut dyn FnMut(usize, usize, Color),
    ) {
        if self.options().pn > 1 || !caster.traces_packets() {
            for &(x, y) in pixels {
                out(
                    x,
                    y,
                    self.pixel_with(camera, (width, height), caster, (x, y), st),
                );
            }
            return;
        }
        let mut values = Vec::with_capacity(PACKET);
        for chunk in pixels.chunks(PACKET) {
            let tasks: Vec<Option<RayTask>> = chunk
                .iter()
                .map(|&(x, y)| self.primary_task(camera, width, height, x, y))
                .collect();
            let traced: Vec<RayTask> = tasks.iter().flatten().cloned().collect();
            values.clear();
            self.trace_tasks(caster, &traced, st, &mut |v| values.push(v));
            let mut values = values.drain(..);
            for (&(x, y), task) in chunk.iter().zip(&tasks) {
                let value = if task.is_some() { values.next() } else { None };
                out(x, y, value.unwrap_or(Color::ZERO));
            }
        }
    }

    /// Traces `tasks` (coherent rays, such as a tile's primary rays)
    /// through `caster`, their nearest hits found as packets of at most
    /// [`PACKET`] where `caster` traces packets; hands each ray's radiance
    /// to `out`, in order. The values are [`Renderer::trace_with`]'s, bit
    /// for bit.
    pub fn trace_tasks<C: RayCaster>(
        &self,
        caster: &C,
        tasks: &[RayTask],
        st: &mut TraceState,
        out: &mut dyn FnMut(Color),
    ) {
        if !caster.traces_packets() {
            for task in tasks {
                out(self.trace_with(caster, task, st).0);
            }
            return;
        }
        let mut segments: Vec<Segment> = Vec::with_capacity(PACKET);
        let mut hits: [Option<Hit>; PACKET] = [None; PACKET];
        for chunk in tasks.chunks(PACKET) {
            segments.clear();
            segments.extend(chunk.iter().map(|t| (t.ray, t.tmin, t.tmax)));
            Self::timed(st, Bucket::Primary, |_| {
                caster.intersect_packet(&segments, &mut hits[..chunk.len()])
            });
            for (task, hit) in chunk.iter().zip(hits) {
                out(self.trace_from_hit(caster, task, hit, st).0);
            }
        }
    }
}

/// The pixels of columns `xs` and rows `ys` in tiles of [`TILE`] x
/// [`TILE`], tile after tile along the rows of tiles, each tile's pixels
/// row by row: the order in which [`Renderer::trace_pixels`] traces them
/// as packets.
pub fn tiles(
    xs: std::ops::Range<usize>,
    ys: std::ops::Range<usize>,
) -> impl Iterator<Item = Vec<(usize, usize)>> {
    let (x0, x1) = (xs.start, xs.end);
    ys.clone().step_by(TILE).flat_map(move |ty| {
        let ty1 = (ty + TILE).min(ys.end);
        (x0..x1).step_by(TILE).map(move |tx| {
            let tx1 = (tx + TILE).min(x1);
            (ty..ty1)
                .flat_map(|y| (tx..tx1).map(move |x| (x, y)))
                .collect()
        })
    })
}
