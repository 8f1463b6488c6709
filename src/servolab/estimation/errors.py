"""The estimation layer's errors.

Every error of the filters is about a value they were given (a covariance that is not
positive definite, a measurement of the wrong shape, a sensor they do not know), so it is an
:class:`EstimationValueError`: bad input, ``servolab`` exits 2.
"""

from __future__ import annotations

from ..errors import ServolabError


class EstimationError(ServolabError):
    """Base of every error raised by :mod:`servolab.estimation`."""


class EstimationValueError(EstimationError, ValueError):
    """A model, covariance, measurement or time step a filter cannot use; the message names
    it."""
