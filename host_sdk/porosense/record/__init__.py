"""Ground truth from a camera: track an actuator in video and place it on the board's clock.

- :mod:`.layout` -- where things are in the image (regions) and the scale (reference length)
- :mod:`.calibration` -- checkerboard camera calibration, lens undistortion, image -> plane mm
- :mod:`.circle` -- circle fit of stripe centres (algebraic, then geometric least squares)
- :mod:`.detect` -- dark-blob detection robust to uneven lighting
- :mod:`.video` -- frames from a camera or a file, one-line errors
- :mod:`.tracker` -- per-frame curvature (1/m), marker displacement dz (mm), indicator level
- :mod:`.blinks` -- the board's sync indicator pattern (firmware/lib/core/sync_blink.h)
- :mod:`.sync` -- blinks in the video -> camera-to-board clock offset and drift
- :mod:`.truth` -- tracked values resampled on the board's sample times (a Recording)
"""
