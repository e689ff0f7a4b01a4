import quadtune
def f(p):  # any Python function to minimise; its minimum is at x = 1, y = -2, n = 3
    return (p["x"] - 1) ** 2 + (p["y"] + 2) ** 2 + 0.5 * abs(p["n"] - 3)
space = {"x": (-5.0, 5.0), "y": (-5.0, 5.0), "n": (1, 8, int)}
study = quadtune.BayesOpt(space, seed=1)  # or quadtune.PSO, quadtune.RandomSearch
for _ in range(40):
    x = study.ask()  # a dict: {"x": ..., "y": ..., "n": <int>}
    study.tell(x, f(x))
print(study.best)
