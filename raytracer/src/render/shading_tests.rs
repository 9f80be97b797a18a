//! Direct lighting's requests with one source: the shortcut that skips
//! the sources' potentials (`Emitter::direct`) asks for the bundle the
//! general path asks for.

use crate::accel::Hit;
use crate::geometry::{Ray, Vec3};
use crate::render::effects::EffectsReport;
use crate::render::light::prepare_lights;
use crate::render::material::{shade, RayTask, Request, ShadeContext, ShadowBundle};
use crate::render::medium::Media;
use crate::render::options::RenderOptions;
use crate::scene::load_rad_str;

/// A floor, a lamp above it facing down, and a second lamp above that
/// facing up: the floor is behind the second lamp, which can send it
/// nothing and has no potential there.
const SCENE: &str = "
void plastic grey 0 0 5 .5 .5 .5 0 0
grey polygon floor 0 0 12 -5 -5 0 5 -5 0 5 5 0 -5 5 0
void light bright 0 0 3 100 100 100
bright polygon lamp_a 0 0 12 -1 -1 4 -1 1 4 1 1 4 1 -1 4
bright polygon lamp_b 0 0 12 -1 -1 6 1 -1 6 1 1 6 -1 1 6
";

/// The shadow bundles shading asks for at `point` on the floor, seen
/// from above, with the first `n` of the scene's sources.
fn bundles(n: usize, point: Vec3) -> Vec<ShadowBundle> {
    let scene = load_rad_str(SCENE, "shortcut.rad").unwrap();
    let options = RenderOptions::default();
    let lights = prepare_lights(&scene).0;
    assert_eq!(lights.len(), 2);
    let lights = &lights[..n];
    let effects = EffectsReport::analyse(&scene, &options, lights);
    let media = Media::default();
    let ctx = ShadeContext {
        scene: &scene,
        options: &options,
        lights,
        effects: &effects,
        media: &media,
    };
    let origin = point + Vec3::new(0.4, -0.3, 2.5);
    let dir = (point - origin).normalize();
    let task = RayTask::primary(Ray { origin, dir }, 0.0, f64::INFINITY, 7);
    let hit = Hit {
        t: (point - origin).length(),
        point,
        normal: Vec3::Z,
        object: 0,
        inner: None,
        surface: {
            let (m, f) = scene.objects[0].surface_at(None);
            Hit::surface_word(m, f)
        },
    };
    let mut out = Vec::new();
    shade(&ctx, &task, &hit, &mut out);
    out.into_iter()
        .filter_map(|r| match r {
            Request::Shadow(b) => Some(b),
            _ => None,
        })
        .collect()
}

#[test]
fn one_source_asks_for_the_bundle_the_general_path_asks_for() {
    for point in [
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::new(0.3, -0.2, 0.0),
        Vec3::new(-4.5, 3.0, 0.0),
    ] {
        let alone = bundles(1, point);
        let beside = bundles(2, point);
        assert_eq!(alone.len(), 1, "one bundle for the lamp at {point}");
        assert_eq!(beside.len(), 1, "the lamp behind sends nothing to {point}");
        assert_eq!(alone, beside, "at {point}");
        assert!(!alone[0].brighter);
        assert!(alone[0].reference.is_finite());
    }
}
