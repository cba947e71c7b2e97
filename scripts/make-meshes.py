#!/usr/bin/env python3
"""Writes the meshes of the shipped example scenes (pathmix's own, procedural):

    scenes/meshes/knot.obj   a (2, 3) torus knot: a tube of radius 0.28 around
                             the knot curve, 192 x 12 quads (4 608 triangles),
                             counter-clockwise seen from outside.

Deterministic: running it again writes the same bytes. Usage:
    python3 scripts/make-meshes.py
"""
import math
import os

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")


def knot_point(t):
    """The (2, 3) torus knot at parameter t in [0, 2 pi)."""
    r = 2.0 + math.cos(3.0 * t)
    return (r * math.cos(2.0 * t), r * math.sin(2.0 * t), -math.sin(3.0 * t))


def sub(a, b):
    return tuple(x - y for x, y in zip(a, b))


def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def normalize(a):
    n = math.sqrt(sum(x * x for x in a))
    return tuple(x / n for x in a)


def knot(segments=192, sides=12, radius=0.28):
    vertices, faces = [], []
    for i in range(segments):
        t = 2.0 * math.pi * i / segments
        p = knot_point(t)
        # A frame along the curve: tangent by central differences, normal toward
        # the curve's second difference, binormal to complete it.
        h = 1e-3
        ahead, behind = knot_point(t + h), knot_point(t - h)
        tangent = normalize(sub(ahead, behind))
        bend = tuple(a + b - 2.0 * c for a, b, c in zip(ahead, behind, p))
        binormal = normalize(cross(tangent, bend))
        normal = cross(binormal, tangent)
        for j in range(sides):
            a = 2.0 * math.pi * j / sides
            offset = tuple(radius * (math.cos(a) * n + math.sin(a) * b) for n, b in zip(normal, binormal))
            vertices.append(tuple(x + o for x, o in zip(p, offset)))
    for i in range(segments):
        for j in range(sides):
            a = i * sides + j
            b = ((i + 1) % segments) * sides + j
            c = ((i + 1) % segments) * sides + (j + 1) % sides
            d = i * sides + (j + 1) % sides
            # Around the tube against the direction of travel: counter-clockwise
            # seen from outside, so face normals point out.
            faces.append((a, d, c, b))
    return vertices, faces


def write_obj(path, vertices, faces, comment):
    with open(path, "w") as f:
        f.write(f"# {comment}\n# Written by scripts/make-meshes.py; do not edit.\n")
        for v in vertices:
            f.write("v {:.6f} {:.6f} {:.6f}\n".format(*v))
        for face in faces:
            f.write("f " + " ".join(str(i + 1) for i in face) + "\n")


def main():
    out = os.path.join(ROOT, "scenes", "meshes")
    os.makedirs(out, exist_ok=True)
    vertices, faces = knot()
    write_obj(os.path.join(out, "knot.obj"), vertices, faces, "(2, 3) torus knot tube, 192 x 12 quads")


if __name__ == "__main__":
    main()
