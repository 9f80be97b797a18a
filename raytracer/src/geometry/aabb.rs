use super::{Ray, Vec3};

/// Axis-aligned bounding box. The empty box has `min > max`.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Aabb {
    pub min: Vec3,
    pub max: Vec3,
}

impl Default for Aabb {
    fn default() -> Self {
        Self::EMPTY
    }
}

impl Aabb {
    pub const EMPTY: Aabb = Aabb {
        min: Vec3::splat(f64::INFINITY),
        max: Vec3::splat(f64::NEG_INFINITY),
    };

    pub fn new(min: Vec3, max: Vec3) -> Self {
        Self { min, max }
    }

    /// The eight corners; corner `i` takes `max` on axis x if bit 0 of `i`
    /// is set (y: bit 1, z: bit 2), `min` otherwise.
    pub fn corners(&self) -> [Vec3; 8] {
        std::array::from_fn(|i| {
            Vec3::new(
                if i & 1 == 0 { self.min.x } else { self.max.x },
                if i & 2 == 0 { self.min.y } else { self.max.y },
                if i & 4 == 0 { self.min.z } else { self.max.z },
            )
        })
    }

    pub fn from_points<I: IntoIterator<Item = Vec3>>(points: I) -> Self {
        points.into_iter().fold(Self::EMPTY, |b, p| b.grow(p))
    }

    pub fn is_empty(&self) -> bool {
        self.min.x > self.max.x || self.min.y > self.max.y || self.min.z > self.max.z
    }

    #[must_use]
    pub fn grow(self, p: Vec3) -> Self {
        Self {
            min: self.min.min(p),
            max: self.max.max(p),
        }
    }

    #[must_use]
    pub fn union(self, o: Aabb) -> Self {
        Self {
            min: self.min.min(o.min),
            max: self.max.max(o.max),
        }
    }

    #[must_use]
    pub fn intersection(self, o: Aabb) -> Self {
        Self {
            min: self.min.max(o.min),
            max: self.max.min(o.max),
        }
    }

    pub fn overlaps(&self, o: &Aabb) -> bool {
        !self.intersection(*o).is_empty()
    }

    pub fn contains(&self, p: Vec3) -> bool {
        p.cmpge(self.min).all() && p.cmple(self.max).all()
    }

    pub fn center(&self) -> Vec3 {
        (self.min + self.max) * 0.5
    }

    pub fn extent(&self) -> Vec3 {
        self.max - self.min
    }

    /// Largest absolute coordinate of the box: the scale used for robust epsilons.
    pub fn magnitude(&self) -> f64 {
        self.min.abs().max(self.max.abs()).max_element()
    }

    /// Slab test. Returns the parametric entry and exit distances clipped to
    /// `[tmin, tmax]`, or `None` if the ray misses. Conservative for rays that
    /// lie exactly in a slab plane (zero direction components give infinities
    /// that compare correctly; NaN from 0*inf is avoided by the min/max order).
    pub fn hit(&self, ray: &Ray, inv_dir: Vec3, tmin: f64, tmax: f64) -> Option<(f64, f64)> {
        let mut t0 = tmin;
        let mut t1 = tmax;
        for a in 0..3 {
            let o = ray.origin[a];
            let lo = (self.min[a] - o) * inv_dir[a];
            let hi = (self.max[a] - o) * inv_dir[a];
            // (x - o) * inf with x == o gives NaN; treat it as "inside the slab".
            let (lo, hi) = if lo <= hi { (lo, hi) } else { (hi, lo) };
            if lo > t0 {
                t0 = lo;
            }
            if hi < t1 {
                t1 = hi;
            }
        }
        // Widen by a few ulps to stay conservative against rounding.
        let eps = (t1.abs().max(t0.abs())) * 4.0 * f64::EPSILON;
        if t0 <= t1 + eps {
            Some((t0, t1))
        } else {
            None
        }
    }
}
