//! Reading patterns, textures and mixtures into [`crate::modifier`]:
//! their string arguments (functions, expressions, files, a transform),
//! the files they load (function files, data files, pictures, fonts) and
//! how they attach to materials.
//!
//! Files named by a modifier are looked up beside the scene file that
//! names them, then along the search path (`RAYPATH`, or what the caller
//! set with [`super::LoadOptions`]), as Radiance's `getpath` does.

use std::sync::Arc;

use super::build::{Builder, Mod};
use super::model::{BrdfFamily, Color, Material, MaterialId};
use super::rad::RawPrim;
use super::xform::{parse_instance_xf, Xf};
use crate::cal::{Context, ExprId, FuncId};
use crate::modifier::font::TextLayout;
use crate::modifier::{Kind, MaterialFuncs, Mixing, Modifier, ModifierId, Picture};
use crate::{Error, Result};

/// The first `fixed` string arguments, and the transform in the rest.
fn split_xf(p: &RawPrim, fixed: usize, meaning: &str) -> Result<Option<Xf>> {
    if p.strs.len() < fixed {
        return Err(Error::parse(
            p.loc.clone(),
            format!(
                "{} '{}': expected at least {fixed} string arguments ({meaning}), got {}",
                p.ptype,
                p.id,
                p.strs.len()
            ),
        ));
    }
    let own = &p.strs[fixed..];
    if own.is_empty() && p.post.is_none() {
        return Ok(None);
    }
    let xf = parse_instance_xf(own, &p.loc).map_err(|e| match e {
        Error::Parse { loc, reason } => Error::Parse {
            loc,
            reason: format!(
                "{} '{}': after its {fixed} arguments ({meaning}) only a transform may follow: {reason}",
                p.ptype, p.id
            ),
        },
        other => other,
    })?;
    Ok(Some(xf.then(&p.post.unwrap_or_default())))
}

/// One side of a mixture.
enum Side {
    Void,
    Material(MaterialId),
    Patterns(Vec<ModifierId>),
}

impl Builder {
    /// A copy of `material` with `chain` applied in front of its own
    /// patterns (a surface whose modifier is a pattern leading to a
    /// material); made once per pair.
    pub(super) fn patterned_material(
        &mut self,
        chain: &[ModifierId],
        material: MaterialId,
    ) -> MaterialId {
        let key = (chain.to_vec(), material);
        if let Some(&id) = self.mods.derived.get(&key) {
            return id;
        }
        let name = self.scene.material_names[material as usize].clone();
        let m = self.scene.material(material).clone();
        let mut mods = chain.to_vec();
        mods.extend_from_slice(self.scene.mods(material));
        let id = self.add_material(&name, m);
        self.scene.material_mods[id as usize] = mods;
        self.mods.derived.insert(key, id);
        id
    }

    /// A pattern's picture; a missing one is said once as a warning.
    fn picture(&mut self, name: &str, p: &RawPrim) -> Result<Picture> {
        let pict = self.mods.pict(name, p)?;
        if let Err(why) = &pict {
            self.warn(
                &p.loc,
                format!(
                    "{why}; rays that reach it count as failed evaluations in the render's report"
                ),
            );
        }
        Ok(pict)
    }

    fn context(&mut self, file: &str, p: &RawPrim) -> Result<Context> {
        let base = p.base_dir();
        let lib = self.mods.lib()?;
        if file == "." {
            Ok(lib.global())
        } else {
            lib.load_file(file, &base, &p.loc)
        }
    }

    fn exprs(&mut self, ctx: Context, texts: &[String], p: &RawPrim) -> Result<Vec<ExprId>> {
        let lib = self.mods.lib()?;
        texts.iter().map(|t| lib.expr(ctx, t, &p.loc)).collect()
    }

    /// The three channel functions of `colordata`, `texdata` and
    /// `colorpict`: Radiance calls a function of fewer than three
    /// arguments with its own channel's value, others with all three.
    fn channel_funcs(
        &mut self,
        ctx: Context,
        names: &[String],
        p: &RawPrim,
    ) -> Result<([FuncId; 3], [bool; 3])> {
        let mut funcs = Vec::with_capacity(3);
        let mut three = [true; 3];
        for (i, name) in names.iter().enumerate() {
            let arity = self.mods.lib()?.arity(ctx, name).unwrap_or(3);
            three[i] = arity >= 3;
            funcs.push(self.func(ctx, name, if three[i] { 3 } else { 1 }, p)?);
        }
        Ok(([funcs[0], funcs[1], funcs[2]], three))
    }

    fn func(&mut self, ctx: Context, name: &str, arity: usize, p: &RawPrim) -> Result<FuncId> {
        self.mods.lib()?.function(ctx, name, arity, &p.loc)
    }

    /// The orientation vector of an anisotropic material (`plastic2`,
    /// `metal2`, `trans2`, `ashik2`): string arguments `ux uy uz funcfile
    /// [transform]`, compiled like a `texfunc` (the expressions may use
    /// the material's real arguments). Returns the modifier that
    /// evaluates it ([`crate::modifier::Patterns::direction`]).
    pub(super) fn aniso_direction(&mut self, p: &RawPrim) -> Result<ModifierId> {
        let xf = split_xf(
            p,
            4,
            "ux, uy and uz of the orientation vector, function file",
        )?;
        let ctx = self.context(&p.strs[3], p)?;
        let e = self.exprs(ctx, &p.strs[..3], p)?;
        Ok(self.push_modifier(p, Kind::Direction([e[0], e[1], e[2]]), xf))
    }

    /// The redirecting functions of `prism1` (`projections` 1) or `prism2`
    /// (2): coefficient and direction per projection, function file,
    /// transform; the reals are `A1`...
    pub(super) fn redirect_modifier(
        &mut self,
        p: &RawPrim,
        projections: usize,
    ) -> Result<ModifierId> {
        let ff = 4 * projections + 1;
        let meaning = if projections == 1 {
            "coef dx dy dz, function file"
        } else {
            "coef1 dx1 dy1 dz1 coef2 dx2 dy2 dz2, function file"
        };
        let xf = split_xf(p, ff, meaning)?;
        let ctx = self.context(&p.strs[ff - 1], p)?;
        let e = self.exprs(ctx, &p.strs[..ff - 1], p)?;
        let kind = Kind::Redirect(e.chunks(4).map(|c| [c[0], c[1], c[2], c[3]]).collect());
        Ok(self.push_modifier(p, kind, xf))
    }

    /// Reads one pattern, texture or mixture and binds its name.
    pub(super) fn add_modifier(&mut self, p: &RawPrim) -> Result<()> {
        let t = p.ptype.as_str();
        self.scene.stats.materials += 1;
        // What this modifier's own modifier contributes.
        let (tail, material): (Vec<ModifierId>, Option<MaterialId>) = match p.modifier.as_str() {
            "void" => (Vec::new(), None),
            m => match self.lookup(m, &p.loc, p)? {
                Mod::Material(id) => (Vec::new(), Some(id)),
                Mod::Pattern { chain, material } => (chain.to_vec(), material),
            },
        };
        if !p.ints.is_empty() {
            return Err(Error::parse(
                p.loc.clone(),
                format!(
                    "{t} '{}': expected 0 integer arguments, got {}",
                    p.id,
                    p.ints.len()
                ),
            ));
        }
        if matches!(t, "specfunc" | "specdata" | "specpict") {
            self.warn_once(
                t,
                &p.loc,
                format!("{t} '{}': spectral patterns are not supported yet; the materials it modifies render unpatterned", p.id),
            );
            self.scope_insert(
                &p.id,
                Mod::Pattern {
                    chain: tail.into(),
                    material,
                },
            );
            return Ok(());
        }
        if t.starts_with("mix") {
            return self.add_mixture(p, tail, material);
        }
        let (kind, xf) = self.pattern_kind(p)?;
        let id = self.push_modifier(p, kind, xf);
        self.bind_pattern(&p.id, id, tail, material);
        Ok(())
    }

    /// Binds `name` to the pattern `id` followed by its modifier's chain.
    fn bind_pattern(
        &mut self,
        name: &str,
        id: ModifierId,
        tail: Vec<ModifierId>,
        material: Option<MaterialId>,
    ) {
        let mut chain = vec![id];
        chain.extend(tail);
        self.scope_insert(
            name,
            Mod::Pattern {
                chain: chain.into(),
                material,
            },
        );
    }

    fn scope_insert(&mut self, name: &str, m: Mod) {
        self.scope.insert(name.to_string(), m);
    }

    fn push_modifier(&mut self, p: &RawPrim, kind: Kind, xf: Option<Xf>) -> ModifierId {
        let id = self.mods.modifiers.len() as ModifierId;
        self.mods.modifiers.push(Modifier {
            name: p.id.clone(),
            ptype: p.ptype.clone(),
            kind,
            xf,
            args: p.reals.clone(),
            loc: p.loc.clone(),
        });
        id
    }

    /// Data coordinates: the `n` expressions from `start`, then the transform.
    fn data_coords(
        &mut self,
        p: &RawPrim,
        ctx: Context,
        start: usize,
        n: usize,
        meaning: &str,
    ) -> Result<(Vec<ExprId>, Option<Xf>)> {
        let xf = split_xf(p, start + n, meaning)?;
        let coords = self.exprs(ctx, &p.strs[start..start + n], p)?;
        Ok((coords, xf))
    }

    fn pattern_kind(&mut self, p: &RawPrim) -> Result<(Kind, Option<Xf>)> {
        let s = &p.strs;
        let need = |n: usize, meaning: &str| -> Result<()> {
            if s.len() < n {
                Err(Error::parse(
                    p.loc.clone(),
                    format!(
                        "{} '{}': expected at least {n} string arguments ({meaning}), got {}",
                        p.ptype,
                        p.id,
                        s.len()
                    ),
                ))
            } else {
                Ok(())
            }
        };
        Ok(match p.ptype.as_str() {
            "brightfunc" => {
                let xf = split_xf(p, 2, "function, function file")?;
                let ctx = self.context(&s[1], p)?;
                let e = self.exprs(ctx, &s[..1], p)?;
                (Kind::BrightFunc(e[0]), xf)
            }
            "colorfunc" | "texfunc" => {
                let meaning = if p.ptype == "colorfunc" {
                    "red, green and blue functions, function file"
                } else {
                    "x, y and z perturbations, function file"
                };
                let xf = split_xf(p, 4, meaning)?;
                let ctx = self.context(&s[3], p)?;
                let e = self.exprs(ctx, &s[..3], p)?;
                let e = [e[0], e[1], e[2]];
                if p.ptype == "colorfunc" {
                    (Kind::ColorFunc(e), xf)
                } else {
                    (Kind::TexFunc(e), xf)
                }
            }
            "brightdata" => {
                need(3, "function, data file, function file, coordinates")?;
                let data = self.mods.data(&s[1], p)?;
                let ctx = self.context(&s[2], p)?;
                let n = data.dims();
                let (coords, xf) = self.data_coords(
                    p,
                    ctx,
                    3,
                    n,
                    "function, data file, function file, one coordinate per data dimension",
                )?;
                let func = self.func(ctx, &s[0], 1, p)?;
                (Kind::BrightData { func, data, coords }, xf)
            }
            "colordata" | "texdata" => {
                need(
                    7,
                    "three functions, three data files, function file, coordinates",
                )?;
                let data = [
                    self.mods.data(&s[3], p)?,
                    self.mods.data(&s[4], p)?,
                    self.mods.data(&s[5], p)?,
                ];
                let n = data[0].dims();
                if data.iter().any(|d| d.dims() != n) {
                    return Err(Error::parse(
                        p.loc.clone(),
                        format!(
                            "{} '{}': its three data files differ in dimensions",
                            p.ptype, p.id
                        ),
                    ));
                }
                let ctx = self.context(&s[6], p)?;
                let (coords, xf) = self.data_coords(p, ctx, 7, n, "three functions, three data files, function file, one coordinate per data dimension")?;
                let (funcs, three) = self.channel_funcs(ctx, &s[..3], p)?;
                if p.ptype == "colordata" {
                    (
                        Kind::ColorData {
                            funcs,
                            three,
                            data,
                            coords,
                        },
                        xf,
                    )
                } else {
                    (
                        Kind::TexData {
                            funcs,
                            three,
                            data,
                            coords,
                        },
                        xf,
                    )
                }
            }
            "colorpict" => {
                let xf = split_xf(p, 7, "three functions, picture, function file, u, v")?;
                let pict = self.picture(&s[3], p)?;
                let ctx = self.context(&s[4], p)?;
                let c = self.exprs(ctx, &s[5..7], p)?;
                let (funcs, three) = self.channel_funcs(ctx, &s[..3], p)?;
                (
                    Kind::ColorPict {
                        funcs,
                        three,
                        pict,
                        coords: [c[0], c[1]],
                    },
                    xf,
                )
            }
            "brighttext" | "colortext" => {
                let (layout, rest) = self.text_layout(p, 0)?;
                let (fore, back) = if p.ptype == "brighttext" {
                    (Color::splat(rest[0]), Color::splat(rest[1]))
                } else {
                    (
                        Color::new(rest[0], rest[1], rest[2]),
                        Color::new(rest[3], rest[4], rest[5]),
                    )
                };
                (Kind::Text { layout, fore, back }, None)
            }
            other => {
                return Err(Error::parse(
                    p.loc.clone(),
                    format!("'{other}' is not a pattern or texture type"),
                ))
            }
        })
    }

    /// A text pattern's font, text and placement; returns the reals after
    /// the placement (the foreground and background values).
    fn text_layout(&mut self, p: &RawPrim, first: usize) -> Result<(Arc<TextLayout>, Vec<f64>)> {
        let s = &p.strs[first..];
        let values = match p.ptype.as_str() {
            "brighttext" => 2,
            "colortext" => 6,
            _ => 0,
        };
        let r = &p.reals;
        if s.len() < 2 || !(r.len() == 9 + values || r.len() == 10 + values) {
            return Err(Error::parse(
                p.loc.clone(),
                format!(
                    "{} '{}': expected a font file and a text file or '.' and words, and {} or {} real arguments \
                     (origin, right and down vectors{}, optional spacing), got {} strings and {} reals",
                    p.ptype,
                    p.id,
                    9 + values,
                    10 + values,
                    if values > 0 { ", foreground and background" } else { "" },
                    s.len(),
                    r.len()
                ),
            ));
        }
        let font = self.mods.font(&s[0], p)?;
        // text.c: words after the file name are the text (the name, usually
        // `.`, is then ignored); otherwise the file holds the lines.
        let lines: Vec<String> = if s.len() > 2 {
            vec![s[2..].join(" ")]
        } else {
            let path = self.mods.locate(&s[1], "text file", p)?;
            crate::modifier::font::read_text_file(&path, &p.loc)?
        };
        let mut placement: Vec<f64> = r[..9].to_vec();
        if r.len() == 10 + values {
            placement.push(r[9 + values]);
        }
        let layout = TextLayout::new(font, lines, &placement, &p.loc)?;
        Ok((Arc::new(layout), r[9..9 + values].to_vec()))
    }

    fn side(&mut self, name: &str, p: &RawPrim) -> Result<Side> {
        if name == "void" {
            return Ok(Side::Void);
        }
        Ok(match self.lookup(name, &p.loc, p)? {
            Mod::Material(id) => Side::Material(id),
            Mod::Pattern {
                chain,
                material: Some(id),
            } => Side::Material(self.patterned_material(&chain, id)),
            Mod::Pattern {
                chain,
                material: None,
            } => Side::Patterns(chain.to_vec()),
        })
    }

    fn add_mixture(
        &mut self,
        p: &RawPrim,
        tail: Vec<ModifierId>,
        material: Option<MaterialId>,
    ) -> Result<()> {
        let s = &p.strs;
        if s.len() < 2 {
            return Err(Error::parse(
                p.loc.clone(),
                format!(
                    "{} '{}': expected the foreground and background modifiers first, got {} string arguments",
                    p.ptype,
                    p.id,
                    s.len()
                ),
            ));
        }
        let fore = self.side(&s[0], p)?;
        let back = self.side(&s[1], p)?;
        let (coef, xf) = match p.ptype.as_str() {
            "mixfunc" => {
                let xf = split_xf(p, 4, "foreground, background, coefficient, function file")?;
                let ctx = self.context(&s[3], p)?;
                let e = self.exprs(ctx, &s[2..3], p)?;
                (Mixing::Func(e[0]), xf)
            }
            "mixdata" => {
                if s.len() < 5 {
                    return Err(Error::parse(
                        p.loc.clone(),
                        format!("{} '{}': expected foreground, background, function, data file, function file and coordinates", p.ptype, p.id),
                    ));
                }
                let data = self.mods.data(&s[3], p)?;
                let ctx = self.context(&s[4], p)?;
                let n = data.dims();
                let (coords, xf) = self.data_coords(p, ctx, 5, n, "foreground, background, function, data file, function file, one coordinate per data dimension")?;
                let func = self.func(ctx, &s[2], 1, p)?;
                (Mixing::Data { func, data, coords }, xf)
            }
            "mixpict" => {
                let xf = split_xf(
                    p,
                    7,
                    "foreground, background, function, picture, function file, u, v",
                )?;
                let pict = self.picture(&s[3], p)?;
                let ctx = self.context(&s[4], p)?;
                let c = self.exprs(ctx, &s[5..7], p)?;
                let func = self.func(ctx, &s[2], 3, p)?;
                (
                    Mixing::Pict {
                        func,
                        pict,
                        coords: [c[0], c[1]],
                    },
                    xf,
                )
            }
            "mixtext" => {
                let (layout, _) = self.text_layout(p, 2)?;
                (Mixing::Text(layout), None)
            }
            other => {
                return Err(Error::parse(
                    p.loc.clone(),
                    format!("'{other}' is not a mixture type"),
                ))
            }
        };
        let is_material = |s: &Side| matches!(s, Side::Material(_));
        if is_material(&fore) || is_material(&back) {
            // A mixture of materials is a material.
            let id = self.push_modifier(
                p,
                Kind::Mix {
                    fore: Vec::new(),
                    back: Vec::new(),
                    coef,
                },
                xf,
            );
            let side = |s: Side| match s {
                Side::Material(m) => Some(m),
                _ => None,
            };
            if !tail.is_empty() || material.is_some() {
                self.warn(
                    &p.loc,
                    format!(
                        "{} '{}': a mixture of materials takes no modifier ('{}' is ignored)",
                        p.ptype, p.id, p.modifier
                    ),
                );
            }
            let mid = self.add_material(
                &p.id,
                Material::Mix {
                    fore: side(fore),
                    back: side(back),
                    modifier: id,
                },
            );
            self.scope_insert(&p.id, Mod::Material(mid));
            return Ok(());
        }
        let chain_of = |s: Side| match s {
            Side::Patterns(c) => c,
            _ => Vec::new(),
        };
        let id = self.push_modifier(
            p,
            Kind::Mix {
                fore: chain_of(fore),
                back: chain_of(back),
                coef,
            },
            xf,
        );
        self.bind_pattern(&p.id, id, tail, material);
        Ok(())
    }
}

impl Builder {
    /// `BRTDfunc` (Radiance's `m_brdf.c`): 10 strings (six specular
    /// expressions, three directional functions, the function file) and
    /// a transform; at least 9 reals (front and back diffuse reflectance,
    /// diffuse transmittance), more for `arg(n)`.
    pub(super) fn brtd_material(&mut self, p: &RawPrim) -> Result<Material> {
        let meaning = "rrefl grefl brefl rtrns gtrns btrns rbrtd gbrtd bbrtd funcfile";
        if !p.ints.is_empty() || p.reals.len() < 9 {
            return Err(Error::parse(
                p.loc.clone(),
                format!(
                    "BRTDfunc '{}': expected 10 or more strings ({meaning} [transform]), 0 integers and 9 or more reals \
                     (front, back diffuse reflectance, diffuse transmittance, [A10 ..]), got {} reals and {} integers",
                    p.id,
                    p.reals.len(),
                    p.ints.len()
                ),
            ));
        }
        let xf = split_xf(p, 10, meaning)?;
        let ctx = self.context(&p.strs[9], p)?;
        let e = self.exprs(ctx, &p.strs[..6], p)?;
        let mut directional: [Option<FuncId>; 3] = [None; 3];
        for k in 0..3 {
            let name = &p.strs[6 + k];
            // m_brdf.c: "0" is the zero function; a channel named like an
            // earlier one takes its value.
            if name == "0" {
                continue;
            }
            directional[k] = match (0..k).find(|&j| p.strs[6 + j] == *name) {
                Some(j) => directional[j],
                None => Some(self.func(ctx, name, 4, p)?),
            };
        }
        let kind = Kind::MaterialFuncs(MaterialFuncs::Brtd {
            specular: [e[0], e[1], e[2], e[3], e[4], e[5]],
            directional,
        });
        let funcs = self.push_modifier(p, kind, xf);
        let r = &p.reals;
        let rgb = |k: usize| Color::new(r[k], r[k + 1], r[k + 2]);
        Ok(Material::Brtd {
            front: rgb(0),
            back: rgb(3),
            tdiff: rgb(6),
            funcs,
            // m_brdf.c computes the direct component for a red function
            // whose name does not start with '0' (or for diffuse parts).
            directional: !p.strs[6].starts_with('0'),
        })
    }

    /// `plasfunc`, `metfunc`, `transfunc` (function, function file,
    /// transform) and `plasdata`, `metdata`, `transdata` (function, data
    /// file, function file, one coordinate function per data dimension,
    /// transform): Radiance's `m_brdf2`.
    pub(super) fn brdf_func_material(&mut self, p: &RawPrim) -> Result<Material> {
        let t = p.ptype.as_str();
        let family = if t.starts_with("plas") {
            BrdfFamily::Plastic
        } else if t.starts_with("met") {
            BrdfFamily::Metal
        } else {
            BrdfFamily::Trans
        };
        let data = t.ends_with("data");
        let (nreals, reals) = if family == BrdfFamily::Trans {
            (6, "red green blue rspec trans tspec [A7 ..]")
        } else {
            (4, "red green blue specularity [A5 ..]")
        };
        let strs = if data {
            "function, data file, function file, one coordinate function per data dimension [transform]"
        } else {
            "function, function file [transform]"
        };
        let nstrs = if data { 4 } else { 2 };
        if !p.ints.is_empty() || p.reals.len() < nreals || p.strs.len() < nstrs {
            return Err(Error::parse(
                p.loc.clone(),
                format!(
                    "{t} '{}': expected {nstrs} or more strings ({strs}), 0 integers and {nreals} or more reals ({reals}), \
                     got {} strings, {} integers and {} reals",
                    p.id,
                    p.strs.len(),
                    p.ints.len(),
                    p.reals.len()
                ),
            ));
        }
        let s = &p.strs;
        let kind = if data {
            let d = self.mods.data(&s[1], p)?;
            let ctx = self.context(&s[2], p)?;
            let n = d.dims();
            let xf = split_xf(p, 3 + n, strs)?;
            let mut coords = Vec::with_capacity(n);
            for name in &s[3..3 + n] {
                coords.push(self.func(ctx, name, 4, p)?);
            }
            let func = self.func(ctx, &s[0], 5, p)?;
            (
                MaterialFuncs::Data {
                    func,
                    data: d,
                    coords,
                },
                xf,
            )
        } else {
            let xf = split_xf(p, 2, strs)?;
            let ctx = self.context(&s[1], p)?;
            (MaterialFuncs::Func(self.func(ctx, &s[0], 4, p)?), xf)
        };
        let funcs = self.push_modifier(p, Kind::MaterialFuncs(kind.0), kind.1);
        let r = &p.reals;
        let trans = family == BrdfFamily::Trans;
        Ok(Material::BrdfFunc {
            family,
            color: Color::new(r[0], r[1], r[2]),
            specularity: r[3],
            transmissivity: if trans { r[4] } else { 0.0 },
            transmitted_specular: if trans { r[5] } else { 0.0 },
            funcs,
        })
    }
}
