"""ident.load_model checks a file before it builds a model (porosense.data.model_file): the
Python API refuses a damaged or hostile model file with one ModelError, as the commands do."""

from __future__ import annotations

import pytest

from porosense.errors import ModelError
from porosense.ident import load_model

ONE_MODEL = (
    '{"format": "porosense.ident.model", "version": 1, "models": [{"kind": "linear", "theta": [THETA], '
    '"scaling": {"u_scale": [1.0], "y_mean": 0.0, "y_std": 1.0}, "ts": TS, "inputs": ["u"], "output": "y"}]}'
)


@pytest.mark.parametrize(
    ("text", "named"),
    [
        (ONE_MODEL.replace("THETA", "NaN").replace("TS", "0.02"), "NaN"),
        (ONE_MODEL.replace("THETA", "0.5").replace("TS", '"0.02"'), "a string"),
        (ONE_MODEL.replace("THETA", "0.5").replace("TS", "-0.02"), "positive"),
        ("[" * 100_000 + "]" * 100_000, "nested"),
    ],
    ids=["nan-coefficient", "ts-as-text", "negative-ts", "deep-nesting"],
)
def test_a_damaged_model_file_is_one_model_error(tmp_path, text, named):
    path = tmp_path / "model.json"
    path.write_text(text)
    with pytest.raises(ModelError, match=named) as err:
        load_model(path)
    assert str(path) in str(err.value) and "\n" not in str(err.value)
