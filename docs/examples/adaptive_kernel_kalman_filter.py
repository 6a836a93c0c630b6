"""
Adaptive kernel Kalman filter
=============================

The adaptive-kernel-Kalman-filter tutorial on fasttrack: a nearly-constant-velocity target
seen by a bearing-only sensor, tracked by the AKKF with quadratic, quartic and Gaussian
kernels.

Run ``python docs/examples/adaptive_kernel_kalman_filter.py [DIR]``; given DIR, it writes its plot there.
"""
import datetime
import sys

import numpy as np

import fasttrack as ft
from fasttrack.metrics import position_rmse

out = sys.argv[1] if len(sys.argv) > 1 else None
rng = np.random.default_rng(50)
start_time = datetime.datetime(2026, 1, 1)

transition_model = ft.CombinedLinearGaussianTransitionModel([ft.ConstantVelocity(1e-4),
                                                             ft.ConstantVelocity(1e-4)])
truth = ft.ground_truth(transition_model, [-0.3, 0.001, 0.7, -0.055], 30,
                        start_time=start_time, rng=rng)
measurement_model = ft.Cartesian2DToBearing(ndim_state=4, mapping=(0, 2),
                                            noise_covar=np.array([[0.005 ** 2]]))
measurements = ft.detections(truth, measurement_model, rng=rng)

number_particles = 30
samples = rng.multivariate_normal(truth[0].state_vector.ravel(),
                                  np.diag([0.1, 0.005, 0.1, 0.01]) ** 2, size=number_particles)
prior = ft.KernelParticleState(samples.T, timestamp=start_time)  # weights 1/M, S = I/M

kernels = {"quadratic": ft.QuadraticKernel(c=1, ialpha=1),
           "quartic": ft.QuarticKernel(c=1, ialpha=1),
           "gaussian": ft.GaussianKernel()}
tracks = {}
for name, kernel in kernels.items():
    predictor = ft.AdaptiveKernelKalmanPredictor(transition_model, kernel)
    updater = ft.AdaptiveKernelKalmanUpdater(measurement_model, kernel, rng=rng)
    track = ft.run_filter(predictor, updater, prior, measurements)
    tracks[name] = track
    print(f"AKKF, {name} kernel: position RMSE {position_rmse(track, truth):.3f}")

if out:
    from fasttrack import plotting
    ax = plotting.plot_ground_truth(truth)
    plotting.plot_detections(measurements, ax=ax)
    for name, track in tracks.items():
        plotting.plot_track(track, ax=ax, label=f"AKKF - {name}",
                            particles=name == "quadratic")
    plotting.save(ax, f"{out}/adaptive_kernel_kalman_filter.png", title="AKKF")
