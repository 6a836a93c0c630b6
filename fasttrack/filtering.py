"""Running a filter over a sequence of detections."""
from .types import Detection, SingleHypothesis, Track


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
    track = Track()
    state = prior
    for k, detection in enumerate(detections):
        if not isinstance(detection, Detection):
            raise TypeError(f"detections[{k}] must be a Detection, got "
                            f"{type(detection).__name__}")
        prediction = predictor.predict(state, detection.timestamp)
        state = updater.update(SingleHypothesis(prediction, detection))
        track.append(state)
    return track
