"""The seed experiment from Python: cosine, light and mixture densities on the
Cornell box, at equal samples and at equal time, and error against time.

    python examples/seed_experiment.py [--size 64] [--spp 64] [--seconds 2]

The reference is a mixture render of `--reference-spp` samples with a seed of
its own. Prints two tables; with matplotlib installed, also plots the relative
RMSE of each density against render time to seed-experiment.png. The `light`
density alone misses indirect light: its error stops falling (bias), which
the plot shows as a floor.
"""

import argparse
import time
from pathlib import Path

import numpy as np

import pathmix

DENSITIES = ["cosine", "light", "mixture"]


def relative_rmse(image, reference):
    return float(np.sqrt(np.mean((image - reference) ** 2)) / reference.mean())


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scene", default=Path(__file__).parents[1] / "scenes" / "cornell.toml")
    parser.add_argument("--size", type=int, default=64, help="image width and height")
    parser.add_argument("--spp", type=int, default=64, help="samples at equal samples")
    parser.add_argument("--seconds", type=float, default=2.0, help="render time at equal time")
    parser.add_argument("--reference-spp", type=int, default=2048)
    parser.add_argument("--plot", default="seed-experiment.png")
    args = parser.parse_args()

    scene = pathmix.load(args.scene)
    size = {"width": args.size, "height": args.size}
    reference = pathmix.render(scene, spp=args.reference_spp, strategy="mixture",
                               seed=0x9E3779B9, **size)

    print(f"equal samples: {args.spp} spp at {args.size}x{args.size}")
    print(f"{'density':>8}  {'seconds':>8}  {'rel. RMSE':>9}")
    for density in DENSITIES:
        started = time.perf_counter()
        image = pathmix.render(scene, spp=args.spp, strategy=density, seed=1, **size)
        seconds = time.perf_counter() - started
        print(f"{density:>8}  {seconds:8.2f}  {relative_rmse(image, reference):9.4f}")

    print(f"\nequal time: {args.seconds:g} s each, error against time")
    print(f"{'density':>8}  {'spp':>6}  {'rel. RMSE':>9}")
    curves = {}
    for density in DENSITIES:
        curve = []
        with pathmix.Session(scene, time=args.seconds, strategy=density, seed=1,
                             **size) as session:
            for step in session.run(every=4):
                curve.append((step.elapsed, relative_rmse(step.image, reference)))
        curves[density] = curve
        print(f"{density:>8}  {step.samples:6d}  {curve[-1][1]:9.4f}")

    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("\n(matplotlib is not installed: no plot)")
        return
    figure, axes = plt.subplots(figsize=(6, 4))
    for density, curve in curves.items():
        seconds, errors = zip(*curve)
        axes.loglog(seconds, errors, marker="o", markersize=3, label=density)
    axes.set_xlabel("render time (s)")
    axes.set_ylabel("relative RMSE")
    axes.set_title(f"Cornell box, {args.size}x{args.size}")
    axes.legend()
    figure.tight_layout()
    figure.savefig(args.plot, dpi=120)
    print(f"\nwrote {args.plot}")


if __name__ == "__main__":
    main()
