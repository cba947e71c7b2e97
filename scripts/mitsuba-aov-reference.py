#!/usr/bin/env python3
"""Renders the AOVs of a Mitsuba 3 XML scene with Mitsuba's `aov` integrator, as
the reference for pathmix's AOVs (`tests/mitsuba.rs`).

Test-only, run by hand, with the Python of scripts/check-mitsuba-xml.py
(`mitsuba` and `numpy`, DRJIT_LIBLLVM_PATH pointing at Debian's libLLVM):

    DRJIT_LIBLLVM_PATH=/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1 \
    v/bin/python scripts/mitsuba-aov-reference.py tests/data/textured.xml \
        tests/data/textured-aovs-mitsuba-64.exr --spp 4096

The scene's own integrator is replaced by `aov` (AOVs of every type pathmix
computes, each named after its type) around a `path` integrator, and the film's
channels are written as one EXR: R, G, B, A, then `albedo.R`, `depth.T`, ...
`-D name=value` passes the scene's parameters, as `mitsuba -D` does.
"""

import argparse

import mitsuba as mi

mi.set_variant("llvm_ad_rgb")

AOVS = "albedo:albedo,depth:depth,position:position,uv:uv,geo_normal:geo_normal,sh_normal:sh_normal"


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scene")
    parser.add_argument("output")
    parser.add_argument("--spp", type=int, default=4096)
    parser.add_argument("--aovs", default=AOVS, help="Mitsuba's aovs string")
    parser.add_argument("-D", action="append", default=[], metavar="NAME=VALUE")
    args = parser.parse_args()
    params = dict(d.split("=", 1) for d in args.D)
    scene = mi.load_file(args.scene, **params)
    integrator = mi.load_dict({"type": "aov", "aovs": args.aovs, "image": {"type": "path"}})
    sensor = scene.sensors()[0]
    mi.render(scene, integrator=integrator, sensor=sensor, spp=args.spp)
    sensor.film().bitmap(raw=False).write(args.output)
    print(f"wrote {args.output}")


if __name__ == "__main__":
    main()
