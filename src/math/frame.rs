//! Orthonormal bases for shading.

use super::Vec3;

/// An orthonormal frame whose local z axis is `n`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frame {
    pub s: Vec3,
    pub t: Vec3,
    pub n: Vec3,
}

impl Frame {
    /// Builds a frame around a unit normal (Duff et al. 2017, branchless).
    pub fn from_normal(n: Vec3) -> Frame {
        let sign = 1.0f32.copysign(n.z);
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        let s = Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
        let t = Vec3::new(b, sign + n.y * n.y * a, -n.y);
        Frame { s, t, n }
    }

    /// The frame around unit normal `n` whose `s` axis follows `tangent`
    /// projected into the tangent plane (Gram-Schmidt), as Mitsuba orients
    /// its shading frames by dp/du: it decides which way anisotropic
    /// roughness runs. Falls back to [`Frame::from_normal`] when the
    /// tangent is zero, not finite or parallel to `n`.
    pub fn from_normal_tangent(n: Vec3, tangent: Vec3) -> Frame {
        let s = (tangent - n * n.dot(tangent)).normalize_or_zero();
        if s == Vec3::ZERO {
            return Frame::from_normal(n);
        }
        Frame {
            s,
            t: n.cross(s),
            n,
        }
    }

    pub fn to_local(&self, v: Vec3) -> Vec3 {
        Vec3::new(v.dot(self.s), v.dot(self.t), v.dot(self.n))
    }

    pub fn to_world(&self, v: Vec3) -> Vec3 {
        self.s * v.x + self.t * v.y + self.n * v.z
    }

    pub fn cos_theta(v: Vec3) -> f32 {
        v.z
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_is_orthonormal() {
        for n in [
            Vec3::Z,
            -Vec3::Z,
            Vec3::X,
            Vec3::new(0.3, -0.4, 0.866).normalize(),
            Vec3::new(1e-8, 0.0, -1.0).normalize(),
        ] {
            let f = Frame::from_normal(n);
            assert!((f.s.length() - 1.0).abs() < 1e-5);
            assert!((f.t.length() - 1.0).abs() < 1e-5);
            assert!(f.s.dot(f.t).abs() < 1e-5);
            assert!(f.s.dot(f.n).abs() < 1e-5);
            assert!(f.s.cross(f.t).dot(n) > 0.999);
            let v = Vec3::new(0.2, 0.5, -0.7);
            assert!((f.to_world(f.to_local(v)) - v).length() < 1e-5);
        }
    }

    #[test]
    fn tangent_frame_follows_the_tangent() {
        let n = Vec3::new(0.3, -0.4, 0.866).normalize();
        let f = Frame::from_normal_tangent(n, Vec3::new(1.0, 0.2, 0.5));
        assert!(f.s.dot(n).abs() < 1e-6 && (f.s.length() - 1.0).abs() < 1e-6);
        assert!(f.s.cross(f.t).dot(n) > 0.999);
        // s is the tangent's projection: the tangent lies in span(s, n).
        let rest = Vec3::new(1.0, 0.2, 0.5) - f.s * f.s.dot(Vec3::new(1.0, 0.2, 0.5));
        assert!(rest.cross(n).length() < 1e-5);
        assert!(f.s.dot(Vec3::new(1.0, 0.2, 0.5)) > 0.0);
        // Degenerate tangents fall back to the normal-only frame.
        for bad in [Vec3::ZERO, n * 2.0, Vec3::splat(f32::NAN)] {
            let g = Frame::from_normal_tangent(n, bad);
            let h = Frame::from_normal(n);
            assert_eq!((g.s, g.t), (h.s, h.t));
        }
    }
}
