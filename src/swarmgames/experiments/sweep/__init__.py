"""``swarmgames sweep``: a scenario over a grid of overrides and seeds, one run folder per run,
the results, their means and 95 % confidence intervals per group, paired differences between
a factor's levels on the same seeds, and plots (docs/sweep.md).

* :mod:`~swarmgames.experiments.sweep.grid`: the factors, their combinations, validation and
  the run folders' names;
* :mod:`~swarmgames.experiments.sweep.executors`: this process, local processes or Ray;
* :mod:`~swarmgames.experiments.sweep.stats`: aggregates and paired differences;
* :mod:`~swarmgames.experiments.sweep.plots`: a figure per metric;
* :mod:`~swarmgames.experiments.sweep.run`: :func:`sweep`, resuming, the sweep's files.
"""

from swarmgames.experiments.sweep.grid import factors_from_assignments, plan_sweep
from swarmgames.experiments.sweep.plots import plot_metric
from swarmgames.experiments.sweep.run import sweep, write_tables
from swarmgames.experiments.sweep.stats import aggregate, paired_differences

__all__ = [
    "aggregate",
    "factors_from_assignments",
    "paired_differences",
    "plan_sweep",
    "plot_metric",
    "sweep",
    "write_tables",
]
