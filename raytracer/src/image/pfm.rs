//! Portable float maps (PFM): a three-line text header (`PF`, the size,
//! the scale whose sign gives the byte order) and 32-bit float RGB
//! triples, rows from the **bottom** of the picture to the top.
//!
//! Written by hand: no well-kept crate writes PFM (the `image` crate
//! reads and writes PNM's PBM, PGM, PPM and PAM, not PFM), and the format
//! is this header and the floats.

use std::io::Write;

use super::Film;

/// Encodes `film` as a little-endian colour PFM (scale `-1.0`): linear
/// radiance as `f32`, unscaled.
pub fn encode_pfm<W: Write>(film: &Film, mut w: W) -> std::io::Result<()> {
    write!(w, "PF\n{} {}\n-1.0\n", film.width(), film.height())?;
    let mut row = Vec::with_capacity(film.width() * 12);
    for y in (0..film.height()).rev() {
        row.clear();
        for c in film.row(y) {
            for v in [c.x, c.y, c.z] {
                row.extend_from_slice(&(v as f32).to_le_bytes());
            }
        }
        w.write_all(&row)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Color;

    #[test]
    fn header_then_bottom_row_first_little_endian() {
        let mut film = Film::new(2, 2);
        film.set(0, 0, Color::new(1.0, 2.0, 3.0)); // top left
        film.set(1, 1, Color::new(0.5, -0.25, 1e30)); // bottom right
        let mut b = Vec::new();
        encode_pfm(&film, &mut b).unwrap();
        let header = b"PF\n2 2\n-1.0\n";
        assert_eq!(&b[..header.len()], header);
        let floats: Vec<f32> = b[header.len()..]
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes(c.try_into().unwrap()))
            .collect();
        assert_eq!(floats.len(), 12);
        // Bottom row first: (0, 1) black, then (1, 1).
        assert_eq!(&floats[0..6], &[0.0, 0.0, 0.0, 0.5, -0.25, 1e30]);
        // Then the top row: (0, 0), then (1, 0) black.
        assert_eq!(&floats[6..12], &[1.0, 2.0, 3.0, 0.0, 0.0, 0.0]);
    }
}
