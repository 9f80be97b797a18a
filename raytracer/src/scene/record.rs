//! A scene as the program that builds it: the top-level records of its
//! files in order, with the plain surfaces (polygons, spheres, cones,
//! cylinders, rings and their inward forms) taken out to be stored apart
//! (a compiled scene groups them by octree cell; see `crate::compiled`).
//!
//! [`record`] loads scene files as [`super::load_with`] does and returns,
//! beside the scene, its [`Program`] and its plain surfaces by object id;
//! [`replay`] interprets the program again, taking the surfaces back, and
//! makes the same scene: the same materials in the same order (the
//! modifiers a run of surfaces uses are looked up again where the run
//! stood, so materials made on first use are made at the same moment), the
//! same objects with the same ids, the same lights. Records that are not
//! plain surfaces (materials, patterns, aliases, `source`, `instance`,
//! `mesh`) stay in the program and are interpreted again: the files they
//! name (function files, data, pictures, instanced octrees) are read again
//! from where they were.
//!
//! Only Radiance inputs can be recorded: an OBJ file's faces are not
//! records, and a scene naming one is refused.

use std::path::Path;

use serde::{Deserialize, Serialize};

use super::build::{is_light_material, Builder, LoadOptions};
use super::model::{Light, LightKind, MaterialId, Object, ObjectId, Scene};
use super::rad::RawPrim;
use crate::geometry::Transform;
use crate::{Error, Result, SourceLoc};

/// The types of plain surfaces, as [`Surface::kind`] numbers them.
const KINDS: [&str; 8] = [
    "polygon", "sphere", "bubble", "cone", "cup", "cylinder", "tube", "ring",
];

/// One plain surface: what its record said (its reals exactly as read) and
/// the material it resolved to.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Surface {
    pub name: String,
    pub material: MaterialId,
    /// Index into the plain surface types: polygon, sphere, bubble, cone,
    /// cup, cylinder, tube, ring.
    pub kind: u8,
    pub reals: Vec<f64>,
}

impl Surface {
    /// The surface's type name (`polygon`, ...), `None` for an unknown kind.
    pub fn type_name(&self) -> Option<&'static str> {
        KINDS.get(self.kind as usize).copied()
    }
}

/// A record kept in the program, as the parser made it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Record {
    pub modifier: String,
    pub ptype: String,
    pub id: String,
    pub strs: Vec<String>,
    pub ints: Vec<String>,
    pub reals: Vec<f64>,
    pub loc: SourceLoc,
    /// An enclosing `!xform`'s transform of an `instance` or `mesh`:
    /// `to_world` and `to_object` (columns) and the scale.
    pub post: Option<(Vec<f64>, Vec<f64>, f64)>,
}

/// One step of a [`Program`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum Step {
    /// Interpret a record.
    Record(Box<Record>),
    /// Objects `first .. first + count` are plain surfaces, stored apart;
    /// `modifiers` are the modifier names they use, in order of first use,
    /// with the material each resolved to.
    Surfaces {
        first: ObjectId,
        count: u32,
        modifiers: Vec<(String, MaterialId)>,
    },
}

/// How to build a scene again, less its plain surfaces.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Program {
    pub steps: Vec<Step>,
    /// Objects of the scene (plain surfaces and instances).
    pub objects: u32,
}

fn to_record(p: &RawPrim) -> Record {
    Record {
        modifier: p.modifier.clone(),
        ptype: p.ptype.clone(),
        id: p.id.clone(),
        strs: p.strs.clone(),
        ints: p.ints.clone(),
        reals: p.reals.clone(),
        loc: p.loc.clone(),
        post: p.post.map(|t| {
            (
                t.to_world.to_cols_array().to_vec(),
                t.to_object.to_cols_array().to_vec(),
                t.scale,
            )
        }),
    }
}

fn from_record(r: &Record) -> Result<RawPrim> {
    let post = match &r.post {
        None => None,
        Some((w, o, scale)) => {
            let mat = |v: &[f64]| -> Result<glam::DMat4> {
                let a: [f64; 16] = v.try_into().map_err(|_| {
                    Error::parse(
                        r.loc.clone(),
                        format!("{} '{}': a transform of {} numbers", r.ptype, r.id, v.len()),
                    )
                })?;
                Ok(glam::DMat4::from_cols_array(&a))
            };
            Some(Transform {
                to_world: mat(w)?,
                to_object: mat(o)?,
                scale: *scale,
            })
        }
    };
    Ok(RawPrim {
        modifier: r.modifier.clone(),
        ptype: r.ptype.clone(),
        id: r.id.clone(),
        strs: r.strs.clone(),
        ints: r.ints.clone(),
        reals: r.reals.clone(),
        loc: r.loc.clone(),
        post,
    })
}

fn builder(options: &LoadOptions) -> Builder {
    let mut b = Builder::new();
    b.mods.search_path = options.search_path.clone();
    b.exp.search_path = options.search_path.clone();
    b
}

/// Loads Radiance scene files (`.rad` text, `.oct` octrees, `-` is not
/// allowed) as one scene and returns it with its program and its plain
/// surfaces by object id (`None` for instances).
pub fn record(
    paths: &[impl AsRef<Path>],
    options: &LoadOptions,
) -> Result<(Scene, Program, Vec<Option<Surface>>)> {
    let mut b = builder(options);
    b.record = Some(Vec::new());
    for p in paths {
        let p = p.as_ref();
        let ext = p
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase);
        match ext.as_deref() {
            _ if p == Path::new("-") => {
                return Err(Error::Usage(
                    "a compiled scene is made from files, not standard input".into(),
                ))
            }
            Some("obj") => {
                return Err(Error::parse(
                    SourceLoc::new(p, 0),
                    "OBJ files cannot be compiled (their faces are not Radiance records): convert them with obj2rad first",
                ))
            }
            Some("oct" | "octf") => b.add_octree_file(p)?,
            _ => b.add_rad_file(p)?,
        }
    }
    let prims = b.record.take().unwrap_or_default();
    let scene = b.finish()?;
    let (program, surfaces) = split(&prims, &scene)?;
    Ok((scene, program, surfaces))
}

/// Separates the plain surfaces from the other records.
fn split(prims: &[RawPrim], scene: &Scene) -> Result<(Program, Vec<Option<Surface>>)> {
    let mut steps = Vec::new();
    let mut surfaces: Vec<Option<Surface>> = Vec::with_capacity(scene.objects.len());
    let mismatch = |p: &RawPrim| {
        Error::parse(
            p.loc.clone(),
            format!(
                "{} '{}': the scene's objects do not follow its records (this input cannot be compiled)",
                p.ptype, p.id
            ),
        )
    };
    for p in prims {
        let next = surfaces.len() as ObjectId;
        if let Some(kind) = KINDS.iter().position(|k| *k == p.ptype) {
            let o = scene
                .objects
                .get(next as usize)
                .ok_or_else(|| mismatch(p))?;
            if o.name != p.id {
                return Err(mismatch(p));
            }
            surfaces.push(Some(Surface {
                name: p.id.clone(),
                material: o.material,
                kind: kind as u8,
                reals: p.reals.clone(),
            }));
            let pair = (p.modifier.clone(), o.material);
            match steps.last_mut() {
                Some(Step::Surfaces {
                    count, modifiers, ..
                }) => {
                    *count += 1;
                    if !modifiers.iter().any(|(m, _)| *m == pair.0) {
                        modifiers.push(pair);
                    }
                }
                _ => steps.push(Step::Surfaces {
                    first: next,
                    count: 1,
                    modifiers: vec![pair],
                }),
            }
        } else {
            if p.ptype == "instance" || p.ptype == "mesh" {
                let o = scene
                    .objects
                    .get(next as usize)
                    .ok_or_else(|| mismatch(p))?;
                if o.name != p.id {
                    return Err(mismatch(p));
                }
                surfaces.push(None);
            }
            steps.push(Step::Record(Box::new(to_record(p))));
        }
    }
    if surfaces.len() != scene.objects.len() {
        return Err(Error::Other(format!(
            "the scene has {} objects but its records make {}: it cannot be compiled",
            scene.objects.len(),
            surfaces.len()
        )));
    }
    let objects = surfaces.len() as u32;
    Ok((Program { steps, objects }, surfaces))
}

/// Builds the scene of `program` again; `surfaces[id]` is taken for every
/// plain surface. `file` names the compiled scene in messages.
pub fn replay(
    program: &Program,
    surfaces: Vec<Option<Surface>>,
    options: &LoadOptions,
    file: &Path,
) -> Result<Scene> {
    if surfaces.len() != program.objects as usize {
        return Err(Error::parse(
            SourceLoc::new(file, 0),
            format!(
                "{} objects stored, the scene program makes {}",
                surfaces.len(),
                program.objects
            ),
        ));
    }
    let mut surfaces = surfaces;
    replay_with(program, options, file, None, |id| {
        surfaces.get_mut(id as usize).and_then(Option::take)
    })
}

/// [`replay`] for a processor's part of a distributed scene: only the
/// plain surfaces in `held` (by id) are made; the others are left out, and
/// the scene is marked [`Scene::distributed`] with `elsewhere`, the
/// materials those surfaces use. A light source must be held.
pub fn replay_part(
    program: &Program,
    held: std::collections::BTreeMap<ObjectId, Surface>,
    elsewhere: &[MaterialId],
    options: &LoadOptions,
    file: &Path,
) -> Result<Scene> {
    let mut held = held;
    replay_with(program, options, file, Some(elsewhere), |id| {
        held.remove(&id)
    })
}

fn replay_with(
    program: &Program,
    options: &LoadOptions,
    file: &Path,
    elsewhere: Option<&[MaterialId]>,
    mut take: impl FnMut(ObjectId) -> Option<Surface>,
) -> Result<Scene> {
    let bad = |reason: String| Error::parse(SourceLoc::new(file, 0), reason);
    let mut b = builder(options);
    let mut objects: Vec<Object> = Vec::new();
    // A distributed scene's ids of `objects`; `next` is the id the program
    // is at (`objects.len()` for a whole scene).
    let mut ids: Vec<ObjectId> = Vec::new();
    let mut next: ObjectId = 0;
    for step in &program.steps {
        match step {
            Step::Record(r) => {
                let mut made = Vec::new();
                b.add_prim(&from_record(r)?, &mut made, true)?;
                if made.len() > 1 {
                    return Err(bad(format!("record '{}' made several objects", r.id)));
                }
                for o in made {
                    objects.push(o);
                    ids.push(next);
                    next += 1;
                }
            }
            Step::Surfaces {
                first,
                count,
                modifiers,
            } => {
                if *first != next {
                    return Err(bad(format!(
                        "surfaces stored from object {first}, the scene program is at object {next}"
                    )));
                }
                for (name, id) in modifiers {
                    let stub = RawPrim {
                        modifier: name.clone(),
                        ptype: "polygon".into(),
                        id: String::new(),
                        strs: Vec::new(),
                        ints: Vec::new(),
                        reals: Vec::new(),
                        loc: SourceLoc::new(file, 0),
                        post: None,
                    };
                    let got = b.surface_material(&stub)?;
                    if got != *id {
                        return Err(bad(format!(
                            "modifier '{name}' resolves to material {got}, the stored surfaces use {id}"
                        )));
                    }
                }
                let end = first.checked_add(*count).filter(|&e| e <= program.objects);
                let Some(end) = end else {
                    return Err(bad(format!(
                        "surfaces {first} + {count} lie beyond the {} objects",
                        program.objects
                    )));
                };
                for id in *first..end {
                    next = id + 1;
                    let s = match (take(id), elsewhere) {
                        (Some(s), _) => s,
                        (None, Some(_)) => continue,
                        (None, None) => {
                            return Err(bad(format!("object {id}: its surface is missing")))
                        }
                    };
                    let object = surface_object(&b, s, id, file)?;
                    let material = object.material;
                    objects.push(object);
                    ids.push(id);
                    if is_light_material(b.scene.material(material)) {
                        b.scene.lights.push(Light {
                            kind: LightKind::Area { object: id },
                            material,
                        });
                    }
                }
            }
        }
    }
    if next != program.objects {
        return Err(bad(format!(
            "the scene program made {next} objects, it should make {}",
            program.objects
        )));
    }
    b.scene.objects = objects;
    let mut scene = b.finish()?;
    if let Some(ms) = elsewhere {
        for &m in ms {
            match scene.materials.get(m as usize) {
                None => {
                    return Err(bad(format!(
                        "surfaces held elsewhere use material {m}, the scene has {}",
                        scene.materials.len()
                    )))
                }
                Some(mat) if is_light_material(mat) => {
                    return Err(bad(format!(
                        "surfaces of light source material {m} are not among the surfaces every processor holds"
                    )))
                }
                Some(_) => {}
            }
        }
        scene.stats.objects = program.objects as usize;
        scene.distributed = Some(super::model::Distributed {
            ids,
            total: program.objects as usize,
            elsewhere: ms.to_vec(),
        });
    }
    Ok(scene)
}

/// Makes stored surfaces into objects (through the loader's shape code, as
/// [`replay`] makes them) for a scene of a given number of materials.
pub struct SurfaceMaker {
    b: Builder,
    materials: usize,
    file: std::path::PathBuf,
}

impl std::fmt::Debug for SurfaceMaker {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SurfaceMaker")
            .field("materials", &self.materials)
            .field("file", &self.file)
            .finish()
    }
}

impl SurfaceMaker {
    /// For a scene of `materials` materials; `file` names it in messages.
    pub fn new(materials: usize, file: &Path) -> Self {
        SurfaceMaker {
            b: Builder::new(),
            materials,
            file: file.to_path_buf(),
        }
    }

    /// Object `id` from its stored surface.
    pub fn make(&self, id: ObjectId, s: Surface) -> Result<Object> {
        make_object(&self.b, self.materials, s, id, &self.file)
    }
}

/// A stored surface as an object, through the loader's own shape code.
fn surface_object(b: &Builder, s: Surface, id: ObjectId, file: &Path) -> Result<Object> {
    make_object(b, b.scene.materials.len(), s, id, file)
}

/// [`surface_object`] for a scene of `materials` materials.
fn make_object(
    b: &Builder,
    materials: usize,
    s: Surface,
    id: ObjectId,
    file: &Path,
) -> Result<Object> {
    let bad = |reason: String| Error::parse(SourceLoc::new(file, 0), reason);
    let ptype = s
        .type_name()
        .ok_or_else(|| bad(format!("object {id}: unknown surface kind {}", s.kind)))?;
    if s.material as usize >= materials {
        return Err(bad(format!(
            "object {id}: material {} of {materials}",
            s.material,
        )));
    }
    let p = RawPrim {
        modifier: String::new(),
        ptype: ptype.to_string(),
        id: s.name,
        strs: Vec::new(),
        ints: Vec::new(),
        reals: s.reals,
        loc: SourceLoc::new(file, 0),
        post: None,
    };
    let shape = b.primitive_shape(&p)?;
    Ok(Object {
        name: p.id,
        shape,
        material: s.material,
    })
}
