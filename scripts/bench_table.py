#!/usr/bin/env python3
"""The summary of scripts/bench-grooves (issue 5's run time against error) from its results.csv:
the time ratio at geometry@64's error for each scene, as bench-grooves prints it, and the markdown
table that docs/grooves.md shows for a run ("Results"): per scene, geometry at 16 and 64 spp, the
groove renderer at each spp, the bare plate's time and the ratio, each cell "seconds, mean dE,
% of pixels >= 10".

Usage: scripts/bench_table.py RESULTS.CSV   (prints the table; bench-grooves also writes it as
results.md beside the CSV)"""

import csv
import sys

# The issue's target: the groove renderer at geometry@64's error in at most 1/20 of its time.
TARGET = 20.0
COLUMNS = ("scene", "method", "spp", "seconds", "mean_de", "pct_ge_10")


class Row:
    def __init__(self, scene, method, spp, seconds, mean_de, pct):
        self.scene, self.method, self.spp = scene, method, spp
        self.seconds, self.mean_de, self.pct = seconds, mean_de, pct


def read(path):
    """The rows of a bench-grooves CSV, by its header's names. A file it cannot read raises
    ValueError naming the file, the line and what was expected."""
    rows = []
    with open(path, newline="") as f:
        reader = csv.reader(f)
        header = next(reader, None)
        if header is None:
            raise ValueError("%s:1: empty; expected a header with %s" % (path, ", ".join(COLUMNS)))
        missing = [c for c in COLUMNS if c not in header]
        if missing:
            raise ValueError("%s:1: header has no column %s" % (path, ", ".join(missing)))
        at = {c: header.index(c) for c in COLUMNS}
        for line, rec in enumerate(reader, start=2):
            if not rec:
                continue
            if len(rec) != len(header):
                raise ValueError("%s:%d: %d fields; expected %d as in the header" % (path, line, len(rec), len(header)))
            try:
                rows.append(Row(rec[at["scene"]], rec[at["method"]], int(rec[at["spp"]]), float(rec[at["seconds"]]),
                                float(rec[at["mean_de"]]), float(rec[at["pct_ge_10"]])))
            except ValueError:
                raise ValueError("%s:%d: spp must be a whole number and seconds, mean_de and pct_ge_10 numbers"
                                 % (path, line)) from None
    return rows


def scenes(rows):
    """The scenes in the order they first appear."""
    out = []
    for r in rows:
        if r.scene not in out:
            out.append(r.scene)
    return out


def of(rows, scene, method):
    """The scene's rows of that method."""
    return [r for r in rows if r.scene == scene and r.method == method]


def one(rows, scene, method, spp):
    """The scene's row of that method at that spp, or None."""
    got = [r for r in of(rows, scene, method) if r.spp == spp]
    return got[0] if got else None


def reach(rows, scene, both=False):
    """The fastest groove render of the scene at geometry@64's mean dE (and, with `both`, at its
    % >= 10 too), or None; also None where the scene has no geometry at 64 spp."""
    g = one(rows, scene, "geometry", 64)
    if g is None:
        return None
    ok = [r for r in of(rows, scene, "groove") if r.mean_de <= g.mean_de and (not both or r.pct <= g.pct)]
    return min(ok, key=lambda r: r.seconds) if ok else None


def never(rows, scene):
    return "never (up to %d spp)" % max([r.spp for r in of(rows, scene, "groove")] or [0])


def ratio_text(rows, scene, both=False):
    """'groove@2, 0.38 s: 1/53.6' or 'never (up to 8 spp)', as bench-grooves prints it."""
    best = reach(rows, scene, both)
    if best is None:
        return never(rows, scene)
    return "groove@%d, %.2f s: 1/%.1f" % (best.spp, best.seconds, one(rows, scene, "geometry", 64).seconds / best.seconds)


def cell(r):
    return "%.2f, %.2f, %.2f" % (r.seconds, r.mean_de, r.pct) if r else "—"


def markdown(rows):
    """The table of docs/grooves.md's "Results" for these rows: a ratio that meets the target is
    in bold."""
    groove_spp = sorted({r.spp for r in rows if r.method == "groove"})
    head = ["scene", "geometry 16 spp", "geometry 64 spp"] + ["groove %d spp" % s for s in groove_spp] + \
        ["bare plate 64 spp", "time ratio at geometry@64's error"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for sc in scenes(rows):
        g64 = one(rows, sc, "geometry", 64)
        bare = one(rows, sc, "bare_plate", 64)
        best = reach(rows, sc)
        if g64 is None:
            ratio = "—"
        elif best is None:
            ratio = never(rows, sc)
        else:
            factor = g64.seconds / best.seconds
            ratio = ("**1/%.1f (%d spp)**" if factor >= TARGET else "1/%.1f (%d spp)") % (factor, best.spp)
        cells = [sc.replace("_", ", "), cell(one(rows, sc, "geometry", 16)), cell(g64)] + \
            [cell(one(rows, sc, "groove", s)) for s in groove_spp] + \
            ["%.2f" % bare.seconds if bare else "—", ratio]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def main():
    if len(sys.argv) != 2:
        sys.exit("usage: scripts/bench_table.py RESULTS.CSV")
    try:
        print(markdown(read(sys.argv[1])), end="")
    except (OSError, ValueError) as e:
        print("bench_table: %s" % e, file=sys.stderr)
        sys.exit(2)


if __name__ == "__main__":
    main()
