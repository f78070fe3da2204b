"""--json output is strict JSON: a NaN or infinite figure becomes null, never a bare NaN token."""

import json
from types import SimpleNamespace

import numpy as np

from porosense.cli._data import emit_json


def _strict(text):
    def refuse(token):
        raise ValueError(f"non-JSON token {token}")

    return json.loads(text, parse_constant=refuse)


def test_non_finite_figures_are_null(tmp_path, capsys):
    doc = {
        "fit": float("nan"),
        "peak": np.float64(np.inf),
        "rows": np.array([1.0, np.nan, -np.inf]),
        "nested": [{"x": (np.nan, 2)}],
        "count": np.int64(3),
        "ok": np.bool_(True),
        "name": "wh",
    }
    out = tmp_path / "r.json"
    emit_json(doc, SimpleNamespace(json=True, json_out=str(out)))
    for text in (capsys.readouterr().out, out.read_text()):
        back = _strict(text)
        assert back == {
            "fit": None,
            "peak": None,
            "rows": [1.0, None, None],
            "nested": [{"x": [None, 2]}],
            "count": 3,
            "ok": True,
            "name": "wh",
        }
