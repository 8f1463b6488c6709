"""The step of a damped least-squares (Levenberg-Marquardt) solver whose variables have bounds.

Clipping the unbounded step into the box is not the best step in the box: with a joint at a
limit, the free step may push it further out while the other joints still have somewhere to
go, and clipping then stalls the solver. :func:`bounded_step` solves the damped subproblem
over the box itself, by a small active set: fix the variables whose step leaves the box at the
bound they cross, solve for the rest, and free again a fixed one whose pull points back
inside. It starts with the variables already at a bound that the steepest descent pushes out
fixed, which is most often the answer: about 1.5 solves a step in the OpenMANIPULATOR-X's IK.

In plain Python on lists: for the handful of joints of an arm, NumPy's call overhead (some
microseconds a call: ``np.linalg.solve`` of a 4x4 costs more than a Cholesky in Python) is
most of the cost, and an IK solve takes tens of these steps.
"""

from __future__ import annotations

import math
from collections.abc import Sequence


def bounded_step(normal: Sequence[Sequence[float]], gradient: Sequence[float], damping: float,
                 low: Sequence[float], high: Sequence[float]) -> list[float]:
    """The ``step`` minimising ``|J step - e|² + damping |step|²`` with ``low <= step <=
    high`` (``low <= 0 <= high``; infinite bounds allowed), given ``normal = JᵀJ`` and
    ``gradient = Jᵀe``: ``(normal + damping I) step = gradient`` on the free variables."""
    n = len(gradient)
    matrix = [[float(normal[i][j]) + (damping if i == j else 0.0) for j in range(n)]
              for i in range(n)]
    fixed = {i: 0.0 for i in range(n)
             if (low[i] == 0.0 and gradient[i] < 0.0) or (high[i] == 0.0 and gradient[i] > 0.0)}
    step = [0.0] * n
    for _ in range(2 * n + 2):
        free = [i for i in range(n) if i not in fixed]
        rest = [gradient[i] - sum(matrix[i][j] * v for j, v in fixed.items()) for i in free]
        for i, v in zip(free, _solve([[matrix[i][j] for j in free] for i in free], rest),
                        strict=True):
            step[i] = v
        for i, v in fixed.items():
            step[i] = v
        out = {i: (low[i] if step[i] < low[i] else high[i]) for i in free
               if not low[i] <= step[i] <= high[i]}
        if out:
            fixed.update(out)
            continue
        # a fixed variable whose pull (gradient - matrix @ step) points back into the box
        pulls = {i: gradient[i] - sum(matrix[i][j] * step[j] for j in range(n)) for i in fixed}
        back = [i for i, pull in pulls.items()
                if (pull > 0 and fixed[i] < high[i]) or (pull < 0 and fixed[i] > low[i])]
        if not back:
            break
        del fixed[max(back, key=lambda i: abs(pulls[i]))]
    return [min(max(v, low[i]), high[i]) for i, v in enumerate(step)]


def _solve(matrix: list[list[float]], rhs: list[float]) -> list[float]:
    """``matrix⁻¹ rhs`` for a symmetric positive definite ``matrix`` (Cholesky; explicit loops
    rather than ``sum`` over generators, which cost three times as much at this size)."""
    n = len(rhs)
    lower = [row[:] for row in matrix]
    for j in range(n):
        row_j = lower[j]
        diagonal = row_j[j]
        for k in range(j):
            diagonal -= row_j[k] * row_j[k]
        diagonal = math.sqrt(diagonal) if diagonal > 1e-300 else 1e-150
        row_j[j] = diagonal
        for i in range(j + 1, n):
            row_i = lower[i]
            total = row_i[j]
            for k in range(j):
                total -= row_i[k] * row_j[k]
            row_i[j] = total / diagonal
    out = list(rhs)
    for i in range(n):
        row_i = lower[i]
        total = out[i]
        for k in range(i):
            total -= row_i[k] * out[k]
        out[i] = total / row_i[i]
    for i in reversed(range(n)):
        total = out[i]
        for k in range(i + 1, n):
            total -= lower[k][i] * out[k]
        out[i] = total / lower[i][i]
    return out
