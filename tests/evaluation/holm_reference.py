"""statsmodels' Holm adjustment, the reference ours is held to, without the ``gc.collect()`` statsmodels runs on
every Holm call: in a test process that already holds thousands of tests' objects each collection cost about
0.3 s, and a property test's 25 examples cost 15 s of CPU."""

from __future__ import annotations

from collections.abc import Sequence
from unittest import mock

from statsmodels.stats import multitest


def statsmodels_holm(ps: Sequence[float]) -> list[float]:
    """Holm-adjusted p-values by statsmodels' ``multipletests`` (its arithmetic, untouched)."""
    with mock.patch("gc.collect", lambda *_: 0):  # statsmodels imports gc inside the function
        return [float(p) for p in multitest.multipletests(list(ps), method="holm")[1]]
