"""Two strahl builds timed against each other on the same render, in pairs: both run at once,
one thread each, each pinned to its own core (`taskset`), the cores swapped every round. What
slows the machine down during a round (another tenant of the host, a frequency change) slows
both, so the ratio of their rendering times varies far less than either time does; the
mean ratio over the rounds, with its standard error, is the figure (docs/performance.md, "The
glTF rooms: what a million triangles add", has what it settled).

    python3 tools/bench/ab_pair.py OLD_BUILD NEW_BUILD [--rounds 30] -- SCENE [strahl render options]
    # e.g. the dense room of tools/bench/cycles_time.py, 32 spp:
    python3 tools/bench/ab_pair.py old/strahl target/release/strahl -- \\
        target/bench-cycles/dense/cornell.gltf --width 240 --height 135 --spp 32 --passes combined

Prints each round's two rendering times (strahl's own "time: … s rendering", which leaves out
loading and the BVH build) and their ratio NEW/OLD, then the ratios' median, mean, standard
deviation and the mean's standard error. A build timed against itself gives a mean of 1 within
its standard error: on the 2-core VM of docs/performance.md, rounds of 3 s spread by 4-6 %
(sd), so 30 rounds resolve about 1 %. Needs a machine with two free cores and `taskset`
(util-linux). The images go to a temporary directory, removed afterwards.
"""

import argparse
import os
import re
import statistics
import subprocess
import sys
import tempfile


def start(build, core, args, out):
    """`build render ARGS -o OUT --threads 1` on `core`, its output captured."""
    cmd = ["taskset", "-c", str(core), build, "render", *args, "-o", out, "--threads", "1"]
    return subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)


def rendering_seconds(process, build):
    """The rendering time `process` (a run of `build`) printed, once it has ended."""
    out, _ = process.communicate()
    found = re.search(r"time: ([0-9.]+) s rendering", out)
    if process.returncode != 0 or not found:
        sys.exit(f"{build} failed (exit {process.returncode}):\n{out}")
    return float(found.group(1))


def main():
    argv = sys.argv[1:]
    split = argv.index("--") if "--" in argv else len(argv)
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], usage=__doc__.split("\n\n")[1].split("\n")[0].strip())
    p.add_argument("old", help="the build to compare with")
    p.add_argument("new", help="the build compared")
    p.add_argument("--rounds", type=int, default=30, help="pairs of runs (default 30)")
    a = p.parse_args(argv[:split])
    render = argv[split + 1 :]
    if not render or a.rounds < 2:
        p.error("give at least two rounds, and the scene after --")
    if os.cpu_count() is None or os.cpu_count() < 2:
        sys.exit("ab_pair.py needs two cores")
    ratios = []
    with tempfile.TemporaryDirectory(prefix="strahl-ab-") as tmp:
        for i in range(a.rounds):
            cores = (0, 1) if i % 2 == 0 else (1, 0)
            old = start(a.old, cores[0], render, os.path.join(tmp, "old.exr"))
            new = start(a.new, cores[1], render, os.path.join(tmp, "new.exr"))
            try:
                t_old, t_new = rendering_seconds(old, a.old), rendering_seconds(new, a.new)
            finally:
                for process in (old, new):
                    if process.poll() is None:
                        process.kill()
                        process.wait()
            ratios.append(t_new / t_old)
            print(f"round {i + 1:2}: old {t_old:.3f} s, new {t_new:.3f} s, new/old {ratios[-1]:.3f}", flush=True)
    sd = statistics.stdev(ratios)
    print(
        f"new/old: median {statistics.median(ratios):.3f}, mean {statistics.mean(ratios):.3f}, "
        f"sd {sd:.3f}, standard error of the mean {sd / len(ratios) ** 0.5:.3f} ({len(ratios)} rounds)"
    )


if __name__ == "__main__":
    main()
