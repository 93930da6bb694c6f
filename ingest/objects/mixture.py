"""A two-class Gaussian mixture fitted to the site itself, and maximum-likelihood labels.

The paper classifies texture by maximum likelihood but does not say where the classes'
statistics come from. They come from the survey: a mixture of two Gaussians, one smooth and
one rough, fitted by expectation–maximisation, so no labelled training data is needed.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

ITERATIONS = 100
TOLERANCE = 1e-6
FLOOR = 1e-6  # variance floor: a class of identical values would have none
SAMPLE = 20_000  # cells the mixture is fitted on: two 2-D Gaussians are known well long before


@dataclass(frozen=True)
class Mixture:
    """Means (2, d), covariances (2, d, d) and weights (2,); class 0 is the smoother."""

    means: NDArray[np.float64]
    covariances: NDArray[np.float64]
    weights: NDArray[np.float64]

    def log_likelihood(self, x: NDArray[np.float64]) -> NDArray[np.float64]:
        """(n, 2) log density of each sample under each class."""
        d = x.shape[1]
        out = np.empty((len(x), 2))
        for k in range(2):
            diff = x - self.means[k]
            inv = np.linalg.inv(self.covariances[k])
            _, logdet = np.linalg.slogdet(self.covariances[k])
            out[:, k] = -0.5 * (((diff @ inv) * diff).sum(axis=1) + logdet + d * np.log(2 * np.pi))
        return out

    def classify(self, x: NDArray[np.float64]) -> NDArray[np.intp]:
        """Maximum-likelihood class of each sample (the weights are left out, as ML does)."""
        return np.argmax(self.log_likelihood(x), axis=1)


def fit_two(x: NDArray[np.float64]) -> Mixture:
    """EM fit of two full-covariance Gaussians to ``x`` (n, d), started from the lower and upper
    halves of the first feature; class 0 has the smaller mean first feature. Beyond
    :data:`SAMPLE` samples it is fitted on an evenly spaced subset (the same every run)."""
    if len(x) > SAMPLE:
        x = x[np.linspace(0, len(x) - 1, SAMPLE).astype(np.intp)]
    n = len(x)
    order = np.argsort(x[:, 0])
    resp = np.zeros((n, 2))
    resp[order[: n // 2], 0] = 1.0
    resp[order[n // 2 :], 1] = 1.0
    mix = _m_step(x, resp)
    last = -np.inf
    for _ in range(ITERATIONS):
        ll = mix.log_likelihood(x) + np.log(mix.weights)
        top = ll.max(axis=1, keepdims=True)
        total = top[:, 0] + np.log(np.exp(ll - top).sum(axis=1))
        resp = np.exp(ll - total[:, None])
        mix = _m_step(x, resp)
        mean_ll = float(total.mean())
        if mean_ll - last < TOLERANCE:
            break
        last = mean_ll
    if mix.means[0, 0] > mix.means[1, 0]:
        mix = Mixture(mix.means[::-1].copy(), mix.covariances[::-1].copy(), mix.weights[::-1].copy())
    return mix


def _m_step(x: NDArray[np.float64], resp: NDArray[np.float64]) -> Mixture:
    d = x.shape[1]
    nk = resp.sum(axis=0) + 1e-12
    means = (resp.T @ x) / nk[:, None]
    cov = np.empty((2, d, d))
    for k in range(2):
        diff = x - means[k]
        cov[k] = (resp[:, k, None] * diff).T @ diff / nk[k] + FLOOR * np.eye(d)
    return Mixture(means, cov, nk / nk.sum())
