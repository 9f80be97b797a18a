//! Similarity transforms after Radiance's `xform`: translations, rotations
//! about the coordinate axes, uniform scaling and mirroring, applied in the
//! order they are chained (like `xform`'s arguments).

use glam::DMat4;

use super::shape::Transform;
use super::{Ray, Vec3};

impl Default for Transform {
    fn default() -> Self {
        Self::IDENTITY
    }
}

/// Exact sine and cosine for multiples of 90 degrees (so that `-rz 90`
/// maps axes onto axes exactly), `sin_cos` of the radian angle otherwise.
fn sin_cos_deg(deg: f64) -> (f64, f64) {
    let r = deg.rem_euclid(360.0);
    if r == 0.0 {
        (0.0, 1.0)
    } else if r == 90.0 {
        (1.0, 0.0)
    } else if r == 180.0 {
        (0.0, -1.0)
    } else if r == 270.0 {
        (-1.0, 0.0)
    } else {
        deg.to_radians().sin_cos()
    }
}

impl Transform {
    pub const IDENTITY: Transform = Transform {
        to_world: DMat4::IDENTITY,
        to_object: DMat4::IDENTITY,
        scale: 1.0,
    };

    /// The identity transform.
    pub fn identity() -> Self {
        Self::IDENTITY
    }

    fn from_pair(to_world: DMat4, to_object: DMat4, scale: f64) -> Self {
        Self {
            to_world,
            to_object,
            scale,
        }
    }

    /// `self` followed by `next` (object -> self -> next -> world).
    #[must_use]
    pub fn then(&self, next: &Transform) -> Transform {
        Transform {
            to_world: next.to_world * self.to_world,
            to_object: self.to_object * next.to_object,
            scale: self.scale * next.scale,
        }
    }

    /// The inverse transform (world and object swapped).
    #[must_use]
    pub fn inverse(&self) -> Transform {
        Transform {
            to_world: self.to_object,
            to_object: self.to_world,
            scale: 1.0 / self.scale,
        }
    }

    /// Followed by a translation by `v` (`xform -t`).
    #[must_use]
    pub fn translate(self, v: Vec3) -> Transform {
        self.then(&Self::from_pair(
            DMat4::from_translation(v),
            DMat4::from_translation(-v),
            1.0,
        ))
    }

    fn rotation(axis: usize, deg: f64) -> Transform {
        let (s, c) = sin_cos_deg(deg);
        let make = |s: f64| {
            let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
            let mut m = [[0.0; 4]; 4];
            m[3][3] = 1.0;
            m[axis][axis] = 1.0;
            // Column-major: m[col][row]. Rotation by the right-hand rule about `axis`.
            m[u][u] = c;
            m[u][v] = s;
            m[v][u] = -s;
            m[v][v] = c;
            DMat4::from_cols_array_2d(&m)
        };
        Self::from_pair(make(s), make(-s), 1.0)
    }

    /// Followed by a rotation of `deg` degrees about the x axis (`xform -rx`).
    #[must_use]
    pub fn rotate_x(self, deg: f64) -> Transform {
        self.then(&Self::rotation(0, deg))
    }

    /// Followed by a rotation of `deg` degrees about the y axis (`xform -ry`).
    #[must_use]
    pub fn rotate_y(self, deg: f64) -> Transform {
        self.then(&Self::rotation(1, deg))
    }

    /// Followed by a rotation of `deg` degrees about the z axis (`xform -rz`).
    #[must_use]
    pub fn rotate_z(self, deg: f64) -> Transform {
        self.then(&Self::rotation(2, deg))
    }

    /// Followed by a uniform scaling by `s` (`xform -s`); `s` must be finite and positive.
    pub fn scale(self, s: f64) -> Result<Transform, String> {
        if !s.is_finite() || s <= 0.0 {
            return Err(format!("scale factor must be positive and finite, got {s}"));
        }
        Ok(self.then(&Self::from_pair(
            DMat4::from_scale(Vec3::splat(s)),
            DMat4::from_scale(Vec3::splat(1.0 / s)),
            s,
        )))
    }

    fn mirror(axis: usize) -> Transform {
        let mut v = Vec3::ONE;
        v[axis] = -1.0;
        let m = DMat4::from_scale(v);
        Self::from_pair(m, m, 1.0)
    }

    /// Followed by a mirror across the plane x = 0 (`xform -mx`).
    #[must_use]
    pub fn mirror_x(self) -> Transform {
        self.then(&Self::mirror(0))
    }

    /// Followed by a mirror across the plane y = 0 (`xform -my`).
    #[must_use]
    pub fn mirror_y(self) -> Transform {
        self.then(&Self::mirror(1))
    }

    /// Followed by a mirror across the plane z = 0 (`xform -mz`).
    #[must_use]
    pub fn mirror_z(self) -> Transform {
        self.then(&Self::mirror(2))
    }

    /// True when the transform reverses handedness (an odd number of
    /// mirrors). A loader that transforms polygon vertices directly must then
    /// reverse their order to keep the surface orientation, as `xform` does.
    pub fn is_mirror(&self) -> bool {
        glam::DMat3::from_mat4(self.to_world).determinant() < 0.0
    }

    /// True when all matrix entries are finite.
    pub fn is_finite(&self) -> bool {
        self.to_world.is_finite() && self.to_object.is_finite() && self.scale.is_finite()
    }

    /// Object-space point to world space.
    #[inline]
    pub fn point(&self, p: Vec3) -> Vec3 {
        self.to_world.transform_point3(p)
    }

    /// Object-space direction to world space (scaled by `scale`).
    #[inline]
    pub fn vector(&self, v: Vec3) -> Vec3 {
        self.to_world.transform_vector3(v)
    }

    /// Object-space unit normal to a world-space unit normal. For a
    /// similarity transform the inverse transpose is the rotation/mirror part,
    /// so the normal is the mirror image of the original one (which is what
    /// `xform` produces by also reversing polygon vertex order).
    #[inline]
    pub fn normal(&self, n: Vec3) -> Vec3 {
        self.to_world.transform_vector3(n).normalize()
    }

    /// World-space point to object space.
    #[inline]
    pub fn inv_point(&self, p: Vec3) -> Vec3 {
        self.to_object.transform_point3(p)
    }

    /// World-space direction to object space.
    #[inline]
    pub fn inv_vector(&self, v: Vec3) -> Vec3 {
        self.to_object.transform_vector3(v)
    }

    /// A world-space ray in object space, with unit direction, and the factor
    /// `k` such that an object-space distance `t_obj` is the world distance
    /// `t_obj / k` (`k` is `1 / scale` up to rounding).
    #[inline]
    pub fn ray_to_object(&self, ray: &Ray) -> (Ray, f64) {
        let o = self.inv_point(ray.origin);
        let d = self.inv_vector(ray.dir);
        let k = d.length();
        (
            Ray {
                origin: o,
                dir: d / k,
            },
            k,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: Vec3, b: Vec3) -> bool {
        (a - b).length() <= 1e-12 * (1.0 + a.length().max(b.length()))
    }

    #[test]
    fn rotations_follow_right_hand_rule() {
        let t = Transform::identity().rotate_z(90.0);
        assert_eq!(t.point(Vec3::X), Vec3::Y);
        let t = Transform::identity().rotate_x(90.0);
        assert_eq!(t.point(Vec3::Y), Vec3::Z);
        let t = Transform::identity().rotate_y(90.0);
        assert_eq!(t.point(Vec3::Z), Vec3::X);
        let t = Transform::identity().rotate_z(30.0);
        assert!(close(
            t.point(Vec3::X),
            Vec3::new(30f64.to_radians().cos(), 0.5, 0.0)
        ));
    }

    #[test]
    fn chain_order_and_inverse() {
        // Rotate, then translate (xform -rz 90 -t 1 0 0).
        let t = Transform::identity()
            .rotate_z(90.0)
            .translate(Vec3::new(1.0, 0.0, 0.0));
        assert!(close(t.point(Vec3::X), Vec3::new(1.0, 1.0, 0.0)));
        let t = t.scale(2.0).unwrap().mirror_y().rotate_x(17.0);
        assert_eq!(t.scale, 2.0);
        assert!(t.is_mirror());
        let p = Vec3::new(0.3, -2.0, 5.0);
        assert!(close(t.inv_point(t.point(p)), p));
        assert!(close(t.inverse().point(t.point(p)), p));
        let id = t.then(&t.inverse());
        assert!(close(id.point(p), p));
        assert!((id.scale - 1.0).abs() < 1e-15);
        // Distances scale by `scale`.
        let q = Vec3::new(1.0, 1.0, 1.0);
        assert!(((t.point(p) - t.point(q)).length() - 2.0 * (p - q).length()).abs() < 1e-12);
        assert!(t.scale(0.0).is_err());
        assert!(t.scale(f64::NAN).is_err());
        assert!(t.scale(-1.0).is_err());
    }

    #[test]
    fn ray_to_object_distance_factor() {
        let t = Transform::identity()
            .scale(4.0)
            .unwrap()
            .rotate_y(33.0)
            .translate(Vec3::new(5.0, 1.0, 2.0));
        let ray = Ray::new(Vec3::new(1.0, 2.0, 3.0), Vec3::new(0.2, -0.4, 1.0));
        let (r, k) = t.ray_to_object(&ray);
        assert!((k - 0.25).abs() < 1e-15);
        let t_world = 3.7;
        let p_obj = r.at(t_world * k);
        assert!(close(t.point(p_obj), ray.at(t_world)));
    }
}
