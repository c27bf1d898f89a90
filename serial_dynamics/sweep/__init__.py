"""Scale-out on Dask: any function over many cases (``run``), the robustness of a controller
under model uncertainty (``monte_carlo``), identification over many recordings
(``identify_recordings``), and studies from a YAML spec (``spec``: ``serial-dynamics
sweep``). docs/scale.md. Needs the ``cluster`` extra (dask[distributed], pandas, pyarrow).
"""
from .identification import identify_recordings
from .robustness import Study, draw, monte_carlo, plot, summary
from .run import run

__all__ = ["run", "monte_carlo", "identify_recordings", "Study", "draw", "summary", "plot"]
