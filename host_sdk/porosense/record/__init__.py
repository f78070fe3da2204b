"""Ground truth from a camera: track an actuator in video and place it on the board's clock.

- :mod:`.layout` -- where things are in the image (regions) and the scale (reference length)
- :mod:`.calibration` -- checkerboard camera calibration, lens undistortion, image -> plane mm
- :mod:`.circle` -- circle fit of stripe centres (algebraic, then geometric least squares)
- :mod:`.detect` -- dark-blob detection robust to uneven lighting
- :mod:`.video` -- frames from a camera or a file, one-line errors
- :mod:`.capture` -- live camera to a video file with host timestamps, beside a board run
- :mod:`.tracker` -- per-frame curvature (1/m), marker displacement dz (mm), indicator level
- :mod:`.blinks` -- the board's sync indicator pattern (firmware/lib/core/sync_blink.h); its
  level on any back-end (real board, simboard, emulator) from the sample times
- :mod:`.sync` -- blinks in the video -> camera-to-board clock offset and drift
- :mod:`.truth` -- tracked values resampled on the board's sample times (a Recording)
"""

from porosense.record.blinks import board_edges, board_levels, indicator_level
from porosense.record.calibration import Calibration, calibrate
from porosense.record.circle import CircleFit, fit_circle
from porosense.record.layout import Layout
from porosense.record.sync import ClockFit, fit_clock, host_clock
from porosense.record.tracker import Track, track_video
from porosense.record.truth import add_truth

__all__ = [
    "Calibration",
    "CircleFit",
    "ClockFit",
    "Layout",
    "Track",
    "add_truth",
    "board_edges",
    "board_levels",
    "calibrate",
    "fit_circle",
    "fit_clock",
    "host_clock",
    "indicator_level",
    "track_video",
]
