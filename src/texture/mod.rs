//! Textures: values that vary over a surface with the hit's (u, v), as
//! Mitsuba 3 defines them (`textures/*.cpp`). One kind per file; a BSDF
//! parameter that accepts a texture holds a [`Texture`], and a constant is
//! the `Constant` kind, so untextured scenes pay one match per lookup.

mod bitmap;
mod checkerboard;
mod mesh_attribute;
mod nori_checker;

pub use bitmap::{BitmapTexture, FilterType, TextureImage, WrapMode};
pub use checkerboard::Checkerboard;
pub use mesh_attribute::{BindError, MeshAttributeTexture};
pub use nori_checker::{CheckerRule, NoriChecker};

use crate::color::{luminance, Rgb};
use crate::math::{Vec2, Vec3};

/// Where a texture (or a BSDF with textures) is read at a hit: its (u, v)
/// and, for per-vertex and per-face mesh data, its triangle and the
/// barycentrics (b1, b2) of the point in it (zero on spheres). A bare uv
/// converts into one.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SurfacePoint {
    pub uv: Vec2,
    pub prim: u32,
    pub bary: Vec2,
    /// dp/du, dp/dv and the geometric normal in the local shading frame,
    /// for bump maps; zero unless the shape's BSDF asks for them
    /// ([`crate::bsdf::Bsdf::needs_differentials`]).
    pub dp_du: Vec3,
    pub dp_dv: Vec3,
    pub ng: Vec3,
}

impl From<Vec2> for SurfacePoint {
    #[inline]
    fn from(uv: Vec2) -> SurfacePoint {
        SurfacePoint {
            uv,
            ..SurfacePoint::default()
        }
    }
}

/// The closed set of textures.
#[derive(Clone, Debug, PartialEq)]
pub enum Texture {
    Constant(Rgb),
    Bitmap(BitmapTexture),
    Checkerboard(Checkerboard),
    /// The Nori forks' checkerboards (ETH's and the Zaragoza fork's).
    NoriChecker(NoriChecker),
    /// A mesh's per-vertex or per-face data (boxed: rare).
    MeshAttribute(Box<MeshAttributeTexture>),
}

impl From<Rgb> for Texture {
    fn from(c: Rgb) -> Texture {
        Texture::Constant(c)
    }
}

impl Texture {
    /// The colour at a surface point (or a bare uv).
    #[inline]
    pub fn eval(&self, at: impl Into<SurfacePoint>) -> Rgb {
        let at = at.into();
        match self {
            Texture::Constant(c) => *c,
            Texture::Bitmap(t) => t.eval(at.uv),
            Texture::Checkerboard(t) => t.eval(at.uv),
            Texture::NoriChecker(t) => t.eval(at.uv),
            Texture::MeshAttribute(t) => t.eval(at),
        }
    }

    /// A single value at `uv` (roughness, opacity): Mitsuba's `eval_1`,
    /// which is a bitmap's luminance but a constant colour's channel mean
    /// (its `srgb` texture's `mean()`); a grey's value either way.
    #[inline]
    pub fn eval_1(&self, at: impl Into<SurfacePoint>) -> f32 {
        let at = at.into();
        match self {
            Texture::Constant(c) => channel_mean(*c),
            Texture::Bitmap(t) => luminance(t.eval(at.uv)),
            Texture::Checkerboard(t) => t.eval_1(at.uv),
            Texture::NoriChecker(t) => t.eval_1(at.uv),
            // One channel is stored in all three; three read as luminance.
            Texture::MeshAttribute(t) => luminance(t.eval(at)),
        }
    }

    /// The gradient of [`Texture::eval_1`] with respect to (u, v), for bump
    /// maps: a bilinear bitmap's slopes; zero for the rest, whose values
    /// are constant or piecewise constant (Mitsuba has no gradient for
    /// them either).
    #[inline]
    pub fn eval_1_grad(&self, at: impl Into<SurfacePoint>) -> Vec2 {
        match self {
            Texture::Bitmap(t) => t.eval_1_grad(at.into().uv),
            _ => Vec2::ZERO,
        }
    }

    /// The value if it does not vary.
    pub fn constant(&self) -> Option<Rgb> {
        match self {
            Texture::Constant(c) => Some(*c),
            _ => None,
        }
    }

    /// Mean colour over the unit uv square (Mitsuba's `mean()`, per
    /// channel): what lobe-selection weights are computed from.
    pub fn mean(&self) -> Rgb {
        match self {
            Texture::Constant(c) => *c,
            Texture::Bitmap(t) => t.image().mean(),
            Texture::Checkerboard(t) => (t.color0 + t.color1) * 0.5,
            Texture::NoriChecker(t) => t.mean(),
            Texture::MeshAttribute(t) => t.mean(),
        }
    }

    /// The mean of [`Texture::eval_1`] over the unit uv square (both are
    /// linear in the colour, so it is the single value of the mean colour).
    pub fn mean_1(&self) -> f32 {
        match self {
            Texture::Bitmap(t) => luminance(t.image().mean()),
            Texture::MeshAttribute(t) => luminance(t.mean()),
            _ => channel_mean(self.mean()),
        }
    }

    /// The largest value in any channel anywhere.
    pub fn max_value(&self) -> f32 {
        match self {
            Texture::Constant(c) => c.max_element(),
            Texture::Bitmap(t) => t.image().max_value(),
            Texture::Checkerboard(t) => t.color0.max_element().max(t.color1.max_element()),
            Texture::NoriChecker(t) => t.max_value(),
            Texture::MeshAttribute(t) => t.max_value(),
        }
    }

    /// Visits a mesh attribute texture (to bind it to its mesh).
    pub fn mesh_attribute_mut(&mut self) -> Option<&mut MeshAttributeTexture> {
        match self {
            Texture::MeshAttribute(t) => Some(t),
            _ => None,
        }
    }

    /// True unless it is a constant.
    pub fn is_varying(&self) -> bool {
        !matches!(self, Texture::Constant(_))
    }
}

/// Mitsuba's `to_uv`: a 2D affine map applied to the hit's uv before a
/// lookup (the 2x2 part and the x/y translation of the XML transform).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UvTransform {
    /// Rows of the 2x3 matrix.
    pub row0: [f32; 3],
    pub row1: [f32; 3],
}

impl Default for UvTransform {
    fn default() -> Self {
        UvTransform::IDENTITY
    }
}

impl UvTransform {
    pub const IDENTITY: UvTransform = UvTransform {
        row0: [1.0, 0.0, 0.0],
        row1: [0.0, 1.0, 0.0],
    };

    /// From a 4x4 scene transform, as Mitsuba reads a 3D transform given
    /// for a 2D one: x and y rows, x and y columns and the translation.
    pub fn from_mat4(m: &crate::math::Mat4) -> UvTransform {
        UvTransform {
            row0: [m.x_axis.x, m.y_axis.x, m.w_axis.x],
            row1: [m.x_axis.y, m.y_axis.y, m.w_axis.y],
        }
    }

    #[inline]
    pub fn apply(&self, uv: Vec2) -> Vec2 {
        if *self == UvTransform::IDENTITY {
            return uv;
        }
        Vec2::new(
            self.row0[0] * uv.x + self.row0[1] * uv.y + self.row0[2],
            self.row1[0] * uv.x + self.row1[1] * uv.y + self.row1[2],
        )
    }
}

/// A texel or square coordinate within +-2^30 (NaN and infinities become
/// 0), so any uv reads some texel or square, integer casts stay defined
/// and interpolation weights stay finite.
#[inline]
pub(crate) fn bounded(x: f32) -> f32 {
    if x.is_finite() {
        x.clamp(-1073741824.0, 1073741824.0)
    } else {
        0.0
    }
}

/// The mean of a colour's channels: Mitsuba's `eval_1` of a constant
/// (`srgb`) colour.
#[inline]
pub(crate) fn channel_mean(c: Rgb) -> f32 {
    (c.x + c.y + c.z) / 3.0
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Mitsuba's `eval_1`: a constant colour's channel mean (its `srgb`
    /// texture's `mean()`), not its luminance; a checkerboard's squares
    /// likewise. (A bitmap's is its luminance: `bitmap.rs`.)
    #[test]
    fn eval_1_of_constants_is_the_channel_mean() {
        let c = Texture::Constant(Rgb::new(0.5, 0.7, 0.3));
        assert!((c.eval_1(Vec2::ZERO) - 0.5).abs() < 1e-6);
        let board = Texture::Checkerboard(Checkerboard {
            color0: Rgb::new(0.9, 0.0, 0.0),
            color1: Rgb::new(0.0, 0.0, 0.6),
            to_uv: UvTransform::default(),
        });
        let values = [0.25f32, 0.75].map(|u| board.eval_1(Vec2::new(u, 0.25)));
        let near = |x: f32| values.iter().any(|v| (v - x).abs() < 1e-6);
        assert!(near(0.3) && near(0.2), "{values:?}");
        // mean_1 is the mean of eval_1 over the squares.
        assert!((board.mean_1() - 0.25).abs() < 1e-6);
        assert!((c.mean_1() - 0.5).abs() < 1e-6);
    }
}
