//! Turning raw Radiance primitives into a [`Scene`]: modifier lookup,
//! materials, shapes, instances, lights and statistics.
//!
//! Records are interpreted in order, as `oconv` does: a modifier must be
//! defined before it is used, a later definition of a name replaces the
//! earlier one for the records that follow, and several files form one scene
//! (later files may use earlier files' materials).

use std::collections::{HashMap, HashSet};
use std::path::{Path, PathBuf};
use std::sync::Arc;

use super::input::{read_input_text, MAX_INPUT_BYTES};
use super::model::*;
use super::modstate::ModState;
use super::obj::{clean_obj, convert_material, obj_error, MtlSource};
use super::rad::{Expander, RawPrim};
use super::xform::{is_surface, parse_instance_xf, PATTERNS};
use crate::geometry::shape::{InstanceGeometry, Shape};
use crate::geometry::Vec3;
use crate::modifier::ModifierId;
use crate::{Error, Result, SourceLoc};

/// What a modifier name stands for.
#[derive(Debug, Clone, PartialEq)]
pub(super) enum Mod {
    /// A material (its own patterns are in `Scene::material_mods`).
    Material(MaterialId),
    /// A pattern, texture or pattern mixture: the chain it starts (itself,
    /// then its modifier's chain, in application order) and the material
    /// that chain leads to, if any (a surface may name a pattern whose
    /// modifier is a material).
    Pattern {
        chain: Arc<[ModifierId]>,
        material: Option<MaterialId>,
    },
}

/// Builds a scene from raw primitives (and OBJ objects, see [`super::obj`]).
pub(crate) struct Builder {
    pub scene: Scene,
    pub(super) scope: HashMap<String, Mod>,
    void_id: Option<MaterialId>,
    default_id: Option<MaterialId>,
    pub exp: Expander,
    /// Instance geometry by source file (and material, for meshes).
    inst_cache: HashMap<(PathBuf, Option<MaterialId>), Arc<InstanceGeometry>>,
    inst_stack: Vec<PathBuf>,
    /// Vertex data of the mesh being loaded as instance geometry.
    pending_shading: Option<crate::geometry::shape::MeshShading>,
    /// Patterns, textures and mixtures, and what they load.
    pub(super) mods: ModState,
    /// Unsupported-type warnings by key: index into `scene.warnings` and count.
    grouped: HashMap<String, (usize, usize)>,
    /// When set, every top-level record interpreted is appended here, in
    /// order (see [`super::record`]).
    pub(super) record: Option<Vec<RawPrim>>,
}

impl Builder {
    pub fn new() -> Self {
        Self {
            scene: Scene::default(),
            scope: HashMap::new(),
            void_id: None,
            default_id: None,
            exp: Expander::with_search_path(LoadOptions::from_env().search_path),
            inst_cache: HashMap::new(),
            inst_stack: Vec::new(),
            pending_shading: None,
            mods: ModState::new(LoadOptions::from_env().search_path),
            grouped: HashMap::new(),
            record: None,
        }
    }

    /// A warning that repeats per object (an unsupported type): said once
    /// per `key`, with the number of times it applied.
    pub fn warn_once(&mut self, key: &str, loc: &SourceLoc, msg: impl Into<String>) {
        match self.grouped.get_mut(key) {
            Some((_, n)) => *n += 1,
            None => {
                self.grouped
                    .insert(key.to_string(), (self.scene.warnings.len(), 1));
                self.scene.warnings.push((loc.clone(), msg.into()));
            }
        }
    }

    pub fn warn(&mut self, loc: &SourceLoc, msg: impl Into<String>) {
        self.scene.warnings.push((loc.clone(), msg.into()));
    }

    pub(super) fn add_material(&mut self, name: &str, m: Material) -> MaterialId {
        let id = self.scene.materials.len() as MaterialId;
        self.scene.materials.push(m);
        self.scene.material_names.push(name.to_string());
        self.scene.material_mods.push(Vec::new());
        id
    }

    pub(super) fn void_material(&mut self) -> MaterialId {
        match self.void_id {
            Some(id) => id,
            None => {
                let id = self.add_material("void", Material::Void);
                self.void_id = Some(id);
                id
            }
        }
    }

    /// The grey plastic used where an OBJ face has no material.
    pub fn default_material(&mut self) -> MaterialId {
        match self.default_id {
            Some(id) => id,
            None => {
                let m = Material::Plastic {
                    color: Color::splat(0.5),
                    specularity: 0.0,
                    roughness: 0.0,
                };
                let id = self.add_material("default_grey", m);
                self.default_id = Some(id);
                id
            }
        }
    }

    /// Registers a material under `name` in the current scope (OBJ loader).
    pub fn define_material(&mut self, name: &str, m: Material) -> MaterialId {
        let id = self.add_material(name, m);
        self.scope.insert(name.to_string(), Mod::Material(id));
        self.scene.stats.materials += 1;
        id
    }

    /// Parses and adds a `.rad` file at top level.
    pub fn add_rad_file(&mut self, path: &Path) -> Result<()> {
        let mut prims = Vec::new();
        self.exp.parse_file(path, None, &mut prims)?;
        let mut objs = std::mem::take(&mut self.scene.objects);
        let r = self.add_prims(&prims, &mut objs, true);
        self.scene.objects = objs;
        r
    }

    /// Adds a Radiance octree at top level (its files or frozen objects).
    pub fn add_octree_file(&mut self, path: &Path) -> Result<()> {
        let p = RawPrim {
            modifier: "void".into(),
            ptype: "octree".into(),
            id: path.display().to_string(),
            strs: Vec::new(),
            ints: Vec::new(),
            reals: Vec::new(),
            loc: SourceLoc::new(path, 0),
            post: None,
        };
        let mut objs = std::mem::take(&mut self.scene.objects);
        let r = self.add_octree(&p, path, &mut objs, true);
        self.scene.objects = objs;
        r
    }

    /// Parses and adds scene text at top level.
    pub fn add_rad_text(&mut self, text: &str, name: &Path) -> Result<()> {
        let mut prims = Vec::new();
        self.exp.parse_text(text, name, &mut prims)?;
        let mut objs = std::mem::take(&mut self.scene.objects);
        let r = self.add_prims(&prims, &mut objs, true);
        self.scene.objects = objs;
        r
    }

    pub(super) fn lookup(&self, name: &str, loc: &SourceLoc, user: &RawPrim) -> Result<Mod> {
        self.scope.get(name).cloned().ok_or_else(|| {
            Error::parse(
                loc.clone(),
                format!(
                    "{} '{}': undefined modifier '{name}' (modifiers must be defined before use)",
                    user.ptype, user.id
                ),
            )
        })
    }

    /// The material a surface with modifier `name` is made of.
    pub(super) fn surface_material(&mut self, p: &RawPrim) -> Result<MaterialId> {
        if p.modifier == "void" {
            return Ok(self.void_material());
        }
        match self.lookup(&p.modifier, &p.loc, p)? {
            Mod::Material(id) => Ok(id),
            Mod::Pattern {
                chain,
                material: Some(id),
            } => Ok(self.patterned_material(&chain, id)),
            Mod::Pattern { material: None, .. } => Err(Error::parse(
                p.loc.clone(),
                format!(
                    "{} '{}': modifier '{}' is a pattern whose modifier chain leads to no material",
                    p.ptype, p.id, p.modifier
                ),
            )),
        }
    }

    /// Interprets raw primitives in order; surfaces go to `objects`. Lights
    /// are only collected at top level (`top`).
    pub fn add_prims(
        &mut self,
        prims: &[RawPrim],
        objects: &mut Vec<Object>,
        top: bool,
    ) -> Result<()> {
        if let (true, Some(record)) = (top, self.record.as_mut()) {
            record.extend_from_slice(prims);
        }
        for p in prims {
            self.add_prim(p, objects, top)?;
        }
        Ok(())
    }

    pub(super) fn add_prim(
        &mut self,
        p: &RawPrim,
        objects: &mut Vec<Object>,
        top: bool,
    ) -> Result<()> {
        let t = p.ptype.as_str();
        if t == "alias" {
            return self.add_alias(p);
        }
        if is_surface(t) {
            return self.add_surface(p, objects, top);
        }
        if PATTERNS.contains(&t) {
            return self.add_modifier(p);
        }
        let Some(m) = self.material(p)? else {
            return Err(Error::parse(
                p.loc.clone(),
                format!("unknown primitive type '{t}' (identifier '{}')", p.id),
            ));
        };
        self.check_material_values(p, &m)?;
        let chain = match p.modifier.as_str() {
            "void" => Vec::new(),
            name => match self.lookup(name, &p.loc, p)? {
                Mod::Material(_) => {
                    self.warn(
                        &p.loc,
                        format!("{t} '{}': its modifier '{name}' is a material, which has no effect here", p.id),
                    );
                    Vec::new()
                }
                Mod::Pattern { chain, material } => {
                    if material.is_some() {
                        self.warn(
                            &p.loc,
                            format!("{t} '{}': the patterns of its modifier '{name}' lead to a material, which has no effect here", p.id),
                        );
                    }
                    chain.to_vec()
                }
            },
        };
        let id = self.add_material(&p.id, m);
        self.scene.material_mods[id as usize] = chain;
        self.scene.stats.materials += 1;
        self.scope.insert(p.id.clone(), Mod::Material(id));
        Ok(())
    }

    /// `mod alias new old`: a copy of `old` whose modifier is `mod`
    /// (`inherit` keeps old's modifier, `void` leaves it without), as
    /// Radiance's readers resolve aliases.
    fn add_alias(&mut self, p: &RawPrim) -> Result<()> {
        let target = &p.strs[0];
        let old = if target == "void" {
            Mod::Material(self.void_material())
        } else {
            self.lookup(target, &p.loc, p)?
        };
        // The new modifier's chain (None: inherit).
        let new_chain: Option<(Vec<ModifierId>, Option<MaterialId>)> = match p.modifier.as_str() {
            "inherit" => None,
            "void" => Some((Vec::new(), None)),
            other => match self.lookup(other, &p.loc, p)? {
                Mod::Pattern { chain, material } => Some((chain.to_vec(), material)),
                Mod::Material(_) => {
                    self.warn(
                        &p.loc,
                        format!("alias '{}': its modifier '{other}' is a material, which has no effect here", p.id),
                    );
                    Some((Vec::new(), None))
                }
            },
        };
        let m = match (old, new_chain) {
            (m, None) => m,
            (Mod::Material(id), Some((chain, _))) => {
                if self.scene.material(id) == &Material::Void
                    || self.scene.mods(id) == chain.as_slice()
                {
                    // Nothing changes: the same material.
                    Mod::Material(id)
                } else {
                    let copy = self.scene.material(id).clone();
                    let nid = self.add_material(&p.id, copy);
                    self.scene.material_mods[nid as usize] = chain;
                    Mod::Material(nid)
                }
            }
            (
                Mod::Pattern {
                    chain: old_chain, ..
                },
                Some((chain, material)),
            ) => {
                // The pattern itself (none for an ignored spectral one),
                // then the new modifier's chain.
                let mut c: Vec<ModifierId> = old_chain.first().copied().into_iter().collect();
                c.extend(chain);
                Mod::Pattern {
                    chain: c.into(),
                    material,
                }
            }
        };
        self.scope.insert(p.id.clone(), m);
        Ok(())
    }

    /// Checks the string and integer argument counts of a material.
    fn counts(p: &RawPrim, strs: std::ops::RangeInclusive<usize>) -> Result<()> {
        if !strs.contains(&p.strs.len()) {
            let want = if strs.start() == strs.end() {
                strs.start().to_string()
            } else {
                format!("{strs:?}")
            };
            return Err(Error::parse(
                p.loc.clone(),
                format!(
                    "{} '{}': expected {want} string arguments, got {}",
                    p.ptype,
                    p.id,
                    p.strs.len()
                ),
            ));
        }
        Self::no_ints(p)
    }

    /// No Radiance primitive or material we read takes integer arguments.
    pub(super) fn no_ints(p: &RawPrim) -> Result<()> {
        if !p.ints.is_empty() {
            return Err(Error::parse(
                p.loc.clone(),
                format!(
                    "{} '{}': expected 0 integer arguments, got {}",
                    p.ptype,
                    p.id,
                    p.ints.len()
                ),
            ));
        }
        Ok(())
    }

    pub(super) fn reals(p: &RawPrim, allowed: &[usize], meaning: &str) -> Result<()> {
        if allowed.contains(&p.reals.len()) {
            return Ok(());
        }
        let want: Vec<String> = allowed.iter().map(|n| n.to_string()).collect();
        Err(Error::parse(
            p.loc.clone(),
            format!(
                "{} '{}': expected {} real arguments ({meaning}), got {}",
                p.ptype,
                p.id,
                want.join(" or "),
                p.reals.len()
            ),
        ))
    }

    /// The material a material record defines, `None` if `p` is not a material type.
    fn material(&mut self, p: &RawPrim) -> Result<Option<Material>> {
        let r = &p.reals;
        let rgb = |k: usize| Color::new(r[k], r[k + 1], r[k + 2]);
        let m = match p.ptype.as_str() {
            "plastic" | "metal" => {
                Self::counts(p, 0..=0)?;
                Self::reals(p, &[5], "red green blue specularity roughness")?;
                let (color, specularity, roughness) = (rgb(0), r[3], r[4]);
                if p.ptype == "plastic" {
                    Material::Plastic {
                        color,
                        specularity,
                        roughness,
                    }
                } else {
                    Material::Metal {
                        color,
                        specularity,
                        roughness,
                    }
                }
            }
            "trans" => {
                Self::counts(p, 0..=0)?;
                Self::reals(
                    p,
                    &[7],
                    "red green blue specularity roughness transmissivity transmitted_specular",
                )?;
                Material::Trans {
                    color: rgb(0),
                    specularity: r[3],
                    roughness: r[4],
                    transmissivity: r[5],
                    transmitted_specular: r[6],
                }
            }
            "glass" => {
                Self::counts(p, 0..=0)?;
                Self::reals(p, &[3, 4], "red green blue transmission [index]")?;
                Material::Glass {
                    transmission: rgb(0),
                    index: r.get(3).copied().unwrap_or(1.52),
                }
            }
            "dielectric" => {
                Self::counts(p, 0..=0)?;
                Self::reals(p, &[5], "red green blue index hartmann")?;
                Material::Dielectric {
                    transmission: rgb(0),
                    index: r[3],
                    hartmann: r[4],
                }
            }
            "mirror" => {
                Self::counts(p, 0..=1)?;
                Self::reals(p, &[3], "red green blue")?;
                let alternate = match p.strs.first().map(String::as_str) {
                    None => None,
                    Some("void") => Some(crate::scene::Alternate::Void),
                    Some(name) => Some(crate::scene::Alternate::Material(
                        self.named_material(name, p)?,
                    )),
                };
                Material::Mirror {
                    color: rgb(0),
                    alternate,
                }
            }
            "interface" => {
                Self::counts(p, 0..=0)?;
                Self::reals(p, &[8], "red1 green1 blue1 index1 red2 green2 blue2 index2")?;
                Material::Interface {
                    inside_transmission: rgb(0),
                    inside_index: r[3],
                    outside_transmission: rgb(4),
                    outside_index: r[7],
                }
            }
            "antimatter" => return self.antimatter(p).map(Some),
            "prism1" | "prism2" => {
                Self::no_ints(p)?;
                let projections = if p.ptype == "prism1" { 1 } else { 2 };
                let modifier = self.redirect_modifier(p, projections)?;
                Material::Prism {
                    modifier,
                    projections: projections as u8,
                }
            }
            "light" => {
                Self::counts(p, 0..=0)?;
                Self::reals(p, &[3], "red green blue radiance")?;
                Material::Light { radiance: rgb(0) }
            }
            "glow" => {
                Self::counts(p, 0..=0)?;
                Self::reals(p, &[4], "red green blue max_radius")?;
                Material::Glow {
                    radiance: rgb(0),
                    max_radius: r[3],
                }
            }
            "illum" => {
                Self::counts(p, 0..=1)?;
                Self::reals(p, &[3], "red green blue radiance")?;
                let alternate = match p.strs.first().map(String::as_str) {
                    None | Some("void") => None,
                    Some(name) => Some(match self.lookup(name, &p.loc, p)? {
                        Mod::Material(id) => id,
                        Mod::Pattern {
                            chain,
                            material: Some(id),
                        } => self.patterned_material(&chain, id),
                        Mod::Pattern { material: None, .. } => {
                            return Err(Error::parse(
                                p.loc.clone(),
                                format!(
                                    "illum '{}': alternate '{name}' leads to no material",
                                    p.id
                                ),
                            ))
                        }
                    }),
                };
                Material::Illum {
                    radiance: rgb(0),
                    alternate,
                }
            }
            "spotlight" => {
                Self::counts(p, 0..=0)?;
                Self::reals(p, &[7], "red green blue angle xdir ydir zdir")?;
                if !(r[3] > 0.0 && r[3] <= 360.0) {
                    return Err(Error::parse(
                        p.loc.clone(),
                        format!(
                            "spotlight '{}': cone angle {} must be in (0, 360] degrees",
                            p.id, r[3]
                        ),
                    ));
                }
                let direction = Vec3::new(r[4], r[5], r[6]);
                // makespot(): the vector's length is the focal length.
                if !(direction.length() > 0.0 && direction.is_finite()) {
                    return Err(Error::parse(
                        p.loc.clone(),
                        format!("spotlight '{}': zero focus vector", p.id),
                    ));
                }
                Material::Spotlight {
                    radiance: rgb(0),
                    angle_deg: r[3],
                    direction,
                }
            }
            "mist" => {
                Self::counts(p, 0..=crate::scene::MAX_MIST_SOURCES)?;
                Self::reals(
                    p,
                    &[0, 3, 6, 7],
                    "[ext_r ext_g ext_b [albedo_r albedo_g albedo_b [eccentricity]]]",
                )?;
                if r.iter().any(|v| !v.is_finite())
                    || r.iter().take(6).any(|&v| v < 0.0)
                    || r.get(6).is_some_and(|g| !(-1.0..=1.0).contains(g))
                {
                    return Err(Error::parse(
                        p.loc.clone(),
                        format!(
                            "mist '{}': extinction and albedo must be finite and not negative, the eccentricity in [-1, 1]",
                            p.id
                        ),
                    ));
                }
                Material::Mist {
                    extinction: if r.len() >= 3 { rgb(0) } else { Color::ZERO },
                    albedo: (r.len() >= 6).then(|| rgb(3)),
                    gecc: r.get(6).copied(),
                    sources: p.strs.clone(),
                }
            }
            "plastic2" | "metal2" | "trans2" => {
                Self::no_ints(p)?;
                let (kind, n, meaning) = match p.ptype.as_str() {
                    "plastic2" => (AnisoKind::Plastic2, 6, "red green blue specularity u_roughness v_roughness"),
                    "metal2" => (AnisoKind::Metal2, 6, "red green blue specularity u_roughness v_roughness"),
                    _ => (AnisoKind::Trans2, 8, "red green blue specularity u_roughness v_roughness transmissivity transmitted_specular"),
                };
                Self::reals(p, &[n], meaning)?;
                // aniso.c refuses these ("roughness too small"): the
                // Gaussian has no specular limit.
                if !(r[4] > crate::geometry::FTINY && r[5] > crate::geometry::FTINY) {
                    return Err(Error::parse(
                        p.loc.clone(),
                        format!(
                            "{} '{}': roughness too small (u {} and v {} must both exceed 1e-6; use {} for a perfectly smooth surface)",
                            p.ptype,
                            p.id,
                            r[4],
                            r[5],
                            if kind == AnisoKind::Trans2 { "trans" } else { "plastic or metal with roughness 0" }
                        ),
                    ));
                }
                let direction = self.aniso_direction(p)?;
                let r = &p.reals;
                Material::Aniso {
                    kind,
                    color: Color::new(r[0], r[1], r[2]),
                    specularity: r[3],
                    u_rough: r[4],
                    v_rough: r[5],
                    transmissivity: r.get(6).copied().unwrap_or(0.0),
                    transmitted_specular: r.get(7).copied().unwrap_or(0.0),
                    direction,
                }
            }
            "ashik2" => {
                Self::no_ints(p)?;
                Self::reals(
                    p,
                    &[8],
                    "diffuse red green blue, specular red green blue, u_power v_power",
                )?;
                if !(r[6] >= 0.0 && r[7] >= 0.0 && r[6].is_finite() && r[7].is_finite()) {
                    return Err(Error::parse(
                        p.loc.clone(),
                        format!(
                            "ashik2 '{}': specular powers {} and {} must be finite and not negative",
                            p.id, r[6], r[7]
                        ),
                    ));
                }
                let direction = self.aniso_direction(p)?;
                let r = &p.reals;
                Material::Ashik {
                    diffuse: Color::new(r[0], r[1], r[2]),
                    specular: Color::new(r[3], r[4], r[5]),
                    u_power: r[6],
                    v_power: r[7],
                    direction,
                }
            }
            "BRTDfunc" => self.brtd_material(p)?,
            "BSDF" | "aBSDF" => self.bsdf_material(p)?,
            "plasfunc" | "metfunc" | "transfunc" | "plasdata" | "metdata" | "transdata" => {
                self.brdf_func_material(p)?
            }
            other => return self.substitute(p, other),
        };
        Ok(Some(m))
    }

    /// The material named `name` in a material's string arguments (a
    /// pattern chain leading to a material gives that patterned material).
    fn named_material(&mut self, name: &str, p: &RawPrim) -> Result<MaterialId> {
        match self.lookup(name, &p.loc, p)? {
            Mod::Material(id) => Ok(id),
            Mod::Pattern {
                chain,
                material: Some(id),
            } => Ok(self.patterned_material(&chain, id)),
            Mod::Pattern { material: None, .. } => Err(Error::parse(
                p.loc.clone(),
                format!(
                    "{} '{}': modifier '{name}' leads to no material",
                    p.ptype, p.id
                ),
            )),
        }
    }

    /// `antimatter`: one or more modifiers whose surfaces it clips; the
    /// first (unless `void`) shades where a ray leaves it into their volume.
    fn antimatter(&mut self, p: &RawPrim) -> Result<Material> {
        Self::counts(p, 1..=64)?;
        Self::reals(p, &[0], "none")?;
        let mut clips = 0u64;
        let mut shade = None;
        for (k, name) in p.strs.iter().enumerate() {
            if name == "void" {
                continue;
            }
            if !self.scope.contains_key(name.as_str()) {
                // m_clip.c: an unknown modifier is a warning and skipped.
                self.warn(
                    &p.loc,
                    format!("antimatter '{}': unknown modifier '{name}' ignored", p.id),
                );
                continue;
            }
            let id = self.named_material(name, p)?;
            if k == 0 {
                shade = Some(id);
            }
            if self.scene.clip_bits.len() <= id as usize {
                self.scene.clip_bits.resize(id as usize + 1, 0);
            }
            let mut bit = self.scene.clip_bits[id as usize];
            if bit == 0 {
                let used = self.scene.clip_bits.iter().fold(0u64, |a, b| a | b);
                if used == u64::MAX {
                    return Err(Error::parse(
                        p.loc.clone(),
                        format!(
                            "antimatter '{}': more than 64 materials clipped in one scene",
                            p.id
                        ),
                    ));
                }
                bit = 1u64 << used.count_ones();
                self.scene.clip_bits[id as usize] = bit;
            }
            clips |= bit;
        }
        Ok(Material::Antimatter { clips, shade })
    }

    /// Materials we do not simulate: a stand-in and a warning saying which.
    fn substitute(&mut self, p: &RawPrim, t: &str) -> Result<Option<Material>> {
        let (m, what) = match t {
            "WGMDfunc" => (
                Material::Plastic {
                    color: Color::splat(0.5),
                    specularity: 0.0,
                    roughness: 0.0,
                },
                "grey plastic (reflectance 0.5)",
            ),
            _ => return Ok(None),
        };
        self.warn_once(
            t,
            &p.loc,
            format!(
                "material type {t} ('{}') is not supported yet; rendered as {what}",
                p.id
            ),
        );
        Ok(Some(m))
    }

    /// Values outside physical sense: an index of refraction that is not
    /// positive is an error (the refraction maths divides by it);
    /// negative reflectances, transmissions, specularities and roughnesses
    /// are warned about (Radiance accepts them, with results that are not
    /// physical).
    fn check_material_values(&mut self, p: &RawPrim, m: &Material) -> Result<()> {
        let (indices, values): (Vec<f64>, Vec<f64>) = match *m {
            Material::Glass {
                transmission,
                index,
            } => (vec![index], transmission.to_array().to_vec()),
            Material::Dielectric {
                transmission,
                index,
                ..
            } => (vec![index], transmission.to_array().to_vec()),
            Material::Interface {
                inside_transmission,
                inside_index,
                outside_transmission,
                outside_index,
            } => {
                let mut v = inside_transmission.to_array().to_vec();
                v.extend(outside_transmission.to_array());
                (vec![inside_index, outside_index], v)
            }
            Material::Plastic {
                color,
                specularity,
                roughness,
            }
            | Material::Metal {
                color,
                specularity,
                roughness,
            } => {
                let mut v = color.to_array().to_vec();
                v.extend([specularity, roughness]);
                (Vec::new(), v)
            }
            Material::Trans {
                color,
                specularity,
                roughness,
                transmissivity,
                transmitted_specular,
            } => {
                let mut v = color.to_array().to_vec();
                v.extend([specularity, roughness, transmissivity, transmitted_specular]);
                (Vec::new(), v)
            }
            Material::Mirror { color, .. } => (Vec::new(), color.to_array().to_vec()),
            _ => return Ok(()),
        };
        if let Some(&n) = indices.iter().find(|&&n| !(n > 0.0 && n.is_finite())) {
            return Err(Error::parse(
                p.loc.clone(),
                format!(
                    "{} '{}': index of refraction {n} must be positive",
                    p.ptype, p.id
                ),
            ));
        }
        if let Some(&x) = values.iter().find(|&&x| x < 0.0) {
            self.warn(
                &p.loc,
                format!(
                    "{} '{}': negative value {x} (a reflectance, transmission, specularity or roughness) is not physical",
                    p.ptype, p.id
                ),
            );
        }
        Ok(())
    }

    fn geometry_error(p: &RawPrim, reason: String) -> Error {
        Error::Geometry {
            loc: p.loc.clone(),
            reason: format!("{} '{}': {reason}", p.ptype, p.id),
        }
    }

    fn add_surface(&mut self, p: &RawPrim, objects: &mut Vec<Object>, top: bool) -> Result<()> {
        Self::no_ints(p)?;
        let material = self.surface_material(p)?;
        let t = p.ptype.as_str();
        if t == "source" {
            return self.add_source(p, material, top);
        }
        if t != "instance" && t != "mesh" && !p.strs.is_empty() {
            return Err(Error::parse(
                p.loc.clone(),
                format!(
                    "{t} '{}': expected 0 string arguments, got {}",
                    p.id,
                    p.strs.len()
                ),
            ));
        }
        let shape = if t == "instance" || t == "mesh" {
            self.instance_shape(p, material)?
        } else {
            self.primitive_shape(p)?
        };
        self.push_object(p, objects, top, shape, material);
        Ok(())
    }

    pub(super) fn primitive_shape(&self, p: &RawPrim) -> Result<Shape> {
        let t = p.ptype.as_str();
        let r = &p.reals;
        let v = |k: usize| Vec3::new(r[k], r[k + 1], r[k + 2]);
        // Coordinates and radii whose squares (and their products) stay
        // finite: a sphere of radius 1e308 cannot be intersected.
        const LIMIT: f64 = 1e30;
        if let Some(&x) = r.iter().find(|x| !x.is_finite() || x.abs() >= LIMIT) {
            return Err(Self::geometry_error(
                p,
                format!("argument {x:e} is out of range (coordinates and sizes must be below {LIMIT:e} in magnitude)"),
            ));
        }
        match t {
            "polygon" => {
                if r.len() % 3 != 0 || r.len() < 9 {
                    return Err(Error::parse(
                        p.loc.clone(),
                        format!(
                            "polygon '{}': expected a multiple of 3 real arguments (at least 9: three vertices), got {}",
                            p.id,
                            r.len()
                        ),
                    ));
                }
                let verts = (0..r.len() / 3).map(|k| v(3 * k)).collect();
                Shape::polygon(verts)
            }
            "sphere" | "bubble" => {
                Self::reals(p, &[4], "xcent ycent zcent radius")?;
                Shape::sphere(v(0), r[3], t == "bubble")
            }
            "cone" | "cup" => {
                Self::reals(p, &[8], "x0 y0 z0 x1 y1 z1 r0 r1")?;
                Shape::cone(v(0), v(3), r[6], r[7], t == "cup")
            }
            "cylinder" | "tube" => {
                Self::reals(p, &[7], "x0 y0 z0 x1 y1 z1 radius")?;
                Shape::cone(v(0), v(3), r[6], r[6], t == "tube")
            }
            "ring" => {
                Self::reals(p, &[8], "xcent ycent zcent xdir ydir zdir r_inner r_outer")?;
                Shape::ring(v(0), v(3), r[6], r[7])
            }
            _ => Err(format!("not a primitive shape type: {t}")),
        }
        .map_err(|reason| Self::geometry_error(p, reason))
    }

    fn push_object(
        &mut self,
        p: &RawPrim,
        objects: &mut Vec<Object>,
        top: bool,
        shape: Shape,
        material: MaterialId,
    ) {
        let t = p.ptype.as_str();
        let id = objects.len() as ObjectId;
        objects.push(Object {
            name: p.id.clone(),
            shape,
            material,
        });
        let is_light = is_light_material(self.scene.material(material));
        if is_light && t != "instance" && t != "mesh" {
            if top {
                self.scene.lights.push(Light {
                    kind: LightKind::Area { object: id },
                    material,
                });
            } else {
                self.warn_once(
                    "instanced emitter",
                    &p.loc,
                    format!(
                        "{t} '{}': emitting surfaces inside instanced geometry are not sampled as light sources",
                        p.id
                    ),
                );
            }
        }
    }

    fn add_source(&mut self, p: &RawPrim, material: MaterialId, top: bool) -> Result<()> {
        if !p.strs.is_empty() {
            return Err(Error::parse(
                p.loc.clone(),
                format!(
                    "source '{}': expected 0 string arguments, got {}",
                    p.id,
                    p.strs.len()
                ),
            ));
        }
        Self::reals(p, &[4], "xdir ydir zdir angle")?;
        let r = &p.reals;
        let dir = Vec3::new(r[0], r[1], r[2]);
        if dir.length() == 0.0 || !dir.length().is_finite() {
            return Err(Self::geometry_error(p, "direction is zero".into()));
        }
        if !(r[3] > 0.0 && r[3] <= 180.0) {
            return Err(Self::geometry_error(
                p,
                format!("angle {} must be in (0, 180] degrees", r[3]),
            ));
        }
        if !self.scene.material(material).is_emitter() {
            return Err(Error::parse(
                p.loc.clone(),
                format!(
                    "source '{}': modifier '{}' is not a light, glow, illum or spotlight material",
                    p.id, p.modifier
                ),
            ));
        }
        if !top {
            self.warn_once(
                "instanced source",
                &p.loc,
                format!("source '{}' inside instanced geometry is ignored", p.id),
            );
            return Ok(());
        }
        let half = (r[3] * 0.5).to_radians();
        let solid_angle = 2.0 * std::f64::consts::PI * (1.0 - half.cos());
        self.scene.lights.push(Light {
            kind: LightKind::Distant {
                dir: dir.normalize(),
                solid_angle,
                name: p.id.clone(),
            },
            material,
        });
        Ok(())
    }

    /// `instance` (of an octree, loaded from its `.rad` source) or `mesh`
    /// (of an `.rtm`, loaded from a sibling `.obj`), with the transform from
    /// its string arguments followed by any enclosing `!xform`.
    fn instance_shape(&mut self, p: &RawPrim, material: MaterialId) -> Result<Shape> {
        let t = p.ptype.as_str();
        let Some(file) = p.strs.first() else {
            return Err(Error::parse(
                p.loc.clone(),
                format!(
                    "{t} '{}': expected the {} file name as first string argument",
                    p.id,
                    if t == "mesh" { "mesh" } else { "octree" }
                ),
            ));
        };
        // Beside the scene file, else along the search path (Radiance's
        // getpath with RAYPATH).
        let named = match p.base_dir().join(file) {
            n if n.exists() => n,
            n => self.mods.find(file, &p.base_dir()).unwrap_or(n),
        };
        // Radiance's own files first (a compiled mesh, an octree), then a
        // source of the same name beside it (an .obj, a .rad).
        let ext = named
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase);
        let native = match (t, ext.as_deref()) {
            ("mesh", Some("rtm")) | ("instance", Some("oct" | "octf")) => named.is_file(),
            _ => false,
        };
        let (source, want) = if native {
            (named.clone(), "")
        } else if t == "instance" {
            (named.with_extension("rad"), "rad")
        } else {
            (named.with_extension("obj"), "obj")
        };
        let ext_ok = native
            || match ext.as_deref() {
                Some("oct" | "octf") => t == "instance",
                Some("rtm") => t == "mesh",
                Some(e) => e == want,
                None => false,
            };
        if !ext_ok || !source.is_file() {
            let kind = if t == "instance" {
                "an octree"
            } else {
                "a compiled mesh"
            };
            return Err(Error::parse(
                p.loc.clone(),
                format!(
                    "{t} '{}': cannot read {kind} '{}': the file is missing, and so is its source '{}' beside it",
                    p.id,
                    named.display(),
                    source.file_name().map(|f| f.to_string_lossy().into_owned()).unwrap_or_default(),
                ),
            ));
        }
        let xf = parse_instance_xf(&p.strs[1..], &p.loc)
            .map_err(|e| retag(e, &format!("{t} '{}': ", p.id)))?
            .then(&p.post.unwrap_or_default());
        let key = std::fs::canonicalize(&source).unwrap_or_else(|_| source.clone());
        let cache_key = (key.clone(), if t == "mesh" { Some(material) } else { None });
        let geometry = match self.inst_cache.get(&cache_key) {
            Some(g) => g.clone(),
            None => {
                if self.inst_stack.contains(&key) {
                    return Err(Error::parse(
                        p.loc.clone(),
                        format!(
                            "{t} '{}': '{}' instances itself (instance cycle)",
                            p.id,
                            source.display()
                        ),
                    ));
                }
                self.inst_stack.push(key);
                let r = self.load_instance_geometry(p, &source, material);
                self.inst_stack.pop();
                let g = Arc::new(r?);
                self.inst_cache.insert(cache_key, g.clone());
                g
            }
        };
        Shape::instance(geometry, xf).map_err(|reason| Self::geometry_error(p, reason))
    }

    fn load_instance_geometry(
        &mut self,
        p: &RawPrim,
        source: &Path,
        material: MaterialId,
    ) -> Result<InstanceGeometry> {
        let saved = std::mem::take(&mut self.scope);
        let mut objects = Vec::new();
        let native = source
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase);
        // An instance's modifier, when not void, overrides the materials inside.
        let overriding = (Some(material) != self.void_id).then_some(material);
        let r = match native.as_deref() {
            Some("rtm") if p.ptype == "mesh" => self.add_rtm(p, source, overriding, &mut objects),
            Some("oct" | "octf") if p.ptype == "instance" => {
                self.add_octree(p, source, &mut objects, false)
            }
            _ if p.ptype == "mesh" => {
                load_obj_into(self, source, overriding, Some(&p.loc), &mut objects)
            }
            _ => {
                let mut prims = Vec::new();
                self.exp
                    .parse_file(source, Some(&p.loc), &mut prims)
                    .and_then(|()| self.add_prims(&prims, &mut objects, false))
            }
        };
        if r.is_ok() && p.ptype == "instance" {
            if let Some(m) = overriding {
                for o in &mut objects {
                    o.material = m;
                }
            }
        }
        self.scope = saved;
        r?;
        if objects.is_empty() {
            return Err(Error::parse(
                p.loc.clone(),
                format!(
                    "{} '{}': '{}' contains no surfaces",
                    p.ptype,
                    p.id,
                    source.display()
                ),
            ));
        }
        let mut g = InstanceGeometry::new(source.display().to_string(), objects);
        g.shading = self.pending_shading.take().map(Arc::new);
        g.modified_instances = (0..g.objects.len() as u32)
            .filter(|&i| {
                let o = &g.objects[i as usize];
                matches!(o.shape, Shape::Instance(_)) && Some(o.material) != self.void_id
            })
            .collect();
        Ok(g)
    }

    /// A Radiance compiled mesh: its stored materials (unless `overriding`)
    /// and its triangles.
    fn add_rtm(
        &mut self,
        p: &RawPrim,
        path: &Path,
        overriding: Option<MaterialId>,
        objects: &mut Vec<Object>,
    ) -> Result<()> {
        let mesh = super::rtm::read_rtm(path, Some(&p.loc))?;
        self.exp.reserve(mesh.triangles.len(), &p.loc)?;
        let mut mats: Vec<Option<MaterialId>> = Vec::with_capacity(mesh.materials.len());
        if overriding.is_none() {
            let mut none = Vec::new();
            for m in &mesh.materials {
                self.add_prim(m, &mut none, false)?;
                mats.push(match self.scope.get(&m.id) {
                    Some(Mod::Material(id)) => Some(*id),
                    Some(Mod::Pattern {
                        chain,
                        material: Some(id),
                    }) => {
                        let (chain, id) = (chain.clone(), *id);
                        Some(self.patterned_material(&chain, id))
                    }
                    _ => None,
                });
            }
        }
        let own = match overriding {
            Some(m) => m,
            None => self.void_material(),
        };
        let smooth = mesh.vertices.iter().all(|v| v.n.is_some());
        let mapped = mesh.vertices.iter().all(|v| v.uv.is_some());
        let mut shading = crate::geometry::shape::MeshShading {
            triangles: Vec::with_capacity(mesh.triangles.len()),
            positions: mesh.vertices.iter().map(|v| v.p).collect(),
            normals: smooth.then(|| {
                mesh.vertices
                    .iter()
                    .map(|v| v.n.unwrap_or_default())
                    .collect()
            }),
            uv: mapped.then(|| {
                mesh.vertices
                    .iter()
                    .map(|v| v.uv.unwrap_or_default())
                    .collect()
            }),
        };
        for (k, tri) in mesh.triangles.iter().enumerate() {
            let material = match (overriding, tri.material) {
                (Some(m), _) => m,
                (None, Some(i)) => mats.get(i as usize).copied().flatten().unwrap_or(own),
                (None, None) => own,
            };
            let v = tri.v.map(|i| mesh.vertices[i as usize].p);
            // Degenerate triangles (zero area) are skipped, as Radiance's
            // mesh intersection never reports them.
            let Ok(shape) = Shape::polygon(v.to_vec()) else {
                continue;
            };
            objects.push(Object {
                name: format!("{}.{k}", p.id),
                shape,
                material,
            });
            shading.triangles.push(tri.v);
        }
        if smooth || mapped {
            self.pending_shading = Some(shading);
        }
        Ok(())
    }

    /// The octree's objects, at top level (its lights sampled) or as an
    /// instance's geometry.
    fn add_octree(
        &mut self,
        p: &RawPrim,
        path: &Path,
        objects: &mut Vec<Object>,
        top: bool,
    ) -> Result<()> {
        let prims = self.octree_prims(p, path)?;
        self.add_prims(&prims, objects, top)
    }

    /// A Radiance octree: the scene files it lists (read as text, relative
    /// to the octree's folder) or the objects a frozen octree stores.
    fn octree_prims(&mut self, p: &RawPrim, path: &Path) -> Result<Vec<RawPrim>> {
        let prims = match super::octfile::read_octree(path, Some(&p.loc))? {
            super::octfile::OctreeContents::Frozen(prims) => prims,
            super::octfile::OctreeContents::Files(names) => {
                let dir = super::rad::base_dir_of(path);
                let loc = SourceLoc::new(path, 0);
                let mut prims = Vec::new();
                for n in names {
                    if let Some(cmd) = n.strip_prefix('!') {
                        let text = format!("!{cmd}\n");
                        self.exp
                            .parse_text(&text, &dir.join("octree-command"), &mut prims)?;
                    } else {
                        self.exp.parse_file(&dir.join(&n), Some(&loc), &mut prims)?;
                    }
                }
                prims
            }
        };
        Ok(prims)
    }

    /// Loads an OBJ file at top level; its emitting faces become area lights.
    pub fn add_obj_file(&mut self, path: &Path) -> Result<()> {
        self.add_obj_with(|b, objs| load_obj_into(b, path, None, None, objs))
    }

    /// Loads OBJ text held in memory at top level; every `mtllib` it names
    /// reads `mtl` (none: a missing library).
    pub fn add_obj_text(&mut self, text: &str, path: &Path, mtl: Option<&str>) -> Result<()> {
        let source = |_: &str| Ok(mtl.map(|t| (path.with_extension("mtl"), t.to_string())));
        self.add_obj_with(|b, objs| load_obj_text(b, text, path, &source, None, objs))
    }

    fn add_obj_with(
        &mut self,
        load: impl FnOnce(&mut Self, &mut Vec<Object>) -> Result<()>,
    ) -> Result<()> {
        let mut objs = std::mem::take(&mut self.scene.objects);
        let start = objs.len();
        let r = load(self, &mut objs);
        for (k, o) in objs.iter().enumerate().skip(start) {
            if is_light_material(self.scene.material(o.material)) {
                self.scene.lights.push(Light {
                    kind: LightKind::Area {
                        object: k as ObjectId,
                    },
                    material: o.material,
                });
            }
        }
        self.scene.objects = objs;
        r
    }

    /// Fills in the statistics and hands over the scene.
    pub fn finish(mut self) -> Result<Scene> {
        for (idx, n) in self.grouped.values() {
            if *n > 1 {
                self.scene.warnings[*idx].1 += &format!(" ({n} primitives like this one)");
            }
        }
        let patterns = std::mem::take(&mut self.mods).finish()?;
        self.scene.patterns = Arc::new(patterns);
        let mut seen = HashSet::new();
        let mut primitives = 0;
        let mut instances = 0;
        count(
            &self.scene.objects,
            &mut seen,
            &mut primitives,
            &mut instances,
            1,
        );
        self.scene.stats.objects = self.scene.objects.len();
        self.scene.stats.primitives = primitives;
        self.scene.stats.instances = instances;
        Ok(self.scene)
    }
}

/// Counts primitives (each shared geometry once) and instance references
/// (every placement, nested ones multiplied out).
fn count(
    objects: &[Object],
    seen: &mut HashSet<*const InstanceGeometry>,
    primitives: &mut usize,
    instances: &mut usize,
    mult: usize,
) {
    for o in objects {
        match &o.shape {
            Shape::Instance(inst) => {
                *instances += mult;
                let g = Arc::as_ptr(&inst.geometry);
                let first = seen.insert(g);
                let mut prims = 0;
                count(&inst.geometry.objects, seen, &mut prims, instances, mult);
                if first {
                    *primitives += prims;
                }
            }
            _ => *primitives += 1,
        }
    }
}

/// Surfaces of these materials are sampled as area lights: light, illum,
/// spotlight, and glow with a positive radius of influence.
pub(crate) fn is_light_material(m: &Material) -> bool {
    match m {
        Material::Light { .. } | Material::Illum { .. } | Material::Spotlight { .. } => true,
        Material::Glow { max_radius, .. } => *max_radius > 0.0,
        _ => false,
    }
}

/// Prefixes the reason of a parse error.
fn retag(e: Error, prefix: &str) -> Error {
    match e {
        Error::Parse { loc, reason } => Error::Parse {
            loc,
            reason: format!("{prefix}{reason}"),
        },
        other => other,
    }
}

/// How scene files are read.
#[derive(Debug, Clone, Default)]
pub struct LoadOptions {
    /// Where `.cal`, data, picture and font files are searched after the
    /// naming file's folder (Radiance's `RAYPATH`).
    pub search_path: Vec<std::path::PathBuf>,
}

impl LoadOptions {
    /// The search path from the `RAYPATH` environment variable.
    pub fn from_env() -> Self {
        Self {
            search_path: std::env::var_os("RAYPATH")
                .map(|v| std::env::split_paths(&v).collect())
                .unwrap_or_default(),
        }
    }
}

/// Loads an OBJ file's faces into `objects`. Faces without a material get
/// `default` (when `None`, a grey plastic with a warning). `from` is where a
/// scene file named it (a Radiance `mesh`), for error messages.
pub(crate) fn load_obj_into(
    b: &mut Builder,
    path: &Path,
    default: Option<MaterialId>,
    from: Option<&SourceLoc>,
    objects: &mut Vec<Object>,
) -> Result<()> {
    let text = read_input_text(path, MAX_INPUT_BYTES).map_err(|e| {
        let why = if e.kind() == std::io::ErrorKind::NotFound {
            "file not found".to_string()
        } else {
            format!("cannot read: {e}")
        };
        obj_error(path, from, why)
    })?;
    let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
    let mtl = move |name: &str| {
        let p = dir.join(name);
        match read_input_text(&p, MAX_INPUT_BYTES) {
            Ok(t) => Ok(Some((p, t))),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
            Err(e) => Err(e.to_string()),
        }
    };
    load_obj_text(b, &text, path, &mtl, default, objects)
}

/// [`load_obj_into`] for OBJ text in memory; `mtl` provides the material
/// libraries it names.
pub(crate) fn load_obj_text(
    b: &mut Builder,
    text: &str,
    path: &Path,
    mtl: &MtlSource<'_>,
    default: Option<MaterialId>,
    objects: &mut Vec<Object>,
) -> Result<()> {
    let clean = clean_obj(text, path, mtl)?;
    for (loc, w) in &clean.warnings {
        b.warn(loc, w.clone());
    }
    let opts = tobj::LoadOptions {
        triangulate: false,
        single_index: false,
        ignore_points: true,
        ignore_lines: true,
    };
    let libs = &clean.mtl;
    let loaded = tobj::load_obj_buf(&mut clean.obj.as_bytes(), &opts, |p| {
        let name = p.to_string_lossy();
        match libs.iter().find(|(n, _)| *n == name) {
            Some((_, text)) => tobj::load_mtl_buf(&mut text.as_bytes()),
            None => Err(tobj::LoadError::OpenFileFailed),
        }
    });
    let (models, mtl) = loaded
        .map_err(|e| Error::parse(SourceLoc::new(path, 0), format!("cannot load OBJ: {e}")))?;
    let file_loc = SourceLoc::new(path, 0);
    let mtls = match mtl {
        Ok(m) => m,
        Err(e) => {
            if !clean.mtl.is_empty() {
                b.warn(
                    &file_loc,
                    format!(
                        "material library could not be loaded ({e}); faces use the default material"
                    ),
                );
            }
            Vec::new()
        }
    };
    let ids: Vec<MaterialId> = mtls
        .iter()
        .map(|m| b.define_material(&m.name, convert_material(m)))
        .collect();
    let mut untextured = 0usize;
    let mut degenerate = 0usize;
    for model in &models {
        let mesh = &model.mesh;
        let material = match mesh.material_id.and_then(|k| ids.get(k)) {
            Some(&id) => id,
            None => {
                untextured += 1;
                match default {
                    Some(d) => d,
                    None => b.default_material(),
                }
            }
        };
        let nfaces = if mesh.face_arities.is_empty() {
            mesh.indices.len() / 3
        } else {
            mesh.face_arities.len()
        };
        let mut start = 0usize;
        for f in 0..nfaces {
            let arity = if mesh.face_arities.is_empty() {
                3
            } else {
                mesh.face_arities[f] as usize
            };
            let Some(idx) = mesh.indices.get(start..start + arity) else {
                return Err(Error::parse(
                    file_loc.clone(),
                    format!("object '{}': face {f} is truncated", model.name),
                ));
            };
            start += arity;
            let mut verts = Vec::with_capacity(arity);
            for &i in idx {
                let k = 3 * i as usize;
                let Some(p) = mesh.positions.get(k..k + 3) else {
                    return Err(Error::parse(
                        file_loc.clone(),
                        format!(
                            "object '{}': face {f} uses vertex {} which does not exist",
                            model.name,
                            i + 1
                        ),
                    ));
                };
                verts.push(Vec3::new(p[0] as f64, p[1] as f64, p[2] as f64));
            }
            match Shape::polygon(verts) {
                Ok(shape) => objects.push(Object {
                    name: format!("{}.{f}", model.name),
                    shape,
                    material,
                }),
                Err(_) => degenerate += 1,
            }
        }
    }
    if untextured > 0 && default.is_none() {
        b.warn(
            &file_loc,
            format!("{untextured} object(s) have no material; using a default grey plastic"),
        );
    }
    if degenerate > 0 {
        b.warn(
            &file_loc,
            format!("{degenerate} degenerate face(s) skipped"),
        );
    }
    Ok(())
}
