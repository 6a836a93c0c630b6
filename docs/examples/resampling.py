"""
Resampling
==========

The resampler tutorial on fasttrack: the five resampling schemes on five weighted particles,
up- and down-sampling, and resampling only when the effective sample size is low.

Run ``python docs/examples/resampling.py [DIR]``; given DIR, it writes its plots there.
"""
import sys

import numpy as np

import fasttrack as ft

out = sys.argv[1] if len(sys.argv) > 1 else None

# Five particles with the tutorial's weights (they need not sum to one: fasttrack normalises).
weights = np.array([1, 5, 1.5, 0.5, 2]) / 10
particles = ft.ParticleState(np.arange(5.0)[None], weight=weights)

schemes = {
    "systematic": ft.SystematicResampler(rng=42),
    "stratified": ft.StratifiedResampler(rng=42),
    "multinomial": ft.MultinomialResampler(rng=42),
    "residual": ft.ResidualResampler(residual_method="systematic", rng=42),
}
for name, resampler in schemes.items():
    resampled = resampler.resample(particles)
    counts = np.bincount(resampled.state_vector[0].astype(int), minlength=5)
    print(f"{name:<12} offspring {counts}, weights {resampled.weight}")

# Offspring counts average to N w over many draws.
draws = np.array([np.bincount(ft.systematic(particles.log_weight, rng=seed), minlength=5)
                  for seed in range(2000)])
print("mean systematic offspring", draws.mean(axis=0), "expected", 5 * weights)

# Up- and down-sampling.
print("up to 10:", ft.MultinomialResampler(rng=1).resample(particles, nparts=10).state_vector)
print("down to 3:", ft.StratifiedResampler(rng=1).resample(particles, nparts=3).state_vector)

# Resample only when the effective sample size falls below N/2.
ess_resampler = ft.ESSResampler(resampler=ft.ResidualResampler("systematic", rng=3))
print(f"ESS {ft.ess(particles.log_weight):.2f}:",
      "kept" if ess_resampler.resample(particles) is particles else "resampled")
skewed = ft.ParticleState(np.arange(5.0)[None], weight=[0.9, 0.025, 0.025, 0.025, 0.025])
print(f"ESS {ft.ess(skewed.log_weight):.2f}:",
      "kept" if ess_resampler.resample(skewed) is skewed else "resampled")

# A list of Particle objects works too.
listed = [ft.Particle([i], weight=1 / 5) for i in range(5)]
print("from particles:", ft.SystematicResampler(rng=0).resample(listed).state_vector)

if out:
    from fasttrack import plotting
    # Each scheme's points (the uniforms its seed-42 draw above used) fall in the bars of the
    # particles it copied; residual resampling's copies are shown as counts.
    for name in ["systematic", "stratified", "multinomial"]:
        ax = plotting.plot_resampling(weights, ft.resampling_points(5, name, rng=42))
        plotting.save(ax, f"{out}/resampling-{name}.png", title=name)
    drawn = schemes["residual"].resample(particles).state_vector[0].astype(int)
    ax = plotting.plot_resampling(weights, offspring=np.bincount(drawn, minlength=5))
    plotting.save(ax, f"{out}/resampling-residual.png", title="residual")
