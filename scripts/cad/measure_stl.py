#!/usr/bin/env python3
"""Measures STL meshes: bounding box, volume and centroid (our own reader; no packages).

Used to take the Model O's geometry and masses from the public CAD of the Yale OpenHand
project (grablab/openhand-hardware, CC BY-NC 3.0), which tmo reads but does not ship:

    python3 scripts/cad/measure_stl.py path/to/*.STL

Prints one line per file: name, extents along x, y, z (mm), volume (cm^3) and centroid
(mm). Volume is the mesh's signed tetrahedron sum, so a closed mesh gives its solid volume.
With `--holes` first, it lists the round holes through each (planar, extruded along z)
part instead: centre and radius of each small round boundary loop of its lowest face.
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




def holes(path, axis=2, max_radius=6.0):
    """Round holes through a planar part extruded along `axis`: the boundary loops of its
    lowest face, each fitted with a circle (centre, radius, and the spread of the loop's
    points about that radius). Pivot holes of a link show as small, round loops."""
    tris = list(triangles(path))
    low = min(min(p[axis] for p in t) for t in tris)
    key = lambda p: tuple(round(c, 4) for c in p)
    face = [t for t in tris if all(abs(p[axis] - low) < 1e-3 for p in t)]
    count = {}
    for t in face:
        ks = [key(p) for p in t]
        for a, b in ((ks[0], ks[1]), (ks[1], ks[2]), (ks[2], ks[0])):
            e = (min(a, b), max(a, b))
            count[e] = count.get(e, 0) + 1
    boundary = [e for e, n in count.items() if n == 1]
    adj = {}
    for a, b in boundary:
        adj.setdefault(a, []).append(b)
        adj.setdefault(b, []).append(a)
    seen = set()
    loops = []
    for start in adj:
        if start in seen:
            continue
        stack, loop = [start], []
        while stack:
            v = stack.pop()
            if v in seen:
                continue
            seen.add(v)
            loop.append(v)
            stack.extend(adj[v])
        loops.append(loop)
    out = []
    others = [i for i in range(3) if i != axis]
    for loop in loops:
        if len(loop) < 8:
            continue
        cx = sum(p[others[0]] for p in loop) / len(loop)
        cy = sum(p[others[1]] for p in loop) / len(loop)
        radii = [((p[others[0]] - cx) ** 2 + (p[others[1]] - cy) ** 2) ** 0.5 for p in loop]
        r = sum(radii) / len(radii)
        spread = max(radii) - min(radii)
        if r <= max_radius and spread < 0.1 * r:
            out.append((cx, cy, r, spread))
    return sorted(out)


def main(argv):
    if argv[:1] == ["--holes"]:
        for path in argv[1:]:
            name = path.rsplit("/", 1)[-1]
            for cx, cy, r, spread in holes(path):
                print(f"{name}\thole at ({cx:.2f}, {cy:.2f}) mm, radius {r:.2f} mm (points within {spread:.3f})")
        return
    for path in argv:
        ext, vol, cen = measure(path)
        name = path.rsplit("/", 1)[-1]
        print(
            f"{name}\t{ext[0]:.1f} x {ext[1]:.1f} x {ext[2]:.1f} mm\t{vol:.2f} cm3\t"
            f"centroid ({cen[0]:.1f}, {cen[1]:.1f}, {cen[2]:.1f}) mm"
        )


if __name__ == "__main__":
    main(sys.argv[1:])
