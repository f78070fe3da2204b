"""The fixed catalogue of causes diagnosis can name (the simulator's effect names and unmodelled_dynamics)."""

from __future__ import annotations

CAUSES = (
    "static_nonlinearity",
    "hysteresis",
    "slow_relaxation",
    "time_delay",
    "drift",
    "periodic_disturbance",
    "load_dependence",
    "saturation",
    "cross_coupling",
    "outliers",
    "unmodelled_dynamics",
)
#: Causes whose extension the on-device structure y = H2(g(sum H1(f(u)))) can carry.
EXPRESSIBLE = (
    "static_nonlinearity",
    "saturation",
    "time_delay",
    "slow_relaxation",
    "cross_coupling",
    "unmodelled_dynamics",
)
NONE = "none"

#: What each cause means and the extension that models it.
DESCRIPTION = {
    "static_nonlinearity": (
        "the residual depends on the signal level",
        "piecewise-linear map on the input (Hammerstein) or output (Wiener) side",
    ),
    "hysteresis": (
        "at equal level the residual depends on the direction of motion",
        "play operators of the model output (Prandtl-Ishlinskii hysteresis), filtered",
    ),
    "slow_relaxation": (
        "the residual follows the input with a time constant much slower than the model's",
        "an extra slow relaxation pole on every input",
    ),
    "time_delay": ("the residual is explained by the model output shifted later in time", "an input delay"),
    "drift": (
        "the residual has a slow trend that no input explains",
        "a random-walk drift state tracked from the measured output",
    ),
    "periodic_disturbance": (
        "the residual spectrum has a line the input does not have",
        "a sinusoidal disturbance at the line's frequency tracked from the measured output",
    ),
    "load_dependence": (
        "the residual depends on a measured load column (offset and gain)",
        "the load column as an extra input and a load-scheduled gain",
    ),
    "saturation": (
        "measured samples pile up at a limit of the ADC or divider",
        "a clipping model at the measured limit",
    ),
    "cross_coupling": (
        "the residual follows measured inputs the model does not use",
        "those columns as extra MISO inputs",
    ),
    "outliers": (
        "the residual has isolated spikes far beyond its noise",
        "outlier rejection (Hampel) and a robust Huber refit",
    ),
    "unmodelled_dynamics": (
        "the residual follows past inputs linearly: the nominal order or structure is too low",
        "re-identify at a higher order",
    ),
    "none": ("no residual test is significant", "none"),
}
