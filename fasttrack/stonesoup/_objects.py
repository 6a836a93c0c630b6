"""Stone Soup objects built at the cost of a dictionary: :func:`builder` gives, for a
Stone Soup type, a function that sets a new instance's properties as its constructor would,
without the constructor's generic argument handling (about 9 us of a state's 10)."""
import functools
import os
import weakref

import numpy as np
from stonesoup.base import Base, Property
from stonesoup.types.array import CovarianceMatrix, StateVector
from stonesoup.types.detection import MissedDetection
from stonesoup.types.multihypothesis import MultipleHypothesis
from stonesoup.types.prediction import GaussianMeasurementPrediction, Prediction
from stonesoup.types.state import CreatableFromState, GaussianState, State

_GENERATED = "BaseMeta.__new__.<locals>.__init__"


def _remember_prior_weakly(instance):
    """What ``Prediction.__init__`` does besides setting properties: the prediction that
    made its prior (through the prior's hypothesis) keeps its own prior by weak reference."""
    hypothesis = getattr(instance.prior, "hypothesis", None)
    prediction = getattr(hypothesis, "prediction", None)
    earlier = getattr(prediction, "prior", None)
    if earlier is not None:
        prediction.prior = weakref.ref(earlier)


def _normalise(instance):
    """What ``MultipleHypothesis.__init__`` does besides setting properties (its callers
    here give single hypotheses only)."""
    if instance.normalise:
        instance.normalise_probabilities()


#: The constructors whose only work besides setting the properties (converting a state
#: vector or covariance that is not yet a ``StateVector`` or ``CovarianceMatrix``, checking
#: shapes, which the builders' callers guarantee) is done after a build by the function
#: given (None: nothing more to do).
_KNOWN_INITS = {
    State.__init__: None,
    GaussianState.__init__: None,
    GaussianMeasurementPrediction.__init__: None,
    MissedDetection.__init__: None,
    Prediction.__init__: _remember_prior_weakly,
    MultipleHypothesis.__init__: _normalise,
}

#: Sample values for the properties of these names that a constructor converts or reads.
_SAMPLES = {"state_vector": lambda: StateVector([[0.0]]),
            "covar": lambda: CovarianceMatrix([[1.0]]),
            "cross_covar": lambda: CovarianceMatrix([[0.0]]),
            "single_hypotheses": list,
            "normalise": lambda: False}


def builder(cls):
    """A function ``build(**values)`` returning what ``cls(**values)`` returns for values of
    the properties' own types (a ``StateVector`` state vector, a ``CovarianceMatrix``
    covariance, dimensions that agree), properties not given taking their defaults (every
    property without a default must be given).

    The instance's ``__dict__`` is set directly, as ``Base.__init__`` sets it, when every
    constructor in ``cls``'s hierarchy is a generated one or one of :data:`_KNOWN_INITS`
    (whose further work is then repeated) and no property has a setter; the result is
    checked once against the constructor's on sample values. Otherwise ``build`` is the
    constructor itself.
    """
    follow_ups = []
    for base in cls.__mro__:
        if base is Base:
            break
        init = vars(base).get("__init__")
        if init is None or init.__qualname__ == _GENERATED:
            continue
        if init not in _KNOWN_INITS:
            return cls
        if _KNOWN_INITS[init] is not None:
            follow_ups.append(_KNOWN_INITS[init])
    properties = cls.properties
    if any(prop._setter is not None for prop in properties.values()):
        return cls
    keys = {name: f"_property_{name}" for name in properties}
    template = {keys[name]: prop.default for name, prop in properties.items()}  # in order
    factories = [(f"_property_{name}", prop.default, prop.default_factory)
                 for name, prop in properties.items()
                 if prop.default_factory is not Property.empty]
    new = cls.__new__

    def build(**values):
        instance = new(cls)
        state = instance.__dict__
        state.update(template)
        for name, value in values.items():
            state[keys[name]] = value
        for key, default, factory in factories:
            if state[key] is default:
                state[key] = factory()
        for follow_up in follow_ups:
            follow_up(instance)
        return instance

    samples = {name: _SAMPLES.get(name, object)() for name in properties}
    try:
        expected = list(vars(cls(**samples)).items())
    except Exception:  # noqa: BLE001 - the constructor refuses samples: use it as it is
        return cls
    built = list(vars(build(**samples)).items())
    same = [key for key, _ in expected] == [key for key, _ in built] and all(
        a is b or _equal_arrays(a, b) for (_, a), (_, b) in zip(expected, built))
    return build if same else cls


def _equal_arrays(a, b):
    return isinstance(a, np.ndarray) and type(a) is type(b) and np.array_equal(a, b)


def from_state(kind, state, **values):
    """``kind.from_state(state, **values)`` (``kind``: ``Prediction``, ``Update``, ...) for a
    ``State``: the type that call chooses, built by :func:`builder`, with the properties it
    shares with ``state`` copied and ``values`` (of the properties' own types) given."""
    if not isinstance(state, State):
        return kind.from_state(state, **values)
    build, shared = _made_from(kind, type(state))
    for name in shared:
        if name not in values:
            values[name] = getattr(state, name)
    return build(**values)


@functools.cache
def _made_from(kind, state_type):
    """The builder of what ``kind.from_state`` makes of a ``state_type``, and the names of
    the properties it copies."""
    mapping = CreatableFromState.class_mapping[kind]
    source = next((type_ for type_ in state_type.__mro__ if type_ in mapping), None)
    if source is None:
        raise TypeError(f"{kind.__name__} type not defined for {state_type.__name__}")
    target = mapping[source]
    return builder(target), tuple(name for name in state_type.properties
                                  if name in target.properties)


def fresh_tags(n):
    """``n`` new tags as Stone Soup's tagged states make them (``str(uuid.uuid4())``: random
    version-4 uuids), from one read of the system's randomness."""
    if not n:
        return []
    raw = np.frombuffer(os.urandom(16 * n), np.uint8).reshape(n, 16).copy()
    raw[:, 6] = raw[:, 6] & 0x0F | 0x40  # the version
    raw[:, 8] = raw[:, 8] & 0x3F | 0x80  # the variant
    h = raw.tobytes().hex()
    return [f"{h[i:i + 8]}-{h[i + 8:i + 12]}-{h[i + 12:i + 16]}-{h[i + 16:i + 20]}-"
            f"{h[i + 20:i + 32]}" for i in range(0, 32 * n, 32)]
