"""Drop-ins for ``stonesoup.updater.pointprocess``: the GM-PHD and GM-LCC updaters, their
Kalman updates and likelihoods computed on arrays."""
import numpy as np
from stonesoup.models.measurement.linear import LinearGaussian as SSLinearGaussian
from stonesoup.types.array import CovarianceMatrix, StateVector
from stonesoup.types.state import TaggedWeightedGaussianState
from stonesoup.types.update import GaussianMixtureUpdate
from stonesoup.updater import kalman as ss_kalman
from stonesoup.updater import pointprocess as ss_pointprocess

from ._convert import all_real, floats
from ._fallback import fall_back
from ._objects import builder, fresh_tags
from ._pending import pending, pending_mixture
from .updater import KalmanUpdater, _measurement_model

_tagged_state = builder(TaggedWeightedGaussianState)
_EPS = np.finfo(float).eps  # Stone Soup's weight for a component of weight 0


#: The point-process updaters' numeric settings: (name, what it must be, the test).
_SETTINGS = (("prob_detection", "a probability in [0, 1]", lambda p: 0.0 <= p <= 1.0),
             ("prob_survival", "a probability in [0, 1]", lambda p: 0.0 <= p <= 1.0),
             ("clutter_spatial_density", "finite and >= 0", lambda c: 0.0 <= c < np.inf))


class _PointProcess:
    """Stone Soup's ``PointProcessUpdater.update``: the Kalman updates and likelihoods of
    every (component, detection) pair computed at once on arrays, for a ``KalmanUpdater``
    and one linear Gaussian measurement model, by Stone Soup's rules: P_S applied at the
    update to every component not tagged 'birth' (a detected birth component is given a new
    tag), a missed birth component dropped, the likelihoods in linear terms, a weight of 0
    set to eps; the missed components scaled by the filter's own update terms. As in Stone
    Soup, a pair's likelihood is of the updater's model, its Kalman update from the
    measurement prediction its hypothesis carries (the hypothesiser's, whose model may be
    another for detections without their own). The update
    of the drop-in hypothesiser's groups (P_D and P_S plain numbers) holds its components as
    arrays until they are read (a :class:`~._pending.PendingMixtureUpdate`, which the
    drop-in reducer reduces as arrays). Another updater or measurement model goes through
    Stone Soup's code."""

    def update(self, hypotheses):
        self._check_settings()
        groups = pending(hypotheses)
        if groups is not None and all(tag is not None for tag in groups.tags) \
                and all_real(groups.weights) and not self._reason(groups.scan.own_models) \
                and all(type(p) in (float, int, np.float64) for p in (self.prob_detection,
                                                                      self.prob_survival)):
            try:
                update = self._scan_update(groups, hypotheses)
            except _Indefinite:
                update = None  # (the hypotheses' own path finds it too)
            if update is not None:
                return update
        pairs = [hypothesis for multiple in hypotheses[:-1] for hypothesis in multiple]
        measurements = [hypothesis.measurement for hypothesis in pairs]
        reason = "no hypotheses" if not hypotheses else self._reason(
            {id(model): model for model in [m.measurement_model for m in measurements]}.values())
        if not reason and not all_real(hypothesis.prediction.weight
                                       for multiple in hypotheses for hypothesis in multiple):
            reason = "a weight that is not a real number"  # (Stone Soup's arithmetic raises)
        predicted = None
        if not reason:
            predicted = _carried_predictions(pairs)
            reason = predicted if isinstance(predicted, str) else None
        if reason:
            fall_back(self, "update", reason)
            return super().update(hypotheses)
        detection = np.repeat(np.arange(len(hypotheses) - 1),
                              [len(multiple) for multiple in hypotheses[:-1]])
        predictions = [p.prediction for p in pairs]
        tags = [prediction.tag for prediction in predictions]
        try:
            means, covars, weights, sums = self._detected(
                np.array([p.state_vector[:, 0] for p in predictions], dtype=np.float64),
                np.array([p.covar for p in predictions], dtype=np.float64),
                np.array([float(p.weight) for p in predictions]),
                np.array([tag == "birth" for tag in tags]), np.arange(len(pairs)),
                _rows(measurements),
                _measurement_model(self.updater, measurements[0]) if pairs else None,
                detection, len(hypotheses) - 1, predicted=predicted)
        except _Indefinite:
            fall_back(self, "update", "an innovation covariance that is not positive definite")
            return super().update(hypotheses)
        updated = [_tagged_state(tag=tag if tag != "birth" else None, weight=weight,
                                 state_vector=mean[:, None].view(StateVector),
                                 covar=covar.view(CovarianceMatrix), timestamp=m.timestamp)
                   for tag, mean, covar, weight, m in zip(
                       tags, means, covars, weights.tolist(), measurements)]
        missed = self._missed_factor(sums, hypotheses)
        updated += [_tagged_state(tag=p.tag, weight=p.weight * missed, state_vector=p.mean,
                                  covar=p.covar, timestamp=p.timestamp)
                    for p in (hypothesis.prediction for hypothesis in hypotheses[-1])
                    if p.tag != "birth"]
        for component in updated:
            if component.weight == 0:
                component.weight = _EPS
        return GaussianMixtureUpdate(hypothesis=hypotheses, components=updated)

    def _check_settings(self):
        """ValueError naming a probability outside [0, 1] or a clutter density that is
        negative or not finite (Stone Soup weighs with them: negative or NaN weights, which
        fail a step later, unnamed); a value that is not a number is Stone Soup's to read."""
        for name, expected, allowed in _SETTINGS:
            value = getattr(self, name)
            try:
                number = float(value)
            except (TypeError, ValueError):
                continue
            if not allowed(number):
                raise ValueError(f"{name} must be {expected}, got {value!r}")

    def _scan_update(self, groups, hypotheses):
        """The update of a drop-in hypothesiser's groups from its scan's arrays (the
        hypotheses not built), a :class:`~._pending.PendingMixtureUpdate`: the pair of
        component k and detection j has k's prediction, weight and tag (a new one for a
        detected birth component), in the groups' order (by detection, then component),
        then the missed components in the components' order. None if the hypotheses'
        measurement predictions, of another model than this updater's, are not arrays of
        the scan (Stone Soup's update uses them), or if a detection changed since the scan
        read it."""
        scan = groups.scan
        if not scan.detections_as_read():
            return None
        owners = np.repeat(np.arange(len(scan.tracks)), np.diff(scan.starts))
        order = np.argsort(scan.candidates, kind="stable")
        k, detection = owners[order], scan.candidates[order]
        model = _measurement_model(self.updater, scan.detections[0]) if k.size else None
        log_likelihoods = scan.log_likelihoods(model)  # (None: the scan's is another model)
        predicted = scan.carried_predictions()
        if k.size and log_likelihoods is None and predicted is None:
            return None
        tags = groups.tags
        pair_tags = [tags[i] for i in k.tolist()]
        born = [q for q, tag in enumerate(pair_tags) if tag == "birth"]
        for q, tag in zip(born, fresh_tags(len(born))):
            pair_tags[q] = tag
        prior = np.array(groups.weights, dtype=np.float64)
        means, covars, weights, sums = self._detected(
            scan.means, scan.covars, prior, np.zeros(prior.size, dtype=np.bool_), k,
            scan.measurements[detection], model, detection, len(scan.detections),
            None if log_likelihoods is None else log_likelihoods[order], predicted)
        kept = [i for i, tag in enumerate(tags) if tag != "birth"]
        weights = np.concatenate([weights, prior[kept] * self._missed_factor(sums, hypotheses)])
        weights[weights == 0] = _EPS
        return pending_mixture(hypotheses, np.concatenate([means, scan.means[kept]]),
                               np.concatenate([covars, scan.covars[kept]]), weights,
                               pair_tags + [tags[i] for i in kept], scan.timestamp)

    def _detected(self, means, covars, weights, born, component, z, model, detection,
                  n_detections, log_likelihoods=None, predicted=None):
        """The posterior means (n, d), covariances (n, d, d) and weights (n,) of the
        (prediction, detection) pairs, and the sum of their likelihood terms for each of
        the ``n_detections``: predicted ``means`` (K, d), ``covars`` (K, d, d), ``weights``
        (K,), ``born`` (K,) whether tagged 'birth', each pair's ``component`` (n,) of them,
        measurement ``z`` (n, m) of ``model``, ``detection`` (n,) number and, if known,
        Gaussian ``log_likelihoods`` (n,) and the measurement predictions the hypotheses
        carry (see :meth:`_pair_updates`)."""
        if not detection.size:
            return means[component], covars[component], np.zeros(0), np.zeros(n_detections)
        means, covars, weights = self._pair_updates(means, covars, weights, born, component,
                                                    z, model, log_likelihoods, predicted)
        sums = np.bincount(detection, weights, minlength=n_detections)
        if self.normalisation:
            weights = weights / (sums[detection] + self.clutter_spatial_density)
        return means, covars, weights, sums

    def _missed_factor(self, sums, hypotheses):
        """What scales a missed component's weight: ``(1 - P_D) l1 P_S``, ``l1`` the
        filter's own update term of the detections' likelihood ``sums``."""
        return (1 - self.prob_detection) * self._calculate_update_terms(list(sums),
                                                                        hypotheses) \
            * self.prob_survival

    def _pair_updates(self, means, covars, prior, born, component, z, model,
                      log_likelihoods=None, predicted=None):
        """Posterior means (n, d), covariances (n, d, d) and unnormalised weights
        ``P_D w q (P_S)`` of the pairs of predicted ``means`` (K, d), ``covars`` (K, d, d)
        of weights ``prior`` (K,) (``born`` (K,): tagged 'birth', no P_S), each pair's
        ``component`` (n,) of them and measurement ``z`` (n, m), as Stone Soup's PHD
        updater computes them: ``q`` from the linear Gaussian ``model`` (or the given
        ``log_likelihoods`` (n,)), the Kalman update from the measurement predictions the
        hypotheses carry, ``predicted`` = (z_hats (K, m), innovation covariances
        (K, m, m), cross covariances (K, d, m)), by default ``model``'s (its gain and
        posterior covariance once per component; the Joseph form with ``model``'s H and
        R, as Stone Soup's)."""
        k, joseph = component, self.updater.use_joseph_cov
        if log_likelihoods is None or predicted is None or joseph:
            h, r = floats(model.matrix()), floats(model.covar())
        if log_likelihoods is None or predicted is None:
            cross = covars @ h.T
            own = means @ h.T, h @ cross + r, cross
        if log_likelihoods is None:
            try:
                lower = np.linalg.cholesky(own[1])
            except np.linalg.LinAlgError:  # (Stone Soup's likelihood refuses it)
                raise _Indefinite from None
            whitened = np.linalg.solve(lower[k], (z - own[0][k])[..., None])[..., 0]
            log_likelihoods = -0.5 * (np.einsum("ki,ki->k", whitened, whitened)
                                      + z.shape[1] * np.log(2 * np.pi)) \
                - np.log(np.diagonal(lower, axis1=1, axis2=2)).sum(axis=1)[k]
        z_hats, innovation, cross = own if predicted is None else predicted
        z_hats = z_hats[k]
        gains = cross @ np.linalg.inv(innovation)
        if joseph:
            i_kh = np.eye(means.shape[1]) - gains @ h
            post = i_kh @ covars @ i_kh.transpose(0, 2, 1) + gains @ r @ gains.transpose(0, 2, 1)
        else:
            post = covars - gains @ innovation @ gains.transpose(0, 2, 1)
        q = np.exp(log_likelihoods)
        weights = self.prob_detection * prior[k] * q
        weights = np.where(born[k], weights, weights * self.prob_survival)
        return means[k] + np.einsum("kij,kj->ki", gains[k], z - z_hats), post[k], weights

    def _reason(self, own_models):
        """Why Stone Soup's code must update the pairs of detections whose own measurement
        models are ``own_models`` (distinct; None for the updater's), or None."""
        if type(self.updater) not in (ss_kalman.KalmanUpdater, KalmanUpdater):
            return f"an updater of type {type(self.updater).__name__}"
        models = {id(model): model for model in (own or self.updater.measurement_model
                                                 for own in own_models)}
        if len(models) > 1:
            return "detections of several measurement models"
        if models and type(next(iter(models.values()))) is not SSLinearGaussian:
            return f"a measurement model of type {type(next(iter(models.values()))).__name__}"
        return None


class _Indefinite(Exception):
    """An innovation covariance of the updater's own model that is not positive definite
    (Stone Soup's code then decides)."""


def _carried_predictions(pairs):
    """The measurement predictions the hypotheses ``pairs`` carry, as arrays (z_hats
    (n, m), innovation covariances (n, m, m), cross covariances (n, d, m)); None if none
    carries one (the updater's model then makes them, as Stone Soup's would); the reason
    Stone Soup's code must run if only some do, or one has no cross covariance."""
    carried = [hypothesis.measurement_prediction for hypothesis in pairs]
    if all(prediction is None for prediction in carried):
        return None
    if any(getattr(prediction, "cross_covar", None) is None for prediction in carried):
        return "hypotheses without a measurement prediction with a cross covariance"
    return (floats(np.array([p.state_vector for p in carried], dtype=np.float64))[:, :, 0],
            floats(np.array([p.covar for p in carried], dtype=np.float64)),
            floats(np.array([p.cross_covar for p in carried], dtype=np.float64)))


def _rows(measurements):
    """The measurements' state vectors as rows (n, m), each measurement read once."""
    unique = {id(m): m for m in measurements}
    if not unique:
        return np.zeros((0, 0))
    rows = dict(zip(unique, np.array([m.state_vector for m in unique.values()],
                                     dtype=np.float64)[:, :, 0]))
    return np.array([rows[id(m)] for m in measurements])


class PHDUpdater(_PointProcess, ss_pointprocess.PHDUpdater):
    __doc__ = "Stone Soup's ``PHDUpdater``, its update on arrays. " + _PointProcess.__doc__


class LCCUpdater(_PointProcess, ss_pointprocess.LCCUpdater):
    __doc__ = ("Stone Soup's ``LCCUpdater`` (its cumulant terms as Stone Soup computes them), "
               "its update on arrays. " + _PointProcess.__doc__)
