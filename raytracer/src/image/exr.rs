//! OpenEXR output through the `exr` crate: linear radiance as 32-bit
//! float RGB, the view in a `radianceView` text attribute.

use std::io::{Cursor, Write};

use exr::meta::attribute::{AttributeValue, Text};
use exr::prelude::{
    Encoding, Image, Layer, LayerAttributes, SpecificChannels, Vec2, WritableImage,
};

use super::film::{Film, HdrInfo};

/// The layer attribute holding Radiance's view options (`-vtv -vp ...`),
/// as the `VIEW=` line of an HDR picture does.
/// (EXR reserves `view` for stereo pictures.)
pub const VIEW_ATTRIBUTE: &str = "radianceView";

/// Encodes `film` as a single-layer RGB EXR of 32-bit floats, ZIP
/// compressed, rows from the top (EXR's increasing line order), and
/// writes it to `w`. The picture is assembled in memory first (the `exr`
/// crate seeks while writing; standard output cannot).
pub fn encode_exr<W: Write>(film: &Film, info: &HdrInfo, mut w: W) -> std::io::Result<()> {
    let mut attrs = LayerAttributes::default();
    if let Some(view) = &info.view {
        if let Some(t) = Text::new_or_none(view.as_str()) {
            attrs
                .other
                .insert(Text::from(VIEW_ATTRIBUTE), AttributeValue::Text(t));
        }
    }
    if let Some(sw) = &info.software {
        attrs.software_name = Text::new_or_none(sw.as_str());
    }
    let (width, height) = (film.width(), film.height());
    let pixels = SpecificChannels::rgb(|p: Vec2<usize>| {
        let c = film.get(p.x(), p.y());
        (c.x as f32, c.y as f32, c.z as f32)
    });
    let layer = Layer::new((width, height), attrs, Encoding::SMALL_LOSSLESS, pixels);
    let mut buf = Cursor::new(Vec::new());
    Image::from_layer(layer)
        .write()
        .to_buffered(&mut buf)
        .map_err(|e| match e {
            exr::error::Error::Io(io) => io,
            other => std::io::Error::other(other.to_string()),
        })?;
    w.write_all(buf.get_ref())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Color;

    #[test]
    fn round_trip_through_the_exr_crate_keeps_f32_pixels_and_the_view() {
        let mut film = Film::new(5, 3);
        for y in 0..3 {
            for x in 0..5 {
                film.set(x, y, Color::new(x as f64 * 0.1, y as f64 * 1e3, 1.0 / 3.0));
            }
        }
        let info = HdrInfo {
            view: Some("-vtv -vp 1 2 3".into()),
            software: Some("test".into()),
        };
        let mut bytes = Vec::new();
        encode_exr(&film, &info, &mut bytes).unwrap();
        use exr::prelude::{ReadChannels as _, ReadLayers as _, ReadSpecificChannel as _};
        let img = exr::prelude::read()
            .no_deep_data()
            .largest_resolution_level()
            .specific_channels()
            .required("R")
            .required("G")
            .required("B")
            .collect_pixels(
                |size: Vec2<usize>, _| vec![vec![[0f32; 3]; size.width()]; size.height()],
                |px: &mut Vec<Vec<[f32; 3]>>, p: Vec2<usize>, (r, g, b): (f32, f32, f32)| {
                    px[p.y()][p.x()] = [r, g, b]
                },
            )
            .first_valid_layer()
            .all_attributes()
            .from_buffered(std::io::Cursor::new(&bytes))
            .expect("readable EXR");
        let layer = &img.layer_data;
        assert_eq!(layer.size, Vec2(5, 3));
        assert_eq!(
            layer.attributes.other.get(&Text::from(VIEW_ATTRIBUTE)),
            Some(&AttributeValue::Text(Text::from("-vtv -vp 1 2 3")))
        );
        for y in 0..3 {
            for x in 0..5 {
                let c = film.get(x, y);
                let got = layer.channel_data.pixels[y][x];
                assert_eq!(got, [c.x as f32, c.y as f32, c.z as f32], "({x}, {y})");
            }
        }
    }
}
