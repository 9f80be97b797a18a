//! A processor's part of a compiled scene: what it reads before rendering
//! ([`HeldPart`]: the replicated part and the octree skeleton) and where it
//! reads the objects of its own cells ([`CellSource`]).
//!
//! The replicated part becomes a [`Scene::distributed`] scene holding only
//! the objects every processor needs: light sources, mirrors and prisms
//! ([`super::replicated_surface`]) and instances; the other surfaces are
//! known by the materials they use. The octree is rebuilt from the
//! skeleton ([`Octree::from_skeleton`]), equal to the whole scene's octree
//! but without intersection data. A processor then reads only the cells it
//! owns (seeking to each; with objects stored once, also the cells where
//! objects its leaves share with others are stored) and builds its copies
//! from them.
//!
//! What grows with the whole scene on every processor: the octree's nodes
//! and its leaf lists (4 bytes per listing), not the objects.

use rustc_hash::FxHashSet;
use std::io::{Read, Seek, SeekFrom};
use std::path::{Path, PathBuf};
use std::sync::Arc;

use super::index::IndexAt;
use super::{
    file_error, CellEntry, CellObjects, CompiledScene, Replicated, Skeleton, SkeletonNode,
};
use crate::accel::{CellTable, NodeId, Octree, SkeletonNode as TreeNode};
use crate::geometry::ObjectId;
use crate::scene::record::{self, Surface};
use crate::scene::{LoadOptions, Scene, View};
use crate::{Error, Result};

/// What a processor holds of a compiled scene before it reads its cells.
#[derive(Debug)]
pub struct HeldPart {
    /// The replicated part: a [`Scene::distributed`] scene.
    pub scene: Scene,
    /// The whole scene's octree, from the skeleton.
    pub octree: Octree,
    /// Where the cells are.
    pub source: CellSource,
    /// The stored views' texts and the work predicted per cell for each
    /// (see [`super::Replicated::predicted`]).
    pub predicted: Vec<(String, Vec<u64>)>,
}

impl HeldPart {
    /// The predicted work of every node of the octree (each node's the
    /// sum of its children's), as predicted at compile time for `view`,
    /// which must be one of the stored views: the cost the `predicted`
    /// distribution cuts by.
    pub fn predicted_costs(&self, view: &View) -> Result<Vec<u64>> {
        let path = &self.source.path;
        if self.predicted.is_empty() {
            return Err(Error::Usage(format!(
                "{}: the predicted distribution of a compiled scene cuts by the work predicted when it was compiled, for the views stored with it, and it has none (compile it with --view-file)",
                path.display()
            )));
        }
        let mut found = None;
        for (k, (text, costs)) in self.predicted.iter().enumerate() {
            let stored =
                View::from_file_text(text, format!("{} (stored view {})", path.display(), k + 1))?;
            if stored == *view {
                found = Some(costs);
                break;
            }
        }
        let Some(cells) = found else {
            return Err(Error::Usage(format!(
                "{}: the predicted distribution of a compiled scene cuts by the work predicted when it was compiled, for the views stored with it; this view is not one of them (render a stored view, or compile with --view-file naming this one)",
                path.display()
            )));
        };
        let mut out = vec![0u64; self.octree.node_count()];
        for ((leaf, _), &c) in self.source.cells.iter().zip(cells) {
            out[leaf as usize] = c;
        }
        self.octree.sum_subtrees(&mut out);
        Ok(out)
    }
}

/// Where a processor reads the objects of its cells.
#[derive(Debug, Clone)]
pub struct CellSource {
    path: PathBuf,
    /// The cell index, read for the entries of the cells wanted.
    index: IndexAt,
    file_len: u64,
    copies: bool,
    materials: usize,
    /// The listing leaves with their accounted bytes, in node order (so a
    /// leaf's place is its cell's): shared with the processors of this
    /// process, which keep it for the run (a list of 16 bytes a cell beside
    /// it took 12 MB of every rank of the 1.5M-triangle city while the
    /// cells were read).
    cells: Arc<CellTable>,
}

impl CompiledScene {
    /// Reads what a processor holds of this scene besides its cells: the
    /// replicated part as a [`Scene::distributed`] scene, and the octree.
    pub fn held_part(self, options: &LoadOptions) -> Result<HeldPart> {
        // The decoded replicated part is let go piece by piece as the held
        // part is made of it, so that at no moment both are whole: the
        // cells' table goes before the octree is built, the skeleton's
        // nodes and lists as soon as it is.
        let CompiledScene {
            path,
            copies,
            index,
            file_len,
            replicated,
            ..
        } = self;
        let Replicated {
            views,
            program,
            skeleton,
            shared,
            elsewhere,
            hit_ratios,
            predicted,
            ..
        } = replicated;
        let n = program.objects as usize;
        let mut held = std::collections::BTreeMap::new();
        for (id, s) in shared {
            if id as usize >= n {
                return Err(file_error(
                    &path,
                    0,
                    format!("shared surface {id} of {n} objects"),
                ));
            }
            held.insert(id, s);
        }
        let mut scene = record::replay_part(&program, held, &elsewhere, options, &path)?;
        drop(program);
        scene.hit_ratios = Some(hit_ratios);
        let Skeleton {
            root,
            nodes,
            cells,
            lists,
            ..
        } = skeleton;
        if lists.len() != cells.len() {
            return Err(file_error(
                &path,
                0,
                format!("{} leaf lists for {} cells", lists.len(), cells.len()),
            ));
        }
        let leaves: Vec<(NodeId, u64)> = cells
            .iter()
            .take_while(|c| c.node != u32::MAX)
            .map(|c| (c.node, c.accounted))
            .collect();
        if leaves.windows(2).any(|w| w[0].0 >= w[1].0)
            || cells[leaves.len()..].iter().any(|c| c.node != u32::MAX)
        {
            return Err(file_error(
                &path,
                0,
                "the skeleton's cells are not in node order, the unlisted objects' last",
            ));
        }
        drop(cells);
        if !predicted.is_empty()
            && (predicted.len() != views.len() || predicted.iter().any(|p| p.len() != leaves.len()))
        {
            return Err(file_error(
                &path,
                0,
                "the predicted work does not match the stored views and cells",
            ));
        }
        let root = root.map(|(c, h)| (crate::geometry::Vec3::from_array(c), h));
        let node = |id: usize| {
            Ok(match nodes[id] {
                SkeletonNode::Internal(first_child) => TreeNode::Internal { first_child },
                SkeletonNode::Empty => TreeNode::Leaf(&[]),
                SkeletonNode::Leaf(cell) => TreeNode::Leaf(
                    lists
                        .get(cell as usize)
                        .ok_or_else(|| format!("node {id}: no cell {cell}"))?,
                ),
            })
        };
        let octree = Octree::from_skeleton(root, n, nodes.len(), node)
            .map_err(|e| file_error(&path, 0, format!("octree skeleton: {e}")))?;
        drop((nodes, lists));
        let predicted = views.into_iter().zip(predicted).collect();
        Ok(HeldPart {
            source: CellSource {
                path,
                index,
                file_len,
                copies,
                materials: scene.materials.len(),
                cells: Arc::new(CellTable::new(leaves)),
            },
            scene,
            octree,
            predicted,
        })
    }
}

impl CellSource {
    /// The compiled scene's file.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Every leaf listing objects, in node order, with the bytes the
    /// parallel renderer accounts for it.
    pub fn cells(&self) -> &Arc<CellTable> {
        &self.cells
    }

    /// Makes the surfaces [`CellSource::read_objects`] reads into objects.
    pub fn maker(&self) -> record::SurfaceMaker {
        record::SurfaceMaker::new(self.materials, &self.path)
    }

    /// The surfaces `leaves` list that `scene` (a processor's
    /// [`HeldPart::scene`]) does not hold, read from the file and handed
    /// to `sink` one by one as their cells are read (each once, the first
    /// stored copy): the leaves' own cells and, where objects are stored
    /// once, the cells storing the objects they share with leaves stored
    /// before them. `octree` gives the leaves' lists. Nothing read is kept
    /// here: a processor turns each surface into its copy at once, so its
    /// part is never held twice (as read and as copies). Errors name the
    /// file, the cell, its byte offset and why; an error of `sink` ends
    /// the reading.
    pub fn read_objects(
        &self,
        scene: &Scene,
        octree: &Octree,
        leaves: &[NodeId],
        mut sink: impl FnMut(ObjectId, Surface) -> Result<()>,
    ) -> Result<()> {
        let mut file = std::fs::File::open(&self.path).map_err(|e| Error::io(&self.path, e))?;
        // Reserved for every listing (an upper bound): grown from empty, the
        // set rehashed its way up.
        let listings = leaves.iter().map(|&l| octree.leaf_objects(l).len()).sum();
        // The wanted objects not read yet.
        let mut left: FxHashSet<ObjectId> =
            FxHashSet::with_capacity_and_hasher(listings, Default::default());
        let mut cells: Vec<u32> = Vec::with_capacity(leaves.len());
        for &leaf in leaves {
            let cell = self.cells.index_of(leaf).ok_or_else(|| {
                Error::Other(format!(
                    "{}: octree leaf {leaf} has no cell",
                    self.path.display()
                ))
            })?;
            cells.push(cell as u32);
            left.extend(
                octree
                    .leaf_objects(leaf)
                    .iter()
                    .filter(|&&o| scene.object(o).is_none()),
            );
        }
        // The first stored copy of each wanted object.
        let mut take = |cell: CellObjects, left: &mut FxHashSet<ObjectId>| -> Result<()> {
            for (id, s) in cell.stored {
                if left.remove(&id) {
                    sink(id, s)?;
                }
            }
            Ok(())
        };
        cells.sort_unstable();
        cells.dedup();
        let entries = self
            .index
            .entries_of(&self.path, &file, self.file_len, &cells)?;
        for (&k, &e) in cells.iter().zip(&entries) {
            take(self.read_cell(&mut file, k as usize, e)?, &mut left)?;
        }
        drop(entries);
        if !self.copies && !left.is_empty() {
            // Stored once, in the first leaf (node order) listing them.
            let mut more = Vec::new();
            let mut unplaced = left.clone();
            for (k, (leaf, _)) in self.cells.iter().enumerate() {
                let ids = octree.leaf_objects(leaf);
                let mut needed = false;
                for o in ids {
                    if unplaced.remove(o) {
                        needed = true;
                    }
                }
                if needed {
                    more.push(k as u32);
                }
                if unplaced.is_empty() {
                    break;
                }
            }
            let entries = self
                .index
                .entries_of(&self.path, &file, self.file_len, &more)?;
            for (&k, &e) in more.iter().zip(&entries) {
                take(self.read_cell(&mut file, k as usize, e)?, &mut left)?;
            }
        }
        if let Some(missing) = left.iter().min() {
            return Err(file_error(
                &self.path,
                0,
                format!(
                    "{} of the objects these cells list are stored nowhere (object {missing})",
                    left.len(),
                ),
            ));
        }
        Ok(())
    }

    /// Cell `k`, whose entry is `e`.
    fn read_cell(&self, file: &mut std::fs::File, k: usize, e: CellEntry) -> Result<CellObjects> {
        let mut bytes = vec![0u8; e.len as usize];
        file.seek(SeekFrom::Start(e.offset))
            .and_then(|_| file.read_exact(&mut bytes))
            .map_err(|err| Error::io(&self.path, err))?;
        super::decode_cell(&self.path, k, e, &bytes)
    }
}
