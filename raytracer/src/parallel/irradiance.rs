//! Diffuse inter-reflection with an irradiance cache in the hybrid
//! workload: the same picture as the sequential renderer, bit for bit, for
//! any runtime, number of processors, policy, cache size and distribution.
//!
//! The cache makes a pixel depend on the records that exist when its
//! points are shaded (the paper, section 4: a data dependency between
//! tasks). Both renderers shade pixels in the waves of
//! [`crate::render::waves`]: within a wave every pixel reads the cache as
//! it was when the wave began plus the records its own trace makes;
//! between waves the wave's records join the cache in pixel order. Here a
//! wave is one of the framework's *epochs* ([`hybrid_sched::Workload::next_epoch`]):
//! its pixels are root tasks in chunks ([`WaveChunk`]: at most 16 pixels,
//! about four chunks per processor), handed out demand-driven; the
//! processor that runs a chunk owns its pixels. Their rays are traced as
//! every other ray is (migrating to the cells they cross, shaded where
//! they hit), and the owner decides the cache's lookups and samples the
//! hemispheres in the sequential renderer's order (`cursor.rs`). A
//! finished pixel's value and records go to the master
//! ([`Record::WavePixels`]); when the wave is over the master feeds them
//! to the waves' state machine ([`Waves`]), which names the next wave, and
//! the wave's records travel to every processor as write-once broadcast
//! data ([`Item::Records`], id [`wave_item`]) before any pixel of the next
//! wave is shaded. A processor's cache for wave `w` is the starting
//! records (`-af`) plus the broadcasts `0..w`, in order: the sequential
//! renderer's cache at that wave. Under the replicated distribution a
//! chunk's pixels are traced whole by the sequential renderer's code.

use std::sync::Arc;

use hybrid_sched::{Addr, Ctx, DataView, Epoch};

use super::tasks::{wave_item, DpTask, Item, RayJob, WaveChunk};
use super::tree::{Child, NodeKey, PixelTrees, Record, RtResult, Traced, WaveBatch};
use super::wave_driver::WaveSummary;
use super::work::Work;
use super::workload::RtWorkload;
use crate::accel::TraceCursor;
use crate::image::Film;
use crate::render::ambient::AmbientCache;
use crate::render::{Renderer, TraceState};
use crate::scene::Color;

impl RtWorkload {
    /// The cache processor `proc` shades its pixels against: the starting
    /// records and the broadcasts of the waves before `wave` (the wave it
    /// shades if `None`), from those it holds in `data`.
    pub(super) fn wave_cache(
        &self,
        proc: usize,
        wave: Option<u32>,
        data: &DataView<'_, Self>,
    ) -> Arc<AmbientCache> {
        let Some(irr) = &self.irradiance else {
            return Arc::default();
        };
        let Some(slot) = irr.slots.get(proc) else {
            return irr.initial.clone();
        };
        let mut slot = slot.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(w) = wave {
            slot.current = slot.current.max(w);
        }
        let s = self.renderer.ambient_settings();
        while slot.built < slot.current {
            // Every task of wave `w` runs after the broadcasts 0..w are
            // held (the framework's guarantee, SEMANTICS.md section 10): a
            // missing one is a broken guarantee, not an empty wave, and
            // ends the run rather than shade against the wrong cache.
            let records = match data.get(&wave_item(slot.built)) {
                Some(Item::Records(r)) => r.clone(),
                _ => panic!(
                    "wave {}: the records of wave {} were not broadcast to processor {proc}",
                    slot.current, slot.built
                ),
            };
            let before = std::mem::take(&mut slot.cache);
            slot.cache = AmbientCache::extended(before, s, records);
            slot.built += 1;
        }
        slot.cache.clone()
    }

    /// Runs a chunk of a wave's pixels (see the module documentation);
    /// `data`: what the processor holds, where the hook has it.
    pub(super) fn run_wave(
        &self,
        chunk: &WaveChunk,
        data: Option<&DataView<'_, Self>>,
        ctx: &mut Ctx<Self>,
    ) {
        let proc = ctx.proc_id();
        if let Some(irr) = &self.irradiance {
            if let Some(slot) = irr.slots.get(proc) {
                let mut slot = slot.lock().unwrap_or_else(|e| e.into_inner());
                slot.current = slot.current.max(chunk.wave);
            }
        }
        if let Some(data) = data {
            if self.replicated() {
                let caster = self.renderer.caster();
                let st = self.run_wave_whole(chunk, data, &caster, ctx);
                return self.charge_counts(&st, ctx);
            }
            // A processor holding every cell traces its pixels whole too,
            // through its hierarchy, which answers as the renderer's does.
            let held = self.whole_caster(proc);
            if let Some(caster) = held.filter(|_| self.opts.inline_local_shadows) {
                let st = self.run_wave_whole(chunk, data, &caster, ctx);
                return self.charge_held(&st, caster.queries.get(), ctx);
            }
        }
        let origin = Addr::Proc(ctx.origin());
        let (w, h) = (self.width, self.height);
        let n = self.renderer.options().pn;
        let mut unseen = WaveBatch::default();
        let mut jobs = Vec::new();
        for &i in &chunk.pixels {
            let (x, y) = (i as usize % w, i as usize / w);
            let root = NodeKey::root(i);
            if n <= 1 {
                match self.primary(x as u32, y as u32) {
                    Some(task) => jobs.push((root, task)),
                    // The view has no ray through it: black, as there.
                    None => unseen.pixels.push((i, Color::ZERO, Vec::new())),
                }
                continue;
            }
            let samples: Vec<_> = (0..n)
                .filter_map(|k| self.renderer.sample_task(&self.view, w, h, x, y, k))
                .collect();
            let mut children = Vec::with_capacity(1 + samples.len());
            children.push(Child::Mean(n));
            children.extend(samples.iter().map(|_| Child::Trace(Color::ONE)));
            let record = Record::Traced(Box::new(Traced {
                base: Color::ZERO,
                children,
                attenuation: None,
                t: f64::INFINITY,
                passes_on: false,
                aw: None,
                requests: Vec::new(),
            }));
            ctx.emit_result(
                origin,
                RtResult {
                    key: root.clone(),
                    record,
                },
            );
            jobs.extend(
                samples
                    .into_iter()
                    .enumerate()
                    .map(|(j, t)| (root.child(1 + j), t)),
            );
        }
        if !unseen.pixels.is_empty() {
            self.ship_wave(unseen, ctx);
        }
        for (key, task) in jobs {
            ctx.charge(super::work::Work::RaysSpawned, 1);
            let job = RayJob {
                key,
                task,
                cursor: TraceCursor::default(),
                next: None,
            };
            let job = match data {
                Some(data) => self.advance_ray(job, data, ctx),
                None => Some(job),
            };
            if let Some(job) = job {
                ctx.spawn_dp(DpTask::Ray(job));
            }
        }
    }

    /// [`Self::run_wave`] where the processor holds the scene: each pixel
    /// traced whole through `caster` by the sequential renderer's code
    /// against the wave's cache; the tally of what was traced.
    fn run_wave_whole<C: crate::render::RayCaster>(
        &self,
        chunk: &WaveChunk,
        data: &DataView<'_, Self>,
        caster: &C,
        ctx: &mut Ctx<Self>,
    ) -> TraceState {
        let cache = self.wave_cache(ctx.proc_id(), Some(chunk.wave), data);
        let mut st = TraceState::default();
        let mut batch = WaveBatch::default();
        let size = (self.width, self.height);
        for &i in &chunk.pixels {
            let (x, y) = (i as usize % self.width, i as usize / self.width);
            st.ambient = Renderer::frozen_state(&cache);
            let c = self
                .renderer
                .pixel_with(&self.view, size, caster, (x, y), &mut st);
            batch.pixels.push((i, c, st.ambient.take_own()));
        }
        batch.counts = st.counts.ambient_cache;
        self.ship_wave(batch, ctx);
        st
    }

    /// Sends finished pixels of the wave to the master (and counts them
    /// for a progress display).
    fn ship_wave(&self, batch: WaveBatch, ctx: &mut Ctx<Self>) {
        if let Some(p) = &self.progress {
            let n = batch.pixels.len() as u64;
            p.fetch_add(n, std::sync::atomic::Ordering::Relaxed);
        }
        ctx.emit_result(
            Addr::Master,
            RtResult {
                key: NodeKey::default(),
                record: Record::WavePixels(Box::new(batch)),
            },
        );
    }

    /// A result merged at a processor of a render with a cache: the
    /// pixel's walk goes on, and its finished pixels go to the master with
    /// their records.
    pub(super) fn merge_wave(
        &self,
        acc: &mut PixelTrees,
        result: RtResult,
        data: &DataView<'_, Self>,
        ctx: &mut Ctx<Self>,
    ) {
        let pixel = result.key.pixel;
        acc.merge(result);
        self.advance_cursor(acc, pixel, data, ctx);
        if acc.pixels.is_empty() {
            return;
        }
        let mut batch = WaveBatch::default();
        for (i, c) in std::mem::take(&mut acc.pixels) {
            let records = acc
                .cursors
                .remove(&i)
                .map(|mut cur| cur.take_own())
                .unwrap_or_default();
            batch.pixels.push((i, c, records));
        }
        batch.counts = std::mem::take(&mut acc.ambient);
        acc.shipped += batch.pixels.len();
        self.ship_wave(batch, ctx);
    }

    /// A wave is over: its values and records go to the waves' state
    /// machine; the next wave's pixels are the roots, this wave's records
    /// the broadcast.
    pub(super) fn next_wave(&self, ended: usize, acc: &mut PixelTrees) -> Option<Epoch<Self>> {
        let irr = self.irradiance.as_ref()?;
        let mut d = irr.driver.lock().unwrap_or_else(|e| e.into_inner());
        let d = &mut *d;
        let waves = d.waves.as_mut()?;
        let mut results = Vec::with_capacity(d.current.len());
        for i in &d.current {
            let Some(r) = acc.wave.remove(i) else {
                d.error = Some(format!("wave {ended}: pixel {i} has no value"));
                return None;
            };
            results.push(r);
        }
        // The broadcast is what the wave added to the master's cache, in
        // its order (a processor's insertion keeps and drops the same).
        let before = waves.cache().len();
        waves.wave_done(&d.current, results);
        let made = waves.cache().records()[before..].to_vec();
        let next = waves.next_wave()?;
        d.current = next;
        let wave = u32::try_from(ended + 1).ok()?;
        Some(Epoch {
            roots: irr.chunks(wave, &d.current),
            broadcast: vec![(wave_item(wave - 1), Item::Records(made))],
        })
    }

    /// The picture of a render with a cache and what the cache did, from
    /// the master's accumulator after the run (`None` without a cache).
    pub(super) fn finish_waves(
        &self,
        master: &mut PixelTrees,
    ) -> Option<crate::Result<(Film, WaveSummary)>> {
        let irr = self.irradiance.as_ref()?;
        let mut d = irr.driver.lock().unwrap_or_else(|e| e.into_inner());
        let lost = |m: String| Some(Err(crate::Error::Other(format!("parallel render {m}"))));
        if let Some(e) = d.error.take() {
            return lost(format!("lost a result: {e}"));
        }
        if master.wave_duplicates > 0 {
            return lost(format!("shaded {} pixels twice", master.wave_duplicates));
        }
        if !master.wave.is_empty() {
            return lost(format!(
                "left {} pixels outside its waves",
                master.wave.len()
            ));
        }
        let waves = d.waves.take()?;
        let out = waves.finish();
        let loaded = irr.initial.len();
        let records = out.cache.len();
        Some(Ok((
            out.film,
            WaveSummary {
                waves: out.waves,
                counts: master.ambient,
                records,
                new_records: out.cache.records()[loaded.min(records)..].to_vec(),
            },
        )))
    }

    /// Charges what a processor holding everything traced whole (`st`,
    /// `queries` of its hierarchy), as the replicated path charges, with
    /// each ray and bundle spawned, retired and (a bundle) run inline.
    pub(super) fn charge_held(
        &self,
        st: &crate::render::TraceState,
        queries: u64,
        ctx: &mut Ctx<Self>,
    ) {
        self.charge_counts(st, ctx);
        let c = &st.counts;
        let rays = c.primary + c.reflection + c.refraction + c.pass_through + c.ambient;
        for (kind, n) in [
            (Work::RaysSpawned, rays),
            (Work::RaysRetired, rays),
            (Work::ShadowSpawned, c.shadow.bundles),
            (Work::ShadowRetired, c.shadow.bundles),
            (Work::ShadowBundlesInline, c.shadow.bundles),
            (Work::TraceLeaves, 0),
            (Work::TraceObjects, 0),
            (Work::TraceLocal, queries),
        ] {
            ctx.charge(kind, n);
        }
    }
}

/// What a point shaded with a cache leaves to its pixel's owner
/// ([`RtWorkload::defer_ambient`]).
pub(super) struct Deferred {
    passes_on: bool,
    aw: Option<Color>,
    requests: Vec<super::tree::HemisphereSeed>,
}

impl Deferred {
    /// The node's record, its hit `t` away: with nothing to decide and
    /// every child's value known, its value.
    pub(super) fn record(
        self,
        base: Color,
        children: Vec<Child>,
        attenuation: Option<super::tree::Attenuation>,
        t: f64,
    ) -> Record {
        if self.aw.is_none() && self.requests.is_empty() && !children.iter().any(Child::awaited) {
            let value = super::tree::evaluate(base, &children, &[], attenuation);
            return Record::Leaf(value, t);
        }
        Record::Traced(Box::new(Traced {
            base,
            children,
            attenuation,
            t,
            passes_on: self.passes_on,
            aw: self.aw,
            requests: self.requests,
        }))
    }
}

impl RtWorkload {
    /// With a cache, a point's `-aw` term and ambient requests become
    /// children its pixel's owner decides (`cursor.rs`), after its
    /// `requests`' children, with the sequential renderer's tests.
    pub(super) fn defer_ambient(
        &self,
        task: &crate::render::RayTask,
        shaded: &crate::render::shading::Shaded,
        requests: &[crate::render::Request],
        children: &mut Vec<Child>,
    ) -> Deferred {
        use crate::render::{RayKind, Request};
        let o = self.renderer.options();
        let aw = (o.aw > 0
            && shaded.constant != Color::ZERO
            && self.renderer.effects().diffuse_interreflection.enabled)
            .then_some(shaded.constant);
        if aw.is_some() {
            children.push(Child::AmbientTerm);
        }
        let mut seeds = Vec::new();
        for req in shaded.ambient.iter().flatten() {
            children.push(Child::Ambient(req.coef));
            seeds.push(super::tree::HemisphereSeed {
                task: *task,
                req: *req,
            });
        }
        // `Renderer::radiance`'s test.
        let passes_on = shaded.base == Color::ZERO
            && shaded.ambient.iter().all(Option::is_none)
            && matches!(
                requests,
                [Request::Trace { task: child, coef }, ..]
                    if child.kind == RayKind::PassThrough && *coef == Color::ONE
            )
            && requests[1..]
                .iter()
                .all(|r| matches!(r, Request::Scatter(_)));
        Deferred {
            passes_on,
            aw,
            requests: seeds,
        }
    }

    /// With a cache, a ray that left the scene: `sky`, infinitely far.
    pub(super) fn sky_record(&self, sky: Color) -> Record {
        match self.irradiance {
            None => Record::Value(sky),
            Some(_) => Deferred {
                passes_on: false,
                aw: None,
                requests: Vec::new(),
            }
            .record(sky, Vec::new(), None, f64::INFINITY),
        }
    }
}
