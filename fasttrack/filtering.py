"""Running a filter over a sequence of detections."""
from . import _validate
from .types import Detection, SingleHypothesis, Track
from .types.tracks import _time_order


def run_filter(predictor, updater, prior, detections):
    """The track of a filter: for each detection in turn, the prior predicted to its
    timestamp and updated with it.

    Parameters
    ----------
    predictor : predictor
        Any fasttrack predictor: ``predictor.predict(state, timestamp)``.
    updater : updater
        Any fasttrack updater, matching the predictor:
        ``updater.update(SingleHypothesis(prediction, detection))``.
    prior : state
        The state before the first detection.
    detections : iterable of Detection
        In time order.

    Returns
    -------
    Track
        The posterior after each detection, with its ``hypothesis`` (the detection, and the
        prediction as a weak link: see :mod:`fasttrack.types`).
    """
    for name, value, method, article in (("predictor", predictor, "predict", "a"),
                                         ("updater", updater, "update", "an")):
        if not callable(getattr(value, method, None)):
            raise TypeError(f"{name} must have {article} {method} method (a fasttrack "
                            f"{name}), got {type(value).__name__}")
    if not (hasattr(prior, "state_vector") and hasattr(prior, "timestamp")):
        raise TypeError(f"prior must be a state (e.g. a GaussianState or ParticleState), got "
                        f"{type(prior).__name__}")
    track = Track()
    state = prior
    for k, detection in enumerate(_validate.iterator(detections, "detections")):
        if not isinstance(detection, Detection):
            raise TypeError(f"detections[{k}] must be a Detection, got "
                            f"{type(detection).__name__}")
        if None not in (detection.timestamp, state.timestamp) \
                and _time_order(detection.timestamp, state.timestamp) < 0:
            raise ValueError(f"detections must be in time order, after the prior: "
                             f"detections[{k}] is at {detection.timestamp}, before "
                             f"{state.timestamp}")
        prediction = predictor.predict(state, detection.timestamp)
        state = updater.update(SingleHypothesis(prediction, detection))
        track.append(state)
    return track
