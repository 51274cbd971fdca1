"""Identification from frequency responses: ``moli.identify(FrequencyData, ...)`` (docs/frequency.md).

A frequency-domain subspace start per order (:mod:`.subspace`, continuous data through
the bilinear map) and, as an option, the MOLI start on the frequency grid (:mod:`.moli_start`),
its modal form (:mod:`.modal_form`), Levenberg-Marquardt on the
weighted FRF error with its analytic Jacobian (:mod:`.fit_error`, :mod:`.refinement`),
the order from held-out lines by the paired rule (:mod:`.orders`, :mod:`.identification`),
and the options these data read (:mod:`.settings`).
"""

from .identification import FrequencyResult, identify_frequency
from .orders import FrequencyStep
from .settings import refuse_frequency_options

__all__ = ["FrequencyResult", "FrequencyStep", "identify_frequency", "refuse_frequency_options"]
