"""Golden runs: refactors must not change what a run computes.

The files in ``tests/data/golden/<case>/`` were written by ``swarmgames run``
(``trajectory.csv`` and ``swarm.csv`` as written, ``metrics.csv`` without its wall-time
columns): the coverage cases before the mission plug-in redesign, which therefore changed
nothing they compute, the other missions' cases when they were added, ``coverage-refine``
(the coverage preset with its best-response refinement) when the refinement was added.
``trajectory.csv`` must stay byte-identical; the other two tables must hold the same values
in the columns recorded then (columns added since, such as ``oscillation``, are checked elsewhere).
The ``coverage`` column of ``swarm.csv`` alone was rewritten since, when the coverage metric's
weighted sum over the ROI became a loop in cell order: as a BLAS dot product it had differed
by a few units in the last place between two CPUs (OpenBLAS selects its kernel by CPU), with
every trajectory byte-identical on both; the rewrite checked that each value moved by at most
1e-12 relative and that the trajectories stayed the same.

**One recording per vector width.** The compiled kernels sum their dot products in the
CPU's vector lanes (``fastmath`` reassociation, docs/game.md) and numpy dispatches its float
kernels by CPU, so float32 results differ in the last bits between a CPU with AVX-512 and
one with AVX2 alone. ``tests/data/golden/`` holds the AVX-512 recordings and
``tests/data/golden-avx2/`` the AVX2 ones; the tests read the set of the CPU they run on
(:func:`golden`). Across the two widths every case but one flies the same trajectory, and
payoffs and coverage differ by at most 9e-8 relative (the regrets, small differences of
nearly equal payoffs, by more); ``coverage-paper``, which has no move cost, swaps robots on
such differences and flies another trajectory (payoffs within 2e-4). ``coverage-csma`` has
an AVX2 recording only.
``python tests/sim/test_golden.py`` records the cases of this CPU's width and prints how
they differ from the other width's.

They were recorded with every neighbour's exact state delivered instantly, which is what
``comms.model = "ideal"`` keeps reproducing bit for bit. With routed messages and no loss
seven of the nine cases fly the same trajectory; ``coverage-paper`` and
``rendezvous`` do not, because a robot's reported S̄_j is the mean of what it has heard, its
neighbours' states of the stage before (the last test of this module).
"""

from __future__ import annotations

from pathlib import Path

import pandas as pd
import pytest

from swarmgames.config import resolve_scenario
from swarmgames.sim import run

DATA = Path(__file__).parent.parent / "data"
#: The recordings of each vector width (module docstring).
ROOTS = {"avx512": DATA / "golden", "avx2": DATA / "golden-avx2"}


def vector_width() -> str:
    """``"avx512"`` on a CPU with AVX-512, else ``"avx2"``."""
    import llvmlite.binding as llvm

    return "avx512" if llvm.get_host_cpu_features().get("avx512f", False) else "avx2"


def golden(case: str) -> Path:
    """The recording of ``case`` for this CPU's vector width (skips when there is none)."""
    folder = ROOTS[vector_width()] / case
    if not (folder / "trajectory.csv").is_file():
        pytest.skip(f"no golden recording of {case!r} for {vector_width()} CPUs")
    return folder


QUICK = ["sim.animation=false", "comms.model='ideal'"]
#: The coverage preset refines every local game's profile to a pure NE since these were
#: recorded (game.refine = "best_response"): its cases pin Algorithm 1 alone, what they
#: recorded, and "coverage-refine" records the preset as shipped.
ALONE = "game.refine='none'"
CASES = {
    "coverage": ("coverage", [ALONE]),
    "coverage-paper": ("coverage-paper", []),
    "lloyd": ("coverage", ["sim.controller='lloyd'", "sim.duration_s=20.0", ALONE]),
    "centralised": ("coverage", ["game.solver='centralised'", "sim.duration_s=20.0", ALONE]),
    "acceleration": (
        "coverage",
        ["swarm.action_set='acceleration'", "sim.duration_s=20.0", ALONE],
    ),
    "hops3": ("coverage", ["network.hops=3", "swarm.n_robots=12", "sim.duration_s=20.0", ALONE]),
    "rendezvous": ("rendezvous", ["sim.duration_s=20.0"]),
    "flocking": ("flocking", ["sim.duration_s=20.0"]),
    "coverage-refine": ("coverage", []),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_run_matches_golden_files(case: str, tmp_path: Path) -> None:
    scenario, overrides = CASES[case]
    config = resolve_scenario(scenario, [*overrides, *QUICK])
    run(config, out=tmp_path / "run", progress=False)
    want, got = golden(case), tmp_path / "run"
    assert (got / "trajectory.csv").read_bytes() == (want / "trajectory.csv").read_bytes()
    for table in ("swarm.csv", "metrics.csv"):
        expected = pd.read_csv(want / table)
        actual = pd.read_csv(got / table)[list(expected.columns)]
        pd.testing.assert_frame_equal(actual, expected, check_exact=True)


def test_the_default_shared_channel_matches_its_golden_files(tmp_path: Path) -> None:
    # ``coverage-csma``: the coverage preset as shipped (``comms.model = "csma"``, the
    # default), 20 s, recorded when the shared channel became the default.
    config = resolve_scenario("coverage", ["sim.animation=false", "sim.duration_s=20.0"])
    assert config.comms.model == "csma"
    run(config, out=tmp_path / "run", progress=False)
    want, got = golden("coverage-csma"), tmp_path / "run"
    assert (got / "trajectory.csv").read_bytes() == (want / "trajectory.csv").read_bytes()
    for table in ("swarm.csv", "metrics.csv"):
        expected = pd.read_csv(want / table)
        actual = pd.read_csv(got / table)[list(expected.columns)]
        pd.testing.assert_frame_equal(actual, expected, check_exact=True)


#: The cases whose trajectory routed delivery without loss leaves unchanged.
ROUTED_SAME = {
    "acceleration",
    "centralised",
    "coverage",
    "coverage-refine",
    "flocking",
    "hops3",
    "lloyd",
}


@pytest.mark.slow
@pytest.mark.parametrize("case", sorted(CASES))
def test_routed_delivery_without_loss_flies_the_golden_trajectories(case: str, tmp_path: Path):
    # Messages stamped at the stage time arrive before the decision (0.1 s later), so the
    # states in the games are the exact ones; what differs is S̄_j, computed by robot j from
    # its beliefs (its neighbours' states of the previous stage), which changes the games of
    # robots with virtual means where the swarm still moves.
    scenario, overrides = CASES[case]
    config = resolve_scenario(scenario, [*overrides, "sim.animation=false", "comms.model='routed'"])
    run(config, out=tmp_path / "run", progress=False)
    same = (tmp_path / "run" / "trajectory.csv").read_bytes() == (
        golden(case) / "trajectory.csv"
    ).read_bytes()
    assert same == (case in ROUTED_SAME)


def _config(case: str):
    if case == "coverage-csma":
        return resolve_scenario("coverage", ["sim.animation=false", "sim.duration_s=20.0"])
    scenario, overrides = CASES[case]
    return resolve_scenario(scenario, [*overrides, *QUICK])


def record(out_root: Path, other_root: Path) -> None:
    """Record every case into ``out_root`` and print how each differs from ``other_root``'s
    recording: whether the trajectory is the same, and the largest relative difference of
    every other column that differs."""
    import tempfile

    import numpy as np

    for case in [*sorted(CASES), "coverage-csma"]:
        with tempfile.TemporaryDirectory() as tmp:
            run(_config(case), out=Path(tmp) / "run", progress=False)
            dest = out_root / case
            dest.mkdir(parents=True, exist_ok=True)
            src = Path(tmp) / "run"
            (dest / "trajectory.csv").write_bytes((src / "trajectory.csv").read_bytes())
            (dest / "swarm.csv").write_bytes((src / "swarm.csv").read_bytes())
            metrics = pd.read_csv(src / "metrics.csv")
            keep = [c for c in metrics.columns if not c.endswith("_ms")]
            metrics[keep].to_csv(dest / "metrics.csv", index=False)
        other = other_root / case
        if not other.is_dir():
            print(f"{case}: recorded (no other recording)")
            continue
        same = (dest / "trajectory.csv").read_bytes() == (other / "trajectory.csv").read_bytes()
        diffs = []
        for table in ("swarm.csv", "metrics.csv"):
            b = pd.read_csv(other / table)
            a = pd.read_csv(dest / table)[list(b.columns)]
            for col in b.columns:
                x, y = a[col].to_numpy(float), b[col].to_numpy(float)
                if not np.array_equal(x, y, equal_nan=True):
                    rel = np.nanmax(np.abs(x - y) / np.maximum(np.abs(y), 1e-300))
                    diffs.append(f"{table}:{col} {rel:.1e}")
        print(f"{case}: trajectory {'same' if same else 'DIFFERENT'}; {', '.join(diffs)}")


if __name__ == "__main__":
    width = vector_width()
    record(ROOTS[width], ROOTS["avx2" if width == "avx512" else "avx512"])
