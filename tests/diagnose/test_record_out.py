"""The leave-one-record-out prediction error that chooses the form of hysteresis' memory
(porosense.diagnose.extensions.record_out_error).

Data: three records drawn here with a fixed seed (random steps through a first-order lag, a
squared-level term, white noise, each record with an offset state of Gaussian prior), whose
leave-one-record-out error is computed in closed form by the normal equations.
"""

from __future__ import annotations

import numpy as np

from porosense.diagnose import extensions
from porosense.diagnose.calibrate import StateColumns
from porosense.diagnose.engine import Record


def _records(rng, n_rec=3, n=400, prior_sd=0.5):
    recs = []
    for _ in range(n_rec):
        u = np.repeat(rng.uniform(0.0, 1.0, n // 40), 40)
        yhat = np.empty(n)
        acc = 0.0
        for k in range(n):
            acc = 0.9 * acc + 0.1 * u[k]
            yhat[k] = acc
        y = yhat + 0.4 * yhat**2 + rng.normal(0.0, prior_sd) + rng.normal(0.0, 0.02, n)
        # the offset as the record's state: column of ones, prior N(0, prior_sd^2) in the
        # posterior's form |r - S d|^2 + |R d - t|^2 at the noise's scale
        state = StateColumns(np.ones((n, 1)), np.array([[0.02 / prior_sd]]), np.zeros(1))
        recs.append(Record(u, y, yhat, 0.05, state=state))
    return recs


def _closed_form(ctx, recs, z_fn):
    """Sum over records of the squared error of the held-out record: the others fitted with
    their states by the augmented normal equations, the held-out state its posterior maximum."""
    total = 0.0
    for k, r in enumerate(recs):
        others = [q for j, q in enumerate(recs) if j != k]
        X = np.vstack([np.column_stack([ctx.generic(q), z_fn(q)]) for q in others])
        n_x = X.shape[1]
        S = np.zeros((len(X), len(others)))
        row = 0
        for j, q in enumerate(others):
            S[row : row + len(q.y), j] = 1.0
            row += len(q.y)
        R = np.zeros((len(others), len(others)))
        for j, q in enumerate(others):
            R[j, j] = q.state.R[0, 0]
        A = np.vstack([np.column_stack([X, S]), np.column_stack([np.zeros((len(others), n_x)), R])])
        b = np.concatenate([np.concatenate([q.e for q in others]), np.zeros(len(others))])
        coef = np.linalg.lstsq(A, b, rcond=None)[0]
        p = r.yhat + np.column_stack([ctx.generic(r), z_fn(r)]) @ coef[:n_x]
        res = r.y - p
        Sk, Rk = r.state.S, r.state.R
        d = np.linalg.solve(Sk.T @ Sk + Rk.T @ Rk, Sk.T @ res)
        total += float(np.sum((res - Sk @ d) ** 2))
    return total


def test_record_out_error_is_the_held_out_records_closed_form_error():
    """Equal to the normal equations' leave-one-record-out error to 1e-6 relative, with the
    records' states refitted as a validation record's is; the true squared-level term lowers
    it (by more than half: it is 0.4 yhat^2 against a noise SD of 0.02)."""
    rng = np.random.default_rng(31)
    recs = _records(rng)
    ctx = extensions.Context(recs[:], recs[:1], correct=False)

    def square(r):
        return r.yhat[:, None] ** 2

    def nothing(r):
        return np.zeros((len(r.y), 0))

    err = extensions.record_out_error(ctx, square)
    ref = _closed_form(ctx, recs, square)
    assert abs(err / ref - 1.0) < 1e-6, (err, ref)
    without = extensions.record_out_error(ctx, nothing)
    assert abs(without / _closed_form(ctx, recs, nothing) - 1.0) < 1e-6
    assert err < 0.5 * without, (err, without)
