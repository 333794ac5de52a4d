"""Unit tests of scripts/sweep/tune.py's objectives, Pareto front and parameter file, with values
derived by hand. Run by tests/tune.rs (python -m unittest, from scripts/sweep/)."""

import math
import tempfile
import unittest
from pathlib import Path

import tune

HEADER = "strategy,world_seed,seed,end_reason,matched_cov_trace,time_s,t90_s\n"


def summary(rows):
    d = tempfile.mkdtemp()
    path = Path(d) / "summary.csv"
    path.write_text(HEADER + "".join(rows))
    return path


class Objectives(unittest.TestCase):
    def test_world_level_means(self):
        # World 1: T_90 100 and 300 -> 200; tr(cov) 1e-3 and 4e-3 -> geometric mean 2e-3.
        # World 2: T_90 500; tr(cov) 8e-3. Over worlds: T_90 (200 + 500) / 2 = 350;
        # tr(cov) sqrt(2e-3 * 8e-3) = 4e-3. Every run reached 90 %.
        path = summary([
            "fit,1,1,no_frontier,1e-3,400,100\n",
            "fit,1,2,no_frontier,4e-3,400,300\n",
            "fit,2,1,no_frontier,8e-3,900,500\n",
        ])
        t90, primary, unreached = tune.objectives(path, 0.1)
        self.assertAlmostEqual(t90, 350.0)
        self.assertAlmostEqual(primary, 4e-3)
        self.assertEqual(unreached, 0.0)

    def test_runs_never_at_90_percent_are_left_out_and_counted(self):
        # World 2's only run never reached 90 %: the objectives are world 1's; 1 of 3 unreached.
        path = summary([
            "fit,1,1,no_frontier,1e-3,400,100\n",
            "fit,1,2,no_frontier,4e-3,400,300\n",
            "fit,2,1,no_frontier,NaN,900,NaN\n",
        ])
        t90, primary, unreached = tune.objectives(path, 0.1)
        self.assertAlmostEqual(t90, 200.0)
        self.assertAlmostEqual(primary, 2e-3)
        self.assertAlmostEqual(unreached, 1 / 3)

    def test_no_run_at_90_percent_is_infinitely_bad(self):
        t90, primary, unreached = tune.objectives(summary(["fit,1,1,stuck,NaN,50,NaN\n"]), 0.1)
        self.assertTrue(math.isinf(t90) and math.isinf(primary))
        self.assertEqual(unreached, 1.0)

    def test_an_empty_summary_is_an_error(self):
        with self.assertRaises(ValueError):
            tune.objectives(summary([]), 0.1)


class Front(unittest.TestCase):
    def test_dominated_points_leave_the_front(self):
        a = {"t90_s": 100, "matched_cov_trace": 3.0}
        b = {"t90_s": 200, "matched_cov_trace": 1.0}
        c = {"t90_s": 150, "matched_cov_trace": 3.5}  # worse than a in both
        d = {"t90_s": 100, "matched_cov_trace": 3.0}  # equal to a: neither dominates
        e = {"t90_s": 200, "matched_cov_trace": 2.0}  # b is better in one, equal in the other
        front = tune.pareto_front([a, b, c, d, e])
        self.assertEqual([id(p) for p in front], [id(a), id(b), id(d)])


class ParamsFile(unittest.TestCase):
    def test_sections_and_kinds(self):
        text = tune.params_toml({"alpha": 0.5, "beta": 0.25, "top_n": 3.0}, tune.SPACE)
        self.assertEqual(text, "[u1]\nalpha = 0.5\n[u2]\nbeta = 0.25\ntop_n = 3\n")

    def test_a_searched_key_goes_into_its_table(self):
        space = dict(tune.SPACE)
        name, spec = tune.parse_search("u2.sigma_bearing_rad=0.005..0.05", DEFAULTS)
        space[name] = spec
        text = tune.params_toml({"beta": 0.5, name: 0.01}, space)
        self.assertEqual(text, "[u2]\nbeta = 0.5\nsigma_bearing_rad = 0.01\n")


# As `fitslam params` prints them, in part.
DEFAULTS = {"u1": {"alpha": 0.35, "gamma": 0.99}, "u2": {"beta": 0.4, "top_n": 7, "sigma_bearing_rad": 0.01,
                                                        "follow_terrain": True, "normalisation": "max"}}


class Search(unittest.TestCase):
    def test_ranges_and_kinds_follow_the_defaults(self):
        self.assertEqual(tune.parse_search("u2.sigma_bearing_rad=0.005..0.05", DEFAULTS),
                         ("u2.sigma_bearing_rad", ("u2.sigma_bearing_rad", float, 0.005, 0.05)))
        # A paper weight keeps its name; an integer parameter gets an integer range.
        self.assertEqual(tune.parse_search("u2.top_n=1..30", DEFAULTS), ("top_n", ("u2.top_n", int, 1, 30)))
        # A float parameter stays a float range whatever the bounds look like.
        self.assertEqual(tune.parse_search("u1.alpha=0..1", DEFAULTS), ("alpha", ("u1.alpha", float, 0.0, 1.0)))

    def test_bad_forms_are_refused(self):
        bad = ["u2.beta", "u2.beta=0..", "u2.beta=1..0", "u2.beta=a..b", "u2.beta=0-1", "u2.top_n=1.5..3",
               "u2.nope=0..1", "beta=0..1", "u2.follow_terrain=0..1", "u2.normalisation=0..1", "u2=0..1"]
        for text in bad:
            with self.assertRaises(ValueError, msg=text):
                tune.parse_search(text, DEFAULTS)


if __name__ == "__main__":
    unittest.main()
