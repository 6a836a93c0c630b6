"""Which drop-in hypothesisers the vectorised scan (``_scan``) computes: the registry of
their ``hypothesise`` functions, and the recipe read from a (gated) hypothesiser."""
from . import predictor as _predictor
from . import updater as _updater
from ._convert import fast_model, zero_control
from ._fallback import unknown_model
from .measures import _measure_kind


#: The ``hypothesise`` functions the vectorised path computes (those of the drop-in gater
#: and hypothesisers, not a subclass's own), each with what it computes: "gate",
#: "distance" or "pda".
_VECTORISED = {}


def vectorised(kind):
    """Class decorator: the vectorised path computes the class's own ``hypothesise`` as
    ``kind`` ("gate", "distance" or "pda")."""
    def register(cls):
        _VECTORISED[cls.hypothesise] = kind
        return cls
    return register


class Recipe:
    """What a (gated) drop-in hypothesiser computes: its base hypothesiser, the kind of
    hypotheses ('distance' or 'pda'), the distance measure, the gaters' thresholds, the
    predictor and updater and the fasttrack transition model."""

    __slots__ = ("base", "kind", "measure", "gates", "predictor", "updater", "transition")

    def __init__(self, base, kind, measure, gates, transition):
        self.base, self.kind, self.measure, self.gates = base, kind, measure, tuple(gates)
        self.predictor, self.updater = base.predictor, base.updater
        self.transition = transition


def recipe_of(hypothesiser):
    """The :class:`Recipe` of ``hypothesiser``, or the reason Stone Soup's code must run."""
    gates = []
    while _VECTORISED.get(type(hypothesiser).hypothesise) == "gate":
        if _measure_kind(hypothesiser.measure) != "mahalanobis":
            return f"a gater's measure {type(hypothesiser.measure).__name__}"
        gates.append(float(hypothesiser.gate_threshold))
        hypothesiser = hypothesiser.hypothesiser
    kind = _VECTORISED.get(type(hypothesiser).hypothesise)
    if kind == "distance":
        measure = _measure_kind(hypothesiser.measure)
        if measure is None or (gates and measure != "mahalanobis"):
            return f"measure {type(hypothesiser.measure).__name__}"
        if hypothesiser.predict_with_measurements:
            return "predict_with_measurements"
    elif kind == "pda":
        measure = "mahalanobis"
        if hypothesiser.include_all and hypothesiser.clutter_spatial_density is None:
            return "include_all without clutter_spatial_density"
    else:
        return f"hypothesiser {type(hypothesiser).__name__}"
    predictor, updater = hypothesiser.predictor, hypothesiser.updater
    if type(predictor).predict is not _predictor._Kalman.predict:
        return f"predictor {type(predictor).__name__}"
    if type(updater).predict_measurement is not _updater._Kalman.predict_measurement:
        return f"updater {type(updater).__name__}"
    transition = fast_model(predictor.transition_model)
    if transition is None:
        return unknown_model(predictor.transition_model)
    if not zero_control(predictor.control_model):
        return "a control model"
    return Recipe(hypothesiser, kind, measure, gates, transition)
