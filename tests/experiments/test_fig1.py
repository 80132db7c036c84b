"""The paper's Figure 1 against the ns-3 3.44 values of docs/reference.md section 4."""

import numpy as np
import pandas as pd
import pytest

from swarmgames.experiments.fig1 import break_points, fig1_positions, reproduce_fig1

# docs/reference.md section 4 (ns-3, tables read at 30 s): spacing -> (direct neighbours, hops).
NS3_LINE = {
    50: (6.000, 1.000),
    100: (4.286, 1.286),
    150: (3.143, 1.619),
    184: (3.143, 1.619),
    185: (1.714, 2.667),
    368: (1.714, 2.667),
    369: (0.0, None),
}
NS3_HEX = {
    100: (6.000, 1.000),
    184: (6.000, 1.000),
    185: (5.143, 1.143),
    212: (5.143, 1.143),
    250: (3.429, 1.429),
    368: (3.429, 1.429),
    369: (0.0, None),
}


@pytest.fixture(scope="module")
def fig1():
    spacings = sorted(set(NS3_LINE) | set(NS3_HEX) | {213})
    return reproduce_fig1(spacings=spacings, seed=0).to_frame()


@pytest.mark.parametrize(
    "layout, spacing, expected",
    [("line", d, v) for d, v in NS3_LINE.items()] + [("hexagon", d, v) for d, v in NS3_HEX.items()],
)
def test_fig1_equals_ns3(fig1, layout, spacing, expected):
    row = fig1[(fig1["layout"] == layout) & (fig1["spacing_m"] == spacing)].iloc[0]
    assert round(row["mean_neighbours"], 3) == expected[0]
    if expected[1] is None:
        assert np.isnan(row["mean_hops"]) and row["routes"] == 0
    else:
        assert round(row["mean_hops"], 3) == expected[1]


def test_hexagon_break_at_212_213(fig1):
    # sqrt(3) * 212.9 m = 368.84 m: the ring's second neighbours drop out past 212.9 m.
    f = fig1[fig1["layout"] == "hexagon"].set_index("spacing_m")
    assert f.loc[212.0, "mean_neighbours"] > f.loc[213.0, "mean_neighbours"]
    assert round(f.loc[213.0, "mean_neighbours"], 3) == 3.429


def test_default_sweep_shows_every_break_point():
    bps = break_points()
    assert [round(x, 2) for x in bps["hexagon"]] == [184.42, 212.95, 368.84]
    spacings = np.arange(10.0, 401.0, 1.0)
    for values in bps.values():
        for b in values:
            # A 1 m grid puts a sample within 1 m on each side of every step.
            assert (b - spacings[spacings < b].max()) <= 1.0
            assert (spacings[spacings > b].min() - b) <= 1.0


def test_oracle_backend_agrees_after_settling():
    a = reproduce_fig1("oracle", spacings=[100.0, 185.0, 250.0]).to_frame()
    b = reproduce_fig1("olsr", spacings=[100.0, 185.0, 250.0]).to_frame()
    pd.testing.assert_frame_equal(a, b)


def test_plot_and_write(tmp_path):
    calls = []
    res = reproduce_fig1(
        spacings=[100.0, 200.0, 400.0], out=tmp_path / "fig1", progress=lambda *a: calls.append(a)
    )
    assert calls[-1] == (6, 6) and len(calls) == 6
    assert (tmp_path / "fig1" / "fig1.csv").exists() and (tmp_path / "fig1" / "fig1.png").exists()
    fig = res.plot()
    assert len(fig.axes) == 4  # two panels, each with a second y-axis
    assert list(res.to_frame().columns) == [
        "layout",
        "spacing_m",
        "mean_neighbours",
        "mean_hops",
        "routes",
    ]


def test_positions():
    hexagon = fig1_positions("hexagon", 100.0)
    d = np.linalg.norm(hexagon[1:] - hexagon[0], axis=1)
    assert np.allclose(d, 100.0)
    assert np.allclose(np.linalg.norm(hexagon[1] - hexagon[2]), 100.0)


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"spacings": [-1.0]}, "spacings must be"),
        ({"spacings": []}, "spacings must be"),
        ({"layouts": ("circle",)}, "layout must be one of line, hexagon"),
        ({"settle_s": 0.0}, "settle_s must be > 0"),
    ],
)
def test_bad_arguments(kwargs, match):
    with pytest.raises(ValueError, match=match):
        reproduce_fig1(**kwargs)


def test_default_sweep_finds_every_ns3_break_point():
    # docs/reference.md section 4: line 184/185 and 368/369 m; hexagon 184/185, 212/213, 368/369 m.
    # The line also steps where the 3rd..6th neighbours along it drop out (R/3 ... R/6).
    steps = reproduce_fig1(seed=1).steps()
    assert steps["hexagon"] == [(184.0, 185.0), (212.0, 213.0), (368.0, 369.0)]
    assert steps["line"] == [
        (61.0, 62.0),
        (73.0, 74.0),
        (92.0, 93.0),
        (122.0, 123.0),
        (184.0, 185.0),
        (368.0, 369.0),
    ]
