"""
Multiple models on Stone Soup's types
=====================================

Stone Soup's multiple-model tutorial flies one target for 600 s: straight, a right turn,
straight, a left turn, straight. An interacting multiple model (IMM) filter of three models,
a left turn, straight flight and a right turn, follows it; its mode probabilities switch
with the manoeuvres. Here the filter is ``fasttrack.stonesoup``'s IMM pair on Stone Soup's
own models, predictors, updaters and ``GaussianMixture`` (one kernel call a step), and the
fixed-interval IMM smoother of ``fasttrack.BatchIMMFilter`` revisits the flight afterwards.

Run ``python docs/examples/multiple_models.py [DIR]``; given DIR, it writes its plots there.
"""
import datetime
import sys

import numpy as np
from stonesoup.functions import gm_reduce_single
from stonesoup.models.measurement.linear import LinearGaussian
from stonesoup.models.transition.linear import (CombinedLinearGaussianTransitionModel,
                                                ConstantVelocity, KnownTurnRate)
from stonesoup.predictor.kalman import KalmanPredictor
from stonesoup.types.detection import Detection
from stonesoup.types.hypothesis import SingleHypothesis
from stonesoup.types.mixture import GaussianMixture
from stonesoup.types.state import WeightedGaussianState
from stonesoup.updater.kalman import KalmanUpdater

import fasttrack as ft
from fasttrack import stonesoup as drop
from fasttrack.scenarios import manoeuvring_target

out = sys.argv[1] if len(sys.argv) > 1 else None
scenario = manoeuvring_target(seed=1)
start = datetime.datetime(2026, 1, 1)
rates = (0.02, 0.0, -0.02)  # rad/s: left, straight, right
q = 1e-2  # the flight's own process noise (m^2/s^3)
models = [KnownTurnRate(turn_noise_diff_coeffs=np.array([q, q]), turn_rate=rate) if rate
          else CombinedLinearGaussianTransitionModel([ConstantVelocity(q)] * 2)
          for rate in rates]
sensor = LinearGaussian(4, [0, 2], np.diag([0.725, 0.7025]))
switching = np.full((3, 3), 0.05) + 0.85 * np.eye(3)  # [i, j]: from model i to model j
predictor = drop.IMMPredictor([KalmanPredictor(model) for model in models], switching)
updater = drop.IMMUpdater([KalmanUpdater(sensor) for _ in models], switching)

x, y = scenario.measurements[0]
state = GaussianMixture([WeightedGaussianState([[x], [-30.0], [y], [-30.0]],
                                               np.diag([1.0, 25.0, 1.0, 25.0]),
                                               timestamp=start, weight=1 / 3)] * 3)
history = []
for t, z in enumerate(scenario.measurements[1:], start=1):
    when = start + datetime.timedelta(seconds=t)
    prediction = predictor.predict(state, timestamp=when)
    state = updater.update(SingleHypothesis(prediction, Detection(
        z.reshape(2, 1), timestamp=when, measurement_model=sensor)))
    history.append(state)

weights = np.array([[float(c.weight) for c in s.components] for s in history])
means = np.array([[np.asarray(c.state_vector, float).ravel() for c in s.components]
                  for s in history])
covars = np.array([[np.asarray(c.covar, float) for c in s.components] for s in history])
estimates = np.array([np.asarray(gm_reduce_single(
    np.asarray([c.state_vector for c in s.components], float)[..., 0].T,
    np.stack([c.covar for c in s.components], axis=2), weights[k])[0], float).ravel()
    for k, s in enumerate(history)])

# The smoother takes the filtered models as arrays: (T, M, d), (T, M, d, d), (T, M).
smoother = ft.BatchIMMFilter([ft.KnownTurnRate([q, q], rate) for rate in rates],
                             ft.LinearGaussian(4, (0, 2), np.diag([0.725, 0.7025])), switching)
smoothed = smoother.smooth(means, covars, weights, 1.0)
smoothed_estimates = ft.BatchIMMFilter.combine(*smoothed)[0]

truths, flown = scenario.truths[1:], scenario.turn_rates[1:]
for name, xs in (("filtered", estimates), ("smoothed", smoothed_estimates)):
    error = np.hypot(xs[:, 0] - truths[:, 0], xs[:, 2] - truths[:, 2])
    print(f"{name} position RMSE: {np.sqrt(np.mean(error ** 2)):.2f} m")
model_flown = np.select([flown > 0, flown < 0], [0, 2], 1)
for name, probs in (("filtered", weights), ("smoothed", smoothed[2])):
    print(f"{name}: the most probable model is the one flown at "
          f"{np.mean(probs.argmax(axis=1) == model_flown):.0%} of the steps")

if out:
    import pathlib

    import matplotlib.pyplot as plt

    from fasttrack import plotting

    fig, (ax, right) = plt.subplots(1, 2, figsize=(11, 5))
    ax.plot(truths[:, 0], truths[:, 2], "k-", lw=1, label="truth")
    ax.plot(*scenario.measurements[1:].T, ".", color="0.6", ms=2, label="measurements")
    ax.plot(estimates[:, 0], estimates[:, 2], "-", color="tab:blue", lw=1, label="IMM")
    ax.plot(smoothed_estimates[:, 0], smoothed_estimates[:, 2], "-", color="tab:red", lw=1,
            label="IMM smoothed")
    ax.set(xlabel="x (m)", ylabel="y (m)", aspect="equal", title="the flight")
    ax.legend()
    for xs, color, label in ((estimates, "tab:blue", "IMM"),
                             (smoothed_estimates, "tab:red", "IMM smoothed")):
        right.plot(np.hypot(xs[:, 0] - truths[:, 0], xs[:, 2] - truths[:, 2]), color=color,
                   lw=1, label=label)
    right.fill_between(np.arange(len(flown)), 0, 1, where=flown != 0, color="tab:gray",
                       alpha=0.2, step="mid", transform=right.get_xaxis_transform(),
                       label="turning")
    right.set(xlabel="scan", ylabel="position error (m)", title="error against the truth")
    right.legend()
    fig.tight_layout()
    fig.savefig(pathlib.Path(out) / "multiple_models_track.png", dpi=120)
    fig, axes = plt.subplots(2, 1, figsize=(8, 5), sharex=True)
    for ax, probs, title in ((axes[0], weights, "filtered"),
                             (axes[1], smoothed[2], "smoothed")):
        plotting.plot_mode_probabilities(probs, ["left turn", "straight", "right turn"],
                                         flown, ax=ax)
        ax.set_title(f"mode probabilities, {title}")
    axes[0].legend(loc="center left", fontsize="small")
    fig.tight_layout()
    fig.savefig(pathlib.Path(out) / "multiple_models_modes.png", dpi=120)
