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

from swarmgames.lazy import lazy_names

__all__ = [
    "aggregate",
    "factors_from_assignments",
    "paired_differences",
    "plan_sweep",
    "plot_metric",
    "sweep",
    "write_tables",
]

#: Where each public name lives: imported on first use, so that a sweep's worker process,
#: which imports only :mod:`~swarmgames.experiments.sweep.executors`, loads neither pandas'
#: statistics nor matplotlib.
_HOMES = {
    "aggregate": "stats",
    "factors_from_assignments": "grid",
    "paired_differences": "stats",
    "plan_sweep": "grid",
    "plot_metric": "plots",
    "sweep": "run",
    "write_tables": "run",
}


__getattr__, __dir__ = lazy_names(__name__, _HOMES, __all__)
