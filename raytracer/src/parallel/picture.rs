//! The picture as the master holds it while processors send their
//! finished pixels ([`super::tree::Record::Pixels`]): every pixel's colour
//! in place, 24 bytes a pixel and one bit for whether it has arrived, so
//! the master's memory is the film's and no more.

use hybrid_sched::serde::{Deserialize, Serialize};

use crate::image::Film;
use crate::scene::Color;

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(crate = "hybrid_sched::serde")]
pub struct Picture {
    colors: Vec<Color>,
    /// One bit per pixel: arrived.
    placed: Vec<u64>,
    /// The first pixel that arrived twice or lies outside the picture.
    fault: Option<u32>,
}

impl Picture {
    /// A picture of `total` pixels, none arrived.
    pub fn new(total: usize) -> Self {
        Picture {
            colors: vec![Color::ZERO; total],
            placed: vec![0; total.div_ceil(64)],
            fault: None,
        }
    }

    /// Pixels in the picture.
    pub fn len(&self) -> usize {
        self.colors.len()
    }

    pub fn is_empty(&self) -> bool {
        self.colors.is_empty()
    }

    /// Places pixel `i` (row-major); one that arrived before, or lies
    /// outside, is remembered as the fault and changes nothing.
    pub fn place(&mut self, i: u32, c: Color) {
        let k = i as usize;
        let (word, bit) = (k / 64, 1u64 << (k % 64));
        match self.colors.get_mut(k) {
            Some(slot) if self.placed[word] & bit == 0 => {
                *slot = c;
                self.placed[word] |= bit;
            }
            _ => {
                self.fault.get_or_insert(i);
            }
        }
    }

    /// Pixels arrived.
    pub fn placed(&self) -> usize {
        self.placed.iter().map(|w| w.count_ones() as usize).sum()
    }

    /// The first pixel that arrived twice or out of range.
    pub fn fault(&self) -> Option<u32> {
        self.fault
    }

    /// The film of `width` x `height` pixels (the picture's size), the
    /// colours moved, not copied; `None` for another size.
    pub fn into_film(self, width: usize, height: usize) -> Option<Film> {
        Film::from_pixels(width, height, self.colors)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pixels_are_placed_once_and_faults_remembered() {
        let mut p = Picture::new(130);
        p.place(129, Color::splat(2.0));
        p.place(0, Color::splat(1.0));
        assert_eq!((p.placed(), p.fault()), (2, None));
        // Twice: the first colour stays, the fault is the pixel.
        p.place(129, Color::splat(5.0));
        p.place(130, Color::ONE);
        assert_eq!((p.placed(), p.fault()), (2, Some(129)));
        let film = p.clone().into_film(13, 10).expect("130 pixels");
        assert_eq!(film.get(0, 0), Color::splat(1.0));
        assert_eq!(film.get(12, 9), Color::splat(2.0));
        assert_eq!(film.get(1, 0), Color::ZERO);
        assert!(p.into_film(13, 11).is_none());
    }
}
