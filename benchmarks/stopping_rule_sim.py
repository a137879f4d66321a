"""The progressive bake's stopping rule (python/sonolux/sound/progressive.py) simulated on linear
statistics, for docs/progressive.md ("Why the L-room ran on to 26 M rays").

Each of the L-room's 65 counted entries (T30, EDT, C80 at 4 receivers x 6 bands, less those left
out) is a mean of i.i.d. per-ray values whose SD makes it need ``NEEDS_RAYS[i]`` rays for SE = target
(the L-room's measured n (SE/target)^2, mean of its 16.8 M and 26 M rounds, 8 groups). G groups hold
cumulative sums; after each round the delete-a-group jackknife SE of a mean is the groups' SD /
sqrt(G); the bake stops when every SE <= target, else the round rule gives the next total. Prints,
per G and rule: mean/median/p90 rays to stop, the true worst SE/target at the stop, and the fraction
of entries whose 95 % interval (Student t, G - 1 degrees of freedom) holds the truth.

Run: ``python benchmarks/stopping_rule_sim.py`` (about a minute; not part of ``make bench``)."""

import math

import numpy as np
from scipy import stats

NEEDS_RAYS = np.array([
    13.0982, 12.3388, 9.9335, 9.0107, 8.7761, 7.5606, 7.4901, 7.0124, 6.9409, 5.881, 5.6058, 4.7334,
    4.6368, 3.3513, 3.1685, 2.4612, 1.8777, 1.8475, 1.7986, 1.3338, 1.1755, 1.1597, 1.1387, 1.1093,
    1.0657, 0.9328, 0.9307, 0.9303, 0.9254, 0.8894, 0.8614, 0.856, 0.7474, 0.7007, 0.6923, 0.6916,
    0.6577, 0.3969, 0.3799, 0.3644, 0.2457, 0.2168, 0.2051, 0.1752, 0.1744, 0.0869, 0.0856, 0.084,
    0.0758, 0.0537, 0.0438, 0.0422, 0.0422, 0.0347, 0.0326, 0.0307, 0.0217, 0.0204, 0.0203, 0.0191,
    0.019, 0.0187, 0.0183, 0.018, 0.018]) * 1e6


def blocks(r, G, down=False):
    b = G * 256
    n = math.floor(r / b) if down else math.ceil(r / b)
    return max(1, n) * b


def run(rng, G, rule, first=16384, cap=50_000_000):
    sigma = np.sqrt(NEEDS_RAYS)
    S = np.zeros((len(NEEDS_RAYS), G))
    n, target, hist = 0, blocks(first, G), []
    while True:
        d = target - n
        S += rng.standard_normal((len(NEEDS_RAYS), G)) * sigma[:, None] * math.sqrt(d / G)
        n = target
        x = S / (n / G)
        se = np.sqrt(((x - x.mean(1, keepdims=True))**2).sum(1) / (G * (G - 1)))
        hist.append((n, se))
        if se.max() <= 1 or n >= cap:
            break
        target = rule(n, se, G, hist, cap)
    t = stats.t.ppf(0.975, G - 1)
    cover = (np.abs(x.mean(1)) <= t * se).mean()
    return n, math.sqrt(NEEDS_RAYS.max() / n), len(hist), cover


def make(margin=1.1, lo=1.25, hi=4.0, rho=1.0):
    def rule(n, se, G, hist, cap):
        w = se.max()
        wanted = n * w * w * margin * rho
        return min(cap, blocks(min(max(wanted, lo * n), hi * n), G))
    return rule


def pooled(margin=1.0, lo=1.25, hi=4.0):
    """per-entry per-ray variance: average of n_k se_k^2 over the rounds, weighted by n_k (late rounds)."""
    def rule(n, se, G, hist, cap):
        ns = np.array([h[0] for h in hist[-2:]], float)
        v = np.array([h[0] * h[1]**2 for h in hist[-2:]])
        need = (v * ns[:, None]).sum(0) / ns.sum()
        wanted = need.max() * margin
        return min(cap, blocks(min(max(wanted, lo * n), hi * n), G))
    return rule


def main():
    rules = {"old": make(), "hi2": make(hi=2.0), "nomargin_hi2": make(margin=1.0, hi=2.0),
             "rho.7": make(rho=0.7/1.1), "pool2": pooled()}
    rng = np.random.default_rng(2)
    for G in (8, 16, 32):
        for name, rule in rules.items():
            out = np.array([run(rng, G, rule) for _ in range(300)])
            rays = out[:, 0] / 1e6
            print(f"G={G:2d} {name:13s} rays mean {rays.mean():6.2f} M median {np.median(rays):6.2f}"
                  f" p90 {np.quantile(rays, 0.9):6.2f} trueworst {out[:, 1].mean():.2f}"
                  f" (max {out[:, 1].max():.2f}) rounds {out[:, 2].mean():.1f}"
                  f" cover {out[:, 3].mean():.3f}", flush=True)


if __name__ == "__main__":
    main()
