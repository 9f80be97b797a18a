//! Tests of fonts and text layout: glyph inside tests on a hand-made font
//! and on helvet.fnt, the three spacings, multi-line text, argument forms,
//! malformed fonts.

use super::*;
use proptest::prelude::*;

/// 'I' is the box x 100..150, y 50..200; ' ' a space. Mean width 50.
const BOX_FONT: &str = "# test font\n32 0\n73 4  100 50 150 50 150 200 100 200\n";

fn box_font() -> Arc<Font> {
    Arc::new(Font::parse(BOX_FONT.as_bytes(), Path::new("box.fnt")).unwrap())
}

fn here() -> SourceLoc {
    SourceLoc::new("scene.rad", 12)
}

/// Origin 0, one cell along +x, one line along -y: cell (a, b) is the
/// point (a, -b, 0).
fn flat(spacing: Option<f64>) -> Vec<f64> {
    let mut r = vec![0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, -1.0, 0.0];
    r.extend(spacing);
    r
}

fn layout(font: Arc<Font>, lines: &[&str], reals: &[f64]) -> TextLayout {
    let lines = lines.iter().map(|s| s.to_string()).collect();
    TextLayout::new(font, lines, reals, &here()).unwrap()
}

fn at(t: &TextLayout, a: f64, b: f64) -> bool {
    t.inside(DVec3::new(a, -b, 0.0))
}

use crate::testdata::radiance_test_file as shared;

#[test]
fn a_font_records_glyph_extents_from_128_and_its_mean_width() {
    let f = box_font();
    assert_eq!(f.glyph(b'I').unwrap().extent(), (100, 150, 50, 200));
    assert!(f.glyph(b' ').unwrap().is_space());
    assert_eq!(f.glyph(b' ').unwrap().extent(), (128, 128, 128, 128));
    assert!(f.glyph(b'A').is_none());
    assert_eq!(f.mean_width(), 50);
    assert_eq!(f.mean_height(), 150);
    // A glyph off to one side still reaches to 128.
    let g = Font::parse(b"65 3 10 10 20 10 20 20", Path::new("a.fnt")).unwrap();
    assert_eq!(g.glyph(b'A').unwrap().extent(), (10, 128, 10, 128));
}

#[test]
fn glyph_inside_test_is_even_odd() {
    let f = box_font();
    let i = f.glyph(b'I').unwrap();
    assert!(i.contains(127.5, 127.5));
    assert!(i.contains(100.2, 50.2));
    assert!(!i.contains(80.0, 127.0));
    assert!(!i.contains(127.0, 210.0));
    assert!(!i.contains(160.0, 100.0));
    assert!(!f.glyph(b' ').unwrap().contains(128.0, 128.0));
}

#[test]
fn helvet_i_and_o_are_inside_where_drawn() {
    let Some(p) = shared("lib/helvet.fnt") else {
        return;
    };
    let f = Font::load(&p, &here()).unwrap();
    let i = f.glyph(b'I').unwrap();
    assert_eq!(i.extent(), (102, 153, 48, 222));
    assert!(i.contains(127.5, 127.5));
    assert!(!i.contains(80.0, 127.0));
    assert!(!i.contains(127.5, 230.0));
    let o = f.glyph(b'O').unwrap();
    assert!(!o.contains(127.5, 135.5), "the O's hole");
    assert!(o.contains(30.5, 135.5), "the O's left side");
    assert!(o.contains(127.5, 60.5), "the O's bottom");
    assert!(!o.contains(127.5, 20.0));
    assert!(!o.contains(250.0, 135.0));
    assert!(f.mean_width() > 50 && f.mean_width() < 255);
    // "IO", one cell each: the I's stem, the O's hole and ring.
    let t = layout(Arc::new(f), &["IO"], &flat(None));
    assert!(at(&t, 0.5, 0.5));
    assert!(!at(&t, 0.2, 0.5));
    assert!(!at(&t, 1.5, 1.0 - 135.5 / 255.0));
    assert!(at(&t, 1.0 + 30.5 / 255.0, 1.0 - 135.5 / 255.0));
    assert!(!at(&t, 2.5, 0.5));
}

#[test]
fn uniform_spacing_gives_each_character_a_cell_and_each_line_a_row() {
    let t = layout(box_font(), &["I", "II", "I I"], &flat(None));
    assert_eq!(t.num_lines(), 3);
    assert_eq!(t.line_width(0), Some(255));
    assert_eq!(t.line_width(1), Some(510));
    assert_eq!(t.line_width(2), Some(765));
    assert!(at(&t, 0.5, 0.5));
    assert!(!at(&t, 1.5, 0.5), "past the end of line 0");
    assert!(at(&t, 1.5, 1.5));
    assert!(at(&t, 2.5, 2.5));
    assert!(!at(&t, 1.5, 2.5), "the space");
    assert!(!at(&t, 0.5, 3.5), "no fourth line");
    assert!(!at(&t, -0.1, 0.5) && !at(&t, 0.5, -0.1));
    // Glyph y runs up from the bottom of the line: near the line's top
    // and bottom is outside the box (50..200).
    assert!(at(&t, 0.5, 0.3));
    assert!(!at(&t, 0.5, 0.1));
    assert!(!at(&t, 0.5, 0.85));
}

#[test]
fn placement_uses_the_right_and_down_vectors_as_a_basis() {
    let o = DVec3::new(1.0, 1.0, 1.0);
    let (r, d) = (DVec3::new(2.0, 0.0, 0.0), DVec3::new(1.0, -3.0, 0.0));
    let reals = [o.x, o.y, o.z, r.x, r.y, r.z, d.x, d.y, d.z];
    let t = layout(box_font(), &["II"], &reals);
    let p = |a: f64, b: f64| o + a * r + b * d;
    let (a, b) = t.text_coords(p(1.25, 0.75) + DVec3::new(0.0, 0.0, 5.0));
    assert!((a - 1.25).abs() < 1e-12 && (b - 0.75).abs() < 1e-12);
    assert!(t.inside(p(1.5, 0.5)));
    assert!(!t.inside(p(1.2, 0.5)));
    assert!(t.inside(p(0.5, 0.5)));
}

#[test]
fn negative_spacing_squeezes_glyph_boxes_together() {
    // cis = 51: boxes 51 apart, 25 before the first and after the last;
    // spacing [-50, 100, 200], cell = mwidth + 51 = 101 units.
    let t = layout(box_font(), &["II"], &flat(Some(-0.2)));
    assert_eq!(t.line_width(0), Some(250));
    assert!(at(&t, 0.7, 0.5));
    assert!(!at(&t, 0.3, 0.5));
    assert!(at(&t, 1.7, 0.5));
    assert!(!at(&t, 1.2, 0.5));
    assert!(!at(&t, 2.6, 0.5), "past the line's width");
    // A space is mwidth wide: [-50, 175, -25, 200].
    let s = layout(box_font(), &["I I"], &flat(Some(-0.2)));
    assert_eq!(s.line_width(0), Some(300));
}

#[test]
fn positive_spacing_stretches_runs_to_average_cells() {
    // Squeezed [-50, 100, 200] stretched to 2 * (50 + 51): [-50, 51, 151].
    let t = layout(box_font(), &["II"], &flat(Some(0.2)));
    assert_eq!(t.line_width(0), Some(152));
    assert!(at(&t, 0.7, 0.5));
    assert!(at(&t, 1.3, 0.5));
    assert!(!at(&t, 1.52, 0.5));
    // A zero spacing real is uniform spacing but 50 units per cell.
    let z = layout(box_font(), &["II"], &flat(Some(0.0)));
    assert_eq!(z.line_width(0), Some(510));
    assert!(at(&z, 2.5, 0.5));
}

#[test]
fn text_arguments_split_as_text_c_reads_them() {
    let s = |v: &[&str]| v.iter().map(|s| s.to_string()).collect::<Vec<_>>();
    // patterns.mat: colortext with an inline word and a squeeze.
    let reals = [
        -5.6, 0.75, 0.5, 0.0, 0.08, 0.0, 0.2, 0.0, 0.0, 1.0, 0.1, 0.1, 0.1, 0.1, 1.0, -0.2,
    ];
    let a = split_text_args(
        TextKind::Color,
        &s(&["helvet.fnt", ".", "Color"]),
        &reals,
        &here(),
    )
    .unwrap();
    assert_eq!(a.font, "helvet.fnt");
    assert_eq!(a.text, TextSource::Inline("Color".into()));
    assert_eq!(a.placement, [&reals[..9], &[-0.2]].concat());
    assert_eq!(a.fore, vec![1.0, 0.1, 0.1]);
    assert_eq!(a.back, vec![0.1, 0.1, 1.0]);
    // brighttext from a file, with proportional spacing.
    let reals = [
        -4.2, 2.3, 0.5, 0.0, 0.025, 0.0, 0.07, 0.0, 0.0, 1.0, 0.01, 0.15,
    ];
    let a = split_text_args(
        TextKind::Bright,
        &s(&["helvet.fnt", "test.txt"]),
        &reals,
        &here(),
    )
    .unwrap();
    assert_eq!(a.text, TextSource::File("test.txt".into()));
    assert_eq!((a.fore.clone(), a.back.clone()), (vec![1.0], vec![0.01]));
    assert_eq!(a.placement.len(), 10);
    // ballcompare.rad: mixtext.
    let reals = [-4.0, 1.05, 2.05, 0.0, 0.05, 0.0, 0.0, 0.0, -0.1, -0.2];
    let strings = s(&["black_shiny", "void", "helvet.fnt", ".", "plastic2"]);
    let a = split_text_args(TextKind::Mix, &strings, &reals, &here()).unwrap();
    assert_eq!(a.modifiers, Some(("black_shiny".into(), "void".into())));
    assert_eq!(a.text, TextSource::Inline("plastic2".into()));
    assert_eq!(a.placement, reals.to_vec());
    assert!(a.fore.is_empty());
    // Several words are one line; too few reals or strings are errors.
    let a = split_text_args(
        TextKind::Mix,
        &s(&["a", "b", "f", ".", "two", "words"]),
        &reals[..9],
        &here(),
    )
    .unwrap();
    assert_eq!(a.text, TextSource::Inline("two words".into()));
    assert_eq!(a.placement.len(), 9);
    let e = split_text_args(TextKind::Bright, &s(&["f", "."]), &reals, &here()).unwrap_err();
    assert!(
        e.to_string().starts_with("scene.rad:12: bad # arguments"),
        "{e}"
    );
    assert!(split_text_args(TextKind::Mix, &s(&["a", "b", "f"]), &reals, &here()).is_err());
}

#[test]
fn text_files_read_as_fgets_does() {
    let dir = std::env::temp_dir().join(format!("hybrid-rt-font-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join("long.txt");
    std::fs::write(&p, format!("ab\r\n\n{}\nlast", "x".repeat(600))).unwrap();
    let lines = read_text_file(&p, &here()).unwrap();
    assert_eq!(lines.len(), 5);
    assert_eq!(lines[0], "ab\r");
    assert_eq!(lines[1], "");
    assert_eq!(lines[2].len(), 511);
    assert_eq!(lines[3].len(), 89);
    assert_eq!(lines[4], "last");
    std::fs::remove_dir_all(&dir).ok();
    let e = read_text_file(Path::new("/nonexistent.txt"), &here()).unwrap_err();
    assert!(e
        .to_string()
        .starts_with("scene.rad:12: cannot open text file"));
}

#[test]
fn the_test_scenes_text_file_lays_out_in_helvet() {
    let (Some(fnt), Some(txt)) = (shared("lib/helvet.fnt"), shared("test.txt")) else {
        return;
    };
    let font = Arc::new(Font::load(&fnt, &here()).unwrap());
    let lines = read_text_file(&txt, &here()).unwrap();
    assert_eq!(lines[0], "A silly  little");
    assert_eq!(lines.len(), 5);
    for spacing in [None, Some(0.15), Some(-0.2)] {
        let t = TextLayout::new(font.clone(), lines.clone(), &flat(spacing), &here()).unwrap();
        assert_eq!(t.num_lines(), 5);
        for (n, line) in lines.iter().enumerate() {
            let w = t.line_width(n).unwrap();
            assert!(w > 0, "{spacing:?} line {n}: width {w}");
            // Some of each line is ink, and nothing past its width is.
            let cells = w as f64 / t.cell;
            let hits = (0..400)
                .filter(|k| at(&t, cells * (*k as f64 + 0.5) / 400.0, n as f64 + 0.5))
                .count();
            assert!(hits > 0, "{spacing:?} {line:?}");
            assert!(!at(&t, cells + 0.01, n as f64 + 0.5));
        }
    }
}

#[test]
fn placement_errors_name_the_primitive() {
    let e = TextLayout::new(box_font(), vec!["I".into()], &[0.0; 8], &here()).unwrap_err();
    assert!(
        e.to_string().starts_with("scene.rad:12: bad # arguments"),
        "{e}"
    );
    // Right parallel to down.
    let reals = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 2.0, 0.0, 0.0];
    let e = TextLayout::new(box_font(), vec!["I".into()], &reals, &here()).unwrap_err();
    assert_eq!(e.to_string(), "scene.rad:12: illegal motion vector");
    let mut reals = flat(None);
    reals[4] = f64::NAN;
    assert!(TextLayout::new(box_font(), vec![], &reals, &here()).is_err());
}

#[test]
fn malformed_fonts_name_file_and_line() {
    let cases = [
        ("65 3 0 0 1\n", "bad.fnt:2: bad vertex for character (65)"),
        ("65 1 0 256\n", "bad.fnt:1: bad vertex for character (65)"),
        ("65 1\n0 -1\n", "bad.fnt:2: bad vertex for character (65)"),
        ("\n\n300 0\n", "bad.fnt:3: illegal character (300)"),
        ("0 0\n", "bad.fnt:1: illegal character (0)"),
        (
            "65 0\n# again\n65 0\n",
            "bad.fnt:3: duplicate character (65)",
        ),
        ("65 x\n", "bad.fnt:1: bad # vertices for character (65)"),
        ("65 40000\n", "bad.fnt:1: bad # vertices for character (65)"),
        ("65", "bad.fnt:1: bad # vertices for character (65)"),
        ("x 0\n", "bad.fnt:1: non-integer"),
        ("65 1 1.5 2\n", "bad.fnt:1: bad vertex"),
        ("99999999999 0\n", "bad.fnt:1: non-integer"),
    ];
    for (text, want) in cases {
        let e = Font::parse(text.as_bytes(), Path::new("bad.fnt"))
            .unwrap_err()
            .to_string();
        assert!(e.starts_with(want), "{text:?}: {e}");
    }
    let e = Font::load(Path::new("/nonexistent.fnt"), &here()).unwrap_err();
    assert!(e
        .to_string()
        .starts_with("scene.rad:12: cannot open font file"));
    // An empty font is a font without glyphs.
    let f = Font::parse(b"# nothing\n", Path::new("e.fnt")).unwrap();
    assert_eq!(f.mean_width(), 0);
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    #[test]
    fn random_font_bytes_never_panic(bytes in prop::collection::vec(any::<u8>(), 0..200)) {
        let _ = Font::parse(&bytes, Path::new("r.fnt"));
        // Mostly numbers, so some parse and get laid out.
        let text: String = bytes.iter().map(|b| match b % 6 {
            0 => ' ',
            1 => '\n',
            _ => char::from(b'0' + b % 10),
        }).collect();
        if let Ok(f) = Font::parse(text.as_bytes(), Path::new("r.fnt")) {
            let line = String::from_utf8_lossy(&bytes).into_owned();
            for s in [None, Some(-0.3), Some(0.4)] {
                let t = TextLayout::new(Arc::new(f.clone()), vec![line.clone()], &flat(s), &here()).unwrap();
                for k in 0..20 {
                    let _ = at(&t, f64::from(k) * 0.37, 0.5);
                }
            }
        }
    }

    #[test]
    fn any_text_spacing_and_point_never_panics(
        line in "[I A\u{0}é]{0,12}",
        spacing in prop::option::of(-5.0f64..5.0),
        a in -3.0f64..20.0,
        b in -1.0f64..3.0,
    ) {
        let t = layout(box_font(), &[&line, "I"], &flat(spacing));
        let _ = at(&t, a, b);
        let _ = t.inside(DVec3::new(f64::MAX, f64::MIN, 0.0));
    }
}
