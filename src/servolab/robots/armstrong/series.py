"""What a walk keeps in memory to plot: samples in a fixed space, however long it runs.

Why: ``servolab walk`` used to append every command sent, every joint state heard and every
motor's temperature and load after every sweep to Python lists, about 13 kB a row played;
``walk --steps 2000`` grew by 100 MB in 90 s and a day's walk would not have fit. The bag
keeps every message (on disk); the plots need no more points than they have pixels. So each
series here holds at most ``capacity`` samples: when it is full every other sample is
dropped and from then on only every ``stride``-th sample is taken (the stride doubles), so the
samples kept are evenly spread over the whole run, the first always among them, and a short
run (a walk of a few steps: fewer samples than ``capacity``) keeps every one. What must be
exact over a run of any length (the largest tracking error) is measured as the samples come,
not from these.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from ..errors import RobotValueError

#: Samples a series keeps at most: a plot 10 inches wide at 100 dpi has 1000 pixels.
CAPACITY = 2048


class Series:
    """``(t, value, ...)`` samples, at most ``capacity`` of them (see the module docstring);
    a value of None is kept as NaN (a plot leaves a gap)."""

    __slots__ = ("_data", "_kept", "seen", "stride")

    def __init__(self, columns: int = 1, capacity: int = CAPACITY) -> None:
        if capacity < 2 or capacity % 2:
            raise RobotValueError(f"series capacity must be even and >= 2, not {capacity}")
        # filled now: the memory is taken at the start, not page by page as the run goes on
        self._data = np.full((capacity, 1 + columns), np.nan, dtype=np.float64)
        self._kept = 0
        #: samples appended (kept or not); every ``stride``-th of them is kept
        self.seen = 0
        self.stride = 1

    def append(self, t: float, *values: float | None) -> None:
        index, self.seen = self.seen, self.seen + 1
        if index % self.stride:
            return
        if self._kept == len(self._data):  # full: keep every other sample, take half as many
            half = self._data[::2]
            self._data[:len(half)] = half
            self._kept = len(half)
            self.stride *= 2
            if index % self.stride:
                return
        row = self._data[self._kept]
        row[0] = t
        row[1:] = [np.nan if v is None else v for v in values]
        self._kept += 1

    def __len__(self) -> int:
        """The samples kept (at most the capacity)."""
        return self._kept

    @property
    def capacity(self) -> int:
        return len(self._data)

    @property
    def t(self) -> npt.NDArray[np.float64]:
        """The kept samples' times (a copy)."""
        return self._data[:self._kept, 0].copy()

    def values(self, column: int = 0) -> npt.NDArray[np.float64]:
        """The kept samples' ``column``-th values (a copy)."""
        return self._data[:self._kept, 1 + column].copy()
