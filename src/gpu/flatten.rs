//! The scene as the GPU reads it: a BVH over triangles and spheres (built
//! on the CPU by obvhs), the primitives in leaf order, shading normals,
//! one material and emission record per shape, the area lights with their
//! choice CDF, and the render's parameters. What the GPU backend does not
//! support yet is an error naming it, never a silently different image.

use bytemuck::{Pod, Zeroable};
use obvhs::{aabb::Aabb as OAabb, bvh2::builder::build_bvh2, BvhBuildParams};

use crate::bsdf::distribution::{MicrofacetDistribution, MicrofacetType};
use crate::bsdf::{Blend, Bsdf, BsdfParam, Principled, PrincipledThin, Tilt, Tilted};
use crate::camera::{Aperture, Projection};
use crate::color::Rgb;
use crate::emitter::{Emitter, EnvGpuFacing, LightBounds};
use crate::geometry::{build_boxes, Geometry, SphereUv};
use crate::integrator::{Integrator, Strategy};
use crate::math::{Aabb, Transform, Vec2, Vec3, PI};
use crate::render::RenderJob;
use crate::sampling::{SamplerKind, STRATIFIED_DIMENSIONS};
use crate::scene::Scene;
use crate::texture::{CheckerRule, FilterType, Texture, UvTransform, WrapMode};

use super::light_groups::{choice_tables, LightGroup};

/// "No index" in the GPU's records.
pub const NONE: u32 = u32::MAX;

/// Marks a sphere where a triangle has its normal slot.
pub const SPHERE: u32 = u32::MAX - 1;
/// Marks a disk whose front is along cross(dx, dy) (`DISK`) or against it
/// (`DISK_FLIPPED`).
pub const DISK: u32 = u32::MAX - 2;
pub const DISK_FLIPPED: u32 = u32::MAX - 3;

/// Vec4 words per area or delta light in `lights`.
pub const LIGHT_WORDS: usize = 6;

/// Light kinds (`lights[LIGHT_WORDS i].w`), as `emitter.wgsl` names them.
pub const LIGHT_TRIANGLE: u32 = 0;
pub const LIGHT_SPHERE: u32 = 1;
pub const LIGHT_POINT: u32 = 2;
pub const LIGHT_SPOT: u32 = 3;
pub const LIGHT_DIRECTIONAL: u32 = 4;
pub const LIGHT_DISK: u32 = 5;
pub const LIGHT_PROJECTOR: u32 = 6;

/// Vec4 words per shape's material record in `shapes`.
pub const SHAPE_WORDS: usize = 4;

/// Material kinds (`shapes[SHAPE_WORDS s].w`), as `bsdf.wgsl` names them.
/// Kinds from `MAT_MIRROR` on are purely specular (no light sampling).
pub const MAT_DIFFUSE: u32 = 0;
pub const MAT_ROUGH_CONDUCTOR: u32 = 2;
pub const MAT_PLASTIC: u32 = 3;
pub const MAT_ROUGH_PLASTIC: u32 = 4;
pub const MAT_ROUGH_DIELECTRIC: u32 = 5;
/// Mitsuba's `principledthin`: A its base colour, B (spec_trans,
/// anisotropic, diff_trans (0 to 2), roughness), C (eta, 0, 0, index of
/// two more words: (sheen, sheen_tint, flatness, spec_tint), the
/// specular reflection, specular transmission, diffuse reflection and
/// diffuse transmission sampling rates). Textured base colour, spec_trans
/// (B.x), eta (C.x) and roughness as `MAT_PRINCIPLED`'s.
pub const MAT_PRINCIPLED_THIN: u32 = 1;
/// Mitsuba's `principled`: A its base colour, B (metallic,
/// anisotropic, clearcoat, roughness), C (spec_trans, eta,
/// clearcoat_gloss, index of two more words: (sheen, sheen_tint,
/// flatness, spec_tint), (diffuse, clearcoat, specular sampling rates,
/// 0)). Textured base colour, metallic (B.x), spec_trans (C.x) and
/// roughness (B.w) put their records there with `MAT_TEXTURED`, `_B`, `_C`
/// and `_ALPHA`.
pub const MAT_PRINCIPLED: u32 = 6;
/// Mitsuba's `blendbsdf`: word A is (the weight, or its texture's record
/// with `MAT_TEXTURED`; the first and the second BSDF's three words, as
/// indices in the shapes buffer). Neither is a blend.
pub const MAT_BLEND: u32 = 7;
/// Nori's `microfacet`: A its kd, B (ks, 0, 0, alpha), C (eta, 0, 0, -1:
/// an isotropic Beckmann distribution for `microfacet()`).
pub const MAT_MICROFACET: u32 = 8;
/// The Zaragoza Nori fork's `roughconductor`: A r0 (Schlick's Fresnel), B
/// (0, 0, 0, alpha), C (0, 0, 0, -1: isotropic Beckmann), sampled from D
/// cos as Nori samples it.
pub const MAT_SCHLICK_CONDUCTOR: u32 = 9;
/// The Zaragoza Nori fork's `roughsubstrate` (Ashikhmin-Shirley): A its
/// kd, B (the diffuse scale 28 (1 - r^2) / (23 pi), 0, 0, alpha), C (eta,
/// 0, 0, -1).
pub const MAT_ROUGH_SUBSTRATE: u32 = 10;
/// Mitsuba's `pplastic`, unpolarised: A its diffuse reflectance, B (its
/// specular reflectance, alpha), C (eta, specular sampling weight, 0,
/// distribution).
pub const MAT_POLARIZED_PLASTIC: u32 = 11;
pub const MAT_MIRROR: u32 = 12;
pub const MAT_DIELECTRIC: u32 = 13;
pub const MAT_CONDUCTOR: u32 = 14;
pub const MAT_THIN_DIELECTRIC: u32 = 15;
/// Straight through with weight A: Mitsuba's `null` (1) and `polarizer`
/// (half its transmittance), a delta lobe of probability 1.
pub const MAT_PASS: u32 = 16;

/// Set in a material's kind word on shapes that have an area emitter
/// (camera rays pass through them under `hide_emitters`).
pub const MAT_EMITS: u32 = 0x100;

/// Set in a material's kind word when the colour of its word A (a diffuse
/// reflectance or a specular reflectance) is a bitmap or checkerboard
/// texture. Word A then holds (texture record index as bits, the
/// plastics' internal reflectance, 1 if the plastic is nonlinear else 0)
/// in place of the colour or the plastics' diffuse term (see
/// `texture_record`).
pub const MAT_TEXTURED: u32 = 0x200;

/// Set when the colour of word B (a plastic's specular reflectance, a
/// dielectric's specular transmittance, a conductor's eta) is a texture:
/// B's first value is then its record index as bits.
pub const MAT_TEXTURED_B: u32 = 0x400;

/// Set when the roughness (word B's last value) is a texture, read as one
/// value (`Texture::eval_1`): that value is then its record index as bits.
pub const MAT_TEXTURED_ALPHA: u32 = 0x800;

/// Set in a `twosided` material's kind word: the same BSDF on both sides.
pub const MAT_TWO_SIDED: u32 = 0x1000;

/// Set in a `mask`'s kind word (the nested BSDF's record with this flag):
/// word D's first value is the opacity.
pub const MAT_MASK: u32 = 0x2000;

/// Set when the mask's opacity is a texture (read as one value): word D's
/// first value is then its record index as bits.
pub const MAT_TEXTURED_MASK: u32 = 0x4000;

/// Set in the front record of a `twosided` material with a different
/// back: word D's second value is the index (as bits) of the back's three
/// words in the shapes buffer (flagged `MAT_TWO_SIDED`).
pub const MAT_BACK: u32 = 0x8000;

/// Set in a `normalmap`'s or `bumpmap`'s kind word (its nested BSDF's
/// record with this flag): word D's third value is the normal or height
/// texture's record index (as bits), its fourth the `TILT_*` flags, its
/// second a bump map's scale.
pub const MAT_NORMAL_MAP: u32 = 0x10000;

/// Set in the kind word of conductors whose k (word C's colour) is a
/// texture: C.x holds its record's index.
pub const MAT_TEXTURED_C: u32 = 0x20000;

/// A Disney BSDF's one-value parameter that is a texture without a flag
/// of its own (anisotropic, clearcoat, clearcoat_gloss, sheen,
/// sheen_tint, flatness, spec_tint, diff_trans) holds, in place of its
/// value, this quiet NaN with its record's index in the low bits
/// ([`DISNEY_RECORD_INDICES`] of them): the shader reads it there
/// (`disney_param`). Constants are finite, so the two never mix.
pub const DISNEY_RECORD: u32 = 0x7fc0_0000;

/// Record indices a [`DISNEY_RECORD`] value can hold.
pub const DISNEY_RECORD_INDICES: u32 = 1 << 22;

/// A normal or bump map's flags (word D's fourth value, as bits): Mitsuba's
/// `flip_invalid_normals` and `use_shadowing_function`, and a map inside
/// a `twosided` material (tilted after the back's directions are
/// mirrored, not before).
pub const TILT_FLIP: u32 = 1;
pub const TILT_SHADOW: u32 = 2;
pub const TILT_INSIDE_TWO_SIDED: u32 = 4;
/// A bump map: the fourth word's texture is a height field (its slopes
/// tilt the normal), its second number the map's scale.
pub const TILT_BUMP: u32 = 16;

/// Set in the kind word of a shape's (front) record where its BSDF
/// `favours_facing_light`: light sampling at its first vertex then uses the
/// environment map's facing density (`envmap/facing.rs`), as the CPU does.
pub const MAT_FACING: u32 = 0x40000;

/// Every flag of a kind word (the rest is the kind).
pub const MAT_FLAGS: u32 =
    MAT_EMITS | MAT_TWO_SIDED | MAT_MASK | MAT_BACK | MAT_TEXTURED_ANY | MAT_FACING;

/// Every texture flag.
pub const MAT_TEXTURED_ANY: u32 = MAT_TEXTURED
    | MAT_TEXTURED_B
    | MAT_TEXTURED_C
    | MAT_TEXTURED_ALPHA
    | MAT_TEXTURED_MASK
    | MAT_NORMAL_MAP;

/// Vec4 words per vertex-data slot in `normals`: a triangle's three vertex
/// normals (zero where the mesh has none), then (u0, v0, u1, v1), (u2, v2,
/// its index in its mesh as bits, 1 if its corners 1 and 2 were swapped
/// else 0); a textured sphere's (u, v) frame: (object x, 1 for ETH's (u, v)
/// else 0), (object y, 0), (object z, 0), then unused words.
pub const SLOT_WORDS: usize = 5;

/// Texture filter and wrap codes in a texture record.
pub const TEX_NEAREST: u32 = 0;
pub const TEX_BILINEAR: u32 = 1;
/// A checkerboard: its two colours stand where a bitmap's texels do.
pub const TEX_CHECKERBOARD: u32 = 2;
/// The Nori forks' `checkerboard`/`checker` (`texture/nori_checker.rs`):
/// the wrap word holds its rule, `CHECKER_ETH` or `CHECKER_ZARAGOZA`.
pub const TEX_NORI_CHECKER: u32 = 3;
/// Mitsuba's `mesh_attribute` (`texture/mesh_attribute.rs`): the width is
/// the values per triangle (3: its corners', interpolated with the hit's
/// barycentrics; 1: the face's), the height the triangles, the texels the
/// values times the texture's scale, triangle by triangle.
pub const TEX_MESH_ATTRIBUTE: u32 = 4;
pub const CHECKER_ETH: u32 = 0;
pub const CHECKER_ZARAGOZA: u32 = 1;
pub const WRAP_REPEAT: u32 = 0;
pub const WRAP_MIRROR: u32 = 1;
pub const WRAP_CLAMP: u32 = 2;

/// The most texels the GPU backend takes from a scene's textures (each
/// texel is a vec4 in the shapes buffer, which must fit one binding).
pub const MAX_TEXELS: usize = 1 << 22;

/// Most primitives the GPU takes once instances are placed (each is a
/// copy of its group's): 48 bytes each in the primitive buffer, the BVH
/// beside them. A scene of many placements of a large group is an
/// error naming the count, not an allocation that never ends.
pub const MAX_PLACED_PRIMS: usize = 1 << 24;

/// Entries of the filter's 1D weight table (over [0, radius]).
pub const FILTER_TABLE: usize = 1024;

/// The render's constants (a read-only storage buffer; `params.wgsl`'s `Params`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct Params {
    pub to_world: [[f32; 4]; 4],
    pub width: u32,
    pub height: u32,
    pub spp_pass: u32,
    pub sample_base: u32,
    pub seed_lo: u32,
    pub seed_hi: u32,
    pub max_depth: u32,
    pub rr_depth: u32,
    pub tan_half_x: f32,
    pub inv_aspect: f32,
    pub lens_radius: f32,
    pub focal_distance: f32,
    pub near_clip: f32,
    pub far_clip: f32,
    pub filter_radius: f32,
    /// 1 where the bounded emitters are chosen by power (more than
    /// `EXHAUSTIVE_MAX` of them), 0 where weighed per shading point: the
    /// tables' decision (`light_groups.rs`), which the shader reads
    /// rather than repeating the limit.
    pub bounded_by_power: u32,
    /// Constant environment radiance.
    pub env: [f32; 4],
    /// Probability that emitter sampling picks the environment.
    pub env_prob: f32,
    pub node_count: u32,
    /// ENV_NONE, ENV_CONSTANT or ENV_MAP.
    pub env_kind: u32,
    /// Whether camera rays see the environment.
    pub env_visible: u32,
    /// Rows of the map's rotation to the world and back (w unused).
    pub env_to_world: [[f32; 4]; 3],
    pub env_to_local: [[f32; 4]; 3],
    pub env_width: u32,
    pub env_bands: u32,
    pub env_bilinear: u32,
    pub env_band_scale: f32,
    pub env_band_offset: f32,
    pub env_col_offset: f32,
    /// Where each table starts in `env_data` (the texels start at 0).
    pub off_edges: u32,
    pub off_inv_heights: u32,
    pub off_rows: u32,
    pub off_band_cdf: u32,
    pub off_col_cdf: u32,
    /// Mitsuba's `hide_emitters` (1): camera rays pass through emitting
    /// shapes and see no environment.
    pub hide_emitters: u32,
    /// 1 for Mitsuba's orthographic camera (`Projection::Orthographic`).
    pub orthographic: u32,
    /// The thin lens's regular polygon (0: a disk) and its rotation.
    pub aperture_blades: u32,
    pub aperture_rotation: f32,
    /// Where the env map's density values start in `env_data`.
    pub off_density: u32,
    /// Where Beckmann's visible-slope guesses start in `shapes`
    /// (`bsdf/beckmann_slopes.rs`'s table, four to a word).
    pub beckmann_table: u32,
    /// The light choice (`light_groups.rs`): where its group records start
    /// in `lights`, how many groups are at infinity (first) and bounded,
    /// and the probability of choosing any light at infinity.
    pub group_base: u32,
    pub unbounded_groups: u32,
    pub bounded_groups: u32,
    pub p_unbounded: f32,
    /// The env map's facing density (`EnvGpuFacing`; `env_blocks` 0 where
    /// it has none): where its tables start in `env_data`, and its blocks.
    pub off_block_cdf: u32,
    pub off_band_sums: u32,
    pub off_cell_sums: u32,
    pub env_blocks: u32,
    pub env_blocks_across: u32,
    pub env_block_col_shift: u32,
    pub env_block_band_shift: u32,
    /// How many numbers of each sample come from scrambled (0, 2)
    /// sequences (`sampling/sobol.rs`): `STRATIFIED_DIMENSIONS` for a
    /// stratified sampler, 0 for an independent one.
    pub stratified_dims: u32,
    /// How light is gathered: `STRATEGY_MIS`, `STRATEGY_MATS` (BSDF
    /// sampling only) or `STRATEGY_EMS` (emitter sampling, and emission
    /// found by the path only after specular bounces), as `path.rs`.
    pub strategy: u32,
    /// 1 for Mitsuba's `volpath` (`volpath.wgsl`), 0 for the path tracer.
    pub volpath: u32,
    /// The medium the camera sits in (`NONE`: vacuum).
    pub camera_medium: u32,
    /// Where the media tables start in `shapes` (`media_words`).
    pub media_base: u32,
    pub _pad: [u32; 3],
}

/// `Params::strategy`.
pub const STRATEGY_MIS: u32 = 0;
pub const STRATEGY_MATS: u32 = 1;
pub const STRATEGY_EMS: u32 = 2;

/// `Params::env_kind`.
pub const ENV_NONE: u32 = 0;
pub const ENV_CONSTANT: u32 = 1;
pub const ENV_MAP: u32 = 2;

/// The flattened scene.
pub struct GpuScene {
    pub params: Params,
    /// Two per node: (min, first index as bits), (max, primitive count as
    /// bits; 0 for an inner node whose children are `first`, `first + 1`).
    pub nodes: Vec<[f32; 4]>,
    /// Three per primitive in leaf order. Triangle: (v0, shape), (v1,
    /// normal slot or NONE), (v2, light or NONE). Sphere: (centre, shape),
    /// (radius, uv-frame slot or NONE, placement slot or NONE, SPHERE),
    /// (0, 0, 0, light or NONE); a placement slot (an unevenly scaled
    /// instance's) holds the world-to-group rows, and centre, radius and
    /// frame are the group's. Disk: (centre,
    /// shape), (dual basis dx, DISK or DISK_FLIPPED), (dy, light or NONE).
    pub prims: Vec<[f32; 4]>,
    /// `SLOT_WORDS` per vertex-data slot: a triangle's vertex normals and
    /// uvs (slots are given to triangles with normals, and to those of
    /// textured shapes), or a textured sphere's (u, v) frame.
    pub normals: Vec<[f32; 4]>,
    /// `SHAPE_WORDS` per shape (`material` says what they hold), then
    /// the rough plastics' coating transmittance tables (16 words each)
    /// and the textures' records (`texture_record`), then Beckmann's
    /// visible-slope guesses (`Params::beckmann_table`).
    pub shapes: Vec<[f32; 4]>,
    /// `LIGHT_WORDS` per light: (p0, centre, position or direction to the
    /// light; kind), (p1, (radius, 0, 0) or the spot's world-to-local row
    /// 0; area or the spot's cos cutoff), (p2 or row 1; CDF up to and
    /// including it within its group), (radiance, intensity or irradiance; shape, a spot's
    /// projected texture's record as bits, or NONE),
    /// (row 2, a disk's front normal or a triangle's or sphere's
    /// vertex-data slot (uvs, (u, v) frame) as bits; the spot's cos beam or
    /// an area light's radiance texture record as bits, NONE if
    /// untextured), (its emitter group as bits, probability within the
    /// group, 0, 0). A disk's (p0, p1, p2) are its centre and axes ex, ey;
    /// the CDF in word 2 runs within the light's group. Then, from
    /// `Params::group_base`, the emitter groups (`light_groups.rs`).
    pub lights: Vec<[f32; 4]>,
    /// The filter's weight at `radius * i / (FILTER_TABLE - 1)`.
    pub filter_table: Vec<f32>,
    /// The environment map's tables (`EnvGpuTables`), one after another:
    /// texels (RGB), band edges, inverse band heights, texel rows (as
    /// bits), band CDF, column CDFs, density values, and the facing
    /// density's block CDFs, band and cell running sums.
    pub env_data: Vec<f32>,
    /// Bit `1 << kind` for every material kind some record or blend layer
    /// has: the shader is specialised to them ([`GpuScene::shader_constants`]).
    pub material_kinds: u32,
}

/// Something in the scene the GPU backend cannot render yet.
#[derive(Debug, thiserror::Error)]
#[error("the GPU backend does not support {0} yet (it renders perspective, thin-lens and orthographic cameras, triangle meshes, rectangles, disks and spheres, shape groups and instances, diffuse, mirror, conductor, rough conductor, plastic, rough plastic, smooth, thin and rough dielectric, pplastic, null, polarizer, Nori's microfacet, the Zaragoza fork's roughconductor and roughsubstrate, principled and principledthin BSDFs (two-sided too, masked, blended, normal- and bump-mapped, anisotropic, textured reflectances, transmittances, conductors' eta and k, roughness and every Disney parameter), area, point, spot and directional lights (textured too) and projectors, a constant environment and environment maps, with the path tracer or direct illumination by MIS, BSDF sampling or emitter sampling, and volpath through homogeneous and heterogeneous media); render on the CPU (--device cpu)")]
pub struct Unsupported(pub String);

fn unsupported<T>(what: impl Into<String>) -> Result<T, Unsupported> {
    Err(Unsupported(what.into()))
}

pub(super) fn bits(u: u32) -> f32 {
    f32::from_bits(u)
}

fn v4(v: Vec3, w: f32) -> [f32; 4] {
    [v.x, v.y, v.z, w]
}

fn luminance(c: Rgb) -> f32 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}

/// One primitive before the BVH orders them.
#[derive(Clone, Copy)]
enum Prim {
    Triangle {
        shape: u32,
        v: [Vec3; 3],
        normals: Option<[Vec3; 3]>,
        /// Vertex uvs, for shapes whose material is textured.
        uvs: Option<[Vec2; 3]>,
        /// The triangle's index in its mesh and whether its corners 1 and
        /// 2 were swapped (rewound by a mirroring instance): where a
        /// `mesh_attribute` texture reads its values.
        index: u32,
        swapped: bool,
    },
    Sphere {
        shape: u32,
        center: Vec3,
        radius: f32,
        /// The (u, v) frame, for spheres whose material is textured:
        /// object x, y and z (the polar axis) in world space (in the
        /// group's space under a `placement`), and the convention.
        uv_frame: Option<([Vec3; 3], SphereUv)>,
        /// An instance's group-to-world transform that scales the sphere
        /// unevenly (an ellipsoid: centre, radius and frame stay in the
        /// group's space); `None` where they are in world space.
        placement: Option<Transform>,
    },
    Disk {
        shape: u32,
        disk: crate::geometry::Disk,
    },
}

impl Prim {
    /// This primitive (of a shape group) where an instance's `t` places it:
    /// triangles rewound where `t` mirrors, so that their front stays
    /// where the CPU's normals (transformed as normals) put it; spheres
    /// moved to the world under similarities, and kept in the group's
    /// space with the transform otherwise (ellipsoids).
    fn placed(&self, t: &Transform) -> Result<Prim, Unsupported> {
        Ok(match *self {
            Prim::Triangle {
                shape,
                v,
                normals,
                uvs,
                index,
                swapped,
            } => {
                let flips = t.flips_handedness();
                let order = if flips { [0, 2, 1] } else { [0, 1, 2] };
                Prim::Triangle {
                    shape,
                    v: order.map(|i| t.point(v[i])),
                    normals: normals.map(|n| order.map(|i| t.normal(n[i]).normalize_or_zero())),
                    uvs: uvs.map(|uv| order.map(|i| uv[i])),
                    index,
                    swapped: swapped != flips,
                }
            }
            Prim::Sphere {
                shape,
                center,
                radius,
                uv_frame,
                placement: _,
            } => {
                if !t.is_similarity() {
                    return Ok(Prim::Sphere {
                        shape,
                        center,
                        radius,
                        uv_frame,
                        placement: Some(*t),
                    });
                }
                Prim::Sphere {
                    shape,
                    center: t.point(center),
                    radius: radius * t.vector(Vec3::X).length(),
                    uv_frame: uv_frame
                        .map(|(axes, uv)| (axes.map(|a| t.vector(a).normalize_or_zero()), uv)),
                    placement: None,
                }
            }
            Prim::Disk { shape, disk } => Prim::Disk {
                shape,
                disk: disk
                    .transformed(t)
                    .map_err(|_| Unsupported("an instance that flattens a disk".into()))?,
            },
        })
    }

    fn bounds(&self) -> Aabb {
        match *self {
            Prim::Triangle { v, .. } => Aabb {
                min: v[0].min(v[1]).min(v[2]),
                max: v[0].max(v[1]).max(v[2]),
            },
            Prim::Sphere {
                center,
                radius,
                placement,
                ..
            } => {
                let local = Aabb {
                    min: center - radius,
                    max: center + radius,
                };
                match placement {
                    None => local,
                    // The group-space box's corners placed: a box around
                    // the ellipsoid.
                    Some(t) => t.bounds(local),
                }
            }
            Prim::Disk { disk, .. } => disk.bounds(),
        }
    }
}

/// The enum variant a value's `Debug` form starts with (`RoughPlastic`).
fn variant_name(v: &impl std::fmt::Debug) -> String {
    let text = format!("{v:?}");
    text.split(['(', ' ', '{'])
        .next()
        .unwrap_or("this")
        .to_string()
}

/// Phase function kinds (`volpath.wgsl`'s `PHASE_*`).
pub const PHASE_ISOTROPIC: u32 = 0;
pub const PHASE_HG: u32 = 1;
pub const PHASE_RAYLEIGH: u32 = 2;
/// Set in a medium's flags where paths sample emitters as they scatter in
/// it (Mitsuba's `sample_emitters`).
pub const MEDIUM_SAMPLES_EMITTERS: u32 = 0x100;
/// Set where its albedo is zero: nothing scatters, free flights pass
/// with the transmittance itself (`medium/mod.rs`).
pub const MEDIUM_ABSORBS_ONLY: u32 = 0x200;

/// Vec4 words per medium record and per volume record in `shapes`.
pub const MEDIUM_WORDS: usize = 4;
pub const VOLUME_WORDS: usize = 5;
/// Set in a heterogeneous medium's flags.
pub const MEDIUM_HETEROGENEOUS: u32 = 0x400;
/// At most this many grid values in all (4 bytes each) go to the GPU.
const MAX_VOXEL_VALUES: usize = 1 << 25;

/// The media as `volpath.wgsl` reads them, words from index `base` of the
/// shapes buffer on: per shape one word (interior, exterior, 0, 0), the
/// index of each side's medium record as bits (`NONE`: vacuum); then per
/// medium its record, `MEDIUM_WORDS` words: (sigma_t, flags) for a
/// homogeneous medium or (scale, majorant, 0, flags) for a heterogeneous
/// one (flags: its `PHASE_*` kind and `MEDIUM_*` bits), (the extinction
/// volume's box's min, Henyey-Greenstein's g), (its max, 0), (the albedo's
/// and the extinction's volume records as bits, 0, 0); then the volume
/// records, `VOLUME_WORDS` words: the world-to-volume rows, then (a
/// constant's value, NONE) or (the grid's resolution, index of its first
/// value in the buffer's scalars) and (values per voxel, `TEX_NEAREST` or
/// `TEX_BILINEAR`, `WRAP_*`, 0); then the grids' values, four to a word.
/// Also the camera's medium's record index.
fn media_words(scene: &Scene, base: usize) -> Result<(Vec<[f32; 4]>, u32), Unsupported> {
    use crate::medium::{MediumKind, Phase, Volume, VolumeData, VolumeFilter};
    let first = base + scene.shape_media.len();
    let record = |m: Option<u32>| m.map_or(NONE, |m| (first + MEDIUM_WORDS * m as usize) as u32);
    let mut words: Vec<[f32; 4]> = (scene.shape_media.iter())
        .map(|i| [bits(record(i.interior)), bits(record(i.exterior)), 0.0, 0.0])
        .collect();
    let volumes_first = first + MEDIUM_WORDS * scene.media.len();
    let mut volumes: Vec<&Volume> = Vec::new();
    let mut volume_record = |v| {
        volumes.push(v);
        bits((volumes_first + VOLUME_WORDS * (volumes.len() - 1)) as u32)
    };
    for medium in &scene.media {
        let (mut flags, g) = match medium.phase {
            Phase::Isotropic => (PHASE_ISOTROPIC, 0.0),
            Phase::HenyeyGreenstein { g } => (PHASE_HG, g),
            Phase::Rayleigh => (PHASE_RAYLEIGH, 0.0),
        };
        if medium.sample_emitters {
            flags |= MEDIUM_SAMPLES_EMITTERS;
        }
        match &medium.kind {
            MediumKind::Homogeneous(h) => {
                if h.albedo.as_constant() == Some(Rgb::ZERO) {
                    flags |= MEDIUM_ABSORBS_ONLY;
                }
                words.push(v4(h.sigma_t, bits(flags)));
                words.push([0.0, 0.0, 0.0, g]);
                words.push([0.0; 4]);
                words.push([volume_record(&h.albedo), bits(NONE), 0.0, 0.0]);
            }
            MediumKind::Heterogeneous(h) => {
                flags |= MEDIUM_HETEROGENEOUS;
                let bbox = h.sigma_t.bbox;
                words.push([h.scale, h.majorant, 0.0, bits(flags)]);
                words.push(v4(bbox.min, g));
                words.push(v4(bbox.max, 0.0));
                let albedo = volume_record(&h.albedo);
                words.push([albedo, volume_record(&h.sigma_t), 0.0, 0.0]);
            }
        }
    }
    let data_first = 4 * (volumes_first + VOLUME_WORDS * volumes.len());
    let mut data: Vec<f32> = Vec::new();
    for v in volumes {
        let m = v.to_local.m;
        words.extend((0..3).map(|i| m.row(i).to_array()));
        match &v.data {
            VolumeData::Constant(c) => {
                words.push(v4(*c, bits(NONE)));
                words.push([0.0; 4]);
            }
            VolumeData::Grid(g) => {
                let start = data_first + data.len();
                if data.len() + g.grid.data.len() > MAX_VOXEL_VALUES {
                    return unsupported(format!(
                        "grid volumes of more than {MAX_VOXEL_VALUES} values in all"
                    ));
                }
                data.extend_from_slice(&g.grid.data);
                let [nx, ny, nz] = g.grid.res.map(|n| bits(n as u32));
                words.push([nx, ny, nz, bits(start as u32)]);
                let filter = match g.filter {
                    VolumeFilter::Nearest => TEX_NEAREST,
                    VolumeFilter::Trilinear => TEX_BILINEAR,
                };
                words.push([
                    bits(g.grid.channels as u32),
                    bits(filter),
                    bits(wrap_code(g.wrap)),
                    0.0,
                ]);
            }
        }
    }
    words.extend(data.chunks(4).map(|c| {
        let mut w = [0.0; 4];
        w[..c.len()].copy_from_slice(c);
        w
    }));
    Ok((words, record(scene.camera_medium)))
}

/// The microfacet words: alpha along the shading frame's s axis (dp/du),
/// and the distribution word, alpha_v / alpha_u (1 where isotropic), negated
/// for Beckmann's (`bsdf.wgsl`'s `microfacet`).
fn roughness(d: &MicrofacetDistribution) -> (f32, f32) {
    let ratio = d.alpha_v / d.alpha_u;
    let word = match d.kind {
        MicrofacetType::Beckmann => -ratio,
        MicrofacetType::Ggx => ratio,
    };
    (d.alpha_u, word)
}

/// Whether a material's roughness differs along u and v: its shapes need
/// the CPU's dp/du on the GPU (vertex uvs, a sphere's axes).
fn anisotropic(bsdf: &Bsdf) -> bool {
    match bsdf {
        Bsdf::RoughConductor(c) => !c.distr.is_isotropic(),
        Bsdf::RoughDielectric(d) => !d.distr.is_isotropic(),
        Bsdf::RoughPlastic(p) => !p.distr.is_isotropic(),
        Bsdf::PolarizedPlastic(p) => !p.distr.is_isotropic(),
        Bsdf::Textured(t) => anisotropic(t.base()),
        Bsdf::Mask(m) => anisotropic(&m.nested),
        Bsdf::TwoSided(t) => anisotropic(&t.front) || anisotropic(&t.back),
        Bsdf::Blend(b) => anisotropic(&b.first) || anisotropic(&b.second),
        Bsdf::Principled(p) => p.anisotropic.is_some(),
        Bsdf::PrincipledThin(p) => p.anisotropic.is_some(),
        _ => false,
    }
}

/// A plastic's diffuse term: the diffuse reflectance over what the
/// coating reflects back inside (`internal`).
fn plastic_diffuse(kd: Rgb, internal: f32, nonlinear: bool) -> Rgb {
    if nonlinear {
        kd / (Rgb::ONE - kd * internal)
    } else {
        kd / (1.0 - internal)
    }
}

/// A shape's `SHAPE_WORDS` material words: [`material`]'s three, then (D,
/// back, 0, 0) with D a `mask`'s opacity (1 for other BSDFs), or its
/// texture's record index as bits (`MAT_TEXTURED_MASK`), and `back` a
/// different back's record (`MAT_BACK`). The mask's nested BSDF gives
/// the three words, with `MAT_MASK` set. A `twosided` material with a
/// different back gives its front's words, and appends its back's to
/// `tables`; both sides have `MAT_TWO_SIDED`.
fn shape_record(
    bsdf: &Bsdf,
    table_base: usize,
    tables: &mut Vec<[f32; 4]>,
) -> Result<[[f32; 4]; SHAPE_WORDS], Unsupported> {
    let flag = |w: &mut [f32; 4], f: u32| w[3] = bits(w[3].to_bits() | f);
    match bsdf {
        Bsdf::Mask(mask) => {
            if matches!(mask.nested, Bsdf::Mask(_)) {
                return unsupported("a mask inside a mask");
            }
            // A normal map's words (D's last two) stay under the mask.
            let [mut a, b, c, [_, back, z, w]] = shape_record(&mask.nested, table_base, tables)?;
            flag(&mut a, MAT_MASK);
            let (d, textured) = fraction_word(&mask.opacity, table_base, tables)?;
            if textured {
                flag(&mut a, MAT_TEXTURED_MASK);
            }
            Ok([a, b, c, [d, back, z, w]])
        }
        Bsdf::Tilted(t) => tilted(t, 0, table_base, tables),
        // twosided(normalmap(X)): X's record, tilted inside the mirroring.
        Bsdf::TwoSided(t) if t.front == t.back && matches!(*t.front, Bsdf::Tilted(_)) => {
            let Bsdf::Tilted(map) = &*t.front else {
                unreachable!()
            };
            let mut words = tilted(map, TILT_INSIDE_TWO_SIDED, table_base, tables)?;
            flag(&mut words[0], MAT_TWO_SIDED);
            Ok(words)
        }
        Bsdf::TwoSided(t) if t.front != t.back => {
            let [mut a, b, c] = material(&t.front, table_base, tables)?;
            flag(&mut a, MAT_TWO_SIDED | MAT_BACK);
            let mut back = material(&t.back, table_base, tables)?;
            flag(&mut back[0], MAT_TWO_SIDED);
            let index = bits((table_base + tables.len()) as u32);
            tables.extend(back);
            Ok([a, b, c, [1.0, index, 0.0, 0.0]])
        }
        other => {
            let [a, b, c] = material(other, table_base, tables)?;
            Ok([a, b, c, [1.0, 0.0, 0.0, 0.0]])
        }
    }
}

/// A `normalmap`'s or `bumpmap`'s shape record: its nested BSDF's three
/// words flagged `MAT_NORMAL_MAP`, then (1, the bump map's scale, the
/// normal or height texture's record, the `TILT_*` flags with `extra`).
/// Masks or different backs under the map are named unsupported.
fn tilted(
    t: &Tilted,
    extra: u32,
    table_base: usize,
    tables: &mut Vec<[f32; 4]>,
) -> Result<[[f32; 4]; SHAPE_WORDS], Unsupported> {
    let [mut a, b, c] = material(&t.nested, table_base, tables)?;
    a[3] = bits(a[3].to_bits() | MAT_NORMAL_MAP);
    let mut flags = extra;
    let (texture, scale) = match &t.tilt {
        Tilt::NormalMap(map) => (&map.normals, 0.0),
        Tilt::BumpMap(bump) => {
            flags |= TILT_BUMP;
            (&bump.height, bump.scale)
        }
    };
    let record = texture_record(texture, table_base, tables)?;
    if t.flip_invalid_normals {
        flags |= TILT_FLIP;
    }
    if t.use_shadowing_function {
        flags |= TILT_SHADOW;
    }
    Ok([a, b, c, [1.0, scale, record, bits(flags)]])
}

/// A BSDF's first three material words, as `bsdf.wgsl` reads them:
/// (A, kind), (B, alpha), (C, distribution) with, per kind, A the
/// diffuse reflectance (diffuse), the specular reflectance (conductors,
/// rough and thin dielectric) or the diffuse term (plastics); B (eta, 0,
/// 0) (dielectric), eta (conductors), the specular transmittance (rough
/// and thin dielectric) or the specular reflectance (plastics); C k
/// (conductors), (eta, 0, 0) (rough and thin dielectric) or (eta,
/// specular sampling weight, transmittance table) (plastics). Textured
/// colours and roughness put their record's index in place of the value
/// and set a flag in the kind (`MAT_TEXTURED`, `_B`, `_ALPHA`).
/// Rough plastics append their table to `tables`, whose words follow the
/// records (`table_base` is where they start).
fn material(
    bsdf: &Bsdf,
    table_base: usize,
    tables: &mut Vec<[f32; 4]>,
) -> Result<[[f32; 4]; 3], Unsupported> {
    let zero = [0.0; 4];
    Ok(match bsdf {
        Bsdf::Diffuse(d) => [v4(d.albedo, bits(MAT_DIFFUSE)), zero, zero],
        Bsdf::Textured(t) => {
            let base = t.base();
            let mut words = material(base, table_base, tables)?;
            let mut kind = words[0][3].to_bits();
            for (param, texture) in t.textures() {
                let Some(slot) = texture_slot(*param, base) else {
                    return unsupported(format!(
                        "a textured {param:?} parameter of the {} BSDF",
                        variant_name(base)
                    ));
                };
                // An isotropic texture names both alphas; a texture on one
                // of them only, or two textures, is anisotropic. The second
                // name adds no record.
                // (The Zaragoza fork's models have one alpha.)
                let one_alpha = matches!(base, Bsdf::SchlickConductor(_) | Bsdf::RoughSubstrate(_));
                let other = match slot {
                    TextureSlot::Alpha if !one_alpha => Some(BsdfParam::AlphaV),
                    TextureSlot::AlphaV => Some(BsdfParam::Alpha),
                    _ => None,
                };
                if let Some(other) = other {
                    let same = |(p, x): &(BsdfParam, Texture)| *p == other && x == texture;
                    if !t.textures().iter().any(same) {
                        return unsupported("a textured anisotropic roughness");
                    }
                }
                if let TextureSlot::AlphaV = slot {
                    continue;
                }
                let record = texture_record(texture, table_base, tables)?;
                match slot {
                    TextureSlot::A => {
                        // The plastics' diffuse term is computed from the
                        // texel (`bsdf.wgsl`'s `material_a`).
                        let (internal, nonlinear) = match base {
                            Bsdf::Plastic(p) => (p.fdr_int, p.nonlinear),
                            Bsdf::RoughPlastic(p) => (p.internal_reflectance, p.nonlinear),
                            _ => (0.0, false),
                        };
                        let nonlinear = if nonlinear { 1.0 } else { 0.0 };
                        words[0] = [record, internal, nonlinear, 0.0];
                        kind |= MAT_TEXTURED;
                    }
                    TextureSlot::B => {
                        words[1][0] = record;
                        kind |= MAT_TEXTURED_B;
                    }
                    TextureSlot::C => {
                        words[2][0] = record;
                        kind |= MAT_TEXTURED_C;
                    }
                    TextureSlot::Alpha => {
                        words[1][3] = record;
                        // One texture for both alphas: isotropic, whatever
                        // the base's constants were.
                        words[2][3] = words[2][3].signum();
                        kind |= MAT_TEXTURED_ALPHA;
                    }
                    TextureSlot::AlphaV => {}
                }
            }
            words[0][3] = bits(kind);
            words
        }
        // The same (non-transmitting) BSDF on both sides: the front, with
        // directions mirrored through the surface when seen from the back.
        Bsdf::TwoSided(t) if t.front == t.back => {
            let mut words = material(&t.front, table_base, tables)?;
            words[0][3] = bits(words[0][3].to_bits() | MAT_TWO_SIDED);
            words
        }
        // A different back: only at the top (`shape_record`).
        Bsdf::TwoSided(_) => {
            return unsupported("a two-sided BSDF with a different back inside another BSDF")
        }
        Bsdf::Tilted(_) => return unsupported("a normal or bump map inside another BSDF"),
        Bsdf::Blend(b) => blend(b, table_base, tables)?,
        Bsdf::Principled(p) => principled(p, table_base, tables)?,
        Bsdf::PrincipledThin(p) => principled_thin(p, table_base, tables)?,
        Bsdf::Mirror(_) => [v4(Vec3::ONE, bits(MAT_MIRROR)), zero, zero],
        Bsdf::Microfacet(m) => [
            v4(m.kd, bits(MAT_MICROFACET)),
            [m.ks, 0.0, 0.0, m.alpha],
            [m.eta, 0.0, 0.0, -1.0],
        ],
        Bsdf::SchlickConductor(c) => [
            v4(c.r0, bits(MAT_SCHLICK_CONDUCTOR)),
            [0.0, 0.0, 0.0, c.alpha],
            [0.0, 0.0, 0.0, -1.0],
        ],
        Bsdf::RoughSubstrate(r) => [
            v4(r.kd, bits(MAT_ROUGH_SUBSTRATE)),
            [r.diffuse_scale(), 0.0, 0.0, r.alpha],
            [r.eta, 0.0, 0.0, -1.0],
        ],
        Bsdf::PolarizedPlastic(p) => {
            let (alpha, distr) = roughness(&p.distr);
            [
                v4(p.diffuse_reflectance, bits(MAT_POLARIZED_PLASTIC)),
                v4(p.specular_reflectance, alpha),
                [p.eta, p.specular_sampling_weight, 0.0, distr],
            ]
        }
        Bsdf::Null => [v4(Vec3::ONE, bits(MAT_PASS)), zero, zero],
        Bsdf::Polarizer(p) => [v4(p.transmittance * 0.5, bits(MAT_PASS)), zero, zero],
        Bsdf::Dielectric(d) => [
            v4(Vec3::ONE, bits(MAT_DIELECTRIC)),
            [d.eta, 0.0, 0.0, 0.0],
            zero,
        ],
        Bsdf::ThinDielectric(d) => [
            v4(d.specular_reflectance, bits(MAT_THIN_DIELECTRIC)),
            v4(d.specular_transmittance, 0.0),
            [d.eta, 0.0, 0.0, 0.0],
        ],
        Bsdf::Conductor(c) => [
            v4(c.specular_reflectance, bits(MAT_CONDUCTOR)),
            v4(c.eta, 0.0),
            v4(c.k, 0.0),
        ],
        Bsdf::RoughConductor(c) => {
            let (alpha, distr) = roughness(&c.distr);
            [
                v4(c.specular_reflectance, bits(MAT_ROUGH_CONDUCTOR)),
                v4(c.eta, alpha),
                v4(c.k, distr),
            ]
        }
        Bsdf::RoughDielectric(d) => {
            let (alpha, distr) = roughness(&d.distr);
            [
                v4(d.specular_reflectance, bits(MAT_ROUGH_DIELECTRIC)),
                v4(d.specular_transmittance, alpha),
                [d.eta, 0.0, 0.0, distr],
            ]
        }
        Bsdf::Plastic(p) => [
            v4(
                plastic_diffuse(p.diffuse_reflectance, p.fdr_int, p.nonlinear),
                bits(MAT_PLASTIC),
            ),
            v4(p.specular_reflectance, 0.0),
            [p.eta, p.specular_sampling_weight, 0.0, 0.0],
        ],
        Bsdf::RoughPlastic(p) => {
            let (alpha, distr) = roughness(&p.distr);
            let table = (table_base + tables.len()) as u32;
            tables.extend(
                p.external_transmittance
                    .chunks(4)
                    .map(|c| [c[0], c[1], c[2], c[3]]),
            );
            [
                v4(
                    plastic_diffuse(p.diffuse_reflectance, p.internal_reflectance, p.nonlinear),
                    bits(MAT_ROUGH_PLASTIC),
                ),
                v4(p.specular_reflectance, alpha),
                [p.eta, p.specular_sampling_weight, bits(table), distr],
            ]
        }
        other => return unsupported(format!("the {} BSDF", variant_name(other))),
    })
}

/// A fraction read as one value (a mask's opacity, a blend's weight): the
/// constant clipped to [0, 1], or its texture's record (appended to
/// `tables`) and true; the shader clips what it reads.
fn fraction_word(
    texture: &Texture,
    table_base: usize,
    tables: &mut Vec<[f32; 4]>,
) -> Result<(f32, bool), Unsupported> {
    Ok(match texture.constant() {
        Some(_) => (texture.eval_1(Vec2::ZERO).clamp(0.0, 1.0), false),
        None => (texture_record(texture, table_base, tables)?, true),
    })
}

/// Reads a Disney BSDF's parameters into material words: constants as
/// values (absent ones zero, which turns off the same terms as the CPU's
/// `None`), textures as records: with their flag set in `kind` (base
/// colour, metallic, spec_trans, eta, roughness) or boxed in a NaN
/// ([`DISNEY_RECORD`]: the rest).
struct DisneyWords<'a> {
    bsdf: &'static str,
    kind: u32,
    table_base: usize,
    tables: &'a mut Vec<[f32; 4]>,
}

impl DisneyWords<'_> {
    /// A one-value parameter: its constant, or its record: with `flag`
    /// set in the kind, else boxed in a NaN ([`DISNEY_RECORD`]).
    fn value(
        &mut self,
        name: &str,
        texture: Option<&Texture>,
        flag: Option<u32>,
    ) -> Result<f32, Unsupported> {
        let Some(texture) = texture else {
            return Ok(0.0);
        };
        match (texture.constant(), flag) {
            (Some(_), _) => Ok(texture.eval_1(Vec2::ZERO)),
            (None, Some(flag)) => {
                self.kind |= flag;
                texture_record(texture, self.table_base, self.tables)
            }
            (None, None) => {
                let record = texture_record(texture, self.table_base, self.tables)?.to_bits();
                if record >= DISNEY_RECORD_INDICES {
                    return unsupported(format!(
                        "a textured {name} parameter of the {} BSDF this far into a \
                         scene this large (its record at {record}, beyond {DISNEY_RECORD_INDICES})",
                        self.bsdf
                    ));
                }
                Ok(bits(DISNEY_RECORD | record))
            }
        }
    }

    /// Word A: the base colour, or its record (`MAT_TEXTURED`).
    fn base_color(&mut self, texture: &Texture) -> Result<[f32; 3], Unsupported> {
        Ok(match texture.constant() {
            Some(c) => c.to_array(),
            None => {
                self.kind |= MAT_TEXTURED;
                let record = texture_record(texture, self.table_base, self.tables)?;
                [record, 0.0, 0.0]
            }
        })
    }

    /// The word both Disney BSDFs share: (sheen, sheen_tint, flatness,
    /// spec_tint), constants or boxed records.
    fn sheen_word(
        &mut self,
        sheen: Option<&Texture>,
        sheen_tint: Option<&Texture>,
        flatness: Option<&Texture>,
        spec_tint: Option<&Texture>,
    ) -> Result<[f32; 4], Unsupported> {
        Ok([
            self.value("sheen", sheen, None)?,
            self.value("sheen_tint", sheen_tint, None)?,
            self.value("flatness", flatness, None)?,
            self.value("spec_tint", spec_tint, None)?,
        ])
    }

    /// Appends `words` to the tables; their index as bits.
    fn more(&mut self, words: [[f32; 4]; 2]) -> f32 {
        let index = bits((self.table_base + self.tables.len()) as u32);
        self.tables.extend(words);
        index
    }
}

/// A `principled` BSDF's three words (`MAT_PRINCIPLED`) and its two more
/// in `tables`; every parameter may be a texture.
fn principled(
    p: &Principled,
    table_base: usize,
    tables: &mut Vec<[f32; 4]>,
) -> Result<[[f32; 4]; 3], Unsupported> {
    let mut w = DisneyWords {
        bsdf: "principled",
        kind: MAT_PRINCIPLED,
        table_base,
        tables,
    };
    let metallic = w.value("metallic", p.metallic.as_ref(), Some(MAT_TEXTURED_B))?;
    let roughness = w.value("roughness", Some(&p.roughness), Some(MAT_TEXTURED_ALPHA))?;
    let spec_trans = w.value("spec_trans", p.spec_trans.as_ref(), Some(MAT_TEXTURED_C))?;
    let anisotropic = w.value("anisotropic", p.anisotropic.as_ref(), None)?;
    let clearcoat = w.value("clearcoat", p.clearcoat.as_ref(), None)?;
    let gloss = w.value("clearcoat_gloss", Some(&p.clearcoat_gloss), None)?;
    let sheen = w.sheen_word(
        p.sheen.as_ref(),
        p.sheen_tint.as_ref(),
        p.flatness.as_ref(),
        p.spec_tint.as_ref(),
    )?;
    let [r, g, b] = w.base_color(&p.base_color)?;
    let more = w.more([sheen, [p.diffuse_rate, p.clearcoat_rate, p.spec_rate, 0.0]]);
    Ok([
        [r, g, b, bits(w.kind)],
        [metallic, anisotropic, clearcoat, roughness],
        [spec_trans, p.eta, gloss, more],
    ])
}

/// A `principledthin` BSDF's three words (`MAT_PRINCIPLED_THIN`) and its
/// two more in `tables`; every parameter may be a texture.
fn principled_thin(
    p: &PrincipledThin,
    table_base: usize,
    tables: &mut Vec<[f32; 4]>,
) -> Result<[[f32; 4]; 3], Unsupported> {
    let mut w = DisneyWords {
        bsdf: "principledthin",
        kind: MAT_PRINCIPLED_THIN,
        table_base,
        tables,
    };
    let spec_trans = w.value("spec_trans", p.spec_trans.as_ref(), Some(MAT_TEXTURED_B))?;
    let roughness = w.value("roughness", Some(&p.roughness), Some(MAT_TEXTURED_ALPHA))?;
    let eta = w.value("eta", Some(&p.eta), Some(MAT_TEXTURED_C))?;
    let anisotropic = w.value("anisotropic", p.anisotropic.as_ref(), None)?;
    let diff_trans = w.value("diff_trans", p.diff_trans.as_ref(), None)?;
    let sheen = w.sheen_word(
        p.sheen.as_ref(),
        p.sheen_tint.as_ref(),
        p.flatness.as_ref(),
        p.spec_tint.as_ref(),
    )?;
    let [r, g, b] = w.base_color(&p.base_color)?;
    let more = w.more([
        sheen,
        [
            p.spec_refl_rate,
            p.spec_trans_rate,
            p.diff_refl_rate,
            p.diff_trans_rate,
        ],
    ]);
    Ok([
        [r, g, b, bits(w.kind)],
        [spec_trans, anisotropic, diff_trans, roughness],
        [eta, 0.0, 0.0, more],
    ])
}

/// A `blendbsdf`'s three words (`MAT_BLEND`): its two BSDFs' words go to
/// `tables`. A `twosided` pair mirrors the blend as a whole; one two-sided
/// BSDF beside a one-sided one, or a blend inside a blend, is named
/// unsupported.
fn blend(
    b: &Blend,
    table_base: usize,
    tables: &mut Vec<[f32; 4]>,
) -> Result<[[f32; 4]; 3], Unsupported> {
    let mut layers = [[[0.0; 4]; 3]; 2];
    for (words, bsdf) in layers.iter_mut().zip([&b.first, &b.second]) {
        if matches!(bsdf, Bsdf::Blend(_)) {
            return unsupported("a blendbsdf inside a blendbsdf");
        }
        *words = material(bsdf, table_base, tables)?;
    }
    let two_sided = layers.map(|w| w[0][3].to_bits() & MAT_TWO_SIDED != 0);
    if two_sided[0] != two_sided[1] {
        return unsupported("a blendbsdf of a two-sided and a one-sided BSDF");
    }
    let mut kind = MAT_BLEND;
    if two_sided[0] {
        kind |= MAT_TWO_SIDED;
    }
    let (weight, textured) = fraction_word(&b.weight, table_base, tables)?;
    if textured {
        kind |= MAT_TEXTURED;
    }
    let mut index = [0.0; 2];
    for (i, mut words) in layers.into_iter().enumerate() {
        words[0][3] = bits(words[0][3].to_bits() & !MAT_TWO_SIDED);
        index[i] = bits((table_base + tables.len()) as u32);
        tables.extend(words);
    }
    Ok([[weight, index[0], index[1], bits(kind)], [0.0; 4], [0.0; 4]])
}

/// `texture.wgsl`'s code for a wrap mode.
fn wrap_code(wrap: WrapMode) -> u32 {
    match wrap {
        WrapMode::Repeat => WRAP_REPEAT,
        WrapMode::Mirror => WRAP_MIRROR,
        WrapMode::Clamp => WRAP_CLAMP,
    }
}

/// Where a textured parameter goes in a material record (`material`).
enum TextureSlot {
    /// Word A's colour (flag `MAT_TEXTURED`).
    A,
    /// Word B's colour (flag `MAT_TEXTURED_B`).
    B,
    /// Word C's colour (flag `MAT_TEXTURED_C`).
    C,
    /// Word B's alpha (flag `MAT_TEXTURED_ALPHA`).
    Alpha,
    /// The second roughness: only as the same texture as `Alpha`.
    AlphaV,
}

/// The slot of `param` of a textured `base` model; `None` where the GPU
/// does not read it from a texture.
fn texture_slot(param: BsdfParam, base: &Bsdf) -> Option<TextureSlot> {
    use BsdfParam as P;
    Some(match (param, base) {
        (
            P::Diffuse,
            Bsdf::Diffuse(_)
            | Bsdf::Plastic(_)
            | Bsdf::RoughPlastic(_)
            | Bsdf::PolarizedPlastic(_)
            | Bsdf::Microfacet(_)
            | Bsdf::RoughSubstrate(_),
        ) => TextureSlot::A,
        (
            P::SpecularReflectance,
            Bsdf::Plastic(_) | Bsdf::RoughPlastic(_) | Bsdf::PolarizedPlastic(_),
        ) => TextureSlot::B,
        (
            P::SpecularReflectance,
            Bsdf::Conductor(_)
            | Bsdf::RoughConductor(_)
            | Bsdf::SchlickConductor(_)
            | Bsdf::ThinDielectric(_)
            | Bsdf::RoughDielectric(_),
        ) => TextureSlot::A,
        (P::SpecularTransmittance, Bsdf::ThinDielectric(_) | Bsdf::RoughDielectric(_)) => {
            TextureSlot::B
        }
        (P::Eta, Bsdf::Conductor(_) | Bsdf::RoughConductor(_)) => TextureSlot::B,
        (P::K, Bsdf::Conductor(_) | Bsdf::RoughConductor(_)) => TextureSlot::C,
        (
            P::Alpha,
            Bsdf::RoughConductor(_)
            | Bsdf::RoughDielectric(_)
            | Bsdf::PolarizedPlastic(_)
            | Bsdf::SchlickConductor(_)
            | Bsdf::RoughSubstrate(_),
        ) => TextureSlot::Alpha,
        (
            P::AlphaV,
            Bsdf::RoughConductor(_) | Bsdf::RoughDielectric(_) | Bsdf::PolarizedPlastic(_),
        ) => TextureSlot::AlphaV,
        _ => return None,
    })
}

/// Appends a texture's record to `words` (which start at index `base` of
/// the shapes buffer) and returns its index there, as bits: (to_uv row 0, index of its first texel as bits),
/// (to_uv row 1, width as bits), (height, filter, wrap, 0 as bits), then
/// its texels (RGB, 0), row by row from the top, looked up as
/// `texture/bitmap.rs` does; a checkerboard has `TEX_CHECKERBOARD` for its
/// filter and its two colours for texels.
fn texture_record(
    texture: &Texture,
    base: usize,
    words: &mut Vec<[f32; 4]>,
) -> Result<f32, Unsupported> {
    let colours;
    let nori_uv;
    let scaled: Vec<Rgb>;
    let (to_uv, (width, height), filter, wrap, texels) = match texture {
        Texture::Bitmap(b) => {
            let img = b.image();
            let filter = match b.filter {
                FilterType::Nearest => TEX_NEAREST,
                FilterType::Bilinear => TEX_BILINEAR,
            };
            let size = (img.width(), img.height());
            (&b.to_uv, size, filter, wrap_code(b.wrap), img.texels())
        }
        Texture::Checkerboard(c) => {
            colours = [c.color0, c.color1];
            (
                &c.to_uv,
                (2, 1),
                TEX_CHECKERBOARD,
                WRAP_REPEAT,
                &colours[..],
            )
        }
        // The Nori forks' checkers: squares at uv * scale + offset, the
        // rule in the wrap word, the values where the keys agree and differ.
        Texture::NoriChecker(c) => {
            colours = [c.same, c.differ];
            nori_uv = UvTransform {
                row0: [c.scale.x, 0.0, c.offset.x],
                row1: [0.0, c.scale.y, c.offset.y],
            };
            let rule = match c.rule {
                CheckerRule::Eth => CHECKER_ETH,
                CheckerRule::Zaragoza => CHECKER_ZARAGOZA,
            };
            (&nori_uv, (2, 1), TEX_NORI_CHECKER, rule, &colours[..])
        }
        Texture::MeshAttribute(a) => {
            let (values, per_triangle) = a.values();
            scaled = values.iter().map(|&v| v * a.scale).collect();
            let triangles = values.len() / per_triangle;
            (
                &UvTransform::IDENTITY,
                (per_triangle, triangles),
                TEX_MESH_ATTRIBUTE,
                0,
                &scaled[..],
            )
        }
        other => return unsupported(format!("a {} texture", variant_name(other))),
    };
    if words.len() + texels.len() > MAX_TEXELS {
        return unsupported(format!(
            "textures of more than {MAX_TEXELS} texels in all (this one has {width} x {height})"
        ));
    }
    let record = base + words.len();
    let first = (record + 3) as u32;
    let (r0, r1) = (to_uv.row0, to_uv.row1);
    words.push([r0[0], r0[1], r0[2], bits(first)]);
    words.push([r1[0], r1[1], r1[2], bits(width as u32)]);
    words.push([bits(height as u32), bits(filter), bits(wrap), 0.0]);
    words.extend(texels.iter().map(|&c| v4(c, 0.0)));
    Ok(bits(record as u32))
}

impl GpuScene {
    /// Flattens `scene` for `job`, or says what the GPU cannot render.
    pub fn new(scene: &Scene, job: &RenderJob, seed: u64) -> Result<GpuScene, Unsupported> {
        let volpath = matches!(job.integrator, Integrator::VolPath { .. });
        let (strategy, max_depth, rr_depth, hide_emitters) = match &job.integrator {
            Integrator::Path { strategy, params } => (
                *strategy,
                params.max_depth.unwrap_or(NONE),
                params.rr_depth,
                params.hide_emitters,
            ),
            // Its emitter and BSDF samples are weighed as the path
            // tracer's with MIS.
            Integrator::VolPath { params } => (
                Strategy::Mis,
                params.max_depth.unwrap_or(NONE),
                params.rr_depth,
                params.hide_emitters,
            ),
            // Direct illumination is the path tracer's first two segments
            // (integrator/mod.rs).
            Integrator::Direct { strategy } => (*strategy, 2, NONE, false),
            other => return unsupported(format!("the {} integrator", variant_name(other))),
        };
        if !volpath && (!scene.media.is_empty() || scene.camera_medium.is_some()) {
            return unsupported("participating media outside the volpath integrator");
        }

        let cam = &scene.camera.params;
        let (aperture_blades, aperture_rotation) = match cam.aperture {
            Aperture::Circular => (0, 0.0),
            Aperture::Polygon { blades, rotation } => (blades, rotation),
        };

        // Primitives, materials, emission.
        let mut prims = Vec::new();
        let mut shapes = Vec::new();
        let mut tables = Vec::new();
        let table_base = SHAPE_WORDS * scene.geometry.len();
        // Per shape: its emitter's radiance (a texture's mean, which weighs
        // the light's choice) and the texture's record as bits, or NONE.
        let mut emissions = Vec::with_capacity(scene.geometry.len());
        let mut material_kinds = 0u32;
        // The primitives of every shape in shape order, each in its own
        // space (a group's shapes in the group's); shape `s`'s begin at
        // `first_prim[s]`.
        let mut first_prim = Vec::with_capacity(scene.geometry.len() + 1);
        for (s, geometry) in scene.geometry.iter().enumerate() {
            first_prim.push(prims.len());
            let shape = s as u32;
            let mut words = shape_record(&scene.bsdfs[s], table_base, &mut tables)?;
            if scene.shape_emitter[s].is_some() {
                words[0][3] = bits(words[0][3].to_bits() | MAT_EMITS);
            }
            if scene.bsdfs[s].favours_facing_light() {
                words[0][3] = bits(words[0][3].to_bits() | MAT_FACING);
            }
            shapes.extend(words);
            let (emission, texture) = match scene.shape_emitter[s] {
                Some(e) => match &scene.emitters[e as usize] {
                    Emitter::Area(a) => match &a.texture {
                        None => (a.radiance, bits(NONE)),
                        Some(t) => (a.radiance, texture_record(t, table_base, &mut tables)?),
                    },
                    _ => return unsupported("an emitter on a shape other than an area light"),
                },
                None => (Rgb::ZERO, bits(NONE)),
            };
            emissions.push((emission, texture));
            // Either side's textures (and their blends' layers') and the
            // emitter's need the hit's uv.
            let kind = words[0][3].to_bits();
            let word = |index: f32| tables[index.to_bits() as usize - table_base];
            // The kind words of the record, its back and their blends'
            // layers: their flags decide the uv, their kinds specialise the
            // shader.
            let with_layers = |w: [f32; 4]| {
                let kind = w[3].to_bits();
                if kind & !MAT_FLAGS != MAT_BLEND {
                    return [kind; 3];
                }
                [kind, word(w[1])[3].to_bits(), word(w[2])[3].to_bits()]
            };
            let back = (kind & MAT_BACK != 0).then(|| with_layers(word(words[3][1])));
            let mut kinds = 0;
            for k in std::iter::once(with_layers(words[0])).chain(back).flatten() {
                kinds |= k;
                material_kinds |= 1 << (k & !MAT_FLAGS);
            }
            // An anisotropic material needs the CPU's dp/du, which the
            // vertex uvs and a sphere's axes give.
            let textured = kinds & MAT_TEXTURED_ANY != 0
                || texture.to_bits() != NONE
                || anisotropic(&scene.bsdfs[s]);
            match geometry {
                Geometry::Mesh(m) => {
                    let has_normals = !m.normals().is_empty();
                    for (t, idx) in m.indices().iter().enumerate() {
                        let normals = has_normals.then(|| idx.map(|i| m.normals()[i as usize]));
                        // Without uvs a triangle's uv is its (b1, b2), as
                        // on the CPU (mesh.rs's `shading_with`).
                        let uvs = textured.then(|| match m.uvs() {
                            [] => [Vec2::ZERO, Vec2::X, Vec2::Y],
                            uvs => idx.map(|i| uvs[i as usize]),
                        });
                        prims.push(Prim::Triangle {
                            shape,
                            v: m.vertices(t),
                            normals,
                            uvs,
                            index: t as u32,
                            swapped: false,
                        });
                    }
                }
                Geometry::Rectangle(r) => {
                    let f = &r.frame;
                    let c = [
                        f.center - f.ex - f.ey,
                        f.center + f.ex - f.ey,
                        f.center + f.ex + f.ey,
                        f.center - f.ex + f.ey,
                    ];
                    // Wound so that the triangles' normal is the
                    // rectangle's front.
                    let flip = (c[1] - c[0]).cross(c[2] - c[0]).dot(f.n) < 0.0;
                    // Mitsuba's rectangle uv: ((x + 1) / 2, (y + 1) / 2).
                    let uv = [Vec2::ZERO, Vec2::X, Vec2::ONE, Vec2::Y];
                    for (index, k) in [[0, 1, 2], [0, 2, 3]].into_iter().enumerate() {
                        let k = if flip { [k[0], k[2], k[1]] } else { k };
                        prims.push(Prim::Triangle {
                            shape,
                            v: k.map(|i| c[i]),
                            normals: None,
                            uvs: textured.then(|| k.map(|i| uv[i])),
                            index: index as u32,
                            swapped: flip,
                        });
                    }
                }
                Geometry::Sphere(sp) => prims.push(Prim::Sphere {
                    shape,
                    center: sp.center,
                    radius: sp.radius,
                    uv_frame: textured.then_some(([sp.x_axis, sp.y_axis, sp.axis], sp.uv)),
                    placement: None,
                }),
                Geometry::Disk(d) => prims.push(Prim::Disk { shape, disk: *d }),
                Geometry::Curve(_) => return unsupported("curves"),
            }
        }
        first_prim.push(prims.len());
        // The top-level primitives stay as they are; a group's are placed
        // wherever its instances put it (its shapes, and so its
        // primitives, are contiguous).
        let top = scene
            .group_shapes
            .first()
            .map_or(scene.geometry.len(), |g| g.start);
        let groups = prims.split_off(first_prim[top]);
        let of_group = |g: u32| {
            let shapes = &scene.group_shapes[g as usize];
            &groups[first_prim[shapes.start] - first_prim[top]
                ..first_prim[shapes.end] - first_prim[top]]
        };
        let placements = (0..scene.bvh.instance_count() as u32).map(|i| scene.bvh.instance(i));
        let total = (placements.clone())
            .map(|instance| of_group(instance.group).len())
            .fold(prims.len(), usize::saturating_add);
        if total > MAX_PLACED_PRIMS {
            return unsupported(format!(
                "{total} primitives once the instances are placed (at most {MAX_PLACED_PRIMS})"
            ));
        }
        for instance in placements {
            for p in of_group(instance.group) {
                prims.push(p.placed(&instance.to_world)?);
            }
        }
        if prims.is_empty() {
            return unsupported("a scene without shapes");
        }
        shapes.extend(tables);
        let media_base = shapes.len();
        let (media, camera_medium) = if volpath {
            media_words(scene, media_base)?
        } else {
            (Vec::new(), NONE)
        };
        shapes.extend(media);
        // Beckmann's visible-slope guesses, for every scene (8 KiB).
        let beckmann_table = shapes.len() as u32;
        shapes.extend(
            crate::bsdf::beckmann_slopes::guess_table()
                .chunks(4)
                .map(|c| [c[0], c[1], c[2], c[3]]),
        );

        // The environment, and the delta lights' records (each with its
        // power, for the choice below).
        let mut env = [0.0f32; 4];
        let mut env_kind = ENV_NONE;
        let mut tables = None;
        let mut delta_lights = Vec::new();
        let mut env_power = None;
        let ctx = scene.emitter_context();
        for (ei, e) in scene.emitters.iter().enumerate() {
            if matches!(e, Emitter::Constant(_) | Emitter::Environment(_)) && env_kind != ENV_NONE {
                return unsupported("more than one environment");
            }
            let none = bits(NONE);
            match e {
                Emitter::Area(_) => {}
                Emitter::Constant(c) => {
                    env = v4(c.radiance, 0.0);
                    env_kind = ENV_CONSTANT;
                    env_power = Some(e.power(&ctx));
                }
                Emitter::Environment(map) => {
                    if let Some(t) = map.gpu_tables(strategy.light_pdf()) {
                        env_kind = ENV_MAP;
                        tables = Some(t);
                        env_power = Some(e.power(&ctx));
                    }
                }
                Emitter::Point(p) => delta_lights.push((
                    [
                        v4(p.position, bits(LIGHT_POINT)),
                        [0.0; 4],
                        [0.0; 4],
                        v4(p.intensity, none),
                        [0.0; 4],
                    ],
                    ei,
                )),
                Emitter::Spot(s) => {
                    // A projected texture: its record in word 3's last value.
                    let texture = match s.texture() {
                        Some(t) => {
                            // (The records and tables are in `shapes` by now.)
                            texture_record(t, 0, &mut shapes)?
                        }
                        None => none,
                    };
                    let rows = s.to_local().transpose();
                    delta_lights.push((
                        [
                            v4(s.position, bits(LIGHT_SPOT)),
                            v4(rows.x_axis, s.cos_cutoff()),
                            v4(rows.y_axis, 0.0),
                            v4(s.intensity, texture),
                            v4(rows.z_axis, s.cos_beam()),
                        ],
                        ei,
                    ));
                }
                Emitter::Directional(d) => delta_lights.push((
                    [
                        v4(-d.direction, bits(LIGHT_DIRECTIONAL)),
                        [0.0; 4],
                        [0.0; 4],
                        v4(d.irradiance, none),
                        [0.0; 4],
                    ],
                    ei,
                )),
                Emitter::Projector(pj) => {
                    // The shader takes the axis from the world-to-local
                    // map's row 2: true unless the placement shears.
                    let rows = pj.to_local().transpose();
                    if rows.z_axis.normalize().dot(pj.axis) < 1.0 - 1e-5 {
                        return unsupported("a projector placed by a shearing transform");
                    }
                    // A bitmap's record in word 3's last value, pi scale
                    // as the intensity; a constant irradiance in it.
                    let (colour, texture) = match pj.irradiance.constant() {
                        Some(c) => (c * (PI * pj.scale), none),
                        None => (
                            Rgb::splat(PI * pj.scale),
                            texture_record(&pj.irradiance, 0, &mut shapes)?,
                        ),
                    };
                    delta_lights.push((
                        [
                            v4(pj.position, bits(LIGHT_PROJECTOR)),
                            v4(rows.x_axis, pj.tan_half()),
                            v4(rows.y_axis, 0.0),
                            v4(colour, texture),
                            v4(rows.z_axis, pj.aspect()),
                        ],
                        ei,
                    ));
                }
            }
        }
        let mut env_data: Vec<f32> = Vec::new();
        let mut offsets = [0u32; 9];
        if let Some(t) = &tables {
            env_data.extend(t.texels.iter().flatten());
            let facing = |f: fn(&EnvGpuFacing) -> &Vec<f32>| {
                t.facing.as_ref().map_or_else(Vec::new, |g| f(g).clone())
            };
            for (k, part) in [
                t.edges.clone(),
                t.inv_heights.clone(),
                t.rows.iter().map(|&r| bits(r)).collect(),
                t.band_cdf.clone(),
                t.col_cdf.clone(),
                t.density.clone(),
                facing(|g| &g.block_cdf),
                facing(|g| &g.band_sums),
                facing(|g| &g.cell_sums),
            ]
            .into_iter()
            .enumerate()
            {
                offsets[k] = env_data.len() as u32;
                env_data.extend(part);
            }
        } else {
            env_data.push(0.0);
        }

        // Lights: one record per emitting triangle, sphere or disk, and the
        // delta lights; grouped per emitter for the choice
        // (`light_groups.rs`).
        let mut lights = Vec::new();
        let mut groups: Vec<LightGroup> = Vec::new();
        // Emitter `e`'s group, its records from `first` on (weights added
        // as they come).
        let group = |e: usize, first: usize| {
            let power = scene.emitters[e].power(&ctx);
            LightGroup {
                bounds: LightBounds::of(&scene.emitters[e], &ctx, power),
                power,
                first,
                weights: Vec::new(),
            }
        };
        let mut group_of_emitter = vec![NONE; scene.emitters.len()];
        let mut prim_light = vec![NONE; prims.len()];
        let mut light_count = 0usize;
        for (pi, p) in prims.iter().enumerate() {
            let (shape, rec, area) = match *p {
                Prim::Triangle { shape, v, .. } => {
                    let area = 0.5 * (v[1] - v[0]).cross(v[2] - v[0]).length();
                    (
                        shape,
                        [
                            v4(v[0], bits(LIGHT_TRIANGLE)),
                            v4(v[1], area),
                            v4(v[2], 0.0),
                        ],
                        area,
                    )
                }
                Prim::Sphere {
                    shape,
                    center,
                    radius,
                    ..
                } => {
                    let area = 4.0 * std::f32::consts::PI * radius * radius;
                    (
                        shape,
                        [
                            v4(center, bits(LIGHT_SPHERE)),
                            [radius, 0.0, 0.0, area],
                            [0.0; 4],
                        ],
                        area,
                    )
                }
                Prim::Disk { shape, disk } => {
                    let f = &disk.frame;
                    let area = disk.area();
                    (
                        shape,
                        [
                            v4(f.center, bits(LIGHT_DISK)),
                            v4(f.ex, area),
                            v4(f.ey, 0.0),
                        ],
                        area,
                    )
                }
            };
            let (radiance, texture) = emissions[shape as usize];
            let power = area * luminance(radiance);
            let emitter = scene.shape_emitter[shape as usize];
            if let (Some(e), true) = (emitter, power > 0.0 && power.is_finite()) {
                if let Prim::Sphere {
                    placement: Some(_), ..
                } = p
                {
                    return unsupported("an emitting sphere that an instance scales unevenly");
                }
                prim_light[pi] = light_count as u32;
                lights.extend(rec);
                lights.push(v4(radiance, bits(shape)));
                // A disk's front; a triangle's or sphere's vertex-data slot
                // (set below, once slots are given out); the radiance
                // texture's record or NONE.
                lights.push(match p {
                    Prim::Disk { disk, .. } => v4(disk.frame.n, texture),
                    _ => [bits(NONE), 0.0, 0.0, texture],
                });
                // The choice's word (`choice_tables`).
                lights.push([0.0; 4]);
                // An emitter's primitives are consecutive (shape order).
                let e = e as usize;
                if group_of_emitter[e] == NONE {
                    group_of_emitter[e] = groups.len() as u32;
                    groups.push(group(e, light_count));
                }
                groups[group_of_emitter[e] as usize].weights.push(area);
                light_count += 1;
            }
        }
        for (rec, e) in delta_lights {
            groups.push(LightGroup {
                weights: vec![1.0],
                ..group(e, light_count)
            });
            lights.extend(rec);
            lights.push([0.0; 4]);
            light_count += 1;
        }
        let choice = choice_tables(&groups, env_power, &mut lights);
        let group_base = lights.len() as u32;
        lights.extend(&choice.groups);

        // The BVH, primitives in its leaf order.
        // Built over scattered boxes (`build_boxes`: identical primitives
        // would make the build quadratic), then refitted to the exact ones.
        let exact: Vec<Aabb> = prims.iter().map(Prim::bounds).collect();
        let mut build_time = std::time::Duration::ZERO;
        let mut bvh = build_bvh2(
            &build_boxes(&exact),
            BvhBuildParams::medium_build(),
            &mut build_time,
        );
        for n in bvh.nodes.iter_mut().filter(|n| n.is_leaf()) {
            let first = n.first_index as usize;
            let leaf = bvh.primitive_indices[first..first + n.prim_count as usize]
                .iter()
                .fold(Aabb::EMPTY, |acc, &i| acc.union(exact[i as usize]));
            n.set_aabb(OAabb::new(leaf.min.into(), leaf.max.into()));
        }
        bvh.refit_all();
        let mut nodes = Vec::with_capacity(bvh.nodes.len() * 2);
        for n in &bvh.nodes {
            nodes.push([
                n.aabb.min.x,
                n.aabb.min.y,
                n.aabb.min.z,
                bits(n.first_index),
            ]);
            nodes.push([n.aabb.max.x, n.aabb.max.y, n.aabb.max.z, bits(n.prim_count)]);
        }
        let mut flat = Vec::with_capacity(prims.len() * 3);
        let mut normals = Vec::new();
        for &i in &bvh.primitive_indices {
            let light = bits(prim_light[i as usize]);
            // A triangle's or sphere's vertex-data slot, which its light
            // record (if it emits) names too.
            let slot = match prims[i as usize] {
                Prim::Triangle {
                    shape,
                    v,
                    normals: n,
                    uvs,
                    index,
                    swapped,
                } => {
                    let slot = if n.is_some() || uvs.is_some() {
                        let slot = (normals.len() / SLOT_WORDS) as u32;
                        normals.extend(n.unwrap_or([Vec3::ZERO; 3]).map(|n| v4(n, 0.0)));
                        let t = uvs.unwrap_or([Vec2::ZERO; 3]);
                        normals.push([t[0].x, t[0].y, t[1].x, t[1].y]);
                        normals.push([t[2].x, t[2].y, bits(index), f32::from(swapped)]);
                        slot
                    } else {
                        NONE
                    };
                    flat.push(v4(v[0], bits(shape)));
                    flat.push(v4(v[1], bits(slot)));
                    flat.push(v4(v[2], light));
                    Some(slot)
                }
                Prim::Sphere {
                    shape,
                    center,
                    radius,
                    uv_frame,
                    placement,
                } => {
                    // An ellipsoid's world-to-group map takes a slot: its
                    // three rows, the translation in w.
                    let placed = match placement {
                        Some(t) => {
                            let slot = (normals.len() / SLOT_WORDS) as u32;
                            let m = t.inverse().m.transpose();
                            normals.extend([m.x_axis, m.y_axis, m.z_axis].map(|r| r.to_array()));
                            normals.extend([[0.0; 4]; SLOT_WORDS - 3]);
                            slot
                        }
                        None => NONE,
                    };
                    // A textured sphere's (u, v) frame takes a vertex-data
                    // slot: object x (with the convention), y and z.
                    let slot = match uv_frame {
                        Some((axes, convention)) => {
                            let slot = (normals.len() / SLOT_WORDS) as u32;
                            let eth = match convention {
                                SphereUv::Mitsuba => 0.0,
                                SphereUv::Eth => 1.0,
                            };
                            normals.push(v4(axes[0], eth));
                            normals.push(v4(axes[1], 0.0));
                            normals.push(v4(axes[2], 0.0));
                            normals.extend([[0.0; 4]; SLOT_WORDS - 3]);
                            slot
                        }
                        None => NONE,
                    };
                    flat.push(v4(center, bits(shape)));
                    flat.push([radius, bits(slot), bits(placed), bits(SPHERE)]);
                    flat.push([0.0, 0.0, 0.0, light]);
                    Some(slot)
                }
                Prim::Disk { shape, disk } => {
                    let f = &disk.frame;
                    let (dx, dy) = f.dual_basis();
                    let marker = if dx.cross(dy).dot(f.n) >= 0.0 {
                        DISK
                    } else {
                        DISK_FLIPPED
                    };
                    flat.push(v4(f.center, bits(shape)));
                    flat.push(v4(dx, bits(marker)));
                    flat.push(v4(dy, light));
                    None
                }
            };
            let emits = prim_light[i as usize];
            if let Some(slot) = slot.filter(|_| emits != NONE) {
                lights[LIGHT_WORDS * emits as usize + 4][0] = bits(slot);
            }
        }
        if normals.is_empty() {
            normals.push([0.0; 4]);
        }
        if lights.is_empty() {
            lights.push([0.0; 4]);
        }

        let radius = job.filter.radius();
        let filter_table = (0..FILTER_TABLE)
            .map(|i| {
                job.filter
                    .eval_1d(radius * i as f32 / (FILTER_TABLE - 1) as f32)
            })
            .collect();
        let mut params = Params {
            to_world: cam.to_world.m.to_cols_array_2d(),
            width: cam.width,
            height: cam.height,
            spp_pass: 1,
            seed_lo: seed as u32,
            seed_hi: (seed >> 32) as u32,
            max_depth,
            rr_depth,
            tan_half_x: (cam.fov_x_deg.to_radians() * 0.5).tan(),
            inv_aspect: cam.height as f32 / cam.width as f32,
            lens_radius: cam.lens_radius,
            focal_distance: cam.focal_distance,
            near_clip: cam.near_clip,
            far_clip: cam.far_clip,
            filter_radius: radius,
            bounded_by_power: choice.bounded_by_power as u32,
            env,
            env_prob: choice.env_prob,
            group_base,
            unbounded_groups: choice.unbounded_groups,
            bounded_groups: choice.bounded_groups,
            p_unbounded: choice.p_unbounded,
            node_count: bvh.nodes.len() as u32,
            env_kind,
            env_visible: 1,
            hide_emitters: hide_emitters as u32,
            orthographic: (cam.projection == Projection::Orthographic) as u32,
            aperture_blades,
            aperture_rotation,
            beckmann_table,
            volpath: volpath as u32,
            camera_medium,
            media_base: media_base as u32,
            strategy: match strategy {
                Strategy::Mis => STRATEGY_MIS,
                Strategy::Mats => STRATEGY_MATS,
                Strategy::Ems => STRATEGY_EMS,
            },
            stratified_dims: match job.sampler {
                SamplerKind::Independent => 0,
                SamplerKind::Stratified => STRATIFIED_DIMENSIONS,
            },
            ..Params::zeroed()
        };
        if let Some(t) = &tables {
            let rows = |m: [[f32; 3]; 3]| m.map(|r| [r[0], r[1], r[2], 0.0]);
            params.env_visible = t.visible as u32;
            params.env_to_world = rows(t.to_world);
            params.env_to_local = rows(t.to_local);
            params.env_width = t.width;
            params.env_bands = t.bands;
            params.env_bilinear = t.bilinear as u32;
            params.env_band_scale = t.band_scale;
            params.env_band_offset = t.band_offset;
            params.env_col_offset = t.col_offset;
            [
                params.off_edges,
                params.off_inv_heights,
                params.off_rows,
                params.off_band_cdf,
                params.off_col_cdf,
                params.off_density,
                params.off_block_cdf,
                params.off_band_sums,
                params.off_cell_sums,
            ] = offsets;
            if let Some(f) = &t.facing {
                params.env_blocks = f.blocks;
                params.env_blocks_across = f.across;
                params.env_block_col_shift = f.col_shift;
                params.env_block_band_shift = f.band_shift;
            }
        }
        Ok(GpuScene {
            params,
            nodes,
            prims: flat,
            normals,
            shapes,
            lights,
            filter_table,
            env_data,
            material_kinds,
        })
    }

    /// The path kernel's pipeline-overridable constants: which optional
    /// material code it keeps (`bsdf.wgsl`'s `BLENDS` and `DISNEY`), so
    /// that scenes without blends or Disney BSDFs run a smaller kernel
    /// (code the compiler drops, not a different image).
    pub fn shader_constants(&self) -> [(&'static str, f64); 3] {
        let has = |kinds: &[u32]| kinds.iter().any(|k| self.material_kinds & (1 << k) != 0);
        let flag = |on: bool| if on { 1.0 } else { 0.0 };
        [
            ("BLENDS", flag(has(&[MAT_BLEND]))),
            ("DISNEY", flag(has(&[MAT_PRINCIPLED, MAT_PRINCIPLED_THIN]))),
            ("VOLPATH", flag(self.params.volpath != 0)),
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::specular_to_eta;
    use crate::gpu::light_groups::GROUP_WORDS;
    use crate::integrator::PathParams;

    fn veach() -> (Scene, RenderJob) {
        let path =
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("bench/lights/veach_mis.xml");
        let (desc, _) = crate::load::load_scene_with(&path, &[]).unwrap();
        (Scene::new(desc.scene).unwrap(), desc.job)
    }

    /// Direct illumination is the path tracer cut after two segments, as
    /// on the CPU, with any of the three strategies.
    #[test]
    fn direct_illumination_is_two_path_segments() {
        let (scene, mut job) = veach();
        assert!(matches!(
            job.integrator,
            Integrator::Direct {
                strategy: Strategy::Mis
            }
        ));
        let flat = GpuScene::new(&scene, &job, 1).unwrap();
        assert_eq!((flat.params.max_depth, flat.params.rr_depth), (2, NONE));
        for (strategy, word) in [
            (Strategy::Ems, STRATEGY_EMS),
            (Strategy::Mats, STRATEGY_MATS),
        ] {
            job.integrator = Integrator::Direct { strategy };
            let flat = GpuScene::new(&scene, &job, 1).unwrap();
            assert_eq!((flat.params.max_depth, flat.params.strategy), (2, word));
        }
        job.integrator = Integrator::Path {
            strategy: Strategy::Mis,
            params: PathParams {
                max_depth: Some(7),
                rr_depth: 4,
                hide_emitters: false,
            },
        };
        let flat = GpuScene::new(&scene, &job, 1).unwrap();
        assert_eq!((flat.params.max_depth, flat.params.rr_depth), (7, 4));
    }

    /// A map of a few small bright boxes (where sampling for what a
    /// surface faces pays, `envmap/facing.rs`) gets the facing tables: per
    /// normal bin a CDF over the blocks ending at one, or zeros for a bin
    /// that sees no light. Shapes whose BSDF favours facing light are flagged, the
    /// glass sphere not; a smooth sunset probe gets no facing tables.
    #[test]
    fn facing_tables_and_flags() {
        let (scene, job) = load("tests/gpu/env_facing.xml");
        let flat = GpuScene::new(&scene, &job, 1).unwrap();
        let p = flat.params;
        let blocks = p.env_blocks as usize;
        assert!(blocks > 0);
        let rows = &flat.env_data[p.off_block_cdf as usize..][..64 * blocks];
        let (mut seeing, mut blind) = (0, 0);
        for row in rows.chunks(blocks) {
            if row.iter().all(|&c| c == 0.0) {
                blind += 1;
                continue;
            }
            seeing += 1;
            assert!(row.windows(2).all(|w| w[0] <= w[1]));
            assert_eq!(row[blocks - 1], 1.0);
        }
        assert!(seeing > blind, "{seeing} bins see light, {blind} none");
        assert!(p.off_band_sums > p.off_block_cdf && p.off_cell_sums > p.off_band_sums);
        let cells = (p.env_width * p.env_bands) as usize;
        assert_eq!(flat.env_data.len(), p.off_cell_sums as usize + cells);
        let facing: Vec<bool> = (0..scene.geometry.len())
            .map(|s| flat.shapes[SHAPE_WORDS * s][3].to_bits() & MAT_FACING != 0)
            .collect();
        assert_eq!(facing, [true, true, true, false, true]);

        let (scene, job) = load("tests/gpu/env_sunset_nori.xml");
        let flat = GpuScene::new(&scene, &job, 1).unwrap();
        assert_eq!(flat.params.env_kind, ENV_MAP);
        assert_eq!(flat.params.env_blocks, 0);
    }

    /// Every light is one record in its emitter's group: Veach's spheres
    /// are bounded groups of one record each, weighed per point; each
    /// record names its group, whose range holds it, and its CDF within
    /// the group ends at one.
    #[test]
    fn lights_are_records_in_emitter_groups() {
        let (scene, job) = veach();
        let flat = GpuScene::new(&scene, &job, 1).unwrap();
        let n = flat.params.group_base as usize / LIGHT_WORDS;
        let groups = (flat.params.unbounded_groups + flat.params.bounded_groups) as usize;
        assert_eq!(flat.params.group_base as usize, n * LIGHT_WORDS);
        assert_eq!(flat.params.bounded_by_power, 0);
        assert_eq!(flat.lights.len(), n * LIGHT_WORDS + groups * GROUP_WORDS);
        let emitters = scene.emitters.len();
        assert!(emitters >= 4, "{emitters} emitters");
        assert_eq!(flat.params.bounded_groups as usize, emitters);
        assert_eq!((flat.params.p_unbounded, flat.params.env_prob), (0.0, 0.0));
        for i in 0..n {
            let rec = &flat.lights[LIGHT_WORDS * i..][..LIGHT_WORDS];
            let g = rec[5][0].to_bits() as usize;
            let group = &flat.lights[n * LIGHT_WORDS + g * GROUP_WORDS..][..GROUP_WORDS];
            let (first, count) = (
                group[2][1].to_bits() as usize,
                group[2][2].to_bits() as usize,
            );
            assert!(
                (first..first + count).contains(&i),
                "record {i} in group {g}"
            );
            assert!(group[2][0] > 0.0, "group {g} has power");
            if i + 1 == first + count {
                assert_eq!(rec[2][3], 1.0, "record {i} ends its group's CDF");
            }
        }
    }

    /// Asserts that the GPU refuses `scene` with an error naming `what`.
    fn assert_refused(scene: &Scene, job: &RenderJob, what: &str) {
        let err = GpuScene::new(scene, job, 1)
            .err()
            .expect("an unsupported scene");
        assert!(err.to_string().contains(what), "{err}");
    }

    /// The material words of the shapes whose kind word has `flag`, in
    /// shape order, each with its kind less the texture flags.
    fn records_with(flat: &GpuScene, shapes: usize, flag: u32) -> Vec<(u32, &[[f32; 4]])> {
        (0..shapes)
            .map(|k| &flat.shapes[k * SHAPE_WORDS..(k + 1) * SHAPE_WORDS])
            .filter(|words| words[0][3].to_bits() & flag != 0)
            .map(|words| (words[0][3].to_bits() & !MAT_TEXTURED_ANY, words))
            .collect()
    }

    /// Asserts that every triangle and sphere of the shapes `needs`
    /// picks has a vertex-data slot (disks need none); returns how many.
    fn count_slotted(flat: &GpuScene, needs: impl Fn(usize) -> bool) -> usize {
        let mut with_slot = 0;
        for r in flat.prims.chunks(3) {
            let (shape, marker) = (r[0][3].to_bits() as usize, r[1][3].to_bits());
            if marker == DISK || marker == DISK_FLIPPED || !needs(shape) {
                continue;
            }
            let slot = if marker == SPHERE { r[1][1] } else { r[1][3] };
            assert_ne!(slot.to_bits(), NONE, "shape {shape}");
            with_slot += 1;
        }
        with_slot
    }

    fn load(file: &str) -> (Scene, RenderJob) {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(file);
        let (desc, _) = crate::load::load_scene_with(&path, &[]).unwrap();
        (Scene::new(desc.scene).unwrap(), desc.job)
    }

    /// A textured area light's records point at its texture's record and
    /// at the vertex-data slot its uvs come from (triangles) or its (u, v)
    /// frame (spheres); an untextured one has no texture; a spot points at
    /// the texture it projects.
    #[test]
    fn textured_lights_point_at_their_textures_and_uvs() {
        let (scene, job) = load("tests/conformance/textured_area.xml");
        let flat = GpuScene::new(&scene, &job, 1).unwrap();
        let mut kinds = Vec::new();
        for rec in flat.lights.chunks(LIGHT_WORDS) {
            let kind = rec[0][3].to_bits();
            if kind > LIGHT_SPHERE {
                continue;
            }
            let texture = rec[4][3].to_bits() as usize;
            assert_ne!(texture as u32, NONE, "light kind {kind} is textured");
            let filter = flat.shapes[texture + 2][1].to_bits();
            let slot = rec[4][0].to_bits();
            assert_ne!(slot, NONE, "light kind {kind} has its uvs");
            kinds.push((kind, filter));
        }
        assert!(kinds.contains(&(LIGHT_TRIANGLE, TEX_BILINEAR)), "{kinds:?}");
        assert!(
            kinds.contains(&(LIGHT_SPHERE, TEX_CHECKERBOARD)),
            "{kinds:?}"
        );

        let (scene, job) = load("tests/gpu/diffuse_box.xml");
        let flat = GpuScene::new(&scene, &job, 1).unwrap();
        for rec in flat.lights.chunks(LIGHT_WORDS) {
            if rec[0][3].to_bits() <= LIGHT_SPHERE {
                assert_eq!(rec[4][3].to_bits(), NONE);
            }
        }

        // Spots: one plain, one projecting a bitmap (word 3's last value).
        let (scene, job) = load("tests/conformance/spot.xml");
        let flat = GpuScene::new(&scene, &job, 1).unwrap();
        let spots: Vec<u32> = (flat.lights.chunks(LIGHT_WORDS))
            .filter(|rec| rec[0][3].to_bits() == LIGHT_SPOT)
            .map(|rec| rec[3][3].to_bits())
            .collect();
        assert_eq!(spots.len(), 2);
        assert!(spots.contains(&NONE), "{spots:?}");
        let record = *spots.iter().find(|&&r| r != NONE).unwrap() as usize;
        assert_eq!(flat.shapes[record + 2][1].to_bits(), TEX_BILINEAR);
    }

    /// A conductor's textured eta is word B's record, its k word C's:
    /// the floor has both, the sphere eta, the cube k.
    #[test]
    fn conductor_eta_and_k_are_records() {
        let (scene, job) = load("tests/gpu/conductor_textures.xml");
        let flat = GpuScene::new(&scene, &job, 1).unwrap();
        let mut seen = Vec::new();
        let flags = MAT_TEXTURED_B | MAT_TEXTURED_C;
        for (kind, words) in records_with(&flat, scene.bsdfs.len(), flags) {
            let textured = words[0][3].to_bits() & flags;
            for (flag, word) in [(MAT_TEXTURED_B, 1), (MAT_TEXTURED_C, 2)] {
                if textured & flag != 0 {
                    let record = words[word][0].to_bits() as usize;
                    assert!(flat.shapes[record + 2][1].to_bits() <= TEX_CHECKERBOARD);
                }
            }
            seen.push((kind, textured));
        }
        assert_eq!(
            seen,
            [
                (MAT_ROUGH_CONDUCTOR, MAT_TEXTURED_B | MAT_TEXTURED_C),
                (MAT_CONDUCTOR, MAT_TEXTURED_B),
                (MAT_ROUGH_CONDUCTOR, MAT_TEXTURED_C),
            ]
        );
    }

    /// Projectors are delta lights with their frame, tan(fov / 2) and
    /// aspect ratio: the bitmap one points at its record with pi scale as
    /// its intensity, the constant one carries pi scale times its
    /// irradiance. One placed by a shear is refused.
    #[test]
    fn projectors_are_delta_lights_with_their_image() {
        let (mut scene, job) = load("tests/conformance/projector.xml");
        let flat = GpuScene::new(&scene, &job, 1).unwrap();
        let records: Vec<_> = flat
            .lights
            .chunks(LIGHT_WORDS)
            .filter(|rec| rec[0][3].to_bits() == LIGHT_PROJECTOR)
            .collect();
        assert_eq!(records.len(), 2);
        let bitmap = records.iter().find(|r| r[3][3].to_bits() != NONE).unwrap();
        let header = &flat.shapes[bitmap[3][3].to_bits() as usize..][..3];
        assert_eq!(header[2][1].to_bits(), TEX_BILINEAR);
        assert_eq!(bitmap[3][..3], [3.0 * PI; 3]);
        assert_eq!(bitmap[1][3], 20f32.to_radians().tan());
        assert_eq!(bitmap[4][3], 2.0, "tiles.png is twice as wide as high");
        let constant = records.iter().find(|r| r[3][3].to_bits() == NONE).unwrap();
        let expect = Rgb::new(0.8, 0.9, 0.5) * PI;
        assert!((Vec3::from_slice(&constant[3][..3]) - expect).length() < 1e-5);

        let k = scene
            .emitters
            .iter()
            .position(|e| matches!(e, Emitter::Projector(_)))
            .unwrap();
        let Emitter::Projector(p) = &scene.emitters[k] else {
            unreachable!()
        };
        let shear = Transform::new(glam::Mat4::from_cols_array(&[
            1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.7, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0,
        ]))
        .unwrap();
        let sheared = crate::emitter::Projector::new(&shear, p.irradiance.clone(), 1.0, 40.0, 1.0);
        scene.emitters[k] = Emitter::Projector(Box::new(sheared.unwrap()));
        assert_refused(&scene, &job, "a projector placed by a shearing transform");
    }

    /// A mask is its nested BSDF's record with `MAT_MASK` and the opacity
    /// (a value, or a texture's record); a two-sided material with a
    /// different back points at the back's words, both sides flagged
    /// two-sided; a mask around it keeps the pointer.
    #[test]
    fn masks_and_different_backs_are_flagged_records() {
        let (scene, job) = load("tests/gpu/masks_and_sides.xml");
        let flat = GpuScene::new(&scene, &job, 1).unwrap();
        let words = |k: usize| &flat.shapes[k * SHAPE_WORDS..(k + 1) * SHAPE_WORDS];
        let kind = |w: &[[f32; 4]]| w[0][3].to_bits();
        let find = |f: &dyn Fn(&Bsdf) -> bool| scene.bsdfs.iter().position(f).unwrap();

        // The pane: a checkerboard opacity over a different back.
        let pane = find(&|b| matches!(b, Bsdf::Mask(m) if matches!(m.nested, Bsdf::TwoSided(_))));
        let w = words(pane);
        let flags = MAT_MASK | MAT_TEXTURED_MASK | MAT_TWO_SIDED | MAT_BACK;
        assert_eq!(kind(w), MAT_DIFFUSE | flags, "{:#x}", kind(w));
        let opacity = w[3][0].to_bits() as usize;
        assert_eq!(flat.shapes[opacity + 2][1].to_bits(), TEX_CHECKERBOARD);
        let back = w[3][1].to_bits() as usize;
        assert_eq!(
            kind(&flat.shapes[back..]),
            MAT_ROUGH_PLASTIC | MAT_TWO_SIDED
        );

        // The gold disk: a constant opacity, no back.
        let disk = find(&|b| matches!(b, Bsdf::Mask(m) if matches!(m.nested, Bsdf::Conductor(_))));
        let w = words(disk);
        assert_eq!(kind(w), MAT_CONDUCTOR | MAT_MASK);
        assert_eq!(w[3][0], 0.5);

        // The panels: rough copper in front, a textured diffuse behind.
        let panel = find(&|b| matches!(b, Bsdf::TwoSided(_)));
        let w = words(panel);
        assert_eq!(kind(w), MAT_ROUGH_CONDUCTOR | MAT_TWO_SIDED | MAT_BACK);
        assert_eq!(w[3][0], 1.0);
        let back = w[3][1].to_bits() as usize;
        let back_kind = kind(&flat.shapes[back..]);
        assert_eq!(back_kind, MAT_DIFFUSE | MAT_TWO_SIDED | MAT_TEXTURED);
    }

    /// A principled BSDF is three words and two more in the tables, its
    /// absent parameters zero; a textured base colour, metallic, spec_trans
    /// and roughness are records flagged as `bsdf.wgsl` reads them; any
    /// other textured parameter is named.
    #[test]
    fn principled_parameters_are_words_or_records() {
        let (mut scene, job) = load("tests/conformance/principled.xml");
        let flat = GpuScene::new(&scene, &job, 1).unwrap();
        let principled: Vec<usize> = (scene.bsdfs.iter().enumerate())
            .filter(|(_, b)| matches!(b, Bsdf::Principled(_)))
            .map(|(k, _)| k)
            .collect();
        assert_eq!(principled.len(), 5);
        let words = |k: usize| &flat.shapes[k * SHAPE_WORDS..(k + 1) * SHAPE_WORDS];
        let more = |k: usize| {
            let i = words(k)[2][3].to_bits() as usize;
            [flat.shapes[i], flat.shapes[i + 1]]
        };
        let kind = |k: usize| words(k)[0][3].to_bits();
        let [checker, sheen, coat, aniso, glass] = principled[..] else {
            unreachable!()
        };
        assert_eq!(
            flat.shader_constants(),
            [("BLENDS", 0.0), ("DISNEY", 1.0), ("VOLPATH", 0.0)]
        );
        // Constants are their channel means: equal within rounding.
        let near = |a: &[f32], b: &[f32]| a.iter().zip(b).all(|(a, b)| (a - b).abs() < 1e-6);
        // A checkerboard base colour; metallic 0.6, spec_tint 0.5.
        assert_eq!(kind(checker), MAT_PRINCIPLED | MAT_TEXTURED);
        assert!(near(&words(checker)[1], &[0.6, 0.0, 0.0, 0.4]));
        assert!(near(&more(checker)[0], &[0.0, 0.0, 0.0, 0.5]));
        // Sheen 0.9, its tint 0.6, flatness 0.7.
        assert_eq!(kind(sheen), MAT_PRINCIPLED);
        assert!(near(&words(sheen)[0][..3], &[0.3, 0.6, 0.2]));
        assert!(near(&more(sheen)[0], &[0.9, 0.6, 0.7, 0.0]));
        // Clearcoat 0.9 of gloss 0.5; eta from specular 0.3.
        assert!(near(&[words(coat)[1][2]], &[0.9]));
        assert!(near(&words(coat)[2][1..3], &[specular_to_eta(0.3), 0.5]));
        let Bsdf::Principled(p) = &scene.bsdfs[coat] else {
            unreachable!()
        };
        assert_eq!(
            more(coat)[1],
            [p.diffuse_rate, p.clearcoat_rate, p.spec_rate, 0.0]
        );
        // Anisotropic 0.8 with a checkerboard metallic: a record in B.x.
        assert_eq!(kind(aniso), MAT_PRINCIPLED | MAT_TEXTURED_B);
        assert!(near(&[words(aniso)[1][1]], &[0.8]));
        let header = |w: f32| flat.shapes[w.to_bits() as usize + 2];
        assert_eq!(header(words(aniso)[1][0])[1].to_bits(), TEX_CHECKERBOARD);
        // spec_trans 0.8, eta 1.4.
        assert!(near(&words(glass)[2][..2], &[0.8, 1.4]));

        let Bsdf::Principled(p) = &mut scene.bsdfs[checker] else {
            unreachable!()
        };
        // A textured parameter without a flag: its record boxed in a NaN.
        p.sheen = Some(p.base_color.clone());
        let flat = GpuScene::new(&scene, &job, 1).unwrap();
        let i = flat.shapes[checker * SHAPE_WORDS + 2][3].to_bits() as usize;
        assert_eq!(header_of_boxed(&flat, flat.shapes[i][0]), TEX_CHECKERBOARD);
        assert_eq!(flat.shapes[i][1..], [0.0, 0.0, 0.5]);
    }

    /// The header word of the record a Disney parameter boxes
    /// ([`DISNEY_RECORD`]); panics if the value is not a boxed record.
    fn header_of_boxed(flat: &GpuScene, value: f32) -> u32 {
        let b = value.to_bits();
        assert_eq!(b & DISNEY_RECORD, DISNEY_RECORD, "{value} is not a record");
        let record = (b & (DISNEY_RECORD_INDICES - 1)) as usize;
        flat.shapes[record + 2][1].to_bits()
    }

    /// A principledthin BSDF is three words and two more: a textured base
    /// colour, spec_trans, eta and roughness are records in their slots;
    /// the other textured parameters are records boxed in their values
    /// (diff_trans kept as given, 0 to 2, by its texture).
    #[test]
    fn principled_thin_parameters_are_words_or_records() {
        let (mut scene, job) = load("tests/gpu/principled_thin.xml");
        let flat = GpuScene::new(&scene, &job, 1).unwrap();
        let thin: Vec<usize> = (scene.bsdfs.iter().enumerate())
            .filter(|(_, b)| matches!(b, Bsdf::PrincipledThin(_)))
            .map(|(k, _)| k)
            .collect();
        let [textured, back] = thin[..] else {
            panic!("{thin:?}")
        };
        let words = |k: usize| &flat.shapes[k * SHAPE_WORDS..(k + 1) * SHAPE_WORDS];
        let kind = |k: usize| words(k)[0][3].to_bits();
        let flags = MAT_TEXTURED | MAT_TEXTURED_B | MAT_TEXTURED_C;
        assert_eq!(kind(textured), MAT_PRINCIPLED_THIN | flags);
        let header = |w: f32| flat.shapes[w.to_bits() as usize + 2];
        assert_eq!(header(words(textured)[1][0])[1].to_bits(), TEX_CHECKERBOARD);
        assert_eq!(header(words(textured)[2][0])[1].to_bits(), TEX_CHECKERBOARD);
        assert_eq!(header(words(textured)[0][0])[1].to_bits(), TEX_BILINEAR);
        assert_eq!(kind(back), MAT_PRINCIPLED_THIN | MAT_TEXTURED_ALPHA);
        let near = |a: &[f32], b: &[f32]| a.iter().zip(b).all(|(a, b)| (a - b).abs() < 1e-6);
        assert!(near(&[words(back)[1][0]], &[0.4]));
        // Anisotropic, diff_trans; sheen and its tint; spec_tint, flatness.
        for value in [words(back)[1][1], words(back)[1][2]] {
            assert_eq!(header_of_boxed(&flat, value), TEX_CHECKERBOARD);
        }
        let i = words(back)[2][3].to_bits() as usize;
        assert_eq!(header_of_boxed(&flat, flat.shapes[i][0]), TEX_CHECKERBOARD);
        assert_eq!(header_of_boxed(&flat, flat.shapes[i][1]), TEX_BILINEAR);
        assert_eq!(flat.shapes[i][2..], [0.0, 0.0]);
        let i = words(textured)[2][3].to_bits() as usize;
        for value in &flat.shapes[i][2..] {
            assert_eq!(header_of_boxed(&flat, *value), TEX_CHECKERBOARD);
        }
        // A constant stays a value (the control: boxing is told apart).
        let Bsdf::PrincipledThin(p) = &mut scene.bsdfs[back] else {
            unreachable!()
        };
        p.diff_trans = Some(Texture::Constant(Rgb::splat(1.2)));
        let flat = GpuScene::new(&scene, &job, 1).unwrap();
        assert!(near(&[flat.shapes[back * SHAPE_WORDS + 1][2]], &[1.2]));
    }

    /// Every code the shaders share with this file has the same value on
    /// both sides (WGSL cannot import Rust's constants).
    #[test]
    fn shader_constants_are_the_flattened_ones() {
        let shaders = [
            include_str!("shaders/params.wgsl"),
            include_str!("shaders/intersect.wgsl"),
            include_str!("shaders/texture.wgsl"),
            include_str!("shaders/bsdf.wgsl"),
            include_str!("shaders/principled.wgsl"),
            include_str!("shaders/emitter.wgsl"),
            include_str!("shaders/volpath.wgsl"),
        ]
        .concat();
        let ours: &[(&str, u32)] = &[
            ("NONE", NONE),
            ("SPHERE", SPHERE),
            ("DISK", DISK),
            ("DISK_FLIPPED", DISK_FLIPPED),
            ("LIGHT_WORDS", LIGHT_WORDS as u32),
            ("LIGHT_SPHERE", LIGHT_SPHERE),
            ("LIGHT_POINT", LIGHT_POINT),
            ("LIGHT_SPOT", LIGHT_SPOT),
            ("LIGHT_DIRECTIONAL", LIGHT_DIRECTIONAL),
            ("LIGHT_DISK", LIGHT_DISK),
            ("LIGHT_PROJECTOR", LIGHT_PROJECTOR),
            ("SHAPE_WORDS", SHAPE_WORDS as u32),
            ("MAT_DIFFUSE", MAT_DIFFUSE),
            ("MAT_ROUGH_CONDUCTOR", MAT_ROUGH_CONDUCTOR),
            ("MAT_PLASTIC", MAT_PLASTIC),
            ("MAT_ROUGH_PLASTIC", MAT_ROUGH_PLASTIC),
            ("MAT_ROUGH_DIELECTRIC", MAT_ROUGH_DIELECTRIC),
            ("MAT_PRINCIPLED", MAT_PRINCIPLED),
            ("MAT_PRINCIPLED_THIN", MAT_PRINCIPLED_THIN),
            ("MAT_BLEND", MAT_BLEND),
            ("MAT_MICROFACET", MAT_MICROFACET),
            ("MAT_SCHLICK_CONDUCTOR", MAT_SCHLICK_CONDUCTOR),
            ("MAT_ROUGH_SUBSTRATE", MAT_ROUGH_SUBSTRATE),
            ("MAT_POLARIZED_PLASTIC", MAT_POLARIZED_PLASTIC),
            ("MAT_MIRROR", MAT_MIRROR),
            ("MAT_DIELECTRIC", MAT_DIELECTRIC),
            ("MAT_CONDUCTOR", MAT_CONDUCTOR),
            ("MAT_THIN_DIELECTRIC", MAT_THIN_DIELECTRIC),
            ("MAT_PASS", MAT_PASS),
            ("MAT_EMITS", MAT_EMITS),
            ("MAT_TEXTURED", MAT_TEXTURED),
            ("MAT_TEXTURED_B", MAT_TEXTURED_B),
            ("MAT_TEXTURED_C", MAT_TEXTURED_C),
            ("MAT_TEXTURED_ALPHA", MAT_TEXTURED_ALPHA),
            ("MAT_TWO_SIDED", MAT_TWO_SIDED),
            ("MAT_MASK", MAT_MASK),
            ("MAT_TEXTURED_MASK", MAT_TEXTURED_MASK),
            ("MAT_BACK", MAT_BACK),
            ("MAT_NORMAL_MAP", MAT_NORMAL_MAP),
            ("MAT_FACING", MAT_FACING),
            ("DISNEY_RECORD", DISNEY_RECORD),
            ("DISNEY_RECORD_INDICES", DISNEY_RECORD_INDICES),
            ("TILT_FLIP", TILT_FLIP),
            ("PHASE_ISOTROPIC", PHASE_ISOTROPIC),
            ("PHASE_HG", PHASE_HG),
            ("PHASE_RAYLEIGH", PHASE_RAYLEIGH),
            ("MEDIUM_SAMPLES_EMITTERS", MEDIUM_SAMPLES_EMITTERS),
            ("MEDIUM_ABSORBS_ONLY", MEDIUM_ABSORBS_ONLY),
            ("MEDIUM_HETEROGENEOUS", MEDIUM_HETEROGENEOUS),
            ("MEDIUM_WORDS", MEDIUM_WORDS as u32),
            ("VOLUME_WORDS", VOLUME_WORDS as u32),
            ("TILT_SHADOW", TILT_SHADOW),
            ("TILT_INSIDE_TWO_SIDED", TILT_INSIDE_TWO_SIDED),
            ("TILT_BUMP", TILT_BUMP),
            ("SLOT_WORDS", SLOT_WORDS as u32),
            ("TEX_NEAREST", TEX_NEAREST),
            ("TEX_BILINEAR", TEX_BILINEAR),
            ("TEX_CHECKERBOARD", TEX_CHECKERBOARD),
            ("TEX_NORI_CHECKER", TEX_NORI_CHECKER),
            ("TEX_MESH_ATTRIBUTE", TEX_MESH_ATTRIBUTE),
            ("CHECKER_ETH", CHECKER_ETH),
            ("CHECKER_ZARAGOZA", CHECKER_ZARAGOZA),
            ("WRAP_REPEAT", WRAP_REPEAT),
            ("WRAP_MIRROR", WRAP_MIRROR),
            ("ENV_NONE", ENV_NONE),
            ("ENV_CONSTANT", ENV_CONSTANT),
            ("ENV_MAP", ENV_MAP),
        ];
        for &(name, value) in ours {
            let decl = format!("const {name}: u32 = ");
            let at = shaders
                .find(&decl)
                .unwrap_or_else(|| panic!("no {name} in the shaders"));
            let literal = shaders[at + decl.len()..].split('u').next().unwrap();
            let theirs = match literal.strip_prefix("0x") {
                Some(hex) => u32::from_str_radix(hex, 16),
                None => literal.parse(),
            };
            assert_eq!(theirs, Ok(value), "{name}");
        }
        // The shader's flag set is ours (it names each flag).
        let flags = shaders.split("const MAT_FLAGS: u32 = ").nth(1).unwrap();
        let flags = flags.split(';').next().unwrap();
        let named: u32 = flags
            .split('|')
            .map(|f| ours.iter().find(|(n, _)| *n == f.trim()).unwrap().1)
            .fold(0, |a, b| a | b);
        assert_eq!(named, MAT_FLAGS);
    }

    /// A blend's record holds its weight (or the weight texture's record)
    /// and points at its two BSDFs' words, wherever it stands: at the top,
    /// under `twosided` (the flag moves to the blend), a mask, a normal
    /// map, or as a different back. Its layers' textures give the shape
    /// uvs. A blend inside a blend, and a two-sided BSDF blended with a
    /// one-sided one, are named unsupported.
    #[test]
    fn blends_point_at_their_two_layers() {
        let (scene, job) = load("tests/gpu/blends.xml");
        let flat = GpuScene::new(&scene, &job, 1).unwrap();
        assert_eq!(
            flat.shader_constants(),
            [("BLENDS", 1.0), ("DISNEY", 0.0), ("VOLPATH", 0.0)]
        );
        let word = |i: f32| flat.shapes[i.to_bits() as usize];
        let kind = |w: [f32; 4]| w[3].to_bits();
        let layers = |w: [f32; 4]| [kind(word(w[1])), kind(word(w[2]))];
        let top = |s: usize| flat.shapes[s * SHAPE_WORDS];
        // The floor: a bitmap weight; a checkerboard diffuse and a rough
        // plastic.
        assert_eq!(kind(top(0)), MAT_BLEND | MAT_TEXTURED | MAT_FACING);
        let weight = word(top(0)[0]);
        assert_eq!(
            weight[3].to_bits() as usize,
            top(0)[0].to_bits() as usize + 3
        );
        assert_eq!(
            layers(top(0)),
            [MAT_DIFFUSE | MAT_TEXTURED, MAT_ROUGH_PLASTIC]
        );
        // Glass and rough gold at 0.3.
        assert_eq!(kind(top(1)), MAT_BLEND);
        assert_eq!(top(1)[0], 0.3);
        assert_eq!(layers(top(1)), [MAT_DIELECTRIC, MAT_ROUGH_CONDUCTOR]);
        // twosided(blend): the blend is two-sided, its layers are not.
        assert_eq!(kind(top(2)), MAT_BLEND | MAT_TWO_SIDED);
        assert_eq!(layers(top(2)), [MAT_DIFFUSE, MAT_ROUGH_CONDUCTOR]);
        // mask(blend) with a textured roughness in its first layer.
        assert_eq!(kind(top(3)), MAT_BLEND | MAT_MASK);
        assert_eq!(flat.shapes[3 * SHAPE_WORDS + 3][0], 0.7);
        assert_eq!(
            layers(top(3)),
            [MAT_ROUGH_CONDUCTOR | MAT_TEXTURED_ALPHA, MAT_PLASTIC]
        );
        // A blend behind a diffuse front.
        assert_eq!(kind(top(4)), MAT_DIFFUSE | MAT_TWO_SIDED | MAT_BACK);
        let back = word(flat.shapes[4 * SHAPE_WORDS + 3][1]);
        assert_eq!(kind(back), MAT_BLEND | MAT_TWO_SIDED);
        assert_eq!(layers(back), [MAT_DIFFUSE, MAT_CONDUCTOR]);
        // normalmap(blend).
        assert_eq!(kind(top(5)), MAT_BLEND | MAT_NORMAL_MAP);
        assert_eq!(layers(top(5)), [MAT_ROUGH_CONDUCTOR; 2]);
        // The layers' textures alone give the masked sphere its frame.
        assert_eq!(count_slotted(&flat, |s| s == 3), 1);

        let refuse = |edit: &dyn Fn(&Blend) -> Blend, what: &str| {
            let (mut scene, job) = load("tests/gpu/blends.xml");
            let Bsdf::Blend(b) = &scene.bsdfs[1] else {
                unreachable!()
            };
            scene.bsdfs[1] = Bsdf::Blend(Box::new(edit(b)));
            assert_refused(&scene, &job, what);
        };
        refuse(
            &|b| Blend {
                second: Bsdf::Blend(Box::new(b.clone())),
                ..b.clone()
            },
            "a blendbsdf inside a blendbsdf",
        );
        refuse(
            &|b| Blend {
                first: Bsdf::TwoSided(crate::bsdf::TwoSided {
                    front: Box::new(b.second.clone()),
                    back: Box::new(b.second.clone()),
                }),
                ..b.clone()
            },
            "a blendbsdf of a two-sided and a one-sided BSDF",
        );
    }

    /// A textured diffuse shape points at its texture's record, whose
    /// header and texels are the image's (a checkerboard's: its colours); its triangles get vertex-data
    /// slots with uvs, its spheres slots with their (u, v) frame. A
    /// conductor with a textured roughness is named as unsupported.
    #[test]
    fn textures_are_records_and_triangles_get_uvs() {
        let (scene, job) = load("tests/gpu/textured.xml");
        let flat = GpuScene::new(&scene, &job, 1).unwrap();
        let Bsdf::Textured(t) = &scene.bsdfs[0] else {
            panic!("the floor is textured");
        };
        let Texture::Bitmap(b) = &t.textures()[0].1 else {
            panic!("with a bitmap");
        };
        let words = &flat.shapes[0..SHAPE_WORDS];
        assert_eq!(
            words[0][3].to_bits(),
            MAT_DIFFUSE | MAT_TEXTURED | MAT_FACING
        );
        let record = words[0][0].to_bits() as usize;
        let header = &flat.shapes[record..record + 3];
        let img = b.image();
        assert_eq!(header[1][3].to_bits() as usize, img.width());
        assert_eq!(header[2][0].to_bits() as usize, img.height());
        assert_eq!(header[0][..3], b.to_uv.row0);
        assert_eq!(
            (header[2][1].to_bits(), header[2][2].to_bits()),
            (TEX_BILINEAR, WRAP_REPEAT)
        );
        let first = header[0][3].to_bits() as usize;
        let last = img.texels().len() - 1;
        assert_eq!(flat.shapes[first][..3], img.texels()[0].to_array());
        assert_eq!(
            flat.shapes[first + last][..3],
            img.texels()[last].to_array()
        );
        // The wall's checkerboard: its colours where texels would be.
        let Bsdf::Textured(t) = &scene.bsdfs[1] else {
            panic!("the wall is textured");
        };
        let Texture::Checkerboard(c) = &t.textures()[0].1 else {
            panic!("with a checkerboard");
        };
        let record = flat.shapes[SHAPE_WORDS][0].to_bits() as usize;
        assert_eq!(flat.shapes[record + 2][1].to_bits(), TEX_CHECKERBOARD);
        let first = flat.shapes[record][3].to_bits() as usize;
        assert_eq!(flat.shapes[first][..3], c.color0.to_array());
        assert_eq!(flat.shapes[first + 1][..3], c.color1.to_array());
        // Every triangle and sphere is of a textured shape here: each has
        // a slot; a sphere's holds its axes.
        let slot = |p: &[[f32; 4]]| match p[1][3].to_bits() {
            SPHERE => Some(p[1][1].to_bits()),
            DISK | DISK_FLIPPED => None,
            s => Some(s),
        };
        let slots: Vec<u32> = flat.prims.chunks(3).filter_map(slot).collect();
        assert!(slots.iter().all(|&s| s != NONE));
        assert_eq!(flat.normals.len(), slots.len() * SLOT_WORDS);
        let s = (scene.geometry.iter())
            .position(|g| matches!(g, Geometry::Sphere(_)))
            .expect("a sphere");
        let Geometry::Sphere(sp) = &scene.geometry[s] else {
            unreachable!()
        };
        let sphere = (flat.prims.chunks(3))
            .find(|p| p[1][3].to_bits() == SPHERE && p[0][3].to_bits() as usize == s);
        let k = sphere.unwrap()[1][1].to_bits() as usize * SLOT_WORDS;
        assert_eq!(flat.normals[k], v4(sp.x_axis, 0.0));
        assert_eq!(flat.normals[k + 2], v4(sp.axis, 0.0));
    }

    /// A mesh_attribute texture's record: its values times its scale,
    /// triangle by triangle (three corners each for per-vertex data, one
    /// for per-face data); unbound, it has no triangles (and reads 0).
    #[test]
    fn mesh_attributes_are_records_of_their_values() {
        use crate::geometry::MeshAttribute;
        use crate::texture::MeshAttributeTexture;
        let colours = MeshAttribute {
            name: "vertex_color".into(),
            per_vertex: true,
            channels: 3,
            values: (0..4).map(|i| Rgb::new(i as f32, 1.0, 2.0)).collect(),
        };
        let weights = MeshAttribute {
            name: "face_weight".into(),
            per_vertex: false,
            channels: 1,
            values: vec![Rgb::splat(0.25), Rgb::splat(0.75)],
        };
        let indices = [[0, 1, 2], [2, 3, 0]];
        let record = |name: &str, scale: f32, bind: bool| {
            let mut t = MeshAttributeTexture::new(name.into(), scale);
            if bind {
                t.bind(&[colours.clone(), weights.clone()], &indices)
                    .unwrap();
            }
            let mut words = vec![[0.0; 4]; 5];
            let at = texture_record(&Texture::MeshAttribute(Box::new(t)), 100, &mut words);
            assert_eq!(at.unwrap().to_bits(), 105);
            words.split_off(5)
        };
        let header = |w: &[[f32; 4]]| {
            (
                w[1][3].to_bits(),
                w[2][0].to_bits(),
                w[2][1].to_bits(),
                w[0][3].to_bits(),
            )
        };
        let w = record("vertex_color", 0.5, true);
        assert_eq!(header(&w), (3, 2, TEX_MESH_ATTRIBUTE, 108));
        let reds: Vec<f32> = w[3..].iter().map(|t| t[0]).collect();
        assert_eq!(reds, [0.0, 0.5, 1.0, 1.0, 1.5, 0.0]);
        assert_eq!(w[3][1..3], [0.5, 1.0]);
        let w = record("face_weight", 2.0, true);
        assert_eq!(header(&w), (1, 2, TEX_MESH_ATTRIBUTE, 108));
        assert_eq!(w[3][..3], [0.5; 3]);
        assert_eq!(w[4][..3], [1.5; 3]);
        assert_eq!(header(&record("vertex_color", 1.0, false)).1, 0);
    }

    /// Triangles of a mesh with a mesh_attribute texture know their index
    /// in the mesh, and whether a mirroring instance swapped their corners
    /// 1 and 2 (the barycentrics then swap back): each of the grid's 48
    /// triangles appears once per copy (two instances, the plain mesh and
    /// the emitting one), swapped in the mirrored instance only; the
    /// emitting mesh's light records point at slots that know them too
    /// (light samples read its mesh_attribute radiance there).
    #[test]
    fn triangles_know_their_index_in_the_mesh() {
        let (scene, job) = load("tests/gpu/mesh_attribute.xml");
        let flat = GpuScene::new(&scene, &job, 1).unwrap();
        let index = |slot: u32| {
            let w = flat.normals[slot as usize * SLOT_WORDS + 4];
            (w[2].to_bits() as usize, usize::from(w[3] != 0.0))
        };
        let mut seen = vec![[0usize; 2]; 48];
        for p in flat.prims.chunks(3) {
            let slot = p[1][3].to_bits();
            if matches!(slot, SPHERE | DISK | DISK_FLIPPED) || slot == NONE {
                continue;
            }
            let (tri, swapped) = index(slot);
            seen[tri][swapped] += 1;
        }
        assert!(seen.iter().all(|&s| s == [3, 1]), "{seen:?}");
        // The light records (the choice tables follow them): the emitting
        // mesh's triangles, textured.
        let emitting = scene
            .shape_emitter
            .iter()
            .position(Option::is_some)
            .unwrap() as u32;
        let mut lit = vec![0usize; 48];
        for rec in flat.lights.chunks(LIGHT_WORDS) {
            let of_mesh = rec[0][3].to_bits() == LIGHT_TRIANGLE && rec[3][3].to_bits() == emitting;
            if of_mesh && rec[4][3].to_bits() != NONE {
                let (tri, swapped) = index(rec[4][0].to_bits());
                assert_eq!(swapped, 0);
                lit[tri] += 1;
            }
        }
        assert!(lit.iter().all(|&n| n == 1), "{lit:?}");
    }

    /// Instances place copies of their group's primitives; too many
    /// copies are an error naming the count, before anything is allocated
    /// for them. (That a mirror rewinds its triangles, the image test's
    /// mirrored instance shows: without it, its faceted one-sided gold
    /// turns black, block |z| 76.)
    #[test]
    fn instances_are_placed_copies_within_a_bound() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/gpu/instances.xml");
        let (desc, _) = crate::load::load_scene_with(&path, &[]).unwrap();
        let (mut desc, job) = (desc.scene, desc.job);
        let scene = Scene::new(desc.clone()).unwrap();
        let flat = GpuScene::new(&scene, &job, 1).unwrap();
        // The group: an icosphere of 80 triangles, a sphere, a rectangle
        // (two triangles); the floor and the light are two triangles each.
        let group = 80 + 1 + 2;
        assert_eq!(scene.bvh.instance_count(), 4);
        assert_eq!(flat.prims.len() / 3, 4 + 4 * group);
        // The unevenly scaled instance's sphere keeps the group's centre
        // and radius and points at its world-to-group rows; the others are
        // in world space.
        let placements: Vec<u32> = (flat.prims.chunks(3))
            .filter(|p| p[1][3].to_bits() == SPHERE)
            .map(|p| p[1][2].to_bits())
            .collect();
        assert_eq!(placements.len(), 4);
        let placed: Vec<_> = placements.iter().filter(|&&k| k != NONE).collect();
        assert_eq!(placed.len(), 1, "{placements:?}");
        let k = *placed[0] as usize * SLOT_WORDS;
        let inst = scene.bvh.instance(3).to_world.inverse().m.transpose();
        assert_eq!(flat.normals[k], inst.x_axis.to_array());
        assert_eq!(flat.normals[k + 2], inst.z_axis.to_array());

        // Placed on a grid.
        let one = desc.instances[0];
        desc.instances = (0..MAX_PLACED_PRIMS / group + 1)
            .map(|i| crate::geometry::Instance {
                to_world: crate::math::Transform::new(glam::Mat4::from_translation(Vec3::new(
                    (i % 512) as f32 * 2.0,
                    0.0,
                    (i / 512) as f32 * 2.0,
                )))
                .unwrap(),
                ..one
            })
            .collect();
        let scene = Scene::new(desc).unwrap();
        assert_refused(&scene, &job, "primitives once the instances are placed");
    }

    /// A rough conductor with a textured roughness and specular
    /// reflectance points at both records; a texture on alpha_u alone is
    /// named as unsupported.
    #[test]
    fn textured_roughness_and_specular_colours_are_records() {
        let (mut scene, job) = load("tests/conformance/textures.xml");
        let flat = GpuScene::new(&scene, &job, 1).unwrap();
        let k = (scene.bsdfs.iter())
            .position(
                |b| matches!(b, Bsdf::Textured(t) if matches!(t.base(), Bsdf::RoughConductor(_))),
            )
            .expect("a textured rough conductor");
        let words = &flat.shapes[k * SHAPE_WORDS..(k + 1) * SHAPE_WORDS];
        let kind = words[0][3].to_bits();
        assert_eq!(
            kind,
            MAT_ROUGH_CONDUCTOR | MAT_TEXTURED | MAT_TEXTURED_ALPHA,
            "{kind:#x}"
        );
        let header = |w: f32| &flat.shapes[w.to_bits() as usize..w.to_bits() as usize + 3];
        assert_eq!(header(words[0][0])[2][1].to_bits(), TEX_CHECKERBOARD);
        assert_eq!(header(words[1][3])[2][1].to_bits(), TEX_BILINEAR);

        let Bsdf::Textured(t) = &scene.bsdfs[k] else {
            unreachable!()
        };
        let texture = t.textures()[0].1.clone();
        let base = t.base().clone();
        // A texture on alpha_u alone is anisotropic: named, not rendered
        // as if alpha_v followed it.
        let alpha_u = crate::bsdf::Textured::new(base, vec![(BsdfParam::Alpha, texture)]);
        scene.bsdfs[k] = Bsdf::Textured(Box::new(alpha_u.unwrap()));
        assert_refused(&scene, &job, "a textured anisotropic roughness");
    }

    /// A normal map is its nested BSDF's record flagged `MAT_NORMAL_MAP`,
    /// pointing at its texture with its switches; inside a `twosided`
    /// material it is also flagged two-sided and tilted inside. A map
    /// inside another BSDF is named unsupported.
    #[test]
    fn normal_maps_are_flagged_records() {
        let (mut scene, job) = load("tests/gpu/normal_map.xml");
        let flat = GpuScene::new(&scene, &job, 1).unwrap();
        let mut tilts = Vec::new();
        for (kind, words) in records_with(&flat, scene.bsdfs.len(), MAT_NORMAL_MAP) {
            let header = &flat.shapes[words[3][2].to_bits() as usize..][..3];
            assert!(header[2][1].to_bits() <= TEX_BILINEAR, "a bitmap");
            tilts.push((kind, words[3][3].to_bits()));
        }
        assert_eq!(
            tilts,
            [
                (MAT_ROUGH_CONDUCTOR, 0),
                (MAT_ROUGH_PLASTIC | MAT_MASK, TILT_FLIP | TILT_SHADOW),
                (
                    MAT_DIFFUSE | MAT_TWO_SIDED,
                    TILT_FLIP | TILT_SHADOW | TILT_INSIDE_TWO_SIDED
                ),
            ]
        );

        let k = scene.bsdfs.len() - 1;
        let Bsdf::TwoSided(t) = scene.bsdfs[k].clone() else {
            panic!("the sphere is two-sided")
        };
        // Under a mask the map keeps its words.
        scene.bsdfs[k] = Bsdf::Mask(Box::new(crate::bsdf::Mask {
            opacity: Texture::Constant(Rgb::splat(0.5)),
            nested: (*t.front).clone(),
        }));
        let flat = GpuScene::new(&scene, &job, 1).unwrap();
        let words = &flat.shapes[k * SHAPE_WORDS..(k + 1) * SHAPE_WORDS];
        assert_eq!(
            words[0][3].to_bits(),
            MAT_DIFFUSE | MAT_MASK | MAT_NORMAL_MAP
        );
        assert_eq!(words[3][0], 0.5);
        assert_eq!(words[3][3].to_bits(), TILT_FLIP | TILT_SHADOW);
        // A different back cannot hold one.
        scene.bsdfs[k] = Bsdf::TwoSided(crate::bsdf::TwoSided {
            front: t.front.clone(),
            back: Box::new(Bsdf::Diffuse(
                crate::bsdf::Diffuse::new(Rgb::splat(0.5)).unwrap(),
            )),
        });
        assert_refused(&scene, &job, "a normal or bump map inside another BSDF");
    }

    /// `Params` is as long as WGSL's struct (a multiple of 16 bytes), and
    /// every scene carries Beckmann's table of visible-slope guesses, in
    /// the shape the shader reads.
    #[test]
    fn params_fill_the_buffer_and_point_at_beckmann_guesses() {
        assert_eq!(std::mem::size_of::<Params>() % 16, 0);
        let (scene, job) = load("tests/gpu/diffuse_box.xml");
        let flat = GpuScene::new(&scene, &job, 1).unwrap();
        let table = crate::bsdf::beckmann_slopes::guess_table();
        let start = flat.params.beckmann_table as usize;
        let words = &flat.shapes[start..];
        assert_eq!(words.len() * 4, table.len());
        assert!(words.iter().flatten().zip(table).all(|(a, b)| a == b));
        // The shader indexes it with the table's own shape.
        let (rows, cols) = crate::bsdf::beckmann_slopes::GUESS_TABLE_SIZE;
        assert_eq!(rows * cols, table.len());
        let shader = include_str!("shaders/bsdf.wgsl");
        assert!(shader.contains(&format!("const BECKMANN_ROWS: u32 = {rows}u;")));
        assert!(shader.contains(&format!("const BECKMANN_COLS: u32 = {cols}u;")));
    }

    /// A bump map is a normal map's record with `TILT_BUMP` and its scale
    /// in word D; under a mask it keeps both, and its shapes get slots
    /// (uvs for the dp/du and dp/dv of triangles, a sphere's axes).
    #[test]
    fn bump_maps_carry_their_scale() {
        let (scene, job) = load("tests/gpu/bump_map.xml");
        let flat = GpuScene::new(&scene, &job, 1).unwrap();
        let mut bumps = Vec::new();
        for (kind, words) in records_with(&flat, scene.bsdfs.len(), MAT_NORMAL_MAP) {
            let header = &flat.shapes[words[3][2].to_bits() as usize..][..3];
            assert_eq!(header[2][1].to_bits(), TEX_BILINEAR, "a bilinear bitmap");
            bumps.push((kind, words[3][0], words[3][1], words[3][3].to_bits()));
        }
        let on = TILT_BUMP | TILT_FLIP | TILT_SHADOW;
        assert_eq!(
            bumps,
            [
                (MAT_ROUGH_PLASTIC, 1.0, 0.2, on),
                (
                    MAT_DIFFUSE | MAT_TWO_SIDED,
                    1.0,
                    -0.08,
                    on | TILT_INSIDE_TWO_SIDED
                ),
                (MAT_ROUGH_CONDUCTOR | MAT_MASK, 0.8, 0.05, TILT_BUMP),
                (MAT_PLASTIC, 1.0, 0.5, on),
            ]
        );
        // Every triangle and sphere of a bumped shape has a slot: the
        // floor's 2 triangles, the icosphere's 80, the sphere.
        let bumped = |s: usize| flat.shapes[s * SHAPE_WORDS][3].to_bits() & MAT_NORMAL_MAP != 0;
        assert_eq!(count_slotted(&flat, bumped), 83);
    }

    /// Anisotropic materials carry alpha_u and the ratio alpha_v / alpha_u
    /// (negated for Beckmann), and their shapes get vertex-data slots for
    /// the CPU's dp/du: the cube's triangles their uvs, the turned sphere
    /// its axes.
    #[test]
    fn anisotropic_roughness_words_and_frames() {
        let (scene, job) = load("tests/gpu/anisotropic.xml");
        let flat = GpuScene::new(&scene, &job, 1).unwrap();
        let mut seen = Vec::new();
        for (k, b) in scene.bsdfs.iter().enumerate() {
            let distr = match b {
                Bsdf::RoughConductor(c) => c.distr,
                Bsdf::RoughDielectric(d) => d.distr,
                _ => continue,
            };
            let words = &flat.shapes[k * SHAPE_WORDS..(k + 1) * SHAPE_WORDS];
            let ratio = distr.alpha_v / distr.alpha_u;
            let sign = match distr.kind {
                MicrofacetType::Beckmann => -1.0,
                MicrofacetType::Ggx => 1.0,
            };
            assert_eq!(words[1][3], distr.alpha_u);
            assert_eq!(words[2][3], sign * ratio);
            assert!(ratio != 1.0);
            seen.push(distr.kind);
        }
        assert_eq!(seen.len(), 5, "{seen:?}");
        // Every triangle and sphere of an anisotropic shape has a slot:
        // the floor's 2 triangles, the cube's 12, the spheres.
        assert_eq!(count_slotted(&flat, |s| anisotropic(&scene.bsdfs[s])), 16);
    }
}
