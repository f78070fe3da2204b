"""porosense: proprioception for 3D-printed graded-porosity soft vacuum actuators.

Subpackages (one concept each; lower layers never import higher ones):

- ``porosense.protocol``  frames and messages of the wire protocol
- ``porosense.sim``       actuator physics and the paper's experiment schedules
- ``porosense.data``      the Recording type and its CSV/JSON/.mat I/O
- ``porosense.ident``     linear, Hammerstein, Wiener and Wiener-Hammerstein identification
- ``porosense.quant``     fixed-point design and the bit-exact firmware reference
- ``porosense.diagnose``  residual analysis, named causes, model extensions
- ``porosense.device``    the Device client over any pyserial URL
- ``porosense.firmware``  the firmware as package data, its host library and upload
- ``porosense.emulator``  the board without hardware: the firmware core over the simulator
- ``porosense.report``    figures and reports
- ``porosense.cli``       the ``porosense`` command

For MATLAB users: ``porosense.Dataset`` (iddata), ``porosense.fit``, ``predict``, ``compare`` and
``resid`` (docs/matlab.md).
"""

from porosense._version import __version__
from porosense.errors import PorosenseError

# MATLAB-style commands on a Dataset (iddata), imported on first use: `import porosense` stays light
# (the command line starts from it) until one of them is asked for.
_LAZY = {
    "Dataset": "porosense.data.dataset",
    "fit": "porosense.ident.iddata",
    "predict": "porosense.ident.iddata",
    "compare": "porosense.ident.iddata",
    "resid": "porosense.ident.iddata",
}

__all__ = ["__version__", "PorosenseError", *_LAZY]


def __getattr__(name):
    if name in _LAZY:
        import importlib

        return getattr(importlib.import_module(_LAZY[name]), name)
    raise AttributeError(f"module 'porosense' has no attribute {name!r}")
