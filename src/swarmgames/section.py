"""The base of every validated configuration section.

Configuration sections are pydantic models that are immutable and reject unknown keys. The
scenario schema (:mod:`swarmgames.config.schema`) builds its sections on :class:`Section`, and
so does every mission's own section (:mod:`swarmgames.missions`): a plug-in's ``[mymission]``
table is validated by the same rules and reported in the same one-line-per-problem form as
the built-in ones.
"""

from __future__ import annotations

from typing import Annotated, Any

from pydantic import BaseModel, ConfigDict, Field

__all__ = ["MAX_COORDINATE_M", "Coordinate", "Section"]

#: Largest coordinate of a point of a scenario, metres: 10 000 km, so that the squared
#: distances of the radio model and the payoffs stay finite far beyond any swarm.
MAX_COORDINATE_M = 1e7

#: A coordinate (x or y) of a point of a scenario, metres, within +-:data:`MAX_COORDINATE_M`.
Coordinate = Annotated[float, Field(ge=-MAX_COORDINATE_M, le=MAX_COORDINATE_M)]


class Section(BaseModel):
    """A configuration section: immutable, strict about unknown keys, defaults validated,
    every float finite (NaN and infinities are rejected, in tuples and optional fields too).

    Examples
    --------
    >>> from pydantic import Field
    >>> class Goal(Section):
    ...     radius_m: float = Field(10.0, gt=0, description="Gathering radius, metres.")
    >>> Goal().radius_m
    10.0
    """

    model_config = ConfigDict(
        extra="forbid", frozen=True, validate_default=True, allow_inf_nan=False
    )

    def check_scenario(self, scenario) -> None:
        """Rules that span this section and the rest of ``scenario`` (a mission's section
        against ``[game]`` or ``[swarm]``, for example); the scenario's validation calls it,
        so ``config check`` and ``run`` agree. Raise ``ValueError`` with a message that
        names the fields, the rule and the values. The base class has none."""

    def derive(self, scenario) -> dict[str, dict[str, Any]]:
        """Fields of the scenario that this section derives from the rest of it, at
        validation time: ``{section: {field: value}}``, ``section`` an attribute of the
        scenario (``"swarm"``, or ``"mission"`` for this section itself). The scenario's
        validation replaces them before its cross-section rules run, and a scenario written
        back (``config show``, a run's ``config.toml``, ``with_overrides``) leaves them out,
        so that it reads back equal and derives them again from the new values of an
        override. Raise ``ValueError`` naming the fields when a derived field was also given
        explicitly (``model_fields_set``). The base class derives nothing."""
        return {}
