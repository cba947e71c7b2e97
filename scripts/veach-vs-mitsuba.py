#!/usr/bin/env python3
"""Veach's scene at its own 768x512: Mitsuba 3's `path` integrator against pathmix's
`nee-mis` (Sobol), uniform and adaptive, each a whole process, side by side in one run.

For each seed it renders Mitsuba (a child Python process, its JIT included), then
pathmix uniform, then pathmix with --adaptive, all at --spp samples per pixel, and
prints each one's wall time, RMSE, image mean and efficiency 1/(MSE * seconds)
against a common reference: the mean of two pathmix `nee-mis` Sobol renders at
--reference-spp with seeds 98 and 99 (cached in --out), whose own noise (half their
mean squared difference, halved again for their mean) is subtracted from each MSE.

Needs a Python with `mitsuba` and `numpy`, as scripts/check-mitsuba-xml.py does.

    python3 scripts/veach-vs-mitsuba.py --spp 256 --seeds 1,2 --out veach-mitsuba
"""

import argparse
import os
import subprocess
import sys
import time

import mitsuba as mi
import numpy as np

mi.set_variant("llvm_ad_rgb")

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SCENE = os.path.join(REPO, "../shared/mitsuba-scenes/veach/veach-mis.xml")
MITSUBA = """
import sys, mitsuba as mi
mi.set_variant("llvm_ad_rgb")
scene = mi.load_file(sys.argv[1])
image = mi.render(scene, spp=int(sys.argv[2]), seed=int(sys.argv[3]))
mi.Bitmap(image).write(sys.argv[4])
"""


def read_exr(path):
    return np.array(mi.Bitmap(path), dtype=np.float64)[..., :3]


def pathmix(binary, spp, seed, exr, extra):
    cmd = [binary, "render", SCENE, "--spp", str(spp), "--seed", str(seed), "--sampler",
           "sobol", "--strategy", "nee-mis", "--quiet", "--exr", exr,
           "-o", exr.replace(".exr", ".png")]
    return cmd + extra


def timed(cmd):
    start = time.perf_counter()
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
    return time.perf_counter() - start


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--pathmix", default=os.path.join(REPO, "target/release/pathmix"))
    parser.add_argument("--spp", type=int, default=256)
    parser.add_argument("--seeds", default="1,2")
    parser.add_argument("--reference-spp", type=int, default=2048)
    parser.add_argument("--out", default="veach-mitsuba")
    args = parser.parse_args()
    os.makedirs(args.out, exist_ok=True)

    halves = []
    for seed in (98, 99):
        path = os.path.join(args.out, f"reference-{args.reference_spp}-{seed}.exr")
        if not os.path.exists(path):
            timed(pathmix(args.pathmix, args.reference_spp, seed, path, []))
        halves.append(read_exr(path))
    reference = (halves[0] + halves[1]) / 2
    # Each half's noise variance is half their squared difference; their mean's, half that.
    reference_mse = np.mean((halves[0] - halves[1]) ** 2) / 4
    print(f"reference: 2 x {args.reference_spp} spp, its own RMSE {np.sqrt(reference_mse):.4f}")

    script = os.path.join(args.out, "render_mitsuba.py")
    with open(script, "w") as f:
        f.write(MITSUBA)
    for seed in map(int, args.seeds.split(",")):
        runs = []
        exr = os.path.join(args.out, f"mitsuba-{seed}.exr")
        runs.append(("Mitsuba path", [sys.executable, script, SCENE, str(args.spp), str(seed), exr], exr))
        for name, extra in (("pathmix nee-mis", []), ("pathmix nee-mis --adaptive", ["--adaptive"])):
            exr = os.path.join(args.out, f"pathmix-{seed}{'-adaptive' if extra else ''}.exr")
            runs.append((name, pathmix(args.pathmix, args.spp, seed, exr, extra), exr))
        for name, cmd, exr in runs:
            seconds = timed(cmd)
            image = read_exr(exr)
            mse = max(np.mean((image - reference) ** 2) - reference_mse, 1e-30)
            mean = image.mean() / reference.mean() - 1
            print(f"{name:28s} seed {seed}  {args.spp} spp  {seconds:7.2f} s  RMSE {np.sqrt(mse):.4f}  "
                  f"mean {mean:+.5f}  efficiency {1 / (mse * seconds):.2f}", flush=True)


if __name__ == "__main__":
    main()
