//! The object reader both dialects share.
//!
//! Nori's and Mitsuba's files have the same shape: object elements
//! (`<bsdf type="...">`) holding property elements (`<float name=".."
//! value=".."/>`), nested objects, and `<transform>`s made of operations.
//! What differs is the vocabulary, described by a [`Dialect`]: which tags
//! are objects or properties, which attributes an object takes, how a
//! colour is spelled, and a few transform rules. Everything here reads the
//! format-neutral tree of [`super::xml`] and reports errors at the
//! element, attribute or token that is wrong.

use std::path::Path;

use super::props::{self, Props, Value};
use super::xml::{describe, Attribute, Pos, SceneNode};
use super::SceneError;
use crate::math::{Mat3, Mat4, Transform, Vec2, Vec3, Vec4};

type Result<T> = std::result::Result<T, SceneError>;

/// Reads the property tags a dialect has beyond the shared ones (Mitsuba's
/// `<spectrum>`): the value and where it stands, or `None` for any other tag.
pub(crate) type SpecialProperty<'f> = &'f dyn Fn(&SceneNode) -> Result<Option<(Value, Pos)>>;

/// For dialects without special property tags.
pub(crate) fn no_special(_: &SceneNode) -> Result<Option<(Value, Pos)>> {
    Ok(None)
}

/// A `<lookat>` that defines no frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
pub(crate) enum LookAtError {
    #[error("invalid <lookat>: target must differ from origin (at a finite distance)")]
    TargetAtOrigin,
    #[error("invalid <lookat>: the up vector must be non-zero and finite")]
    ZeroUp,
    #[error("invalid <lookat>: the up vector is parallel to the viewing direction")]
    ParallelUp,
}

/// The vocabulary of one scene dialect.
pub(crate) struct Dialect {
    /// Element tags that create objects.
    pub object_tags: &'static [&'static str],
    /// Property tags that become objects when they carry a `type`
    /// attribute (Mitsuba's `<spectrum type="...">`).
    pub typed_property_objects: &'static [&'static str],
    /// Element tags that set a property of the enclosing object.
    pub property_tags: &'static [&'static str],
    /// Operations inside `<transform>`.
    pub transform_ops: &'static [&'static str],
    /// Elements that may only stand directly inside `<scene>`.
    pub scene_only: &'static [&'static str],
    /// Other elements the dialect handles itself (Mitsuba's `<ref>`).
    pub other_tags: &'static [&'static str],
    /// Attributes of an object element (`type` first).
    pub object_attributes: &'static [&'static str],
    /// How a colour property's element is spelled (`color`, `rgb`).
    pub color_tag: &'static str,
    /// Points and vectors may be given as `x`, `y`, `z` attributes instead
    /// of `value`, or as one number for all three.
    pub xyz_attributes: bool,
    /// A `<matrix>` may be 3x3 as well as 4x4.
    pub matrix3: bool,
    /// A `<point>` or `<vector>` may hold two numbers (a [`Value::Pair`]:
    /// ETH's Nori writes its textures' `scale` and `delta` so).
    pub pairs: bool,
    /// The dialect's `<lookat>`: origin, target and `up` (None if not given).
    pub look_at: fn(Vec3, Vec3, Option<Vec3>) -> std::result::Result<Mat4, LookAtError>,
    /// The element of a shape (`mesh`, `shape`), where area emitters go.
    pub shape_tag: &'static str,
    /// Advice for elements the dialect does not know but a user may
    /// write (the other dialect's spelling, a fork's extension).
    pub element_hints: &'static [(&'static str, &'static str)],
}

impl Dialect {
    /// True if `node` creates an object.
    pub fn is_object(&self, node: &SceneNode) -> bool {
        let tag = node.tag.as_str();
        self.object_tags.contains(&tag)
            || (self.typed_property_objects.contains(&tag) && node.attr("type").is_some())
    }

    /// True if `node` sets a property.
    pub fn is_property(&self, node: &SceneNode) -> bool {
        self.property_tags.contains(&node.tag.as_str()) && !self.is_object(node)
    }

    /// Properties nothing asked for, for an object described as `owner`.
    pub fn props<'a>(&self, file: &'a Path, owner: &str, node: &SceneNode) -> Props<'a> {
        let mut p = Props::new(file, owner, node.pos);
        p.set_color_tag(self.color_tag);
        p
    }

    /// Reads an object element's property elements into a [`Props`] and
    /// returns its other child elements (objects and the dialect's other
    /// tags) in document order. `special` reads the property tags the
    /// shared reader does not know (`Ok(None)`: not one of them).
    pub fn read_object<'a, 'n>(
        &self,
        file: &'a Path,
        node: &'n SceneNode,
        owner: &str,
        special: SpecialProperty,
    ) -> Result<(Props<'a>, Vec<&'n SceneNode>)> {
        no_text(file, node, owner)?;
        let mut props = self.props(file, owner, node);
        let mut children = Vec::new();
        for ch in &node.children {
            let tag = ch.tag.as_str();
            if self.is_object(ch) || self.other_tags.contains(&tag) {
                children.push(ch);
            } else if self.is_property(ch) {
                self.read_property(file, ch, &mut props, special)?;
            } else {
                return Err(self.out_of_place(file, ch));
            }
        }
        Ok((props, children))
    }

    /// The error for an element that is no object or property here.
    pub fn out_of_place(&self, file: &Path, node: &SceneNode) -> SceneError {
        let tag = node.tag.as_str();
        if self.transform_ops.contains(&tag) {
            SceneError::new(
                file,
                node.pos,
                format!("<{tag}> may only stand inside a <transform>"),
            )
        } else if self.scene_only.contains(&tag) {
            SceneError::new(
                file,
                node.pos,
                format!("<{tag}> may only stand directly inside <scene>"),
            )
        } else {
            self.unknown_element(file, node)
        }
    }

    /// An element the dialect does not know, with its advice or the
    /// closest known name.
    pub fn unknown_element(&self, file: &Path, node: &SceneNode) -> SceneError {
        if let Some((_, hint)) = self.element_hints.iter().find(|(t, _)| *t == node.tag) {
            return SceneError::new(
                file,
                node.pos,
                format!("unknown element <{}> ({hint})", node.tag),
            );
        }
        let known = self
            .object_tags
            .iter()
            .chain(self.property_tags)
            .chain(self.transform_ops)
            .chain(self.scene_only)
            .chain(self.other_tags);
        let hint = known
            .map(|k| (props::edit_distance(&node.tag, k), k))
            .filter(|(d, _)| *d <= 2)
            .min_by_key(|(d, _)| *d)
            .map(|(_, k)| format!(" (did you mean <{k}>?)"))
            .unwrap_or_default();
        SceneError::new(
            file,
            node.pos,
            format!("unknown element <{}>{hint}", node.tag),
        )
    }

    /// Checks an object element's attributes and returns its type, one of
    /// `known`. A type in `unsupported` (one the file format defines and
    /// lente does not render) is named as such; `hint` may add advice
    /// about a type (in brackets after the message).
    pub fn object_type<'n>(
        &self,
        file: &Path,
        node: &'n SceneNode,
        known: &[&str],
        unsupported: &[&str],
        hint: &dyn Fn(&str) -> Option<&'static str>,
    ) -> Result<&'n str> {
        for a in &node.attributes {
            if !self.object_attributes.contains(&a.name.as_str()) {
                return Err(SceneError::new(
                    file,
                    a.pos,
                    format!(
                        "unexpected attribute '{}' on <{}> (it takes {})",
                        a.name,
                        node.tag,
                        quoted_list(self.object_attributes)
                    ),
                ));
            }
        }
        self.type_of(file, node, known, unsupported, hint)
    }

    /// An object element's type, one of `known` (its other attributes
    /// checked by the caller: [`Dialect::object_type`] takes only `type`).
    pub fn type_of<'n>(
        &self,
        file: &Path,
        node: &'n SceneNode,
        known: &[&str],
        unsupported: &[&str],
        hint: &dyn Fn(&str) -> Option<&'static str>,
    ) -> Result<&'n str> {
        let Some(t) = node.attr("type") else {
            return Err(SceneError::new(
                file,
                node.pos,
                format!(
                    "<{}> needs a 'type' attribute (one of: {})",
                    node.tag,
                    known.join(", ")
                ),
            ));
        };
        if known.contains(&t.value.as_str()) {
            return Ok(&t.value);
        }
        let what = if unsupported.contains(&t.value.as_str()) {
            format!("{} is not supported by lente", describe(node))
        } else {
            format!("unknown <{}> type '{}'", node.tag, t.value)
        };
        let hint = hint(&t.value)
            .map(|h| format!(" ({h})"))
            .unwrap_or_default();
        Err(SceneError::new(
            file,
            t.value_pos,
            format!("{what}; lente reads: {}{hint}", known.join(", ")),
        ))
    }

    /// An area emitter must stand in a shape and every other emitter
    /// directly in the scene; `in_shape` says where `node` (an emitter of
    /// type `ty`) stands.
    pub fn check_emitter_place(
        &self,
        file: &Path,
        node: &SceneNode,
        ty: &str,
        in_shape: bool,
    ) -> Result<()> {
        let owner = describe(node);
        let shape = self.shape_tag;
        let message = match (in_shape, ty == "area") {
            (true, false) => format!(
                "{owner} cannot stand inside a <{shape}>; only area emitters can, a {ty} \
                 emitter belongs directly inside <scene>"
            ),
            (false, true) => format!(
                "{owner} cannot stand inside <scene>; an area emitter belongs inside a <{shape}>"
            ),
            _ => return Ok(()),
        };
        Err(SceneError::new(file, node.pos, message))
    }

    /// Reads one property element into `props`.
    pub fn read_property(
        &self,
        file: &Path,
        node: &SceneNode,
        props: &mut Props,
        special: SpecialProperty,
    ) -> Result<()> {
        let tag = node.tag.as_str();
        let (value, value_pos) = if tag == "transform" {
            check_attributes(file, node, &["name"], &["name"])?;
            no_text(file, node, "<transform>")?;
            (Value::Transform(self.read_transform(file, node)?), node.pos)
        } else if let Some(v) = special(node)? {
            v
        } else {
            let vector = matches!(tag, "point" | "vector");
            let allowed: &[&str] = if vector && self.xyz_attributes {
                &["name", "value", "x", "y", "z"]
            } else {
                &["name", "value"]
            };
            let required: &[&str] = if vector && self.xyz_attributes {
                &["name"]
            } else {
                &["name", "value"]
            };
            check_attributes(file, node, allowed, required)?;
            no_content(file, node)?;
            let v = node.attr("value");
            let value = match (tag, v) {
                ("boolean", Some(v)) => Value::Bool(props::parse_bool(file, v)?),
                ("integer", Some(v)) => Value::Int(props::parse_int(file, v)?),
                ("float", Some(v)) => Value::Float(props::parse_float(file, v)?),
                ("string", Some(v)) => Value::String(v.value.clone()),
                ("point" | "vector", Some(v))
                    if self.pairs && props::tokens(&v.value).len() == 2 =>
                {
                    let n = props::parse_numbers(file, v)?;
                    Value::Pair(Vec2::new(n[0], n[1]))
                }
                ("point", _) => Value::Point(self.xyz(file, node, 0.0, self.xyz_attributes)?),
                ("vector", _) => Value::Vector(self.xyz(file, node, 0.0, self.xyz_attributes)?),
                (t, Some(v)) if t == self.color_tag => {
                    Value::Color(props::parse_vec3(file, v, true)?)
                }
                _ => unreachable!("only property tags come here"),
            };
            let value_pos = if vector && self.xyz_attributes {
                node.pos
            } else {
                v.map_or(node.pos, |a| a.value_pos)
            };
            (value, value_pos)
        };
        let name = node.attr_value("name").unwrap_or_default();
        props.insert(name, value, node.pos, value_pos);
        Ok(())
    }

    /// A vector given as `value` (three numbers, or one for all three if
    /// `allow_one`) or, where the dialect allows it, as `x`, `y`, `z`
    /// attributes (missing ones take `default`).
    fn xyz(&self, file: &Path, node: &SceneNode, default: f32, allow_one: bool) -> Result<Vec3> {
        if let Some(v) = node.attr("value") {
            if let Some(a) = ["x", "y", "z"].iter().find_map(|n| node.attr(n)) {
                return Err(SceneError::new(
                    file,
                    a.pos,
                    format!(
                        "<{}> takes either 'value' or 'x', 'y', 'z', not both",
                        node.tag
                    ),
                ));
            }
            return props::parse_vec3(file, v, allow_one);
        }
        let mut out = Vec3::splat(default);
        for (i, n) in ["x", "y", "z"].iter().enumerate() {
            if let Some(a) = node.attr(n) {
                out[i] = props::parse_float(file, a)?;
            }
        }
        Ok(out)
    }

    /// [`Dialect::xyz`] with finite numbers.
    fn finite_xyz(&self, file: &Path, node: &SceneNode, default: f32) -> Result<Vec3> {
        let v = match node.attr("value") {
            Some(a) if !self.xyz_attributes => {
                return finite_vec3(file, a, node.tag == "scale");
            }
            _ => self.xyz(file, node, default, true)?,
        };
        if !v.is_finite() {
            return Err(SceneError::new(
                file,
                node.pos,
                format!(
                    "<{}> needs finite numbers, found {} {} {}",
                    node.tag, v.x, v.y, v.z
                ),
            ));
        }
        Ok(v)
    }

    /// `<transform>`: its operations in document order, each applied after
    /// the ones before it, i.e. left-multiplied (M = op * M), as both Nori
    /// and Mitsuba (`parse_transform_node`) do.
    pub fn read_transform(&self, file: &Path, node: &SceneNode) -> Result<Transform> {
        let err = |pos, msg: &str| SceneError::new(file, pos, msg);
        let mut m = Mat4::IDENTITY;
        for op in &node.children {
            let tag = op.tag.as_str();
            if !self.transform_ops.contains(&tag) {
                if self.is_object(op) || self.property_tags.contains(&tag) {
                    let ops: Vec<String> = self
                        .transform_ops
                        .iter()
                        .map(|t| format!("<{t}>"))
                        .collect();
                    return Err(SceneError::new(
                        file,
                        op.pos,
                        format!(
                            "<transform> may only contain {}, not <{tag}>",
                            ops.join(", ")
                        ),
                    ));
                }
                return Err(self.unknown_element(file, op));
            }
            no_content(file, op)?;
            let xyz: &[&str] = if self.xyz_attributes {
                &["value", "x", "y", "z"]
            } else {
                &["value"]
            };
            let value_required: &[&str] = if self.xyz_attributes { &[] } else { &["value"] };
            let om = match tag {
                "translate" => {
                    check_attributes(file, op, xyz, value_required)?;
                    Mat4::from_translation(self.finite_xyz(file, op, 0.0)?)
                }
                "scale" => {
                    check_attributes(file, op, xyz, value_required)?;
                    let s = self.finite_xyz(file, op, 1.0)?;
                    if s.x * s.y * s.z == 0.0 {
                        let at = op.attr("value").map_or(op.pos, |a| a.value_pos);
                        return Err(err(
                            at,
                            "a scale by zero cannot be undone (the transform would be singular)",
                        ));
                    }
                    Mat4::from_scale(s)
                }
                "rotate" => {
                    let (allowed, required): (&[&str], &[&str]) = if self.xyz_attributes {
                        (&["angle", "value", "x", "y", "z", "axis"], &["angle"])
                    } else {
                        (&["axis", "angle"], &["axis", "angle"])
                    };
                    check_attributes(file, op, allowed, required)?;
                    let axis = match op.attr("axis") {
                        Some(_) if ["value", "x", "y", "z"].iter().any(|n| op.attr(n).is_some()) => {
                            return Err(err(
                                op.pos,
                                "<rotate> takes its axis either as 'axis', 'value' or 'x', 'y', 'z'",
                            ))
                        }
                        Some(a) => finite_vec3(file, a, false)?,
                        None => self.finite_xyz(file, op, 0.0)?,
                    };
                    let angle_attr = op.attr("angle").expect("checked");
                    let angle = props::parse_float(file, angle_attr)?;
                    if !angle.is_finite() {
                        return Err(SceneError::new(
                            file,
                            angle_attr.value_pos,
                            format!("the angle must be a finite number, found {angle}"),
                        ));
                    }
                    let len = axis.length();
                    if !(len > 0.0 && len.is_finite()) {
                        let at = op.attr("axis").map_or(op.pos, |a| a.value_pos);
                        return Err(err(at, "the rotation axis must not be zero"));
                    }
                    Mat4::from_axis_angle(axis / len, angle.to_radians())
                }
                "matrix" => {
                    check_attributes(file, op, &["value"], &["value"])?;
                    let attr = op.attr("value").expect("checked");
                    let v = props::parse_numbers(file, attr)?;
                    if v.iter().any(|x| !x.is_finite()) {
                        return Err(err(attr.value_pos, "the matrix must hold finite numbers"));
                    }
                    let mm = match v.len() {
                        // Written row by row; glam stores columns.
                        16 => Mat4::from_cols_slice(&v).transpose(),
                        9 if self.matrix3 => Mat4::from_mat3(Mat3::from_cols_slice(&v).transpose()),
                        n => {
                            let want = if self.matrix3 {
                                "16 numbers (4x4) or 9 (3x3)"
                            } else {
                                "16 numbers (4x4)"
                            };
                            return Err(SceneError::new(
                                file,
                                attr.value_pos,
                                format!("a <matrix> needs {want}, found {n}"),
                            ));
                        }
                    };
                    if (mm.row(3) - Vec4::W).abs().max_element() > 1e-6 {
                        return Err(err(
                            attr.value_pos,
                            "the last row of a <matrix> must be 0 0 0 1 (projective transforms are not supported)",
                        ));
                    }
                    if Transform::new(mm).is_none() {
                        return Err(err(op.pos, "this <matrix> is singular"));
                    }
                    mm
                }
                "lookat" => {
                    let required: &[&str] = if self.xyz_attributes {
                        &["origin", "target"]
                    } else {
                        &["origin", "target", "up"]
                    };
                    check_attributes(file, op, &["origin", "target", "up"], required)?;
                    let attr = |n| op.attr(n).expect("checked");
                    let origin = finite_vec3(file, attr("origin"), false)?;
                    let target = finite_vec3(file, attr("target"), false)?;
                    let up = match op.attr("up") {
                        Some(a) => Some(finite_vec3(file, a, false)?),
                        None => None,
                    };
                    (self.look_at)(origin, target, up).map_err(|e| err(op.pos, &e.to_string()))?
                }
                _ => unreachable!("checked against transform_ops"),
            };
            m = om * m;
        }
        Transform::new(m).ok_or_else(|| {
            err(
                node.pos,
                "this transform is singular or not finite (it cannot be inverted)",
            )
        })
    }
}

/// Only `allowed` attributes, and all of `required`.
pub(crate) fn check_attributes(
    file: &Path,
    node: &SceneNode,
    allowed: &[&str],
    required: &[&str],
) -> Result<()> {
    for a in &node.attributes {
        if !allowed.contains(&a.name.as_str()) {
            let expected = if allowed.is_empty() {
                "it takes none".to_string()
            } else {
                format!("it takes {}", quoted_list(allowed))
            };
            return Err(SceneError::new(
                file,
                a.pos,
                format!(
                    "unexpected attribute '{}' on <{}> ({expected})",
                    a.name, node.tag
                ),
            ));
        }
    }
    for r in required {
        if node.attr(r).is_none() {
            return Err(SceneError::new(
                file,
                node.pos,
                format!("<{}> needs a '{r}' attribute", node.tag),
            ));
        }
    }
    Ok(())
}

/// No text directly inside `node` (described as `owner` in the message).
pub(crate) fn no_text(file: &Path, node: &SceneNode, owner: &str) -> Result<()> {
    match node.text.first() {
        Some(t) => Err(SceneError::new(
            file,
            t.pos,
            format!(
                "unexpected text '{}' inside {owner}",
                props::shorten(&t.text)
            ),
        )),
        None => Ok(()),
    }
}

/// No child elements and no text.
pub(crate) fn no_content(file: &Path, node: &SceneNode) -> Result<()> {
    if let Some(ch) = node.children.first() {
        return Err(SceneError::new(
            file,
            ch.pos,
            format!("<{}> cannot stand inside <{}>", ch.tag, node.tag),
        ));
    }
    no_text(file, node, &format!("<{}>", node.tag))
}

/// The error for an object that may not stand inside `parent`; `hint`
/// says where it belongs (starting with "; ").
pub(crate) fn misplaced(
    file: &Path,
    node: &SceneNode,
    at: Pos,
    parent: &str,
    hint: &str,
) -> SceneError {
    SceneError::new(
        file,
        at,
        format!("{} cannot stand inside {parent}{hint}", describe(node)),
    )
}

/// Three finite numbers in an attribute (or one, repeated, if `allow_one`).
pub(crate) fn finite_vec3(file: &Path, attr: &Attribute, allow_one: bool) -> Result<Vec3> {
    let v = props::parse_vec3(file, attr, allow_one)?;
    if !v.is_finite() {
        return Err(SceneError::new(
            file,
            attr.value_pos,
            format!("expected finite numbers, found '{}'", attr.value.trim()),
        ));
    }
    Ok(v)
}

/// `'a', 'b', 'c'`.
pub(crate) fn quoted_list(names: &[&str]) -> String {
    names
        .iter()
        .map(|n| format!("'{n}'"))
        .collect::<Vec<_>>()
        .join(", ")
}
