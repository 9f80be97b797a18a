//! Scene model: objects, materials and light sources, independent of file format.

use crate::geometry::{Aabb, Shape, Vec3};
use crate::SourceLoc;

/// RGB radiometric colour (Radiance's units: watts/sr/m^2 per channel).
pub type Color = glam::DVec3;

/// Index into [`Scene::materials`].
pub type MaterialId = u32;
/// Index into [`Scene::objects`].
pub type ObjectId = u32;

/// A named surface: one Radiance primitive (or one OBJ face group).
#[derive(Debug, Clone)]
pub struct Object {
    pub name: String,
    pub shape: Shape,
    pub material: MaterialId,
}

/// Surface materials, after Radiance. Parameters keep Radiance's meaning.
#[derive(Debug, Clone, PartialEq)]
pub enum Material {
    /// Radiance `void`: the surface is invisible (no shading, no occlusion).
    Void,
    /// Diffuse + isotropic specular, uncoloured highlight.
    Plastic {
        color: Color,
        specularity: f64,
        roughness: f64,
    },
    /// Like plastic but the highlight takes the material colour.
    Metal {
        color: Color,
        specularity: f64,
        roughness: f64,
    },
    /// Translucent plastic: `transmissivity` of the non-specular light passes
    /// through, `transmitted_specular` of that is specular (unscattered).
    Trans {
        color: Color,
        specularity: f64,
        roughness: f64,
        transmissivity: f64,
        transmitted_specular: f64,
    },
    /// Thin glass: transmission per channel at normal incidence, index (default 1.52).
    Glass { transmission: Color, index: f64 },
    /// Boundary between media: transmission per unit length, index, Hartmann constant.
    Dielectric {
        transmission: Color,
        index: f64,
        hartmann: f64,
    },
    /// Perfect specular reflector.
    Mirror { color: Color },
    /// Emitter (light source when on a surface sampled as area light).
    Light { radiance: Color },
    /// Emitter that is not sampled as a light beyond `max_radius` (0 = never a source).
    Glow { radiance: Color, max_radius: f64 },
    /// Emitter for direct light only; seen directly or in reflections as its alternate material.
    Illum {
        radiance: Color,
        alternate: Option<MaterialId>,
    },
    /// Directional emitter: full output within `angle_deg` of `direction` (if given; else of the surface normal).
    Spotlight {
        radiance: Color,
        angle_deg: f64,
        direction: Vec3,
    },
    /// Radiance `mist`: the invisible boundary of a participating medium.
    /// Inside, rays gain `extinction` per unit length, take `albedo` and
    /// `gecc` (Henyey-Greenstein eccentricity) where given, and scatter the
    /// light of the sources whose object names are in `sources`.
    Mist {
        extinction: Color,
        albedo: Option<Color>,
        gecc: Option<f64>,
        sources: Vec<String>,
    },
    /// A mixture of two materials (`mixfunc`, `mixdata`, `mixpict`,
    /// `mixtext` whose sides are materials): `modifier` computes the
    /// foreground fraction per ray ([`crate::modifier::Patterns::mix_coefficient`]);
    /// a side of `None` (`void`) lets the ray pass through.
    Mix {
        fore: Option<MaterialId>,
        back: Option<MaterialId>,
        modifier: crate::modifier::ModifierId,
    },
}

impl Material {
    /// True for materials whose surfaces emit light.
    pub fn is_emitter(&self) -> bool {
        matches!(
            self,
            Material::Light { .. }
                | Material::Glow { .. }
                | Material::Illum { .. }
                | Material::Spotlight { .. }
        )
    }
}

/// How a light source is sampled for direct lighting.
#[derive(Debug, Clone, PartialEq)]
pub enum LightKind {
    /// An emitting surface in the scene, sampled over its area (subdivided
    /// into patches per `-ds`). The object is `Scene::objects[object]`.
    Area { object: ObjectId },
    /// Radiance `source`: a distant light in direction `dir` (unit, towards
    /// the light) subtending `solid_angle` steradians.
    Distant { dir: Vec3, solid_angle: f64 },
}

#[derive(Debug, Clone, PartialEq)]
pub struct Light {
    pub kind: LightKind,
    pub material: MaterialId,
}

/// Counts reported like the paper's Table 1.
#[derive(Debug, Clone, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct SceneStats {
    /// Top-level objects (primitives + instances).
    pub objects: usize,
    /// Geometric primitives, counting instanced geometry once.
    pub primitives: usize,
    /// Instance references.
    pub instances: usize,
    /// Materials, patterns and textures defined.
    pub materials: usize,
}

/// A loaded scene. Objects reference materials by index.
#[derive(Debug, Clone, Default)]
pub struct Scene {
    pub objects: Vec<Object>,
    pub materials: Vec<Material>,
    pub material_names: Vec<String>,
    /// Light sources, derived from emitting objects and `source` primitives.
    pub lights: Vec<Light>,
    /// Per material, the patterns and textures that modify it, in the
    /// order Radiance applies them (empty for most materials).
    pub material_mods: Vec<Vec<crate::modifier::ModifierId>>,
    /// The scene's patterns, textures and mixtures and the function
    /// program they evaluate (empty when the scene has none).
    pub patterns: std::sync::Arc<crate::modifier::Patterns>,
    /// Warnings produced while loading (unsupported patterns, ignored options), with locations.
    pub warnings: Vec<(SourceLoc, String)>,
    pub stats: SceneStats,
}

impl Scene {
    pub fn material(&self, id: MaterialId) -> &Material {
        &self.materials[id as usize]
    }

    /// The patterns and textures applied to material `id` (often none).
    #[inline]
    pub fn mods(&self, id: MaterialId) -> &[crate::modifier::ModifierId] {
        self.material_mods
            .get(id as usize)
            .map_or(&[], |v| v.as_slice())
    }

    /// World bounds of all objects.
    pub fn bounds(&self) -> Aabb {
        self.objects
            .iter()
            .fold(Aabb::EMPTY, |b, o| b.union(o.shape.bounds()))
    }
}
