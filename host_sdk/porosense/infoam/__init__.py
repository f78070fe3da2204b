"""Print planning for graded-porosity actuators by liquid rope coiling (the InFoam method).

calibrate the machine and material -> describe a design as regions of target porosity ->
plan and write G-code (with a preview) -> predict stroke and sensitivity with the simulator.
"""

from porosense.infoam.calibration import (
    PAPER_COIL_RADIUS,
    CoilRadiusFit,
    Machine,
    Material,
    PorosityModel,
    paper_calibration,
    porosity_from_mass,
)
from porosense.infoam.design import Circle, Design, Rect, Region, get_design, paper_bending, paper_contractor
from porosense.infoam.gcode import PrintJob, PrintSettings, generate
from porosense.infoam.gcode_reader import GcodeSummary, read_gcode
from porosense.infoam.predict import Prediction, predict

__all__ = [
    "PAPER_COIL_RADIUS", "CoilRadiusFit", "Machine", "Material", "PorosityModel", "paper_calibration",
    "porosity_from_mass", "Circle", "Design", "Rect", "Region", "get_design", "paper_bending",
    "paper_contractor", "PrintJob", "PrintSettings", "generate", "GcodeSummary", "read_gcode",
    "Prediction", "predict",
]
