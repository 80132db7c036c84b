"""Axis labels with units for the columns of a run's tables and a sweep's figures.

Column names carry their unit as a suffix (``goal_distance_m``, ``coverage_end_dbm``,
``mean_speed_m_s``); the few that do not are listed in :data:`UNITS`. The figures of a run and
of a sweep read their labels here, so a unit is written the same way everywhere.

Examples
--------
>>> column_label("coverage_end_dbm")
'coverage end (dBm)'
>>> column_label("mean_speed_m_s")
'mean speed (m/s)'
"""

from __future__ import annotations

__all__ = ["UNITS", "column_label", "column_unit"]

#: Units of the columns whose name does not end in one.
UNITS = {"coverage": "dBm", "bytes_per_robot": "bytes", "mean_info_age_s": "s"}

#: Name suffixes and the units they stand for, longest first.
_SUFFIXES = (
    ("_bytes_per_robot_stage", "bytes"),
    ("_m_s", "m/s"),
    ("_dbm", "dBm"),
    ("_db", "dB"),
    ("_ms", "ms"),
    ("_m", "m"),
    ("_s", "s"),
)


def column_unit(name: str) -> tuple[str, str]:
    """``(words, unit)`` of a column name: the name without its unit suffix, underscores as
    spaces, and the unit ('' when it has none)."""
    if name in UNITS:
        return name.replace("_", " "), UNITS[name]
    for suffix, unit in _SUFFIXES:
        if name.endswith(suffix) and len(name) > len(suffix):
            return name[: -len(suffix)].replace("_", " "), unit
    return name.replace("_", " "), ""


def column_label(name: str) -> str:
    """An axis label for a column: its words and, if it has one, its unit in brackets."""
    words, unit = column_unit(name)
    return f"{words} ({unit})" if unit else words
