//! The waves of a render with an irradiance cache: what the master drives
//! them with and what each processor's cache is (the workload's side is
//! `irradiance.rs`).

use std::sync::{Arc, Mutex};

use super::tasks::{DdTask, WaveChunk};
use crate::render::ambient::{AmbientCache, AmbientRecord, AmbientSettings};
use crate::render::waves::Waves;
use crate::render::Renderer;

/// Most pixels of a chunk: many enough that handing them out costs little.
const CHUNK: usize = 16;

/// Pixels per chunk for a wave of `len` pixels on `procs` processors: at
/// most [`CHUNK`], and few enough that every processor gets about four (a
/// wave is a barrier: a coarse wave of 64 pixels in chunks of 16 would
/// keep all but four processors waiting).
fn chunk_len(len: usize, procs: usize) -> usize {
    len.div_ceil(4 * procs.max(1)).clamp(1, CHUNK)
}

/// The waves of a render with an irradiance cache.
#[derive(Debug)]
pub(super) struct Irradiance {
    /// Records the render starts from (`-af`).
    pub(super) initial: Arc<AmbientCache>,
    /// Per processor, the cache of the wave it shades.
    pub(super) slots: Vec<Mutex<WaveSlot>>,
    /// The master's.
    pub(super) driver: Mutex<Driver>,
    procs: usize,
    /// The picture's size, its adaptive sampling (`-ps`, `-pt`) and the
    /// cache's settings: what the master makes the waves from.
    plan: (usize, usize, (u32, f64), AmbientSettings),
}

/// A processor's cache: the wave it shades, and the broadcasts it holds
/// added so far.
#[derive(Debug)]
pub(super) struct WaveSlot {
    pub(super) current: u32,
    pub(super) built: u32,
    pub(super) cache: Arc<AmbientCache>,
}

pub(super) struct Driver {
    pub(super) waves: Option<Waves>,
    /// The pixels of the wave running.
    pub(super) current: Vec<u32>,
    /// What went wrong between waves (a lost pixel), reported at the end.
    pub(super) error: Option<String>,
}

impl std::fmt::Debug for Driver {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Driver")
            .field("current", &self.current.len())
            .field("error", &self.error)
            .finish()
    }
}

/// What the cache did in a render: the waves, the counts, the records at
/// the end and those the render added.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct WaveSummary {
    pub waves: usize,
    pub counts: crate::render::ambient::AmbientCounts,
    pub records: usize,
    #[serde(skip)]
    pub new_records: Vec<AmbientRecord>,
}

impl Irradiance {
    /// The waves of `renderer`'s render at `width` x `height` on `procs`
    /// processors, from the records `initial`; `None` without a cache.
    pub(super) fn new(
        renderer: &Renderer<'static>,
        width: usize,
        height: usize,
        procs: usize,
        initial: &[AmbientRecord],
    ) -> Option<Self> {
        if !renderer.caches_ambient() {
            return None;
        }
        let s = *renderer.ambient_settings();
        let mut base = AmbientCache::default();
        for r in initial {
            base.insert(&s, *r);
        }
        let initial = Arc::new(base);
        let o = renderer.options();
        Some(Irradiance {
            plan: (width, height, (o.ps, o.pt), s),
            slots: (0..procs.max(1))
                .map(|_| {
                    Mutex::new(WaveSlot {
                        current: 0,
                        built: 0,
                        cache: initial.clone(),
                    })
                })
                .collect(),
            initial,
            // Made by the master when it asks for the roots: no other MPI
            // rank holds the waves' picture.
            driver: Mutex::new(Driver {
                waves: None,
                current: Vec::new(),
                error: None,
            }),
            procs,
        })
    }

    pub(super) fn chunks(&self, wave: u32, pixels: &[u32]) -> Vec<DdTask> {
        pixels
            .chunks(chunk_len(pixels.len(), self.procs))
            .map(|c| {
                DdTask::Wave(Box::new(WaveChunk {
                    wave,
                    pixels: c.to_vec(),
                }))
            })
            .collect()
    }

    /// The first wave's chunks (on the master, which makes the waves).
    pub(super) fn roots(&self) -> Vec<DdTask> {
        let mut d = self.driver.lock().unwrap_or_else(|e| e.into_inner());
        if d.waves.is_none() {
            let (w, h, ps, s) = self.plan;
            let mut waves = Waves::new(w, h, ps, s, self.initial.clone());
            d.current = waves.next_wave().unwrap_or_default();
            d.waves = Some(waves);
        }
        self.chunks(0, &d.current)
    }
}
