"""Multi-target data association on arrays: gating, clusters, nearest-neighbour and global
nearest-neighbour assignment, and joint probabilistic data association (the public face of
:mod:`fasttrack.core.gating`, :mod:`fasttrack.core.assign` and :mod:`fasttrack.core.jpda`)."""
from ..core.assign import (assign2d, assign2d_batch, global_nearest_neighbour, gnn_assign,
                           nearest_neighbour)
from ..core.gating import Clusters, Gate, clusters, gate
from ..core.jpda import jpda_marginals, pda_weights

__all__ = ["Clusters", "Gate", "assign2d", "assign2d_batch", "clusters", "gate", "gnn_assign",
           "global_nearest_neighbour", "jpda_marginals", "nearest_neighbour", "pda_weights"]
