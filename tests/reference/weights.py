"""Mirrors of ``fasttrack._jit.weights``: relative weights, log-sum-exp, ESS, weighted
moments and normalisation, from log weights."""
import numpy as np


def relative_weights(log_w, log_w_max, out):
    out[:] = np.exp(log_w - log_w_max)


def log_sum_exp(log_w, log_w_max):
    return log_w_max + np.log(np.sum(np.exp(log_w - log_w_max)))


def ess(log_w, log_w_max):
    w = np.exp(log_w - log_w_max)
    return w.sum() ** 2 / (w**2).sum()


def weighted_mean(x, log_w, log_w_max, mean):
    w = np.exp(log_w - log_w_max)
    mean[:] = x @ w / w.sum()


def weighted_mean_covar(x, log_w, log_w_max, mean, covar):
    w = np.exp(log_w - log_w_max)
    mean[:] = np.average(x, axis=1, weights=w)
    covar[:] = np.atleast_2d(np.cov(x, ddof=0, aweights=w))


def normalise_in_place(log_w, log_w_max):
    w = np.exp(log_w - log_w_max)
    log_w[:] = (log_w - log_w_max) - np.log(w.sum())
    return w.sum() ** 2 / (w**2).sum()
