"""What the optimisers of :mod:`proleg.study` return, and the unit-box map they share
(a module of its own so that optimize, codesign and cma import it without a cycle)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pandas as pd

from .space import LogRange


@dataclass
class OptimizationResult:
    """``best_params`` {name: value}, ``best_value`` (one objective) or ``best_trials`` (several),
    ``trials`` (optuna's trials table), ``rows`` (the evaluated study rows) and the optuna study."""

    best_params: dict
    best_value: float | list | None
    trials: pd.DataFrame
    rows: pd.DataFrame
    optuna_study: object


def to_unit(study, names, vals):
    out = []
    for k in names:
        d = study.space.dims[k]
        x = float(vals[k])
        if isinstance(d, LogRange):
            out.append((math.log10(x) - math.log10(d.lo)) / (math.log10(d.hi) - math.log10(d.lo)))
        else:
            out.append((x - d.lo) / (d.hi - d.lo))
    return np.clip(np.array(out), 0.0, 1.0)
