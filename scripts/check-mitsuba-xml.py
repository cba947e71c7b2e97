#!/usr/bin/env python3
"""Renders a Mitsuba 3 XML scene with Mitsuba and with pathmix, and compares them.

Test-only, run by hand (Mitsuba is slow to install and to JIT-compile). Needs a
Python with `mitsuba` and `numpy` (e.g. `python3 -m venv v && v/bin/pip install
mitsuba numpy`), Debian's `libllvm19` and DRJIT_LIBLLVM_PATH pointing at it.

    DRJIT_LIBLLVM_PATH=/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1 \
    v/bin/python scripts/check-mitsuba-xml.py ../shared/mitsuba-scenes/cbox/cbox-rgb.xml \
        --spp 256 --reference-spp 4096

Both renderers get the same file, size (`-D res=...` style parameters are passed
to both with -D) and sample count. A common reference (Mitsuba at
--reference-spp, two halves with their own seeds, so its own noise is known) is
rendered once, or read with --reference. Checks, against the reference:
  * each image's mean within 0.3% (per channel),
  * no 16x16 block of pathmix's image off by more than 5% (mean luminance),
  * pathmix's RMSE explained by noise: within 0.7-1.4x of what pathmix's per-pixel
    standard error (`--variance`: the sample variance under the independent sampler,
    the spread of the 4 replicates under Sobol) and the reference's noise predict.
Reports each renderer's time, paths/s and RMSE. --write-reference FILE stores
the reference (linear RGB EXR) for tests/, and beside it FILE-variance.exr, its
own noise, which --reference reads where present.

--scale F renders both at F times the film's size (Mitsuba through an edited copy
of the file, pathmix with --width/--height). A published scene older than
Mitsuba 3 (../shared/scenes-bitterli/) is given to Mitsuba after the edits it
needs and pathmix does not (`<lookAt>` → `<lookat>`; the film's `banner` and
`highQualityEdges`/`high_quality_edges` removed), from a copy whose relative file
names still resolve against the scene's folder; pathmix reads the file unchanged.
"""

import argparse
import os
import re
import xml.etree.ElementTree as ET
import subprocess
import sys
import tempfile
import time

import numpy as np

import mitsuba as mi

mi.set_variant("llvm_ad_rgb")

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def luminance(img):
    return img @ np.array([0.2126, 0.7152, 0.0722])


def film_size(path):
    """The film's width and height as the file gives them (Mitsuba's defaults otherwise)."""
    root = ET.parse(path).getroot()
    inline_includes(root, os.path.dirname(os.path.abspath(path)))
    film = root.find("./sensor/film")
    size = {"width": 768, "height": 576}
    for e in film.iter("integer") if film is not None else []:
        if e.get("name") in size:
            size[e.get("name")] = int(e.get("value"))
    return size["width"], size["height"]


def inline_includes(element, folder):
    """Each `<include>` under `element` replaced by the included scene's contents,
    so that a copy can edit a sensor an included file holds. File names resolve
    against the scene's folder, as Mitsuba's file resolver does."""
    children = []
    for child in element:
        if child.tag == "include":
            included = ET.parse(os.path.join(folder, child.get("filename"))).getroot()
            inline_includes(included, folder)
            children.extend(included)
        else:
            inline_includes(child, folder)
            children.append(child)
    element[:] = children


def for_mitsuba3(path, size, out_dir):
    """A copy of the scene Mitsuba 3 loads, its includes inlined: the edits it
    needs, the film at `size`."""
    tree = ET.parse(path)
    folder = os.path.dirname(os.path.abspath(path))
    inline_includes(tree.getroot(), folder)
    for e in tree.getroot().iter():
        if e.tag == "lookAt":
            e.tag = "lookat"
        for child in list(e):
            if child.get("name") in ("banner", "highQualityEdges", "high_quality_edges"):
                e.remove(child)
    if size is not None:
        for e in tree.getroot().find("./sensor/film").iter("integer"):
            if e.get("name") in ("width", "height"):
                e.set("value", str(size[e.get("name") == "height"]))
    copy = os.path.join(out_dir, "mitsuba3-" + os.path.basename(path))
    tree.write(copy)
    mi.file_resolver().append(folder)
    return copy


def mitsuba_render(path, params, spp, seed, passes=1):
    """Mean image over `passes` renders of spp/passes samples (bounded memory) and seconds."""
    scene = mi.load_file(path, **params)
    total = np.zeros_like(np.array(mi.render(scene, spp=1, seed=seed + 10_000)), dtype=np.float64)
    start = time.perf_counter()  # after the JIT's warm-up render
    per_pass = spp // passes
    for p in range(passes):
        total += np.array(mi.render(scene, spp=per_pass, seed=seed + p), dtype=np.float64)
    return total / passes, time.perf_counter() - start


def pathmix_render(binary, path, params, spp, seed, out_dir, extra):
    exr = os.path.join(out_dir, "pathmix.exr")
    se = os.path.join(out_dir, "pathmix-se.exr")
    cmd = [binary, "render", path, "--spp", str(spp), "--seed", str(seed), "--exr", exr,
           "--variance", se, "-o", os.path.join(out_dir, "pathmix.png"), "--quiet"]
    for k, v in params.items():
        cmd += ["-D", f"{k}={v}"]
    cmd += extra
    run = subprocess.run(cmd, capture_output=True, text=True)
    if run.returncode != 0:
        sys.exit(f"pathmix failed ({run.returncode}):\n{run.stderr}")
    found = re.search(r"in ([0-9.]+) s: ([0-9.]+) M paths/s", run.stdout + run.stderr)
    seconds = float(found.group(1))
    img = np.array(mi.Bitmap(exr), dtype=np.float64)[..., :3]
    std_error = np.array(mi.Bitmap(se), dtype=np.float64)[..., :3]
    return img, std_error, seconds, run.stderr


def noise_path(reference):
    """Where a stored reference keeps its own noise (the variance its two halves show)."""
    return os.path.splitext(reference)[0] + "-variance.exr"


def blocks(img, size=16):
    h, w = img.shape[:2]
    lum = luminance(img)
    return lum[: h // size * size, : w // size * size].reshape(h // size, size, w // size, size).mean(axis=(1, 3))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scene")
    ap.add_argument("--size", type=int, help="width and height, given as -D res=SIZE (for scenes "
                    "with a $res parameter, such as tests/data/bunny-box.xml)")
    ap.add_argument("--spp", type=int, default=256)
    ap.add_argument("--reference-spp", type=int, default=4096)
    ap.add_argument("--reference", help="an existing reference EXR instead of rendering one")
    ap.add_argument("--write-reference", help="store the rendered reference here")
    ap.add_argument("--scale", type=float, help="render at this fraction of the film's size")
    ap.add_argument("--mean-tolerance", type=float, default=0.003,
                    help="largest relative difference of an image's mean from the reference's")
    ap.add_argument("-D", action="append", default=[], metavar="NAME=VALUE")
    ap.add_argument("--pathmix", default=os.path.join(REPO, "target/release/pathmix"))
    ap.add_argument("--pathmix-arg", action="append", default=[], metavar="ARG",
                    help="one more argument for pathmix's render (repeatable), e.g. "
                    "--pathmix-arg=--sampler --pathmix-arg=sobol")
    args = ap.parse_args()

    params = dict(d.split("=", 1) for d in args.D)
    if args.size is not None:
        params.setdefault("res", str(args.size))
    size = None
    if args.scale is not None:
        size = tuple(max(1, round(side * args.scale)) for side in film_size(args.scene))
        args.pathmix_arg += ["--width", str(size[0]), "--height", str(size[1])]
    with tempfile.TemporaryDirectory() as tmp:
        mitsuba_scene = for_mitsuba3(args.scene, size, tmp)
        if args.reference:
            ref = np.array(mi.Bitmap(args.reference), dtype=np.float64)[..., :3]
            var_path = noise_path(args.reference)
            ref_var = (np.array(mi.Bitmap(var_path), dtype=np.float64)[..., :3]
                       if os.path.exists(var_path) else np.zeros_like(ref))
        else:
            half = args.reference_spp // 2
            passes = max(1, half // 256)
            a, _ = mitsuba_render(mitsuba_scene, params, half, 1_000, passes)
            b, _ = mitsuba_render(mitsuba_scene, params, half, 2_000, passes)
            ref = (a + b) / 2
            ref_var = (a - b) ** 2 / 4
            if args.write_reference:
                mi.Bitmap(ref.astype(np.float32)).write(args.write_reference)
                mi.Bitmap(ref_var.astype(np.float32)).write(noise_path(args.write_reference))
                print(f"wrote {args.write_reference} and {noise_path(args.write_reference)}")
        mts, mts_seconds = mitsuba_render(mitsuba_scene, params, args.spp, 7, max(1, args.spp // 256))
        pm, pm_se, pm_seconds, pm_log = pathmix_render(args.pathmix, args.scene, params, args.spp, 7, tmp,
                                                   args.pathmix_arg)
    if pm_log.strip():
        print(pm_log.strip())

    h, w = ref.shape[:2]
    paths = w * h * args.spp
    rmse = lambda img: float(np.sqrt(np.mean((img - ref) ** 2)))
    print(f"{args.scene}: {w}x{h}, {args.spp} spp, reference {args.reference or f'Mitsuba {args.reference_spp} spp'}")
    print("| renderer | seconds | M paths/s | RMSE |")
    print("|---|--:|--:|--:|")
    print(f"| pathmix | {pm_seconds:.2f} | {paths / pm_seconds / 1e6:.2f} | {rmse(pm):.4g} |")
    print(f"| Mitsuba {mi.__version__} | {mts_seconds:.2f} | {paths / mts_seconds / 1e6:.2f} | {rmse(mts):.4g} |")

    ok = True
    ref_mean = ref.mean(axis=(0, 1))
    for name, img in [("pathmix", pm), ("Mitsuba", mts)]:
        rel = img.mean(axis=(0, 1)) / ref_mean - 1
        good = bool(np.all(np.abs(rel) <= args.mean_tolerance))
        ok &= good
        print(f"{name} mean against the reference: {np.array2string(rel * 100, precision=3)} % "
              f"({'ok' if good else 'FAIL'}: within {args.mean_tolerance * 100:g}%)")
    off = np.abs(blocks(pm) / blocks(ref) - 1)
    good = bool(off.max() <= 0.05)
    ok &= good
    print(f"largest 16x16 block difference: {off.max() * 100:.2f}% ({'ok' if good else 'FAIL'}: within 5%)")
    predicted = float(np.sqrt(np.mean(pm_se ** 2 + ref_var)))
    ratio = rmse(pm) / predicted
    good = 0.7 <= ratio <= 1.4
    ok &= good
    print(f"pathmix RMSE / noise estimate: {ratio:.3f} ({'ok' if good else 'FAIL'}: within 0.7-1.4)")
    sys.exit(0 if ok else 1)


if __name__ == "__main__":
    main()
