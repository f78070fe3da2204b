"""The demo report's results table is a real table built from the order search, not text."""

from __future__ import annotations

import numpy as np

from porosense import ident
from porosense.workflows.demo_report import search_tables


def test_search_table_has_one_row_per_structure_and_the_search_numbers():
    from scipy import signal

    rng = np.random.default_rng(8)
    us = [np.repeat(rng.uniform(-1, 1, 30), 20)[:, None] for _ in range(2)]
    ys = [np.tanh(signal.lfilter([0.2], [1, -0.8], u[:, 0])) + rng.normal(0, 0.01, len(u)) for u in us]
    res = ident.search(
        u=us[:1],
        y=ys[:1],
        ts=0.02,
        validation=(us[1:], ys[1:]),
        structures=("linear", "wiener"),
        poles=[1],
        n_breakpoints=4,
        starts=1,
        max_nfev=20,
        progress=False,
        grid=None,
    )
    (table,) = search_tables([res], ["est", "val"], ["y"])
    assert table.header == ["structure", "poles", "zeros", "est", "val", "mean"]
    assert [r[0].lstrip("* ") for r in table.rows] == ["linear", "wiener"]
    per = res.best_per_structure()
    for row in table.rows:
        c = per[row[0].lstrip("* ")]
        fit, rms = (float(v) for v in row[3].split(" / "))
        assert abs(fit - c.fit_estimation[0]) <= 0.05 and abs(rms - c.rms_estimation[0]) <= 0.05
    assert sum(r[0].startswith("* ") for r in table.rows) == 1
    assert "<table>" in table.html() and table.markdown().count("\n|") == 2 + len(table.rows)
