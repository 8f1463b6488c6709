"""Fuzzing as a habit (issue 45): every parser of outside input has a hypothesis fuzzer,
marked ``fuzz``. ``make test`` runs each briefly; ``benchmarks/fuzz.py`` runs them all
``SERVOLAB_FUZZ_SCALE`` times longer and prints the inputs tried and the failures found."""

from __future__ import annotations

import os

from hypothesis import HealthCheck, settings


def scale() -> int:
    """How many times the suite's number of examples a fuzzer tries (1 in ``make test``)."""
    text = os.environ.get("SERVOLAB_FUZZ_SCALE", "1")
    try:
        value = int(text)
    except ValueError:
        raise ValueError(f"SERVOLAB_FUZZ_SCALE={text!r} is not a whole number") from None
    if value < 1:
        raise ValueError(f"SERVOLAB_FUZZ_SCALE={value} must be 1 or more")
    return value


def fuzzing(examples: int) -> settings:
    """A fuzzer's hypothesis settings: ``examples`` in the suite, times :func:`scale` in the
    long run; no deadline (a loaded CI machine is slow, not wrong)."""
    return settings(max_examples=examples * scale(), deadline=None,
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
