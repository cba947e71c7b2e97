"""What rendering a scene again costs: ten renders in one process against ten
times one render's sampling alone (its time from first to last submission).

    python examples/repeat_render.py [--scene scenes/cornell.toml] [--spp 16] [--size 600]

The first render of the process opens the device and compiles the kernel; the
ten after it reuse both (docs/python.md), so their wall time over ten times the
sampling time is the per-call overhead: planning, buffers, readback.
"""

import argparse
import statistics
import time
from pathlib import Path

import pathmix


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scene", default=Path(__file__).parents[1] / "scenes" / "cornell.toml")
    parser.add_argument("--spp", type=int, default=16)
    parser.add_argument("--size", type=int, default=600)
    parser.add_argument("--repeats", type=int, default=10)
    args = parser.parse_args()

    settings = {"spp": args.spp, "width": args.size, "height": args.size, "seed": 1}
    started = time.perf_counter()
    scene = pathmix.load(args.scene)
    pathmix.render(scene, **settings)
    first = time.perf_counter() - started

    sampling = []
    started = time.perf_counter()
    for _ in range(args.repeats):
        reports = []
        pathmix.render(scene, progress=reports.append, **settings)
        sampling.append(reports[-1]["elapsed"])
    repeated = time.perf_counter() - started

    alone = statistics.median(sampling)
    print(f"{args.size}x{args.size}, {args.spp} spp, {Path(args.scene).name}")
    print(f"first render (load, device, kernel compile): {first:.3f} s")
    print(f"one render's sampling alone (median of {args.repeats}): {alone:.3f} s")
    print(f"{args.repeats} renders in one process: {repeated:.3f} s")
    print(f"ratio to {args.repeats} x the sampling alone: {repeated / (args.repeats * alone):.3f}")


if __name__ == "__main__":
    main()
