#!/usr/bin/env python3
"""Converts trials of the proactive-slip-control dataset (imanlab, MIT licence; two Xela uSkin
4x4 sensors, 16 taxels x (x, y, z) raw counts at about 60 Hz, per-frame slip labels from a
wrist-camera ArUco marker) into tmo's interchange CSV (docs/formats.md, "Interchange CSV").

    scripts/xela_to_interchange.py DATA_DIR... --out trials.csv [--split train|test ...]

Each DATA_DIR is one `data_sample_<date>` folder holding xela_sensor1.csv, xela_sensor2.csv,
slip_label.csv and robot_state.csv (its `time` column is each row's time, s). Row k of every
file is frame k. Only the standard library is used.
"""
import argparse
import csv
import os
import sys


def read_rows(path):
    with open(path, newline="") as f:
        r = csv.reader(f)
        header = next(r)
        return header, [row for row in r if row]


def counts(text):
    """Raw counts are whole numbers; the source writes them as floats (16080.0)."""
    v = float(text)
    return str(int(v)) if v.is_integer() else text


def convert(folder, split, out, with_z):
    name = os.path.basename(os.path.normpath(folder)).replace("data_sample_", "")
    _, labels = read_rows(os.path.join(folder, "slip_label.csv"))
    header, robot = read_rows(os.path.join(folder, "robot_state.csv"))
    times = [float(r[header.index("time")]) for r in robot]
    sensors = []
    for s in (1, 2):
        h, rows = read_rows(os.path.join(folder, f"xela_sensor{s}.csv"))
        taxels = len(h) // 3
        if len(h) != 3 * taxels or h[0] != "txl1_x":
            sys.exit(f"{folder}/xela_sensor{s}.csv: expected txl<N>_x, _y, _z columns")
        sensors.append((s, taxels, rows))
    frames = min([len(labels), len(times)] + [len(rows) for _, _, rows in sensors])
    written = 0
    for k in range(frames):
        slip = 1 if float(labels[k][0]) > 0.5 else 0
        for s, taxels, rows in sensors:
            row = rows[k]
            for e in range(taxels):
                x, y, z = (counts(v) for v in row[3 * e : 3 * e + 3])
                line = [name, f"xela{s}", k, f"{times[k]:.4f}", e, x, y]
                line += [z, slip] if with_z else [slip]
                if split:
                    line.append(split)
                out.writerow(line)
                written += 1
    return name, frames, written


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("folders", nargs="+")
    p.add_argument("--out", required=True)
    p.add_argument("--split", nargs="*", help="one split name per folder (e.g. train test)")
    p.add_argument("--no-z", action="store_true", help="leave out the taxels' z (normal) counts")
    a = p.parse_args()
    if a.split and len(a.split) != len(a.folders):
        sys.exit(f"--split gives {len(a.split)} names for {len(a.folders)} folders")
    with open(a.out, "w", newline="") as f:
        out = csv.writer(f, lineterminator="\n")
        cols = ["trial", "sensor", "frame", "t_s", "element", "x", "y"]
        cols += ["slip"] if a.no_z else ["z", "slip"]
        out.writerow(cols + (["split"] if a.split else []))
        for i, folder in enumerate(a.folders):
            name, frames, rows = convert(folder, a.split[i] if a.split else None, out, not a.no_z)
            print(f"{name}: {frames} frames, {rows} rows", file=sys.stderr)
    print(f"wrote {a.out}", file=sys.stderr)


if __name__ == "__main__":
    main()
