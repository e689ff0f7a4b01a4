"""Parameter importance of a run from its own evaluations: Sobol' indices of a Gaussian-process
surrogate (numpy and scipy only; Debian: python3-numpy, python3-scipy).

The surrogate: a Gaussian process with a Matérn 5/2 kernel, one length scale per parameter
(automatic relevance determination), a constant mean and a noise term, fitted to log(value) of
the evaluations by maximising the marginal likelihood (L-BFGS-B from seeded starts). Inputs are
the parameters scaled to [0, 1] across their box (the logarithm first for a log parameter).

The indices: variance-based (Sobol') sensitivity of the surrogate's posterior mean over the
whole box (uniform in the scaled coordinates), estimated from Saltelli's A/B/AB_i design:
first order S_i by Saltelli (2010), total S_Ti by Jansen (1999). S_i: the share of the variance
that parameter i explains alone; S_Ti: its share with every interaction it takes part in.
Where the tuners did not sample, the surrogate returns to its mean, so the indices describe the
region the run explored.

    fit(X, y, seed)                 -> Surrogate (predict(X), loo_r2, length_scales)
    sobol(f, d, n, seed)            -> (first, total) of a function on [0, 1]^d
    partial_dependence(f, d, i, j)  -> grid of the mean of f over the other coordinates
    importance(X, y, seed)          -> {"first", "total", "loo_r2", "n"} (the report's numbers)
"""
import numpy as np
from scipy import linalg, optimize

SQRT5 = np.sqrt(5.0)


def scale(values, lower, upper, log):
    """Parameter values mapped to [0, 1] across [lower, upper] (in log space for a log one)."""
    v = np.asarray(values, dtype=float)
    if log:
        v, lower, upper = np.log(v), np.log(lower), np.log(upper)
    return (v - lower) / (upper - lower) if upper > lower else np.zeros_like(v)


def unscale(u, lower, upper, log):
    """The inverse of scale()."""
    u = np.asarray(u, dtype=float)
    if log:
        return np.exp(np.log(lower) + u * (np.log(upper) - np.log(lower)))
    return lower + u * (upper - lower)


def matern52(a, b, length_scales):
    """The Matérn 5/2 correlation of the rows of a and b (unit variance)."""
    d = np.sqrt(np.maximum(
        ((a[:, None, :] - b[None, :, :]) / length_scales) ** 2, 0.0).sum(axis=2))
    return (1.0 + SQRT5 * d + 5.0 / 3.0 * d ** 2) * np.exp(-SQRT5 * d)


class Surrogate:
    """A fitted Gaussian process (see the module documentation)."""

    def __init__(self, X, y, theta):
        self.X = X
        self.mean = float(np.mean(y))
        self.std = float(np.std(y)) or 1.0
        z = (y - self.mean) / self.std
        d = X.shape[1]
        self.length_scales = np.exp(theta[:d])
        self.signal = np.exp(theta[d])
        self.noise = np.exp(theta[d + 1])
        K = self.signal * matern52(X, X, self.length_scales) + self.noise * np.eye(len(X))
        self.chol = linalg.cho_factor(K, lower=True)
        self.alpha = linalg.cho_solve(self.chol, z)
        # Leave-one-out residuals in closed form: alpha_i / (K^-1)_ii.
        k_inv_diag = np.diag(linalg.cho_solve(self.chol, np.eye(len(X))))
        residual = self.alpha / k_inv_diag
        self.loo_r2 = float(1.0 - np.sum(residual ** 2) / np.sum(z ** 2)) if np.any(z) else 0.0

    def predict(self, Xs):
        """Posterior mean of log(value) at the rows of Xs (scaled coordinates), in chunks."""
        out = np.empty(len(Xs))
        for k in range(0, len(Xs), 4096):
            part = Xs[k:k + 4096]
            out[k:k + 4096] = self.signal * matern52(part, self.X, self.length_scales) @ self.alpha
        return self.mean + self.std * out


def _negative_log_likelihood(theta, X, z):
    """The negative log marginal likelihood of z (up to a constant) and its gradient in theta
    (log length scales, log signal variance, log noise variance)."""
    d = X.shape[1]
    length_scales, signal, noise = np.exp(theta[:d]), np.exp(theta[d]), np.exp(theta[d + 1])
    diff2 = ((X[:, None, :] - X[None, :, :]) / length_scales) ** 2  # (n, n, d)
    r = np.sqrt(diff2.sum(axis=2))
    e = np.exp(-SQRT5 * r)
    corr = (1.0 + SQRT5 * r + 5.0 / 3.0 * r ** 2) * e
    K = signal * corr + (noise + 1e-8) * np.eye(len(X))
    try:
        c = linalg.cho_factor(K, lower=True)
    except linalg.LinAlgError:
        return 1e10, np.zeros_like(theta)
    alpha = linalg.cho_solve(c, z)
    value = float(0.5 * z @ alpha + np.sum(np.log(np.diag(c[0]))))
    inner = linalg.cho_solve(c, np.eye(len(X))) - np.outer(alpha, alpha)
    grad = np.empty_like(theta)
    # d corr / d log l_k = 5/3 (1 + sqrt5 r) exp(-sqrt5 r) (x_k - x'_k)^2 / l_k^2
    common = signal * 5.0 / 3.0 * (1.0 + SQRT5 * r) * e
    for k in range(d):
        grad[k] = 0.5 * np.sum(inner * common * diff2[:, :, k])
    grad[d] = 0.5 * np.sum(inner * signal * corr)
    grad[d + 1] = 0.5 * noise * np.trace(inner)
    return value, grad


def fit(X, y, seed, starts=4):
    """A Surrogate fitted to (X in [0, 1]^d, y): marginal likelihood maximised from `starts`
    seeded starting points."""
    X = np.asarray(X, dtype=float)
    y = np.asarray(y, dtype=float)
    z = (y - y.mean()) / (y.std() or 1.0)
    d = X.shape[1]
    rng = np.random.default_rng(seed)
    bounds = [(np.log(0.03), np.log(30.0))] * d + [(np.log(0.05), np.log(20.0)),
                                                   (np.log(1e-4), np.log(2.0))]
    best = None
    for s in range(starts):
        theta0 = np.array([np.log(0.5)] * d + [0.0, np.log(0.1)]) if s == 0 else \
            np.array([rng.uniform(lo, hi) for lo, hi in bounds])
        result = optimize.minimize(_negative_log_likelihood, theta0, args=(X, z),
                                   method="L-BFGS-B", jac=True, bounds=bounds)
        if best is None or result.fun < best.fun:
            best = result
    return Surrogate(X, y, best.x)


def sobol(f, d, n, seed):
    """(first-order, total) Sobol' indices of f: R^(m x d) -> R^m over the uniform [0, 1]^d,
    from n rows each of the A, B and AB_i matrices (f evaluated (d + 2) n times)."""
    rng = np.random.default_rng(seed)
    A = rng.random((n, d))
    B = rng.random((n, d))
    fa, fb = f(A), f(B)
    centre = np.mean(np.concatenate([fa, fb]))
    fa, fb = fa - centre, fb - centre
    variance = np.var(np.concatenate([fa, fb]))
    first, total = np.zeros(d), np.zeros(d)
    if variance <= 0:
        return first, total
    for i in range(d):
        AB = A.copy()
        AB[:, i] = B[:, i]
        fab = f(AB) - centre
        first[i] = np.mean(fb * (fab - fa)) / variance
        total[i] = 0.5 * np.mean((fa - fab) ** 2) / variance
    return first, total


def partial_dependence(f, d, i, j, points=25, samples=256, seed=0):
    """(grid, values): values[b, a] is the mean of f over the coordinates other than i and j
    (seeded uniform samples) with x_i = grid[a] and x_j = grid[b]."""
    rng = np.random.default_rng(seed)
    grid = np.linspace(0.0, 1.0, points)
    rest = rng.random((samples, d))
    values = np.empty((points, points))
    for b, xj in enumerate(grid):
        rows = np.repeat(rest[None, :, :], points, axis=0)  # (points, samples, d)
        rows[:, :, i] = grid[:, None]
        rows[:, :, j] = xj
        values[b] = f(rows.reshape(-1, d)).reshape(points, samples).mean(axis=1)
    return grid, values


def importance(X, y, seed, n=4096):
    """Sobol' indices of a surrogate of log(y) over X (scaled, [0, 1]^d): {"first", "total",
    "loo_r2", "n", "surrogate"}."""
    model = fit(X, np.log(np.asarray(y, dtype=float)), seed)
    first, total = sobol(model.predict, np.asarray(X).shape[1], n, seed + 1)
    return {"first": first, "total": total, "loo_r2": model.loo_r2, "n": len(y),
            "surrogate": model}
