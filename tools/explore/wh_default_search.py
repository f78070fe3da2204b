"""The default staged order search of ``porosense identify`` on the measured WH benchmark.

Estimation on the first N realisations (default 5), validation on the next one, the paper's
grid (poles 1..10, zeros < poles, 4 structures), 10 breakpoints, 2 starts, 200 evaluations,
selection by the validation fit; ``--process-noise`` refits the best Wiener and WH candidates
with a process noise whose level is measured from the two periods of each realisation.
Prints the search table and rule, the wall time, and the noise-free multisine test RMSE (mV)
of the best candidate of each structure and of the selected one.
``--wh``: the WH structure only (``identify --structure wh``).
Realisations: ``N`` (the first N, validation on the next) or ``A-B`` (A to B, validation on the
one after B, or before A when B is the last).
Run: .venv/bin/python tools/explore/wh_default_search.py [N | A-B] [--process-noise] [--wh]
"""

import sys
import time

import numpy as np
from wh_benchmark import realisations, records

from porosense import ident
from porosense.ident import STRUCTURES

SKIP = 200
FS = 78125.0  # Hz


def main() -> int:
    args = [a for a in sys.argv[1:] if not a.startswith("--")]
    which = realisations(args[0] if args else "5")
    extra = which[-1] + 1 if which[-1] < 9 else which[0] - 1
    n = len(which)
    us, ys, ut, yt = records(which + [extra])
    t0 = time.perf_counter()
    structures = ("wh",) if "--wh" in sys.argv else STRUCTURES
    res = ident.search(
        u=us[:n],
        y=ys[:n],
        ts=1 / FS,
        validation=(us[n:], ys[n:]),
        validation_skip=SKIP,
        skip=SKIP,
        structures=structures,
        n_breakpoints=10,
        starts=2,
        max_nfev=200,
        criterion="fit",
        staged=True,
        process_noise="--process-noise" in sys.argv,
        progress=False,
    )
    wall = time.perf_counter() - t0
    print(res)
    print(f"wall {wall:.1f} s on realisations {which[0]}-{which[-1]} (validation on {extra})")

    def test_mv(model) -> float:
        return ident.rmse(yt[SKIP:], np.asarray(model.predict(u=ut)).ravel()[SKIP:]) * 1e3

    for s, c in res.best_per_structure("fit").items():
        noise = " (process noise)" if c.model.spec.g_noise else ""
        print(
            f"{s} {c.n_poles}p{c.n_zeros}z{noise}: validation fit {c.validation_fit:.2f} %, "
            f"test RMSE {test_mv(c.model):.2f} mV"
        )
    for c in res.candidates:
        if c.model.spec.g_noise:
            print(
                f"refitted with process noise: {c.structure} {c.n_poles}p{c.n_zeros}z, validation fit "
                f"{c.validation_fit:.2f} %, test RMSE {test_mv(c.model):.2f} mV"
            )
    print(f"selected: test RMSE {test_mv(res.model):.2f} mV")
    return 0


if __name__ == "__main__":
    sys.exit(main())
