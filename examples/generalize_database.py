"""Generalizing a database of demonstrations to a new situation (the paper's eq. 6).

    python examples/generalize_database.py

Eight demonstrations reach for targets on a table, each labelled with its target (x, y) in m:
the query. A planar two-link arm (links 0.4 and 0.3 m) moves its two joints; the demonstrations
follow a minimum-jerk path in joint space, with a lift of the elbow that grows with the distance.
The database is saved and loaded (as ``dmprs demos import`` would have written it), then
``Generalizer(method="lwr-gp")`` predicts the DMP for targets no demonstration reached, and we
check where the fingertip ends up.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np

import dmprs

L1, L2 = 0.4, 0.3


def fingertip(q: np.ndarray) -> np.ndarray:
    """Forward kinematics of the planar arm: joint angles (..., 2) -> fingertip (..., 2) in m."""
    a, b = q[..., 0], q[..., 0] + q[..., 1]
    return np.stack([L1 * np.cos(a) + L2 * np.cos(b), L1 * np.sin(a) + L2 * np.sin(b)], axis=-1)


def inverse(p: np.ndarray) -> np.ndarray:
    """The elbow-down joint angles that put the fingertip at p (2,)."""
    c = (p @ p - L1**2 - L2**2) / (2 * L1 * L2)
    elbow = np.arccos(np.clip(c, -1, 1))
    shoulder = np.arctan2(p[1], p[0]) - np.arctan2(L2 * np.sin(elbow), L1 + L2 * np.cos(elbow))
    return np.array([shoulder, elbow])


START = np.array([0.3, 1.6])  # joint angles at rest


def demonstration(target: np.ndarray, duration: float = 1.5, n: int = 301) -> dmprs.Trajectory:
    t = np.linspace(0.0, duration, n)
    s = t / duration
    m = 10 * s**3 - 15 * s**4 + 6 * s**5
    goal = inverse(target)
    q = START + np.outer(m, goal - START)
    q[:, 1] += 0.5 * np.linalg.norm(target) * np.sin(np.pi * s) ** 2  # lift the elbow on the way
    return dmprs.Trajectory(t, q)


def main(directory: Path | None = None) -> dict:
    rng = np.random.default_rng(0)
    targets = np.column_stack([rng.uniform(0.3, 0.55, 8), rng.uniform(-0.2, 0.3, 8)])
    db = dmprs.Database(query_names=("target_x", "target_y"), query_units=("m", "m"))
    for k, target in enumerate(targets):
        db.add(target, demonstration(target), label=f"reach {k}")
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(directory or tmp) / "reaches"
        db.save(path)
        db = dmprs.Database.load(path)
    print(f"{db}")
    gen = dmprs.Generalizer(db, method="lwr-gp", n_basis=25)
    new = np.array([[0.42, 0.05], [0.5, -0.1], [0.35, 0.2]])
    errors = []
    for q in new:
        dmp = gen.predict(q)
        path = dmp.rollout(dt=0.005, until_rest=True, rest_tol=1e-4)
        end = fingertip(path.y[-1])
        errors.append(float(np.linalg.norm(end - q)))
        lift = float(path.y[:, 1].max() - max(path.y[0, 1], path.y[-1, 1]))
        print(f"target {q} m: fingertip ends at {np.round(end, 4)} m ({errors[-1] * 1e3:.1f} mm off), "
              f"elbow lift {lift:.3f} rad, duration {dmp.tau:.2f} s")
    return {"errors_m": errors, "n_demos": len(db)}


if __name__ == "__main__":
    main()
