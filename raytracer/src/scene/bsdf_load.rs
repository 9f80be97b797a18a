//! Reading `BSDF` and `aBSDF` material records: the XML file (loaded
//! once per scene and shared), the thickness, the up vector, the diffuse
//! reals (see [`crate::render::bsdf`]).

use std::sync::Arc;

use super::build::Builder;
use super::model::{Color, Material};
use super::rad::RawPrim;
use crate::scene::klems::KlemsData;
use crate::{Error, Result};

impl Builder {
    /// `mod BSDF id 6+ thick file ux uy uz funcfile [xf] 0 0|3|6|9 ...`
    /// or `mod aBSDF id 5+ file ux uy uz funcfile [xf] 0 0|3|6|9 ...`.
    pub(super) fn bsdf_material(&mut self, p: &RawPrim) -> Result<Material> {
        Self::no_ints(p)?;
        let thick = p.ptype == "BSDF";
        Self::reals(
            p,
            &[0, 3, 6, 9],
            "front diffuse reflection, back diffuse reflection, diffuse transmission (RGB each)",
        )?;
        let lead = usize::from(thick) + 1;
        if p.strs.len() < lead + 4 {
            return Err(Error::parse(
                p.loc.clone(),
                format!(
                    "{} '{}': expected at least {} string arguments ({}BSDF file, ux uy uz, function file), got {}",
                    p.ptype,
                    p.id,
                    lead + 4,
                    if thick { "thickness, " } else { "" },
                    p.strs.len()
                ),
            ));
        }
        if thick {
            let t = &p.strs[0];
            match t.parse::<f64>() {
                Ok(v) if v.abs() <= crate::geometry::FTINY => {}
                _ => {
                    return Err(Error::parse(
                        p.loc.clone(),
                        format!(
                            "BSDF '{}': thickness '{t}' is not supported (only 0: a proxy surface with a thickness is not implemented)",
                            p.id
                        ),
                    ))
                }
            }
        }
        let name = &p.strs[lead - 1];
        let path = self.mods.locate(name, "BSDF file", p)?;
        let shown = path.display().to_string();
        let data = match self.scene.bsdfs.iter().position(|d| d.path == shown) {
            Some(i) => i,
            None => {
                let d = KlemsData::load(&path).map_err(|why| {
                    Error::parse(p.loc.clone(), format!("{} '{}': {why}", p.ptype, p.id))
                })?;
                self.scene.bsdfs.push(Arc::new(d));
                self.scene.bsdfs.len() - 1
            }
        };
        let transmits = self.scene.bsdfs[data].parts[2..]
            .iter()
            .any(Option::is_some);
        if !thick && transmits {
            self.warn(
                &p.loc,
                format!(
                    "aBSDF '{}': the unscattered 'through' component of '{name}' (view and shadow rays passing straight) is not simulated; its transmission is sampled like BSDF's",
                    p.id
                ),
            );
        }
        // The up vector: the strings after the file, as an orientation.
        let mut q = p.clone();
        q.strs.drain(..lead);
        let direction = self.aniso_direction(&q)?;
        let r = &p.reals;
        let rgb = |k: usize| {
            if r.len() >= k + 3 {
                Color::new(r[k], r[k + 1], r[k + 2])
            } else {
                Color::ZERO
            }
        };
        Ok(Material::Bsdf {
            data: data as u32,
            rdiff_front: rgb(0),
            rdiff_back: rgb(3),
            tdiff: rgb(6),
            direction,
        })
    }
}
