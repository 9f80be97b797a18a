//! Tests of the binary Radiance readers: the portable encodings, compiled
//! meshes (`.rtm`: the real `woman.rtm` and hand-written ones) and octrees
//! (hand-written after `writeoct.c`, normal and frozen), and that no input
//! makes them panic or hang.

use std::path::{Path, PathBuf};

use glam::DVec3;
use proptest::prelude::*;

use super::octfile::{parse_octree, read_octree, OctreeContents, OCT_MAGIC};
use super::rad::RawPrim;
use super::radbin::{decode_dir, encode_dir};
use super::radbin::{frexp, put_flt, put_int, put_scene, put_str, BinReader};
use super::rtm::{parse_rtm, read_rtm, RtmMesh, MESH_MAGIC};
use crate::{Error, SourceLoc};

fn woman_rtm() -> PathBuf {
    crate::testdata::radiance_tests_dir().join("woman.rtm")
}

fn p() -> &'static Path {
    Path::new("test.bin")
}

/// The reason of a parse error on line 0 of `test.bin` (anything else fails).
fn reason(e: Error) -> String {
    match e {
        Error::Parse { loc, reason } => {
            assert_eq!(loc.line, 0, "{reason}");
            assert_eq!(loc.file, p());
            reason
        }
        e => panic!("expected a parse error, got {e}"),
    }
}

fn prim(modifier: &str, ptype: &str, id: &str, strs: &[&str], reals: &[f64]) -> RawPrim {
    RawPrim {
        modifier: modifier.into(),
        ptype: ptype.into(),
        id: id.into(),
        strs: strs.iter().map(|s| s.to_string()).collect(),
        ints: Vec::new(),
        reals: reals.to_vec(),
        loc: SourceLoc::new(p(), 0),
        post: None,
    }
}

// ---------------------------------------------------------------- encodings

#[test]
fn ints_are_big_endian_and_sign_extended() {
    let mut b = Vec::new();
    put_int(&mut b, 0x0143, 2);
    put_int(&mut b, -1, 1);
    put_int(&mut b, -2, 4);
    put_int(&mut b, 0x8000_0000, 4);
    assert_eq!(b, [0x01, 0x43, 0xff, 0xff, 0xff, 0xff, 0xfe, 0x80, 0, 0, 0]);
    let mut r = BinReader::new(&b, p());
    assert_eq!(r.int(2, "x").unwrap(), 323);
    assert_eq!(r.int(1, "x").unwrap(), -1);
    assert_eq!(r.int(4, "x").unwrap(), -2);
    // Stored as 4 bytes it reads back negative (getint sign-extends) ...
    let mut r2 = r.clone();
    assert_eq!(r2.int(4, "x").unwrap(), -0x8000_0000);
    // ... and as unsigned for vertex coordinates.
    assert_eq!(r.u32("x").unwrap(), 0x8000_0000);
    assert!(r.at_end());
    let e = reason(r.int(1, "the answer").unwrap_err());
    assert!(
        e.contains("truncated") && e.contains("the answer") && e.contains("byte 11"),
        "{e}"
    );
}

#[test]
fn floats_follow_putflt() {
    // 0.5 = frexp 0.5 * 2^0; 1 = 0.5 * 2^1; -3 = -0.75 * 2^2.
    let mut b = Vec::new();
    put_flt(&mut b, 1.0);
    assert_eq!(b, [0x3f, 0xff, 0xff, 0xff, 0x01]);
    b.clear();
    put_flt(&mut b, 0.0);
    assert_eq!(b, [0, 0, 0, 0, 0]);
    for &(f, tol) in &[
        (1.0, 1e-9),
        (-3.0, 1e-9),
        (0.0, 0.0),
        (1e-30, 1e-39),
        (123456.789, 1e-4),
    ] {
        let mut b = Vec::new();
        put_flt(&mut b, f);
        let g = BinReader::new(&b, p()).flt("x").unwrap();
        assert!((g - f).abs() <= tol, "{f} -> {g}");
    }
    // Overflow clamps, underflow flushes to zero (as Radiance writes).
    let mut b = Vec::new();
    put_flt(&mut b, 1e300);
    put_flt(&mut b, 1e-300);
    let mut r = BinReader::new(&b, p());
    let big = r.flt("x").unwrap();
    assert!(big > 1e38 && big < 2e38, "{big}");
    assert_eq!(r.flt("x").unwrap(), 0.0);
}

#[test]
fn frexp_matches_c() {
    assert_eq!(frexp(1.0), (0.5, 1));
    assert_eq!(frexp(-3.0), (-0.75, 2));
    assert_eq!(frexp(0.0), (0.0, 0));
    assert_eq!(frexp(0.75), (0.75, 0));
    let (m, e) = frexp(f64::MIN_POSITIVE / 4.0);
    assert_eq!((m, e), (0.5, -1023));
}

#[test]
fn strings_and_headers() {
    let mut b = b"#?RADIANCE\nsome command\nFORMAT=Radiance_tmesh\n\n".to_vec();
    put_str(&mut b, "hello");
    put_str(&mut b, "");
    b.extend_from_slice(b"abc");
    let mut r = BinReader::new(&b, p());
    assert_eq!(
        r.header("Radiance_tmesh").unwrap(),
        ["some command", "FORMAT=Radiance_tmesh"]
    );
    assert_eq!(r.str("s").unwrap(), "hello");
    assert_eq!(r.str("s").unwrap(), "");
    let e = reason(r.str("a name").unwrap_err());
    assert!(e.contains("NUL") && e.contains("a name"), "{e}");
    // Wrong format, no magic, no end.
    let e = reason(
        BinReader::new(&b, p())
            .header("Radiance_octree")
            .unwrap_err(),
    );
    assert!(
        e.contains("Radiance_tmesh") && e.contains("Radiance_octree"),
        "{e}"
    );
    let e = reason(
        BinReader::new(b"P6\n1 1\n", p())
            .header("Radiance_tmesh")
            .unwrap_err(),
    );
    assert!(e.contains("#?"), "{e}");
    let e = reason(
        BinReader::new(b"#?RADIANCE\nabc\n", p())
            .header("x")
            .unwrap_err(),
    );
    assert!(e.contains("header"), "{e}");
}

#[test]
fn direction_codes_round_trip() {
    let mut worst: f64 = 0.0;
    for i in 0..2000 {
        // A spread of directions over the sphere, every octant.
        let z = 1.0 - 2.0 * (i as f64 + 0.5) / 2000.0;
        let phi = i as f64 * 2.399963;
        let s = (1.0 - z * z).sqrt();
        let d = DVec3::new(s * phi.cos(), s * phi.sin(), z);
        let c = encode_dir(d);
        assert_ne!(c, 0);
        let back = decode_dir(c);
        assert!((back.length() - 1.0).abs() < 1e-12, "{back}");
        worst = worst.max(back.angle_between(d).to_degrees());
    }
    // dircode.c: "maximum error of 0.0058 degrees".
    assert!(worst < 0.006, "worst {worst} degrees");
    assert_eq!(decode_dir(0), DVec3::ZERO);
    for axis in [DVec3::X, DVec3::NEG_Y, DVec3::Z, DVec3::NEG_Z] {
        assert!(decode_dir(encode_dir(axis)).angle_between(axis) < 1e-3);
    }
}

#[test]
fn object_records_round_trip() {
    let objs = vec![
        prim("void", "plastic", "red", &[], &[0.5, 0.1, 0.1, 0.0, 0.0]),
        prim("void", "brightfunc", "dirt", &["dirt", "dirt.cal"], &[]),
        prim("dirt", "metal", "rusty", &[], &[0.3, 0.2, 0.1, 0.9, 0.05]),
        prim("rusty", "sphere", "ball", &[], &[0.0, -1.5, 2.0, 0.25]),
    ];
    for objsize in [1, 2, 4, 8] {
        let mut b = Vec::new();
        put_scene(&mut b, &objs, objsize);
        b.push(0x77); // trailing byte left unread
        let mut r = BinReader::new(&b, p());
        let back = r.scene(objsize).unwrap();
        assert_eq!(r.remaining(), 1);
        assert_eq!(back.len(), objs.len());
        for (a, o) in back.iter().zip(&objs) {
            assert_eq!(
                (&a.modifier, &a.ptype, &a.id),
                (&o.modifier, &o.ptype, &o.id)
            );
            assert_eq!(a.strs, o.strs);
            assert_eq!(a.loc, SourceLoc::new(p(), 0));
            for (x, y) in a.reals.iter().zip(&o.reals) {
                assert!((x - y).abs() < 1e-9, "{x} {y}");
            }
        }
    }
    // A modifier index past the objects, a type past the table.
    let mut b = Vec::new();
    put_str(&mut b, "plastic");
    put_str(&mut b, "");
    put_int(&mut b, 0, 1);
    put_int(&mut b, 5, 4);
    put_str(&mut b, "x");
    put_int(&mut b, 0, 2);
    put_int(&mut b, 0, 2);
    put_int(&mut b, -1, 1);
    let e = reason(BinReader::new(&b, p()).scene(4).unwrap_err());
    assert!(e.contains("modifier index 5"), "{e}");
    b[9] = 3; // the type index
    let e = reason(BinReader::new(&b, p()).scene(4).unwrap_err());
    assert!(e.contains("type index 3"), "{e}");
}

// ------------------------------------------------------------------- meshes

/// One vertex as stored: cube coordinates, normal code, (u,v) codes.
#[derive(Clone)]
struct V {
    xyz: [u32; 3],
    n: u32,
    uv: [u32; 2],
}

/// One patch as `putpatch` writes it.
#[derive(Clone, Default)]
struct Patch {
    flags: i64,
    verts: Vec<V>,
    tris: Vec<[u8; 3]>,
    /// One per triangle, or one for all (written as count 1).
    mats: Vec<i64>,
    j1: Vec<(i64, u8, u8, i64)>,
    j2: Vec<(i64, i64, u8, i64)>,
}

/// Writes a mesh the way `writemesh.c` does (with a trivial octree).
fn write_rtm(
    org: [f64; 3],
    size: f64,
    uvlim: [[f64; 2]; 2],
    mats: &[RawPrim],
    patches: &[Patch],
) -> Vec<u8> {
    let mut b = b"#?RADIANCE\nobj2mesh test\nFORMAT=Radiance_tmesh\n\n".to_vec();
    put_int(&mut b, MESH_MAGIC + 4, 2);
    for o in org {
        put_str(&mut b, &format!("{o}"));
    }
    put_str(&mut b, &format!("{size}"));
    for f in [uvlim[0][0], uvlim[1][0], uvlim[0][1], uvlim[1][1]] {
        put_flt(&mut b, f);
    }
    // Octree: a tree of one full leaf {2 triangles} and seven empties.
    b.push(2);
    b.push(1);
    put_int(&mut b, 2, 4);
    put_int(&mut b, 0, 4);
    put_int(&mut b, 1, 4);
    b.extend_from_slice(&[0; 7]);
    put_scene(&mut b, mats, 4);
    put_int(&mut b, patches.len() as i64, 4);
    for pp in patches {
        put_int(&mut b, pp.flags, 1);
        put_int(&mut b, pp.verts.len() as i64, 2);
        for v in &pp.verts {
            for c in v.xyz {
                put_int(&mut b, i64::from(c), 4);
            }
        }
        if pp.flags & 2 != 0 {
            for v in &pp.verts {
                put_int(&mut b, i64::from(v.n), 4);
            }
        }
        if pp.flags & 4 != 0 {
            for v in &pp.verts {
                put_int(&mut b, i64::from(v.uv[0]), 4);
                put_int(&mut b, i64::from(v.uv[1]), 4);
            }
        }
        put_int(&mut b, pp.tris.len() as i64, 2);
        for t in &pp.tris {
            b.extend_from_slice(t);
        }
        if pp.mats.len() > 1 {
            put_int(&mut b, pp.tris.len() as i64, 2);
            for &m in &pp.mats {
                put_int(&mut b, m, 2);
            }
        } else {
            put_int(&mut b, 1, 2);
            put_int(&mut b, pp.mats.first().copied().unwrap_or(-1), 2);
        }
        put_int(&mut b, pp.j1.len() as i64, 2);
        for &(v1, v2, v3, m) in &pp.j1 {
            put_int(&mut b, v1, 4);
            b.push(v2);
            b.push(v3);
            put_int(&mut b, m, 2);
        }
        put_int(&mut b, pp.j2.len() as i64, 2);
        for &(v1, v2, v3, m) in &pp.j2 {
            put_int(&mut b, v1, 4);
            put_int(&mut b, v2, 4);
            b.push(v3);
            put_int(&mut b, m, 2);
        }
    }
    b
}

/// Two patches with normals and (u,v) in the first, a joiner and a double
/// joiner, two materials (one modifying the other).
fn small_mesh() -> Vec<u8> {
    let v = |x: u32, y: u32, z: u32| V {
        xyz: [x, y, z],
        n: encode_dir(DVec3::Z),
        uv: [1 << 31, 1 << 30],
    };
    let p0 = Patch {
        flags: 7,
        verts: vec![
            v(0, 0, 0),
            v(1 << 31, 0, 0),
            v(0, 1 << 31, 0),
            V {
                n: 0,
                uv: [0, 0],
                ..v(u32::MAX, u32::MAX, u32::MAX)
            },
        ],
        tris: vec![[0, 1, 2], [1, 3, 2]],
        mats: vec![0, -1],
        ..Default::default()
    };
    let p1 = Patch {
        flags: 1,
        verts: vec![v(10, 20, 30), v(40, 50, 60)],
        tris: vec![],
        mats: vec![1],
        // (patch 0, vertex 3), then local 0 and 1.
        j1: vec![(3, 0, 1, 1)],
        j2: vec![(2, 1, 1, -1)],
    };
    let mats = vec![
        prim("void", "plastic", "skin", &[], &[0.8, 0.6, 0.5, 0.0, 0.0]),
        prim("skin", "plastic", "cloth", &[], &[0.2, 0.2, 0.6, 0.0, 0.1]),
    ];
    write_rtm(
        [-1.0, 2.0, 0.5],
        4.0,
        [[-1.0, 0.0], [1.0, 2.0]],
        &mats,
        &[p0, p1],
    )
}

#[test]
fn small_mesh_decodes() {
    let m = parse_rtm(&small_mesh(), p()).unwrap();
    assert_eq!(m.header, ["obj2mesh test", "FORMAT=Radiance_tmesh"]);
    assert_eq!(m.patches, 2);
    assert_eq!(m.materials.len(), 2);
    assert_eq!(
        (m.materials[0].modifier.as_str(), m.materials[0].id.as_str()),
        ("void", "skin")
    );
    assert_eq!(
        (m.materials[1].modifier.as_str(), m.materials[1].id.as_str()),
        ("skin", "cloth")
    );
    assert_eq!(m.vertices.len(), 6);
    let res = 4.0 / 4294967296.0;
    let v0 = m.vertices[0];
    assert_eq!(v0.p, DVec3::new(-1.0, 2.0, 0.5) + DVec3::splat(0.5 * res));
    assert_eq!(m.vertices[1].p.x, -1.0 + (2147483648.0 + 0.5) * res);
    assert!(m.vertices[3].p.cmplt(m.bounds.max).all());
    assert!(m.vertices[3]
        .p
        .cmpgt(m.bounds.max - DVec3::splat(1e-9))
        .all());
    assert!(v0.n.unwrap().angle_between(DVec3::Z) < 1e-3);
    // uv: lim0 + (lim1 - lim0) (c + .5) / 2^32.
    let uv = v0.uv.unwrap();
    assert!(
        (uv[0] - 0.0).abs() < 1e-9 && (uv[1] - 0.5).abs() < 1e-9,
        "{uv:?}"
    );
    // Vertex 3: zero codes mean no normal and no (u,v).
    assert_eq!((m.vertices[3].n, m.vertices[3].uv), (None, None));
    // Patch 1 has neither.
    assert_eq!((m.vertices[4].n, m.vertices[4].uv), (None, None));
    assert_eq!(
        m.vertices[4].p,
        DVec3::new(-1.0, 2.0, 0.5) + DVec3::new(10.5, 20.5, 30.5) * res
    );
    let t: Vec<([u32; 3], Option<u32>)> = m.triangles.iter().map(|t| (t.v, t.material)).collect();
    assert_eq!(
        t,
        [
            ([0, 1, 2], Some(0)),
            ([1, 3, 2], None),
            ([3, 4, 5], Some(1)),
            ([2, 1, 5], None),
        ]
    );
    assert_eq!(m.bounds.min, DVec3::new(-1.0, 2.0, 0.5));
    assert_eq!(m.bounds.max, DVec3::new(3.0, 6.0, 4.5));
    assert_eq!(m.uv_limits, [[-1.0, 0.0], [1.0, 2.0]]);
}

#[test]
fn sole_material_applies_to_all_local_triangles() {
    let v = |x| V {
        xyz: [x, 0, 0],
        n: 0,
        uv: [0, 0],
    };
    let pp = Patch {
        flags: 1,
        verts: vec![v(0), v(1), v(2), v(3)],
        tris: vec![[0, 1, 2], [1, 2, 3], [0, 2, 3]],
        mats: vec![0],
        ..Default::default()
    };
    let mats = vec![prim("void", "metal", "m", &[], &[1.0, 1.0, 1.0, 0.9, 0.0])];
    let m = parse_rtm(&write_rtm([0.0; 3], 1.0, [[0.0; 2]; 2], &mats, &[pp]), p()).unwrap();
    assert!(m.triangles.iter().all(|t| t.material == Some(0)));
    assert_eq!(m.triangles.len(), 3);
}

#[test]
fn bad_meshes_are_errors_with_reasons() {
    let good = small_mesh();
    let magic_at = good.windows(2).position(|w| w == b"\n\n").unwrap() + 2;
    let check = |b: &[u8], want: &str| {
        let e = reason(parse_rtm(b, p()).unwrap_err());
        assert!(e.contains(want), "expected '{want}' in: {e}");
    };
    // Wrong magic number (an octree's), wrong format, not Radiance at all.
    let mut b = good.clone();
    b[magic_at..magic_at + 2].copy_from_slice(&((OCT_MAGIC + 4) as u16).to_be_bytes());
    check(&b, "incompatible mesh format");
    let b = String::from_utf8_lossy(&good).replace("Radiance_tmesh", "Radiance_octree");
    check(b.as_bytes(), "wrong file format");
    check(b"\x89PNG\r\n", "#?");
    check(b"", "#?");
    // Every truncation is an error (no panic), most say so.
    for n in 0..good.len() {
        let e = reason(parse_rtm(&good[..n], p()).unwrap_err());
        assert!(
            e.contains("truncated") || e.contains("header") || e.contains("#?"),
            "at {n}: {e}"
        );
    }
    // A joiner naming a vertex that does not exist.
    let v = |x| V {
        xyz: [x, 0, 0],
        n: 0,
        uv: [0, 0],
    };
    let bad = |pp: Patch, mats: &[RawPrim]| write_rtm([0.0; 3], 1.0, [[0.0; 2]; 2], mats, &[pp]);
    let pp = Patch {
        flags: 1,
        verts: vec![v(0), v(1)],
        j1: vec![(7 << 8, 0, 1, -1)],
        ..Default::default()
    };
    check(&bad(pp, &[]), "names no vertex");
    let pp = Patch {
        flags: 1,
        verts: vec![v(0), v(1)],
        tris: vec![[0, 1, 2]],
        ..Default::default()
    };
    check(&bad(pp, &[]), "names no vertex");
    let pp = Patch {
        flags: 1,
        verts: vec![v(0), v(1), v(2)],
        tris: vec![[0, 1, 2]],
        mats: vec![3],
        ..Default::default()
    };
    check(&bad(pp, &[]), "material index 3");
    let pp = Patch {
        flags: 9,
        verts: vec![v(0)],
        ..Default::default()
    };
    check(&bad(pp, &[]), "bad patch flags");
    let pp = Patch {
        flags: 5,
        verts: vec![v(0)],
        ..Default::default()
    };
    check(&bad(pp, &[]), "(u,v) limits are empty");
    let pp = Patch {
        flags: 1,
        verts: vec![],
        ..Default::default()
    };
    let mut b = bad(pp, &[]);
    b.extend_from_slice(&[0; 32]); // room for the smallest patch
    check(&b, "number of patch vertices 0");
    // A damaged octree node.
    let mut b = good.clone();
    let tree_at = good.windows(4).position(|w| w == [2, 1, 0, 0]).unwrap();
    b[tree_at] = 9;
    check(&b, "damaged mesh octree");
}

#[test]
fn unreadable_mesh_names_where_it_was_named() {
    let from = SourceLoc::new("scene.rad", 12);
    match read_rtm(Path::new("/nonexistent/x.rtm"), Some(&from)).unwrap_err() {
        Error::Parse { loc, reason } => {
            assert_eq!(loc, from);
            assert!(reason.contains("/nonexistent/x.rtm"), "{reason}");
        }
        e => panic!("{e}"),
    }
    assert!(matches!(
        read_rtm(Path::new("/nonexistent/x.rtm"), None),
        Err(Error::Io { .. })
    ));
}

fn load_woman() -> Option<RtmMesh> {
    let path = woman_rtm();
    if !path.exists() {
        eprintln!("skipping: {} not found", path.display());
        return None;
    }
    Some(read_rtm(&path, None).unwrap())
}

#[test]
fn woman_rtm_reads() {
    let Some(m) = load_woman() else { return };
    let nv = m.vertices.len();
    let with_n = m.vertices.iter().filter(|v| v.n.is_some()).count();
    let with_uv = m.vertices.iter().filter(|v| v.uv.is_some()).count();
    let mut per_mat = vec![0usize; m.materials.len()];
    let mut no_mat = 0;
    for t in &m.triangles {
        match t.material {
            Some(k) => per_mat[k as usize] += 1,
            None => no_mat += 1,
        }
    }
    let tight = crate::geometry::Aabb::from_points(m.vertices.iter().map(|v| v.p));
    println!("woman.rtm: header {:?}", m.header);
    println!(
        "woman.rtm: {} patches, {nv} vertices ({with_n} with normals, {with_uv} with uv), {} triangles ({no_mat} without material)",
        m.patches,
        m.triangles.len()
    );
    println!(
        "woman.rtm: cube {:?} size {}, uv limits {:?}, vertex bounds {:?} .. {:?}",
        m.cube_origin, m.cube_size, m.uv_limits, tight.min, tight.max
    );
    for (o, n) in m.materials.iter().zip(&per_mat) {
        println!(
            "woman.rtm: material {} {} {} strs {:?} reals {:?}: {n} triangles",
            o.modifier, o.ptype, o.id, o.strs, o.reals
        );
    }
    // Facts of this file (obj2mesh -a woman.mat).
    assert_eq!(
        m.header.last().map(String::as_str),
        Some("FORMAT=Radiance_tmesh")
    );
    assert_eq!(m.header[0], "obj2mesh -a woman.mat");
    assert_eq!(nv, WOMAN_VERTICES);
    assert_eq!(m.triangles.len(), WOMAN_TRIANGLES);
    let names: Vec<&str> = m.materials.iter().map(|o| o.id.as_str()).collect();
    assert_eq!(names, WOMAN_MATERIALS);
    // Every index in range, every material used, normals unit, vertices in
    // the cube.
    for t in &m.triangles {
        assert!(t.v.iter().all(|&k| (k as usize) < nv));
        assert!(
            t.v[0] != t.v[1] && t.v[1] != t.v[2] && t.v[0] != t.v[2],
            "{t:?}"
        );
    }
    // Aliases keep the referent in strs[0] (as rad.rs records them).
    let shoe4 = &m.materials[13];
    assert_eq!(
        (shoe4.modifier.as_str(), shoe4.ptype.as_str()),
        ("inherit", "alias")
    );
    assert_eq!(shoe4.strs, ["shoe:3"]);
    let types: Vec<&str> = m.materials.iter().map(|o| o.ptype.as_str()).collect();
    assert_eq!(types.iter().filter(|t| **t == "plastic").count(), 16);
    assert_eq!(types.iter().filter(|t| **t == "alias").count(), 5);
    assert!(m
        .materials
        .iter()
        .all(|o| o.ptype == "alias" || o.modifier == "void"));
    assert!(m
        .materials
        .iter()
        .all(|o| o.ptype != "plastic" || o.reals.len() == 5));
    // Most materials are used (iris:1 and pupil:1 are not).
    assert_eq!(
        per_mat.iter().filter(|&&n| n == 0).count(),
        2,
        "{per_mat:?}"
    );
    for v in &m.vertices {
        if let Some(n) = v.n {
            assert!((n.length() - 1.0).abs() < 1e-9, "{n}");
        }
        assert!(
            v.p.cmpge(m.bounds.min).all() && v.p.cmplt(m.bounds.max).all(),
            "{}",
            v.p
        );
    }
    // Vertex order agrees with the normals (decoding and joiner vertex
    // order): the face normal points the way of the vertex normals for
    // nearly every triangle.
    let mut agree = 0;
    for t in &m.triangles {
        let [a, b, c] = t.v.map(|k| m.vertices[k as usize]);
        let face = (b.p - a.p).cross(c.p - a.p);
        let n = a.n.unwrap() + b.n.unwrap() + c.n.unwrap();
        if face.dot(n) > 0.0 {
            agree += 1;
        }
    }
    println!(
        "woman.rtm: {agree} of {} triangles wind with their vertex normals",
        m.triangles.len()
    );
    assert!(agree as f64 > 0.97 * m.triangles.len() as f64, "{agree}");
    // (u,v) within the limits.
    let [lo, hi] = m.uv_limits;
    for v in &m.vertices {
        let uv = v.uv.unwrap();
        assert!((0..2).all(|i| uv[i] > lo[i] && uv[i] < hi[i]), "{uv:?}");
    }
    // Every vertex is used.
    let mut used = vec![false; nv];
    for t in &m.triangles {
        for k in t.v {
            used[k as usize] = true;
        }
    }
    println!(
        "woman.rtm: {} vertices unused",
        used.iter().filter(|u| !**u).count()
    );
    // The cube is tight around the model on at least one axis.
    assert!((tight.max - tight.min).max_element() > 0.9 * m.cube_size);
}

// Facts of the file as read (printed by woman_rtm_reads).
const WOMAN_VERTICES: usize = 25075;
const WOMAN_TRIANGLES: usize = 43210;
const WOMAN_MATERIALS: &[&str] = &[
    "band:2",
    "cloth:2",
    "eyeBrow:1",
    "eyeball:1",
    "fingerNails:1",
    "hair",
    "innerMouth:1",
    "iris:1",
    "lashes:1",
    "lips:1",
    "pupil:1",
    "shirt:5",
    "shoe:3",
    "shoe:4",
    "skin:1",
    "nipple:1",
    "sole:3",
    "sole:4",
    "teeth:1",
    "toenail:1",
    "tongue:1",
];

#[test]
fn woman_rtm_truncations_are_errors() {
    let path = woman_rtm();
    let Ok(data) = std::fs::read(&path) else {
        return;
    };
    for n in [
        0,
        10,
        60,
        100,
        1000,
        5000,
        data.len() / 3,
        data.len() / 2,
        data.len() - 1,
    ] {
        let e = reason(parse_rtm(&data[..n], p()).unwrap_err());
        assert!(
            e.contains("truncated") || e.contains("header") || e.contains("#?"),
            "at {n}: {e}"
        );
    }
}

// ----------------------------------------------------------------- octrees

fn oct_head(objsize: usize) -> Vec<u8> {
    let mut b = b"#?RADIANCE\noconv test.rad\nFORMAT=Radiance_octree\n\n".to_vec();
    put_int(&mut b, OCT_MAGIC + objsize as i64, 2);
    for s in ["-1", "-2.5", "0", "10"] {
        put_str(&mut b, s);
    }
    b
}

/// A normal octree listing two scene files and 3 objects, as `writeoct`
/// writes it (objsize 4).
fn normal_octree() -> Vec<u8> {
    let mut b = oct_head(4);
    put_str(&mut b, "materials.rad");
    put_str(&mut b, "!xform -t 1 0 0 room.rad");
    put_str(&mut b, "");
    put_int(&mut b, 3, 4);
    // Tree: one subdivided node, second child a full set {1, 2}, one of
    // its children subdivided again with a full set {0}.
    b.push(2);
    b.push(0);
    b.push(1);
    put_int(&mut b, 2, 4);
    put_int(&mut b, 1, 4);
    put_int(&mut b, 2, 4);
    b.push(2);
    b.push(1);
    put_int(&mut b, 1, 4);
    put_int(&mut b, 0, 4);
    b.extend_from_slice(&[0; 7]);
    b.extend_from_slice(&[0; 5]);
    b
}

fn frozen_objects() -> Vec<RawPrim> {
    vec![
        prim("void", "plastic", "white", &[], &[0.7, 0.7, 0.7, 0.0, 0.0]),
        prim("void", "light", "bright", &[], &[100.0, 100.0, 100.0]),
        prim("white", "sphere", "ball", &[], &[0.0, 0.0, 1.0, 0.5]),
        prim(
            "bright",
            "polygon",
            "lamp",
            &[],
            &[0., 0., 3., 1., 0., 3., 1., 1., 3.],
        ),
        prim("white", "mesh", "statue", &["woman.rtm", "-s", "2"], &[]),
    ]
}

/// A frozen octree (`oconv -f`): no file names, the objects after the tree.
fn frozen_octree(objsize: usize) -> Vec<u8> {
    let objs = frozen_objects();
    let mut b = oct_head(objsize);
    put_str(&mut b, "");
    put_int(&mut b, objs.len() as i64, objsize);
    b.push(1);
    put_int(&mut b, 3, objsize);
    for k in [2, 3, 4] {
        put_int(&mut b, k, objsize);
    }
    put_scene(&mut b, &objs, objsize);
    b
}

#[test]
fn normal_octree_lists_its_files() {
    let o = parse_octree(&normal_octree(), p()).unwrap();
    assert_eq!(o.header, ["oconv test.rad", "FORMAT=Radiance_octree"]);
    assert_eq!(o.cube_origin, DVec3::new(-1.0, -2.5, 0.0));
    assert_eq!(o.cube_size, 10.0);
    assert_eq!(o.objects, 3);
    assert_eq!(
        o.contents,
        OctreeContents::Files(vec![
            "materials.rad".into(),
            "!xform -t 1 0 0 room.rad".into()
        ])
    );
}

#[test]
fn frozen_octree_stores_its_objects() {
    for objsize in [4, 8] {
        let o = parse_octree(&frozen_octree(objsize), p()).unwrap();
        assert_eq!(o.objects, 5);
        let OctreeContents::Frozen(objs) = o.contents else {
            panic!("not frozen")
        };
        let want = frozen_objects();
        assert_eq!(objs.len(), want.len());
        for (a, w) in objs.iter().zip(&want) {
            assert_eq!(
                (&a.modifier, &a.ptype, &a.id, &a.strs),
                (&w.modifier, &w.ptype, &w.id, &w.strs)
            );
            assert_eq!(a.reals.len(), w.reals.len());
            for (x, y) in a.reals.iter().zip(&w.reals) {
                assert!((x - y).abs() <= 1e-9 * y.abs().max(1.0));
            }
            assert_eq!(a.loc, SourceLoc::new(p(), 0));
        }
    }
}

#[test]
fn bad_octrees_are_errors_with_reasons() {
    let check = |b: &[u8], want: &str| {
        let e = reason(parse_octree(b, p()).unwrap_err());
        assert!(e.contains(want), "expected '{want}' in: {e}");
    };
    for good in [normal_octree(), frozen_octree(4)] {
        for n in 0..good.len() {
            let e = reason(parse_octree(&good[..n], p()).unwrap_err());
            assert!(
                e.contains("truncated") || e.contains("header") || e.contains("#?"),
                "at {n}: {e}"
            );
        }
    }
    // A mesh is not an octree.
    check(&small_mesh(), "wrong file format");
    let mut b = normal_octree();
    let at = b.windows(2).position(|w| w == b"\n\n").unwrap() + 2;
    b[at..at + 2].copy_from_slice(&((MESH_MAGIC + 4) as u16).to_be_bytes());
    check(&b, "incompatible octree format");
    // Object count disagreeing with the stored objects.
    let objs = frozen_objects();
    let mut b2 = oct_head(4);
    put_str(&mut b2, "");
    put_int(&mut b2, 9, 4);
    b2.push(0);
    put_scene(&mut b2, &objs, 4);
    check(&b2, "stores 5 objects but its header count says 9");
    // Bad node type.
    let mut b = normal_octree();
    let tree = b.len() - (1 + 1 + 1 + 12 + 1 + 1 + 8 + 7 + 5);
    assert_eq!(b[tree], 2);
    b[tree] = 3;
    check(&b, "damaged octree");
    // Garbage cube size.
    let mut b = b"#?RADIANCE\n\n".to_vec();
    put_int(&mut b, OCT_MAGIC + 4, 2);
    for s in ["0", "0", "0", "nan"] {
        put_str(&mut b, s);
    }
    check(&b, "not a finite number");
}

#[test]
fn unreadable_octree_names_where_it_was_named() {
    let from = SourceLoc::new("scene.rad", 3);
    match read_octree(Path::new("/nonexistent/x.oct"), Some(&from)).unwrap_err() {
        Error::Parse { loc, .. } => assert_eq!(loc, from),
        e => panic!("{e}"),
    }
}

// --------------------------------------------------------- no panic, ever

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    #[test]
    fn random_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..400)) {
        let _ = parse_rtm(&bytes, p());
        let _ = parse_octree(&bytes, p());
        // Behind a valid header and format number too.
        for (mut head, magic) in [
            (b"#?RADIANCE\n\n".to_vec(), MESH_MAGIC),
            (b"#?RADIANCE\n\n".to_vec(), OCT_MAGIC),
        ] {
            put_int(&mut head, magic + 4, 2);
            head.extend_from_slice(&bytes);
            let _ = parse_rtm(&head, p());
            let _ = parse_octree(&head, p());
        }
    }

    #[test]
    fn damaged_files_never_panic(
        which in 0usize..3,
        edits in proptest::collection::vec((any::<prop::sample::Index>(), any::<u8>()), 1..6),
        cut in any::<prop::sample::Index>(),
    ) {
        let mut b = match which {
            0 => small_mesh(),
            1 => normal_octree(),
            _ => frozen_octree(4),
        };
        for (i, v) in &edits {
            let k = i.index(b.len());
            b[k] = *v;
        }
        let n = cut.index(b.len() + 1);
        for data in [&b[..], &b[..n]] {
            if let Ok(m) = parse_rtm(data, p()) {
                for t in &m.triangles {
                    prop_assert!(t.v.iter().all(|&k| (k as usize) < m.vertices.len()));
                    prop_assert!(t.material.is_none_or(|k| (k as usize) < m.materials.len()));
                }
            }
            let _ = parse_octree(data, p());
        }
    }
}

// ---------------------------------------------------------------------------
// Loading them as scenes: octrees as scene files and as instances, meshes
// with their own or an overriding material.

fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("hybrid-rt-bin-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

#[test]
fn octrees_load_as_scenes_and_instances() {
    let d = scratch("oct");
    // A frozen octree holds its objects (without the mesh, not here).
    let objs: Vec<RawPrim> = frozen_objects().into_iter().take(4).collect();
    let mut b = oct_head(4);
    put_str(&mut b, "");
    put_int(&mut b, objs.len() as i64, 4);
    b.push(1);
    put_int(&mut b, 2, 4);
    for k in [2, 3] {
        put_int(&mut b, k, 4);
    }
    put_scene(&mut b, &objs, 4);
    std::fs::write(d.join("frozen.octf"), &b).unwrap();
    let s = super::load(&[d.join("frozen.octf")]).unwrap();
    assert_eq!(s.objects.len(), 2);
    assert_eq!(s.lights.len(), 1, "the frozen lamp is a light at top level");
    // A normal octree lists the files oconv read (one a command).
    std::fs::write(
        d.join("materials.rad"),
        "void plastic grey\n0\n0\n5 .5 .5 .5 0 0\n",
    )
    .unwrap();
    std::fs::write(d.join("room.rad"), "grey sphere s\n0\n0\n4 0 0 0 1\n").unwrap();
    std::fs::write(d.join("listed.oct"), normal_octree()).unwrap();
    let s = super::load(&[d.join("listed.oct")]).unwrap();
    assert_eq!(s.objects.len(), 1);
    match &s.objects[0].shape {
        crate::geometry::Shape::Sphere { center, .. } => assert_eq!(center.x, 1.0),
        other => panic!("{other:?}"),
    }
    // As an instance, with an overriding modifier.
    let scene = "void metal chrome\n0\n0\n5 .6 .6 .75 1 0\n\
                 chrome instance a\n5 frozen.octf -t 5 0 0\n0\n0\n\
                 void instance b\n1 listed.oct\n0\n0\n";
    std::fs::write(d.join("inst.rad"), scene).unwrap();
    let s = super::load(&[d.join("inst.rad")]).unwrap();
    assert_eq!(s.objects.len(), 2);
    let crate::geometry::Shape::Instance(i) = &s.objects[0].shape else {
        panic!()
    };
    assert!(i
        .geometry
        .objects
        .iter()
        .all(|o| s.material_names[o.material as usize] == "chrome"));
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn woman_mesh_loads_with_its_materials_or_an_override() {
    let path = woman_rtm();
    if !path.is_file() {
        return;
    }
    let d = scratch("mesh");
    let text = format!(
        "void metal chrome\n0\n0\n5 .6 .6 .75 1 0\n\
         void mesh own\n1 {0}\n0\n0\n\
         chrome mesh shiny\n3 {0} -s 2\n0\n0\n",
        path.display()
    );
    std::fs::write(d.join("m.rad"), text).unwrap();
    let s = super::load(&[d.join("m.rad")]).unwrap();
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    let geo = |k: usize| match &s.objects[k].shape {
        crate::geometry::Shape::Instance(i) => i.clone(),
        other => panic!("{other:?}"),
    };
    let own = geo(0);
    let shiny = geo(1);
    assert_eq!(own.geometry.objects.len(), 43_210);
    let names: std::collections::HashSet<&str> = own
        .geometry
        .objects
        .iter()
        .map(|o| s.material_names[o.material as usize].as_str())
        .collect();
    assert!(
        names.contains("skin:1") && names.contains("hair"),
        "{names:?}"
    );
    // The alias `nipple:1` resolves to skin:1's material.
    assert!(shiny
        .geometry
        .objects
        .iter()
        .all(|o| s.material_names[o.material as usize] == "chrome"));
    let sh = own.geometry.shading.as_ref().expect("smooth shading");
    assert!(sh.normals.is_some() && sh.uv.is_some());
    assert_eq!(sh.triangles.len(), own.geometry.objects.len());
    assert_eq!(shiny.transform.scale, 2.0);
    std::fs::remove_dir_all(&d).ok();
}
