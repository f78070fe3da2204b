"""Model files: read any porosense model file (a model, a model set or an extended model).

Writing is each model's own (:meth:`porosense.ident.models.Model.save`,
:meth:`porosense.ident.extended.ExtendedModel.save`); reading needs to know every kind of file,
so it sits above both and neither imports the other's reader.
"""

from __future__ import annotations

from pathlib import Path

from porosense.data.model_file import read_model_document
from porosense.errors import ModelError
from porosense.ident import extended, series
from porosense.ident.models import FORMAT, FORMAT_VERSION, Model, ModelSet, save_models

__all__ = ["load_model", "save_models"]


def load_model(path):
    """Load a model file.

    Parameters
    ----------
    path : str or Path
        A file written by ``save`` (porosense.ident.model, .extended or .series format).

    Returns
    -------
    Model, ModelSet, ExtendedModel or SeriesModel
        The single-output model, a :class:`ModelSet` for several outputs, the extended model, or a
        model followed by a series transfer function (porosense.ident.series).
    """
    path = Path(path)
    # Size, nesting depth, NaN/Infinity and field types are checked before anything is built,
    # so a damaged or hostile file ends in one ModelError on every path that loads a model.
    doc = read_model_document(path)
    if isinstance(doc, dict) and doc.get("format") == extended.FORMAT:
        if doc.get("version") != extended.FORMAT_VERSION:
            raise ModelError(
                f"{path}: extended model version {doc.get('version')}, this build reads {extended.FORMAT_VERSION}"
            )
        return extended.ExtendedModel.from_dict(doc)
    if isinstance(doc, dict) and doc.get("format") == series.FORMAT:
        if doc.get("version") != series.FORMAT_VERSION:
            raise ModelError(
                f"{path}: series model version {doc.get('version')}, this build reads {series.FORMAT_VERSION}"
            )
        return series.SeriesModel.from_dict(doc)
    if not isinstance(doc, dict) or doc.get("format") != FORMAT:
        raise ModelError(f"{path} is not a porosense model file")
    if doc.get("version") != FORMAT_VERSION:
        raise ModelError(f"{path}: model format version {doc.get('version')}, this build reads {FORMAT_VERSION}")
    try:
        models = [Model.from_dict(d) for d in doc["models"]]
    except (KeyError, TypeError, ValueError) as exc:
        raise ModelError(f"{path}: malformed model file ({exc})") from exc
    return models[0] if len(models) == 1 else ModelSet(models)
