"""Multi-target data association on arrays: gating, clusters, nearest-neighbour and global
nearest-neighbour assignment, and joint probabilistic data association."""
from .assignment import assign2d, assign2d_batch, gnn_assign
from .gating import Clusters, Gate, clusters, gate
from .jpda import jpda_marginals, pda_weights
from .neighbour import global_nearest_neighbour, nearest_neighbour

__all__ = ["Clusters", "Gate", "assign2d", "assign2d_batch", "clusters", "gate", "gnn_assign",
           "global_nearest_neighbour", "jpda_marginals", "nearest_neighbour", "pda_weights"]
