import quadtune, yaml
class Legs:  # a planner in Python: the A* path's corners, each leg cut into n_pol parts
    def waypoints(self, query, params):  # params: n_pol (an int, tuned), v_des, ...
        path, n = query.path, params["n_pol"]
        return [a + (b - a) * k / n for a, b in zip(path, path[1:]) for k in range(1, n + 1)]
quadtune.register_planner("legs", Legs())
config = yaml.safe_load(open("examples/own_planner/waypoint.yaml"))  # or write the dict here
config["planner"]["type"] = "legs"
del config["planner"]["waypoint"]
outcome = quadtune.run(config, "results/python_planner", overwrite=True)
for row in outcome.summary["validation"]:
    print(row["method"], "held-out f_l", round(row["mean_value"], 2), row["params"])
