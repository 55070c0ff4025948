"""A study's worker processes start with 'spawn', which runs the user's script again in each
worker. A script that runs its study at the top level, without ``if __name__ == "__main__":``,
is refused at once with what to add (issue 42: it ran 88 s and returned every row as
``worker_died``, the cause left in stderr tracebacks).

Each case is a script run in a fresh interpreter (``__main__`` must be the script); the tiny
builder is never built, since the check comes before any worker or build.
"""

import subprocess
import sys
import textwrap

import pytest

HEADER = """
import proleg as pl
from proleg.study import executors


def leg(L1, L2):
    m = pl.Model("tiny_leg", gravity=(0, 0, -9.81))
    p = m.add_part("thigh", mass=1.0, inertia=(0.01, 0.01, 0.01), position=(0, 0, -L1 / 2))
    m.add_joint(pl.Revolute("hip", m.ground, p, at=(0, 0, 0), axis=(0, 1, 0)))
    return pl.assemble(m)


study = pl.study.Study(leg, space={"L1": [0.2, 0.3], "L2": 0.25}, outputs={"z": lambda r: r.part("thigh").position[-1, 2]},
                       simulate=dict(t_end=0.01))
"""


def run_script(tmp_path, body, timeout=300):
    path = tmp_path / "first_study.py"
    path.write_text(textwrap.dedent(HEADER) + textwrap.dedent(body))
    return subprocess.run([sys.executable, str(path)], cwd=tmp_path, capture_output=True, text=True, timeout=timeout)


def test_a_script_without_the_main_guard_is_told_what_to_add(tmp_path):
    # one script for both sides of the rule: what runs under the guard (directly or through a
    # function) passes the check; the unguarded study is refused before any worker starts
    out = run_script(tmp_path, """
        def main():
            return executors.unguarded_main_line()


        if __name__ == "__main__":
            print("guarded:", executors.unguarded_main_line(), main())
        print("unguarded at:", executors.unguarded_main_line())
        table = study.run(design="grid", executor="processes", progress=False)
        print("ran", len(table))
    """)
    assert out.returncode == 1 and "ran" not in out.stdout
    assert "guarded: None None" in out.stdout
    line = 1 + (tmp_path / "first_study.py").read_text().splitlines().index('print("unguarded at:", executors.unguarded_main_line())')
    assert f"unguarded at: first_study.py, line {line}" in out.stdout
    assert "proleg.errors.ModelError: Study: the worker processes start with 'spawn'" in out.stderr
    assert f"(first_study.py, line {line + 1})" in out.stderr
    assert 'Put the call under `if __name__ == "__main__":`' in out.stderr and 'executor="vmap" or "local"' in out.stderr
    assert "worker_died" not in out.stdout + out.stderr


@pytest.mark.slow
def test_a_worker_that_reruns_the_study_stops_the_driver_at_once(tmp_path):
    """Where the driver's check cannot see the script's top level (here switched off), the
    spawned worker that reaches a study's pool while it starts exits with BOOTSTRAP_EXIT and
    the driver raises the same error, instead of retrying every batch as a crashed worker.
    Slow: a worker process imports proleg (seconds) before it fails."""
    out = run_script(tmp_path, """
        executors.unguarded_main_line = lambda: None
        table = study.run(design="grid", executor="processes", workers=1, progress=False)
        print("ran", len(table))
    """)
    assert out.returncode == 1 and "ran" not in out.stdout
    assert "proleg.errors.ModelError: Study: the worker processes start with 'spawn'" in out.stderr
    assert f"proleg: Study: the worker processes" in out.stderr  # the worker's own line
    assert "worker_died" not in out.stdout + out.stderr
