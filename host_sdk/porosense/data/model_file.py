"""A model file checked before anything builds a model from it: size, nesting depth, NaN and
infinite values, and the types and shapes of the fields a model is made of.

The commands read model files that users pass around; a damaged or hostile one must end in
one line (ModelError, exit 4), never a traceback, a hang or an exhausted memory:

- at most :data:`MAX_BYTES` bytes and :data:`MAX_DEPTH` levels of nesting (Python's JSON
  parser recurses: 200,000 nested brackets ended in a RecursionError);
- NaN and Infinity tokens are named as such wherever they stand in a model's numbers;
- every model of a ``porosense.ident.model`` file: ``ts`` a positive finite number (a string
  such as ``"0.02"`` is refused), ``theta`` and ``scaling.u_scale`` lists of finite numbers,
  ``inputs`` a list of names matching ``u_scale``, ``output`` a name, ``orders`` and ``spec``
  of integers; the ``nominal`` and ``series`` models of a ``porosense.ident.series`` file alike.
"""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

from porosense.errors import ModelError

MAX_BYTES = 16 * 1024 * 1024
MAX_DEPTH = 32
MODEL_FORMAT = "porosense.ident.model"
MODEL_FORMAT_VERSION = 1  # the version this build reads (porosense.ident.models writes it)
SERIES_FORMAT = "porosense.ident.series"  # a model and its series block (porosense.ident.series)

_STRINGS = re.compile(r'"(?:[^"\\]|\\.)*"')
_BRACKETS = re.compile(r"[\[\]{}]")


class _NotANumber(float):
    """A NaN or Infinity token of the file, remembered by name."""

    token: str

    def __new__(cls, token: str):
        obj = super().__new__(cls, {"NaN": "nan", "Infinity": "inf", "-Infinity": "-inf"}[token])
        obj.token = token
        return obj


def nesting_depth(text: str) -> int:
    """The deepest nesting of JSON arrays and objects in ``text`` (strings skipped)."""
    depth = deepest = 0
    for b in _BRACKETS.findall(_STRINGS.sub('""', text)):
        depth += 1 if b in "[{" else -1
        deepest = max(deepest, depth)
    return deepest


def read_model_document(path) -> dict:
    """The JSON document of the model file at ``path``, checked (see the module's docstring).

    Raises
    ------
    ModelError
        Naming the file and the first problem found.
    """
    path = Path(path)
    try:
        size = path.stat().st_size
    except FileNotFoundError:
        raise ModelError(f"model file {path} not found") from None
    except OSError as exc:
        raise ModelError(f"model file {path}: {exc.strerror}") from None
    if size > MAX_BYTES:
        raise ModelError(f"{path}: {size:,} bytes, more than a model file holds (at most {MAX_BYTES:,})")
    try:
        text = path.read_bytes().decode("utf-8")
    except UnicodeDecodeError:
        raise ModelError(f"{path} is not a model file (not UTF-8 text)") from None
    except OSError as exc:
        raise ModelError(f"model file {path}: {exc.strerror}") from None
    depth = nesting_depth(text)
    if depth > MAX_DEPTH:
        raise ModelError(f"{path}: JSON nested {depth:,} levels deep (a model file has at most {MAX_DEPTH})")
    try:
        doc = json.loads(text, parse_constant=_NotANumber)
    except (json.JSONDecodeError, RecursionError, ValueError) as exc:
        raise ModelError(f"{path} is not a model file: {exc}") from None
    if not isinstance(doc, dict):
        raise ModelError(f"{path} is not a porosense model file (its JSON is not an object)")
    if doc.get("format") == MODEL_FORMAT:
        # The version first: another version's fields may be laid out otherwise.
        if doc.get("version") != MODEL_FORMAT_VERSION:
            raise ModelError(
                f"{path}: model format version {doc.get('version')}, this build reads {MODEL_FORMAT_VERSION}"
            )
        models = doc.get("models")
        if not isinstance(models, list) or not models:
            raise ModelError(f"{path}: 'models' must be a non-empty list of models")
        for k, m in enumerate(models):
            _check_model(path, f"models[{k}]", m)
    if doc.get("format") == SERIES_FORMAT:
        for part in ("nominal", "series"):
            _check_model(path, part, doc.get(part))
    return doc


def _number(path, where: str, v, *, positive: bool = False) -> float:
    if isinstance(v, _NotANumber):
        raise ModelError(f"{path}: {where} is {v.token}, a non-finite value a model cannot hold")
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        shown = f'a string ("{v}")' if isinstance(v, str) else f"of type {type(v).__name__}"
        raise ModelError(f"{path}: {where} is {shown}, expected a number")
    if not math.isfinite(float(v)):
        raise ModelError(f"{path}: {where} is non-finite ({v})")
    if positive and not v > 0:
        raise ModelError(f"{path}: {where} is {v}, expected a positive number")
    return float(v)


def _numbers(path, where: str, v) -> list:
    if not isinstance(v, list):
        raise ModelError(f"{path}: {where} must be a list of numbers, not {type(v).__name__}")
    for i, x in enumerate(v):
        _number(path, f"{where}[{i}]", x)
    return v


def _check_model(path, where: str, m) -> None:
    if not isinstance(m, dict):
        raise ModelError(f"{path}: {where} must be an object")
    for key in ("kind", "theta", "scaling", "ts", "inputs", "output"):
        if key not in m:
            raise ModelError(f"{path}: {where} has no '{key}'")
    _number(path, f"{where}.ts (s)", m["ts"], positive=True)
    _numbers(path, f"{where}.theta", m["theta"])
    scaling = m["scaling"]
    if not isinstance(scaling, dict):
        raise ModelError(f"{path}: {where}.scaling must be an object")
    u_scale = _numbers(path, f"{where}.scaling.u_scale", scaling.get("u_scale"))
    for key in ("y_mean", "y_std"):
        _number(path, f"{where}.scaling.{key}", scaling.get(key))
    inputs = m["inputs"]
    if not isinstance(inputs, list) or not inputs or not all(isinstance(s, str) for s in inputs):
        raise ModelError(f"{path}: {where}.inputs must be a list of column names")
    if len(inputs) != len(u_scale):
        raise ModelError(f"{path}: {where} has {len(inputs)} inputs but {len(u_scale)} input scales")
    if not isinstance(m["output"], str):
        raise ModelError(f"{path}: {where}.output must be a column name")
    for block in ("orders", "spec"):
        d = m.get(block, {})
        if not isinstance(d, dict):
            raise ModelError(f"{path}: {where}.{block} must be an object")
        for k, v in d.items():
            if not isinstance(v, (int, bool)) or isinstance(v, float):
                raise ModelError(f"{path}: {where}.{block}.{k} is {v!r}, expected an integer")
            if not -1 <= int(v) <= 1000:
                raise ModelError(f"{path}: {where}.{block}.{k} = {v} is out of range")
