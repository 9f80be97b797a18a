//! Tests of data files and pictures as data: hand-computed interpolation,
//! the Radiance test scenes' files, malformed input.

use super::*;
use crate::image::hdr::from_rgbe;
use proptest::prelude::*;

fn data(text: &str) -> DataArray {
    DataArray::parse(text.as_bytes(), Path::new("t.dat")).expect("parses")
}

fn parse_err(text: &str) -> String {
    DataArray::parse(text.as_bytes(), Path::new("bad.dat"))
        .expect_err("should be refused")
        .to_string()
}

fn close(a: f64, b: f64) {
    assert!((a - b).abs() <= 1e-9 * (1.0 + b.abs()), "{a} != {b}");
}

use crate::testdata::radiance_test_file as shared;

fn here() -> SourceLoc {
    SourceLoc::new("scene.rad", 7)
}

#[test]
fn one_dimension_interpolates_inside_and_extrapolates_then_tapers_outside() {
    // Points at 0, 1, 2 with values 30, 20, 40.
    let d = data("1\n0 2 3\n30 20 40\n");
    assert_eq!(d.dims(), 1);
    close(d.value(&[0.0]), 30.0);
    close(d.value(&[0.5]), 25.0);
    close(d.value(&[1.5]), 30.0);
    close(d.value(&[2.0]), 40.0);
    // One division past the end: linear from the last two points...
    close(d.value(&[2.5]), 50.0);
    close(d.value(&[3.0]), 60.0);
    // ...then (2*y1 - y0) / (x - (i - 1)) with i = 1: at x = 4, 60 / 4.
    close(d.value(&[4.0]), 15.0);
    close(d.value(&[11.0]), 60.0 / 11.0);
    // Below: linear for one division (x = -0.5: 30*1.5 - 20*0.5)...
    close(d.value(&[-0.5]), 35.0);
    close(d.value(&[-1.0]), 40.0);
    // ...then (2*y0 - y1) / (i - x): at x = -2, 40 / 2.
    close(d.value(&[-2.0]), 20.0);
    close(d.value(&[-4.0]), 10.0);
}

#[test]
fn two_dimensions_are_bilinear_with_the_last_dimension_fastest() {
    // First dimension 0..1 (2 points), second 0..2 (3 points):
    // rows [1 2 3] and [4 5 6].
    let d = data("2\n0 1 2\n0 2 3\n1 2 3\n4 5 6\n");
    assert_eq!(d.counts(), vec![2, 3]);
    close(d.value(&[0.0, 2.0]), 3.0);
    close(d.value(&[1.0, 0.0]), 4.0);
    close(d.value(&[0.5, 0.5]), 3.0);
    close(d.value(&[0.25, 1.5]), 2.5 * 0.75 + 5.5 * 0.25);
}

#[test]
fn three_dimensions_reproduce_a_trilinear_function() {
    // v(a, b, c) = a + 2b + 4c on the unit cube's corners, in any layout.
    let d = data("3 0 1 2 0 1 2\n0 1 2 # a comment between numbers\n 0 4 2 6 1 5 3 7");
    for &(a, b, c) in &[(0.3, 0.6, 0.9), (0.0, 1.0, 0.5), (1.0, 1.0, 1.0)] {
        close(d.value(&[a, b, c]), a + 2.0 * b + 4.0 * c);
    }
}

#[test]
fn uneven_spacing_finds_the_cell_by_search() {
    let d = data("1\n0 0 4  0 1 3 7\n0 10 20 100\n");
    close(d.value(&[0.5]), 5.0);
    close(d.value(&[2.0]), 15.0);
    close(d.value(&[5.0]), 60.0);
    close(d.value(&[7.0]), 100.0);
    // Past the end: x = 2 + (9 - 3)/4 = 3.5, linear; x = 6.25, tapered.
    close(d.value(&[9.0]), 140.0);
    close(d.value(&[20.0]), 180.0 / 5.25);
    // Below the start: x = -1 (linear), x = -3 (tapered).
    close(d.value(&[-1.0]), -10.0);
    close(d.value(&[-3.0]), -10.0 / 3.0);
}

#[test]
fn decreasing_coordinates_work_evenly_and_unevenly_spaced() {
    let even = data("1\n2 0 3\n10 20 40\n");
    close(even.value(&[2.0]), 10.0);
    close(even.value(&[1.5]), 15.0);
    close(even.value(&[0.0]), 40.0);
    assert_eq!(even.range(0), (2.0, 0.0));
    let uneven = data("1\n0 0 4\n3 2 1 0\n30 20 10 0\n");
    close(uneven.value(&[2.5]), 25.0);
    close(uneven.value(&[0.5]), 5.0);
    close(uneven.value(&[3.0]), 30.0);
    close(uneven.value(&[0.0]), 0.0);
    // Outside at the high-coordinate end (x = -1): 2*30 - 20.
    close(uneven.value(&[4.0]), 40.0);
}

#[test]
fn values_are_single_precision_as_in_radiance() {
    let d = data("1 0 1 2 0.1 0.2");
    assert_eq!(d.value(&[0.0]), f64::from(0.1f32));
}

#[test]
fn rect_fixture_has_its_header_dimensions_and_grid_values() {
    let Some(p) = shared("rect_fixture.dat") else {
        return;
    };
    let d = DataArray::load(&p, &here()).unwrap();
    assert_eq!(d.dims(), 2);
    assert_eq!(d.counts(), vec![3, 11]);
    assert_eq!(d.range(0), (0.0, 90.0));
    assert_eq!(d.range(1), (0.0, 90.0));
    let v = |x: f64| f64::from(x as f32);
    close(d.value(&[0.0, 0.0]), v(0.828120278));
    close(d.value(&[0.0, 36.0]), v(0.765891585));
    close(d.value(&[45.0, 9.0]), v(0.824638952));
    close(d.value(&[90.0, 90.0]), 0.0);
    close(d.value(&[90.0, 81.0]), v(0.0217582837));
    // Midway between four grid points: their mean.
    let mean = (v(0.828120278) + v(0.829425776) + v(0.828120278) + v(0.824638952)) / 4.0;
    close(d.value(&[22.5, 4.5]), mean);
    // Along the second axis only, between 9 and 18 degrees at 45.
    close(
        d.value(&[45.0, 12.0]),
        v(0.824638952) * (2.0 / 3.0) + v(0.806797161) / 3.0,
    );
}

#[test]
fn the_test_scenes_data_files_load_with_their_header_counts() {
    for (name, counts) in [
        ("tcutoff.dat", vec![10]),
        ("flower.dat", vec![10, 10]),
        ("glass_illR.dat", vec![8, 23]),
        ("glass_illG.dat", vec![8, 23]),
        ("glass_illB.dat", vec![8, 23]),
        ("sawtooth.dat", vec![16, 16, 16, 16]),
    ] {
        let Some(p) = shared(name) else {
            continue;
        };
        let d = DataArray::load(&p, &here()).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(d.counts(), counts, "{name}");
        assert_eq!(d.values().len(), counts.iter().product::<usize>());
    }
    if let Some(p) = shared("tcutoff.dat") {
        // 90 down to 0 in 10 points: 0 at 90 degrees, 10 at 0.
        let d = DataArray::load(&p, &here()).unwrap();
        assert_eq!(d.range(0), (90.0, 0.0));
        close(d.value(&[90.0]), 0.0);
        close(d.value(&[0.0]), 10.0);
        close(d.value(&[10.0]), 1.0);
        close(d.value(&[15.0]), 0.625);
    }
    if let Some(p) = shared("glass_illR.dat") {
        let d = DataArray::load(&p, &here()).unwrap();
        // The first coordinate as stored (single precision): the first value.
        close(
            d.value(&[f64::from(1.071429f32), 0.0]),
            f64::from(-1.825565e+01f32),
        );
    }
}

#[test]
fn a_missing_file_names_the_scene_line() {
    let e = DataArray::load(Path::new("/nonexistent/x.dat"), &here())
        .unwrap_err()
        .to_string();
    assert!(e.starts_with("scene.rad:7: cannot open data file"), "{e}");
}

#[test]
fn malformed_data_files_name_file_and_line() {
    let cases = [
        // Too few values: the end of the file, on its last line.
        ("1\n0 1 3\n1 2\n", "bad.dat:4: unexpected end of file"),
        ("1\n0 1 3\n1 2", "bad.dat:3: unexpected end of file"),
        // Garbage where a value belongs.
        ("1\n0 1 3\n1 two 3\n", "bad.dat:3: bad format"),
        ("2\n0 1 2\n0 1 x\n", "bad.dat:3: bad format"),
        ("1\n0 1 2.5\n1 2 3\n", "bad.dat:2: bad format"),
        ("\u{1}\n", "bad.dat:1: bad format"),
        ("", "bad.dat:1: unexpected end of file"),
        ("# only a comment\n", "bad.dat:2: unexpected end of file"),
        // Dimensions.
        ("0\n", "bad.dat:1: bad number of dimensions 0"),
        ("6\n", "bad.dat:1: bad number of dimensions 6"),
        ("-1\n", "bad.dat:1: bad number of dimensions -1"),
        ("1\n0 1 1\n5\n", "bad.dat:2: dimension 1 has 1 points"),
        // Huge counts are refused before anything is allocated.
        ("1\n0 1 99999999999\n", "bad.dat:2: bad format"),
        ("1\n0 1 2000000000\n1 2\n", "bad.dat:2: 2000000000 points"),
        (
            "5\n0 1 60000\n0 1 60000\n0 1 60000\n0 1 60000\n0 1 60000\n",
            "bad.dat:2: 60000 points in dimension 1",
        ),
        // Unevenly spaced points must be monotonic.
        (
            "1\n0 0 3\n0 2 1\n1 2 3\n",
            "bad.dat:3: bad format: coordinates",
        ),
        // Radiance's word buffer holds 63 characters.
        (
            &format!("1\n0 1 2\n1 {}\n", "1".repeat(64)),
            "bad.dat:3: bad format",
        ),
    ];
    for (text, want) in cases {
        let e = parse_err(text);
        assert!(e.starts_with(want), "{text:?}: {e}");
    }
}

#[test]
fn numbers_follow_radiances_float_syntax() {
    for ok in ["1", "-1", "+.5", "5.", "1e3", "1.5E-3", "-.5e+2"] {
        assert!(is_flt(ok.as_bytes()), "{ok}");
    }
    for bad in [
        ".", "-", "e5", "1e", "1e+", "inf", "nan", "0x10", "1.2.3", "1e5.0",
    ] {
        assert!(!is_flt(bad.as_bytes()), "{bad}");
    }
    assert!(is_int(b"-12") && is_int(b"+3") && !is_int(b"3.") && !is_int(b"+"));
    // A comment may start right after a word.
    let d = data("1#dims\n0 1 2#range\n4 6#values");
    close(d.value(&[0.5]), 5.0);
}

/// A picture written by hand: 3 wide, 2 high, flat scanlines, top first.
fn tiny_picture(extra_header: &str) -> (Vec<u8>, [[u8; 4]; 6]) {
    let top = [[128, 0, 0, 129], [0, 128, 0, 129], [0, 0, 128, 129]];
    let bottom = [[64, 64, 64, 129], [128, 128, 128, 130], [255, 0, 0, 128]];
    let mut b =
        format!("#?RADIANCE\n{extra_header}FORMAT=32-bit_rle_rgbe\n\n-Y 2 +X 3\n").into_bytes();
    for p in top.iter().chain(&bottom) {
        b.extend_from_slice(p);
    }
    let px = [top[0], top[1], top[2], bottom[0], bottom[1], bottom[2]];
    (b, px)
}

fn rgb(p: [u8; 4]) -> [f64; 3] {
    let c = from_rgbe(p);
    [c.x, c.y, c.z]
}

fn close3(a: [f64; 3], b: [f64; 3]) {
    for k in 0..3 {
        close(a[k], b[k]);
    }
}

#[test]
fn a_picture_spans_its_aspect_with_the_origin_at_the_lower_left() {
    let (bytes, px) = tiny_picture("");
    let p = PictureData::parse(&bytes, Path::new("t.hdr")).unwrap();
    assert_eq!(p.resolution(), (3, 2));
    // Wider than high: v in [0, 1], u in [0, 3/2].
    let (umax, vmax) = p.extent();
    close(umax, 1.5);
    close(vmax, 1.0);
    close(p.aspect(), 1.5);
    let [t0, t1, t2, b0, b1, b2] = px.map(rgb);
    close3(p.value(0.0, 0.0), b0);
    close3(p.value(0.75, 0.0), b1);
    close3(p.value(1.5, 0.0), b2);
    close3(p.value(0.0, 1.0), t0);
    close3(p.value(1.5, 1.0), t2);
    // Halfway between the first two columns and the two rows.
    let mid: [f64; 3] = std::array::from_fn(|k| (t0[k] + t1[k] + b0[k] + b1[k]) / 4.0);
    close3(p.value(0.375, 0.5), mid);
}

#[test]
fn pixel_aspect_stretches_the_picture_coordinates() {
    // PIXASPECT 2 (pixels twice as high as wide): 3 <= 2*2, so u spans
    // [0, 1] and v [0, 2*2/3].
    let (bytes, px) = tiny_picture("PIXASPECT=2\n");
    let p = PictureData::parse(&bytes, Path::new("t.hdr")).unwrap();
    let (umax, vmax) = p.extent();
    close(umax, 1.0);
    close(vmax, f64::from((2.0f64 * 2.0 / 3.0) as f32));
    close3(p.value(1.0, vmax), rgb(px[2]));
}

#[test]
fn malformed_pictures_are_refused_without_panicking() {
    let (good, _) = tiny_picture("");
    let cases: Vec<(Vec<u8>, &str)> = vec![
        (b"not a picture".to_vec(), "no #? magic"),
        (good[..good.len() - 3].to_vec(), "bad picture file"),
        (
            b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 100000 +X 100000\n".to_vec(),
            "more than the file",
        ),
        (
            b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 1 +X 2\n\x80\x80\x80\x80\x80\x80\x80\x80"
                .to_vec(),
            "at least 2x2",
        ),
        (
            {
                let (b, _) = tiny_picture("PIXASPECT=0\n");
                b
            },
            "pixel aspect",
        ),
    ];
    for (bytes, want) in cases {
        let e = PictureData::parse(&bytes, Path::new("bad.hdr"))
            .expect_err("refused")
            .to_string();
        assert!(e.starts_with("bad.hdr: bad picture file"), "{e}");
        assert!(e.contains(want), "{e}");
    }
    let e = PictureData::load(Path::new("/nonexistent.hdr"), &here())
        .unwrap_err()
        .to_string();
    assert!(
        e.starts_with("scene.rad:7: cannot open picture file"),
        "{e}"
    );
}

#[test]
fn flower_hdr_loads_as_a_square_picture() {
    let Some(path) = shared("flower.hdr") else {
        return;
    };
    let p = PictureData::load(&path, &here()).unwrap();
    assert_eq!(p.resolution(), (525, 525));
    assert_eq!(p.extent(), (1.0, 1.0));
    // The lower-left sample is the last scanline's first pixel.
    let bytes = std::fs::read(&path).unwrap();
    let img = read_hdr(&mut &bytes[..]).unwrap();
    let ll = img.film.get(0, 524);
    close3(p.value(0.0, 0.0), [ll.x, ll.y, ll.z]);
    let ur = img.film.get(524, 0);
    close3(p.value(1.0, 1.0), [ur.x, ur.y, ur.z]);
    // flower.dat is the picture filtered down to 10x10 (grey), so the
    // picture and the data file should roughly agree in the middle.
    if let Some(dat) = shared("flower.dat") {
        let d = DataArray::load(&dat, &here()).unwrap();
        assert!(d.values().iter().all(|v| v.is_finite()));
    }
}

/// Text built from words a data file could contain, so random inputs often
/// get past the header.
fn data_like() -> impl Strategy<Value = String> {
    let word = prop_oneof![
        Just("1".to_string()),
        Just("2".to_string()),
        Just("3".to_string()),
        Just("0".to_string()),
        Just("-1".to_string()),
        Just("0.5".to_string()),
        Just("1e3".to_string()),
        Just("#".to_string()),
        Just("\n".to_string()),
        Just("x".to_string()),
        (-5i32..5).prop_map(|v| v.to_string()),
        any::<f32>().prop_map(|v| v.to_string()),
    ];
    prop::collection::vec(word, 0..40).prop_map(|w| w.join(" "))
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    #[test]
    fn random_bytes_never_panic(bytes in prop::collection::vec(any::<u8>(), 0..200)) {
        let _ = DataArray::parse(&bytes, Path::new("r.dat"));
        let _ = PictureData::parse(&bytes, Path::new("r.hdr"));
        let mut pic = b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 2 +X 3\n".to_vec();
        pic.extend_from_slice(&bytes);
        if let Ok(p) = PictureData::parse(&pic, Path::new("r.hdr")) {
            let _ = p.value(0.3, -7.0);
        }
    }

    #[test]
    fn data_like_text_never_panics_and_evaluates_anywhere(
        text in data_like(),
        pt in prop::collection::vec(prop_oneof![any::<f64>(), -10.0f64..10.0], 5),
    ) {
        if let Ok(d) = DataArray::parse(text.as_bytes(), Path::new("r.dat")) {
            let _ = d.value(&pt[..d.dims()]);
        }
    }
}
