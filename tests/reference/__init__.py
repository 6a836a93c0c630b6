"""Plain-NumPy mirrors of the kernels in ``fasttrack._jit`` (same names, same arguments,
loops allowed), one module per kernel module: the kernel ``fasttrack._jit.<module>.<name>``
has its mirror ``reference.<module>.<name>`` (tests/test_jit.py checks it). ``status`` and
``sensor`` hold the status codes and measurement kinds that several mirrors share. Tests give
a kernel and its mirror the same inputs, including the same random stream keys, and compare:
integers equal, floats close.

Tests import the modules they use: ``import reference.kalman``, then
``reference.kalman.update_one(...)``."""
