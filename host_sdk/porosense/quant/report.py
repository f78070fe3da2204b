"""Quantization report: formats chosen, sizes, and the fit of the fixed-point reference."""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass, field

from porosense.dsp.metrics import fit_percent  # noqa: F401  (part of quant's API)
from porosense.files import write_text


@dataclass
class RecordingFit:
    """Fit of one output on one recording.

    Fits are NRMSE fits in % (100 = perfect); None where there is no measured output.

    Attributes
    ----------
    recording : str
        Recording label.
    output : str
        Output name.
    fit_float_vs_data : float or None
        The float model against the measured output, %.
    fit_fixed_vs_data : float or None
        The fixed-point model against the measured output, %.
    fit_fixed_vs_float : float
        The fixed-point model against the float one, %.
    saturated_samples : int
        Samples where any fixed-point node saturated.
    noise_lsb : float
        RMS of the noise probe's white input noise, device LSB (0.01 % dR); 0 when not probed.
    fit_noisy_vs_data : float or None
        The fixed-point model on the noisy inputs against the measured output, %.
    fit_noisy_vs_fixed : float or None
        The fixed-point model on the noisy inputs against itself on the clean ones, %.
    """

    recording: str
    output: str
    fit_float_vs_data: float | None
    fit_fixed_vs_data: float | None
    fit_fixed_vs_float: float
    saturated_samples: int
    noise_lsb: float = 0.0  # RMS (device LSB) of the noise probe's white input noise
    fit_noisy_vs_data: float | None = None  # the fixed-point model on the noisy inputs
    fit_noisy_vs_fixed: float | None = None

    @property
    def loss_points(self) -> float | None:
        """How many fit points the fixed-point model loses against the float one on the data."""
        if self.fit_float_vs_data is None or self.fit_fixed_vs_data is None:
            return None
        return self.fit_float_vs_data - self.fit_fixed_vs_data

    @property
    def noise_loss_points(self) -> float | None:
        """Fit points that ``noise_lsb`` of white sensor noise costs the device (against the data)."""
        if self.fit_fixed_vs_data is None or self.fit_noisy_vs_data is None:
            return None
        return self.fit_fixed_vs_data - self.fit_noisy_vs_data


@dataclass
class QuantReport:
    """How a model was quantized and how well the fixed-point version fits.

    Attributes
    ----------
    blob_bytes : int
        Blob length, bytes.
    capacity_bytes : int
        Bytes the blob was allowed.
    n_sections : int
        Second-order sections in the blob.
    wide_numerators : int
        Sections with 32-bit numerators.
    delta_sections : int
        Sections in delta form (for poles near z = 1).
    out_scale : list of float
        Per output, output units per estimate LSB.
    scaling : str
        How node ranges were bounded, and the input ranges used.
    nodes : list of dict
        Per node (``"p1.h1[0]"``, ``"p1.sum"``, ...), its guaranteed float interval and its scale
        (float units per LSB).
    notes : list of str
        Decisions and warnings (compact tables, forced checks, off-grid inputs).
    fits : list of RecordingFit
        Per recording and output.
    """

    blob_bytes: int
    capacity_bytes: int
    n_sections: int
    wide_numerators: int
    delta_sections: int
    out_scale: list[float]
    scaling: str
    nodes: list[dict] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    fits: list[RecordingFit] = field(default_factory=list)

    @property
    def saturated_samples(self) -> int:
        return int(sum(f.saturated_samples for f in self.fits))

    @property
    def worst_loss_points(self) -> float | None:
        losses = [f.loss_points for f in self.fits if f.loss_points is not None]
        return max(losses) if losses else None

    @property
    def worst_noise_loss_points(self) -> float | None:
        losses = [f.noise_loss_points for f in self.fits if f.noise_loss_points is not None]
        return max(losses) if losses else None

    def to_dict(self) -> dict:
        """The report as a plain dict, with the derived figures.

        Returns
        -------
        dict
            The fields, ``saturated_samples``, ``worst_loss_points``, ``worst_noise_loss_points`` and
            per fit its ``loss_points`` and ``noise_loss_points`` (fit points).
        """
        d = asdict(self)
        d["saturated_samples"] = self.saturated_samples
        d["worst_loss_points"] = self.worst_loss_points
        d["worst_noise_loss_points"] = self.worst_noise_loss_points
        for f, fd in zip(self.fits, d["fits"]):
            fd["loss_points"] = f.loss_points
            fd["noise_loss_points"] = f.noise_loss_points
        d["nodes"] = [
            {**n, "interval": [float(v) for v in n["interval"]], "scale": float(n["scale"])} for n in self.nodes
        ]
        return d

    def to_json(self, path=None) -> str:
        """The report as JSON text, optionally written to a file (whole or not at all).

        Parameters
        ----------
        path : str or Path or None
            Also write it there.

        Returns
        -------
        str
            The JSON text.
        """
        text = json.dumps(self.to_dict(), indent=2, default=float)
        if path is not None:
            write_text(path, text + "\n")
        return text

    def lines(self) -> list[str]:
        """The report in lines of text, as ``porosense quantize`` prints it.

        Returns
        -------
        list of str
            Size, scaling, out_scale, then one line per recording and output.
        """
        out = [
            f"blob {self.blob_bytes} of {self.capacity_bytes} bytes; {self.n_sections} sections "
            f"({self.wide_numerators} with 32-bit numerators, {self.delta_sections} in delta form)",
            f"scaling: {self.scaling}",
            "out_scale: " + ", ".join(f"{s:.6g}" for s in self.out_scale),
            "fits: the bit-exact fixed-point estimator on the device's inputs (rounded to its LSB "
            "as the device rounds)",
        ]
        out += [f"note: {n}" for n in self.notes if n.startswith("inputs not on the device")]
        for f in self.fits:
            parts = [f"{f.recording} {f.output}: fixed vs float {f.fit_fixed_vs_float:.2f} %"]
            if f.fit_float_vs_data is not None:
                parts.append(
                    f"float vs data {f.fit_float_vs_data:.2f} %, fixed vs data "
                    f"{f.fit_fixed_vs_data:.2f} % (loss {f.loss_points:+.3f} points)"
                )
            if f.noise_loss_points is not None:
                parts.append(
                    f"with {f.noise_lsb:g} LSB RMS input noise fixed vs data {f.fit_noisy_vs_data:.2f} % "
                    f"(noise costs {f.noise_loss_points:+.3f} points)"
                )
            parts.append(f"saturated samples {f.saturated_samples}")
            out.append("; ".join(parts))
        return out

    def __str__(self) -> str:
        return "\n".join(self.lines())

    def plot(self, ax=None):
        """Bar chart of the fit loss per recording and output, fit points (0.5-point line dashed).

        Parameters
        ----------
        ax : matplotlib Axes or None
            Where to draw (None: a new figure).

        Returns
        -------
        matplotlib Axes
            The axes drawn on.
        """
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots(figsize=(6, 3))
        labels = [f"{f.recording}\n{f.output}" for f in self.fits]
        ax.bar(range(len(labels)), [f.loss_points or 0.0 for f in self.fits])
        ax.set_xticks(range(len(labels)), labels, fontsize=7)
        ax.axhline(0.5, color="r", lw=0.8, ls="--")
        ax.set_ylabel("fit loss (points)")
        return ax
