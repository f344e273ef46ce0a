"""What scripts/fuzz-configs and scripts/fuzz-meshes share: running `defectgen generate` on one
input and judging the outcome. A run passes when it either succeeds with finite images (no NaN or
infinity in any EXR channel) and annotations that parse, or is refused with exit status 2, one
message naming one of the input files, and no output folder. Anything else (a crash, another exit
status, a refusal that names no input, a folder left behind, a NaN, a run past 300 s) fails."""
import argparse, json, os, random, shutil, subprocess, sys


def finite_exr(path):
    p = subprocess.run(["oiiotool", path, "--printstats"], capture_output=True, text=True)
    if p.returncode:
        return "oiiotool cannot read " + path
    for line in p.stdout.splitlines():
        if "NanCount" in line or "InfCount" in line:
            if any(int(v) for v in line.split(":")[1].split()):
                return "%s: %s" % (os.path.basename(path), line.strip())
    return None


def run_one(binary, cfg, out, names):
    """Runs generate on cfg into out. names: the file names a refusal may name. Returns
    (kind, what, problem): kind "ok" or "refused" (problem None) or "failed"; what for the log."""
    try:
        p = subprocess.run([binary, "generate", cfg, "--out", out, "--quiet", "--threads", "2"],
                           capture_output=True, timeout=300)
        rc, err = p.returncode, p.stderr.decode("utf-8", "replace").strip()
    except subprocess.TimeoutExpired:
        rc, err = None, "timed out"
    problem = None
    if rc == 0:
        what = "ok"
        try:
            json.load(open(os.path.join(out, "annotations.json")))
            exrs = [os.path.join(out, "images", e) for e in sorted(os.listdir(os.path.join(out, "images")))
                    if e.endswith(".exr")]
            problem = None if exrs else "no EXR written"
            for e in exrs:
                problem = problem or finite_exr(e)
        except (OSError, ValueError) as e:
            problem = "output unreadable: %s" % e
    elif rc == 2:
        what = "refused: " + (err.splitlines()[-1] if err else "")
        if not err or not any(n in err for n in names):
            problem = "refusal names none of " + ", ".join(names)
        elif len(err.splitlines()) != 1:
            problem = "refusal is %d lines" % len(err.splitlines())
        elif os.path.exists(out):
            problem = "output folder left behind"
    else:
        what = "exit %s: %s" % (rc, err.splitlines()[-1] if err else "")
        problem = "neither success nor a refusal"
    if not problem:
        shutil.rmtree(out, ignore_errors=True)
    return ("failed" if problem else "ok" if rc == 0 else "refused"), what, problem


def start(prog, count, work):
    """The fuzzers' options (--seed, --count, --binary, --work) and their start: returns the
    arguments, a random generator seeded with --seed, the binary's absolute path and an emptied
    folder WORK/SEED for the inputs and outputs."""
    ap = argparse.ArgumentParser(prog=prog)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--count", type=int, default=count)
    ap.add_argument("--binary", default="build/defectgen")
    ap.add_argument("--work", default=work)
    args = ap.parse_args()
    out = os.path.abspath(os.path.join(args.work, str(args.seed)))
    shutil.rmtree(out, ignore_errors=True)
    os.makedirs(out)
    return args, random.Random(args.seed), os.path.abspath(args.binary), out


class Tally:
    """Counts run_one's verdicts and ends the fuzzer with its summary line: exit status 1 when
    any run failed."""

    def __init__(self):
        self.counts = {"ok": 0, "refused": 0, "failed": 0}

    def add(self, kind):
        self.counts[kind] += 1

    def finish(self, n, inputs, where):
        c = self.counts
        print("%d %s: %d rendered, %d refused with a message, %d failed; %s"
              % (n, inputs, c["ok"], c["refused"], c["failed"], where))
        sys.exit(1 if c["failed"] else 0)
