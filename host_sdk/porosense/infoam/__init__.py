"""Print planning for graded-porosity actuators by liquid rope coiling (the InFoam method).

calibrate the machine and material -> describe a design as regions of target porosity ->
plan and write G-code for a machine profile (with a preview) -> predict stroke and
sensitivity with the simulator; printable holders and frames as STL (``parts``).
"""

from porosense.infoam.calibration import (
    PAPER_COIL_RADIUS,
    CoilRadiusFit,
    PorosityModel,
    paper_calibration,
    porosity_from_mass,
)
from porosense.infoam.design import (
    Annulus,
    Circle,
    Design,
    Rect,
    Region,
    get_design,
    paper_bending,
    paper_contractor,
    paper_segment,
)
from porosense.infoam.gcode import PrintJob, PrintSettings, generate
from porosense.infoam.gcode_reader import GcodeSummary, read_gcode
from porosense.infoam.predict import Prediction, predict
from porosense.infoam.profiles import Machine, Material, list_machines, load_machine, load_material

__all__ = [
    "PAPER_COIL_RADIUS",
    "CoilRadiusFit",
    "PorosityModel",
    "paper_calibration",
    "porosity_from_mass",
    "Annulus",
    "Circle",
    "Design",
    "Rect",
    "Region",
    "get_design",
    "paper_bending",
    "paper_contractor",
    "paper_segment",
    "PrintJob",
    "PrintSettings",
    "generate",
    "GcodeSummary",
    "read_gcode",
    "Prediction",
    "predict",
    "Machine",
    "Material",
    "list_machines",
    "load_machine",
    "load_material",
]
