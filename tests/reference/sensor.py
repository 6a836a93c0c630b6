"""The measurement kinds of ``fasttrack._jit.sensor`` (plain ints), which mirrors of several
modules take. The sensor kernels themselves are private: the mirrors of the kernels that call
them cover them."""

SELECT, BEARING_RANGE, BEARING = 0, 1, 2
