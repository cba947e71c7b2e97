#!/usr/bin/env python3
"""The table behind pathmix's default settings: efficiency per strategy, light weight
and Russian-roulette depth, on the shipped scenes and Mitsuba's.

For each scene, renders a reference (nee-mis, roulette from 5, 4x the samples, cached in
--out, with its own per-pixel standard error), then every configuration at the scene's samples per pixel, --rounds times, in interleaved order so that
a change in the machine's load falls on all of them alike. The cost of a render is the
CPU time of the whole `pathmix render` process (user + system, both cores), which a
shared machine disturbs less than the wall clock; the error is the relative MSE against
the reference (per-pixel squared error over the squared image mean, averaged over the
RGB channels), less the reference's own, which its standard-error map estimates.
Efficiency is 1 / (relative MSE x CPU seconds), as `converge` reports it, and each row
is also given relative to the current default (mixture 0.5, roulette off). The last
table is the geometric mean of those ratios over the scenes.

Needs a Python with numpy and `mitsuba` (to read EXR), as scripts/check-mitsuba-xml.py.

    python3 scripts/defaults-table.py --out defaults-out
"""

import argparse
import math
import os
import resource
import subprocess
import sys

import mitsuba as mi
import numpy as np

mi.set_variant("scalar_rgb")

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SHARED = os.path.join(REPO, "../shared/mitsuba-scenes")
# Scene and samples per pixel, chosen so that a render takes a second or more of CPU
# (the process's start, about 0.2 s, then matters little).
SCENES = {
    "cornell-boxes": (os.path.join(REPO, "scenes/cornell-boxes.toml"), 1024),
    "cornell": (os.path.join(REPO, "scenes/cornell.toml"), 512),
    "furnace": (os.path.join(REPO, "scenes/furnace.toml"), 1024),
    "sky": (os.path.join(REPO, "scenes/sky.toml"), 256),
    "materials": (os.path.join(REPO, "scenes/materials.toml"), 64),
    "cbox-rgb": (os.path.join(SHARED, "cbox/cbox-rgb.xml"), 64),
    "veach-mis": (os.path.join(SHARED, "veach/veach-mis.xml"), 64),
}
STRATEGIES = [
    ("bsdf", ["--strategy", "bsdf"]),
    ("mixture 0.25", ["--strategy", "mixture", "--light-weight", "0.25"]),
    ("mixture 0.5", ["--strategy", "mixture", "--light-weight", "0.5"]),
    ("mixture 0.75", ["--strategy", "mixture", "--light-weight", "0.75"]),
    ("nee-mis", ["--strategy", "nee-mis"]),
]
ROULETTE = ["off", "3", "5", "8"]
DEFAULT = ("mixture 0.5", "off")


def rgb(path):
    return np.array(mi.Bitmap(path), dtype=np.float64)[..., :3]


def render(binary, scene, args, exr):
    """Renders and returns the process's CPU seconds."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    cmd = [binary, "render", scene, "--exr", exr, "-o", exr[:-4] + ".png", "--quiet", "--max-depth", "50"] + args
    run = subprocess.run(cmd, capture_output=True, text=True)
    if run.returncode != 0:
        sys.exit(f"{' '.join(cmd)} failed:\n{run.stderr}")
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--size", type=int, default=128, help="width and height")
    ap.add_argument("--spp-scale", type=float, default=1.0, help="multiplies each scene's samples per pixel")
    ap.add_argument("--reference-factor", type=int, default=4, help="reference spp over measured spp")
    ap.add_argument("--rounds", type=int, default=2)
    ap.add_argument("--scenes", default=",".join(SCENES), help="comma-separated names of " + ", ".join(SCENES))
    ap.add_argument("--out", default="defaults-out")
    ap.add_argument("--pathmix", default=os.path.join(REPO, "target/release/pathmix"))
    args = ap.parse_args()
    os.makedirs(args.out, exist_ok=True)
    size = ["--width", str(args.size), "--height", str(args.size)]
    configs = [(s, rr, a + ["--rr-depth", rr]) for s, a in STRATEGIES for rr in ROULETTE]
    ratios = {(s, rr): [] for s, rr, _ in configs}

    for name in args.scenes.split(","):
        scene, spp = SCENES[name]
        spp = max(4, int(spp * args.spp_scale))
        ref_spp = spp * args.reference_factor
        ref_exr = os.path.join(args.out, f"{name}-reference-{args.size}-{ref_spp}.exr")
        if not os.path.exists(ref_exr):
            print(f"{name}: reference at {ref_spp} spp", file=sys.stderr)
            render(args.pathmix, scene, size + ["--spp", str(ref_spp), "--strategy", "nee-mis", "--rr-depth",
                                                "5", "--seed", "99", "--variance", ref_exr[:-4] + "-se.exr"], ref_exr)
        reference = rgb(ref_exr)
        reference_mse = (rgb(ref_exr[:-4] + "-se.exr") ** 2).mean()
        mean = reference.mean()
        # Warm Mesa's shader cache, so that no measured run compiles a pipeline.
        for _, _, a in configs:
            render(args.pathmix, scene, size + ["--spp", "4"] + a, os.path.join(args.out, "warm.exr"))
        mse = {(s, rr): [] for s, rr, _ in configs}
        cpu = {(s, rr): [] for s, rr, _ in configs}
        for r in range(args.rounds):
            order = configs if r % 2 == 0 else configs[::-1]
            for s, rr, a in order:
                exr = os.path.join(args.out, "run.exr")
                seconds = render(args.pathmix, scene, size + ["--spp", str(spp), "--seed", str(r + 1)] + a, exr)
                mse[(s, rr)].append((((rgb(exr) - reference) ** 2).mean() - reference_mse) / mean**2)
                cpu[(s, rr)].append(seconds)
        eff = {k: 1.0 / (np.mean(mse[k]) * np.mean(cpu[k])) for k in mse}
        print(f"\n### {name} ({args.size}², {spp} spp, {args.rounds} rounds; reference {ref_spp} spp)\n")
        print("| strategy | roulette | rel. RMSE | CPU s | efficiency | vs default |")
        print("|---|---|--:|--:|--:|--:|")
        for k in mse:
            ratio = eff[k] / eff[DEFAULT]
            ratios[k].append(ratio)
            print(f"| {k[0]} | {k[1]} | {math.sqrt(np.mean(mse[k])):.4f} | {np.mean(cpu[k]):.2f} "
                  f"| {eff[k]:.3g} | {ratio:.2f}× |")
        sys.stdout.flush()

    print("\n### Geometric mean over the scenes, relative to the default\n")
    print("| strategy | " + " | ".join(f"roulette {rr}" for rr in ROULETTE) + " |")
    print("|---|" + "--:|" * len(ROULETTE))
    for s, _ in STRATEGIES:
        cells = [math.exp(np.mean(np.log(ratios[(s, rr)]))) for rr in ROULETTE]
        print(f"| {s} | " + " | ".join(f"{c:.2f}×" for c in cells) + " |")


if __name__ == "__main__":
    main()
