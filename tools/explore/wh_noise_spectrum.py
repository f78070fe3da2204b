"""The noise path against the whole path of the measured WH benchmark, band by band.

The difference between the two periods of each realisation holds the process noise alone,
passed through g and H2; the best linear approximation (period-averaged output over input, at
the excited lines) holds H1 H2. Printed per band: the difference's power and the BLA's gain
(dB), and each one's drop below its own level in the band 300-1200 Hz. If the process noise is
white over the band, the ratio of the drops is the share of the roll-off that H2 carries.
Run: .venv/bin/python tools/explore/wh_noise_spectrum.py [realisations, default 10]
"""

import sys

import numpy as np
from wh_benchmark import records

from porosense.ident.noise_level import repeated_period

FS = 78125.0  # Hz
EDGES = (300, 1200, 1600, 2000, 2500, 3000, 3500, 4000, 4500, 5000, 5500, 6000, 7000, 9000, 12000)  # Hz


def main() -> int:
    n = int(sys.argv[1]) if len(sys.argv) > 1 else 10
    us, ys, _, _ = records(n)
    period = repeated_period(us[0])
    noise, u_pow, frfs = 0.0, 0.0, []
    for u, y in zip(us, ys):
        u = u[:, 0]
        noise = noise + np.abs(np.fft.rfft(y[period : 2 * period] - y[:period])) ** 2
        uf = np.fft.rfft(u[period : 2 * period] + u[:period])
        yf = np.fft.rfft(y[period : 2 * period] + y[:period])
        u_pow = u_pow + np.abs(uf) ** 2
        frfs.append(yf / np.where(np.abs(uf) > 0, uf, np.nan))
    f = np.fft.rfftfreq(period, 1 / FS)
    excited = u_pow > 1e-3 * u_pow.max()
    gain = np.abs(np.nanmean(np.array(frfs), axis=0))

    def band(a, b):
        m = (f >= a) & (f < b)
        return 10 * np.log10(np.mean(noise[m])), 20 * np.log10(np.mean(gain[m & excited]))

    n0, g0 = band(EDGES[0], EDGES[1])
    print(f"{n} realisations, period {period} samples; drops below the {EDGES[0]}-{EDGES[1]} Hz band")
    print(f"{'band (Hz)':>14}{'noise dB':>10}{'BLA dB':>9}{'noise drop':>12}{'BLA drop':>10}{'ratio':>7}")
    for a, b in zip(EDGES[1:-1], EDGES[2:]):
        nd, gd = band(a, b)
        ratio = (n0 - nd) / (g0 - gd) if g0 - gd > 1.0 else float("nan")
        print(f"{a:>7}-{b:<6}{nd:>10.1f}{gd:>9.1f}{n0 - nd:>12.1f}{g0 - gd:>10.1f}{ratio:>7.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
