//! Sensors and what they hold: `perspective` and `thinlens` sensors, the
//! `hdrfilm`, reconstruction filters and samplers.

use super::{Child, Ctx};
use crate::camera::{Aperture, CameraParam, CameraParams, FovAxis, MAX_RESOLUTION};
use crate::image::{Filter, FilterParam, MAX_FILTER_RADIUS};
use crate::load::props::{int_in, Kind, Props};
use crate::load::xml::{Pos, SceneNode};
use crate::load::SceneError;
use crate::math::{Aabb, Mat4, Transform, Vec3};
use crate::sampling::SamplerKind;

type Result<T> = std::result::Result<T, SceneError>;

/// A sensor with its film and sampler.
pub(super) struct SensorDesc {
    pub camera: CameraParams,
    pub filter: Filter,
    pub spp: u32,
    pub sampler: SamplerKind,
    /// The medium the camera sits in.
    pub medium: Option<u32>,
}

impl<'d> Ctx<'d> {
    /// `perspective`, `thinlens` and `orthographic` (Mitsuba's
    /// `sensors/perspective.cpp`, `thinlens.cpp`, `orthographic.cpp`,
    /// `render/sensor.cpp`): image x runs towards camera -x and y towards
    /// -y, exactly lente's camera, so `to_world` is used as it is (with its
    /// scale, which sizes the orthographic sensor plane).
    pub(super) fn sensor(&mut self, node: &'d SceneNode) -> Result<SensorDesc> {
        let ty = self.object_type(
            node,
            &["perspective", "thinlens", "orthographic"],
            &[
                "telecentric",
                "radiancemeter",
                "irradiancemeter",
                "distant",
                "batch",
                "fisheye",
            ],
        )?;
        let owner = format!("<sensor type=\"{ty}\">");
        let (mut p, children) = self.read_object(node, &owner)?;
        let mut film: Option<Child> = None;
        let mut sampler: Option<Child> = None;
        let mut medium: Option<Child> = None;
        for c in children {
            let slot = match c.node.tag.as_str() {
                "film" => &mut film,
                "sampler" => &mut sampler,
                "medium" => &mut medium,
                _ => return Err(self.misplaced(&c, &owner)),
            };
            if let Some(first) = slot {
                return Err(self.err(
                    c.at,
                    format!(
                        "a sensor can have only one <{}> (the first is at {})",
                        c.node.tag, first.at
                    ),
                ));
            }
            *slot = Some(c);
        }
        let (width, height, filter) = match &film {
            Some(c) => self.enter(c, |x| x.film(c.node))?,
            None => (768, 576, mitsuba_gaussian(0.5)),
        };
        let (spp, sampler) = match &sampler {
            Some(c) => self.enter(c, |x| x.sampler(c.node))?,
            None => (4, SamplerKind::Independent),
        };
        let medium = match &medium {
            Some(c) => Some(self.medium_index(c)?),
            None => None,
        };
        let aspect = width as f64 / height as f64;
        let orthographic = ty == "orthographic";
        let (fov_x, fov_axis) = if orthographic {
            // Unused: the sensor plane's size is to_world's scale.
            (30.0, crate::camera::FovAxis::X)
        } else {
            horizontal_fov(&mut p, aspect)?
        };
        let near_clip = p.get_float("near_clip", 1e-2)?;
        let far_clip = p.get_float("far_clip", 1e4)?;
        // Mitsuba asks more of near_clip than lente's camera does.
        if near_clip <= 0.0 {
            return Err(p.error(
                "near_clip",
                format!("'near_clip' must be positive, found {near_clip}"),
            ));
        }
        // Read by both types (Mitsuba's ProjectiveCamera); default far_clip.
        let focus_distance = p.get_float("focus_distance", far_clip)?;
        let to_world = p.get_transform("to_world", Transform::IDENTITY)?;
        if has_scale(&to_world) && !orthographic {
            return Err(p.error(
                "to_world",
                "scale factors in a sensor's to_world are not allowed (Mitsuba refuses them too); \
                 use only rotations, translations and lookat",
            ));
        }
        let (lens_radius, focal_distance) = if ty == "thinlens" {
            let r = p.require_float("aperture_radius")?;
            if r == 0.0 {
                p.warn(
                    "aperture_radius",
                    "'aperture_radius' is 0: this thin lens is a pinhole",
                );
            }
            (r, focus_distance)
        } else {
            // A pinhole has no focus: the distance is never used.
            (0.0, far_clip)
        };
        for name in ["principal_point_offset_x", "principal_point_offset_y"] {
            let v = p.get_float(name, 0.0)?;
            if v != 0.0 {
                return Err(p.error(name, format!("'{name}' is not supported (only 0)")));
            }
        }
        let open = p.get_float("shutter_open", 0.0)?;
        let close = p.get_float("shutter_close", 0.0)?;
        if close < open {
            return Err(p.error(
                "shutter_close",
                "'shutter_close' must not come before 'shutter_open'",
            ));
        }
        let camera = CameraParams {
            width,
            height,
            fov_x_deg: fov_x,
            fov_axis,
            near_clip,
            far_clip,
            to_world,
            lens_radius,
            focal_distance,
            aperture: Aperture::Circular,
            autofocus: false,
            projection: if orthographic {
                crate::camera::Projection::Orthographic
            } else {
                crate::camera::Projection::Perspective
            },
        };
        camera
            .validate()
            .map_err(|e| p.param_error(mitsuba_camera_name(e.param()), e))?;
        p.finish(&mut self.warnings);
        Ok(SensorDesc {
            camera,
            filter,
            spp,
            sampler,
            medium,
        })
    }

    /// `hdrfilm` (Mitsuba's `render/film.cpp`, `films/hdrfilm.cpp`):
    /// 768 x 576 and a gaussian filter by default. Output formats are
    /// accepted and ignored (lente writes EXR and PNG).
    pub(super) fn film(&mut self, node: &'d SceneNode) -> Result<(u32, u32, Filter)> {
        let ty = self.object_type(node, &["hdrfilm"], &["specfilm", "tape"])?;
        let owner = format!("<film type=\"{ty}\">");
        let (mut p, children) = self.read_object(node, &owner)?;
        let width = int_in(&mut p, "width", 768, 1, MAX_RESOLUTION as i64)? as u32;
        let height = int_in(&mut p, "height", 576, 1, MAX_RESOLUTION as i64)? as u32;
        let cx = p.get_int("crop_offset_x", 0)?;
        let cy = p.get_int("crop_offset_y", 0)?;
        let cw = p.get_int("crop_width", width as i64)?;
        let ch = p.get_int("crop_height", height as i64)?;
        if (cx, cy, cw, ch) != (0, 0, width as i64, height as i64) {
            let name = [
                "crop_offset_x",
                "crop_offset_y",
                "crop_width",
                "crop_height",
            ]
            .into_iter()
            .find(|n| p.has(n))
            .unwrap_or("crop_width");
            return Err(p.error(
                name,
                "crop windows are not supported: render the full image and crop it afterwards",
            ));
        }
        p.get_bool("sample_border", false)?;
        for (name, default, known) in [
            (
                "pixel_format",
                "rgb",
                &["luminance", "luminance_alpha", "rgb", "rgba", "xyz", "xyza"][..],
            ),
            (
                "component_format",
                "float16",
                &["float16", "float32", "uint32"][..],
            ),
            (
                "file_format",
                "openexr",
                &["openexr", "exr", "rgbe", "pfm"][..],
            ),
        ] {
            let v = p.get_string(name, default.into())?.to_ascii_lowercase();
            if !known.contains(&v.as_str()) {
                p.warn(
                    name,
                    format!(
                        "unknown {name} '{v}' (Mitsuba knows {}); ignored: lente writes RGB EXR and PNG",
                        known.join(", ")
                    ),
                );
            }
        }
        p.finish(&mut self.warnings);
        let mut filter: Option<(Filter, Pos)> = None;
        for c in children {
            if c.node.tag != "rfilter" {
                return Err(self.misplaced(&c, &owner));
            }
            if let Some((_, first)) = filter {
                return Err(self.err(
                    c.at,
                    format!("a film can have only one <rfilter> (the first is at {first})"),
                ));
            }
            filter = Some((self.enter(&c, |x| x.rfilter(c.node))?, c.at));
        }
        Ok((
            width,
            height,
            filter.map_or_else(|| mitsuba_gaussian(0.5), |f| f.0),
        ))
    }

    /// Mitsuba's `rfilters/`: box (radius 0.5), tent (radius 1), gaussian
    /// (stddev 0.5, cut off at 4 stddev), mitchell (B = C = 1/3, radius 2),
    /// catmullrom (Mitchell with B = 0, C = 1/2), lanczos (`lobes` 3).
    pub(super) fn rfilter(&mut self, node: &'d SceneNode) -> Result<Filter> {
        let ty = self.object_type(
            node,
            &[
                "box",
                "tent",
                "gaussian",
                "mitchell",
                "catmullrom",
                "lanczos",
            ],
            &[],
        )?;
        let owner = format!("<rfilter type=\"{ty}\">");
        let (mut p, children) = self.read_object(node, &owner)?;
        self.no_children(&children, &owner)?;
        let filter = match ty {
            "box" => Filter::Box { radius: 0.5 },
            "tent" => Filter::Tent {
                radius: p.get_float("radius", 1.0)?,
            },
            "gaussian" => mitsuba_gaussian(p.get_float("stddev", 0.5)?),
            "mitchell" => Filter::Mitchell {
                radius: 2.0,
                b: p.get_float("B", 1.0 / 3.0)?,
                c: p.get_float("C", 1.0 / 3.0)?,
            },
            "lanczos" => Filter::Lanczos {
                radius: int_in(&mut p, "lobes", 3, 1, MAX_FILTER_RADIUS as i64)? as f32,
            },
            _ => Filter::Mitchell {
                radius: 2.0,
                b: 0.0,
                c: 0.5,
            },
        };
        filter.validate().map_err(|e| {
            // Mitsuba's gaussian radius is 4 stddev.
            let name = match (ty, e.param()) {
                ("gaussian", FilterParam::Radius) => "stddev",
                (_, param) => crate::load::objects::filter_name(param),
            };
            p.param_error(name, &e)
        })?;
        p.finish(&mut self.warnings);
        Ok(filter)
    }

    /// Samplers: `sample_count` (default 4) and the kind of sampling.
    /// Mitsuba's stratified samplers round the count up as Mitsuba does
    /// (with its warning) and all take lente's stratified sampling
    /// (`sampling/sobol.rs`), which is stratified in 2D and in 1D like
    /// the best of them.
    pub(super) fn sampler(&mut self, node: &'d SceneNode) -> Result<(u32, SamplerKind)> {
        let ty = self.object_type(
            node,
            &[
                "independent",
                "stratified",
                "multijitter",
                "ldsampler",
                "orthogonal",
            ],
            &[],
        )?;
        let owner = format!("<sampler type=\"{ty}\">");
        let (mut p, children) = self.read_object(node, &owner)?;
        self.no_children(&children, &owner)?;
        // Every rounding below stays within u32 for counts up to 2^30.
        let asked = int_in(&mut p, "sample_count", 4, 1, 1 << 30)? as u32;
        if p.has("seed") {
            p.get_int("seed", 0)?;
            p.warn("seed", "'seed' is ignored; use lente's --seed");
        }
        let (spp, kind) = match ty {
            "independent" => (asked, SamplerKind::Independent),
            _ => {
                if ty != "ldsampler" && !p.get_bool("jitter", true)? {
                    p.warn(
                        "jitter",
                        "'jitter' false (points at the strata's centres) is not supported: \
                         lente's stratified points are always scrambled within their strata",
                    );
                }
                if ty == "orthogonal" && p.get_int("strength", 2)? != 2 {
                    p.warn(
                        "strength",
                        "'strength' is ignored: lente's stratified points are (0, 2) sequences",
                    );
                }
                (mitsuba_sample_count(ty, asked), SamplerKind::Stratified)
            }
        };
        if spp != asked {
            p.warn(
                "sample_count",
                format!(
                    "the {ty} sampler rounds 'sample_count' {asked} up to {spp}, as Mitsuba does"
                ),
            );
        }
        p.finish(&mut self.warnings);
        Ok((spp, kind))
    }
}

/// The sample count Mitsuba 3's `ty` sampler takes for `asked`:
/// `stratified` the next square, `ldsampler` the next square of a power
/// of two (at least 4), `multijitter` a grid of ceil(asked / r) x r with
/// r = floor(sqrt(asked)), `orthogonal` the next square of a prime
/// (checked against Mitsuba 3.9.1 for counts 1-1024).
pub(super) fn mitsuba_sample_count(ty: &str, asked: u32) -> u32 {
    let next_square = |ok: &dyn Fn(u32) -> bool, start: u32| {
        let mut r = start;
        while r * r < asked || !ok(r) {
            r += 1;
        }
        r * r
    };
    match ty {
        "stratified" => next_square(&|_| true, 1),
        "ldsampler" => next_square(&|r: u32| r.is_power_of_two(), 2),
        "orthogonal" => next_square(
            &|r: u32| {
                (2..r)
                    .take_while(|d| d * d <= r)
                    .all(|d| !r.is_multiple_of(d))
            },
            2,
        ),
        "multijitter" => {
            let r = asked.isqrt();
            asked.div_ceil(r) * r
        }
        _ => asked,
    }
}

/// The horizontal field of view in degrees from `fov` + `fov_axis` or
/// `focal_length` (Mitsuba's `parse_fov` in `render/sensor.cpp`; `aspect`
/// is width / height).
pub(super) fn horizontal_fov(p: &mut Props, aspect: f64) -> Result<(f32, FovAxis)> {
    if p.has("fov") && p.has("focal_length") {
        return Err(p.error(
            "focal_length",
            "give either 'fov' or 'focal_length', not both",
        ));
    }
    let (fov, axis, from) = if p.has("fov") {
        let fov = p.require_float("fov")? as f64;
        if !(fov > 0.0 && fov < 180.0) {
            return Err(p.error(
                "fov",
                format!("'fov' must be between 0 and 180 degrees (exclusive), found {fov}"),
            ));
        }
        let axis = match p
            .get_string("fov_axis", "x".into())?
            .to_ascii_lowercase()
            .as_str()
        {
            "x" => FovAxis::X,
            "y" => FovAxis::Y,
            "diagonal" => FovAxis::Diagonal,
            "smaller" => FovAxis::Smaller,
            "larger" => FovAxis::Larger,
            other => {
                return Err(p.error(
                    "fov_axis",
                    format!("unknown fov_axis '{other}'; use x, y, diagonal, smaller or larger"),
                ))
            }
        };
        (fov, axis, "fov")
    } else {
        let f = if p.kind_of("focal_length") == Some(Kind::Float)
            || p.kind_of("focal_length") == Some(Kind::Int)
        {
            p.require_float("focal_length")? as f64
        } else {
            let s = p.get_string("focal_length", "50mm".into())?;
            let t = s.trim();
            let t = t.strip_suffix("mm").unwrap_or(t).trim();
            t.parse::<f64>().map_err(|_| {
                p.error(
                    "focal_length",
                    format!("cannot read the focal length '{s}' (expected e.g. 50mm)"),
                )
            })?
        };
        if !(f > 0.0 && f.is_finite()) {
            return Err(p.error(
                "focal_length",
                format!("the focal length must be positive, found {f}"),
            ));
        }
        // The diagonal of 35 mm film (36 x 24 mm).
        let diag = (36.0f64 * 36.0 + 24.0 * 24.0).sqrt();
        (
            2.0 * (diag / (2.0 * f)).atan().to_degrees(),
            FovAxis::Diagonal,
            "focal_length",
        )
    };
    let x = axis.horizontal_fov(fov, aspect);
    if !(x > 0.0 && x < 180.0) {
        return Err(p.error(
            from,
            format!("the horizontal field of view must be between 0 and 180 degrees, found {x}"),
        ));
    }
    Ok((x as f32, axis))
}

/// Mitsuba's name of a camera parameter (the film's size and the
/// aperture's shape are no sensor properties: errors about them point at
/// the sensor).
fn mitsuba_camera_name(param: CameraParam) -> &'static str {
    match param {
        CameraParam::Width => "width",
        CameraParam::Height => "height",
        CameraParam::FieldOfView => "fov",
        CameraParam::NearClip => "near_clip",
        CameraParam::FarClip => "far_clip",
        CameraParam::LensRadius => "aperture_radius",
        CameraParam::FocalDistance => "focus_distance",
        CameraParam::ApertureBlades | CameraParam::ApertureRotation => "aperture",
    }
}

/// Mitsuba's gaussian filter: cut off at 4 standard deviations.
fn mitsuba_gaussian(stddev: f32) -> Filter {
    Filter::Gaussian {
        radius: 4.0 * stddev,
        stddev,
    }
}

/// Mitsuba's camera for a scene without a sensor (`render/scene.cpp`): fov
/// 45 along x, looking down +z from in front of the bounding box, centred
/// on it and far enough back to see all of it.
pub(super) fn default_sensor(bounds: Aabb) -> SensorDesc {
    let mut camera = CameraParams {
        width: 768,
        height: 576,
        fov_x_deg: 45.0,
        fov_axis: crate::camera::FovAxis::X,
        near_clip: 1e-2,
        far_clip: 1e4,
        to_world: Transform::IDENTITY,
        lens_radius: 0.0,
        focal_distance: 1e4,
        aperture: Aperture::Circular,
        autofocus: false,
        projection: crate::camera::Projection::Perspective,
    };
    if !bounds.is_empty() {
        let c = bounds.center();
        let ext = bounds.diagonal();
        let max = ext.max_element();
        let distance = max / (2.0 * 22.5f32.to_radians().tan());
        if max > 0.0 && distance.is_finite() {
            camera.far_clip = max * 5.0 + distance;
            camera.near_clip = distance / 100.0;
            camera.focal_distance = distance + ext.z / 2.0;
            camera.to_world = Transform::new(Mat4::from_translation(Vec3::new(
                c.x,
                c.y,
                bounds.min.z - distance,
            )))
            .unwrap_or(Transform::IDENTITY);
        }
    }
    SensorDesc {
        camera,
        filter: mitsuba_gaussian(0.5),
        spp: 4,
        sampler: SamplerKind::Independent,
        medium: None,
    }
}

/// Mitsuba's `Transform::has_scale`: M M^T differs from the identity by
/// more than 1e-3 somewhere (mirrors do not count as scale).
fn has_scale(t: &Transform) -> bool {
    !t.is_rotation(super::ROTATION_TOLERANCE)
}

#[cfg(test)]
mod tests {
    use super::mitsuba_sample_count;

    /// The counts Mitsuba 3.9.1's samplers report (`sample_count()` after
    /// `load_dict`) for these requests.
    #[test]
    fn sample_counts_round_as_mitsuba() {
        let asked = [
            1, 2, 4, 5, 8, 9, 10, 16, 20, 27, 63, 64, 65, 100, 125, 128, 256, 1000, 1024,
        ];
        let mitsuba: [(&str, [u32; 19]); 4] = [
            (
                "stratified",
                [
                    1, 4, 4, 9, 9, 9, 16, 16, 25, 36, 64, 64, 81, 100, 144, 144, 256, 1024, 1024,
                ],
            ),
            (
                "multijitter",
                [
                    1, 2, 4, 6, 8, 9, 12, 16, 20, 30, 63, 64, 72, 100, 132, 132, 256, 1023, 1024,
                ],
            ),
            (
                "ldsampler",
                [
                    4, 4, 4, 16, 16, 16, 16, 16, 64, 64, 64, 64, 256, 256, 256, 256, 256, 1024,
                    1024,
                ],
            ),
            (
                "orthogonal",
                [
                    4, 4, 4, 9, 9, 9, 25, 25, 25, 49, 121, 121, 121, 121, 169, 169, 289, 1369, 1369,
                ],
            ),
        ];
        for (ty, want) in mitsuba {
            for (n, w) in asked.iter().zip(want) {
                assert_eq!(mitsuba_sample_count(ty, *n), w, "{ty} {n}");
            }
        }
        assert_eq!(mitsuba_sample_count("independent", 10), 10);
        // The largest count the reader accepts rounds without overflow.
        for ty in ["stratified", "multijitter", "ldsampler", "orthogonal"] {
            assert!(mitsuba_sample_count(ty, 1 << 30) >= 1 << 30);
        }
    }
}
