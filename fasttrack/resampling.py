"""Resampling on plain arrays: ancestor indices from log weights (the public face of
:mod:`fasttrack.core.resample`, which documents the conventions)."""
from .core.resample import (ResidualMethod, ess, multinomial, normalise,
                            resampling_points, residual, stratified, systematic)

__all__ = ["ResidualMethod", "ess", "multinomial", "normalise", "resampling_points", "residual",
           "stratified", "systematic"]
