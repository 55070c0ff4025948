"""What a fresh process pays before its first table (issue 20, warm start ≤ 1 s): jaxlib's LAPACK
kernels without importing all of ``scipy.linalg`` (proleg/_lapack_table.py, 0.2–0.35 s), and an
assemble that proves joint rows independent without SciPy's pivoted QR where the singular
values suffice (assembly/assemble.py:find_redundant_rows). Each check runs in a new
interpreter: what is imported depends on the whole process."""

import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest
import scipy.linalg

from proleg.assembly.assemble import find_redundant_rows


def run_fresh(code: str, **env) -> str:
    import os

    out = subprocess.run([sys.executable, "-c", textwrap.dedent(code)], capture_output=True, text=True, timeout=300,
                         env={**os.environ, "PROLEG_CACHE_DIR": "", **env})
    assert out.returncode == 0, out.stderr[-3000:]
    return out.stdout.strip()


BENCH = str(Path(__file__).resolve().parents[1] / "bench")
README = """
    import sys
    import proleg as pl
    assert "scipy.linalg" not in sys.modules
    sys.path.insert(0, {bench!r})
    from common import readme_model  # the README's ten-line double pendulum
    res = pl.simulate(pl.assemble(readme_model()), t_end=0.5, dt_output=0.01, coordinates="{coords}")
    df = res.to_frame()
    print("scipy.linalg" in sys.modules, len(df), repr(float(res.part("lower").position[-1, 0])))
"""


@pytest.mark.parametrize("coords", ["auto", "absolute"])
def test_readme_example_runs_without_importing_scipy_linalg(coords):
    """The README example, planar and in absolute coordinates (whose Newton step uses LAPACK's
    LU through jaxlib), runs to its table without ``scipy.linalg``; and gives the answer of a
    process where jaxlib imported ``scipy.linalg`` itself (PROLEG_PRELOAD_LAPACK=0)."""
    fast = run_fresh(README.format(coords=coords, bench=BENCH)).split()
    slow = run_fresh(README.format(coords=coords, bench=BENCH), PROLEG_PRELOAD_LAPACK="0").split()
    assert fast[:2] == ["False", "51"]
    assert slow[0] == "True"  # the switch works, so the comparison is of the two paths
    # bitwise: both processes run the same executable on the same LAPACK (SciPy's); the point is
    # that the preload changes nothing, so no tolerance
    assert float(fast[2]) == float(slow[2])


def test_scipy_linalg_imported_later_is_whole():
    """After the preload, ``import scipy.linalg`` gives the full package, with the preloaded
    modules as its ``cython_blas``/``cython_lapack`` attributes, and JAX's and SciPy's LU agree."""
    out = run_fresh("""
        import sys
        import numpy as np
        import proleg  # noqa: F401
        import jax.numpy as jnp
        import jax.scipy.linalg as jsl
        assert "scipy.linalg.cython_lapack" in sys.modules and "scipy.linalg" not in sys.modules
        a = np.array([[4.0, 1.0, 0.5], [1.0, 3.0, 0.2], [0.5, 0.2, 2.0]]); b = np.array([1.0, 2.0, 3.0])
        x = np.asarray(jsl.lu_solve(jsl.lu_factor(jnp.asarray(a)), jnp.asarray(b)))
        import scipy.linalg
        import scipy.linalg.cython_blas as blas
        assert scipy.linalg.cython_lapack is sys.modules["scipy.linalg.cython_lapack"]
        assert scipy.linalg.cython_blas is blas
        print(np.abs(x - scipy.linalg.lu_solve(scipy.linalg.lu_factor(a), b)).max(), np.abs(a @ x - b).max())
    """)
    diff, resid = (float(v) for v in out.split())
    # backward-stable solves: both within 64 eps ‖a‖₂ ‖x‖ = 1.05e-13 (‖a‖₂ = 4.72, ‖x‖ = 1.58,
    # cond 2.5), whichever BLAS kernels ran; a wrong pivoting or a foreign LU is off by O(1)
    tol = 64 * np.finfo(float).eps * 4.72 * 1.58
    assert diff < tol and resid < tol


def test_no_preload_where_scipy_linalg_came_first():
    out = run_fresh("""
        import scipy.linalg, sys
        from proleg._lapack_table import preload
        print(preload(), sum(type(f).__name__ == "_AttachOnImport" for f in sys.meta_path))
    """)
    assert out.split() == ["False", "0"]


def reference_rows(Phi_q, nbody, tol=1e-9):
    """find_redundant_rows' pivoted QR without the singular-value shortcut."""
    nj = Phi_q.shape[0] - nbody
    Pj = Phi_q[:nj].copy()
    if nbody:
        Qn, _ = np.linalg.qr(Phi_q[nj:].T)
        Pj = Pj - (Pj @ Qn) @ Qn.T
    _, R, piv = scipy.linalg.qr(Pj.T, pivoting=True, mode="economic")
    d = np.abs(np.diag(R))
    rank = int(np.sum(d > tol * d[0]))
    return np.sort(piv[:rank]), np.sort(piv[rank:])


@pytest.mark.parametrize("seed", range(40))
def test_redundant_rows_shortcut_keeps_what_the_qr_keeps(seed):
    """The shortcut (σ_min > 2·tol·σ_max keeps every row: for any QR |r_kk| ≥ σ_min and
    |r_11| ≤ σ_max) never disagrees with the pivoted QR: random joint-row matrices with 1–3
    normalisation rows, independent, with duplicated rows, and near the threshold
    (σ_min/σ_max from 1e-12 to 1e-6)."""
    rng = np.random.default_rng(seed)
    nbody = int(rng.integers(1, 4))
    n = 7 * nbody
    nj = int(rng.integers(1, n - nbody))
    U, _ = np.linalg.qr(rng.normal(size=(nj, nj)))
    V, _ = np.linalg.qr(rng.normal(size=(n, n)))
    kind = seed % 4
    s = np.logspace(0, -3, nj)
    if kind == 1:
        s[-1] = 10.0 ** rng.uniform(-12, -6)  # around tol = 1e-9
    Pj = (U * s) @ V[:nj]
    if kind == 2 and nj > 1:
        Pj[-1] = Pj[0] * 2.0  # a redundant joint row
    N = rng.normal(size=(nbody, n))
    Phi_q = np.vstack([Pj, N])
    keep, drop = find_redundant_rows(Phi_q, nbody)
    rkeep, rdrop = reference_rows(Phi_q, nbody)
    np.testing.assert_array_equal(keep, rkeep)
    np.testing.assert_array_equal(drop, rdrop)
    if kind == 2 and nj > 1:
        assert len(drop) == 1
