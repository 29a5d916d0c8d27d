#!/usr/bin/env python3
"""Measures STL meshes: bounding box, volume and centroid (our own reader; no packages).

Used to take the Model O's geometry and masses from the public CAD of the Yale OpenHand
project (grablab/openhand-hardware, CC BY-NC 3.0), which tmo reads but does not ship:

    python3 scripts/cad/measure_stl.py path/to/*.STL

Prints one line per file: name, extents along x, y, z (mm), volume (cm^3) and centroid
(mm). Volume is the mesh's signed tetrahedron sum, so a closed mesh gives its solid volume.
"""
import struct
import sys


def triangles(path):
    data = open(path, "rb").read()
    if len(data) >= 84:
        count = struct.unpack_from("<I", data, 80)[0]
        if 84 + 50 * count == len(data):
            for k in range(count):
                v = struct.unpack_from("<12f", data, 84 + 50 * k)
                yield v[3:6], v[6:9], v[9:12]
            return
    # ASCII STL
    verts = []
    for line in data.decode("latin-1").splitlines():
        parts = line.split()
        if parts[:1] == ["vertex"]:
            verts.append(tuple(float(x) for x in parts[1:4]))
            if len(verts) == 3:
                yield tuple(verts)
                verts = []


def measure(path):
    lo = [float("inf")] * 3
    hi = [float("-inf")] * 3
    volume = 0.0
    moment = [0.0, 0.0, 0.0]
    for a, b, c in triangles(path):
        for p in (a, b, c):
            for i in range(3):
                lo[i] = min(lo[i], p[i])
                hi[i] = max(hi[i], p[i])
        # signed volume of the tetrahedron (origin, a, b, c)
        v = (
            a[0] * (b[1] * c[2] - b[2] * c[1])
            - a[1] * (b[0] * c[2] - b[2] * c[0])
            + a[2] * (b[0] * c[1] - b[1] * c[0])
        ) / 6.0
        volume += v
        for i in range(3):
            moment[i] += v * (a[i] + b[i] + c[i]) / 4.0
    centroid = [m / volume if volume else 0.0 for m in moment]
    return [h - l for l, h in zip(lo, hi)], volume / 1000.0, centroid


if __name__ == "__main__":
    for path in sys.argv[1:]:
        ext, vol, cen = measure(path)
        name = path.rsplit("/", 1)[-1]
        print(
            f"{name}\t{ext[0]:.1f} x {ext[1]:.1f} x {ext[2]:.1f} mm\t{vol:.2f} cm3\t"
            f"centroid ({cen[0]:.1f}, {cen[1]:.1f}, {cen[2]:.1f}) mm"
        )
