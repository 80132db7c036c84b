"""Tests of the per-hop-count placement of a model within ns-3's run-to-run spread (no ns-3
needed: the recorded runs in tests/data/ns3 stand in for it)."""

from __future__ import annotations

import json
import os

import numpy as np
import pandas as pd
import pytest

from swarmgames.experiments.fidelity import (
    CLASSES,
    FidelityResult,
    fidelity,
    hop_tensor,
    main,
    pair_counts,
)

DATA = os.path.join(os.path.dirname(__file__), "..", "data", "ns3")


def test_hop_tensor_places_rows_at_their_sample_and_skips_other_times():
    hops = pd.DataFrame({"t": [1.0, 1.0, 2.0, 2.5], "node": [0, 1, 0, 0], "dest": [1, 0, 2, 1],
                         "hops": [1, 1, 4, 2]})  # fmt: skip
    out = hop_tensor(hops, 3, np.array([1.0, 2.0]))
    assert out.shape == (2, 3, 3)
    assert out[0].tolist() == [[0, 1, 0], [1, 0, 0], [0, 0, 0]]
    assert out[1].tolist() == [[0, 0, 4], [0, 0, 0], [0, 0, 0]]  # t = 2.5 is no sample


def test_pair_counts_by_hand():
    a = np.array([[0, 1, 2, 3], [1, 0, 1, 6], [2, 1, 0, 0], [3, 0, 0, 0]])
    b = np.array([[0, 1, 2, 4], [1, 0, 1, 5], [2, 1, 0, 3], [0, 0, 0, 0]])
    c = pair_counts(a, b)
    rows = dict(zip(CLASSES, c.tolist(), strict=True))
    # routes in a, routes in b, entries in either, entries that agree
    assert rows["1"] == [4, 4, 4, 4]
    assert rows["2"] == [2, 2, 2, 2]
    assert rows["3"] == [2, 1, 3, 0]  # a: (0,3), (3,0); b: (2,3)
    assert rows["4"] == [0, 1, 1, 0]  # b: (0,3)
    assert rows["5+"] == [1, 1, 1, 0]  # 6 and 5 are both 5+ but differ
    assert rows["all"] == [9, 9, 10, 6]


def test_table_places_the_model_by_mid_rank():
    result = FidelityResult(
        name="toy",
        model="m",
        runs=(1, 2, 3, 4),
        seeds=(0, 1, 2),
        routes_ns3=np.tile([[10], [20], [30], [40]], (1, 6)),
        routes_model=np.tile([[20], [30], [25]], (1, 6)),
        agreement_ns3=np.tile([[0.90], [0.92], [0.94]], (1, 6)),
        agreement_model=np.tile([[0.92]], (12, 6)),
    )
    row = result.to_frame().iloc[0]
    assert row["ns3_routes"] == 25.0 and row["model_routes"] == 25.0 and row["excess"] == 0.0
    assert row["routes_percentile"] == 50.0  # 10 and 20 below, 30 and 40 above
    assert row["agreement_percentile"] == 50.0  # 0.90 below, 0.92 equal, 0.94 above
    assert (row["ns3_agreement_min"], row["ns3_agreement_max"]) == (0.90, 0.94)
    assert "| 1 | 25 | 25 | +0.0 % | 50 |" in result.to_markdown()


def _copies(folder, runs=(1, 2)):
    """A recording of identical 'ns-3 runs': instant BFS tables of a still 3-node line."""
    positions = pd.DataFrame(
        {"t": 0.0, "node": [0, 1, 2], "x": [0.0, 300.0, 600.0], "y": 0.0, "z": 0.0}
    )
    positions = pd.concat([positions, positions.assign(t=10.0)], ignore_index=True)
    pairs = pd.DataFrame({"node": [0, 0, 1, 1, 2, 2], "dest": [1, 2, 0, 2, 0, 1],
                          "hops": [1, 2, 1, 1, 2, 1]})  # fmt: skip
    hops = pd.concat(
        [pairs.assign(run=k, t=float(t)) for k in runs for t in range(11)], ignore_index=True
    )[["run", "t", "node", "dest", "hops"]]
    folder.mkdir()
    positions.to_csv(folder / "positions.csv", index=False)
    hops.to_csv(folder / "hops.csv.xz", index=False)
    meta = {"kind": "line", "sample": 1.0, "runs": list(runs)}
    (folder / "meta.json").write_text(json.dumps(meta))
    return folder


def test_a_model_equal_to_every_run_agrees_fully_and_sits_at_the_median(tmp_path):
    result = fidelity(_copies(tmp_path / "line", runs=(1, 2, 3)), "oracle", seeds=(0, 1),
                      warmup_s=0.0)  # fmt: skip
    frame = result.to_frame().set_index("hops")
    assert result.runs == (1, 2, 3) and result.agreement_ns3.shape == (3, 6)
    assert result.agreement_model.shape == (6, 6) and result.routes_model.shape == (2, 6)
    assert frame.loc["all", "ns3_routes"] == frame.loc["all", "model_routes"] == 66  # 11 x 6
    assert (frame["model_agreement"] == 1.0).all() and (frame["ns3_agreement"] == 1.0).all()
    assert frame.loc[["1", "2", "all"], "agreement_percentile"].eq(50.0).all()
    assert np.isnan(frame.loc["3", "excess"])  # no 3-hop routes at all


def test_bad_arguments(tmp_path):
    with pytest.raises(ValueError, match=r"at least two ns-3 runs \(got 1\)"):
        fidelity(os.path.join(DATA, "waypoint_20"))
    with pytest.raises(ValueError, match="seeds must name at least one seed"):
        fidelity(_copies(tmp_path / "line"), "oracle", seeds=())


def test_cli_prints_a_table_per_recording(tmp_path, capsys):
    folder = _copies(tmp_path / "line")
    assert main([str(folder), "--model", "oracle", "--seeds", "1", "--warmup", "0"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("line: oracle (seeds 0-0) against ns-3 (runs 1-2)")
    assert "| all | 66 | 66 | +0.0 % |" in out
    with pytest.raises(SystemExit) as exc:
        main([str(folder), "--seeds", "0"])
    assert exc.value.code == 2


def test_olsr_stays_within_ns3_run_to_run_spread_on_fast_20():
    # docs/ns3.md "Fidelity beyond 2 hops": measured with seeds 0-9, the model's median
    # agreement lies inside the range of ns-3's pairwise agreements for every hop count, and
    # at ns-3's 69th percentile overall.
    result = fidelity(os.path.join(DATA, "fast_20"), seeds=range(3))
    frame = result.to_frame().set_index("hops")
    inside = frame["model_agreement"].between(frame["ns3_agreement_min"],
                                              frame["ns3_agreement_max"])  # fmt: skip
    assert inside.all(), frame
    assert 10 <= frame.loc["all", "agreement_percentile"] <= 90
    assert abs(frame.loc["3", "excess"]) < 0.02


def test_olsr_beyond_two_hops_sits_in_the_middle_of_ns3_spread_on_fast_40():
    # docs/ns3.md "Fidelity beyond 2 hops", seeds 0-2: agreement at ns-3's 84th/73rd/73rd
    # percentile for 3/4/5+ hops, 3- and 4-hop routes within 0.5 % of ns-3's median. Before
    # the floods used the MPR selectors and links of the moment a copy arrives (and the
    # topology set ns-3's ANSN rules), the 4-hop agreement was at the 44th percentile and
    # 4-hop routes 1.2 % short with these seeds (22nd and 2.1 % with seeds 0-9).
    frame = fidelity(os.path.join(DATA, "fast_40"), seeds=range(3)).to_frame().set_index("hops")
    assert (frame.loc[["3", "4", "5+"], "agreement_percentile"] >= 60).all(), frame
    assert (frame.loc[["3", "4"], "excess"].abs() < 0.01).all(), frame
