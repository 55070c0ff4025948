"""Experimental modal analysis (proleg.identify.hammer) on synthetic hammer data with known modes,
and the torso FE model (issue 17)."""

import numpy as np
import pytest

from proleg.errors import DataError, ModelError
from proleg.identify.hammer import comparison_table, mac, modal, synthetic_hammer_test


def test_two_close_modes_both_found():
    """Modes at 50 and 52 Hz (4 % apart, zeta 1 %) and two well separated ones, four channels:
    frequencies within 1 %, damping within 20 %, shapes with MAC > 0.99 (residues = phi_out phi_in)."""
    f = np.array([30.0, 50.0, 52.0, 120.0])
    z = np.array([0.03, 0.01, 0.01, 0.01])
    rng = np.random.default_rng(3)
    phi = rng.normal(size=(4, 4))
    pin = np.array([1.0, 0.8, -0.9, 0.7])
    t, F, A = synthetic_hammer_test(f, z, phi, pin, seed=4)
    r = modal(t, F, A, f_range=(10, 300))
    assert r.frequencies.size == 4
    assert r.frequencies == pytest.approx(f, rel=0.01)
    assert r.damping == pytest.approx(z, rel=0.2)
    assert np.all(np.diag(mac(phi, r.shapes)) > 0.99)
    assert r.n_averages == 5


def test_cluster_of_three_modes_with_different_damping():
    """Three modes within 10 % (100, 104, 109 Hz) with damping 0.5 %, 3 % and 1 %: the broad middle
    mode makes no peak of its own next to the sharp ones, so peak picking alone finds two; the
    residual-driven model-order selection (:func:`proleg.identify.hammer._fit_band`) adds the third.
    All three within 1 % in frequency and 20 % in damping, and no extra pole."""
    f = np.array([100.0, 104.0, 109.0])
    z = np.array([0.005, 0.03, 0.01])
    phi = np.array([[1.0, 0.9, 0.6], [0.7, -1.0, 0.8], [-0.5, 0.8, 1.0], [0.9, 0.3, -0.7]])
    t, F, A = synthetic_hammer_test(f, z, phi, np.array([1.0, 0.9, 0.8]), block=16.0, seed=5)
    r = modal(t, F, A, f_range=(50, 200))
    assert r.frequencies.size == 3
    assert r.frequencies == pytest.approx(f, rel=0.01)
    assert r.damping == pytest.approx(z, rel=0.2)
    assert np.all(np.diag(mac(phi, r.shapes)) > 0.98)


def test_fe_guided_picking_and_table():
    f = np.array([2.0, 32.0, 40.0])
    z = np.array([0.05, 0.03, 0.01])
    phi = np.array([[1.0, 0.5, 0.2], [0.9, -0.6, 0.3], [1.1, 0.1, -0.8]])
    t, F, A = synthetic_hammer_test(f, z, phi, phi[0], block=32.0, seed=1)
    r = modal(t, F, A, f_guess=[1.9, 31, 41], f_range=(0.5, 200))
    assert r.frequencies == pytest.approx(f, rel=0.01)
    assert r.damping == pytest.approx(z, rel=0.2)
    tab, M = comparison_table(f * 1.05, phi, r.frequencies, r.shapes)
    assert list(tab["FE mode"]) == [1, 2, 3]
    assert tab["difference [%]"].to_numpy() == pytest.approx(5.0, rel=0.02)
    assert M.shape == (3, 3) and np.all(np.diag(M) > 0.99)


def test_bad_records_name_the_column():
    t = np.arange(1000) / 1000.0
    F = np.zeros(1000)
    F[10:13] = 100.0
    A = np.random.default_rng(0).normal(size=(1000, 2))
    t_bad = t.copy()
    t_bad[500:] += 0.0004
    with pytest.raises(DataError, match="'time' is not regularly sampled"):
        modal(t_bad, F, A, source="accel.csv")
    with pytest.raises(DataError, match="force.*same length"):
        modal(t, F[:-5], A)
    with pytest.raises(DataError, match="acceleration channels.*same length"):
        modal(t, F, A[:-5])


def test_torso_modes_follow_table2_pattern():
    from proleg.robots.torso import torso_modal

    r = torso_modal(n_modes=30)
    f, kinds = r.frequencies, r.kind
    # six rigid-body modes on the foam, all below 10 Hz, carry the whole mass
    assert sum(k.startswith("support") for k in kinds) == 6
    eff = r.effective_mass
    total = eff.attrs["total_mass"]
    for c in ("x [kg]", "y [kg]", "z [kg]"):
        assert eff[c].iloc[:6].sum() == pytest.approx(total, rel=1e-3)
    # then the heavy masses on their mounts, before the frame's own modes
    first_mount = kinds.index("heavy masses on mounts")
    first_frame = kinds.index("frame")
    assert f[first_mount] < f[first_frame]
    with pytest.raises(ModelError, match="tube_wall"):
        torso_modal(tube_wall=0.03)
    with pytest.raises(ModelError, match="n_cross"):
        torso_modal(n_cross=9)


def test_torso_table2_calibrated_on_bounce_only():
    """Issue 31: the pads are calibrated on Table 2's bounce row (experimental 2 Hz) and nothing
    else; the calibrated bounce obeys the closed form of a rigid body on four pads,
    f = sqrt(4 k_pad / m) / 2 pi, within 1 % (the frame barely bends); the other rows are
    predictions: the frame rows are the modes of highest mass-weighted MAC with the bare frame's
    elastic modes (MAC >= 0.8) and lie above 100 Hz; scoring the bounce row as validation is refused."""
    from proleg.errors import DataError
    from proleg.identify.calibration import check_held_out, split_scores
    from proleg.robots.torso import PARAM_RANGES, calibrate_pads, table2_comparison, torso_modal

    cal = calibrate_pads()
    assert cal.fitted_on == ("bounce on foam",) and not cal.at_bound
    assert PARAM_RANGES["pad_stiffness"][0] < cal.value < PARAM_RANGES["pad_stiffness"][1]
    assert cal.achieved == pytest.approx(2.0, rel=1e-5)
    r = torso_modal(n_modes=40, pad_stiffness=cal.value, pad_shear_stiffness=0.5 * cal.value)
    t = table2_comparison(r)
    m = r.effective_mass.attrs["total_mass"]
    assert t["FE [Hz]"].iloc[0] == pytest.approx(np.sqrt(4 * cal.value / m) / (2 * np.pi), rel=0.01)
    assert list(t["kind"].str[:5]) == ["suppo", "heavy", "heavy", "frame", "frame", "frame"]
    assert (t["MAC with bare frame"].iloc[3:] >= 0.8).all()
    assert (t["FE [Hz]"].iloc[3:] > 100.0).all()
    assert (t["paper experimental [Hz]"] == [2, 30, 37, 112, 145, 155]).all()
    fitted, predicted = split_scores(t, [cal])
    assert list(fitted["quantity"]) == ["bounce on foam"] and "bounce on foam" not in set(predicted["quantity"])
    check_held_out(predicted["quantity"], [cal])
    with pytest.raises(DataError, match="bounce on foam"):
        check_held_out(t["quantity"], [cal])


def test_torso_fe_modes_to_uff(tmp_path):
    """torso_modal's FE modes and geometry as UFF 15/82/55, read back to the format's 6 digits."""
    from proleg.identify.uff import read_modes_uff
    from proleg.robots.torso import torso_modal

    r = torso_modal(n_modes=12)
    r.write_uff(tmp_path / "torso.uff", n_modes=12)
    m = read_modes_uff(tmp_path / "torso.uff")
    fr = r.frame
    assert m.coordinates.shape == fr.node_coordinates.shape and len(m.lines) == len(fr.elements)
    assert m.frequencies == pytest.approx(r.frequencies, rel=5e-6)
    S = r.shapes[: fr.ndof].reshape(-1, 6, 12)
    assert np.all(np.abs(m.shapes - S) <= 5e-6 * np.abs(S) + 1e-300)


def test_cli_identify_modal(tmp_path):
    import pandas as pd
    from typer.testing import CliRunner

    from proleg.cli.main import app

    t, F, A = synthetic_hammer_test([30.0, 120.0], [0.02, 0.01], np.array([[1.0, 0.5], [0.4, -1.0]]), [1.0, 0.7])
    pd.DataFrame({"time": t, "force": F}).to_csv(tmp_path / "force.csv", index=False)
    pd.DataFrame({"time": t, "a0": A[:, 0], "a1": A[:, 1]}).to_csv(tmp_path / "accel.csv", index=False)
    pd.DataFrame({"time": t[:-2], "a0": A[:-2, 0]}).to_csv(tmp_path / "short.csv", index=False)
    run = CliRunner().invoke(app, ["identify", "modal", str(tmp_path / "force.csv"), str(tmp_path / "accel.csv"), "--json",
                                      "--f-min", "10"])
    assert run.exit_code == 0, run.output
    import json

    out = json.loads(run.output)
    assert out["frequencies_hz"] == pytest.approx([30.0, 120.0], rel=0.01)
    bad = CliRunner().invoke(app, ["identify", "modal", str(tmp_path / "force.csv"), str(tmp_path / "short.csv")])
    assert bad.exit_code == 2 and "short.csv" in bad.output and "'time'" in bad.output


def test_lone_guess_finds_a_shifted_weak_mode():
    """A weak 2 Hz mode (a torso bouncing on foam) guessed 9 % low by the FE model, next to a strong
    60 Hz mode: found within 1 % in frequency and 20 % in damping. (The torso-modal scenario is where
    the isolated-guess rule matters: a ripple of the mode indicator 0.4 % from the 1.8 Hz guess was
    taken for the 2.0 Hz bounce, -8.6 %; now -0.03 %.)"""
    f, z = np.array([2.0, 60.0]), np.array([0.05, 0.01])
    phi = np.array([[0.1, 1.0], [0.08, -0.8]])
    t, F, A = synthetic_hammer_test(f, z, phi, np.array([0.1, 1.0]), block=32.0, seed=2)
    r = modal(t, F, A, f_guess=[1.82, 60.0], f_range=(1.0, 200), band=0.12)
    assert r.frequencies == pytest.approx(f, rel=0.01)
    assert r.damping == pytest.approx(z, rel=0.2)
