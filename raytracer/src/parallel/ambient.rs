//! Diffuse inter-reflection in parallel.

use crate::render::Renderer;
use crate::{Error, Result};

/// The hybrid-scheduled workload assembles pixels from ray-tree records
/// and has no irradiance cache: it refuses renders that need one (or more
/// than one primary ray per pixel) instead of silently dropping the term.
pub fn check_hybrid(renderer: &Renderer<'_>) -> Result<()> {
    let o = renderer.options();
    if renderer.effects().diffuse_interreflection.enabled {
        return Err(Error::Usage(format!(
            "-ab {}: the hybrid-scheduled renderer does not compute diffuse inter-reflection; use --ambient-parallel or render sequentially",
            o.ab
        )));
    }
    if o.pn > 1 {
        return Err(Error::Usage(format!(
            "-pn {}: the hybrid-scheduled renderer traces one primary ray per pixel",
            o.pn
        )));
    }
    Ok(())
}
