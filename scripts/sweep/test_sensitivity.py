"""Unit tests of scripts/sweep/sensitivity.py with values derived by hand. Run by tests/tune.rs
(python -m unittest, from scripts/sweep/)."""

import math
import tempfile
import unittest
from pathlib import Path

import sensitivity

DEFAULTS = {"u1": {"alpha": 0.35}, "u2": {"top_n": 7, "beta": 0.4, "follow_terrain": True}}


class Vary(unittest.TestCase):
    def test_kinds_follow_the_defaults(self):
        self.assertEqual(sensitivity.parse_vary("u2.top_n=10,1,7", DEFAULTS), ("u2.top_n", int, [1, 7, 10], 7))
        self.assertEqual(sensitivity.parse_vary("u1.alpha=1,0,0.35", DEFAULTS), ("u1.alpha", float, [0.0, 0.35, 1.0], 0.35))
        # A parameter whose default is unset (absent from `fitslam params`) takes floats.
        self.assertEqual(sensitivity.parse_vary("u2.waypoint_spacing_m=2,1", DEFAULTS), ("u2.waypoint_spacing_m", float, [1.0, 2.0], None))

    def test_bad_keys_and_values_are_named(self):
        for text, needle in [("u2.follow_terrain=0,1", "not a numeric"), ("u2.top_n=1.5,2", "not ints"), ("u2.beta", "expected")]:
            with self.assertRaises(ValueError) as e:
                sensitivity.parse_vary(text, DEFAULTS)
            self.assertIn(needle, str(e.exception))


class WorldValues(unittest.TestCase):
    def test_per_world_means_over_the_runs_that_reached_90(self):
        d = Path(tempfile.mkdtemp()) / "summary.csv"
        d.write_text("strategy,world_seed,seed,matched_cov_trace,t90_s\n"
                     "fit,2,1,1e-3,100\n"
                     "fit,2,2,4e-3,300\n"
                     "fit,1,1,8e-3,500\n"
                     "fit,3,1,NaN,NaN\n")
        # World 1: (500, ln 8e-3); world 2: T_90 (100 + 300) / 2 = 200, mean of ln 1e-3 and
        # ln 4e-3 = ln 2e-3; world 3 never reached 90 % and is left out.
        got = sensitivity.world_values(d)
        self.assertEqual(len(got), 2)
        self.assertEqual(got[0][0], 500.0)
        self.assertAlmostEqual(got[0][1], math.log(8e-3))
        self.assertEqual(got[1][0], 200.0)
        self.assertAlmostEqual(got[1][1], math.log(2e-3))

    def test_mean_and_standard_error(self):
        # 2, 4, 6: mean 4, sample SD 2, SE 2 / √3.
        mean, se = sensitivity.mean_se([2.0, 4.0, 6.0])
        self.assertEqual(mean, 4.0)
        self.assertAlmostEqual(se, 2.0 / math.sqrt(3.0))
        self.assertEqual(sensitivity.mean_se([5.0]), (5.0, 0.0))


if __name__ == "__main__":
    unittest.main()
