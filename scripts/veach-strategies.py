#!/usr/bin/env python3
"""Veach's multiple-importance-sampling scene, per strategy and per plate, at equal time.

Renders `../shared/mitsuba-scenes/veach/veach-mis.xml` (read unchanged; pathmix's
--width/--height override its film) with each pathmix strategy for the same time
budget, and Mitsuba 3's `path` integrator for the same budget, and prints each one's
RMSE against a common reference on each of the four plates (alpha 0.005, 0.02, 0.05,
0.1, top to bottom) and on the whole image, with the whole image's efficiency
1/(MSE * seconds). The reference is pathmix's `nee-mis` at --reference-spp (cached in
--out), or --reference FILE.

Needs a Python with `mitsuba` and `numpy`, as scripts/check-mitsuba-xml.py does.

    python3 scripts/veach-strategies.py --seconds 20 --out veach-out
"""

import argparse
import os
import re
import subprocess
import sys
import time

import mitsuba as mi
import numpy as np

mi.set_variant("llvm_ad_rgb")

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SCENE = os.path.join(REPO, "../shared/mitsuba-scenes/veach/veach-mis.xml")
# The plates' rows, as fractions of the image height (Veach's fixed camera).
PLATES = [(0.40, 0.50), (0.52, 0.62), (0.65, 0.76), (0.79, 0.90)]
STRATEGIES = [("bsdf", []), ("light", []), ("mixture", ["--light-weight", "0.5"]), ("nee-mis", [])]


def read_exr(path):
    return np.array(mi.Bitmap(path), dtype=np.float64)[..., :3]


def pathmix(binary, args, exr):
    cmd = [binary, "render", SCENE, "--exr", exr, "-o", exr.replace(".exr", ".png"), "--quiet"] + args
    run = subprocess.run(cmd, capture_output=True, text=True)
    if run.returncode != 0:
        sys.exit(f"pathmix failed:\n{run.stderr}")
    found = re.search(r"at (\d+) spp in ([0-9.]+) s", run.stdout)
    return read_exr(exr), int(found.group(1)), float(found.group(2))


def mitsuba(width, height, seconds):
    """Mitsuba's `path` on the same file, its sensor remade at width x height."""
    scene = mi.load_file(SCENE)
    sensor = mi.load_dict({
        "type": "perspective",
        "fov": 28,
        "fov_axis": "smaller",
        "to_world": mi.ScalarTransform4f().look_at(origin=[0, 2, 15], target=[0, -2, 2.5], up=[0, 1, 0]),
        "film": {"type": "hdrfilm", "width": width, "height": height, "rfilter": {"type": "gaussian"}},
        "sampler": {"type": "independent"},
    })
    mi.render(scene, sensor=sensor, spp=1)  # the JIT's warm-up
    total, spp, start = None, 0, time.perf_counter()
    while time.perf_counter() - start < seconds:
        img = np.array(mi.render(scene, sensor=sensor, spp=16, seed=spp), dtype=np.float64)[..., :3]
        total = img * 16 if total is None else total + img * 16
        spp += 16
    return total / spp, spp, time.perf_counter() - start


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--width", type=int, default=384)
    ap.add_argument("--height", type=int, default=256)
    ap.add_argument("--seconds", type=float, default=20.0)
    ap.add_argument("--reference-spp", type=int, default=4096)
    ap.add_argument("--reference")
    ap.add_argument("--out", default="veach-out")
    ap.add_argument("--pathmix", default=os.path.join(REPO, "target/release/pathmix"))
    args = ap.parse_args()
    os.makedirs(args.out, exist_ok=True)
    size = ["--width", str(args.width), "--height", str(args.height)]

    ref_path = args.reference or os.path.join(args.out, f"reference-{args.reference_spp}.exr")
    if not os.path.exists(ref_path):
        pathmix(args.pathmix, size + ["--spp", str(args.reference_spp), "--seed", "99"], ref_path)
    ref = read_exr(ref_path)
    h = ref.shape[0]
    rows = [(int(a * h), int(b * h)) for a, b in PLATES]

    results = []
    for name, extra in STRATEGIES:
        exr = os.path.join(args.out, f"{name}.exr")
        img, spp, seconds = pathmix(args.pathmix, size + ["--strategy", name, "--time", f"{args.seconds}s"] + extra, exr)
        results.append((f"pathmix {name}", img, spp, seconds))
    results.append(("Mitsuba path", *mitsuba(args.width, args.height, args.seconds)))

    print(f"Veach's scene at {args.width}x{args.height}, about {args.seconds:g} s each; "
          f"RMSE against {ref_path}")
    print("| renderer, strategy | spp | s | plate 1 (α 0.005) | plate 2 (0.02) | plate 3 (0.05) | plate 4 (0.1) | image | 1/(MSE·s) |")
    print("|---|--:|--:|--:|--:|--:|--:|--:|--:|")
    for name, img, spp, seconds in results:
        per_plate = [np.sqrt(np.mean((img[a:b] - ref[a:b]) ** 2)) for a, b in rows]
        mse = np.mean((img - ref) ** 2)
        plates = " | ".join(f"{e:.4f}" for e in per_plate)
        print(f"| {name} | {spp} | {seconds:.1f} | {plates} | {np.sqrt(mse):.4f} | {1 / (mse * seconds):.3g} |")


if __name__ == "__main__":
    main()
