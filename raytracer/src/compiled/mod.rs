//! Compiled scenes, like Radiance's `oconv`: a scene's sources turned into
//! one binary file from which a processor can read the part every
//! processor needs (the replicated part) and only the octree cells it
//! owns.
//!
//! # Layout
//!
//! | bytes | what |
//! |---|---|
//! | 0..8 | [`MAGIC`] |
//! | 8..12 | format [`VERSION`] (u32, little-endian, as every number of the header) |
//! | 12..16 | flags: bit 0 set when every cell stores a copy of each object it lists |
//! | 16..24, 24..28 | length and CRC-32 of the replicated part |
//! | 28..36, 36..40 | length and CRC-32 of the cell index |
//! | 40..44 | CRC-32 of bytes 0..40 |
//! | 44.. | the replicated part, the cell index, the cells |
//!
//! The replicated part ([`Replicated`], postcard) holds the scene's
//! [`Program`] (its materials, patterns, aliases, distant sources and
//! instances as records, in order; see [`crate::scene::record`]), the
//! octree skeleton (every node, and for each leaf listing objects its
//! bounds, object count and bytes), the emitting surfaces (light sources are sampled from every
//! processor), the source file names, the views given and the work
//! predicted per cell for each ([`Replicated::predicted`]). The cell index
//! is one `(offset, length, CRC-32)` per cell (postcard); a cell
//! ([`CellObjects`], postcard) lists the object ids its leaf holds and
//! stores the plain surfaces it owns: by default each object once, in the
//! first leaf (in node order) that lists it, the other leaves naming it by
//! id; with copies, every leaf that lists an object stores it. One more
//! cell after the leaves holds the objects no leaf lists (none in practice).
//!
//! Reading checks the magic, the version and every checksum before it
//! uses anything, so a file of another version, a truncated or a damaged
//! one is an error naming the file, the byte offset and the reason, never
//! a panic. (The cell index is read as a stream and its checksum known at
//! its end; see the `index` module.)
//!
//! Loading ([`load_scene`]) replays the program with the stored surfaces:
//! the scene is the one its sources make (same objects, ids, materials and
//! lights), so a render of the compiled scene equals the render of its
//! sources bit for bit. Files the records name (function files, data,
//! pictures, instanced octrees) are read again from where they were
//! (`hybrid-rt compile` names its sources by absolute paths for this), as
//! with a Radiance octree that is not frozen.

mod distributed;
mod index;

pub use distributed::{CellSource, HeldPart};
use index::file_error;
pub use index::CellEntry;

use std::io::{Read, Seek, SeekFrom};
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::accel::{NodeView, Octree, OctreeParams};
use crate::geometry::{Aabb, MaterialId, ObjectId};
use crate::scene::record::{self, Program, Surface};
use crate::scene::{HitRatios, LoadOptions, Scene, View};
use crate::{Error, Result};

/// The first bytes of a compiled scene (the line ending catches a file
/// mangled by text-mode transfer, as PNG's signature does).
pub const MAGIC: [u8; 8] = *b"HRTSCN\r\n";
/// The format version this build reads and writes.
pub const VERSION: u32 = 3;
/// Bytes of the fixed header.
pub const HEADER_LEN: usize = 44;
/// Flag: every cell stores a copy of each object it lists.
const FLAG_COPIES: u32 = 1;

/// A node of the octree skeleton, in the octree's node order.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum SkeletonNode {
    /// An internal node: its first child (the eight are contiguous, in
    /// octant order).
    Internal(u32),
    /// A leaf listing objects: its cell (index into [`Skeleton::cells`]).
    Leaf(u32),
    /// A leaf listing no object (it has no cell).
    Empty,
}

/// What every processor knows of a cell without reading it.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CellInfo {
    /// The leaf's node (`u32::MAX` for the cell of unlisted objects); its
    /// bounds are [`Skeleton::node_bounds`].
    pub node: u32,
    /// Objects the leaf lists.
    pub objects: u32,
    /// Plain surfaces the cell stores.
    pub stored: u32,
    /// Bytes of the cell in the file.
    pub bytes: u64,
    /// Bytes the parallel renderer accounts for the cell (each object's
    /// size shared among the leaves listing it, as
    /// `parallel::RtWorkload` accounts a scene loaded whole), so a
    /// partition of the compiled scene is the partition of its sources.
    pub accounted: u64,
}

/// The octree skeleton: nodes and cells, no objects.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Skeleton {
    pub params: OctreeParams,
    /// The root cell's centre and half size (`None`: no objects).
    pub root: Option<([f64; 3], f64)>,
    pub nodes: Vec<SkeletonNode>,
    /// One per leaf listing objects, in node order, then the cell of
    /// unlisted objects.
    pub cells: Vec<CellInfo>,
    /// Per cell, the object ids its leaf lists (what a processor needs to
    /// traverse the octree and to know which cells hold what; the cells
    /// hold them too, for a cell read alone).
    pub lists: LeafLists,
}

/// Lists of object ids, one per cell, held in one allocation (a list per
/// cell in its own vector cost a 1.5-million-triangle scene's processors
/// 44 MB where the ids are 12 MB). Encoded as a sequence of sequences,
/// exactly as a `Vec<Vec<ObjectId>>`.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct LeafLists {
    ids: Vec<ObjectId>,
    /// `ends[k]`: where list `k` ends in `ids` (it starts where list
    /// `k - 1` ends).
    ends: Vec<u32>,
}

impl LeafLists {
    /// Lists.
    pub fn len(&self) -> usize {
        self.ends.len()
    }

    pub fn is_empty(&self) -> bool {
        self.ends.is_empty()
    }

    /// List `k`.
    pub fn get(&self, k: usize) -> Option<&[ObjectId]> {
        let end = *self.ends.get(k)? as usize;
        let start = match k {
            0 => 0,
            _ => self.ends[k - 1] as usize,
        };
        self.ids.get(start..end)
    }

    /// The lists in order.
    pub fn iter(&self) -> impl ExactSizeIterator<Item = &[ObjectId]> + '_ {
        // `get` cannot fail for `k < len` (`push` and decoding keep
        // `ends` ascending and within `ids`).
        (0..self.len()).map(|k| self.get(k).unwrap_or_default())
    }

    /// Appends a list; `None` past 2^32 ids in all.
    fn push(&mut self, list: &[ObjectId]) -> Option<()> {
        self.ids.extend_from_slice(list);
        self.ends.push(u32::try_from(self.ids.len()).ok()?);
        Some(())
    }
}

impl Serialize for LeafLists {
    fn serialize<S: serde::Serializer>(&self, s: S) -> std::result::Result<S::Ok, S::Error> {
        s.collect_seq(self.iter())
    }
}

impl<'de> Deserialize<'de> for LeafLists {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        use serde::de::{DeserializeSeed, Error as _, SeqAccess, Visitor};
        /// Reads one list onto the end of the flat ids.
        struct Append<'a>(&'a mut Vec<ObjectId>);
        impl<'de> DeserializeSeed<'de> for Append<'_> {
            type Value = ();
            fn deserialize<D: serde::Deserializer<'de>>(
                self,
                d: D,
            ) -> std::result::Result<(), D::Error> {
                d.deserialize_seq(self)
            }
        }
        impl<'de> Visitor<'de> for Append<'_> {
            type Value = ();
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a list of object ids")
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> std::result::Result<(), A::Error> {
                while let Some(id) = seq.next_element::<ObjectId>()? {
                    self.0.push(id);
                }
                Ok(())
            }
        }
        struct Lists;
        impl<'de> Visitor<'de> for Lists {
            type Value = LeafLists;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("lists of object ids")
            }
            fn visit_seq<A: SeqAccess<'de>>(
                self,
                mut seq: A,
            ) -> std::result::Result<LeafLists, A::Error> {
                let mut lists = LeafLists::default();
                if let Some(n) = seq.size_hint() {
                    // A damaged length must not reserve gigabytes: at most
                    // what the input could hold, one byte per list.
                    lists.ends.reserve(n.min(1 << 24));
                }
                while seq.next_element_seed(Append(&mut lists.ids))?.is_some() {
                    let end = u32::try_from(lists.ids.len())
                        .map_err(|_| A::Error::custom("more than 2^32 listed ids"))?;
                    lists.ends.push(end);
                }
                lists.ids.shrink_to_fit();
                lists.ends.shrink_to_fit();
                Ok(lists)
            }
        }
        d.deserialize_seq(Lists)
    }
}

impl Skeleton {
    /// Every node's cell, in node order (exactly the octree's
    /// [`Octree::node_bounds`]); `None` if a node is named twice or a child
    /// lies outside the node list.
    pub fn node_bounds(&self) -> Option<Vec<Aabb>> {
        let Some((c, h)) = self.root else {
            return self.nodes.is_empty().then(Vec::new);
        };
        let mut cells: Vec<Option<(crate::geometry::Vec3, f64)>> = vec![None; self.nodes.len()];
        *cells.first_mut()? = Some((crate::geometry::Vec3::from_array(c), h));
        for id in 0..self.nodes.len() {
            let (centre, half) = cells[id]?;
            if let SkeletonNode::Internal(first) = self.nodes[id] {
                let first = first as usize;
                // Children follow their parent: no cycle.
                if first <= id || first.checked_add(8)? > self.nodes.len() {
                    return None;
                }
                let q = half * 0.5;
                for i in 0..8 {
                    let s = |bit: usize| if i & bit != 0 { q } else { -q };
                    let child = &mut cells[first + i];
                    if child.is_some() {
                        return None;
                    }
                    *child = Some((centre + crate::geometry::Vec3::new(s(1), s(2), s(4)), q));
                }
            }
        }
        cells
            .into_iter()
            .map(|c| c.map(|(c, h)| Aabb::new(c - h, c + h)))
            .collect()
    }
}

/// The part of a compiled scene every processor reads.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Replicated {
    /// The files compiled, as named.
    pub sources: Vec<PathBuf>,
    /// Views given to `compile` (the text of each view file); `render`
    /// uses the first when given no view.
    pub views: Vec<String>,
    pub program: Program,
    pub skeleton: Skeleton,
    /// The plain surfaces every processor holds (also in their cells):
    /// light sources, and mirrors and prisms, which make virtual light
    /// sources (see [`replicated_surface`]).
    pub shared: Vec<(ObjectId, Surface)>,
    /// The materials of the plain surfaces not in `shared`, each once,
    /// ascending: what a processor knows of the surfaces it does not hold
    /// (the materials a scene uses decide the effects it renders).
    pub elsewhere: Vec<MaterialId>,
    /// The light sources' hit ratios, measured with the whole scene at
    /// compile time (Radiance's default `-dr`).
    pub hit_ratios: HitRatios,
    /// Per view of `views` (in order), the predicted work of each cell
    /// (`skeleton.cells`' order, the unlisted objects' entry left out),
    /// predicted with the whole scene at compile time: what `render
    /// --distribution predicted` cuts the octree by (a processor of a
    /// distributed scene cannot predict it). Empty where `compile` was
    /// given no predictor ([`compile_with`]).
    pub predicted: Vec<Vec<u64>>,
}

/// Predicts the work of every node of the octree built with the given
/// parameters over a scene, seen from each of the views (each node's cost
/// the sum of its children's; one vector per view): the parallel
/// renderer's prediction, which the compiler cannot name itself (the
/// parallel renderer reads compiled scenes).
pub type Predictor<'a> = &'a dyn Fn(&Scene, &OctreeParams, &[View]) -> Result<Vec<Vec<u64>>>;

/// Whether every processor holds `o`, a top-level surface of `scene`:
/// light sources (sampled from everywhere), and planar mirrors and prisms
/// (the renderer's set-up makes virtual light sources of them).
pub fn replicated_surface(scene: &Scene, o: &crate::geometry::Object) -> bool {
    use crate::scene::Material;
    let mut m = scene.material(o.material);
    if crate::scene::is_light_material(m) {
        return true;
    }
    if let Material::Illum {
        alternate: Some(a), ..
    } = m
    {
        m = scene.material(*a);
    }
    matches!(m, Material::Mirror { .. } | Material::Prism { .. })
}

/// One cell: the object ids its leaf lists and the surfaces it stores.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct CellObjects {
    pub listed: Vec<ObjectId>,
    pub stored: Vec<(ObjectId, Surface)>,
}

/// A cell as [`CompiledScene::into_scene`] reads it: the listed ids are
/// stepped over (the octree is built again from the objects), not stored.
#[derive(Debug, Deserialize)]
struct CellStored {
    #[allow(dead_code)] // read to step over it
    listed: Skipped,
    stored: Vec<(ObjectId, Surface)>,
}

/// A sequence of ids decoded and dropped.
#[derive(Debug)]
struct Skipped;

impl<'de> Deserialize<'de> for Skipped {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        struct V;
        impl<'de> serde::de::Visitor<'de> for V {
            type Value = Skipped;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a sequence of object ids")
            }
            fn visit_seq<A: serde::de::SeqAccess<'de>>(
                self,
                mut seq: A,
            ) -> std::result::Result<Skipped, A::Error> {
                while seq.next_element::<ObjectId>()?.is_some() {}
                Ok(Skipped)
            }
        }
        d.deserialize_seq(V)
    }
}

/// How objects listed by several leaves are stored.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Storage {
    /// Once, in the first leaf listing it; other leaves name its id.
    #[default]
    Once,
    /// A copy in every leaf listing it.
    Copies,
}

/// What [`compile`] wrote.
#[derive(Debug, Clone, PartialEq)]
pub struct CompileStats {
    pub objects: usize,
    pub cells: usize,
    /// Sum over leaves of the objects they list.
    pub object_refs: usize,
    pub replicated_bytes: u64,
    pub index_bytes: u64,
    pub cell_bytes: u64,
    pub file_bytes: u64,
}

fn encode<T: Serialize>(value: &T) -> Result<Vec<u8>> {
    postcard::to_stdvec(value).map_err(|e| Error::Other(format!("encoding a compiled scene: {e}")))
}

/// Compiles scene files (Radiance text and octrees) into `out`. `views`
/// are view options stored with the scene; `params` build the skeleton.
pub fn compile(
    sources: &[PathBuf],
    views: Vec<String>,
    params: &OctreeParams,
    storage: Storage,
    out: &Path,
) -> Result<CompileStats> {
    compile_with(sources, views, params, storage, None, out)
}

/// [`compile`], storing for each view the work `predict` predicts per
/// cell ([`Replicated::predicted`]).
pub fn compile_with(
    sources: &[PathBuf],
    views: Vec<String>,
    params: &OctreeParams,
    storage: Storage,
    predict: Option<Predictor<'_>>,
    out: &Path,
) -> Result<CompileStats> {
    let bytes = compile_to_bytes_with(sources, views, params, storage, predict)?;
    let stats = stats_of(&bytes);
    std::fs::write(out, &bytes).map_err(|e| Error::io(out, e))?;
    stats
}

/// [`compile`] into memory.
pub fn compile_to_bytes(
    sources: &[PathBuf],
    views: Vec<String>,
    params: &OctreeParams,
    storage: Storage,
) -> Result<Vec<u8>> {
    compile_to_bytes_with(sources, views, params, storage, None)
}

/// [`compile_with`] into memory.
pub fn compile_to_bytes_with(
    sources: &[PathBuf],
    views: Vec<String>,
    params: &OctreeParams,
    storage: Storage,
    predict: Option<Predictor<'_>>,
) -> Result<Vec<u8>> {
    let (scene, program, surfaces) = record::record(sources, &LoadOptions::from_env())?;
    let octree = Octree::build(&scene.objects, params);
    // Each node's leaf cell, and each leaf's objects.
    let mut nodes = Vec::with_capacity(octree.node_count());
    let mut leaves: Vec<(u32, &[ObjectId])> = Vec::new();
    for id in 0..octree.node_count() as u32 {
        nodes.push(match octree.node(id) {
            NodeView::Internal { children } => SkeletonNode::Internal(children[0]),
            NodeView::Leaf { objects: [] } => SkeletonNode::Empty,
            NodeView::Leaf { objects } => {
                leaves.push((id, objects));
                SkeletonNode::Leaf(leaves.len() as u32 - 1)
            }
        });
    }
    let mut placed = vec![false; surfaces.len()];
    let mut cells: Vec<CellObjects> = Vec::with_capacity(leaves.len() + 1);
    for (_, objects) in &leaves {
        let mut cell = CellObjects {
            listed: objects.to_vec(),
            stored: Vec::new(),
        };
        for &o in *objects {
            let Some(Some(s)) = surfaces.get(o as usize) else {
                continue;
            };
            if storage == Storage::Copies || !placed[o as usize] {
                cell.stored.push((o, s.clone()));
            }
            placed[o as usize] = true;
        }
        cells.push(cell);
    }
    let mut rest = CellObjects::default();
    for (o, s) in surfaces.iter().enumerate() {
        if let (Some(s), false) = (s, placed[o]) {
            rest.stored.push((o as ObjectId, s.clone()));
        }
    }
    cells.push(rest);
    let blobs = cells.iter().map(encode).collect::<Result<Vec<_>>>()?;
    let mut infos: Vec<CellInfo> = leaves
        .iter()
        .map(|&(node, _)| CellInfo {
            node,
            objects: 0,
            stored: 0,
            bytes: 0,
            accounted: 0,
        })
        .collect();
    infos.push(CellInfo {
        node: u32::MAX,
        objects: 0,
        stored: 0,
        bytes: 0,
        accounted: 0,
    });
    // The parallel renderer's accounting (RtWorkload::new): an object
    // listed in n leaves puts 1/n of its bytes in each.
    let mut listed = vec![0u32; scene.objects.len()];
    for (_, objects) in &leaves {
        for &o in *objects {
            listed[o as usize] += 1;
        }
    }
    for (info, (_, objects)) in infos.iter_mut().zip(&leaves) {
        info.accounted = objects
            .iter()
            .map(|&o| {
                let n = listed[o as usize].max(1) as usize;
                (crate::accel::object_bytes(&scene.objects[o as usize]).div_ceil(n) + 4) as u64
            })
            .sum();
    }
    for ((info, cell), blob) in infos.iter_mut().zip(&cells).zip(&blobs) {
        info.objects = cell.listed.len() as u32;
        info.stored = cell.stored.len() as u32;
        info.bytes = blob.len() as u64;
    }
    let shared = scene
        .objects
        .iter()
        .zip(&surfaces)
        .enumerate()
        .filter_map(|(id, (o, s))| {
            let s = s.as_ref()?;
            replicated_surface(&scene, o).then(|| (id as ObjectId, s.clone()))
        })
        .collect();
    let elsewhere: Vec<MaterialId> = scene
        .objects
        .iter()
        .zip(&surfaces)
        .filter(|(o, s)| s.is_some() && !replicated_surface(&scene, o))
        .map(|(o, _)| o.material)
        .collect::<std::collections::BTreeSet<_>>()
        .into_iter()
        .collect();
    let hit_ratios = measure_hit_ratios(&scene)?;
    let mut predicted = Vec::new();
    if let (Some(predict), false) = (predict, views.is_empty()) {
        let parsed = views
            .iter()
            .enumerate()
            .map(|(k, text)| View::from_file_text(text, format!("stored view {}", k + 1)))
            .collect::<Result<Vec<_>>>()?;
        let all = predict(&scene, params, &parsed)?;
        if all.len() != views.len() {
            return Err(Error::Other(format!(
                "compile: predictions for {} views of {}",
                all.len(),
                views.len()
            )));
        }
        for costs in all {
            if costs.len() != octree.node_count() {
                return Err(Error::Other(format!(
                    "compile: a prediction of {} nodes for an octree of {}",
                    costs.len(),
                    octree.node_count()
                )));
            }
            predicted.push(
                leaves
                    .iter()
                    .map(|&(node, _)| costs[node as usize])
                    .collect(),
            );
        }
    }
    let replicated = Replicated {
        sources: sources.to_vec(),
        views,
        program,
        skeleton: Skeleton {
            params: params.clone(),
            root: octree.root_cell().map(|(c, h)| (c.to_array(), h)),
            nodes,
            cells: infos,
            lists: {
                let mut lists = LeafLists::default();
                for c in &cells {
                    lists.push(&c.listed).ok_or_else(|| {
                        Error::Other("compile: more than 2^32 listed object ids".into())
                    })?;
                }
                lists
            },
        },
        shared,
        elsewhere,
        hit_ratios,
        predicted,
    };
    let rep = encode(&replicated)?;
    // The cell offsets depend on the index's length, which depends on the
    // offsets' encoding: lay the cells out from the end of an index whose
    // length is fixed by encoding it until it stops changing.
    let mut index_len = 0usize;
    let index = loop {
        let mut offset = (HEADER_LEN + rep.len() + index_len) as u64;
        let entries: Vec<CellEntry> = blobs
            .iter()
            .enumerate()
            .map(|(k, b)| {
                let len = u32::try_from(b.len()).map_err(|_| {
                    Error::Other(format!(
                        "compiling a scene: cell {k} takes {} bytes, more than a cell may (4 GiB)",
                        b.len()
                    ))
                })?;
                let e = CellEntry {
                    offset,
                    len,
                    crc: crc32fast::hash(b),
                };
                offset += b.len() as u64;
                Ok(e)
            })
            .collect::<Result<_>>()?;
        let index = encode(&entries)?;
        if index.len() == index_len {
            break index;
        }
        index_len = index.len();
    };
    let flags = if storage == Storage::Copies {
        FLAG_COPIES
    } else {
        0
    };
    let mut out = Vec::with_capacity(
        HEADER_LEN + rep.len() + index.len() + blobs.iter().map(Vec::len).sum::<usize>(),
    );
    out.extend_from_slice(&MAGIC);
    out.extend_from_slice(&VERSION.to_le_bytes());
    out.extend_from_slice(&flags.to_le_bytes());
    out.extend_from_slice(&(rep.len() as u64).to_le_bytes());
    out.extend_from_slice(&crc32fast::hash(&rep).to_le_bytes());
    out.extend_from_slice(&(index.len() as u64).to_le_bytes());
    out.extend_from_slice(&crc32fast::hash(&index).to_le_bytes());
    let header_crc = crc32fast::hash(&out);
    out.extend_from_slice(&header_crc.to_le_bytes());
    debug_assert_eq!(out.len(), HEADER_LEN);
    out.extend_from_slice(&rep);
    out.extend_from_slice(&index);
    for b in &blobs {
        out.extend_from_slice(b);
    }
    Ok(out)
}

/// The light sources' hit ratios a renderer of the whole scene measures
/// with the default options.
fn measure_hit_ratios(scene: &Scene) -> Result<HitRatios> {
    let options = crate::render::RenderOptions::default();
    let dr = options.dr;
    if scene.objects.is_empty() && scene.lights.is_empty() {
        return Ok(HitRatios {
            dr,
            ratios: Vec::new(),
        });
    }
    let r = crate::render::Renderer::new(scene, options)?;
    Ok(HitRatios {
        dr,
        ratios: r.lights().iter().map(|l| l.hit_ratio).collect(),
    })
}

fn stats_of(bytes: &[u8]) -> Result<CompileStats> {
    let path = Path::new("<compiled scene>");
    let header = Header::parse(bytes, path, bytes.len() as u64)?;
    let rep: Replicated = decode(
        path,
        HEADER_LEN as u64,
        &bytes[HEADER_LEN..][..header.replicated_len as usize],
    )?;
    let objects = rep.program.objects as usize;
    let cells = rep.skeleton.cells.len();
    let object_refs = rep.skeleton.cells.iter().map(|c| c.objects as usize).sum();
    let cell_bytes = rep.skeleton.cells.iter().map(|c| c.bytes).sum();
    Ok(CompileStats {
        objects,
        cells,
        object_refs,
        replicated_bytes: header.replicated_len,
        index_bytes: header.index_len,
        cell_bytes,
        file_bytes: bytes.len() as u64,
    })
}

/// The fixed header, checked.
#[derive(Debug, Clone, Copy)]
struct Header {
    flags: u32,
    replicated_len: u64,
    replicated_crc: u32,
    index_len: u64,
    index_crc: u32,
}

impl Header {
    /// Parses and checks the header of a file of `file_len` bytes whose
    /// first bytes are `b`.
    fn parse(b: &[u8], path: &Path, file_len: u64) -> Result<Header> {
        if b.len() < MAGIC.len() || b[..MAGIC.len()] != MAGIC {
            return Err(file_error(
                path,
                0,
                "not a compiled scene (no magic number)",
            ));
        }
        if b.len() < HEADER_LEN {
            return Err(file_error(
                path,
                b.len() as u64,
                format!("truncated: the header has {HEADER_LEN} bytes"),
            ));
        }
        let u32_at = |k: usize| u32::from_le_bytes(b[k..k + 4].try_into().expect("4 bytes"));
        let u64_at = |k: usize| u64::from_le_bytes(b[k..k + 8].try_into().expect("8 bytes"));
        let version = u32_at(8);
        if version != VERSION {
            return Err(file_error(
                path,
                8,
                format!("format version {version}, this program reads version {VERSION} (compile the scene again)"),
            ));
        }
        if crc32fast::hash(&b[..40]) != u32_at(40) {
            return Err(file_error(
                path,
                40,
                "the header's checksum does not match (damaged file)",
            ));
        }
        let h = Header {
            flags: u32_at(12),
            replicated_len: u64_at(16),
            replicated_crc: u32_at(24),
            index_len: u64_at(28),
            index_crc: u32_at(36),
        };
        let end = (HEADER_LEN as u64)
            .checked_add(h.replicated_len)
            .and_then(|e| e.checked_add(h.index_len));
        match end {
            Some(e) if e <= file_len => Ok(h),
            _ => Err(file_error(
                path,
                file_len,
                format!(
                    "truncated: the replicated part and index need {} bytes, the file has {file_len}",
                    h.replicated_len.saturating_add(h.index_len).saturating_add(HEADER_LEN as u64)
                ),
            )),
        }
    }

    fn index_offset(&self) -> u64 {
        HEADER_LEN as u64 + self.replicated_len
    }
}

fn decode<'a, T: Deserialize<'a>>(path: &Path, offset: u64, bytes: &'a [u8]) -> Result<T> {
    match postcard::take_from_bytes::<T>(bytes) {
        Ok((v, [])) => Ok(v),
        Ok((_, rest)) => Err(file_error(
            path,
            offset + (bytes.len() - rest.len()) as u64,
            format!("{} bytes left over after the data", rest.len()),
        )),
        Err(e) => Err(file_error(path, offset, format!("cannot decode: {e}"))),
    }
}

/// Cell `cell`'s bytes (those `e` gives), checked and decoded.
fn decode_cell<'a, T: Deserialize<'a>>(
    path: &Path,
    cell: usize,
    e: CellEntry,
    bytes: &'a [u8],
) -> Result<T> {
    check_crc(path, e.offset, bytes, e.crc, &format!("cell {cell}"))?;
    decode(path, e.offset, bytes)
}

fn check_crc(path: &Path, offset: u64, bytes: &[u8], crc: u32, what: &str) -> Result<()> {
    if crc32fast::hash(bytes) == crc {
        Ok(())
    } else {
        Err(file_error(
            path,
            offset,
            format!("the checksum of {what} does not match (damaged file)"),
        ))
    }
}

/// Whether `path` starts with a compiled scene's magic number.
pub fn is_compiled(path: &Path) -> bool {
    let mut magic = [0u8; MAGIC.len()];
    std::fs::File::open(path)
        .and_then(|mut f| f.read_exact(&mut magic))
        .is_ok()
        && magic == MAGIC
}

/// An open compiled scene: its replicated part read and checked, its cells
/// read on demand.
#[derive(Debug)]
pub struct CompiledScene {
    path: PathBuf,
    file: std::fs::File,
    file_len: u64,
    copies: bool,
    replicated: Replicated,
    /// Where the cell index is, checked when the file was opened; it is
    /// read again where entries are needed (see the `index` module).
    index: index::IndexAt,
    /// The whole index, decoded at the first [`CompiledScene::read_cell`].
    entries: Option<Vec<CellEntry>>,
}

impl CompiledScene {
    /// Opens `path`, reads its header and replicated part and checks its
    /// cell index (read as a stream, not kept: see the `index` module).
    pub fn open(path: &Path) -> Result<CompiledScene> {
        let mut file = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
        let file_len = file.metadata().map_err(|e| Error::io(path, e))?.len();
        let mut head = Vec::with_capacity(HEADER_LEN);
        (&mut file)
            .take(HEADER_LEN as u64)
            .read_to_end(&mut head)
            .map_err(|e| Error::io(path, e))?;
        let header = Header::parse(&head, path, file_len)?;
        let mut rep = vec![0u8; header.replicated_len as usize];
        file.read_exact(&mut rep).map_err(|e| Error::io(path, e))?;
        let rep_at = HEADER_LEN as u64;
        check_crc(
            path,
            rep_at,
            &rep,
            header.replicated_crc,
            "the replicated part",
        )?;
        let replicated: Replicated = decode(path, rep_at, &rep)?;
        drop(rep);
        let index = index::IndexAt {
            offset: header.index_offset(),
            len: header.index_len,
            crc: header.index_crc,
            cells: 0,
        }
        .check(path, &file, file_len, replicated.skeleton.cells.len())?;
        Ok(CompiledScene {
            path: path.to_path_buf(),
            file,
            file_len,
            copies: header.flags & FLAG_COPIES != 0,
            replicated,
            index,
            entries: None,
        })
    }

    /// The part every processor holds.
    pub fn replicated(&self) -> &Replicated {
        &self.replicated
    }

    /// Cells (leaves, then the cell of unlisted objects).
    pub fn cell_count(&self) -> usize {
        self.index.cells
    }

    /// Whether every cell stores a copy of each object it lists.
    pub fn copies(&self) -> bool {
        self.copies
    }

    /// Bytes of the whole file.
    pub fn file_len(&self) -> u64 {
        self.file_len
    }

    /// Reads one cell (seeking to it; the first call decodes the index).
    pub fn read_cell(&mut self, cell: usize) -> Result<CellObjects> {
        if self.entries.is_none() {
            self.entries = Some(self.index.all(&self.path, &self.file, self.file_len)?);
        }
        let e = self
            .entries
            .as_ref()
            .and_then(|entries| entries.get(cell).copied())
            .ok_or_else(|| {
                Error::Usage(format!(
                    "{}: no cell {cell} (the scene has {})",
                    self.path.display(),
                    self.index.cells
                ))
            })?;
        let mut bytes = vec![0u8; e.len as usize];
        self.file
            .seek(SeekFrom::Start(e.offset))
            .and_then(|_| self.file.read_exact(&mut bytes))
            .map_err(|err| Error::io(&self.path, err))?;
        decode_cell(&self.path, cell, e, &bytes)
    }

    /// Reads every cell and builds the whole scene (what `render` does
    /// with a compiled scene).
    pub fn into_scene(self, options: &LoadOptions) -> Result<Scene> {
        let surfaces = self.read_surfaces()?;
        let mut scene = record::replay(&self.replicated.program, surfaces, options, &self.path)?;
        // The ratios a processor holding part of the scene renders with.
        scene.hit_ratios = Some(self.replicated.hit_ratios.clone());
        Ok(scene)
    }

    /// Every stored surface by object id (`None` for instances), read
    /// cell after cell through one buffer.
    pub fn read_surfaces(&self) -> Result<Vec<Option<Surface>>> {
        let n = self.replicated.program.objects as usize;
        let mut surfaces: Vec<Option<Surface>> = vec![None; n];
        let mut reader = std::io::BufReader::with_capacity(1 << 20, &self.file);
        let mut at = u64::MAX;
        let mut bytes = Vec::new();
        let entries = self.index.all(&self.path, &self.file, self.file_len)?;
        for (k, &e) in entries.iter().enumerate() {
            if e.offset != at {
                reader
                    .seek(SeekFrom::Start(e.offset))
                    .map_err(|err| Error::io(&self.path, err))?;
            }
            bytes.resize(e.len as usize, 0);
            reader
                .read_exact(&mut bytes)
                .map_err(|err| Error::io(&self.path, err))?;
            at = e.offset + u64::from(e.len);
            let cell: CellStored = decode_cell(&self.path, k, e, &bytes)?;
            for (id, s) in cell.stored {
                let slot = surfaces.get_mut(id as usize).ok_or_else(|| {
                    file_error(
                        &self.path,
                        e.offset,
                        format!("cell {k}: object {id} of {n}"),
                    )
                })?;
                if slot.is_none() {
                    *slot = Some(s);
                }
            }
        }
        Ok(surfaces)
    }
}

/// Loads a scene: a compiled scene when `paths` is one file starting with
/// [`MAGIC`], else the sources with [`crate::scene::load`].
pub fn load(paths: &[PathBuf]) -> Result<Scene> {
    match paths {
        [one] if is_compiled(one) => load_scene(one),
        _ => {
            if let Some(p) = paths.iter().find(|p| is_compiled(p)) {
                return Err(Error::Usage(format!(
                    "{}: a compiled scene must be the only scene file given",
                    p.display()
                )));
            }
            crate::scene::load(paths)
        }
    }
}

/// Loads a compiled scene whole.
pub fn load_scene(path: &Path) -> Result<Scene> {
    CompiledScene::open(path)?.into_scene(&LoadOptions::from_env())
}
