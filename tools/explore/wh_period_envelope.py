"""Does the process noise of the measured WH benchmark leave a time-varying envelope in the
period differences?

Noise entering before g passes through g's local slope, so where H1's output sweeps g's kinks
the period differences d = y_(k+1) - y_k should swell and shrink with it, and their envelope
would carry H1 and g independently of the noise's colour. Printed per realisation: the
coefficient of variation of d^2 smoothed over W samples, divided by the same for 20
phase-randomised copies of d (same spectrum, stationary); a ratio near 1 means no envelope
beyond chance. Then the correlation of the envelope with the period-averaged output.
Run: .venv/bin/python tools/explore/wh_period_envelope.py
"""

import sys

import numpy as np
from scipy.ndimage import uniform_filter1d
from wh_benchmark import records

PERIOD = 4096
SKIP = 200


def main() -> int:
    us, ys, _, _ = records(10)
    rng = np.random.default_rng(0)
    for w in (16, 64, 256):
        ratios = []
        for y in ys:
            d = y[PERIOD + SKIP : 2 * PERIOD] - y[SKIP:PERIOD]
            env = uniform_filter1d(d**2, w)
            surrogate = []
            for _ in range(20):
                spec = np.fft.rfft(d) * np.exp(2j * np.pi * rng.random(len(d) // 2 + 1))
                s = uniform_filter1d(np.fft.irfft(spec, len(d)) ** 2, w)
                surrogate.append(np.std(s) / np.mean(s))
            ratios.append((np.std(env) / np.mean(env)) / np.mean(surrogate))
        print(f"window {w:3d} samples: envelope variation / stationary {np.round(ratios, 2).tolist()}")
    for i, y in enumerate(ys[:3]):
        d = y[PERIOD + SKIP : 2 * PERIOD] - y[SKIP:PERIOD]
        mean = (y[PERIOD + SKIP : 2 * PERIOD] + y[SKIP:PERIOD]) / 2
        print(
            f"realisation {i}: correlation of the envelope (64 samples) with the mean output "
            f"{np.corrcoef(uniform_filter1d(d**2, 64), mean)[0, 1]:+.3f}; std of d {np.std(d) * 1e3:.0f} mV, "
            f"of the mean output {np.std(mean) * 1e3:.0f} mV"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
