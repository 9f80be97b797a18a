//! Antimatter (Radiance's `m_clip.c`): volumes cut out of other volumes.
//!
//! Every ray carries a clip set (a bit mask; each material some
//! `antimatter` names has one bit, [`Scene::clip_bit`]). A ray meeting an
//! antimatter surface from its front enters the antimatter: the named
//! materials join its clip set; meeting it from behind it leaves and they
//! are removed. Either way the ray passes on unchanged. Surfaces of
//! materials in the clip set are not there for the ray. Children inherit
//! their parent's clip set; shadow rays carry it too and update it the
//! same way.
//!
//! Radiance 5.4 would shade the antimatter surface as its first named
//! material where a ray leaves it into that material's volume, but its
//! test (`rp->rtype == RAYREFL`, a single ray type compared with a mask of
//! several) never holds, so the reference images show the surface as
//! invisible everywhere; so does this renderer.

use crate::accel::Hit;
use crate::geometry::Vec3;
use crate::scene::{Material, MaterialId, Scene};

/// How a ray with clip set `clip` travelling in `dir` fares at `hit` on a
/// surface of `material`: `Some(new clip set)` if it passes through
/// (the surface is clipped away, or is antimatter), `None` if the surface
/// is there.
#[inline]
pub fn pass_through(
    scene: &Scene,
    clip: u64,
    dir: Vec3,
    hit: &Hit,
    material: MaterialId,
) -> Option<u64> {
    if clip & scene.clip_bit(material) != 0 {
        return Some(clip);
    }
    match scene.material(material) {
        Material::Antimatter { clips, .. } => {
            let entering = -dir.dot(hit.normal) > 0.0;
            Some(if entering {
                clip | clips
            } else {
                clip & !clips
            })
        }
        _ => None,
    }
}
