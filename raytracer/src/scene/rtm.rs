//! Radiance compiled triangle meshes (`.rtm`, `FORMAT=Radiance_tmesh`, made
//! by `obj2mesh`), read the way Radiance's `readmesh.c` and `mesh.c` do.
//!
//! Layout after the information header: the format number
//! (`MESHMAGIC + objsize`, 2 bytes); the mesh cube (origin x, y, z and size,
//! as text strings); the (u,v) limits (4 reals: u min, u max, v min, v max);
//! the mesh octree (skipped here: we build our own structure); the stored
//! materials (binary object records, see [`super::radbin`]); the patch count
//! (4 bytes) and the patches. A patch holds up to 256 vertices (flags, then
//! 32-bit fixed-point positions within the cube, optional 32-bit encoded
//! normals, optional 32-bit fixed-point (u,v) within the limits), local
//! triangles (three 1-byte vertex indices) with one material or one per
//! triangle, joiner triangles (one vertex elsewhere, named by a 4-byte
//! vertex id `patch << 8 | index`) and double joiners (two vertices
//! elsewhere). Materials are 2-byte indices into the stored materials, -1
//! meaning the `mesh` primitive's own modifier.
//!
//! [`read_rtm`] flattens this into one vertex list (patches in file order)
//! and one triangle list (per patch: local, joiner, double joiner
//! triangles, in file order, with Radiance's vertex order).

#![cfg_attr(not(test), allow(dead_code))] // the builder wires these in

use std::path::Path;

use glam::DVec3;

use super::rad::RawPrim;
use super::radbin::{decode_dir, BinReader};
use crate::geometry::Aabb;
use crate::{Error, Result, SourceLoc};

/// `MESHMAGIC` in Radiance's `mesh.h` (the format number less `objsize`).
pub(crate) const MESH_MAGIC: i64 = 8 + 311;
/// The header's `FORMAT=` value.
pub(crate) const MESH_FORMAT: &str = "Radiance_tmesh";

const MT_V: i64 = 1;
const MT_N: i64 = 2;
const MT_UV: i64 = 4;

/// A decoded compiled mesh.
#[derive(Debug, Clone)]
pub(crate) struct RtmMesh {
    /// The stored modifiers, in file order (their loc: the `.rtm` path,
    /// line 0). Their modifiers are `void` or the name of another stored
    /// object.
    pub materials: Vec<RawPrim>,
    pub vertices: Vec<RtmVertex>,
    pub triangles: Vec<RtmTriangle>,
    /// The mesh cube (`origin` to `origin + size`): every vertex lies in it.
    pub bounds: Aabb,
    pub cube_origin: DVec3,
    pub cube_size: f64,
    /// `[[u min, v min], [u max, v max]]`.
    pub uv_limits: [[f64; 2]; 2],
    /// Information header lines (the command that made it, `FORMAT=`).
    pub header: Vec<String>,
    /// Number of patches in the file.
    pub patches: usize,
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct RtmVertex {
    pub p: DVec3,
    /// Unit normal, where the vertex has one.
    pub n: Option<DVec3>,
    pub uv: Option<[f64; 2]>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct RtmTriangle {
    /// Indices into [`RtmMesh::vertices`].
    pub v: [u32; 3],
    /// Index into [`RtmMesh::materials`]; `None` = the mesh primitive's own
    /// modifier.
    pub material: Option<u32>,
}

/// Reads a compiled mesh. `from` is where it was named (for the error if
/// it cannot be read).
pub(crate) fn read_rtm(path: &Path, from: Option<&SourceLoc>) -> Result<RtmMesh> {
    let data =
        crate::input::read_input(path, crate::input::MAX_INPUT_BYTES).map_err(|e| match from {
            Some(loc) => Error::parse(
                loc.clone(),
                format!("cannot read mesh file '{}': {e}", path.display()),
            ),
            None => Error::io(path, e),
        })?;
    parse_rtm(&data, path)
}

/// A triangle as stored: three vertex ids (`patch << 8 | index`), its
/// material index, and where it was read (for messages).
struct RawTri {
    vid: [i64; 3],
    mat: i64,
    at: usize,
}

/// Decodes a compiled mesh from its bytes; `path` is used in messages.
pub(crate) fn parse_rtm(data: &[u8], path: &Path) -> Result<RtmMesh> {
    let mut r = BinReader::new(data, path);
    let header = r.header(MESH_FORMAT)?;
    let objsize = r.magic(MESH_MAGIC, "mesh")?;
    let mut org = [0.0; 3];
    for (i, o) in org.iter_mut().enumerate() {
        *o = r.str_real(&format!("mesh cube origin {}", ["x", "y", "z"][i]))?;
    }
    let at = r.pos();
    let size = r.str_real("mesh cube size")?;
    if size <= 0.0 {
        return Err(r.error_at(at, format!("illegal mesh cube size {size}")));
    }
    // Written as u min, u max, v min, v max.
    let (u0, u1) = (r.flt("the (u,v) limits")?, r.flt("the (u,v) limits")?);
    let (v0, v1) = (r.flt("the (u,v) limits")?, r.flt("the (u,v) limits")?);
    let uvlim = [[u0, v0], [u1, v1]];
    // As checkmesh: (u,v) needs a non-empty range on both axes.
    let no_uv_bounds = u1 - u0 <= 1e-9 || v1 - v0 <= 1e-9;
    r.skip_tree(objsize, "mesh octree")?;
    let materials = r.scene(objsize)?;
    let nmats = materials.len();
    // Smallest patch: flags, count, one vertex, five 2-byte counts/indices.
    const MIN_PATCH: usize = 1 + 2 + 12 + 2 + 2 + 2 + 2 + 2;
    let npatches = r.count(4, 1 << 22, MIN_PATCH, "number of mesh patches")?;

    let origin = DVec3::from_array(org);
    let vres = size / 4294967296.0;
    let mut vertices: Vec<RtmVertex> = Vec::new();
    let mut base: Vec<(usize, usize)> = Vec::with_capacity(npatches); // (first vertex, count)
    let mut raw: Vec<RawTri> = Vec::new();
    for pn in 0..npatches as i64 {
        let at = r.pos();
        let flags = r.int(1, "patch flags")?;
        if flags & MT_V == 0 || flags & !(MT_V | MT_N | MT_UV) != 0 {
            return Err(r.error_at(at, format!("patch {pn}: bad patch flags {flags}")));
        }
        let at = r.pos();
        let nverts = r.int(2, "number of patch vertices")?;
        if !(1..=256).contains(&nverts) {
            return Err(r.error_at(
                at,
                format!("patch {pn}: bad number of patch vertices {nverts} (expected 1 to 256)"),
            ));
        }
        let nv = nverts as usize;
        if flags & MT_UV != 0 && no_uv_bounds {
            return Err(r.error_at(
                at,
                format!(
                    "patch {pn}: (u,v) coordinates but the mesh's (u,v) limits are empty \
                     (u {} to {}, v {} to {})",
                    uvlim[0][0], uvlim[1][0], uvlim[0][1], uvlim[1][1]
                ),
            ));
        }
        let first = vertices.len();
        for _ in 0..nv {
            let mut p = [0.0; 3];
            for (j, c) in p.iter_mut().enumerate() {
                *c = org[j] + (f64::from(r.u32("a vertex coordinate")?) + 0.5) * vres;
            }
            vertices.push(RtmVertex {
                p: DVec3::from_array(p),
                n: None,
                uv: None,
            });
        }
        if flags & MT_N != 0 {
            for v in &mut vertices[first..] {
                let code = r.u32("a vertex normal")?;
                v.n = (code != 0).then(|| decode_dir(code));
            }
        }
        if flags & MT_UV != 0 {
            for v in &mut vertices[first..] {
                let (a, b) = (r.u32("a vertex (u,v)")?, r.u32("a vertex (u,v)")?);
                if a != 0 {
                    let f = |i: usize, c: u32| {
                        uvlim[0][i]
                            + (uvlim[1][i] - uvlim[0][i]) * (f64::from(c) + 0.5) / 4294967296.0
                    };
                    v.uv = Some([f(0, a), f(1, b)]);
                }
            }
        }
        base.push((first, nv));
        let local = pn << 8;
        // Local triangles.
        let ntris = r.count(2, 512, 3, "number of local triangles")?;
        let first_tri = raw.len();
        for _ in 0..ntris {
            let at = r.pos();
            let b = r.bytes(3, "a local triangle")?;
            raw.push(RawTri {
                vid: [
                    local | i64::from(b[0]),
                    local | i64::from(b[1]),
                    local | i64::from(b[2]),
                ],
                mat: -1,
                at,
            });
        }
        // Their material(s): a count above 1 means one per triangle.
        if r.int(2, "the local triangle material count")? > 1 {
            for t in &mut raw[first_tri..] {
                t.mat = r.int(2, "a local triangle material")?;
            }
        } else {
            let m = r.int(2, "the patch material")?;
            for t in &mut raw[first_tri..] {
                t.mat = m;
            }
        }
        // Joiner triangles: one vertex in another patch.
        let nj1 = r.count(2, 512, 8, "number of joiner triangles")?;
        for _ in 0..nj1 {
            let at = r.pos();
            let v1 = r.int(4, "a joiner triangle")?;
            let b = r.bytes(2, "a joiner triangle")?;
            let (v2, v3) = (local | i64::from(b[0]), local | i64::from(b[1]));
            let mat = r.int(2, "a joiner triangle material")?;
            raw.push(RawTri {
                vid: [v1, v2, v3],
                mat,
                at,
            });
        }
        // Double joiners: two vertices in other patches.
        let nj2 = r.count(2, 256, 11, "number of double joiner triangles")?;
        for _ in 0..nj2 {
            let at = r.pos();
            let v1 = r.int(4, "a double joiner triangle")?;
            let v2 = r.int(4, "a double joiner triangle")?;
            let v3 = local | i64::from(r.byte("a double joiner triangle")?);
            let mat = r.int(2, "a double joiner triangle material")?;
            raw.push(RawTri {
                vid: [v1, v2, v3],
                mat,
                at,
            });
        }
    }
    if vertices.len() > u32::MAX as usize {
        return Err(r.error("too many vertices"));
    }
    let resolve = |vid: i64, at: usize| -> Result<u32> {
        let (pn, k) = (vid >> 8, (vid & 0xff) as usize);
        match usize::try_from(pn).ok().and_then(|pn| base.get(pn)) {
            Some(&(first, n)) if vid >= 0 && k < n => Ok((first + k) as u32),
            _ => Err(r.error_at(
                at,
                format!(
                    "triangle vertex id {vid} (patch {pn}, vertex {k}) names no vertex \
                     ({npatches} patches)"
                ),
            )),
        }
    };
    let mut triangles = Vec::with_capacity(raw.len());
    for t in &raw {
        let v = [
            resolve(t.vid[0], t.at)?,
            resolve(t.vid[1], t.at)?,
            resolve(t.vid[2], t.at)?,
        ];
        let material = match t.mat {
            -1 => None,
            m if m >= 0 && (m as usize) < nmats => Some(m as u32),
            m => {
                return Err(r.error_at(
                    t.at,
                    format!(
                        "triangle material index {m} is not one of the {nmats} stored materials"
                    ),
                ))
            }
        };
        triangles.push(RtmTriangle { v, material });
    }
    Ok(RtmMesh {
        materials,
        vertices,
        triangles,
        bounds: Aabb::new(origin, origin + DVec3::splat(size)),
        cube_origin: origin,
        cube_size: size,
        uv_limits: uvlim,
        header,
        patches: npatches,
    })
}
