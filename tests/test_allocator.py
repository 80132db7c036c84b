"""Freed memory kept for reuse (swarmgames.allocator): the second array of a size is not
faulted in again, the opt-out leaves glibc alone, and the results do not change.

Each check runs in a fresh interpreter: the settings are process-wide and cannot be undone.
"""

from __future__ import annotations

import ctypes
import json
import os
import platform
import subprocess
import sys

import pytest

pytestmark = pytest.mark.skipif(
    platform.system() != "Linux"
    or platform.libc_ver()[0] != "glibc"
    or not hasattr(ctypes.CDLL(None), "mallinfo2"),
    reason="the settings are glibc's, and the checks read glibc >= 2.33's mallinfo2",
)

# Where glibc's mallinfo2 says a 64 MiB array lives: in an mmap of its own (above glibc's
# 32 MiB mmap threshold, unmapped when freed) or in the heap, which keeps it once freed.
_WHERE = """
import ctypes, json, numpy as np
from swarmgames.allocator import reuse_freed_memory, reusing_freed_memory
class Info(ctypes.Structure):
    _fields_ = [(f, ctypes.c_size_t) for f in (
        "arena", "ordblks", "smblks", "hblks", "hblkhd", "usmblks", "fsmblks", "uordblks",
        "fordblks", "keepcost")]
mallinfo2 = ctypes.CDLL(None).mallinfo2
mallinfo2.restype = Info
applied = reuse_freed_memory()
a = np.ones(8 * 2**20)
mapped = mallinfo2().hblkhd
del a
kept = mallinfo2().arena
print(json.dumps({"applied": applied, "in_force": reusing_freed_memory(), "mapped": mapped,
                  "kept": kept}))
"""
_MIB64 = 64 * 2**20

_STAGE = """
import hashlib, sys
from swarmgames.allocator import reuse_freed_memory
from swarmgames.bench.stage import StageBench
from swarmgames.config import scaled_config
reuse_freed_memory()
cfg = scaled_config(40, area_per_robot_m2=300.0).with_overrides({"swarm.start_max_neighbours": 0})
sb = StageBench(40, config=cfg, seed=3)
for _ in range(3):
    sb.step()
print(hashlib.sha256(sb.states.tobytes()).hexdigest())
"""


def _python(code: str, malloc: str | None) -> str:
    env = {k: v for k, v in os.environ.items() if k != "SWARMGAMES_MALLOC"}
    if malloc is not None:
        env["SWARMGAMES_MALLOC"] = malloc
    res = subprocess.run(
        [sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=600
    )
    assert res.returncode == 0, res.stderr
    return res.stdout.strip().splitlines()[-1]


def test_a_large_array_comes_from_the_heap_and_stays_there_once_freed():
    reuse = json.loads(_python(_WHERE, None))
    assert reuse["applied"] and reuse["in_force"]
    assert reuse["mapped"] < _MIB64 <= reuse["kept"], reuse


def test_system_leaves_the_allocator_as_it_is():
    system = json.loads(_python(_WHERE, "system"))
    assert not system["applied"] and not system["in_force"]
    assert system["mapped"] >= _MIB64 > system["kept"], system  # glibc's own: an mmap


def test_stages_are_the_same_bit_for_bit_either_way():
    """A dense 40-UAV float32 run (OLSR's 2-hop tables, the fused kernels, the shared
    pairwise tables): only where the memory comes from changes."""
    assert _python(_STAGE, None) == _python(_STAGE, "system")


def test_the_command_applies_it(tmp_path):
    code = (
        "import sys; from swarmgames import cli, allocator; sys.argv = ['swarmgames', '--version'];"
        "\ntry:\n    cli.main()\nexcept SystemExit:\n    pass\n"
        "print(allocator.reusing_freed_memory())"
    )
    assert _python(code, None) == "True"
    assert _python(code, "system") == "False"
