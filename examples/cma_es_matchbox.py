"""CMA-ES on a dmprs Gymnasium environment: learn the matchbox flip-up in the space of the DMP's
weights, one whole strike per step (as fancy_gym's black-box environments are used).

    pip install "dmprs[gym]" && python examples/cma_es_matchbox.py [--iterations 30]

The search starts from the weights the generalizer gives for the desired outcome (action 0) and
stops at the first upright box or after ``--iterations`` generations.
"""

from __future__ import annotations

import argparse
import warnings

import cma
import gymnasium as gym
import numpy as np

import dmprs.envs  # noqa: F401 - registers the dmprs/... environments


def main(iterations: int = 30, seed: int = 1) -> dict:
    env = gym.make("dmprs/MatchboxFlipWeights-v0")
    env.reset(seed=seed)
    n = env.action_space.shape[0]

    def episode(a: np.ndarray) -> tuple[float, dict]:
        env.reset(seed=seed)
        _, reward, _, _, info = env.step(a)
        return reward, info

    es = cma.CMAEvolutionStrategy(np.zeros(n), 0.1, {"seed": seed, "bounds": [-1, 1], "verbose": -9,
                                                       "popsize": 8})
    best: dict = {"reward": -np.inf, "success": False, "evaluations": 0}
    for generation in range(iterations):
        xs = es.ask()
        results = [episode(np.asarray(x)) for x in xs]
        es.tell(xs, [-r for r, _ in results])  # CMA-ES minimizes: the cost is |eps|
        best["evaluations"] += len(xs)
        for r, info in results:
            if r > best["reward"]:
                best.update(reward=r, success=info["success"], regime=info.get("regime"), generation=generation)
        print(f"generation {generation:2d}: best |eps| {-best['reward']:.4f} rad, regime {best['regime']}")
        if best["success"]:
            break
    env.close()
    return best


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--iterations", type=int, default=30)
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args()
    warnings.filterwarnings("ignore", module="gymnasium")
    result = main(args.iterations, args.seed)
    print(f"{'upright' if result['success'] else 'not upright'} after {result['evaluations']} strikes")
