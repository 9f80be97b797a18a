//! What shading needs from the geometry: nearest hit and any hit.
//!
//! The sequential renderer casts through a hierarchy over the whole scene
//! ([`BvhCaster`]); the octree ([`OctreeCaster`]) answers the same queries
//! exactly, and other casters (over a subset of the octree's cells, say)
//! implement [`RayCaster`] too.

use crate::accel::{intersect_brute_force, occluded_brute_force, Bvh, Hit, Octree};
use crate::geometry::{Aabb, Ray, Segment};
use crate::scene::{Object, ObjectId};

/// Ray queries against scene geometry.
pub trait RayCaster {
    /// Nearest hit with `tmin < t < tmax`.
    fn intersect(&self, ray: &Ray, tmin: f64, tmax: f64) -> Option<Hit>;
    /// True if an object other than `ignore` is hit with `tmin < t < tmax`.
    fn occluded(&self, ray: &Ray, tmin: f64, tmax: f64, ignore: Option<ObjectId>) -> bool;
    /// Whether [`RayCaster::occluded_packet`] traces its rays together
    /// (faster than one at a time for coherent rays); where it does not,
    /// callers trace them one at a time as they need them.
    fn traces_packets(&self) -> bool {
        false
    }
    /// `out[i]`: [`RayCaster::occluded`] of `rays[i]` with `ignore`, for
    /// at most [`crate::geometry::PACKET`] rays.
    fn occluded_packet(&self, rays: &[Segment], ignore: Option<ObjectId>, out: &mut [bool]) {
        for ((ray, tmin, tmax), o) in rays.iter().zip(out) {
            *o = self.occluded(ray, *tmin, *tmax, ignore);
        }
    }
    /// `out[i]`: [`RayCaster::intersect`] of `rays[i]`, bit for bit, for at
    /// most [`crate::geometry::PACKET`] rays (traced together where
    /// [`RayCaster::traces_packets`]).
    fn intersect_packet(&self, rays: &[Segment], out: &mut [Option<Hit>]) {
        for ((ray, tmin, tmax), o) in rays.iter().zip(out) {
            *o = self.intersect(ray, *tmin, *tmax);
        }
    }
    /// Tells the caster that the queries to come are one shadow bundle's
    /// (rays from one point towards one light), lying mostly inside
    /// `region` where it is given, so that it may share among them what it
    /// learns from the first (see `parallel/bundle_judge.rs`). A hint
    /// only: every answer stays the same.
    fn begin_bundle(&self, _region: Option<&Aabb>) {}
}

/// Casts rays through an octree built over `objects`.
#[derive(Debug, Clone, Copy)]
pub struct OctreeCaster<'a> {
    pub octree: &'a Octree,
    pub objects: &'a [Object],
}

impl RayCaster for OctreeCaster<'_> {
    #[inline]
    fn intersect(&self, ray: &Ray, tmin: f64, tmax: f64) -> Option<Hit> {
        self.octree.intersect(self.objects, ray, tmin, tmax)
    }

    #[inline]
    fn occluded(&self, ray: &Ray, tmin: f64, tmax: f64, ignore: Option<ObjectId>) -> bool {
        self.octree.occluded(self.objects, ray, tmin, tmax, ignore)
    }
}

/// Casts rays through a [`Bvh`] built over `objects`.
#[derive(Debug, Clone, Copy)]
pub struct BvhCaster<'a> {
    pub bvh: &'a Bvh,
    pub objects: &'a [Object],
}

impl RayCaster for BvhCaster<'_> {
    #[inline]
    fn intersect(&self, ray: &Ray, tmin: f64, tmax: f64) -> Option<Hit> {
        self.bvh.intersect(self.objects, ray, tmin, tmax)
    }

    #[inline]
    fn occluded(&self, ray: &Ray, tmin: f64, tmax: f64, ignore: Option<ObjectId>) -> bool {
        self.bvh.occluded(self.objects, ray, tmin, tmax, ignore)
    }

    fn traces_packets(&self) -> bool {
        true
    }

    fn occluded_packet(&self, rays: &[Segment], ignore: Option<ObjectId>, out: &mut [bool]) {
        self.bvh.occluded_packet(self.objects, rays, ignore, out)
    }

    fn intersect_packet(&self, rays: &[Segment], out: &mut [Option<Hit>]) {
        self.bvh.intersect_packet(self.objects, rays, out)
    }
}

/// Tests every object: the reference the octree is checked against.
#[derive(Debug, Clone, Copy)]
pub struct BruteForceCaster<'a>(pub &'a [Object]);

impl RayCaster for BruteForceCaster<'_> {
    fn intersect(&self, ray: &Ray, tmin: f64, tmax: f64) -> Option<Hit> {
        intersect_brute_force(self.0, ray, tmin, tmax)
    }

    fn occluded(&self, ray: &Ray, tmin: f64, tmax: f64, ignore: Option<ObjectId>) -> bool {
        occluded_brute_force(self.0, ray, tmin, tmax, ignore)
    }
}
