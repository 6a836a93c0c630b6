"""
Particle filter
===============

The particle-filter tutorial on fasttrack: a nearly-constant-velocity target seen by a
bearing-range sensor, tracked by a sequential importance resampling particle filter.

Run ``python docs/examples/particle_filter.py [DIR]``; given DIR, it writes its plot there.
"""
import datetime
import sys

import numpy as np

import fasttrack as ft
from fasttrack.metrics import position_rmse

out = sys.argv[1] if len(sys.argv) > 1 else None
rng = np.random.default_rng(1991)
start_time = datetime.datetime(2026, 1, 1)

# Ground truth: CV in x and y with q = 0.05, 21 states a second apart.
transition_model = ft.CombinedLinearGaussianTransitionModel([ft.ConstantVelocity(0.05),
                                                             ft.ConstantVelocity(0.05)])
truth = ft.ground_truth(transition_model, [0, 1, 0, 1], 21, start_time=start_time, rng=rng)

# Bearing (0.2 deg) and range (1 m) from a sensor at (50, 0).
measurement_model = ft.CartesianToBearingRange(
    ndim_state=4, mapping=(0, 2), noise_covar=np.diag([np.radians(0.2), 1]),
    translation_offset=[50, 0])
measurements = ft.detections(truth, measurement_model, rng=rng)

predictor = ft.ParticlePredictor(transition_model, rng=rng)
updater = ft.ParticleUpdater(measurement_model, ft.SystematicResampler(rng=rng))

# Prior: 1000 samples of N((0, 1, 0, 1), diag(1.5, 0.5, 1.5, 0.5)), equal weights.
number_particles = 1000
samples = rng.multivariate_normal([0, 1, 0, 1], np.diag([1.5, 0.5, 1.5, 0.5]),
                                  size=number_particles)
prior = ft.ParticleState(samples.T, timestamp=start_time)

# The tutorial's loop; ft.run_filter(predictor, updater, prior, measurements) does the same.
track = ft.Track()
for measurement in measurements:
    prediction = predictor.predict(prior, timestamp=measurement.timestamp)
    hypothesis = ft.SingleHypothesis(prediction, measurement)
    post = updater.update(hypothesis)
    track.append(post)
    prior = track[-1]

print(f"{len(track)} updates, position RMSE {position_rmse(track, truth):.2f} m")

if out:
    from fasttrack import plotting
    ax = plotting.plot_ground_truth(truth)
    plotting.plot_detections(measurements, ax=ax)
    plotting.plot_track(track, ax=ax, particles=True, color="tab:red")
    plotting.save(ax, f"{out}/particle_filter.png", title="Particle filter")
