//! What travels to a pixel's owner: the records of the nodes of its ray
//! tree, keyed by their paths ([`NodeKey`]), and what a node's value is
//! made of ([`Child`]); assembled into pixels by [`super::tree`].

use hybrid_sched::serde::{Deserialize, Serialize};
use hybrid_sched::ByteSize;

use crate::render::ambient::{AmbientCounts, AmbientRecord, AmbientRequest};
use crate::render::RayTask;
use crate::scene::Color;

/// Names one node of a pixel's ray tree: the pixel (row-major index) and
/// the request indices leading to it from the primary ray.
#[derive(Clone, Debug, Default, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(crate = "hybrid_sched::serde")]
pub struct NodeKey {
    pub pixel: u32,
    pub path: Vec<u16>,
}

impl NodeKey {
    /// The primary ray of `pixel`.
    pub fn root(pixel: u32) -> Self {
        NodeKey {
            pixel,
            path: Vec::new(),
        }
    }

    /// The node of request `i` of this node.
    pub fn child(&self, i: usize) -> Self {
        let mut path = Vec::with_capacity(self.path.len() + 1);
        path.extend_from_slice(&self.path);
        path.push(u16::try_from(i).unwrap_or(u16::MAX));
        NodeKey {
            pixel: self.pixel,
            path,
        }
    }

    fn bytes(&self) -> usize {
        std::mem::size_of::<Self>() + 2 * self.path.len()
    }
}

/// How a request's value enters its parent.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(crate = "hybrid_sched::serde")]
pub enum Child {
    /// A traced ray: `coef` times its radiance.
    Trace(Color),
    /// A shadow bundle: its (already weighted) result.
    Shadow,
    /// An in-scattering shadow bundle: its result, added after the
    /// attenuation (these come last).
    Scatter,
    /// A shadow bundle run in the step that shaded its point: its result,
    /// carried in the record (no result of its own travels).
    Known(Color),
    /// An in-scattering bundle run there: as [`Child::Scatter`], carried.
    KnownScatter(Color),
    /// A hemisphere sampled for diffuse inter-reflection (without an
    /// irradiance cache): `coef` times its value, added before the other
    /// requests' (the sequential renderer's order).
    Ambient(Color),
    /// A sample ray of a hemisphere node ([`Record::Hemisphere`]): its
    /// value enters the mean of its stratum.
    Stratum,
    /// Where no hemisphere is sampled (its rays would exceed `-lr` or fall
    /// below `-lw`): the term, `coef` times the value taken instead
    /// (`-av`), carried (one colour, as every other child: a record's
    /// bytes are priced by its children).
    AmbientKnown(Color),
    /// With an irradiance cache: a point's `-aw` term (its `-av` term moved
    /// to the cache's average), decided where the pixel is assembled
    /// (`cursor.rs`) and added as it arrives, before the hemispheres'.
    AmbientTerm,
    /// First child of a pixel of several primary rays (`-pn`, the count):
    /// the node's value is the sum of its other children's values, in
    /// order, divided by it (`Renderer::pixel`). Carried.
    Mean(u32),
}

// A record's bytes are priced by its children (the simulated runs').
#[cfg(target_pointer_width = "64")]
const _: () = assert!(std::mem::size_of::<Child>() == 32);

impl Child {
    /// Whether its value arrives as a result of its own.
    pub(super) fn awaited(&self) -> bool {
        !matches!(
            self,
            Child::Known(_) | Child::KnownScatter(_) | Child::AmbientKnown(_) | Child::Mean(_)
        )
    }
}

/// A medium's effect on a ray's value: the factor it is multiplied by,
/// then the ambient in-scattering added.
pub type Attenuation = (Color, Color);

/// What one node contributes.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(crate = "hybrid_sched::serde")]
pub enum Record {
    /// A ray that hit a surface: the local part, the requests in order, and
    /// the medium's attenuation over the ray's length (if any): the factor
    /// and the ambient in-scattering then added.
    Shaded {
        base: Color,
        children: Vec<Child>,
        attenuation: Option<Attenuation>,
    },
    /// A final value: a ray that left the scene, or a shadow bundle's result.
    Value(Color),
    /// A hemisphere of `strata` sample rays, one per stratum (children
    /// `0..strata`), whose value is the mean over the strata
    /// ([`crate::render::ambient::strata_mean_of_first_pass`]).
    Hemisphere { strata: u16 },
    /// A hemisphere of `strata` first samples (children `0..strata`) that
    /// may take super-samples (`-as`), which depend on the first samples'
    /// values: with what the pixel's owner needs to make them once those
    /// are in ([`super::tree::PixelTrees::wanted`]).
    SuperHemisphere {
        strata: u16,
        seed: Box<HemisphereSeed>,
    },
    /// With an irradiance cache: a ray's node with what the pixel's owner
    /// decides in the sequential renderer's order (`cursor.rs`).
    Traced(Box<Traced>),
    /// With an irradiance cache: a ray's node with nothing for the owner
    /// to decide and every child's value known: its value, and the
    /// distance to its hit (infinite: it left the scene).
    Leaf(Color, f64),
    /// The answers to a lookup's leak tests ([`super::tasks::LeakDp`]),
    /// for the pixel's owner.
    Leaks(Vec<bool>),
    /// With an irradiance cache, for the master: finished pixels of the
    /// wave running with the records each made, and the cache's counts.
    WavePixels(Box<WaveBatch>),
    /// Finished pixels (row-major index, radiance) a processor sends to
    /// the master ([`super::tree::PixelTrees::ship_pixels`]), which places them in its
    /// picture ([`super::tree::PixelTrees::place_batch`]); the key names no node.
    Pixels(Vec<(u32, Color)>),
}

/// A ray's node when the pixel's owner decides the irradiance cache's
/// lookups: its [`Record::Shaded`] parts, with the ambient requests and
/// the `-aw` term left to the owner, and what a hemisphere's record needs
/// of its sample rays (the distance to the surface hit).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(crate = "hybrid_sched::serde")]
pub struct Traced {
    pub base: Color,
    /// The requests' children, then [`Child::AmbientTerm`] if `aw`, then a
    /// [`Child::Ambient`] per ambient request.
    pub children: Vec<Child>,
    pub attenuation: Option<Attenuation>,
    /// Distance to the hit (infinite: the ray left the scene).
    pub t: f64,
    /// The surface only passes the ray on: its distance is the hit's plus
    /// its first child's (Radiance's `raytrans()`).
    pub passes_on: bool,
    /// `-aw`: the point's constant term, whose `-av` moves to the cache's
    /// average.
    pub aw: Option<Color>,
    /// The ambient requests, in order, with the ray they are made for.
    pub requests: Vec<HemisphereSeed>,
}

/// Finished pixels of a wave: (row-major index, value, the records its
/// trace made in order), and what the irradiance cache did for them.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(crate = "hybrid_sched::serde")]
pub struct WaveBatch {
    pub pixels: Vec<(u32, Color, Vec<AmbientRecord>)>,
    pub counts: AmbientCounts,
}

/// What a hemisphere is made from: the ray whose hit it samples and the
/// point's request ([`crate::render::ambient::Hemisphere::new`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(crate = "hybrid_sched::serde")]
pub struct HemisphereSeed {
    pub task: RayTask,
    pub req: AmbientRequest,
}

/// A super-sampling hemisphere at the pixel's owner.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(crate = "hybrid_sched::serde")]
pub struct SuperState {
    pub seed: HemisphereSeed,
    /// The strata of the super-samples, in the order they were made
    /// (children `strata..`), once they are.
    pub second: Option<Vec<u16>>,
}

/// A super-sampling hemisphere whose samples so far are all in: its node,
/// its state and its children's values by index, for the workload to make
/// its super-samples or its value ([`super::tree::PixelTrees::await_second`],
/// [`super::tree::PixelTrees::deliver`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(crate = "hybrid_sched::serde")]
pub struct Wanted {
    pub key: NodeKey,
    pub state: SuperState,
    pub values: Vec<Color>,
}

/// A result message: one node's record, sent to the pixel's owner.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(crate = "hybrid_sched::serde")]
pub struct RtResult {
    pub key: NodeKey,
    pub record: Record,
}

impl ByteSize for RtResult {
    fn byte_size(&self) -> usize {
        let extra = match &self.record {
            Record::Shaded { children, .. } => children.len() * std::mem::size_of::<Child>(),
            Record::Value(_) | Record::Leaf(..) | Record::Hemisphere { .. } => 0,
            Record::SuperHemisphere { .. } => std::mem::size_of::<HemisphereSeed>(),
            Record::Pixels(pixels) => std::mem::size_of_val(pixels.as_slice()),
            Record::Traced(t) => {
                std::mem::size_of::<Traced>()
                    + std::mem::size_of_val(t.children.as_slice())
                    + std::mem::size_of_val(t.requests.as_slice())
            }
            Record::Leaks(answers) => answers.len(),
            Record::WavePixels(b) => b
                .pixels
                .iter()
                .map(|p| 32 + std::mem::size_of_val(p.2.as_slice()))
                .sum(),
        };
        self.key.bytes() + std::mem::size_of::<Record>() + extra
    }
}
