"""What the paper's claims are built from: one outcome, a model's error on an output.

The claims themselves are the systems': ``claims`` in
:mod:`~skhybrid.benchmarks.pendulum` and :mod:`~skhybrid.benchmarks.double_pendulum`.
"""

import numpy as np

__all__ = ["HYBRIDS", "NEURAL_HYBRIDS", "claim", "median_window_db", "rmse"]

#: The hybrids of the paper's zoo (:func:`~skhybrid.experiments.model_zoo`).
HYBRIDS = (
    "physics+linear",
    "physics+dense",
    "physics+rnn (mse)",
    "physics+rnn (ljung-box)",
    "physics+cyclic",
    "ensemble",
)
NEURAL_HYBRIDS = tuple(h for h in HYBRIDS if h != "physics+linear")


def claim(text, passed, detail):
    """One claim's outcome: ``{"claim": text, "passed": bool, "detail": detail}``."""
    return {"claim": text, "passed": bool(passed), "detail": detail}


def median_window_db(result, split, model, output):
    """Median over the report's short windows of ``model``'s dB RMSE on ``output``."""
    j = result.target_names.index(output)
    return float(np.median(result.windowed_db(split)[model][:, j]))


def rmse(result, split, model, output):
    """``model``'s one-step RMSE on ``output`` over the whole ``split``."""
    j = result.target_names.index(output)
    residual = result.splits[split].y[:, j] - result.predictions[split][model][:, j]
    return float(np.sqrt(np.mean(residual**2)))
