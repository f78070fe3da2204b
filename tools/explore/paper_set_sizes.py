"""Blob sizes of the paper's 3-DoF model set against the model stores.

Twenty random structures at the paper's orders (three 3-input Wiener-Hammerstein models, 2 poles
per block, 10 breakpoints; porosense.quant.random_models, seeds 0..19), quantised on (-90, 10) %
dR with full tables (no capacity limit) and for a flash slot (compact tables when full ones do
not fit). Prints the ranges and the room left in one flash slot and in the EEPROM area.
Run: .venv/bin/python tools/explore/paper_set_sizes.py
"""

import numpy as np

from porosense.protocol import model_layout as layout
from porosense.quant.quantize import quantize
from porosense.quant.random_models import random_structure


def main() -> None:
    full, slot = [], []
    for seed in range(20):
        s = random_structure(np.random.default_rng(seed), 3, 3, h1_poles=2, h2_poles=2, breakpoints=10, kind="wh")
        full.append(len(quantize(s, input_range=(-90.0, 10.0), capacity=4096, noise_lsb=0).blob.to_bytes()))
        slot.append(
            len(quantize(s, input_range=(-90.0, 10.0), capacity=layout.FLASH_BLOB_MAX, noise_lsb=0).blob.to_bytes())
        )
    print(f"full tables: {min(full)}..{max(full)} B")
    print(
        f"for a {layout.FLASH_BLOB_MAX}-byte flash slot: {min(slot)}..{max(slot)} B, "
        f"{layout.FLASH_BLOB_MAX - max(slot)}..{layout.FLASH_BLOB_MAX - min(slot)} B to spare per slot"
    )
    print(f"EEPROM area {layout.MAX_BLOB_LEN} B: holds {sum(n <= layout.MAX_BLOB_LEN for n in slot)} of 20 alone")


if __name__ == "__main__":
    main()
