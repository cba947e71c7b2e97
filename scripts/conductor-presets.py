#!/usr/bin/env python3
"""Print NAMED_CONDUCTORS (src/scene/parse.rs): the RGB `eta` and `k` that
Mitsuba 3's RGB variants use for each named conductor preset. With `--unlisted`,
print UNLISTED_CONDUCTORS (src/scene/spectrum.rs) instead: the presets Mitsuba reads
from its data folder (`data/ior/NAME.eta.spd`) that its documentation does not list.

Mitsuba turns a preset's measured spectra into RGB when it loads the plugin (and clamps
out-of-gamut colours to 0, with a warning), so the numbers are read back from a loaded
`conductor` with `mi.traverse`, not recomputed.

    DRJIT_LIBLLVM_PATH=/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1 \
        /work/mi/bin/python scripts/conductor-presets.py [--unlisted]
"""
import pathlib
import sys

import mitsuba as mi
import numpy as np

# Mitsuba's `conductor` plugin documentation lists these (src/bsdfs/conductor.cpp).
NAMES = [
    "a-C", "Ag", "Al", "AlAs", "AlSb", "Au", "Be", "Cr", "CsI", "Cu", "Cu2O", "CuO",
    "d-C", "Hg", "HgTe", "Ir", "K", "Li", "MgO", "Mo", "Na_palik", "Nb", "Ni_palik",
    "Rh", "Se", "SiC", "SnTe", "Ta", "Te", "ThF4", "TiC", "TiN", "TiO2", "VC",
    "V_palik", "VN", "W", "none",
]


def rgb(value):
    # `none` holds one number for all channels. str() of a float32 is the shortest
    # decimal that reads back as the same 32-bit float Mitsuba holds.
    channels = [value] * 3 if isinstance(value, float) else list(value)
    return "[" + ", ".join(str(np.float32(c)) for c in channels) + "]"


def main():
    mi.set_variant("scalar_rgb")
    # The clamping warnings (AlAs, AlSb, MgO, SiC, TiO2) would land in the table.
    mi.set_log_level(mi.LogLevel.Error)
    print(f"// Mitsuba {mi.__version__}, variant scalar_rgb: (name, eta, k)")
    names = NAMES
    if sys.argv[1:] == ["--unlisted"]:
        data = pathlib.Path(mi.__file__).parent / "data" / "ior"
        found = sorted(p.name.removesuffix(".eta.spd") for p in data.glob("*.eta.spd"))
        names = [name for name in found if name not in NAMES]
    for name in names:
        params = mi.traverse(mi.load_dict({"type": "conductor", "material": name}))
        print(f'    ("{name}", {rgb(params["eta.value"])}, {rgb(params["k.value"])}),')


if __name__ == "__main__":
    main()
