//! "Only the effects a scene calls for are simulated": one look at the
//! scene and the options decides which kinds of secondary work can occur,
//! and says why, so a render's statistics explain themselves.

use serde::{Deserialize, Serialize};

use super::light::PreparedLight;
use super::options::RenderOptions;
use crate::geometry::Shape;
use crate::geometry::FTINY;
use crate::scene::{Material, MaterialId, Object, Scene};

/// Whether an effect runs, and the reason.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Effect {
    pub enabled: bool,
    pub reason: String,
}

impl Effect {
    fn on(reason: impl Into<String>) -> Self {
        Self {
            enabled: true,
            reason: reason.into(),
        }
    }
    fn off(reason: impl Into<String>) -> Self {
        Self {
            enabled: false,
            reason: reason.into(),
        }
    }
    fn no_media() -> Self {
        Self::off("no mist and no global medium (-me 0 0 0)")
    }
    fn no_patterns() -> Self {
        Self::off("no pattern, texture or mixture modifies a material the scene uses")
    }
}

/// The effects a render simulates.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct EffectsReport {
    /// Direct light from area sources: shadow bundles over subdivided patches.
    pub area_shadows: Effect,
    /// Direct light from distant sources: one shadow ray each.
    pub distant_shadows: Effect,
    /// Adaptive shadow testing (`-dt` > 0).
    pub adaptive_shadow_testing: Effect,
    /// Shadow rays that pass through glass, trans or invisible surfaces.
    pub transparent_shadows: Effect,
    /// Specular reflection rays (mirror, glass, dielectric, specular plastic/metal/trans).
    pub reflection: Effect,
    /// Refraction / specular transmission rays (glass, dielectric, trans).
    pub refraction: Effect,
    /// Absorption inside dielectrics.
    pub absorption: Effect,
    /// Constant ambient term (`-av`).
    pub ambient: Effect,
    /// Diffuse inter-reflection (`-ab`).
    pub diffuse_interreflection: Effect,
    /// Patterns, textures and mixtures evaluated per ray (Radiance's
    /// function language, data files, pictures, text).
    #[serde(default = "Effect::no_patterns")]
    pub patterns: Effect,
    /// Participating media: extinction along rays, ambient and light-source
    /// in-scattering (`mist`, `-me`).
    #[serde(default = "Effect::no_media")]
    pub media: Effect,
}

/// Materials some surface actually uses (instances included; an `illum`'s
/// alternate counts too).
fn used_materials(scene: &Scene) -> Vec<bool> {
    let mut used = vec![false; scene.materials.len()];
    fn visit(objects: &[Object], used: &mut Vec<bool>, seen: &mut Vec<*const ()>) {
        for o in objects {
            if let Some(u) = used.get_mut(o.material as usize) {
                *u = true;
            }
            if let Shape::Instance(inst) = &o.shape {
                let key = std::sync::Arc::as_ptr(&inst.geometry) as *const ();
                if !seen.contains(&key) {
                    seen.push(key);
                    visit(&inst.geometry.objects, used, seen);
                }
            }
        }
    }
    visit(&scene.objects, &mut used, &mut Vec::new());
    // A processor's part of a distributed scene: the surfaces held
    // elsewhere count too.
    for &m in scene.distributed.iter().flat_map(|d| &d.elsewhere) {
        if let Some(u) = used.get_mut(m as usize) {
            *u = true;
        }
    }
    // Follow illum alternates.
    let mut changed = true;
    while changed {
        changed = false;
        for (i, m) in scene.materials.iter().enumerate() {
            if !used[i] {
                continue;
            }
            let next: [Option<MaterialId>; 2] = match m {
                Material::Illum { alternate, .. } => [*alternate, None],
                Material::Mix { fore, back, .. } => [*fore, *back],
                _ => [None, None],
            };
            for a in next.into_iter().flatten() {
                if let Some(u) = used.get_mut(a as usize) {
                    if !*u {
                        *u = true;
                        changed = true;
                    }
                }
            }
        }
    }
    used
}

fn names(scene: &Scene, ids: &[MaterialId]) -> String {
    let mut v: Vec<&str> = ids
        .iter()
        .map(|&i| {
            scene
                .material_names
                .get(i as usize)
                .map_or("?", |s| s.as_str())
        })
        .collect();
    let more = v.len().saturating_sub(4);
    v.truncate(4);
    let mut s = v.join(", ");
    if more > 0 {
        s.push_str(&format!(" and {more} more"));
    }
    s
}

impl EffectsReport {
    /// The effects that run, by name (`area shadows`, `reflection`, ...),
    /// in the report's order.
    pub fn enabled_names(&self) -> Vec<&'static str> {
        [
            ("area shadows", &self.area_shadows),
            ("distant shadows", &self.distant_shadows),
            ("adaptive shadow testing", &self.adaptive_shadow_testing),
            ("transparent shadows", &self.transparent_shadows),
            ("reflection", &self.reflection),
            ("refraction", &self.refraction),
            ("absorption", &self.absorption),
            ("ambient", &self.ambient),
            ("diffuse inter-reflection", &self.diffuse_interreflection),
            ("patterns", &self.patterns),
            ("media", &self.media),
        ]
        .into_iter()
        .filter(|(_, e)| e.enabled)
        .map(|(n, _)| n)
        .collect()
    }
}

impl EffectsReport {
    /// Analyses `scene` under `options` with the sampled `lights`.
    pub fn analyse(scene: &Scene, options: &RenderOptions, lights: &[PreparedLight]) -> Self {
        let used = used_materials(scene);
        let mut reflective = Vec::new();
        let mut refractive = Vec::new();
        let mut absorbing = Vec::new();
        let mut see_through = Vec::new();
        let mut diffuse = false;
        let mut patterned = Vec::new();
        let mut mists = Vec::new();
        for (i, m) in scene.materials.iter().enumerate() {
            if !used[i] {
                continue;
            }
            let id = i as MaterialId;
            if !scene.mods(id).is_empty() || matches!(m, Material::Mix { .. }) {
                patterned.push(id);
            }
            match m {
                Material::Mirror { alternate, .. } => {
                    reflective.push(id);
                    if *alternate == Some(crate::scene::Alternate::Void) {
                        see_through.push(id);
                    }
                }
                Material::Interface {
                    inside_transmission,
                    outside_transmission,
                    ..
                } => {
                    reflective.push(id);
                    refractive.push(id);
                    see_through.push(id);
                    if inside_transmission.min_element() < 1.0
                        || outside_transmission.min_element() < 1.0
                    {
                        absorbing.push(id);
                    }
                }
                Material::Antimatter { .. } => see_through.push(id),
                Material::Prism { .. } => refractive.push(id),
                Material::Glass { transmission, .. } => {
                    reflective.push(id);
                    if transmission.max_element() > 1e-15 {
                        refractive.push(id);
                        see_through.push(id);
                    }
                }
                Material::Dielectric { transmission, .. } => {
                    reflective.push(id);
                    refractive.push(id);
                    // Shadow rays are refracted through it.
                    see_through.push(id);
                    if transmission.min_element() < 1.0 {
                        absorbing.push(id);
                    }
                }
                Material::Plastic {
                    specularity,
                    roughness,
                    ..
                }
                | Material::Metal {
                    specularity,
                    roughness,
                    ..
                } => {
                    diffuse = true;
                    // Pure specular (roughness 0) always reflects; rough only above -st.
                    if *specularity > FTINY
                        && (roughness * roughness <= FTINY || *specularity > options.st)
                    {
                        reflective.push(id);
                    }
                }
                Material::Trans {
                    specularity,
                    roughness,
                    transmissivity,
                    transmitted_specular,
                    ..
                } => {
                    diffuse = true;
                    let pure = roughness * roughness <= FTINY;
                    // Fresnel can raise a pure surface's specularity, so any is enough there.
                    if *specularity > FTINY && (pure || *specularity > options.st) {
                        reflective.push(id);
                    }
                    let tspec = transmissivity * transmitted_specular;
                    if tspec > FTINY && (pure || tspec > options.st) {
                        refractive.push(id);
                    }
                    if pure && tspec > FTINY {
                        see_through.push(id);
                    }
                }
                Material::Aniso {
                    specularity,
                    transmissivity,
                    transmitted_specular,
                    ..
                } => {
                    diffuse = true;
                    // Roughness is never 0: sampled only above -st.
                    if *specularity > FTINY && *specularity > options.st {
                        reflective.push(id);
                    }
                    let tspec = transmissivity * (1.0 - specularity) * transmitted_specular;
                    if tspec > FTINY && tspec > options.st {
                        refractive.push(id);
                    }
                }
                // m_bsdf: diffuse parts, one sampled ray each for the
                // non-diffuse reflection and transmission.
                Material::Bsdf { data, .. } => {
                    diffuse = true;
                    let d = scene.bsdfs.get(*data as usize);
                    let has = |k: usize| {
                        d.is_some_and(|d| d.parts[k].as_ref().is_some_and(|m| m.max_hemi > FTINY))
                    };
                    if has(0) || has(1) {
                        reflective.push(id);
                    }
                    if has(2) || has(3) {
                        refractive.push(id);
                    }
                }
                Material::Ashik { specular, .. } => {
                    diffuse = true;
                    if specular.max_element() > FTINY
                        && crate::image::brightness(*specular) > options.st
                    {
                        reflective.push(id);
                    }
                }
                Material::Void
                | Material::Illum {
                    alternate: None, ..
                } => see_through.push(id),
                // m_brdf: diffuse, a mirror ray, a straight-through ray
                // (which shadow rays take too).
                Material::Brtd { .. } => {
                    diffuse = true;
                    reflective.push(id);
                    refractive.push(id);
                    see_through.push(id);
                }
                // m_brdf2: diffuse and towards light sources only.
                Material::BrdfFunc { .. } => diffuse = true,
                Material::Mist { .. } => {
                    see_through.push(id);
                    mists.push(id);
                }
                _ => {}
            }
        }
        let area = lights.iter().filter(|l| !l.is_distant()).count();
        let distant = lights.len() - area;
        // Virtual sources (mirror and prism relays) among them.
        let relayed = |want_distant: bool| {
            let n = lights
                .iter()
                .filter(|l| l.virt.is_some() && l.is_distant() == want_distant)
                .count();
            if n > 0 {
                format!(
                    " ({n} of them virtual: relayed by mirrors or prisms, -dr {})",
                    options.dr
                )
            } else {
                String::new()
            }
        };
        let area_shadows = if area > 0 && diffuse {
            Effect::on(format!(
                "{area} area source(s){}: shadow bundles over patches with size/distance below -ds {}",
                relayed(false),
                options.ds
            ))
        } else if area > 0 {
            Effect::off("no diffuse or rough surface to light (only specular materials)")
        } else {
            Effect::off("no area light sources in the scene")
        };
        let distant_shadows = if distant > 0 && diffuse {
            Effect::on(format!(
                "{distant} distant source(s){}: one shadow ray each",
                relayed(true)
            ))
        } else if distant > 0 {
            Effect::off("no diffuse or rough surface to light (only specular materials)")
        } else {
            Effect::off("no distant (`source`) light sources in the scene")
        };
        let adaptive_shadow_testing = if options.dt > 0.0 {
            Effect::on(format!(
                "-dt {} -dc {}: shadow rays for minor patches are estimated",
                options.dt, options.dc
            ))
        } else {
            Effect::off("-dt 0: every patch gets a shadow ray")
        };
        let transparent_shadows = if see_through.is_empty() {
            Effect::off("no glass, dielectric, clear trans, antimatter or invisible surfaces: shadow rays need only an any-hit test")
        } else {
            Effect::on(format!(
                "shadow rays pass through {}",
                names(scene, &see_through)
            ))
        };
        let reflection = if reflective.is_empty() {
            Effect::off(format!(
                "no mirror, glass, dielectric or specular material (specularity above -st {} or roughness 0)",
                options.st
            ))
        } else if options.lr == 0 {
            Effect::off("-lr 0 limits rays to primary rays")
        } else {
            Effect::on(format!(
                "reflective materials: {}",
                names(scene, &reflective)
            ))
        };
        let refraction = if refractive.is_empty() {
            Effect::off("no glass, dielectric or transmitting trans material")
        } else if options.lr == 0 {
            Effect::off("-lr 0 limits rays to primary rays")
        } else {
            Effect::on(format!(
                "transmitting materials: {}",
                names(scene, &refractive)
            ))
        };
        let absorption = if absorbing.is_empty() {
            Effect::off("no dielectric with transmission below 1")
        } else {
            Effect::on(format!("absorbing media: {}", names(scene, &absorbing)))
        };
        let ambient = if options.av != crate::scene::Color::ZERO {
            Effect::on(format!(
                "-av {} {} {}",
                options.av.x, options.av.y, options.av.z
            ))
        } else {
            Effect::off("-av 0 0 0")
        };
        let diffuse_interreflection = if options.ab == 0 {
            Effect::off("-ab 0: diffuse surfaces use the constant ambient -av")
        } else if !diffuse {
            Effect::off(format!(
                "-ab {}: no diffuse surface (plastic, metal or trans) to gather light",
                options.ab
            ))
        } else if options.lr == 0 {
            Effect::off("-lr 0 limits rays to primary rays")
        } else {
            Effect::on(format!(
                "-ab {} -aa {} -ar {} -ad {} -as {}: irradiance cache{}",
                options.ab,
                options.aa,
                options.ar,
                options.ad,
                options.as_,
                if options.aa > 0.0 {
                    ""
                } else {
                    " off (-aa 0: a hemisphere at every diffuse point)"
                }
            ))
        };
        let patterns = if patterned.is_empty() {
            Effect::no_patterns()
        } else {
            Effect::on(format!(
                "{} modifier(s) of {} material(s) evaluated per ray: {}",
                scene.patterns.modifiers.len(),
                patterned.len(),
                names(scene, &patterned)
            ))
        };
        let global = options.me.max_element() > 0.0;
        let media = if mists.is_empty() && !global {
            Effect::no_media()
        } else {
            let mut what = Vec::new();
            if global {
                what.push(format!(
                    "global medium -me {} {} {} -ma {} {} {} -mg {}",
                    options.me.x,
                    options.me.y,
                    options.me.z,
                    options.ma.x,
                    options.ma.y,
                    options.ma.z,
                    options.mg
                ));
            }
            if !mists.is_empty() {
                what.push(format!("mists {}", names(scene, &mists)));
            }
            Effect::on(format!(
                "{}: extinction along rays, in-scattering every -ms {}",
                what.join("; "),
                options.ms
            ))
        };
        Self {
            media,
            patterns,
            area_shadows,
            distant_shadows,
            adaptive_shadow_testing,
            transparent_shadows,
            reflection,
            refraction,
            absorption,
            ambient,
            diffuse_interreflection,
        }
    }
}
