use super::Vec3;

/// A ray with unit-length direction.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Ray {
    pub origin: Vec3,
    pub dir: Vec3,
}

impl Ray {
    /// Builds a ray, normalising `dir`. `dir` must be finite and non-zero.
    pub fn new(origin: Vec3, dir: Vec3) -> Self {
        Self {
            origin,
            dir: dir.normalize(),
        }
    }

    /// The point at distance `t` along the ray.
    #[inline]
    pub fn at(&self, t: f64) -> Vec3 {
        self.origin + self.dir * t
    }
}

/// A ray with the per-ray constants of the watertight ray/triangle test
/// (Woop, Benthin and Wald 2013) and of slab tests precomputed. Build one per
/// ray and pass it to [`crate::geometry::Shape::intersect_prepared`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PreparedRay {
    pub ray: Ray,
    /// Component-wise `1 / dir` (infinite for zero components).
    pub inv_dir: Vec3,
    /// Axis permutation: `kz` is the dominant axis of `dir`; `kx`, `ky` keep
    /// the winding direction.
    pub kx: usize,
    pub ky: usize,
    pub kz: usize,
    /// Shear constants `dir[kx]/dir[kz]`, `dir[ky]/dir[kz]`, `1/dir[kz]`.
    pub sx: f64,
    pub sy: f64,
    pub sz: f64,
}

impl PreparedRay {
    #[inline]
    pub fn new(ray: &Ray) -> Self {
        let d = ray.dir;
        let kz = d.abs().max_position();
        let mut kx = (kz + 1) % 3;
        let mut ky = (kx + 1) % 3;
        // An array, not `DVec3`'s `Index` (a `match` per access).
        let a = d.to_array();
        if a[kz] < 0.0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        Self {
            ray: *ray,
            inv_dir: Vec3::ONE / d,
            kx,
            ky,
            kz,
            sx: a[kx] / a[kz],
            sy: a[ky] / a[kz],
            sz: 1.0 / a[kz],
        }
    }
}
