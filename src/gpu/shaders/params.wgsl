// The render's constants: `Params` in flatten.rs, field for field, in a
// read-only storage buffer (a uniform one made lavapipe recompile the
// kernel every pass: gpu/mod.rs).
struct Params {
    to_world: mat4x4<f32>,
    width: u32,
    height: u32,
    spp_pass: u32,
    sample_base: u32,
    seed_lo: u32,
    seed_hi: u32,
    max_depth: u32,
    rr_depth: u32,
    tan_half_x: f32,
    inv_aspect: f32,
    lens_radius: f32,
    focal_distance: f32,
    near_clip: f32,
    far_clip: f32,
    filter_radius: f32,
    bounded_by_power: u32,
    env: vec4<f32>,
    env_prob: f32,
    node_count: u32,
    env_kind: u32,
    env_visible: u32,
    env_to_world: array<vec4<f32>, 3>,
    env_to_local: array<vec4<f32>, 3>,
    env_width: u32,
    env_bands: u32,
    env_bilinear: u32,
    env_band_scale: f32,
    env_band_offset: f32,
    env_col_offset: f32,
    off_edges: u32,
    off_inv_heights: u32,
    off_rows: u32,
    off_band_cdf: u32,
    off_col_cdf: u32,
    hide_emitters: u32,
    orthographic: u32,
    aperture_blades: u32,
    aperture_rotation: f32,
    off_density: u32,
    beckmann_table: u32,
    group_base: u32,
    unbounded_groups: u32,
    bounded_groups: u32,
    p_unbounded: f32,
    off_block_cdf: u32,
    off_band_sums: u32,
    off_cell_sums: u32,
    env_blocks: u32,
    env_blocks_across: u32,
    env_block_col_shift: u32,
    env_block_band_shift: u32,
    stratified_dims: u32,
    strategy: u32,
    volpath: u32,
    camera_medium: u32,
    media_base: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

// Params::strategy: how light is gathered (path.rs's Strategy).
const STRATEGY_MIS: u32 = 0u;
const STRATEGY_MATS: u32 = 1u;
const STRATEGY_EMS: u32 = 2u;

const ENV_NONE: u32 = 0u;
const ENV_CONSTANT: u32 = 1u;
const ENV_MAP: u32 = 2u;

const NONE: u32 = 0xffffffffu;
const SPHERE: u32 = 0xfffffffeu;
const DISK: u32 = 0xfffffffdu;
const DISK_FLIPPED: u32 = 0xfffffffcu;
const PI: f32 = 3.14159265358979;
const INV_PI: f32 = 0.318309886183791;
const INF: f32 = 3.0e38;

// True for NaN and the infinities.
fn not_finite(x: f32) -> bool {
    return (bitcast<u32>(x) & 0x7f800000u) == 0x7f800000u;
}
