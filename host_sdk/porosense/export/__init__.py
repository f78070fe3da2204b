"""Models out of porosense: standalone C code and python-control transfer functions.

- :func:`c_source` -- one C file (no dependencies, no allocation) with ``<name>_init`` and
  ``<name>_step`` that run the estimator one sample at a time, in double precision by
  default (``-DPOROSENSE_REAL=float`` for a small MCU).
- :func:`control_blocks` / :func:`write_control` -- each model's linear blocks as
  ``control.TransferFunction`` (dt = Ts), its static nonlinearities as breakpoints.
- :func:`matlab_variables` / :func:`write_mat` -- the same blocks as MATLAB variables (a .mat
  file that docs/matlab.md turns into ``idtf``/``idnlhw`` objects).
"""

from porosense.export.c_code import c_source
from porosense.export.control_tf import control_blocks, write_control
from porosense.export.matlab import matlab_variables, write_mat

__all__ = ["c_source", "control_blocks", "matlab_variables", "write_control", "write_mat"]
