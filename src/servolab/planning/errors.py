"""The planning layer's errors.

Value errors are bad input (a cost below 1, a cell outside the grid, a DWA parameter out of
range), refused before anything is planned: ``servolab`` exits 2 for them. :class:`NoPath`
is not one: the grid and both ends were good, the map just has no way through, so it is a
failure at run time (exit 1), as it is for a navigator that waits for a way to open.
"""

from __future__ import annotations

from ..errors import ServolabError


class PlanningError(ServolabError):
    """Base of every error raised by :mod:`servolab.planning`."""


class PlanningValueError(PlanningError, ValueError):
    """A grid, cell, costmap or parameter a planner cannot use; the message names it."""


class NoPath(PlanningError):
    """No path joins the start to the goal (the start's distance to the goal is infinite).
    Not a ValueError: nothing given was wrong, and cells may free later."""
