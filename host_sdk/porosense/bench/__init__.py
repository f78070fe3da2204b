"""Benchmarks behind ``porosense bench AREA [--json] [--size small|full]``.

Each area is a module ``porosense.bench.<area>`` exposing ``run(size: str) -> dict`` whose
result holds the figures (plain JSON types) and, under ``"summary"``, one line per figure
for people. ``size="small"`` is the CI-sized run; ``"full"`` the figure the issues quote.
"""

AREAS = ("protocol", "sim", "paper", "ident", "firmware", "device", "quant", "diagnose", "record", "control")
