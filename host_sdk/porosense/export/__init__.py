"""Models out of porosense: standalone C code and python-control transfer functions.

- :func:`c_source` -- one C file (no dependencies, no allocation) with ``<name>_init`` and
  ``<name>_step`` that run the estimator one sample at a time, in double precision by
  default (``-DPOROSENSE_REAL=float`` for a small MCU).
- :func:`control_blocks` / :func:`write_control` -- each model's linear blocks as
  ``control.TransferFunction`` (dt = Ts), its static nonlinearities as breakpoints.
"""

from porosense.export.c_code import c_source
from porosense.export.control_tf import control_blocks, write_control

__all__ = ["c_source", "control_blocks", "write_control"]
