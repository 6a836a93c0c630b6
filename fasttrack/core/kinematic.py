"""The compiled functions of the built-in nonlinear motion models (their filters call them
as they call a user's model function)."""
from .. import _jit

_turn = _jit.lazy("turn")


def constant_turn():
    """The constant-turn function ``f(states, dt)`` (:func:`fasttrack._jit.turn.
    constant_turn`), compiled on first use."""
    return _turn.constant_turn
