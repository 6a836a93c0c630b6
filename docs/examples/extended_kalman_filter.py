"""
Extended Kalman filter
======================

The extended-Kalman-filter tutorial on fasttrack: the particle-filter tutorial's target and
bearing-range sensor, tracked by an EKF whose measurement Jacobian comes from finite
differences (Stone Soup's rule) or in closed form.

Run ``python docs/examples/extended_kalman_filter.py [DIR]``; given DIR, it writes its plot there.
"""
import datetime
import sys

import numpy as np

import fasttrack as ft
from fasttrack.metrics import position_rmse

out = sys.argv[1] if len(sys.argv) > 1 else None
rng = np.random.default_rng(1991)
start_time = datetime.datetime(2026, 1, 1)

transition_model = ft.CombinedLinearGaussianTransitionModel([ft.ConstantVelocity(0.05),
                                                             ft.ConstantVelocity(0.05)])
truth = ft.ground_truth(transition_model, [0, 1, 0, 1], 21, start_time=start_time, rng=rng)
measurement_model = ft.CartesianToBearingRange(
    ndim_state=4, mapping=(0, 2), noise_covar=np.diag([np.radians(0.2), 1]),
    translation_offset=[50, 0])
measurements = ft.detections(truth, measurement_model, rng=rng)

# A bearing-range detection mapped back to Cartesian coordinates.
print("first detection at", measurement_model.inverse_function(measurements[0]).ravel()[[0, 2]])

predictor = ft.ExtendedKalmanPredictor(transition_model)
tracks = {}
for jacobian in ("forward", "analytic"):
    updater = ft.ExtendedKalmanUpdater(measurement_model, jacobian=jacobian)
    prior = ft.GaussianState([0, 1, 0, 1], np.diag([1.5, 0.5, 1.5, 0.5]), timestamp=start_time)
    track = ft.run_filter(predictor, updater, prior, measurements)
    tracks[jacobian] = track
    print(f"{jacobian} Jacobian: position RMSE {position_rmse(track, truth):.2f} m")

difference = max(np.abs(a.state_vector - b.state_vector).max()
                 for a, b in zip(tracks["forward"], tracks["analytic"]))
print(f"largest difference between the two tracks: {difference:.2e}")

if out:
    from fasttrack import plotting
    ax = plotting.plot_ground_truth(truth)
    plotting.plot_detections(measurements, ax=ax)
    plotting.plot_track(tracks["forward"], ax=ax, uncertainty=True, color="tab:red")
    plotting.save(ax, f"{out}/extended_kalman_filter.png", title="Extended Kalman filter")
