"""Large swarms from the default settings: no cliffs (issue 13, "No cliffs")."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

import swarmgames

#: Address space the child may reserve (Numba and OpenBLAS reserve more than they touch).
ADDRESS_SPACE = 6 * 2**30

CHILD = """
import json, resource, sys
resource.setrlimit(resource.RLIMIT_AS, ({limit}, {limit}))
from swarmgames.config import resolve_scenario
from swarmgames.sim import run
cfg = resolve_scenario("coverage", ["swarm.n_robots=300", "sim.duration_s=2.0",
                                    "sim.animation=false", "sim.memory_limit_gib=1.5"])
res = run(cfg, out=None, progress=False)
# The peak resident set of this process image: VmHWM restarts at exec, ru_maxrss does not
# (it would report the forking parent's size, the test session's).
with open("/proc/self/status") as fh:
    rss = next(int(line.split()[1]) for line in fh if line.startswith("VmHWM:")) * 1024
json.dump({{"rss": rss, "stages": len(res.swarm), "k": int(res.metrics["neighbours"].max()) + 1}},
          sys.stdout)
"""


@pytest.mark.slow
@pytest.mark.skipif(sys.platform != "linux", reason="RLIMIT_AS and /proc/self/status: Linux")
def test_300_robots_from_the_default_take_off_run_within_a_memory_limit():
    # Regression: from the fixed 25 m disc every robot saw every other (N^3 work), and 300
    # robots died out of memory with no warning. The grown disc and the bounded stage run in
    # well under 1.5 GiB; the run is not refused by its own estimate at that limit either.
    src = str(Path(swarmgames.__file__).resolve().parents[1])
    env = {"PYTHONPATH": src, "PATH": "/usr/bin:/bin"}
    # Numba compiles the kernels on their first call in a fresh checkout (LLVM takes several
    # hundred MB while it does); a small run first puts them in the on-disk cache, so that
    # the peak measured is the run's own.
    warm = CHILD.format(limit=ADDRESS_SPACE).replace("swarm.n_robots=300", "swarm.n_robots=7")
    subprocess.run([sys.executable, "-c", warm], capture_output=True, timeout=600, env=env)
    out = subprocess.run(
        [sys.executable, "-c", CHILD.format(limit=ADDRESS_SPACE)],
        capture_output=True,
        text=True,
        timeout=600,
        env=env,
        check=False,
    )
    assert out.returncode == 0, out.stderr[-2000:]
    got = json.loads(out.stdout)
    assert got["stages"] == 2
    assert got["k"] < 150  # the take-off disc spreads the swarm (a 25 m disc: K = 300)
    assert got["rss"] < 1.5 * 2**30
