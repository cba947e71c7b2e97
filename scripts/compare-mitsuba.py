#!/usr/bin/env python3
"""Side-by-side speed and error: pathmix against Mitsuba 3's CPU backend.

Renders the same scene (default scenes/cornell-boxes.toml) at the same size and
samples with both renderers (box pixel filter, same maximum depth), measures each
one's RMSE against a common high-sample pathmix reference, and prints seconds,
paths/s, RMSE and the efficiency 1 / (MSE x seconds) of both, with their ratio.

Run by hand, not in CI:

    python3 scripts/compare-mitsuba.py [--scene scenes/cornell-boxes.toml]
        [--size 256] [--spp 256] [--reference-spp 4096] [--reference-renderer pathmix|mitsuba]
        [--pathmix mixture/sobol,mixture/independent,nee-mis/sobol/5]
        [--mitsuba-samplers independent,multijitter] [--max-depth 50]
        [--without-avx512]
    python3 scripts/compare-mitsuba.py --scene S.toml --size 64 --reference-spp 65536 \
        --mitsuba-reference-only out.exr

Scenes may hold quads, boxes, spheres and meshes (OBJ and PLY files, with their
scale, rotate_y / rotate and translate; Mitsuba computes smooth normals where the
file has none, as pathmix does), and a background colour (`render.background`, as
Mitsuba's `constant` emitter). With `--reference-renderer mitsuba` the common
reference is Mitsuba's `path` integrator (independent sampler) at
`--reference-spp`, and the script also prints each image's mean against the
reference's and its worst 16x16 block. The reference is kept in `--out` under a name
made of the scene file's name, the depth, the renderer, the size and the samples, and
reused by later runs that match. `--mitsuba-reference-only OUT` only writes
that Mitsuba render (the test fixture `tests/fixtures/mitsuba-cbox-bunny-64.exr`
was made so).

`--pathmix` lists pathmix runs as strategy/sampler, with an optional third part,
the Russian roulette depth (default off); `--mitsuba-samplers` lists
Mitsuba samplers (`independent` is Mitsuba's default; `multijitter`,
`stratified`, `ldsampler` and `orthogonal` stratify). The reference is pathmix
with the Sobol sampler.

It creates a virtual environment in .venv-mitsuba with `mitsuba` and `numpy` from
PyPI and re-runs itself there. Mitsuba's LLVM backend needs LLVM 19 (LLVM 15
crashes it): `sudo apt-get install libllvm19` on Debian 12.

`--without-avx512` has both renderers compile their kernels for AVX2 without
AVX-512, as on AMD's Zen 2 and Zen 3 and on Intel's desktop CPUs: pathmix's
lavapipe through Mesa's `GALLIUM_OVERRIDE_CPU_CAPS=avx`, Mitsuba's Dr.Jit through
its `jit_llvm_set_target` (a Zen 3 target, 8 lanes). On a CPU with AVX-512 this
measures, on one machine, what a CPU without it would show.

Mitsuba's `max_depth` counts path vertices including the camera's first hit, so
pathmix's max_depth D (scattering events) is Mitsuba's D + 1. Mitsuba's path
integrator does next-event estimation with MIS and Russian roulette from depth 5
(its defaults): a different, also unbiased, estimator of the same image.
"""

import argparse
import math
import os
import re
import subprocess
import sys
import time
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
VENV = ROOT / ".venv-mitsuba"
LIBLLVM = "/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1"


def ensure_environment():
    """Re-runs this script inside a venv that has mitsuba and numpy."""
    if os.environ.get("PATHMIX_COMPARE_VENV") == "1":
        return
    python = VENV / "bin" / "python"
    if not python.exists():
        print(f"creating {VENV} with mitsuba and numpy", file=sys.stderr)
        subprocess.check_call([sys.executable, "-m", "venv", str(VENV)])
        subprocess.check_call([str(python), "-m", "pip", "install", "-q", "mitsuba", "numpy"])
    if not Path(LIBLLVM).exists():
        sys.exit(f"{LIBLLVM} not found: install LLVM 19 (sudo apt-get install libllvm19)")
    env = dict(os.environ, PATHMIX_COMPARE_VENV="1", DRJIT_LIBLLVM_PATH=LIBLLVM)
    os.execve(str(python), [str(python), *sys.argv], env)


def rotate_y(p, degrees):
    """The book's rotate_y, object to world (as pathmix's scene parser)."""
    t = math.radians(degrees)
    c, s = math.cos(t), math.sin(t)
    return [c * p[0] + s * p[2], p[1], -s * p[0] + c * p[2]]


def add(a, b):
    return [x + y for x, y in zip(a, b)]


def cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def box_quads(lo, hi):
    """Six outward quads (q, u, v), as the book's box() and pathmix's parser."""
    dx, dy, dz = [hi[0] - lo[0], 0, 0], [0, hi[1] - lo[1], 0], [0, 0, hi[2] - lo[2]]
    neg = lambda v: [-x for x in v]
    return [
        ([lo[0], lo[1], hi[2]], dx, dy),
        ([hi[0], lo[1], hi[2]], neg(dz), dy),
        ([hi[0], lo[1], lo[2]], neg(dx), dy),
        ([lo[0], lo[1], lo[2]], dz, dy),
        ([lo[0], hi[1], hi[2]], dx, neg(dz)),
        ([lo[0], lo[1], lo[2]], dx, dz),
    ]


def object_transform(mi, obj):
    """An object's scale, rotation and translation (in that order) as pathmix applies them."""
    T = mi.ScalarTransform4f
    if "matrix" in obj:
        m = obj["matrix"]
        return T([m[0:4], m[4:8], m[8:12], m[12:16]])
    scale = obj.get("scale", 1.0)
    scale = [scale] * 3 if isinstance(scale, (int, float)) else scale
    if "rotate" in obj:
        axis, angle = obj["rotate"]["axis"], obj["rotate"]["angle"]
    else:
        axis, angle = [0, 1, 0], obj.get("rotate_y", 0.0)
    return T().translate(obj.get("translate", [0, 0, 0])) @ T().rotate(axis, angle) @ T().scale(scale)


def mitsuba_scene(mi, scene, size, spp, max_depth, sampler, scene_dir=Path(".")):
    """The pathmix scene file as a Mitsuba scene dictionary."""
    T = mi.ScalarTransform4f
    materials = {}
    for name, m in scene.get("materials", {}).items():
        kind = m["type"]
        if kind == "lambertian":
            materials[name] = ({"type": "diffuse", "reflectance": {"type": "rgb", "value": m["albedo"]}}, m.get("emit"))
        elif kind == "light":
            materials[name] = ({"type": "diffuse", "reflectance": {"type": "rgb", "value": [0, 0, 0]}}, m["emit"])
        elif kind == "dielectric":
            materials[name] = ({"type": "dielectric", "int_ior": m["ior"], "ext_ior": 1.0}, None)
        else:
            sys.exit(f"material type {kind} has no Mitsuba equivalent in this script")

    shapes = {}

    def quad(q, u, v, material):
        bsdf, emit = materials[material]
        n = cross(u, v)
        length = math.sqrt(sum(x * x for x in n))
        n = [x / length for x in n]
        centre = add(q, [0.5 * (a + b) for a, b in zip(u, v)])
        # The rectangle [-1, 1]^2 x {0} with normal +z, onto q + a u + b v.
        matrix = [
            [u[0] / 2, v[0] / 2, n[0], centre[0]],
            [u[1] / 2, v[1] / 2, n[1], centre[1]],
            [u[2] / 2, v[2] / 2, n[2], centre[2]],
            [0, 0, 0, 1],
        ]
        shape = {"type": "rectangle", "to_world": T(matrix), "bsdf": bsdf}
        if emit and max(emit) > 0:
            shape["emitter"] = {"type": "area", "radiance": {"type": "rgb", "value": emit}}
        shapes[f"shape{len(shapes)}"] = shape

    for obj in scene.get("objects", []):
        angle, offset = obj.get("rotate_y", 0.0), obj.get("translate", [0, 0, 0])
        place = lambda p: add(rotate_y(p, angle), offset)
        turn = lambda v: rotate_y(v, angle)
        if obj["type"] == "quad":
            quad(place(obj["q"]), turn(obj["u"]), turn(obj["v"]), obj["material"])
        elif obj["type"] == "box":
            for q, u, v in box_quads(obj["min"], obj["max"]):
                quad(place(q), turn(u), turn(v), obj["material"])
        elif obj["type"] == "mesh":
            bsdf, emit = materials[obj["material"]]
            path = (scene_dir / obj["file"]).resolve()
            shape = {"type": path.suffix.lstrip(".").lower(), "filename": str(path),
                     "to_world": object_transform(mi, obj), "bsdf": bsdf,
                     "face_normals": not obj.get("smooth", True)}
            if emit and max(emit) > 0:
                shape["emitter"] = {"type": "area", "radiance": {"type": "rgb", "value": emit}}
            shapes[f"shape{len(shapes)}"] = shape
        elif obj["type"] == "sphere":
            bsdf, emit = materials[obj["material"]]
            shape = {"type": "sphere", "center": place(obj["center"]), "radius": obj["radius"], "bsdf": bsdf}
            if emit and max(emit) > 0:
                shape["emitter"] = {"type": "area", "radiance": {"type": "rgb", "value": emit}}
            shapes[f"shape{len(shapes)}"] = shape

    # pathmix's background is the radiance of rays that leave the scene: Mitsuba's
    # constant emitter (which its path integrator also samples by NEE).
    background = scene.get("render", {}).get("background", [0, 0, 0])
    if max(background) > 0:
        shapes["background"] = {"type": "constant", "radiance": {"type": "rgb", "value": background}}

    camera = scene["camera"]
    return {
        "type": "scene",
        "integrator": {"type": "path", "max_depth": max_depth + 1},
        "sensor": {
            "type": "perspective",
            "fov_axis": "y",
            "fov": camera.get("vfov", 40),
            # look_at gives the same right-handed view as the book's camera.
            "to_world": T().look_at(
                origin=camera["lookfrom"], target=camera["lookat"], up=camera.get("vup", [0, 1, 0])
            ),
            "sampler": {"type": sampler, "sample_count": spp},
            "film": {
                "type": "hdrfilm",
                "width": size,
                "height": size,
                "pixel_format": "rgb",
                "rfilter": {"type": "box"},
            },
        },
        **shapes,
    }


def without_avx512(mi):
    """Has Dr.Jit compile Mitsuba's kernels for Zen 3 (AVX2, 8 lanes) from now on,
    through drjit-core's `jit_llvm_set_target(cpu, features, vector_width)`."""
    import ctypes
    import drjit
    core = ctypes.CDLL(str(Path(drjit.__file__).parent / "libdrjit-core.so"))
    set_target = core._Z19jit_llvm_set_targetPKcS0_j
    set_target.argtypes = [ctypes.c_char_p, ctypes.c_char_p, ctypes.c_uint32]
    set_target(b"znver3", b"+avx2,+fma,+f16c,+bmi2,+popcnt,-avx512f", 8)
    width = core._Z21jit_llvm_vector_widthv
    width.restype = ctypes.c_uint32
    assert width() == 8, "Dr.Jit kept its vector width"


def pathmix(args, spp, out, seed, strategy="mixture", sampler="sobol", rr_depth="off"):
    """Renders with the release binary; returns the seconds it reports, or with
    `--whole-process` the wall-clock seconds of the whole command."""
    cmd = [
        str(ROOT / "target" / "release" / "pathmix"), "render", str(args.scene),
        "--width", str(args.size), "--height", str(args.size), "--spp", str(spp),
        "--max-depth", str(args.max_depth), "--seed", str(seed), "--quiet",
        "--strategy", strategy, "--sampler", sampler, "--rr-depth", rr_depth,
        "-o", str(out.with_suffix(".png")), "--exr", str(out),
    ]
    started = time.perf_counter()
    result = subprocess.run(cmd, capture_output=True, text=True, check=True)
    if args.whole_process:
        return time.perf_counter() - started
    return float(re.search(r"in ([0-9.]+) s", result.stdout).group(1))


def main():
    ensure_environment()
    import mitsuba as mi
    import numpy as np

    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--scene", type=Path, default=ROOT / "scenes" / "cornell-boxes.toml")
    parser.add_argument("--size", type=int, default=256)
    parser.add_argument("--spp", type=int, default=256)
    parser.add_argument("--max-depth", type=int, default=50)
    parser.add_argument("--reference-spp", type=int, default=4096)
    parser.add_argument("--out", type=Path, default=ROOT / "compare-out")
    parser.add_argument("--pathmix", default="mixture/sobol,mixture/independent,nee-mis/sobol/5",
                        help="pathmix runs, comma-separated strategy/sampler[/roulette depth]")
    parser.add_argument("--mitsuba-samplers", default="independent,multijitter",
                        help="Mitsuba samplers, comma-separated")
    parser.add_argument("--reference-renderer", choices=["pathmix", "mitsuba"], default="pathmix")
    parser.add_argument("--whole-process", action="store_true",
                        help="time each render from start to end: pathmix's whole command (no warm-up run), "
                             "Mitsuba's scene loading, kernel compilation and render")
    parser.add_argument("--mitsuba-reference-only", type=Path, metavar="OUT",
                        help="only render Mitsuba's reference into OUT (EXR)")
    parser.add_argument("--without-avx512", action="store_true",
                        help="both renderers compile for AVX2 without AVX-512 (as on AMD Zen 2 and 3)")
    args = parser.parse_args()
    args.out.mkdir(exist_ok=True)

    mi.set_variant("llvm_ad_rgb")
    if args.without_avx512:
        # Inherited by every pathmix child process: Mesa's llvmpipe drops AVX-512.
        os.environ["GALLIUM_OVERRIDE_CPU_CAPS"] = "avx"
        without_avx512(mi)
    scene = tomllib.loads(args.scene.read_text())

    def mitsuba_render(spp, sampler, seed):
        description = mitsuba_scene(mi, scene, args.size, spp, args.max_depth, sampler,
                                    args.scene.resolve().parent)
        return mi.render(mi.load_dict(description), spp=spp, seed=seed)

    if args.mitsuba_reference_only:
        mi.Bitmap(mitsuba_render(args.reference_spp, "independent", 12345)).write(
            str(args.mitsuba_reference_only))
        return
    subprocess.run(["cargo", "build", "--release", "--quiet"], cwd=ROOT, check=True)

    # Kept and reused: named by everything that makes the image.
    reference_path = args.out / (f"reference-{args.scene.stem}-depth{args.max_depth}-"
                                 f"{args.reference_renderer}-{args.size}-{args.reference_spp}.exr")
    if not reference_path.exists():
        print(f"rendering the reference with {args.reference_renderer} ({args.reference_spp} spp)...",
              file=sys.stderr)
        if args.reference_renderer == "pathmix":
            pathmix(args, args.reference_spp, reference_path, seed=12345)
        else:
            mi.Bitmap(mitsuba_render(args.reference_spp, "independent", 12345)).write(str(reference_path))
    reference = np.array(mi.Bitmap(str(reference_path)), dtype=np.float64)[..., :3]

    paths = args.size * args.size * args.spp
    rows = []

    # pathmix: the reported time excludes start-up; warm the pipeline cache first.
    for variant in args.pathmix.split(","):
        strategy, sampler, rr_depth = (variant.split("/") + ["off"])[:3]
        out = args.out / f"pathmix-{strategy}-{sampler}-rr{rr_depth}.exr"
        if not args.whole_process:
            pathmix(args, 1, args.out / "pathmix-warm.exr", 1, strategy, sampler, rr_depth)
        seconds = pathmix(args, args.spp, out, 1, strategy, sampler, rr_depth)
        image = np.array(mi.Bitmap(str(out)), dtype=np.float64)[..., :3]
        roulette = "" if rr_depth == "off" else f", roulette from {rr_depth}"
        rows.append((f"pathmix ({strategy}, {sampler}{roulette})", seconds, image))
    ours = len(rows)

    # Mitsuba: the first render JIT-compiles its kernels; time a second one.
    for sampler in args.mitsuba_samplers.split(","):
        description = mitsuba_scene(mi, scene, args.size, args.spp, args.max_depth, sampler,
                                    args.scene.resolve().parent)
        if args.whole_process:
            started = time.perf_counter()
            mitsuba = mi.load_dict(description)
        else:
            mitsuba = mi.load_dict(description)
            mi.render(mitsuba, spp=1, seed=0)
            started = time.perf_counter()
        result = mi.render(mitsuba, spp=args.spp, seed=1)
        image = np.array(result, dtype=np.float64)[..., :3]
        rows.append((f"Mitsuba 3 llvm_ad_rgb (path, NEE+MIS, {sampler})",
                     time.perf_counter() - started, image))
        mi.Bitmap(result).write(str(args.out / f"mitsuba-{sampler}.exr"))

    print(f"\n{args.scene.name}, {args.size}x{args.size}, {args.spp} spp, max depth {args.max_depth}; "
          f"reference: {args.reference_renderer} {args.reference_spp} spp\n")
    print("| renderer | seconds | M paths/s | RMSE | efficiency 1/(MSE s) |")
    print("|---|---|---|---|---|")
    efficiencies = []
    for name, seconds, image in rows:
        mse = float(np.mean((image - reference) ** 2))
        efficiency = 1.0 / (mse * seconds)
        efficiencies.append(efficiency)
        print(f"| {name} | {seconds:.2f} | {paths / seconds / 1e6:.2f} | {math.sqrt(mse):.4f} | {efficiency:.0f} |")
    print("\nefficiency ratio pathmix / Mitsuba (rows: pathmix runs; columns: Mitsuba samplers):")
    for i in range(ours):
        ratios = [efficiencies[i] / efficiencies[j] for j in range(ours, len(rows))]
        print(f"  {rows[i][0]}: " + ", ".join(f"{r:.2f}x" for r in ratios))
    blocks = lambda image: image.reshape(args.size // 16, 16, args.size // 16, 16, 3).mean(axis=(1, 3, 4))
    for name, _, image in rows:
        mean_ratio = float(np.mean(image)) / float(np.mean(reference))
        worst = float(np.max(np.abs(blocks(image) / blocks(reference) - 1.0)))
        print(f"{name}: mean / reference mean {mean_ratio:.4f}, worst 16x16 block off by {100 * worst:.2f}%")
    mitsuba = rows[ours][2]
    mirrored = math.sqrt(float(np.mean((mitsuba[:, ::-1] - reference) ** 2)))
    print(f"RMSE of Mitsuba's image mirrored: {mirrored:.4f} (the scenes match when the mean "
          "ratios are 1 and this is much larger than the RMSE)")


if __name__ == "__main__":
    main()
