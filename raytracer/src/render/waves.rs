//! The order in which a render with an irradiance cache shades its pixels,
//! so that the picture is the same however many processors render it.
//!
//! With Radiance's cache a pixel's value depends on which records exist
//! when its points are shaded, and so on the order of the pixels before
//! it. Rendered in parallel, that order is the scheduler's. Here pixels
//! are shaded in *waves*: lattices of pixels from coarse to fine (every
//! 2^k-th pixel of every 2^k-th row, `k` falling to 0; each finer lattice
//! in three waves: the points between two coarser ones along a row, along
//! a column, then the centres, so that every point has shaded neighbours
//! one lattice step away). Within a wave every
//! pixel sees the cache as it was when the wave began plus the records its
//! own trace made; when the wave ends, the records of its pixels join the
//! cache in pixel order. A pixel's value thus depends only on the waves
//! before it, never on which processor shaded it or when, and the coarse
//! waves spread records over the picture before the fine ones need them,
//! as Radiance's overture pass does. The price: two pixels of one wave
//! cannot share a record made in that wave, so some hemispheres are
//! sampled twice (few, since the finer waves mostly find records made by
//! the coarser ones).
//!
//! With adaptive pixel sampling (`-ps` > 1) the waves cover the sampling
//! grid's lattice; then the sampler is run over the values known so far,
//! an unknown pixel standing for "do not refine on my account" (NaN, which
//! no difference test passes), and the pixels it asks for are shaded
//! next (in the order of the waves of the full lattice that hold them, one
//! wave each, so that neighbours along an edge share records); until it
//! asks for none, when its picture is the render. Every
//! pixel it would ask for with all values known is asked for in some
//! wave (a request waits only for the values it depends on), so the
//! picture is exactly the adaptive sampler's over the waves' values.

use std::sync::Arc;

use super::adaptive::Grid;
use super::ambient::{AmbientCache, AmbientRecord, AmbientSettings};
use crate::image::Film;
use crate::scene::Color;
use crate::Result;

/// Shades a wave: each pixel (row-major index) against the cache given,
/// frozen, giving its value and the records its trace made.
pub type ShadeWave<'a> =
    dyn FnMut(&[u32], &Arc<AmbientCache>) -> Result<Vec<(Color, Vec<AmbientRecord>)>> + 'a;

/// A picture rendered in waves: the film, the cache at the end, and the
/// number of waves.
pub struct WaveRender {
    pub film: Film,
    pub cache: Arc<AmbientCache>,
    pub waves: usize,
}

/// Renders a `width` x `height` picture with adaptive sampling `ps`, `pt`
/// in waves, starting from `cache`: `shade` shades each wave's pixels
/// (sequentially or in parallel: the result is the same), `progress`
/// hears the pixels shaded so far.
pub fn render_in_waves(
    width: usize,
    height: usize,
    (ps, pt): (u32, f64),
    s: &AmbientSettings,
    cache: Arc<AmbientCache>,
    shade: &mut ShadeWave<'_>,
    progress: &mut dyn FnMut(usize),
) -> Result<WaveRender> {
    let mut waves = Waves::new(width, height, (ps, pt), *s, cache);
    while let Some(wave) = waves.next_wave() {
        let results = shade(&wave, waves.cache())?;
        waves.wave_done(&wave, results);
        progress(waves.shaded());
    }
    Ok(waves.finish())
}

/// The waves of a render as a state machine, for a driver that shades
/// them elsewhere (the framework's epochs): ask [`Waves::next_wave`] for a
/// wave's pixels, shade them against [`Waves::cache`], hand the results
/// to [`Waves::wave_done`]; when no wave is left, [`Waves::finish`] gives
/// the picture. [`render_in_waves`] is this loop.
pub struct Waves {
    width: usize,
    height: usize,
    ps: u32,
    pt: f64,
    s: AmbientSettings,
    cache: Arc<AmbientCache>,
    /// Each pixel's value, once shaded.
    memo: Vec<Option<Color>>,
    /// Waves to shade next, in order.
    queue: std::collections::VecDeque<Vec<u32>>,
    /// Whether the sampler's requests are still to be asked for (`-ps` >
    /// 1, once the lattice is shaded).
    refining: bool,
    /// The rank of each pixel's wave in the full lattice's waves (for
    /// grouping the sampler's requests), computed when first needed.
    rank: Vec<u16>,
    film: Film,
    shaded: usize,
    waves: usize,
}

impl Waves {
    /// The waves of a `width` x `height` render with adaptive sampling
    /// `ps`, `pt`, starting from `cache`.
    pub fn new(
        width: usize,
        height: usize,
        (ps, pt): (u32, f64),
        s: AmbientSettings,
        cache: Arc<AmbientCache>,
    ) -> Self {
        Waves {
            width,
            height,
            ps,
            pt,
            s,
            cache,
            memo: vec![None; width * height],
            queue: cache_waves(width, height, ps as usize).into(),
            refining: ps > 1,
            rank: Vec::new(),
            film: Film::new(width, height),
            shaded: 0,
            waves: 0,
        }
    }

    /// The cache as the next wave finds it (frozen while it is shaded).
    pub fn cache(&self) -> &Arc<AmbientCache> {
        &self.cache
    }

    /// Pixels shaded so far.
    pub fn shaded(&self) -> usize {
        self.shaded
    }

    /// The next wave's pixels (row-major indices, ascending within a
    /// lattice wave), or `None` when the picture is complete.
    pub fn next_wave(&mut self) -> Option<Vec<u32>> {
        if let Some(w) = self.queue.pop_front() {
            return Some(w);
        }
        if !self.refining {
            return None;
        }
        // The adaptive sampler over the values known so far: the pixels
        // it asks for, grouped by the full lattice's waves (requests along
        // an edge are neighbours: so they share).
        if self.rank.is_empty() {
            self.rank = vec![0u16; self.width * self.height];
            for (k, wave) in cache_waves(self.width, self.height, 1).iter().enumerate() {
                for &i in wave {
                    self.rank[i as usize] = k.min(u16::MAX as usize) as u16;
                }
            }
        }
        let (width, memo, film) = (self.width, &self.memo, &mut self.film);
        let grid = Grid::new(self.width, self.height, self.ps, self.pt);
        let mut wanted: Vec<u32> = Vec::new();
        let mut carry = None;
        for band in grid.bands() {
            grid.fill_region(
                0..width,
                band,
                &mut carry,
                &mut |x, y| {
                    memo[y * width + x].unwrap_or_else(|| {
                        wanted.push((y * width + x) as u32);
                        Color::splat(f64::NAN)
                    })
                },
                &mut |x, y, c| film.set(x, y, c),
            );
        }
        if wanted.is_empty() {
            // The sampler asks for nothing more: its picture is the render.
            self.refining = false;
            return None;
        }
        let rank = &self.rank;
        wanted.sort_unstable_by_key(|&i| (rank[i as usize], i));
        wanted.dedup();
        for group in wanted.chunk_by(|a, b| rank[*a as usize] == rank[*b as usize]) {
            self.queue.push_back(group.to_vec());
        }
        self.queue.pop_front()
    }

    /// The values of `wave`'s pixels and the records their traces made (in
    /// the wave's order): the records join the cache in pixel order.
    pub fn wave_done(&mut self, wave: &[u32], results: Vec<(Color, Vec<AmbientRecord>)>) {
        let mut made = Vec::new();
        for (&i, (c, own)) in wave.iter().zip(results) {
            self.memo[i as usize] = Some(c);
            made.extend(own);
        }
        let before = std::mem::take(&mut self.cache);
        self.cache = AmbientCache::extended(before, &self.s, made);
        self.shaded += wave.len();
        self.waves += 1;
    }

    /// The picture (once [`Waves::next_wave`] has returned `None`), the
    /// cache at the end and the number of waves shaded.
    pub fn finish(mut self) -> WaveRender {
        if self.ps <= 1 {
            for (i, c) in self.memo.iter().enumerate() {
                self.film
                    .set(i % self.width, i / self.width, c.unwrap_or(Color::ZERO));
            }
        }
        WaveRender {
            film: self.film,
            cache: self.cache,
            waves: self.waves,
        }
    }
}

/// Pixel indices (row-major) of each wave, coarsest first: the points of
/// the lattice of spacing `step` (1, or `-ps`), every one in exactly one
/// wave. The coarsest wave has a spacing of at least half the picture's
/// larger side (at most four pixels): every later wave finds records.
pub fn cache_waves(width: usize, height: usize, step: usize) -> Vec<Vec<u32>> {
    let step = step.max(1);
    let coarsest_target = width.max(height).div_ceil(2).max(1);
    let mut levels = 0;
    while (step << levels) < coarsest_target && levels < 30 {
        levels += 1;
    }
    let mut waves = Vec::new();
    for k in (0..=levels).rev() {
        let stride = step << k;
        let lattice = |parity: Option<(usize, usize)>| {
            let mut wave = Vec::new();
            for y in (0..height).step_by(stride) {
                for x in (0..width).step_by(stride) {
                    if parity
                        .is_none_or(|(px, py)| (x / stride) % 2 == px && (y / stride) % 2 == py)
                    {
                        wave.push((y * width + x) as u32);
                    }
                }
            }
            wave
        };
        if k == levels {
            waves.push(lattice(None));
        } else {
            // Between the points of the coarser lattice: first those
            // between two of them along a row, then along a column, then
            // the centres, each next to points already shaded.
            for parity in [(1, 0), (0, 1), (1, 1)] {
                waves.push(lattice(Some(parity)));
            }
        }
    }
    waves.retain(|w| !w.is_empty());
    waves
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn waves_cover_the_lattice_once_coarse_to_fine() {
        for (w, h, step) in [(1, 1, 1), (7, 3, 1), (64, 48, 1), (100, 37, 4), (5, 5, 8)] {
            let waves = cache_waves(w, h, step);
            let mut seen = vec![0u32; w * h];
            for wave in &waves {
                assert!(wave.windows(2).all(|p| p[0] < p[1]), "row-major");
                for &i in wave {
                    seen[i as usize] += 1;
                }
            }
            for (i, n) in seen.iter().enumerate() {
                let (x, y) = (i % w, i / w);
                let on = x % step == 0 && y % step == 0;
                assert_eq!(*n, u32::from(on), "{w}x{h}/{step}: pixel {x},{y}");
            }
            // The first wave is at most four pixels.
            assert!(waves[0].len() <= 4, "{}", waves[0].len());
        }
    }
}
