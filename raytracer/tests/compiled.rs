//! Compiled scenes (`hybrid-rt compile`) and the seeded city
//! (`hybrid-rt generate city`): the compiled scene is the scene its sources
//! make, renders of the two are equal byte for byte (sequential and with
//! two processors), and a damaged, truncated or foreign file is an error,
//! never a panic. Small scenes only: fast in debug builds.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use hybrid_rt::accel::{NodeView, Octree, OctreeParams};
use hybrid_rt::compiled::{self, CompiledScene, SkeletonNode, Storage, HEADER_LEN, MAGIC};
use hybrid_rt::scene::{self, generate, LoadOptions, Scene};

fn tmpdir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("hybrid-rt-compiled-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn run(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_hybrid-rt"))
        .args(args)
        .output()
        .expect("runs")
}

/// `render SCENE --view-file VF -x SIZE -y SIZE -o PIC` and `extra`.
fn render(scene: &Path, vf: &Path, size: usize, pic: &Path, extra: &[&str]) -> Output {
    let size = size.to_string();
    let mut args = vec![
        "render",
        scene.to_str().unwrap(),
        "--view-file",
        vf.to_str().unwrap(),
        "-x",
        &size,
        "-y",
        &size,
        "-o",
        pic.to_str().unwrap(),
    ];
    args.extend(extra);
    run(&args)
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Writes `name` (a built-in scene: cornell, studio, or city of `size`
/// triangles) and its view into `dir`; returns the scene file.
fn write_scene(dir: &Path, name: &str, size: usize) -> PathBuf {
    let rad = dir.join(format!("{name}.rad"));
    let o = run(&[
        "generate",
        name,
        "--size",
        &size.to_string(),
        "-o",
        rad.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    rad
}

/// Everything of a scene that shading reads, as text.
fn fingerprint(s: &Scene) -> String {
    format!(
        "{:?}\n{:?}\n{:?}\n{:?}\n{:?}\n{:?}\n{:?}",
        s.objects, s.materials, s.material_names, s.material_mods, s.lights, s.stats, s.clip_bits
    )
}

fn compile_bytes(sources: &[PathBuf], storage: Storage) -> Vec<u8> {
    compiled::compile_to_bytes(sources, Vec::new(), &OctreeParams::default(), storage)
        .unwrap_or_else(|e| panic!("compiles: {e}"))
}

fn load_bytes(dir: &Path, name: &str, bytes: &[u8]) -> hybrid_rt::Result<Scene> {
    let path = dir.join(name);
    std::fs::write(&path, bytes).unwrap();
    CompiledScene::open(&path)?.into_scene(&LoadOptions::default())
}

#[test]
fn the_city_is_deterministic_sized_and_lit() {
    let (a, sa) = generate::city_with_stats(7, 2000);
    let (b, _) = generate::city_with_stats(7, 2000);
    assert_eq!(a, b, "same seed and size, same bytes");
    assert_ne!(a, generate::city(8, 2000), "another seed, another city");
    assert!(sa.triangles >= 2000, "{sa:?}");
    assert!(
        sa.triangles < 2000 + 1500,
        "one building too many at most: {sa:?}"
    );
    let s = scene::load_rad_str(&a, "city.rad").unwrap();
    assert_eq!(s.stats.instances, 0, "real geometry");
    assert_eq!(s.stats.primitives, sa.primitives);
    let tris: usize = s
        .objects
        .iter()
        .map(|o| match &o.shape {
            hybrid_rt::geometry::Shape::Polygon(p) => p.triangles.len(),
            _ => 0,
        })
        .sum();
    assert_eq!(tris, sa.triangles);
    assert_eq!(s.lights.len(), sa.lights);
    assert!(s.lights.len() >= 4, "a sun, a sky and lamps");
    let (_, big) = generate::city_with_stats(1, 40_000);
    assert!(big.triangles >= 40_000 && big.buildings > sa.buildings);
}

#[test]
fn a_compiled_scene_is_the_scene_of_its_sources() {
    let dir = tmpdir("same");
    generate::write_all(&dir, generate::DEFAULT_SEED).unwrap();
    let city = dir.join("city.rad");
    std::fs::write(&city, generate::city(3, 1500)).unwrap();
    for name in ["cornell.rad", "studio.rad", "conference.rad", "city.rad"] {
        let src = vec![dir.join(name)];
        let want = fingerprint(&scene::load(&src).unwrap());
        for storage in [Storage::Once, Storage::Copies] {
            let bytes = compile_bytes(&src, storage);
            let got = load_bytes(&dir, "x.hrtc", &bytes)
                .unwrap_or_else(|e| panic!("{name} {storage:?}: {e}"));
            assert!(fingerprint(&got) == want, "{name} {storage:?} differs");
        }
    }
    // Several files form one scene, as with oconv.
    let a = dir.join("a.rad");
    let b = dir.join("b.rad");
    std::fs::write(
        &a,
        "void plastic red 0 0 5 .8 .1 .1 0 0\nvoid light l 0 0 3 9 9 9\n",
    )
    .unwrap();
    std::fs::write(
        &b,
        "red sphere s 0 0 4 0 0 0 1\nl polygon p 0 0 9 0 0 3 1 0 3 0 1 3\nvoid plastic red 0 0 5 .1 .8 .1 0 0\nred ring r 0 0 8 0 0 -1 0 0 1 0 2\n",
    )
    .unwrap();
    let src = vec![a, b];
    let want = fingerprint(&scene::load(&src).unwrap());
    let got = load_bytes(&dir, "ab.hrtc", &compile_bytes(&src, Storage::Once)).unwrap();
    assert_eq!(fingerprint(&got), want);
}

#[test]
fn cells_hold_the_octree_leaves_and_the_skeleton_its_cells() {
    let dir = tmpdir("cells");
    let src = dir.join("studio.rad");
    std::fs::write(&src, generate::studio(generate::DEFAULT_SEED)).unwrap();
    let s = scene::load(&[&src]).unwrap();
    let octree = Octree::build(&s.objects, &OctreeParams::default());
    let out = dir.join("studio.hrtc");
    let stats = compiled::compile(
        std::slice::from_ref(&src),
        vec!["-vp 1 2 3".into()],
        &OctreeParams::default(),
        Storage::Once,
        &out,
    )
    .unwrap();
    assert_eq!(stats.objects, s.objects.len());
    assert_eq!(stats.object_refs, octree.stats().object_refs);
    let mut c = CompiledScene::open(&out).unwrap();
    let rep = c.replicated().clone();
    assert_eq!(rep.views, vec!["-vp 1 2 3".to_string()]);
    assert_eq!(rep.skeleton.nodes.len(), octree.node_count());
    let bounds = rep.skeleton.node_bounds().expect("a well-formed skeleton");
    for (id, b) in bounds.iter().enumerate() {
        assert_eq!(*b, octree.node_bounds(id as u32), "node {id}");
    }
    // Every object stored exactly once; each cell lists its leaf's objects.
    let mut stored = vec![0usize; s.objects.len()];
    let mut file_bytes = 0;
    for (k, info) in rep.skeleton.cells.iter().enumerate() {
        let cell = c.read_cell(k).unwrap();
        file_bytes += info.bytes;
        assert_eq!(cell.listed.len(), info.objects as usize);
        assert_eq!(cell.stored.len(), info.stored as usize);
        assert_eq!(rep.skeleton.lists.get(k), Some(cell.listed.as_slice()));
        if info.node != u32::MAX {
            assert_eq!(
                rep.skeleton.nodes[info.node as usize],
                SkeletonNode::Leaf(k as u32)
            );
            assert!(
                matches!(octree.node(info.node), NodeView::Leaf { objects } if objects == cell.listed.as_slice())
            );
        }
        for (id, _) in &cell.stored {
            stored[*id as usize] += 1;
        }
    }
    assert_eq!(file_bytes, stats.cell_bytes);
    assert!(stored.iter().all(|&n| n == 1), "each object once");
    assert!(c.read_cell(rep.skeleton.cells.len()).is_err());
    // The emitting surfaces are in the replicated part (the studio has
    // no mirror or prism, which would be too).
    let area: Vec<u32> = s
        .lights
        .iter()
        .filter_map(|l| match l.kind {
            scene::LightKind::Area { object } => Some(object),
            _ => None,
        })
        .collect();
    assert!(!area.is_empty());
    let shared: Vec<u32> = rep.shared.iter().map(|(id, _)| *id).collect();
    assert_eq!(shared, area);
    assert!(!rep.elsewhere.is_empty());
    assert_eq!(rep.hit_ratios.ratios.len(), area.len());
}

/// CRC-32 (IEEE), bit by bit: the checksum the format names.
/// The skeleton's leaf lists, held flat, are encoded exactly as a vector of
/// vectors (the format's definition), and read back from one.
#[test]
fn leaf_lists_are_encoded_as_a_vector_of_vectors() {
    let nested: Vec<Vec<u32>> = vec![vec![3, 1, 4], vec![], vec![1, 5], vec![9, 2, 6, 5, 3]];
    let bytes = postcard::to_stdvec(&nested).unwrap();
    let lists: compiled::LeafLists = postcard::from_bytes(&bytes).unwrap();
    assert_eq!(lists.len(), nested.len());
    for (k, l) in nested.iter().enumerate() {
        assert_eq!(lists.get(k), Some(l.as_slice()));
    }
    assert_eq!(lists.get(nested.len()), None);
    assert_eq!(postcard::to_stdvec(&lists).unwrap(), bytes);
    let empty: compiled::LeafLists = postcard::from_bytes(&[0]).unwrap();
    assert!(empty.is_empty());
    // Truncated input is an error, not a panic.
    assert!(postcard::from_bytes::<compiled::LeafLists>(&bytes[..bytes.len() - 1]).is_err());
}

#[test]
fn cell_entries_read_the_64_bit_lengths_of_earlier_files() {
    // Files before the index held its lengths in 32 bits wrote them as a
    // `u64`: the same varint, so they read alike; a length past 32 bits is
    // an error, not a truncated length.
    #[derive(serde::Serialize)]
    struct Wide {
        offset: u64,
        len: u64,
        crc: u32,
    }
    let wide = |len| {
        postcard::to_stdvec(&vec![Wide {
            offset: 1 << 40,
            len,
            crc: 0xdead_beef,
        }])
        .unwrap()
    };
    let entries: Vec<compiled::CellEntry> = postcard::from_bytes(&wide(123_456_789)).unwrap();
    assert_eq!(
        entries,
        [compiled::CellEntry {
            offset: 1 << 40,
            len: 123_456_789,
            crc: 0xdead_beef
        }]
    );
    assert_eq!(postcard::to_stdvec(&entries).unwrap(), wide(123_456_789));
    assert!(postcard::from_bytes::<Vec<compiled::CellEntry>>(&wide(1 << 32)).is_err());
}

fn crc32(bytes: &[u8]) -> u32 {
    let mut c = !0u32;
    for &b in bytes {
        c ^= b as u32;
        for _ in 0..8 {
            c = if c & 1 != 0 {
                (c >> 1) ^ 0xedb8_8320
            } else {
                c >> 1
            };
        }
    }
    !c
}

/// SplitMix64, for the damage below.
fn next(state: &mut u64) -> u64 {
    *state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
    let mut z = *state;
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// `good` with about one byte in `one_in` of `part` replaced at random,
/// and the part's checksum (at header byte `crc_at`) and the header's made
/// to match: damage only a decoder can notice.
fn noisy(
    good: &[u8],
    part: std::ops::Range<usize>,
    crc_at: usize,
    one_in: u64,
    rng: &mut u64,
) -> Vec<u8> {
    let mut bad = good.to_vec();
    for b in bad[part.clone()].iter_mut() {
        if next(rng) % one_in == 0 {
            *b = next(rng) as u8;
        }
    }
    let crc = crc32(&bad[part]);
    bad[crc_at..crc_at + 4].copy_from_slice(&crc.to_le_bytes());
    let crc = crc32(&bad[..40]);
    bad[40..44].copy_from_slice(&crc.to_le_bytes());
    bad
}

#[test]
fn damaged_truncated_and_foreign_files_are_errors_naming_the_offset() {
    let dir = tmpdir("damage");
    let src = dir.join("cornell.rad");
    std::fs::write(&src, generate::cornell(generate::DEFAULT_SEED)).unwrap();
    let good = compile_bytes(&[src], Storage::Once);
    assert!(load_bytes(&dir, "good.hrtc", &good).is_ok());
    assert_eq!(&good[..8], &MAGIC);
    // The header's checksum is the CRC-32 of its first 40 bytes.
    assert_eq!(
        crc32(&good[..40]),
        u32::from_le_bytes(good[40..44].try_into().unwrap())
    );
    let mut rng = 19u64;
    // Every byte is under a checksum: any flip is caught.
    for _ in 0..200 {
        let mut bad = good.clone();
        let at = (next(&mut rng) % bad.len() as u64) as usize;
        bad[at] ^= 1 << (next(&mut rng) % 8);
        let e = load_bytes(&dir, "flip.hrtc", &bad).expect_err("a flipped byte is caught");
        let msg = e.to_string();
        assert!(msg.contains("flip.hrtc"), "{msg}");
        if at >= MAGIC.len() {
            assert!(msg.contains("byte "), "{msg}");
        }
    }
    for _ in 0..100 {
        let cut = (next(&mut rng) % good.len() as u64) as usize;
        let e = load_bytes(&dir, "cut.hrtc", &good[..cut]).expect_err("truncated");
        let msg = e.to_string();
        assert!(msg.contains("cut.hrtc"), "{msg}");
    }
    // Noise in the replicated part with its checksums made to match: the
    // decoder or the replay says why, without panicking.
    let rep_len = u64::from_le_bytes(good[16..24].try_into().unwrap()) as usize;
    let rep = HEADER_LEN..HEADER_LEN + rep_len;
    for _ in 0..100 {
        let bad = noisy(&good, rep.clone(), 24, 64, &mut rng);
        let _ = load_bytes(&dir, "noise.hrtc", &bad);
    }
    // Noise in the cell index (read as a stream) with its checksums made
    // to match: an error naming the file, or cells that decode, never a
    // panic or a read beyond the file.
    let index_len = u64::from_le_bytes(good[28..36].try_into().unwrap()) as usize;
    let index = rep.end..rep.end + index_len;
    for round in 0..100 {
        let bad = noisy(&good, index.clone(), 36, 16, &mut rng);
        if let Err(e) = load_bytes(&dir, "index.hrtc", &bad) {
            let msg = e.to_string();
            assert!(msg.contains("index.hrtc"), "round {round}: {msg}");
        }
    }
    let mut other = good.clone();
    let v = hybrid_rt::compiled::VERSION + 1;
    other[8..12].copy_from_slice(&v.to_le_bytes());
    let e = load_bytes(&dir, "other.hrtc", &other)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains(&format!("version {v}")) && e.contains("byte 8"),
        "{e}"
    );
    // A file without the magic is a scene source to `render`, and not a
    // compiled scene to the reader.
    let e = load_bytes(&dir, "text.hrtc", b"void plastic x 0 0 5 1 1 1 0 0\n")
        .unwrap_err()
        .to_string();
    assert!(e.contains("not a compiled scene"), "{e}");
}

#[test]
fn renders_of_a_compiled_scene_equal_renders_of_its_sources() {
    let dir = tmpdir("render");
    for (name, size) in [("cornell", 0), ("studio", 0), ("city", 1200)] {
        let rad = write_scene(&dir, name, size);
        let vf = rad.with_extension("vf");
        let hrtc = dir.join(format!("{name}.hrtc"));
        let o = run(&[
            "compile",
            rad.to_str().unwrap(),
            "-o",
            hrtc.to_str().unwrap(),
            "--view-file",
            vf.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        for procs in [None, Some("2")] {
            let mut pics = Vec::new();
            for (k, scene) in [&rad, &hrtc].into_iter().enumerate() {
                let pic = dir.join(format!("{name}{k}.hdr"));
                let procs = procs.map(|p| ["--procs", p]);
                let o = render(scene, &vf, 32, &pic, procs.as_ref().map_or(&[][..], |p| p));
                assert!(o.status.success(), "{name}: {}", stderr(&o));
                pics.push(std::fs::read(&pic).unwrap());
            }
            assert!(
                pics[0] == pics[1],
                "{name} --procs {procs:?}: pictures differ"
            );
        }
    }
    // With -ab a compiled scene is read processor by processor, with an
    // irradiance cache and without: the hemispheres' rays migrate, and the
    // picture is the sequential one.
    let ambient = |scene: &str, aa: &str, procs: &[&str], pic: &str| {
        let ab = ["-ab", "2", "-ad", "16", "-as", "0", "-aa", aa];
        let (vf, pic) = (dir.join("cornell.vf"), dir.join(pic));
        let o = render(&dir.join(scene), &vf, 16, &pic, &[&ab[..], procs].concat());
        assert!(o.status.success(), "{}", stderr(&o));
        (stderr(&o), std::fs::read(pic).unwrap())
    };
    for aa in ["0.3", "0"] {
        let (_, whole) = ambient("cornell.rad", aa, &[], "ab0.hdr");
        for procs in [&["--procs", "3"][..], &["--procs", "3", "--cache", "50%"]] {
            let (said, parallel) = ambient("cornell.hrtc", aa, procs, "ab1.hdr");
            assert!(!said.contains("loaded whole"), "{said}");
            assert_eq!(
                said.contains("irradiance cache:"),
                aa != "0",
                "-aa {aa}: {said}"
            );
            assert!(
                whole == parallel,
                "-ab 2 -aa {aa} {procs:?} on the compiled scene"
            );
        }
    }

    // The view stored in a compiled scene is the default view.
    let moved = dir.join("moved");
    std::fs::create_dir_all(&moved).unwrap();
    let lone = moved.join("city.hrtc");
    std::fs::copy(dir.join("city.hrtc"), &lone).unwrap();
    let pic = moved.join("stored.hdr");
    let o = run(&[
        "render",
        lone.to_str().unwrap(),
        "-x",
        "32",
        "-y",
        "32",
        "-o",
        pic.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("its stored view"), "{}", stderr(&o));
    assert!(std::fs::read(&pic).unwrap() == std::fs::read(dir.join("city0.hdr")).unwrap());
    // A damaged compiled scene: render says which file, where and why.
    let mut bytes = std::fs::read(&lone).unwrap();
    let at = bytes.len() - 3;
    bytes[at] ^= 0x10;
    std::fs::write(&lone, &bytes).unwrap();
    let o = run(&[
        "render",
        lone.to_str().unwrap(),
        "-x",
        "8",
        "-y",
        "8",
        "-o",
        pic.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let e = stderr(&o);
    assert!(
        e.contains("city.hrtc") && e.contains("byte ") && e.contains("damaged"),
        "{e}"
    );
    assert!(!e.contains("panicked"), "{e}");
    // A compiled scene is the only scene file of a render.
    let hrtc = dir.join("cornell.hrtc");
    let rad = dir.join("cornell.rad");
    let o = run(&[
        "render",
        rad.to_str().unwrap(),
        hrtc.to_str().unwrap(),
        "-o",
        dir.join("x.hdr").to_str().unwrap(),
    ]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("only scene file"), "{}", stderr(&o));
}

#[test]
fn compile_refuses_what_it_cannot_compile() {
    let dir = tmpdir("refuse");
    let obj = dir.join("t.obj");
    std::fs::write(&obj, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    let out = dir.join("t.hrtc");
    let o = run(&[
        "compile",
        obj.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("obj2rad"), "{}", stderr(&o));
    let bad = dir.join("bad.rad");
    std::fs::write(
        &bad,
        "void plastic x 0 0 5 1 1 1 0 0\nx sphere s 0 0 3 0 0 0\n",
    )
    .unwrap();
    let o = run(&[
        "compile",
        bad.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("bad.rad:2"), "{}", stderr(&o));
    assert!(!out.exists());
}
