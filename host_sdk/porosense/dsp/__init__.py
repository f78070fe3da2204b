"""Signal pieces shared by identification, quantization, diagnosis and the estimator structure.

sections  pure delays in cascades of second-order sections
filters   the discrete Laguerre bank and the play (backlash) operator
metrics   the paper's NRMSE fit and RMS % (docs/design.md)
blas      one BLAS thread around fits of many small products (porosense.dsp.blas.single_threaded)
"""

from porosense.dsp.filters import laguerre_bank, play_operator
from porosense.dsp.metrics import fit_percent, rms_percent, rmse
from porosense.dsp.sections import fold_delay, split_delay

__all__ = ["fit_percent", "fold_delay", "laguerre_bank", "play_operator", "rms_percent", "rmse", "split_delay"]
