"""Scout II report prose: every number in the findings is computed by the run (issues 31, 44).

The findings are written from a summary of the run's metrics (scout2_report._summary). Perturb
every computed number by 7 %: every number in the prose must change, except the paper's cited
reference values (scout2_data) and the study settings (factors, commanded speed). A frozen
number ("21 % and 11 %", "about 9 %") would survive the perturbation and fail this test.
"""

import re

import numpy as np

from proleg.robots import scout2_data as D
from proleg.papers.scout2_report import LOW_SPEED_TARGET, findings

NUM = re.compile(r"[-+]?\d+(?:\.\d+)?")


def metrics(v, sr, period=1, fell=False, strides=8):
    return {"forward_speed": v, "specific_resistance_electrical": sr, "specific_resistance_mechanical": 0.3 * sr, "period": period,
            "fell": fell, "strides": strides}


def summary(f=1.0):
    return {
        "printed_I": {**metrics(np.nan, np.nan, period=0, strides=0), "stalled": True, "longest_brake": 2.31 * f},
        "printed_II": {**metrics(np.nan, np.nan, period=0, strides=0), "stalled": True, "longest_brake": 2.73 * f},
        "I": metrics(1.611 * f, 1.13 * f), "II": metrics(1.297 * f, 1.37 * f, period=2),
        "calibrated": 37.3 * f, "calibrated_ratio": 0.678 * f, "calibrated_speed": 1.297 * f, "calibration_met": True,
        "overshoot_I": 3.9 * f, "low": {"Model II, low speed": metrics(0.853 * f, 2.31 * f, period=2)},
        "targets": {"I": "not found", "II": -0.07 * f},
        "sens": [{"parameter": "belt damper", "factor": 10.0, "speed change [%]": -8.7 * f},
                 {"parameter": "joint damping", "factor": 0.1, "speed change [%]": 1.3 * f}],
        "ranges": [{"speed [m/s]": 1.38 * f}, {"speed [m/s]": 1.52 * f}],
    }


def reference_tokens():
    vm = D.SPEED_MEASURED
    refs = {D.SPEED_MEASURED, D.SPEED_MODEL_I, D.SPEED_MODEL_II, LOW_SPEED_TARGET, 10, 0.1}
    toks = {f"{x:g}" for x in refs} | {str(x) for x in refs}
    toks |= {f"{100 * (D.SPEED_MODEL_I / vm - 1):+.0f}"}
    return toks


def test_every_number_in_the_findings_is_computed():
    a, b = findings(summary(1.0)), findings(summary(1.07))
    cite = re.compile(r"(Table|Fig\.|Eq\.|seed) \d+|§\d+(\.\d+)*|scout2\w*")  # citations and file names are labels, not results
    ta, tb = NUM.findall(cite.sub("", a)), NUM.findall(cite.sub("", b))
    assert len(ta) == len(tb) >= 15  # same sentences, many numbers
    refs = reference_tokens()
    frozen = [x for x, y in zip(ta, tb) if x == y and x not in refs]
    assert not frozen, f"numbers that did not follow the computation: {frozen}\n{a}"
    # the paper's comparison numbers appear only as cited references
    assert "about 9" not in a  # the sensitivity number comes from the sensitivity rows


def test_findings_report_a_fall_and_no_bound():
    s = summary()
    s["I"] = metrics(np.nan, np.nan, period=0, fell=True, strides=0)
    s["II"] = metrics(0.367, 4.16, period=0)
    s["low"] = {"Model I, low speed": metrics(np.nan, np.nan, period=0, strides=0)}
    text = findings(s)
    assert "Model I falls" in text and "stops bounding" in text
    assert "does not settle into a steady gait" in text and "0.367 m/s on average" in text
    assert "slower than" not in text and "faster than" not in text  # no order without two bounds


def test_findings_state_the_calibration_and_its_miss():
    s = summary()
    text = findings(s)
    assert "37.3 N s/m per virtual leg (0.68 × Table 6)" in text and "within the measured spread" in text
    assert "With Table 6 as printed: Model I stalls" in text
    s["calibration_met"] = False
    assert "not within the measured spread" in findings(s)


def test_findings_report_the_stance_brake_stall():
    s = summary()
    s["I"] = {**metrics(np.nan, np.nan, period=0, strides=0), "stalled": True, "longest_brake": 4.4}
    s2 = {**s, "I": {**s["I"], "longest_brake": 4.4 * 1.07}}
    a, b = findings(s), findings(s2)
    assert "Model I stalls" in a and "4.40 s" in a and "4.71 s" in b


def test_findings_stop_where_nothing_was_calibrated():
    s = summary()
    s = {"printed_I": s["printed_I"], "printed_II": s["printed_II"], "stopped": "no leg damping in 16.5–55 N s/m makes Model II bound"}
    text = findings(s)
    assert text.endswith("No leg damping in 16.5–55 N s/m makes Model II bound.")
    assert "Model II stalls" in text and "Predicted" not in text
