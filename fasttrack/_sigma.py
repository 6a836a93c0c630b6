"""The sigma-point parameters of the unscented classes, as settings."""
from . import _validate
from .core import unscented as _unscented


class SigmaPointSettings:
    """``alpha``, ``beta`` and ``kappa`` of an unscented filter as settings: each
    assignment, the constructor's and any later one, is checked as
    :func:`fasttrack.core.unscented.check_parameters` checks it, and the spread
    ``alpha**2 (d + kappa)`` of each state dimension d when the filter next needs it
    (:meth:`_resolved_kappa`)."""

    alpha = _validate.Setting("_checked_parameter")
    beta = _validate.Setting("_checked_parameter")
    kappa = _validate.Setting("_checked_parameter")

    def _checked_parameter(self, value, name):
        parameters = {"alpha": 0.5, "beta": 2.0, "kappa": None, name: value}
        value = _unscented.check_parameters(**parameters)[("alpha", "beta", "kappa").index(name)]
        self.__dict__["_kappas"] = {}  # (each resolved again from the new values)
        return value

    def _resolved_kappa(self, d):
        """``kappa`` for ``d`` state dimensions (None: ``3 - d``), its spread checked (see
        :func:`fasttrack.core.unscented.scaling`); remembered per dimension."""
        kappa = self._kappas.get(d)
        if kappa is None:
            kappa = self._kappas[d] = _unscented.scaling(self.alpha, self.kappa, d)
        return kappa
