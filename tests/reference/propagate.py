"""Mirrors of ``fasttrack._jit.propagate``: particles moved by a linear transition or a
user's function, with the kernels' layout of the process noise."""
import numpy as np

from .numeric import fill_normals
from .status import OK
from .user import output_status


PROPAGATE_BLOCK = 1024


def _process_noise(noise_root, key, n):
    """S z for n particles, with the kernels' layout of the normals: block b fills
    ``even * BLOCK`` normals (even = d rounded up to even) from pair ``b * BLOCK * even / 2``,
    and component c of its particle i is entry ``c * BLOCK + i``."""
    d = noise_root.shape[0]
    even = d + d % 2
    blocks = -(-n // PROPAGATE_BLOCK)
    z = np.empty((d, blocks * PROPAGATE_BLOCK))
    for b in range(blocks):
        block = np.empty(even * PROPAGATE_BLOCK)
        fill_normals(key, b * PROPAGATE_BLOCK * even // 2, block)
        z[:, b * PROPAGATE_BLOCK:(b + 1) * PROPAGATE_BLOCK] = block[:d * PROPAGATE_BLOCK].reshape(
            d, PROPAGATE_BLOCK)
    return noise_root @ z[:, :n]


def propagate_linear(x, matrix, noise_root, key, out):
    out[:] = matrix @ x
    if np.any(noise_root != 0):
        out += _process_noise(noise_root, key, x.shape[1])


def propagate_function(function, time_interval, x, noise_root, key, out):
    values = function(np.ascontiguousarray(x), time_interval)
    status = output_status(values, x.shape[0], x.shape[1])
    if status == OK:
        out[:] = values
        if np.any(noise_root != 0):
            out += _process_noise(noise_root, key, x.shape[1])
    return status
