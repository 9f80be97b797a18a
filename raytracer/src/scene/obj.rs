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
//! A missing or unreadable MTL file is a warning, and faces without a
//! material get a default grey plastic (reflectance 0.5). `tobj` reports no
//! line numbers, so OBJ errors name the file and what went wrong.

use std::path::Path;

use super::build::Builder;
use super::model::{Color, Material, MaterialId, Object};
use crate::geometry::{Shape, Vec3};
use crate::{Error, Result, SourceLoc};

fn obj_error(path: &Path, from: Option<&SourceLoc>, what: String) -> Error {
    match from {
        Some(loc) => Error::parse(
            loc.clone(),
            format!("OBJ file '{}': {what}", path.display()),
        ),
        None => Error::parse(SourceLoc::new(path, 0), what),
    }
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
    if !path.is_file() {
        return Err(obj_error(path, from, "file not found".into()));
    }
    let opts = tobj::LoadOptions {
        triangulate: false,
        single_index: false,
        ignore_points: true,
        ignore_lines: true,
    };
    let (models, mtl) = tobj::load_obj(path, &opts)
        .map_err(|e| obj_error(path, from, format!("cannot load OBJ: {e}")))?;
    let file_loc = SourceLoc::new(path, 0);
    let mtls = match mtl {
        Ok(m) => m,
        Err(e) => {
            b.warn(
                &file_loc,
                format!(
                    "material library could not be loaded ({e}); faces use the default material"
                ),
            );
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
                return Err(obj_error(
                    path,
                    from,
                    format!("object '{}': face {f} is truncated", model.name),
                ));
            };
            start += arity;
            let mut verts = Vec::with_capacity(arity);
            for &i in idx {
                let k = 3 * i as usize;
                let Some(p) = mesh.positions.get(k..k + 3) else {
                    return Err(obj_error(
                        path,
                        from,
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
