#!/usr/bin/env python3
"""Efficiency, 1/(relMSE * seconds), of pathmix's defaults against Mitsuba 3's `path`
integrator with its `independent` and `multijitter` samplers, on one Mitsuba scene,
side by side in one run (issue 48's table).

Run by hand, with nothing else running, as scripts/check-mitsuba-xml.py is (same
Python, same DRJIT_LIBLLVM_PATH):

    v/bin/python scripts/efficiency-vs-mitsuba.py ../shared/mitsuba-scenes/veach/veach-mis.xml \
        --reference veach-ref.exr --spp 64

relMSE = mean((x - r)^2 / (r^2 + 0.01)) over pixels and channels against
--reference (a converged image: e.g. one check-mitsuba-xml.py --write-reference
wrote, or Mitsuba at thousands of spp), so the lights' own pixels do not decide the
figure. Where the reference's own noise is stored beside it (FILE-variance.exr, as
--write-reference writes it), its share is subtracted from every row's relMSE. Both
renderers render at the reference's size: pathmix with --width and --height,
Mitsuba with the film's size edited in a copy, its includes inlined.
Seconds, both warm: pathmix's render time as it reports it (its whole process also
printed) in a second run of the same command, the first having left the kernel in
Mesa's shader cache (which otherwise compiles it within the render, 0.3-1.5 s);
Mitsuba's render after a warm-up render that compiles its kernels. Every run gets the same samples per pixel; each extra --pathmix-run
is another pathmix configuration (its arguments, comma-separated) to compare.
"""

import argparse
import importlib.util
import os
import re
import subprocess
import sys
import tempfile
import time
import xml.etree.ElementTree as ET

import numpy as np

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
spec = importlib.util.spec_from_file_location("check", os.path.join(REPO, "scripts/check-mitsuba-xml.py"))
check = importlib.util.module_from_spec(spec)
spec.loader.exec_module(check)
mi = check.mi


def rel_mse(img, ref):
    return float(np.mean((img - ref) ** 2 / (ref ** 2 + 0.01)))


def with_sampler(path, sampler, out_dir):
    """A copy of Mitsuba's copy of the scene (its includes inlined) with the
    sensor's sampler `sampler`."""
    tree = ET.parse(path)
    sensor = tree.getroot().find("./sensor")
    element = sensor.find("./sampler")
    if element is None:
        element = ET.SubElement(sensor, "sampler")
    element.set("type", sampler)
    copy = os.path.join(out_dir, f"{sampler}-" + os.path.basename(path))
    tree.write(copy)
    return copy


def pathmix(binary, scene, params, spp, seed, size, extra, out_dir):
    exr = os.path.join(out_dir, "pathmix.exr")
    cmd = [binary, "render", scene, "--spp", str(spp), "--seed", str(seed), "--exr", exr,
           "-o", os.path.join(out_dir, "pathmix.png")]
    cmd += ["--width", str(size[0]), "--height", str(size[1])]
    for k, v in params.items():
        cmd += ["-D", f"{k}={v}"]
    # A first run compiles the kernel into Mesa's shader cache, as Mitsuba's
    # warm-up render compiles its own: both renderers are timed warm.
    subprocess.run(cmd + extra, capture_output=True, text=True)
    start = time.perf_counter()
    run = subprocess.run(cmd + extra, capture_output=True, text=True)
    whole = time.perf_counter() - start
    if run.returncode != 0:
        sys.exit(f"pathmix failed ({run.returncode}):\n{run.stderr}")
    seconds = float(re.search(r"in ([0-9.]+) s: ", run.stdout + run.stderr).group(1))
    # The adapter line names the driver's version, which moves pathmix's time
    # (docs/benchmarks.md, Mesa's lavapipe: 22.3 against 25.0).
    notes = [line for line in (run.stdout + run.stderr).splitlines()
             if "warning" in line or line.startswith(("adaptive:", "adapter:"))]
    return np.array(mi.Bitmap(exr), dtype=np.float64)[..., :3], seconds, whole, notes


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scene")
    ap.add_argument("--reference", required=True, help="a converged EXR of the same size")
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("-D", action="append", default=[], metavar="NAME=VALUE",
                    help="a scene parameter, for both renderers")
    ap.add_argument("--pathmix", default=os.path.join(REPO, "target/release/pathmix"))
    ap.add_argument("--pathmix-run", action="append", default=[], metavar="ARGS",
                    help="another pathmix configuration, e.g. --pathmix-run=--sampler,independent")
    args = ap.parse_args()

    ref = np.array(mi.Bitmap(args.reference), dtype=np.float64)[..., :3]
    # The reference's own noise, where stored beside it, is in every row's error:
    # E[(x - r)^2] = E[(x - truth)^2] + Var(r) for x independent of r.
    noise_file = check.noise_path(args.reference)
    reference_noise = 0.0
    if os.path.exists(noise_file):
        ref_var = np.array(mi.Bitmap(noise_file), dtype=np.float64)[..., :3]
        reference_noise = float(np.mean(ref_var / (ref ** 2 + 0.01)))
    size = (ref.shape[1], ref.shape[0])
    params = dict(d.split("=", 1) for d in args.D)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for extra in [""] + args.pathmix_run:
            img, seconds, whole, notes = pathmix(args.pathmix, args.scene, params, args.spp, args.seed, size,
                                                 [a for a in extra.split(",") if a], tmp)
            name = "pathmix " + (extra.replace(",", " ") or "defaults")
            rows.append((name, seconds, rel_mse(img, ref), f"whole process {whole:.2f} s"))
            for note in notes:
                print(f"{name}: {note}")
        base = check.for_mitsuba3(args.scene, size, tmp)
        for sampler in ["independent", "multijitter"]:
            copy = with_sampler(base, sampler, tmp)
            img, seconds = check.mitsuba_render(copy, params, args.spp, args.seed, max(1, args.spp // 256))
            rows.append((f"Mitsuba {mi.__version__} {sampler}", seconds, rel_mse(img, ref), ""))

    h, w = ref.shape[:2]
    print(f"{args.scene}: {w}x{h}, {args.spp} spp, reference {args.reference}")
    if reference_noise:
        print(f"the reference's own noise, {reference_noise:.3e} relMSE ({noise_file}), "
              "is subtracted from every row's")
        rows = [(name, seconds, err - reference_noise, note) for name, seconds, err, note in rows]
    print("| renderer | seconds | M paths/s | relMSE | efficiency | over each Mitsuba row | |")
    print("|---|--:|--:|--:|--:|--:|---|")
    mitsuba = [1 / (err * s) for name, s, err, _ in rows if name.startswith("Mitsuba")]
    for name, seconds, err, note in rows:
        e = 1 / (err * seconds)
        ratios = ", ".join(f"{e / m:.2f}×" for m in mitsuba)
        print(f"| {name} | {seconds:.2f} | {w * h * args.spp / seconds / 1e6:.2f} | {err:.3e} | {e:.3g} "
              f"| {ratios} | {note} |")

if __name__ == "__main__":
    main()
