"""Figures of sound fields, written to files with matplotlib's Agg backend (no display needed).

- :mod:`sonolux.plotting.responses`: echograms per azimuth sector (the paper's figure 7) and
  energy decay curves per band, for one receiver.
- :mod:`sonolux.plotting.maps`: parameter maps over the floor plan, x along the plot's width
  and y up, with the room's outline at the receivers' height and the sources.
"""

from __future__ import annotations

from typing import Any


def pyplot() -> Any:
    """matplotlib.pyplot on the Agg backend (files only; imported on first use)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt
