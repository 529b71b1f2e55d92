#!/usr/bin/env python3
"""Writes src/color/cie_tables.rs: the CIE 1931 2-degree colour-matching
functions and the CIE D65 illuminant, 360-830 nm every 5 nm (95 samples),
the sampling Mitsuba 3 pre-integrates RGB-mode spectra with.

Sources (public CIE data, read through colour-science's datasets):
- CMFs: CIE 018:2019, 1 nm table, taken every 5 nm;
- D65: CIE 015:2018 relative spectral power, 5 nm; colour-science's copy
  stops at 780 nm, so 785-830 nm are entered below from the CIE table.

Usage: pip install colour-science; python scripts/make_cie_tables.py
"""
import pathlib
import warnings

warnings.filterwarnings("ignore")
import colour  # noqa: E402

WAVELENGTHS = range(360, 831, 5)
D65_785_830 = [63.8434, 64.304, 61.8779, 59.4519, 55.7054, 51.959, 54.6998,
               57.4406, 58.8765, 60.3125]

cmf = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"]
d65 = colour.SDS_ILLUMINANTS["D65"]
d65_values = [float(d65[w]) for w in range(360, 781, 5)] + D65_785_830
assert len(d65_values) == 95


def lit(v):
    """A Rust float literal with the table's 7 significant digits; the
    interpolation noise colour-science leaves where the CIE table has 0
    (z-bar at 650 nm: -1.9e-21) is written as 0."""
    if abs(v) < 1e-15:
        v = 0.0
    s = f"{v:.7g}"
    return s if any(c in s for c in ".e") else s + ".0"


def row(values):
    return "\n".join("    " + ", ".join(lit(v) for v in values[i:i + 5]) + ","
                     for i in range(0, len(values), 5))


out = [
    "//! CIE 1931 2-degree colour-matching functions and the D65 illuminant,",
    "//! 360-830 nm every 5 nm. Written by scripts/make_cie_tables.py from",
    "//! CIE 018:2019 and CIE 015:2018 (public CIE data); do not edit.",
    "",
    "/// First wavelength of the tables, nm.",
    "pub const CIE_MIN: f32 = 360.0;",
    "/// Last wavelength of the tables, nm.",
    "pub const CIE_MAX: f32 = 830.0;",
    "/// Samples per table (5 nm apart).",
    "pub const CIE_SAMPLES: usize = 95;",
    "",
]
for name, idx in (("X", 0), ("Y", 1), ("Z", 2)):
    vals = [float(cmf[w][idx]) for w in WAVELENGTHS]
    out += [f"/// CIE 1931 {name.lower()}-bar.", f"pub const CIE_{name}: [f32; CIE_SAMPLES] = [",
            row(vals), "];", ""]
out += ["/// CIE D65, relative spectral power (100 at 560 nm).",
        "pub const CIE_D65: [f32; CIE_SAMPLES] = [", row(d65_values), "];", ""]
path = pathlib.Path(__file__).resolve().parent.parent / "src/color/cie_tables.rs"
path.parent.mkdir(exist_ok=True)
path.write_text("\n".join(out))
print("wrote", path)
