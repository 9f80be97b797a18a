use crate::geometry::Color;

/// Linear RGB radiance per pixel; row 0 is the top row.
#[derive(Debug, Clone, PartialEq)]
pub struct Film {
    width: usize,
    height: usize,
    pixels: Vec<Color>,
}

impl Film {
    /// A black film. Panics only if `width * height` overflows `usize`,
    /// which callers rule out by validating the resolution first.
    pub fn new(width: usize, height: usize) -> Self {
        let n = width.checked_mul(height).expect("film size overflows");
        Self {
            width,
            height,
            pixels: vec![Color::ZERO; n],
        }
    }

    /// A film of `width` x `height` pixels, row-major from the top row;
    /// `None` if `pixels` holds another number.
    pub fn from_pixels(width: usize, height: usize, pixels: Vec<Color>) -> Option<Self> {
        (width.checked_mul(height) == Some(pixels.len())).then_some(Self {
            width,
            height,
            pixels,
        })
    }

    pub fn width(&self) -> usize {
        self.width
    }

    pub fn height(&self) -> usize {
        self.height
    }

    /// Pixel at column `x`, row `y` (row 0 at the top).
    pub fn get(&self, x: usize, y: usize) -> Color {
        self.pixels[y * self.width + x]
    }

    pub fn set(&mut self, x: usize, y: usize, c: Color) {
        self.pixels[y * self.width + x] = c;
    }

    /// All pixels, row-major from the top row.
    pub fn pixels(&self) -> &[Color] {
        &self.pixels
    }

    /// Mutable row `y`.
    pub fn row_mut(&mut self, y: usize) -> &mut [Color] {
        let w = self.width;
        &mut self.pixels[y * w..(y + 1) * w]
    }

    /// Row `y`.
    pub fn row(&self, y: usize) -> &[Color] {
        &self.pixels[y * self.width..(y + 1) * self.width]
    }

    /// Mean of Radiance's brightness ([`brightness`]) over all pixels.
    pub fn mean_brightness(&self) -> f64 {
        if self.pixels.is_empty() {
            return 0.0;
        }
        self.pixels.iter().map(|&c| brightness(c)).sum::<f64>() / self.pixels.len() as f64
    }
}

/// Radiance's `bright()`: luminance-like weighting of its RGB primaries
/// (CIE_rf, CIE_gf, CIE_bf in color.h).
#[inline]
pub fn brightness(c: Color) -> f64 {
    0.265074126 * c.x + 0.670114631 * c.y + 0.064811243 * c.z
}

/// Extra information written into an HDR header.
#[derive(Debug, Clone, Default)]
pub struct HdrInfo {
    /// Radiance view options (`-vtv -vp ...`), written as a `VIEW=` line.
    pub view: Option<String>,
    /// Software name for the header comment.
    pub software: Option<String>,
}
