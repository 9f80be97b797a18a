//! Wavefront OBJ/MTL input through `tobj`.
//!
//! Faces stay polygons (no triangulation here: the geometry module
//! triangulates each polygon itself), one [`Object`] per face, named
//! `<object>.<face>`. MTL materials map onto Radiance ones:
//!
//! | MTL                                   | material                                         |
//! |---------------------------------------|--------------------------------------------------|
//! | `Ke` non-zero                         | `light` with radiance `Ke`                       |
//! | `illum` 6 or 7 (refraction)           | `dielectric`, index `Ni` (default 1.5)           |
//! | `illum` 4, or `d` < 1                 | `glass`, transmission `1 - d`, index `Ni` (1.52) |
//! | otherwise                             | `plastic`: colour `Kd`, specularity mean(`Ks`), roughness `sqrt(2 / (Ns + 2))` |
//!
//! A missing MTL file is a warning, and faces without a material get a
//! default grey plastic (reflectance 0.5).
//!
//! `tobj` reports no line numbers and panics on some malformed lines (an
//! MTL line `Kd 1`), so every OBJ and MTL line is checked here first, with
//! errors naming `file:line` and the reason, and `tobj` is handed a
//! cleaned copy holding only what is used (positions, faces with resolved
//! position indices, objects, groups and materials), which it cannot fail
//! on. Files are read through [`super::input::read_input`]: no device,
//! FIFO or directory, at most 2 GiB.

use std::path::{Path, PathBuf};

use super::model::{Color, Material};
use crate::{Error, Result, SourceLoc};

pub(super) fn obj_error(path: &Path, from: Option<&SourceLoc>, what: String) -> Error {
    match from {
        Some(loc) => Error::parse(
            loc.clone(),
            format!("OBJ file '{}': {what}", path.display()),
        ),
        None => Error::parse(SourceLoc::new(path, 0), what),
    }
}

/// Parses an OBJ/MTL number: finite, as `tobj` reads it (`f32`).
fn number(word: &str, loc: &SourceLoc, what: &str) -> Result<f64> {
    match word.parse::<f32>() {
        Ok(x) if x.is_finite() => Ok(x as f64),
        Ok(_) => Err(Error::parse(
            loc.clone(),
            format!("{what}: '{word}' is not a finite number"),
        )),
        Err(_) => Err(Error::parse(
            loc.clone(),
            format!("{what}: '{word}' is not a number"),
        )),
    }
}

/// The rest of a line after its keyword, trimmed (names may hold spaces).
fn rest<'a>(line: &'a str, key: &str) -> &'a str {
    line.trim_start()[key.len()..].trim()
}

/// Checks an MTL file line by line and returns the cleaned text `tobj`
/// reads: `newmtl`, colours as three numbers (`Kd 0.5` means grey, as the
/// MTL format allows), `Ns`, `Ni`, `d` (`Tr` becomes `d`), `illum`; other
/// statements (texture maps, ...) are dropped as unused. Non-finite or
/// negative values, an index of refraction <= 0 and a dissolve outside
/// 0..=1 are errors.
pub fn clean_mtl(text: &str, file: &Path) -> Result<String> {
    let mut out = String::with_capacity(text.len() / 2);
    let mut have_material = false;
    for (k, raw) in text.lines().enumerate() {
        let loc = SourceLoc::new(file, k + 1);
        let line = raw.split('#').next().unwrap_or("");
        let words: Vec<&str> = line.split_whitespace().collect();
        let Some(&key) = words.first() else { continue };
        let args = &words[1..];
        let one = |what: &str| -> Result<f64> {
            match args {
                [w] => number(w, &loc, what),
                _ => Err(Error::parse(
                    loc.clone(),
                    format!("{what} takes one number, found {}", args.len()),
                )),
            }
        };
        let need_material = || -> Result<()> {
            if have_material {
                Ok(())
            } else {
                Err(Error::parse(
                    loc.clone(),
                    format!("'{key}' before any 'newmtl'"),
                ))
            }
        };
        match key {
            "newmtl" => {
                let name = rest(line, key);
                if name.is_empty() {
                    return Err(Error::parse(loc, "newmtl needs a material name"));
                }
                out.push_str(&format!("newmtl {name}\n"));
                have_material = true;
            }
            "Ka" | "Kd" | "Ks" | "Ke" | "Tf" => {
                need_material()?;
                let c = match args {
                    [r] => {
                        let r = number(r, &loc, key)?;
                        [r, r, r]
                    }
                    [r, g, b] => [
                        number(r, &loc, key)?,
                        number(g, &loc, key)?,
                        number(b, &loc, key)?,
                    ],
                    [first, ..] if matches!(*first, "spectral" | "xyz") => {
                        return Err(Error::parse(
                            loc,
                            format!("{key} {first}: only RGB colours are supported"),
                        ))
                    }
                    _ => {
                        return Err(Error::parse(
                            loc,
                            format!(
                                "{key} takes one or three numbers (r g b), found {}",
                                args.len()
                            ),
                        ))
                    }
                };
                if c.iter().any(|&x| x < 0.0) {
                    return Err(Error::parse(
                        loc,
                        format!("{key}: negative colour {} {} {}", c[0], c[1], c[2]),
                    ));
                }
                if key != "Tf" {
                    out.push_str(&format!("{key} {} {} {}\n", c[0], c[1], c[2]));
                }
            }
            "Ns" => {
                need_material()?;
                let v = one("Ns")?;
                if v < 0.0 {
                    return Err(Error::parse(loc, format!("Ns: negative shininess {v}")));
                }
                out.push_str(&format!("Ns {v}\n"));
            }
            "Ni" => {
                need_material()?;
                let v = one("Ni")?;
                if v <= 0.0 {
                    return Err(Error::parse(
                        loc,
                        format!("Ni: index of refraction {v} must be positive"),
                    ));
                }
                out.push_str(&format!("Ni {v}\n"));
            }
            "d" | "Tr" => {
                need_material()?;
                // `d -halo 0.5` is a variant of `d`.
                let args: Vec<&str> = args.iter().copied().filter(|w| *w != "-halo").collect();
                let v = match args.as_slice() {
                    [w] => number(w, &loc, key)?,
                    _ => {
                        return Err(Error::parse(
                            loc,
                            format!("{key} takes one number, found {}", args.len()),
                        ))
                    }
                };
                if !(0.0..=1.0).contains(&v) {
                    return Err(Error::parse(loc, format!("{key}: {v} is outside 0..1")));
                }
                let d = if key == "Tr" { 1.0 - v } else { v };
                out.push_str(&format!("d {d}\n"));
            }
            "illum" => {
                need_material()?;
                let v = match args {
                    [w] => w.parse::<u8>().ok().filter(|&i| i <= 10),
                    _ => None,
                };
                let Some(v) = v else {
                    return Err(Error::parse(
                        loc,
                        format!(
                            "illum takes one illumination model 0..10, found '{}'",
                            args.join(" ")
                        ),
                    ));
                };
                out.push_str(&format!("illum {v}\n"));
            }
            // Texture maps and anything else: not used.
            _ => {}
        }
    }
    Ok(out)
}

/// Where a material library comes from: given its name as written in the
/// OBJ file, its text, `Ok(None)` when it does not exist (a warning), or
/// an error (not a regular file, too large, unreadable).
pub type MtlSource<'a> =
    dyn Fn(&str) -> std::result::Result<Option<(PathBuf, String)>, String> + 'a;

/// Checks an OBJ file line by line (errors name `file:line`), reads the
/// material libraries it names through `mtl`, and returns the cleaned OBJ
/// text, the cleaned MTL texts by name, and the warnings.
pub(super) struct CleanObj {
    pub(super) obj: String,
    pub(super) mtl: Vec<(String, String)>,
    pub(super) warnings: Vec<(SourceLoc, String)>,
}

pub(super) fn clean_obj(text: &str, file: &Path, mtl: &MtlSource<'_>) -> Result<CleanObj> {
    let mut out = String::with_capacity(text.len());
    let mut libs: Vec<(String, String)> = Vec::new();
    let mut warnings = Vec::new();
    let mut nv: usize = 0;
    let (mut nvt, mut nvn) = (0usize, 0usize);
    // Lines ending in a backslash continue on the next one.
    let mut joined = String::new();
    let mut first_line = 0usize;
    for (k, raw) in text.lines().enumerate() {
        if joined.is_empty() {
            first_line = k + 1;
        }
        if let Some(head) = raw.strip_suffix('\\') {
            joined.push_str(head);
            joined.push(' ');
            continue;
        }
        joined.push_str(raw);
        let full = std::mem::take(&mut joined);
        let loc = SourceLoc::new(file, first_line);
        let line = full.split('#').next().unwrap_or("");
        let words: Vec<&str> = line.split_whitespace().collect();
        let Some(&key) = words.first() else { continue };
        let args = &words[1..];
        match key {
            "v" => {
                let n = args.len();
                if !(n == 3 || n == 4 || n == 6) {
                    return Err(Error::parse(
                        loc,
                        format!("v takes x y z (and w, or r g b), found {n} numbers"),
                    ));
                }
                let mut p = [0.0; 3];
                for (i, w) in args.iter().enumerate() {
                    let x = number(w, &loc, "v")?;
                    if i < 3 {
                        p[i] = x;
                    } else if n == 4 && x == 0.0 {
                        return Err(Error::parse(loc, "v: weight w is 0"));
                    } else if n == 4 {
                        for c in &mut p {
                            *c /= x;
                        }
                    }
                }
                if p.iter()
                    .any(|c| !c.is_finite() || c.abs() > f32::MAX as f64)
                {
                    return Err(Error::parse(loc, "v: coordinate out of range"));
                }
                nv += 1;
                out.push_str(&format!(
                    "v {} {} {}\n",
                    p[0] as f32, p[1] as f32, p[2] as f32
                ));
            }
            "vt" | "vn" => {
                if args.is_empty() || args.len() > 3 {
                    return Err(Error::parse(
                        loc,
                        format!("{key} takes one to three numbers, found {}", args.len()),
                    ));
                }
                for w in args {
                    number(w, &loc, key)?;
                }
                if key == "vt" {
                    nvt += 1
                } else {
                    nvn += 1
                }
            }
            "f" | "fo" => {
                let mut face = String::from("f");
                for w in args {
                    let parts: Vec<&str> = w.split('/').collect();
                    if parts.len() > 3 || parts[0].is_empty() {
                        return Err(Error::parse(
                            loc,
                            format!("face vertex '{w}': expected v, v/vt, v//vn or v/vt/vn"),
                        ));
                    }
                    let mut resolved = 0usize;
                    for (i, part) in parts.iter().enumerate() {
                        if i > 0 && part.is_empty() {
                            continue;
                        }
                        let (count, what) = match i {
                            0 => (nv, "vertex"),
                            1 => (nvt, "texture coordinate"),
                            _ => (nvn, "normal"),
                        };
                        let Ok(x) = part.parse::<i64>() else {
                            return Err(Error::parse(
                                loc,
                                format!("face vertex '{w}': '{part}' is not an index"),
                            ));
                        };
                        let idx = if x > 0 && (x as u64) <= count as u64 {
                            x as usize
                        } else if x < 0 && x.unsigned_abs() <= count as u64 {
                            count + 1 - x.unsigned_abs() as usize
                        } else {
                            return Err(Error::parse(
                                loc,
                                format!(
                                    "face vertex '{w}': {what} {x} does not exist ({count} defined so far)"
                                ),
                            ));
                        };
                        if i == 0 {
                            resolved = idx;
                        }
                    }
                    face.push_str(&format!(" {resolved}"));
                }
                // Points and lines are not surfaces.
                if args.len() >= 3 {
                    out.push_str(&face);
                    out.push('\n');
                }
            }
            "o" | "g" => {
                let name = rest(line, key);
                out.push_str(&format!("{key} {name}\n"));
            }
            "usemtl" => {
                let name = rest(line, key);
                if name.is_empty() {
                    return Err(Error::parse(loc, "usemtl needs a material name"));
                }
                out.push_str(&format!("usemtl {name}\n"));
            }
            "mtllib" => {
                let name = rest(line, key);
                if name.is_empty() {
                    return Err(Error::parse(loc, "mtllib needs a file name"));
                }
                match mtl(name) {
                    Ok(Some((path, text))) => {
                        let clean = clean_mtl(&text, &path)?;
                        out.push_str(&format!("mtllib {name}\n"));
                        libs.push((name.to_string(), clean));
                    }
                    Ok(None) => warnings.push((
                        loc,
                        format!(
                            "material library '{name}' could not be loaded (no such file); faces use the default material"
                        ),
                    )),
                    Err(why) => {
                        return Err(Error::parse(
                            loc,
                            format!("cannot read material library '{name}': {why}"),
                        ))
                    }
                }
            }
            // Smoothing groups, curves, points, lines and the like: unused.
            _ => {}
        }
    }
    Ok(CleanObj {
        obj: out,
        mtl: libs,
        warnings,
    })
}

/// Converts one MTL material.
pub(crate) fn convert_material(m: &tobj::Material) -> Material {
    let v = |a: Option<[f32; 3]>| a.map(|c| Color::new(c[0] as f64, c[1] as f64, c[2] as f64));
    let kd = v(m.diffuse).unwrap_or(Color::splat(0.5));
    let ks = v(m.specular).unwrap_or(Color::ZERO);
    let ke = v(m.emissive).unwrap_or(Color::ZERO);
    let d = m.dissolve.map(|d| d as f64).unwrap_or(1.0);
    let ni = m.optical_density.map(|n| n as f64);
    let illum = m.illumination_model.unwrap_or(2);
    if ke.max_element() > 0.0 {
        Material::Light { radiance: ke }
    } else if illum == 6 || illum == 7 {
        Material::Dielectric {
            transmission: Color::ONE,
            index: ni.unwrap_or(1.5),
            hartmann: 0.0,
        }
    } else if illum == 4 || d < 1.0 {
        let t = if d < 1.0 { 1.0 - d } else { 0.9 };
        Material::Glass {
            transmission: Color::splat(t),
            index: ni.unwrap_or(1.52),
        }
    } else {
        let ns = m.shininess.map(|s| s as f64).unwrap_or(0.0).max(0.0);
        let specularity = if illum >= 2 {
            (ks.x + ks.y + ks.z) / 3.0
        } else {
            0.0
        };
        let roughness = if specularity > 0.0 {
            (2.0 / (ns + 2.0)).sqrt()
        } else {
            0.0
        };
        Material::Plastic {
            color: kd,
            specularity,
            roughness,
        }
    }
}
