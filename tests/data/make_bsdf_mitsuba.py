# Reference values from Mitsuba 3 (pip `mitsuba`, variant scalar_rgb; tested
# with 3.9.1) for tests/integration/bsdf_mitsuba.rs. eval() is Mitsuba's
# f * |cos theta_o|. Run: python3 make_bsdf_mitsuba.py > bsdf_mitsuba.txt
# (then put back the header comment that describes the columns).
import mitsuba as mi, math
mi.set_variant('scalar_rgb')

def rgb(v): return {'type': 'rgb', 'value': v}
CONFIGS = [
  ('conductor_au', {'type': 'conductor', 'material': 'Au'}),
  ('conductor_none', {'type': 'conductor'}),
  ('rc_beck_cu', {'type': 'roughconductor', 'material': 'Cu', 'alpha': 0.3}),
  ('rc_ggx_aniso_au', {'type': 'roughconductor', 'material': 'Au', 'distribution': 'ggx', 'alpha_u': 0.1, 'alpha_v': 0.4}),
  ('rc_ggx_none_novis', {'type': 'roughconductor', 'distribution': 'ggx', 'alpha': 0.2, 'sample_visible': False}),
  ('rc_beck_aniso_al_novis', {'type': 'roughconductor', 'material': 'Al', 'alpha_u': 0.05, 'alpha_v': 0.2, 'sample_visible': False, 'specular_reflectance': rgb([0.9, 0.8, 0.7])}),
  ('rd_beck', {'type': 'roughdielectric', 'alpha': 0.3}),
  ('rd_ggx_aniso', {'type': 'roughdielectric', 'distribution': 'ggx', 'alpha_u': 0.2, 'alpha_v': 0.5, 'int_ior': 1.33, 'ext_ior': 1.0}),
  ('rd_ggx_novis', {'type': 'roughdielectric', 'distribution': 'ggx', 'alpha': 0.25, 'sample_visible': False, 'specular_reflectance': rgb([0.9, 0.8, 0.7]), 'specular_transmittance': rgb([0.5, 0.6, 0.7])}),
  ('rd_beck_novis', {'type': 'roughdielectric', 'alpha': 0.15, 'sample_visible': False}),
  ('thin', {'type': 'thindielectric'}),
  ('plastic', {'type': 'plastic', 'diffuse_reflectance': rgb([0.2, 0.5, 0.8])}),
  ('plastic_nl', {'type': 'plastic', 'diffuse_reflectance': rgb([0.6, 0.3, 0.1]), 'specular_reflectance': rgb([0.7, 0.7, 0.7]), 'nonlinear': True, 'int_ior': 1.6}),
  ('twosided_rc', {'type': 'twosided', 'bsdf': {'type': 'roughconductor', 'material': 'Cu', 'distribution': 'ggx', 'alpha': 0.3}}),
  ('twosided_pair', {'type': 'twosided', 'a': {'type': 'diffuse', 'reflectance': rgb([0.3, 0.4, 0.5])}, 'b': {'type': 'roughconductor', 'distribution': 'ggx', 'alpha': 0.2}}),
  ('dielectric', {'type': 'dielectric'}),
  ('roughplastic', {'type': 'roughplastic', 'diffuse_reflectance': rgb([0.2, 0.5, 0.8])}),
  ('roughplastic_ggx_nl', {'type': 'roughplastic', 'distribution': 'ggx', 'alpha': 0.3, 'int_ior': 1.6, 'nonlinear': True, 'diffuse_reflectance': rgb([0.6, 0.3, 0.1]), 'specular_reflectance': rgb([0.7, 0.7, 0.7])}),
  ('roughplastic_novis', {'type': 'roughplastic', 'distribution': 'ggx', 'alpha': 0.2, 'sample_visible': False}),
  ('pplastic', {'type': 'pplastic', 'diffuse_reflectance': rgb([0.2, 0.5, 0.8])}),
  ('pplastic_ggx_aniso', {'type': 'pplastic', 'distribution': 'ggx', 'alpha_u': 0.1, 'alpha_v': 0.35, 'int_ior': 1.6, 'diffuse_reflectance': rgb([0.6, 0.3, 0.1]), 'specular_reflectance': rgb([0.7, 0.7, 0.7])}),
  ('pplastic_novis', {'type': 'pplastic', 'alpha': 0.2, 'sample_visible': False, 'eta': 1.33}),
  ('pthin_default', {'type': 'principledthin'}),
  ('pthin_full', {'type': 'principledthin', 'base_color': rgb([0.7, 0.4, 0.2]), 'roughness': 0.35, 'spec_trans': 0.6, 'diff_trans': 0.8, 'sheen': 0.5, 'sheen_tint': 0.3, 'spec_tint': 0.4, 'flatness': 0.3, 'eta': 1.4}),
  ('pthin_aniso', {'type': 'principledthin', 'base_color': rgb([0.3, 0.6, 0.9]), 'anisotropic': 0.6, 'spec_trans': 1.0, 'roughness': 0.3, 'eta': 1.6, 'specular_reflectance_sampling_rate': 2.0}),
]

def d(th, ph, below=False):
    t, p = math.radians(th), math.radians(ph)
    z = math.cos(t) * (-1 if below else 1)
    return [math.sin(t) * math.cos(p), math.sin(t) * math.sin(p), z]

WI = [d(10, 30), d(45, 200), d(75, 120), d(30, 80, True), d(70, 300, True)]
WO = [d(0.5, 0), d(20, 215), d(50, 20), d(80, 300), d(15, 100, True), d(40, 10, True), d(60, 250, True)]
SAMPLES = [(0.1, (0.3, 0.7)), (0.5, (0.05, 0.2)), (0.7, (0.8, 0.45)), (0.95, (0.6, 0.95)), (0.02, (0.99, 0.01))]

def f(v):
    s = '%.9g' % v
    if 'e' not in s and '.' not in s and 'n' not in s: s += '.0'
    return s
def v3(v): return '%s %s %s' % tuple(f(float(x)) for x in v)

ctx = mi.BSDFContext()
out = []
for name, dct in CONFIGS:
    b = mi.load_dict(dct)
    out.append('# %s' % name)
    for wi in WI:
        si = mi.SurfaceInteraction3f()
        si.wi = mi.Vector3f(wi)
        for wo in WO:
            e = b.eval(ctx, si, mi.Vector3f(wo))
            p = b.pdf(ctx, si, mi.Vector3f(wo))
            out.append('E %s %s %s %s %s' % (name, v3(wi), v3(wo), v3(e), f(float(p))))
        for s1, s2 in SAMPLES:
            bs, w = b.sample(ctx, si, s1, mi.Point2f(s2))
            ok = float(bs.pdf) > 0 and max(float(x) for x in w) > 0
            if ok:
                spec = mi.has_flag(bs.sampled_type, mi.BSDFFlags.Delta)
                out.append('S %s %s %s %s %s %s %s %s %s %s' % (name, v3(wi), f(s1), f(s2[0]), f(s2[1]), v3(bs.wo), v3(w), f(float(bs.pdf)), 'true' if spec else 'false', f(float(bs.eta))))
            else:
                out.append('N %s %s %s %s %s' % (name, v3(wi), f(s1), f(s2[0]), f(s2[1])))
print('\n'.join(out))
