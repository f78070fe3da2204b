"""System identification: linear, Hammerstein, Wiener and Wiener-Hammerstein models.

Discrete-time MISO models per output, estimated on simulation error jointly over several
recordings, stable by construction, with the paper's order search and selection. Every model
converts to :class:`porosense.structure.EstimatorStructure` (what quant and the firmware run).
"""

from porosense.ident.candidates import Candidate, SearchResult, approx_blob_bytes, tie_tolerance
from porosense.ident.identify import Identification, identify
from porosense.ident.metrics import fit_percent, information_criteria, rms_percent, rmse
from porosense.ident.models import (
    KINDS,
    Hammerstein,
    Linear,
    Model,
    ModelSet,
    Wiener,
    WienerHammerstein,
    make_model,
    save_models,
)
from porosense.ident.options import CRITERIA, STRUCTURES, SearchOptions, order_grid
from porosense.ident.scoring import SimulationFit, format_percent, simulation_fit
from porosense.ident.search import search
from porosense.ident.smoothness import SmoothnessChoice, choose_smoothness
from porosense.ident.storage import load_model

__all__ = [
    "CRITERIA",
    "KINDS",
    "Candidate",
    "SmoothnessChoice",
    "choose_smoothness",
    "Hammerstein",
    "Identification",
    "identify",
    "Linear",
    "Model",
    "ModelSet",
    "SearchOptions",
    "SearchResult",
    "SimulationFit",
    "STRUCTURES",
    "Wiener",
    "WienerHammerstein",
    "approx_blob_bytes",
    "fit_percent",
    "format_percent",
    "information_criteria",
    "load_model",
    "make_model",
    "order_grid",
    "rms_percent",
    "rmse",
    "save_models",
    "search",
    "tie_tolerance",
    "simulation_fit",
]
