//! Several primary rays per pixel (`-pn`) in the hybrid workload: each
//! sample's ray is a ray job of its own, and the pixel a node of its ray
//! tree whose children are its samples and whose value is their mean, in
//! sample order, divided by `-pn` ([`Child::Mean`]), as
//! [`crate::render::Renderer::pixel`] computes it. A sample the view gives
//! no ray adds nothing, as there.

use hybrid_sched::{Addr, Ctx};

use super::tasks::Tile;
use super::tree::{Child, NodeKey, Record, RtResult};
use super::workload::RtWorkload;
use crate::render::{RayCaster, RayTask, TraceState};
use crate::scene::Color;

impl RtWorkload {
    /// Tile `t`'s primary rays with their ray-tree keys: one a pixel
    /// ([`RtWorkload::tile_primaries`]), or with `-pn` above 1 every
    /// sample's, each pixel's node (its record, the mean of its samples)
    /// sent to the tile's origin now.
    pub(super) fn tile_jobs(&self, t: &Tile, ctx: &mut Ctx<Self>) -> Vec<(NodeKey, RayTask)> {
        let n = self.renderer.options().pn;
        if n <= 1 {
            return self.tile_primaries(t, ctx.proc_id()).collect();
        }
        // With one sample a pixel, which these do not use.
        let _ = self.take_tile(t, ctx.proc_id());
        let origin = Addr::Proc(ctx.origin());
        let mut jobs = Vec::new();
        for (x, y) in pixels(t) {
            let root = NodeKey::root(y * self.width as u32 + x);
            let samples: Vec<RayTask> = (0..n)
                .filter_map(|k| {
                    let (w, h) = (self.width, self.height);
                    self.renderer
                        .sample_task(&self.view, w, h, x as usize, y as usize, k)
                })
                .collect();
            let mut children = Vec::with_capacity(1 + samples.len());
            children.push(Child::Mean(n));
            children.extend(samples.iter().map(|_| Child::Trace(Color::ONE)));
            let record = Record::Shaded {
                base: Color::ZERO,
                children,
                attenuation: None,
            };
            let key = root.clone();
            ctx.emit_result(origin, RtResult { key, record });
            let keyed = samples.into_iter().enumerate();
            jobs.extend(keyed.map(|(j, task)| (root.child(1 + j), task)));
        }
        jobs
    }

    /// With `-pn` above 1, each pixel of tile `t` traced whole through
    /// `caster` by the sequential renderer's code, its value sent to the
    /// tile's origin; returns the tally of what was traced.
    pub(super) fn trace_samples_whole<C: RayCaster>(
        &self,
        t: &Tile,
        caster: &C,
        ctx: &mut Ctx<Self>,
    ) -> TraceState {
        // With one sample a pixel, which these do not use.
        let _ = self.take_tile(t, ctx.proc_id());
        let origin = Addr::Proc(ctx.origin());
        let mut st = TraceState::default();
        let size = (self.width, self.height);
        for (x, y) in pixels(t) {
            let at = (x as usize, y as usize);
            let value = self
                .renderer
                .pixel_with(&self.view, size, caster, at, &mut st);
            let key = NodeKey::root(y * self.width as u32 + x);
            let record = Record::Value(value);
            ctx.emit_result(origin, RtResult { key, record });
        }
        st
    }
}

/// Tile `t`'s pixels, row by row.
fn pixels(t: &Tile) -> impl Iterator<Item = (u32, u32)> + '_ {
    (t.y0..t.y1).flat_map(move |y| (t.x0..t.x1).map(move |x| (x, y)))
}
