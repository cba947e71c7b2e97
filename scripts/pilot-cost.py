#!/usr/bin/env python3
"""What `--strategy auto`'s pilot costs, per scene and seed (the table in docs/benchmarks.md).

Renders each scene at its own size with `--strategy auto --spp 256`, one whole
process per seed, and prints the pilot's choice, its wall time, the run's, and:

- net cost: the pilot's wall time less the time the run saved by starting from the
  chosen candidate's kept samples (at the run's own time per sample), over the time
  of the whole 256-spp render;
- pilot / render: the pilot's wall time over the run's.

Run it on an idle machine (nothing else building or rendering), after a release
build; the first run of a scene also fills Mesa's shader cache, so pass --warm-up.

    python3 scripts/pilot-cost.py --seeds 1 2 3 4 5 --warm-up
"""

import argparse
import os
import re
import subprocess
import sys

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BINARY = os.path.join(REPO, "target/release/pathmix")
SCENES = {
    "cornell-boxes": "scenes/cornell-boxes.toml",
    "cornell": "scenes/cornell.toml",
    "sky": "scenes/sky.toml",
    "teapot": "tests/data/teapot-sky-glossy.xml",
    "veach": "../shared/mitsuba-scenes/veach/veach-mis.xml",
}
SPP = 256


def render(scene, seed, out):
    command = [BINARY, "render", os.path.join(REPO, scene), "--strategy", "auto"]
    command += ["--spp", str(SPP), "--seed", str(seed), "-o", out]
    done = subprocess.run(command, capture_output=True, text=True)
    if done.returncode != 0:
        sys.exit(f"{' '.join(command)} failed:\n{done.stderr}")
    text = done.stderr + done.stdout
    pilot = re.search(r"pilot of \d+ candidates? at \S+, .* ([\d.]+) s in all", text)
    choice = re.search(r"^chose (\S+)", text, re.M)
    run = re.search(r"rendered \S+ at \d+ spp in ([\d.]+) s", text)
    kept = re.search(r"the pilot's (\d+) spp of \S+ are the run's first samples", text)
    if not (pilot and choice and run):
        sys.exit(f"unexpected output of {' '.join(command)}:\n{text}")
    return float(pilot[1]), choice[1], float(run[1]), int(kept[1]) if kept else 0


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--scenes", nargs="+", default=list(SCENES), choices=list(SCENES))
    parser.add_argument("--seeds", nargs="+", type=int, default=[1, 2, 3, 4, 5])
    parser.add_argument("--warm-up", action="store_true", help="one untimed run per scene first")
    parser.add_argument("--out", default="/tmp/pilot-cost.png")
    args = parser.parse_args()
    print(f"{'scene':<14} {'seed':>4} {'choice':<13} {'pilot s':>8} {'run s':>8} "
          f"{'kept':>4} {'net cost':>8} {'pilot/run':>9}")
    for name in args.scenes:
        if args.warm_up:
            render(SCENES[name], args.seeds[0], args.out)
        for seed in args.seeds:
            pilot, choice, run, kept = render(SCENES[name], seed, args.out)
            per_sample = run / (SPP - kept)
            net = (pilot - kept * per_sample) / (SPP * per_sample)
            print(f"{name:<14} {seed:>4} {choice:<13} {pilot:>8.2f} {run:>8.2f} "
                  f"{kept:>4} {net:>7.1%} {pilot / run:>8.1%}", flush=True)


if __name__ == "__main__":
    main()
