#!/usr/bin/env python3
"""Checks bench_plot_grooves, the plotter of scripts/bench-grooves (issue 5's run time against
error): on a small CSV it writes a PNG that an independent reader decodes, with one panel per scene
and the target box (1/20 of geometry@64's time, below its error) only where the scene has geometry
at 64 spp; a CSV it cannot read gives exit status 2 and one message naming the file and line.

Usage: bench_plot_check.py --plotter PATH --work DIR"""

import argparse
import os
import shutil
import subprocess
import sys
import unittest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import coco_reader  # noqa: E402  (its PNG decoder)

ARGS = None
HEADER = ("scene,method,spp,seconds,mean_de,pct_ge_10,wall_seconds,mean_de_scratches,mean_de_rest,seeds,"
          "mean_de_min,mean_de_max")
TARGET_FILL = (205, 240, 205)  # RGB of the target box (bench_plot_grooves, target_fill in BGR)
GROOVE = (220, 40, 40)         # RGB of the groove renderer's line


def row(scene, method, spp, seconds, mean_de, seeds=1, lo=None, hi=None):
    lo = mean_de if lo is None else lo
    hi = mean_de if hi is None else hi
    return "%s,%s,%d,%g,%g,0,%g,0,0,%d,%g,%g" % (scene, method, spp, seconds, mean_de, seconds + 0.2, seeds, lo, hi)


def plate(scene):
    """One scene on axes of whole decades (0.01 to 1 s, mean dE 0.1 to 10): geometry at 1 to 256
    spp (at 64 spp 0.4 s and mean dE 0.5), the groove renderer at 1 to 8 spp below and left of it,
    the bare plate."""
    rows = [row(scene, "geometry", s, t, e) for s, t, e in ((1, 0.05, 10), (4, 0.08, 3), (16, 0.15, 1))]
    rows.append(row(scene, "geometry", 64, 0.4, 0.5, 4, 0.45, 0.55))
    rows.append(row(scene, "geometry", 256, 1.0, 0.3))
    rows += [row(scene, "groove", s, 0.01 * s, 0.3 / s ** 0.5, 4, 0.1 * (8 / s) ** 0.5, 0.4 / s ** 0.5)
             for s in (1, 2, 4, 8)]
    rows.append(row(scene, "bare_plate", 64, 0.2, 9.0))
    return rows


class BenchPlot(unittest.TestCase):
    def setUp(self):
        self.work = os.path.join(ARGS.work, self.id().split(".")[-1])
        shutil.rmtree(self.work, ignore_errors=True)
        os.makedirs(self.work)

    def plot(self, lines):
        csv_path = os.path.join(self.work, "results.csv")
        with open(csv_path, "w") as f:
            f.write("\n".join(lines) + "\n")
        png = os.path.join(self.work, "results.png")
        p = subprocess.run([ARGS.plotter, csv_path, png], capture_output=True, text=True)
        return p, csv_path, png

    def colours(self, png):
        img = coco_reader.read_png(png)
        self.assertEqual((img["channels"], img["bit_depth"]), (3, 8))
        px = img["pixels"]
        counts = {}
        for i in range(0, len(px), 3):
            c = (px[i], px[i + 1], px[i + 2])
            counts[c] = counts.get(c, 0) + 1
        return img, counts

    def test_panels_and_target_box(self):
        # Two scenes with geometry at 64 spp and one without: three panels in one row (560 x 410
        # each); the box is drawn twice.
        no_g64 = [r for r in plate("c") if ",geometry,64," not in r]
        p, _, png = self.plot([HEADER] + plate("a") + plate("b") + no_g64)
        self.assertEqual(p.returncode, 0, p.stderr)
        img, counts = self.colours(png)
        self.assertEqual((img["width"], img["height"]), (3 * 560, 410))
        self.assertGreater(counts.get(GROOVE, 0), 100)
        box = counts.get(TARGET_FILL, 0)
        # Each box spans the plot's left edge to 1/20 of 0.4 s (0.02 s: 0.301 of two decades of
        # the plot's 470 pixels) and its bottom up to mean dE 0.5 (0.699 of two decades of 285):
        # about 71 x 100 pixels, less what is drawn over it (grid lines, the groove's points).
        expected = 2 * (0.301 / 2 * 470) * (0.699 / 2 * 285)
        self.assertGreater(box, 0.8 * expected)
        self.assertLess(box, 1.05 * expected)
        # The scene without geometry at 64 spp alone: no box at all.
        p, _, png = self.plot([HEADER] + no_g64)
        self.assertEqual(p.returncode, 0, p.stderr)
        img, counts = self.colours(png)
        self.assertEqual((img["width"], img["height"]), (3 * 560, 410))
        self.assertEqual(counts.get(TARGET_FILL, 0), 0)
        self.assertGreater(counts.get(GROOVE, 0), 100)

    def test_bad_csv_is_refused(self):
        cases = [
            ([HEADER, row("a", "groove", 1, 0.1, 0.2).replace("0.1,", "fast,", 1)], ":2:", "'seconds'"),
            ([HEADER, row("a", "groove", 1, 0.1, 0.2), "a,groove,2"], ":3:", "fields"),
            ([HEADER.replace("mean_de,", "error,", 1), row("a", "groove", 1, 0.1, 0.2)], ":1:", "'mean_de'"),
            ([HEADER, row("a", "groove", 1, 0.0, 0.2)], ":2:", "above 0"),
            ([HEADER], "no rows", "no rows"),
        ]
        for lines, where, what in cases:
            p, csv_path, png = self.plot(lines)
            self.assertEqual(p.returncode, 2, (lines, p.stderr))
            msg = p.stderr.strip()
            self.assertEqual(len(msg.splitlines()), 1, msg)
            self.assertIn(csv_path, msg)
            self.assertIn(where, msg)
            self.assertIn(what, msg)
            self.assertFalse(os.path.exists(png), "a refused CSV left a picture behind")


if __name__ == "__main__":
    ap = argparse.ArgumentParser()
    ap.add_argument("--plotter", required=True)
    ap.add_argument("--work", required=True)
    ARGS, rest = ap.parse_known_args()
    unittest.main(argv=[sys.argv[0]] + rest, verbosity=2)
