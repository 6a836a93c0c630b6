"""Plots of tracking scenarios and resampling, with matplotlib (``pip install
'fasttrack[plot]'``).

Every function draws on the given ``ax`` (a new figure's axes if None) and returns the axes;
nothing is shown. Positions are the state components ``mapping`` (default x = 0, y = 2).
"""
import numpy as np

try:
    import matplotlib.figure
except ImportError as error:
    raise ImportError("fasttrack.plotting needs matplotlib: pip install 'fasttrack[plot]'") \
        from error

from .models.measurement import CartesianToBearingRange


def _axes(ax):
    if ax is not None:
        return ax
    figure = matplotlib.figure.Figure(figsize=(7, 5.5))
    return figure.add_subplot()


def _positions(states, mapping):
    return np.array([np.ravel(getattr(s, "mean", s.state_vector))[list(mapping)]
                     for s in states]).reshape(-1, 2)


def plot_ground_truth(truth, mapping=(0, 2), ax=None, units="m", **style):
    """The true path as a dashed line; the axes are labelled with the position components
    and their ``units``."""
    ax = _axes(ax)
    xy = _positions(truth, mapping)
    ax.plot(xy[:, 0], xy[:, 1], **{"linestyle": "--", "color": "k", "label": "ground truth",
                                   **style})
    ax.set_xlabel(f"x = state[{mapping[0]}] ({units})")
    ax.set_ylabel(f"y = state[{mapping[1]}] ({units})")
    return ax


def plot_detections(detections, measurement_model=None, ax=None, **style):
    """Detections mapped back to the position plane: bearing-range detections through the
    model's ``inverse_function``; bearing-only ones as rays from the sensor, three times as
    long as the distance to the far corner of the axes' current view, and left out of the
    axes' autoscaling (so they never stretch the view of what else is drawn)."""
    ax = _axes(ax)
    points, rays = [], []
    for detection in detections:
        model = getattr(detection, "measurement_model", None) or measurement_model
        if isinstance(model, CartesianToBearingRange):
            points.append(model.inverse_function(detection)[list(model.mapping[:2]), 0])
        elif model is not None and model.ndim_meas == 1 and model.angle_components == (0,):
            rays.append((model, float(np.ravel(detection.state_vector)[0])))
        else:
            raise ValueError(f"cannot map {type(model).__name__} detections to positions")
    if points:
        xy = np.array(points)
        ax.scatter(xy[:, 0], xy[:, 1], **{"marker": "o", "facecolors": "none",
                                          "edgecolors": "tab:gray", "label": "detections",
                                          **style})
    corners = np.array([[x, y] for x in ax.get_xlim() for y in ax.get_ylim()])
    segments = []
    for model, bearing in rays:
        origin = np.ravel(model.translation_offset)[:2]
        reach = 3 * (np.linalg.norm(corners - origin, axis=1).max() or 1.0)
        angle = bearing + model.rotation_offset.ravel()[2]
        segments.append([origin, origin + reach * np.array([np.cos(angle), np.sin(angle)])])
    if segments:
        from matplotlib.collections import LineCollection
        ax.add_collection(LineCollection(segments, **{
            "color": "tab:blue", "alpha": 0.25, "linewidth": 0.8, "label": "bearings",
            **style}), autolim=False)
    return ax


def _ellipse(ax, mean, covar, **style):
    from matplotlib.patches import Ellipse
    values, vectors = np.linalg.eigh(covar)
    angle = np.degrees(np.arctan2(vectors[1, -1], vectors[0, -1]))
    width, height = 2 * np.sqrt(np.maximum(values[::-1], 0.0))
    ax.add_patch(Ellipse(mean, width, height, angle=angle,
                         **{"fill": False, "alpha": 0.4, **style}))


def plot_track(track, mapping=(0, 2), ax=None, particles=False, uncertainty=False,
               label="track", **style):
    """A track's means as a line; with ``particles``, every state's particle cloud; with
    ``uncertainty``, the one-sigma ellipse of each state's position covariance (39 % of the
    probability in 2-D)."""
    ax = _axes(ax)
    xy = _positions(track, mapping)
    line, = ax.plot(xy[:, 0], xy[:, 1], **{"marker": ".", "label": label, **style})
    index = list(mapping)
    for k, state in enumerate(track):
        if particles and getattr(state, "state_vector", np.empty((0, 0))).shape[1] > 1:
            cloud = np.asarray(state.state_vector)[index]
            ax.scatter(cloud[0], cloud[1], s=1, alpha=0.15, color=line.get_color(),
                       label=f"{label} particles" if k == 0 else None)
        if uncertainty:
            covar = np.asarray(state.covar)[np.ix_(index, index)]
            mean = np.ravel(getattr(state, "mean", state.state_vector))[index]
            _ellipse(ax, mean, covar, edgecolor=line.get_color(),
                     label=f"{label} 1-sigma ellipses" if k == 0 else None)
    return ax


def _paths(ids_per_scan, points_per_scan):
    """{identity: (n, 2) positions in scan order} from per-scan identities and points."""
    paths = {}
    for ids, points in zip(ids_per_scan, points_per_scan):
        for i, xy in zip(ids, points):
            paths.setdefault(int(i), []).append(xy)
    return {i: np.array(xy) for i, xy in paths.items()}


def plot_multi_target(scenario, tracks=None, mapping=(0, 2), ax=None, units="m"):
    """A multi-target scenario: every target's true path (dashed), the clutter of all scans
    (grey dots), the target detections (circles) and, given the tracker's output ``tracks``
    (one track set per scan, with ``ids`` and ``means``), each track's path in its own
    colour. Needs a position sensor (detections in the ``mapping`` plane).

    Parameters
    ----------
    scenario : fasttrack.simulate.MultiTargetScenario
    tracks : sequence of TrackSet or GaussianMixture, optional
        E.g. ``MultiTargetTracker.run(scenario.detections)``, or the labelled estimates of
        ``PHDTracker.run`` (a path per label).
    mapping : sequence of int
        The position components of the states.
    ax : matplotlib.axes.Axes, optional
    units : str
        Position units, for the axis labels.
    """
    ax = _axes(ax)
    index = list(mapping)
    truths = _paths(scenario.truth_ids, [x[:, index] for x in scenario.truths])
    for k, xy in enumerate(truths.values()):
        ax.plot(xy[:, 0], xy[:, 1], linestyle="--", color="k", linewidth=0.8,
                label="ground truth" if k == 0 else None)
    detections = np.concatenate(scenario.detections)
    origins = np.concatenate(scenario.origins)
    ax.scatter(*detections[origins < 0].T, s=2, color="tab:gray", alpha=0.5, label="clutter")
    ax.scatter(*detections[origins >= 0].T, s=8, facecolors="none", edgecolors="tab:blue",
               linewidths=0.5, label="target detections")
    if tracks is not None:
        labelled = not all(hasattr(t, "ids") for t in tracks)  # a PHD tracker's estimates
        paths = _paths([t.labels if labelled else t.ids for t in tracks],
                       [t.means[:, index] for t in tracks])
        name = "estimates (a path per label)" if labelled else "tracks"
        for k, xy in enumerate(paths.values()):
            ax.plot(xy[:, 0], xy[:, 1], linewidth=1.2, label=name if k == 0 else None)
    ax.set_xlabel(f"x = state[{mapping[0]}] ({units})")
    ax.set_ylabel(f"y = state[{mapping[1]}] ({units})")
    return ax


def plot_target_count(scenario, estimated, ax=None):
    """The number of targets over the scans: the truth's (a step line) and each series of
    ``estimated``.

    Parameters
    ----------
    scenario : fasttrack.simulate.MultiTargetScenario
    estimated : dict of str to sequence of float
        Label: one estimated number a scan (e.g. the number of a PHD tracker's estimates).
    ax : matplotlib.axes.Axes, optional
    """
    ax = _axes(ax)
    scans = np.arange(len(scenario.truths))
    ax.step(scans, [len(x) for x in scenario.truths], where="mid", color="k", linewidth=1.5,
            label="true number")
    for label, counts in estimated.items():
        ax.plot(scans[:len(counts)], counts, marker=".", markersize=4, linewidth=0.8,
                label=label)
    ax.set_xlabel("scan")
    ax.set_ylabel("number of targets")
    return ax


def plot_paths(paths, ax=None, units="m"):
    """Paths in the plane, the first dashed black (a truth), the others in colour.

    Parameters
    ----------
    paths : dict of str to (n, 2) array_like
        Label: positions (x, y) in order.
    ax : matplotlib.axes.Axes, optional
    units : str
        Position units, for the axis labels.
    """
    ax = _axes(ax)
    for k, (label, xy) in enumerate(paths.items()):
        xy = np.asarray(xy, dtype=np.float64)
        style = {"linestyle": "--", "color": "k", "linewidth": 0.8} if k == 0 else \
            {"linewidth": 1.0}
        ax.plot(xy[:, 0], xy[:, 1], label=label, **style)
    ax.set_xlabel(f"x ({units})")
    ax.set_ylabel(f"y ({units})")
    return ax


def plot_mode_probabilities(mode_probs, labels, turn_rates=None, ax=None):
    """A multiple-model filter's mode probabilities over the scans, a line a model, over
    the manoeuvres flown (grey where the target turned).

    Parameters
    ----------
    mode_probs : (T, M) array_like
    labels : sequence of M str
        The models' names.
    turn_rates : (T,) array_like, optional
        The turn rate flown into each scan (e.g. ``ManoeuvringScenario.turn_rates``).
    ax : matplotlib.axes.Axes, optional
    """
    ax = _axes(ax)
    probs = np.asarray(mode_probs, dtype=np.float64)
    scans = np.arange(probs.shape[0])
    if turn_rates is not None:
        turning = np.asarray(turn_rates)[:probs.shape[0]] != 0
        ax.fill_between(scans, 0, 1, where=turning, color="tab:gray", alpha=0.2,
                        step="mid", label="turning")
    for column, label in zip(probs.T, labels):
        ax.plot(scans, column, linewidth=1.0, label=label)
    ax.set_ylim(0, 1)
    ax.set_xlabel("scan")
    ax.set_ylabel("mode probability")
    return ax


def plot_resampling(weights, points=None, offspring=None, ax=None):
    """The resampling picture of the resampler tutorial: each particle's weight as a bar of
    the cumulative weights on [0, 1], and either the uniform ``points`` a scheme drew (each
    falls in the bar of the particle it selects), or the ``offspring`` counts: a particle
    drawn k times gets k marks spread across its own bar and the label "x k"."""
    ax = _axes(ax)
    weights = np.asarray(weights, dtype=np.float64)
    cdf = np.concatenate(([0.0], np.cumsum(weights / weights.sum())))
    for i in range(weights.size):
        ax.barh(0, cdf[i + 1] - cdf[i], left=cdf[i], height=0.5, edgecolor="k",
                label=f"particle {i} (w = {weights[i] / weights.sum():.3g})"
                if weights.size <= 10 else None)
    marks = np.asarray(points, dtype=np.float64) if points is not None else np.empty(0)
    if offspring is not None:
        offspring = np.asarray(offspring)
        if offspring.shape != weights.shape:
            raise ValueError(f"offspring must have one count per weight, {weights.shape}, "
                             f"got {offspring.shape}")
        marks = np.concatenate([cdf[i] + (np.arange(k) + 0.5) / k * (cdf[i + 1] - cdf[i])
                                for i, k in enumerate(offspring) if k > 0] or [np.empty(0)])
        for i, k in enumerate(offspring):
            if k > 0:
                ax.annotate(f"x {k}", ((cdf[i] + cdf[i + 1]) / 2, -0.38), ha="center",
                            fontsize="small")
    if marks.size:
        ax.scatter(marks, np.full(marks.size, 0.35), marker="v", color="k", zorder=3,
                   label="drawn points" if offspring is None else "drawn copies")
    ax.set_xlim(0, 1)
    ax.set_ylim(-0.5, 0.5)
    ax.set_yticks([])
    ax.set_xlabel("cumulative normalised weight")
    return ax


def save(ax, path, legend=True, title=None):
    """Write the axes' figure to ``path`` (PNG by extension; its folder is created if
    needed); returns the path."""
    import pathlib
    pathlib.Path(path).parent.mkdir(parents=True, exist_ok=True)
    if title:
        ax.set_title(title)
    if legend and ax.get_legend_handles_labels()[0]:
        ax.legend(loc="best", fontsize="small")
    ax.figure.savefig(path, dpi=100, bbox_inches="tight")
    return path
