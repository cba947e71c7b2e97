#!/usr/bin/env python3
"""Print the RGB that Mitsuba 3's RGB variant `llvm_ad_rgb` uses for the spectra of
the tests in src/scene/spectrum.rs: each spectrum is loaded in a `diffuse` BSDF (a
reflectance), an `area` emitter (an emission) or a `conductor` (its `eta`, an
unbounded spectrum), and its colour read back with `mi.traverse`.

Mitsuba's RGB variants cannot evaluate a `blackbody` plugin, so the black body is
Mitsuba's `blackbody` evaluated in `scalar_spectral` at the 1000 wavelengths over which
Mitsuba integrates, then read by `llvm_ad_rgb` as an emitter's sampled spectrum: the
colour its spectral variants render the black body with, reduced as its RGB variants
reduce every emitted spectrum.

    DRJIT_LIBLLVM_PATH=/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1 \\
        /work/mitsuba-venv/bin/python scripts/spectrum-references.py
"""
import pathlib
import re
import sys
import tempfile

import mitsuba as mi
import numpy as np

CBOX = pathlib.Path("/work/shared/scenes-bitterli/cbox/scene.xml")
# The .spd file of `spd_files_read_as_mitsuba_reads_them`.
SPD = "# a reflectance\n400 0.1\n500 0.5\n\n600 0.9 # the peak\n700 0.3\n"
# Out of sRGB's gamut: negative red and blue.
NARROW_GREEN = "500:0, 520:1, 540:0"
ETA = "400:1.5, 500:0.8, 600:0.3, 700:0.2"


def rgb(value):
    return "[" + ", ".join(str(np.float32(c)) for c in np.array(value).ravel()) + "]"


def load(tag, ty, name, attributes):
    inner = f'<spectrum name="{name}" {attributes}/>'
    params = mi.traverse(mi.load_string(f'<{tag} version="3.0.0" type="{ty}">{inner}</{tag}>'))
    return rgb(params[f"{name}.value"])


def reflectance(attributes):
    return load("bsdf", "diffuse", "reflectance", attributes)


def emission(attributes):
    return load("emitter", "area", "radiance", attributes)


def eta(attributes):
    return load("bsdf", "conductor", "eta", attributes)


def blackbody_samples(temperature):
    mi.set_variant("scalar_spectral")
    plugin = mi.load_dict({"type": "blackbody", "temperature": temperature})
    si = mi.SurfaceInteraction3f()
    pairs = []
    for i in range(1000):
        w = 360.0 + (i / 999.0) * (830.0 - 360.0)
        si.wavelengths = mi.Spectrum(w)
        pairs.append(f"{w!r}:{float(plugin.eval(si)[0])!r}")
    mi.set_variant("llvm_ad_rgb")
    return ", ".join(pairs)


def main():
    mi.set_variant("llvm_ad_rgb")
    # The clamping warnings of out-of-gamut colours would land among the values.
    mi.set_log_level(mi.LogLevel.Error)
    print(f"// Mitsuba {mi.__version__}, variant llvm_ad_rgb")
    text = CBOX.read_text()
    for name in ["white", "red", "green"]:
        value = re.search(rf'id="{name}">\s*<spectrum name="reflectance" value="([^"]*)"', text)[1]
        print(f"cbox {name}:", reflectance(f'value="{value}"'))
    print("cbox light:", emission('value="400:0, 500:8, 600:15.6, 700:18.4"'))
    print("uniform 0.5 reflectance:", reflectance('value="0.5"'))
    print("flat 0.5 reflectance:", reflectance('value="360:0.5, 830:0.5"'))
    print("uniform 2 emission:", emission('value="2"'))
    print("narrow green reflectance:", reflectance(f'value="{NARROW_GREEN}"'))
    print("narrow green emission:", emission(f'value="{NARROW_GREEN}"'))
    print("eta:", eta(f'value="{ETA}"'))
    with tempfile.TemporaryDirectory() as folder:
        spd = pathlib.Path(folder) / "test.spd"
        spd.write_text(SPD)
        print("spd reflectance:", reflectance(f'filename="{spd}"'))
        print("spd emission:", emission(f'filename="{spd}"'))
    for temperature in [2700, 6500]:
        print(f"blackbody {temperature}:", emission(f'value="{blackbody_samples(temperature)}"'))


if __name__ == "__main__":
    sys.exit(main())
