#!/usr/bin/env python3
"""Checks scripts/bench_table.py, the summary of scripts/bench-grooves: on small CSVs, the time
ratio at geometry@64's error (the fastest groove render at or below its mean dE, and at or below
both its mean dE and its % >= 10), the markdown table of docs/grooves.md's "Results" with the
target met in bold, and one message naming the file and line, with exit status 2, for a CSV it
cannot read.

Usage: bench_table_check.py --source DIR --work DIR"""

import argparse
import os
import subprocess
import sys
import unittest

ARGS = None
HEADER = ("scene,method,spp,seconds,mean_de,pct_ge_10,wall_seconds,mean_de_scratches,mean_de_rest,seeds,"
          "mean_de_min,mean_de_max")


def row(scene, method, spp, seconds, mean_de, pct):
    return "%s,%s,%d,%r,%r,%r,%r,0,0,1,%r,%r" % (scene, method, spp, seconds, mean_de, pct, seconds + 0.3, mean_de,
                                                  mean_de)


# parallel_ring: geometry@64 0.50 s at 0.20 and 0.10%; the groove renderer reaches its mean dE at
# 2 spp (0.02 s: 1/25.0, the target met) but its % >= 10 only at 4 spp (0.05 s: 1/10.0).
# ends_bar: never below geometry@64's mean dE. door_bar: no geometry at 64 spp.
ROWS = [row("parallel_ring", "groove", s, t, e, p)
        for s, t, e, p in ((1, 0.0125, 0.30, 0.0), (2, 0.02, 0.20, 0.2), (4, 0.05, 0.15, 0.1), (8, 0.1, 0.1, 0.0))]
ROWS += [row("parallel_ring", "geometry", 16, 0.3, 0.4, 0.5), row("parallel_ring", "geometry", 64, 0.5, 0.2, 0.1),
         row("parallel_ring", "bare_plate", 64, 0.25, 11.0, 20.0)]
ROWS += [row("ends_bar", "groove", s, 0.1 * s, 0.5, 0.0) for s in (1, 2, 4, 8)]
ROWS += [row("ends_bar", "geometry", 64, 0.4, 0.45, 0.3), row("ends_bar", "bare_plate", 64, 0.2, 9.0, 30.0)]
ROWS += [row("door_bar", "groove", 1, 0.3, 0.1, 0.0)]


class BenchTable(unittest.TestCase):
    def setUp(self):
        sys.path.insert(0, os.path.join(ARGS.source, "scripts"))
        import bench_table
        self.bt = bench_table
        self.csv = os.path.join(ARGS.work, "results.csv")
        with open(self.csv, "w") as f:
            f.write(HEADER + "\n" + "\n".join(ROWS) + "\n")

    def test_ratios(self):
        rows = self.bt.read(self.csv)
        self.assertEqual(len(rows), len(ROWS))
        self.assertEqual(self.bt.ratio_text(rows, "parallel_ring"), "groove@2, 0.02 s: 1/25.0")
        self.assertEqual(self.bt.ratio_text(rows, "parallel_ring", both=True), "groove@4, 0.05 s: 1/10.0")
        self.assertEqual(self.bt.ratio_text(rows, "ends_bar"), "never (up to 8 spp)")
        self.assertIsNone(self.bt.reach(rows, "door_bar"))

    def test_table(self):
        lines = self.bt.markdown(self.bt.read(self.csv)).splitlines()
        self.assertEqual(lines[0], "| scene | geometry 16 spp | geometry 64 spp | groove 1 spp | groove 2 spp | "
                         "groove 4 spp | groove 8 spp | bare plate 64 spp | time ratio at geometry@64's error |")
        self.assertEqual(lines[1], "|---|---|---|---|---|---|---|---|---|")
        self.assertEqual(lines[2], "| parallel, ring | 0.30, 0.40, 0.50 | 0.50, 0.20, 0.10 | 0.01, 0.30, 0.00 | "
                         "0.02, 0.20, 0.20 | 0.05, 0.15, 0.10 | 0.10, 0.10, 0.00 | 0.25 | **1/25.0 (2 spp)** |")
        self.assertEqual(lines[3], "| ends, bar | — | 0.40, 0.45, 0.30 | 0.10, 0.50, 0.00 | 0.20, 0.50, 0.00 | "
                         "0.40, 0.50, 0.00 | 0.80, 0.50, 0.00 | 0.20 | never (up to 8 spp) |")
        self.assertEqual(lines[4], "| door, bar | — | — | 0.30, 0.10, 0.00 | — | — | — | — | — |")
        self.assertEqual(len(lines), 5)

    def test_a_csv_it_cannot_read_is_refused(self):
        cases = {
            "no_header.csv": ("", ":1: empty"),
            "no_seconds.csv": (HEADER.replace("seconds,mean_de", "secs,mean_de") + "\n", ":1: header has no column seconds"),
            "short.csv": (HEADER + "\n" + ROWS[0] + "\n" + "parallel_ring,groove,2\n", ":3: 3 fields; expected 12"),
            "word.csv": (HEADER + "\n" + ROWS[0].replace(",0.0125,", ",fast,", 1) + "\n", ":2: spp must be a whole"),
        }
        for name, (text, what) in cases.items():
            with self.subTest(name):
                path = os.path.join(ARGS.work, name)
                with open(path, "w") as f:
                    f.write(text)
                with self.assertRaises(ValueError) as e:
                    self.bt.read(path)
                self.assertIn(path + what, str(e.exception))
                p = subprocess.run([sys.executable, os.path.join(ARGS.source, "scripts", "bench_table.py"), path],
                                   capture_output=True, text=True)
                self.assertEqual(p.returncode, 2)
                self.assertEqual(p.stdout, "")
                self.assertEqual(len(p.stderr.splitlines()), 1, p.stderr)
                self.assertTrue(p.stderr.startswith("bench_table: " + path + what), p.stderr)


def main():
    global ARGS
    ap = argparse.ArgumentParser()
    ap.add_argument("--source", required=True)
    ap.add_argument("--work", required=True)
    ARGS, rest = ap.parse_known_args()
    os.makedirs(ARGS.work, exist_ok=True)
    unittest.main(argv=[sys.argv[0]] + rest, verbosity=2)


if __name__ == "__main__":
    main()
