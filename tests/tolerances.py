"""Tolerances that several test files share, each derived once here (issue 34: a tolerance
follows from the problem or the solver's guarantee, never from one machine's last digits)."""

from proleg.solvers.galpha import StepOptions

#: max |Φ| at every output of an α-method run (GeneralizedAlpha, HHT; adaptive or fixed step).
#: What the solver guarantees: an accepted step's end meets |Φ| < 5 phi_tol (the check after
#: Newton, solvers/galpha.py), and an output between step ends is the Hermite interpolant
#: projected once onto Φ = 0 with the step's Newton matrix (solvers/driver.py dense_output),
#: which contracts the interpolant's |Φ| by O(h) but does not reach round-off. Measured on the
#: four-bar (tests/test_core_fourbar.py): 7.9e-10 (Intel, AVX-512) and 1.13e-9 with XLA, NumPy
#: and OpenBLAS limited to AVX2 (as on AMD Zen), i.e. above 1e-9 on some CPUs. 50 phi_tol
#: = 5e-9 leaves that a factor 4; a joint that drifts open is off by 1e-6 or more. The suite's
#: α-method runs measured (Intel Xeon, AVX-512): 6.1e-10 (stiff-bushing pendulum, default
#: tolerances), 1.8e-10 and 1.3e-10 (reused Jacobians, geared four-bar), the rest ≤ 2e-11.
#: Runs on joint coordinates (Tsit5, Radau5 on a tree) hold the joints by construction: round-off.
CONSTRAINT_RESIDUAL = 50 * StepOptions().phi_tol
