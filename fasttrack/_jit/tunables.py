"""Every tunable of fasttrack in one place: the size thresholds that pick serial or
threaded builds, the block sizes of the kernels, and the numerical tolerances and limits.

Kernels read these as compile-time constants; this module lives beside them so that the
kernel cache's source stamp covers it (a new value recompiles what depends on it).
"""

# -- threads: work below which a kernel or a stack of filters runs on one thread ---------

#: Work sizes (elements of a kernel's ``size`` argument) below which it runs on one thread,
#: from the measured crossovers on 2 cores: kernels doing tens of flops per element (a
#: transition, a likelihood, Gram rows) pay for a second thread from about 4,000 particles
#: of 4 components; those doing a few (weights, sums, gathers) from about 32,000 elements.
SERIAL_BELOW_HEAVY = 16_384
SERIAL_BELOW_LIGHT = 32_768
#: Work (``truths.size`` or ``costs.size`` elements) below which the batched assignment
#: kernels run on one thread: every element costs a row of a Dijkstra search or more, so a
#: second thread pays from a few thousand.
SERIAL_BELOW_ASSIGN = 4096
#: Track-detection pairs below which the PDA weights run on one thread: measured on 2
#: cores, 100 x 200 pairs take 0.11 ms on one thread and 0.22 ms on two, 300 x 600 the same
#: on both, 1000 x 2000 1.5x less on two.
SERIAL_BELOW_PAIRS = 131_072
#: Filters of a Gaussian stack below which its chunks run on one thread.
SERIAL_BELOW_FILTERS = 1024

# -- blocks -------------------------------------------------------------------------------

#: Particles per block in the kernels over particle clouds (propagation, likelihoods, weight
#: sums): a block of a few rows fits a core's L1 cache, and the random stream's layout
#: depends on it.
BLOCK = 1024
#: Filters per block of the Kalman and unscented stack kernels (chunks of a stack are
#: aligned to it).
FILTERS_PER_BLOCK = 128
#: Weights summed per block by the backward simulation (independent sums that the processor
#: overlaps), and searched block by block.
FFBS_BLOCK = 16
#: State dimensions for which the RTS smoother compiles the pass with the dimension a
#: constant, so that LLVM unrolls the loops over it (d = 4: 2.0x faster a step).
UNROLLED_DIMENSIONS = (2, 4, 6)

# -- tolerances and limits ------------------------------------------------------------------

#: Relative tolerance of the positive semi-definiteness checks: an eigenvalue (or a
#: Cholesky pivot) below ``-PSD_TOLERANCE`` times the largest is negative, not rounding.
PSD_TOLERANCE = 1e-10
#: The most a mean's component may exceed its standard deviation in an unscented transform:
#: its sigma points ``x +- sqrt(c) L`` keep about ``16 - log10(ratio)`` digits of their
#: spread (float64), so beyond 1e12 the transform's moments would be rounding errors.
SIGMA_RESOLUTION = 1e12
#: Variances below this count as none in that check: a state known to 1e-100 is known
#: exactly (its transform is f(x), whatever rounds), as a zero covariance's is.
NEGLIGIBLE_VARIANCE = 1e-200
#: Up to this bound on the condition number of ``F F^T + lam I`` the AKKF's ridge map is
#: computed through its Cholesky factorisation (relative error about cond * eps <= 2e-8);
#: above it, by LQ, whose error grows with the square root of the condition number only.
CHOLESKY_CONDITION = 1e8
#: A filter's Gaussian kernel of fixed variance whose value between typical points (at
#: their median squared distance) is below this carries no information between them.
NEGLIGIBLE_KERNEL = 1e-6
#: Pairs of points sampled by the median heuristic when there are more than all pairs.
MEDIAN_PAIRS = 256
#: Proposals a backward-simulation path draws by rejection before it takes the exact draw:
#: this bounds the tail of the transition density to 32 proposals more than the exact draw
#: (as much as 2048 / N exact draws, see :data:`PROPOSAL_COST`), while a path accepting one
#: proposal in 10 still falls back only 3 % of the time.
MAX_PROPOSALS = 32
#: The cost of one proposal (two uniforms, a bisection, a distance) in units of one
#: particle's term of the exact draw, measured on 2 cores at N = 1000, d = 4 (about 90 ns
#: against 1.4 ns): rejection pays while its acceptance rate exceeds this over N.
PROPOSAL_COST = 64.0
#: Most detections a JPDA level's frontier may hold (bits of an int64 below its sign bit).
MAX_FRONTIER = 63
#: Default most nodes of one cluster's EHM net (memory: roughly 8 bytes per node, 8 per
#: node and hypothesis, plus 16 for its forward and backward weights).
MAX_NODES = 2**22
#: Most joint events times tracks of a JPDA cluster that a process's first calls enumerate
#: in NumPy (``fasttrack.core.jpda``) instead of loading the EHM kernels.
ENUMERATED_EVENTS = 4096

#: Work a process runs in NumPy before its first kernel (``fasttrack._jit.numpy_first``), in
#: units of one filter, track or detection handled (a one-filter Kalman step is one unit,
#: 30-60 us in NumPy; a scan of K tracks and M detections a few times K + M units, 1-8 us
#: each): a short script never pays Numba's set-up (its import, target, kernel loads and
#: exit, about 0.7 s), and a long one spends at most about as long again in NumPy first.
NUMPY_WORK = 8000

#: Below this many components a mixture reduction tests every pair; above, a grid on two state
#: axes gates the merge tests.
REDUCE_GRID_FROM = 64
#: Most components of a gated mixture reduction whose merge radius exceeds the grid's cell
#: (they are tested against every merge; the cell is their next-largest radius).
REDUCE_WIDE = 32
