//! Typed property lookup with defaults and positioned errors.
//!
//! A dialect module reads the property elements of one object into a
//! [`Props`], then asks for each property by name and type. Every lookup is
//! remembered: properties nothing asked for become warnings (with the
//! closest known name as a suggestion), and a property given twice warns
//! too. The number parsers here are shared by the dialects.

use std::path::Path;

use super::xml::{Attribute, Pos};
use super::{SceneError, Warning};
use crate::color::{Rgb, Spectrum, SpectrumUse};
use crate::math::{Transform, Vec2, Vec3};
use crate::texture::Texture;

/// The type of a property, named as the scene file spells it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    Bool,
    Int,
    Float,
    String,
    Point,
    Vector,
    Color,
    Transform,
    Texture,
    Spectrum,
    /// A `<point>` or `<vector>` of two numbers (ETH's Nori textures).
    Pair,
}

impl Kind {
    pub fn name(self) -> &'static str {
        match self {
            Kind::Bool => "boolean",
            Kind::Int => "integer",
            Kind::Float => "float",
            Kind::String => "string",
            Kind::Point => "point",
            Kind::Vector => "vector",
            Kind::Color => "color",
            Kind::Transform => "transform",
            Kind::Texture => "texture",
            Kind::Spectrum => "spectrum",
            Kind::Pair => "point or vector of two numbers",
        }
    }
}

/// A property value.
#[derive(Clone, Debug, PartialEq)]
pub enum Value {
    Bool(bool),
    Int(i64),
    Float(f32),
    String(String),
    Point(Vec3),
    Vector(Vec3),
    Color(Rgb),
    Transform(Transform),
    /// A varying texture (`bitmap`, `checkerboard`); constant ones are
    /// `Color` or `Float`.
    Texture(Texture),
    /// A spectrum; it becomes a colour when read, in the way its object's
    /// [`SpectrumUse`] says.
    Spectrum(Spectrum),
    /// Two numbers given as a `<point>` or `<vector>` (Nori dialect only).
    Pair(Vec2),
}

impl Value {
    pub fn kind(&self) -> Kind {
        match self {
            Value::Bool(_) => Kind::Bool,
            Value::Int(_) => Kind::Int,
            Value::Float(_) => Kind::Float,
            Value::String(_) => Kind::String,
            Value::Point(_) => Kind::Point,
            Value::Vector(_) => Kind::Vector,
            Value::Color(_) => Kind::Color,
            Value::Transform(_) => Kind::Transform,
            Value::Texture(_) => Kind::Texture,
            Value::Spectrum(_) => Kind::Spectrum,
            Value::Pair(_) => Kind::Pair,
        }
    }
}

/// One named property with where it was written.
#[derive(Clone, Debug)]
pub struct Property {
    pub name: String,
    pub value: Value,
    /// The property's element.
    pub pos: Pos,
    /// Its value (errors about the value point here).
    pub value_pos: Pos,
    used: bool,
}

/// The properties of one object.
#[derive(Debug)]
pub struct Props<'a> {
    file: &'a Path,
    owner: String,
    pos: Pos,
    props: Vec<Property>,
    queried: Vec<String>,
    warnings: Vec<Warning>,
    /// How the dialect spells a colour property's element (`color`, `rgb`).
    color_tag: &'static str,
    /// How spectra become colours ([`Props::set_spectrum_use`]).
    spectrum_use: SpectrumUse,
}

type Result<T> = std::result::Result<T, SceneError>;

macro_rules! getters {
    ($get:ident, $opt:ident, $req:ident, $kind:expr, $ty:ty, $pat:pat => $val:expr) => {
        /// The property's value, or `default` if it is not given.
        pub fn $get(&mut self, name: &str, default: $ty) -> Result<$ty> {
            Ok(self.$opt(name)?.unwrap_or(default))
        }

        /// The property's value, if it is given.
        pub fn $opt(&mut self, name: &str) -> Result<Option<$ty>> {
            match self.lookup(name, $kind)? {
                None => Ok(None),
                Some($pat) => Ok(Some($val)),
                Some(_) => unreachable!("lookup checked the type"),
            }
        }

        /// The property's value; an error at the object if it is missing.
        pub fn $req(&mut self, name: &str) -> Result<$ty> {
            match self.$opt(name)? {
                Some(v) => Ok(v),
                None => Err(self.missing(name, $kind)),
            }
        }
    };
}

impl<'a> Props<'a> {
    /// An empty list for the object described as `owner` (e.g.
    /// `<camera type="perspective">`) whose element starts at `pos`.
    pub fn new(file: &'a Path, owner: impl Into<String>, pos: Pos) -> Props<'a> {
        Props {
            file,
            owner: owner.into(),
            pos,
            props: Vec::new(),
            queried: Vec::new(),
            warnings: Vec::new(),
            color_tag: "color",
            spectrum_use: SpectrumUse::Reflectance,
        }
    }

    /// How spectra read from now on become colours (reflectances unless
    /// told otherwise); returns the previous setting.
    pub fn set_spectrum_use(&mut self, use_: SpectrumUse) -> SpectrumUse {
        std::mem::replace(&mut self.spectrum_use, use_)
    }

    /// Names colour properties `<tag>` in messages (Mitsuba writes `<rgb>`).
    pub fn set_color_tag(&mut self, tag: &'static str) {
        self.color_tag = tag;
    }

    /// The element name of a kind of property, as this dialect spells it.
    fn kind_name(&self, kind: Kind) -> &'static str {
        match kind {
            Kind::Color => self.color_tag,
            k => k.name(),
        }
    }

    /// The type a property is given as, if it is given (does not count as
    /// reading it).
    pub fn kind_of(&self, name: &str) -> Option<Kind> {
        self.props
            .iter()
            .find(|p| p.name == name)
            .map(|p| p.value.kind())
    }

    /// The names of the properties given as textures, in file order
    /// (`bumpmap` takes its one texture under any name).
    pub fn texture_names(&self) -> Vec<String> {
        self.props
            .iter()
            .filter(|p| p.value.kind() == Kind::Texture)
            .map(|p| p.name.clone())
            .collect()
    }

    pub fn owner(&self) -> &str {
        &self.owner
    }

    pub fn file(&self) -> &'a Path {
        self.file
    }

    /// Adds a property; if the name is taken the new value wins, with a warning.
    pub fn insert(&mut self, name: &str, value: Value, pos: Pos, value_pos: Pos) {
        let prop = Property {
            name: name.to_string(),
            value,
            pos,
            value_pos,
            used: false,
        };
        if let Some(old) = self.props.iter_mut().find(|p| p.name == name) {
            self.warnings.push(Warning::new(
                self.file,
                pos,
                format!(
                    "property '{name}' of {} is given more than once (also at {}); the last value wins",
                    self.owner, old.pos
                ),
            ));
            *old = prop;
        } else {
            self.props.push(prop);
        }
    }

    /// True if the property is given (does not count as reading it).
    pub fn has(&self, name: &str) -> bool {
        self.props.iter().any(|p| p.name == name)
    }

    /// Where errors about the property's value should point: its value if
    /// given, else the object.
    pub fn value_pos(&self, name: &str) -> Pos {
        self.props
            .iter()
            .find(|p| p.name == name)
            .map_or(self.pos, |p| p.value_pos)
    }

    /// An error about the value of property `name`.
    pub fn error(&self, name: &str, message: impl Into<String>) -> SceneError {
        SceneError::new(self.file, self.value_pos(name), message)
    }

    /// An error about property `name` from a domain type's validation,
    /// whose message completes a sentence that starts with the name.
    pub fn param_error(&self, name: &str, e: impl std::fmt::Display) -> SceneError {
        self.error(name, format!("'{name}' {e}"))
    }

    /// A warning about the object as a whole.
    pub fn object_warning(&self, message: impl Into<String>) -> Warning {
        Warning::new(self.file, self.pos, message)
    }

    /// An error about the object as a whole.
    pub fn object_error(&self, message: impl Into<String>) -> SceneError {
        SceneError::new(self.file, self.pos, message)
    }

    fn missing(&self, name: &str, kind: Kind) -> SceneError {
        self.object_error(format!(
            "{} needs the property '{name}' (a <{}>)",
            self.owner,
            self.kind_name(kind)
        ))
    }

    fn lookup(&mut self, name: &str, want: Kind) -> Result<Option<Value>> {
        if !self.queried.iter().any(|q| q == name) {
            self.queried.push(name.to_string());
        }
        let Some(p) = self.props.iter_mut().find(|p| p.name == name) else {
            return Ok(None);
        };
        p.used = true;
        let found = p.value.kind();
        if found == want {
            return Ok(Some(p.value.clone()));
        }
        // An integer stands in for a float.
        if let (Kind::Float, Value::Int(i)) = (want, &p.value) {
            return Ok(Some(Value::Float(*i as f32)));
        }
        // A spectrum is a colour (a flat one a number too), in RGB.
        match (want, &p.value) {
            (Kind::Float, Value::Spectrum(Spectrum::Uniform(v))) => {
                return Ok(Some(Value::Float(*v)));
            }
            (Kind::Color, Value::Spectrum(spectrum)) => {
                let (rgb, clipped) = spectrum.to_rgb(self.spectrum_use);
                if clipped {
                    let warning = Warning::new(
                        self.file,
                        p.value_pos,
                        format!(
                            "the spectrum of '{name}' is outside the sRGB gamut{}; \
                             clipped to {} {} {}, as Mitsuba's RGB modes do",
                            if self.spectrum_use == SpectrumUse::Reflectance {
                                " or above 1"
                            } else {
                                ""
                            },
                            rgb.x,
                            rgb.y,
                            rgb.z
                        ),
                    );
                    self.warnings.push(warning);
                }
                return Ok(Some(Value::Color(rgb)));
            }
            // Two numbers where three belong.
            (Kind::Point | Kind::Vector, Value::Pair(_)) => {
                return Err(SceneError::new(
                    self.file,
                    p.value_pos,
                    "expected 3 numbers, found 2",
                ));
            }
            (Kind::Pair, _) => {
                return Err(SceneError::new(
                    self.file,
                    p.value_pos,
                    format!("'{name}' of {} takes two numbers", self.owner),
                ));
            }
            _ => {}
        }
        Err(SceneError::new(
            self.file,
            p.pos,
            format!(
                "property '{name}' of {} must be a <{}>, but it is given as a <{}>",
                self.owner,
                self.kind_name(want),
                self.kind_name(found)
            ),
        ))
    }

    getters!(get_bool, opt_bool, require_bool, Kind::Bool, bool, Value::Bool(v) => v);
    getters!(get_int, opt_int, require_int, Kind::Int, i64, Value::Int(v) => v);
    getters!(get_string, opt_string, require_string, Kind::String, String, Value::String(v) => v);
    getters!(get_transform, opt_transform, require_transform, Kind::Transform, Transform, Value::Transform(v) => v);
    getters!(get_float_raw, opt_float_raw, require_float_raw, Kind::Float, f32, Value::Float(v) => v);
    getters!(get_point_raw, opt_point_raw, require_point_raw, Kind::Point, Vec3, Value::Point(v) => v);
    getters!(get_vector_raw, opt_vector_raw, require_vector_raw, Kind::Vector, Vec3, Value::Vector(v) => v);
    getters!(get_rgb_raw, opt_rgb_raw, require_rgb_raw, Kind::Color, Rgb, Value::Color(v) => v);

    fn finite(&self, name: &str, v: Option<f32>) -> Result<Option<f32>> {
        match v {
            Some(x) if !x.is_finite() => {
                Err(self.error(name, format!("'{name}' must be a finite number, found {x}")))
            }
            _ => Ok(v),
        }
    }

    fn finite3(&self, name: &str, v: Option<Vec3>) -> Result<Option<Vec3>> {
        match v {
            Some(x) if !x.is_finite() => Err(self.error(
                name,
                format!(
                    "'{name}' must be finite numbers, found {} {} {}",
                    x.x, x.y, x.z
                ),
            )),
            _ => Ok(v),
        }
    }

    /// A finite float (integers are accepted too).
    pub fn opt_float(&mut self, name: &str) -> Result<Option<f32>> {
        let v = self.opt_float_raw(name)?;
        self.finite(name, v)
    }

    pub fn get_float(&mut self, name: &str, default: f32) -> Result<f32> {
        Ok(self.opt_float(name)?.unwrap_or(default))
    }

    pub fn require_float(&mut self, name: &str) -> Result<f32> {
        let v = self.require_float_raw(name)?;
        Ok(self.finite(name, Some(v))?.unwrap_or(v))
    }

    /// A float that may also be infinite (not NaN).
    pub fn get_float_or_inf(&mut self, name: &str, default: f32) -> Result<f32> {
        let v = self.get_float_raw(name, default)?;
        if v.is_nan() {
            return Err(self.error(name, format!("'{name}' must be a number, found NaN")));
        }
        Ok(v)
    }

    /// A point with finite coordinates.
    pub fn opt_point(&mut self, name: &str) -> Result<Option<Vec3>> {
        let v = self.opt_point_raw(name)?;
        self.finite3(name, v)
    }

    pub fn get_point(&mut self, name: &str, default: Vec3) -> Result<Vec3> {
        Ok(self.opt_point(name)?.unwrap_or(default))
    }

    pub fn require_point(&mut self, name: &str) -> Result<Vec3> {
        match self.opt_point(name)? {
            Some(v) => Ok(v),
            None => Err(self.missing(name, Kind::Point)),
        }
    }

    /// A vector with finite coordinates.
    pub fn opt_vector(&mut self, name: &str) -> Result<Option<Vec3>> {
        let v = self.opt_vector_raw(name)?;
        self.finite3(name, v)
    }

    pub fn get_vector(&mut self, name: &str, default: Vec3) -> Result<Vec3> {
        Ok(self.opt_vector(name)?.unwrap_or(default))
    }

    pub fn require_vector(&mut self, name: &str) -> Result<Vec3> {
        match self.opt_vector(name)? {
            Some(v) => Ok(v),
            None => Err(self.missing(name, Kind::Vector)),
        }
    }

    /// Two finite numbers, written as a `<point>` or `<vector>` of two.
    pub fn get_pair(&mut self, name: &str, default: Vec2) -> Result<Vec2> {
        match self.lookup(name, Kind::Pair)? {
            None => Ok(default),
            Some(Value::Pair(v)) if v.is_finite() => Ok(v),
            Some(_) => Err(self.error(name, format!("'{name}' must be two finite numbers"))),
        }
    }

    /// A colour with finite, non-negative components.
    pub fn opt_rgb(&mut self, name: &str) -> Result<Option<Rgb>> {
        let v = self.opt_rgb_raw(name)?;
        let v = self.finite3(name, v)?;
        if let Some(c) = v {
            if c.min_element() < 0.0 {
                return Err(self.error(
                    name,
                    format!(
                        "'{name}' must not be negative, found {} {} {}",
                        c.x, c.y, c.z
                    ),
                ));
            }
        }
        Ok(v)
    }

    pub fn get_rgb(&mut self, name: &str, default: Rgb) -> Result<Rgb> {
        Ok(self.opt_rgb(name)?.unwrap_or(default))
    }

    pub fn require_rgb(&mut self, name: &str) -> Result<Rgb> {
        match self.opt_rgb(name)? {
            Some(v) => Ok(v),
            None => Err(self.missing(name, Kind::Color)),
        }
    }

    /// A colour with finite, non-negative components, where a single
    /// number (a `<float>` or `<integer>`) stands for a grey.
    pub fn opt_rgb_or_float(&mut self, name: &str) -> Result<Option<Rgb>> {
        match self.kind_of(name) {
            Some(Kind::Float) | Some(Kind::Int) => {
                let v = self.opt_float(name)?;
                if let Some(x) = v {
                    if x < 0.0 {
                        return Err(
                            self.error(name, format!("'{name}' must not be negative, found {x}"))
                        );
                    }
                }
                Ok(v.map(Rgb::splat))
            }
            _ => self.opt_rgb(name),
        }
    }

    pub fn get_rgb_or_float(&mut self, name: &str, default: Rgb) -> Result<Rgb> {
        Ok(self.opt_rgb_or_float(name)?.unwrap_or(default))
    }

    /// A property that may vary over a surface: a texture, or a constant
    /// colour or number (checked as [`Props::opt_rgb_or_float`]).
    pub fn opt_texture(&mut self, name: &str) -> Result<Option<Texture>> {
        if self.kind_of(name) == Some(Kind::Texture) {
            return match self.lookup(name, Kind::Texture)? {
                Some(Value::Texture(t)) => Ok(Some(t)),
                _ => unreachable!("lookup checked the type"),
            };
        }
        Ok(self.opt_rgb_or_float(name)?.map(Texture::Constant))
    }

    pub fn get_texture(&mut self, name: &str, default: Rgb) -> Result<Texture> {
        Ok(self
            .opt_texture(name)?
            .unwrap_or(Texture::Constant(default)))
    }

    /// Replaces a constant colour's negative components by their
    /// magnitudes and returns the colour as written, if it had any. For
    /// values whose every use is squared (a conductor's `eta` and `k`),
    /// where Mitsuba takes negatives as they are.
    pub fn make_color_magnitude(&mut self, name: &str) -> Option<Rgb> {
        let p = self.props.iter_mut().find(|p| p.name == name)?;
        match &mut p.value {
            Value::Color(c) if c.min_element() < 0.0 => {
                let written = *c;
                *c = c.abs();
                Some(written)
            }
            Value::Float(x) if *x < 0.0 => {
                let written = Rgb::splat(*x);
                *x = x.abs();
                Some(written)
            }
            _ => None,
        }
    }

    /// A warning about property `name` (at its value, or at the object).
    pub fn warn(&mut self, name: &str, message: impl Into<String>) {
        let pos = self.value_pos(name);
        self.warnings.push(Warning::new(self.file, pos, message));
    }

    /// Ends the lookups: duplicate-property warnings, then one warning per
    /// property nothing read, in document order.
    pub fn finish(self, warnings: &mut Vec<Warning>) {
        warnings.extend(self.warnings);
        let mut unused: Vec<&Property> = self.props.iter().filter(|p| !p.used).collect();
        unused.sort_by_key(|p| p.pos);
        for p in unused {
            let mut msg = format!("unused property '{}' of {}", p.name, self.owner);
            if let Some(s) = closest(&p.name, &self.queried) {
                msg.push_str(&format!(" (did you mean '{s}'?)"));
            }
            warnings.push(Warning::new(self.file, p.pos, msg));
        }
    }
}

/// The known name closest to `name` within edit distance 2.
fn closest<'n>(name: &str, known: &'n [String]) -> Option<&'n str> {
    known
        .iter()
        .map(|k| (edit_distance(name, k), k))
        .filter(|(d, _)| *d <= 2)
        .min_by_key(|(d, _)| *d)
        .map(|(_, k)| k.as_str())
}

/// Levenshtein distance (characters; ASCII case differences count 1).
pub fn edit_distance(a: &str, b: &str) -> usize {
    let a: Vec<char> = a.chars().collect();
    let b: Vec<char> = b.chars().collect();
    let mut prev: Vec<usize> = (0..=b.len()).collect();
    let mut cur = vec![0; b.len() + 1];
    for i in 1..=a.len() {
        cur[0] = i;
        for j in 1..=b.len() {
            let sub = prev[j - 1] + usize::from(a[i - 1] != b[j - 1]);
            cur[j] = sub.min(prev[j] + 1).min(cur[j - 1] + 1);
        }
        std::mem::swap(&mut prev, &mut cur);
    }
    prev[b.len()]
}

/// Tokens of a number list: split on commas and whitespace, empty pieces
/// skipped; each with its byte offset.
pub fn tokens(s: &str) -> Vec<(usize, &str)> {
    let mut out = Vec::new();
    let mut start = None;
    for (i, c) in s.char_indices() {
        let sep = c == ',' || c.is_whitespace();
        match (sep, start) {
            (true, Some(b)) => {
                out.push((b, &s[b..i]));
                start = None;
            }
            (false, None) => start = Some(i),
            _ => {}
        }
    }
    if let Some(b) = start {
        out.push((b, &s[b..]));
    }
    out
}

fn parse_f32(tok: &str) -> Option<f32> {
    tok.parse::<f32>().ok()
}

/// All numbers of an attribute's value; a token that is not a number is
/// an error at that token.
pub fn parse_numbers(file: &Path, attr: &Attribute) -> Result<Vec<f32>> {
    tokens(&attr.value)
        .into_iter()
        .map(|(off, tok)| {
            parse_f32(tok).ok_or_else(|| {
                SceneError::new(
                    file,
                    attr.pos_in_value(off),
                    format!("cannot read '{tok}' as a number"),
                )
            })
        })
        .collect()
}

fn count_error(file: &Path, attr: &Attribute, what: &str, found: usize) -> SceneError {
    SceneError::new(
        file,
        attr.value_pos,
        format!("expected {what}, found {found} in '{}'", attr.value.trim()),
    )
}

/// Exactly one number (which may be infinite or NaN; callers check).
pub fn parse_float(file: &Path, attr: &Attribute) -> Result<f32> {
    let v = parse_numbers(file, attr)?;
    match v[..] {
        [x] => Ok(x),
        _ => Err(count_error(file, attr, "1 number", v.len())),
    }
}

/// Three numbers, or one repeated thrice if `allow_one`.
pub fn parse_vec3(file: &Path, attr: &Attribute, allow_one: bool) -> Result<Vec3> {
    let v = parse_numbers(file, attr)?;
    match v[..] {
        [x, y, z] => Ok(Vec3::new(x, y, z)),
        [x] if allow_one => Ok(Vec3::splat(x)),
        _ => Err(count_error(file, attr, "3 numbers", v.len())),
    }
}

/// A decimal integer.
pub fn parse_int(file: &Path, attr: &Attribute) -> Result<i64> {
    let t = tokens(&attr.value);
    match t[..] {
        [(off, tok)] => tok.parse::<i64>().map_err(|_| {
            SceneError::new(
                file,
                attr.pos_in_value(off),
                format!("cannot read '{tok}' as an integer"),
            )
        }),
        _ => Err(count_error(file, attr, "1 integer", t.len())),
    }
}

/// `true` or `false` (any case).
pub fn parse_bool(file: &Path, attr: &Attribute) -> Result<bool> {
    match attr.value.trim().to_ascii_lowercase().as_str() {
        "true" => Ok(true),
        "false" => Ok(false),
        _ => Err(SceneError::new(
            file,
            attr.value_pos,
            format!("expected true or false, found '{}'", attr.value.trim()),
        )),
    }
}

/// Integer property within [min, max].
pub(crate) fn int_in(p: &mut Props, name: &str, default: i64, min: i64, max: i64) -> Result<i64> {
    let v = p.get_int(name, default)?;
    if v < min || v > max {
        return Err(p.error(
            name,
            format!("'{name}' must be between {min} and {max}, found {v}"),
        ));
    }
    Ok(v)
}

pub(crate) fn positive(p: &mut Props, name: &str, default: f32) -> Result<f32> {
    let v = p.get_float(name, default)?;
    if v <= 0.0 {
        return Err(p.error(name, format!("'{name}' must be positive, found {v}")));
    }
    Ok(v)
}

pub(crate) fn non_negative(p: &mut Props, name: &str, default: f32) -> Result<f32> {
    let v = p.get_float(name, default)?;
    if v < 0.0 {
        return Err(p.error(name, format!("'{name}' must not be negative, found {v}")));
    }
    Ok(v)
}

pub(crate) fn shorten(s: &str) -> String {
    let mut out: String = s.chars().take(30).collect();
    if s.chars().count() > 30 {
        out.push_str("...");
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tokens_split_on_commas_and_whitespace() {
        let t: Vec<&str> = tokens(" 1,2  3,\n4 ,, 5 ").iter().map(|t| t.1).collect();
        assert_eq!(t, ["1", "2", "3", "4", "5"]);
        assert_eq!(tokens("a, b")[1].0, 3);
    }

    #[test]
    fn edit_distances() {
        assert_eq!(edit_distance("fov", "fvo"), 2);
        assert_eq!(edit_distance("nearclip", "nearClip"), 1);
        assert_eq!(edit_distance("", "abc"), 3);
        assert_eq!(edit_distance("width", "width"), 0);
    }

    #[test]
    fn lookups_track_use_and_types() {
        let file = Path::new("s.xml");
        let mut p = Props::new(file, "<camera>", Pos::new(1, 1));
        p.insert("fov", Value::Int(40), Pos::new(2, 3), Pos::new(2, 30));
        p.insert("fvo", Value::Float(1.0), Pos::new(3, 3), Pos::new(3, 30));
        p.insert(
            "name",
            Value::String("x".into()),
            Pos::new(4, 3),
            Pos::new(4, 30),
        );
        assert_eq!(p.get_float("fov", 30.0).unwrap(), 40.0);
        assert_eq!(p.get_float("nearClip", 1e-4).unwrap(), 1e-4);
        let e = p.get_float("name", 1.0).unwrap_err();
        assert_eq!((e.line, e.col), (4, 3));
        assert!(e.message.contains("<float>") && e.message.contains("<string>"));
        let mut w = Vec::new();
        p.finish(&mut w);
        assert_eq!(w.len(), 1);
        assert!(w[0].message.contains("did you mean 'fov'"), "{}", w[0]);
        assert_eq!((w[0].line, w[0].col), (3, 3));
    }

    #[test]
    fn duplicates_warn_and_last_wins() {
        let file = Path::new("s.xml");
        let mut p = Props::new(file, "<camera>", Pos::new(1, 1));
        p.insert("fov", Value::Float(1.0), Pos::new(2, 3), Pos::new(2, 30));
        p.insert("fov", Value::Float(2.0), Pos::new(3, 3), Pos::new(3, 30));
        assert_eq!(p.get_float("fov", 30.0).unwrap(), 2.0);
        let mut w = Vec::new();
        p.finish(&mut w);
        assert_eq!(w.len(), 1);
        assert_eq!((w[0].line, w[0].col), (3, 3));
        assert!(w[0].message.contains("more than once"));
    }

    #[test]
    fn missing_required_property_is_an_error_at_the_object() {
        let mut p = Props::new(
            Path::new("s.xml"),
            "<emitter type=\"point\">",
            Pos::new(7, 5),
        );
        let e = p.require_rgb("power").unwrap_err();
        assert_eq!((e.line, e.col), (7, 5));
        assert!(e.message.contains("'power'"));
    }
}
