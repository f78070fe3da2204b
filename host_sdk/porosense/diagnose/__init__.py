"""Diagnosis: what a simulation or model gets wrong, why, the extended model, and the gain.

    from porosense.diagnose import Record, diagnose
    d = diagnose([Record(u, y, yhat, ts)], [Record(u_val, y_val, yhat_val, ts)])
    d.top, d.findings[0].evidence, d.to_json("out.json"), d.plot("report/")

See :mod:`.engine` for the procedure, :mod:`.stats` for the residual tests and their
false-alarm levels, :mod:`.extensions` for the extension of each cause.
"""

from porosense.diagnose.catalogue import CAUSES, DESCRIPTION, NONE
from porosense.diagnose.engine import Diagnosis, Finding, Record, diagnose, predict_as_started, predict_at_rest_level

__all__ = [
    "CAUSES",
    "DESCRIPTION",
    "NONE",
    "Diagnosis",
    "Finding",
    "Record",
    "diagnose",
    "predict_as_started",
    "predict_at_rest_level",
]
